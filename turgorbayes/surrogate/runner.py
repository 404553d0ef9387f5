"""Running the FE points of a surrogate build: one point, and serial, process-pool or Dask sweeps."""

import os
import platform
import time
import traceback
from concurrent.futures import ProcessPoolExecutor, as_completed
from contextlib import contextmanager
from multiprocessing import get_context

from turgorbayes.surrogate import provenance
from turgorbayes.surrogate.store import result_record

__all__ = ["executor", "run_point", "run_points"]


def run_point(point_fn, pressure_fn, cfg, x, ratio):
    """Run one grid point and return its record; never raises for a failed FE run.

    Parameters
    ----------
    point_fn : callable
        ``point_fn(P, ratio, cfg)`` -> an ``IndentationResult``-like object
        (:func:`turgorbayes.fem.indentation_point`).
    pressure_fn : callable
        ``pressure_fn(x, ratio, cfg)`` -> pressure [Pa] for the target inflation number
        (:func:`turgorbayes.fem.pressure_for_inflation_number`).
    cfg : dataclass
        FE settings passed through.
    x : float
        Target inflation number [dimensionless].
    ratio : float
        ``E_par/E_perp`` [dimensionless].

    Returns
    -------
    dict
        ``status`` ("ok" or "failed"), ``x_target``, ``ratio``, the result fields or ``error``
        and ``traceback``, ``wall_time_s``, ``host``, ``pid``, ``started_utc``.
    """
    rec = {"x_target": float(x), "ratio": float(ratio), "host": platform.node(),
           "pid": os.getpid(), "started_utc": provenance.utc_now()}
    t0 = time.perf_counter()
    try:
        fields, converged = result_record(point_fn(pressure_fn(x, ratio, cfg), ratio, cfg))
        rec.update(fields)
        rec["status"] = "ok" if converged else "failed"
        if not converged:
            rec["error"] = "the FE reported converged=False"
    except Exception as err:  # noqa: BLE001 -- every failure is recorded, none dropped
        rec.update(status="failed", error=f"{type(err).__name__}: {err}",
                   traceback=traceback.format_exc())
    rec["wall_time_s"] = time.perf_counter() - t0
    # looked up on the module at call time, so a test can substitute it
    rec["fe_source_sha256"] = provenance.source_sha256(point_fn.__module__)
    return rec


@contextmanager
def _thread_limits(n_threads):
    """Limit BLAS/OpenMP threads of the worker processes spawned inside the block.

    Two workers on two cores each running a multi-threaded solver oversubscribe the machine;
    a spawned child reads these variables when it starts. Variables the user set are kept.
    """
    names = ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS")
    added = [n for n in names if n not in os.environ]
    for n in added:
        os.environ[n] = str(n_threads)
    try:
        yield
    finally:
        for n in added:
            os.environ.pop(n, None)


def _run_serial(tasks, job):
    for x, r in tasks:
        yield run_point(*job, x, r)


def _run_pool(tasks, job, workers):
    cores = os.cpu_count() or 1
    # spawn, not fork: the parent runs threads (tqdm's monitor) and fork + threads can deadlock.
    with _thread_limits(max(1, cores // workers)), ProcessPoolExecutor(
        max_workers=workers, mp_context=get_context("spawn")
    ) as pool:
        futures = {pool.submit(run_point, *job, x, r): (x, r) for x, r in tasks}
        try:
            for fut in as_completed(futures):
                yield _future_record(fut, *futures[fut])
        finally:
            pool.shutdown(wait=True, cancel_futures=True)


def _run_dask(tasks, job, scheduler):
    from dask.distributed import Client
    from dask.distributed import as_completed as dask_completed

    client = scheduler if isinstance(scheduler, Client) else Client(scheduler)
    try:
        futures = {
            client.submit(run_point, *job, x, r, pure=False, key=f"fe-point-r{r:.9g}-x{x:.9g}"):
            (x, r) for x, r in tasks
        }
        for fut in dask_completed(futures):
            yield _future_record(fut, *futures[fut])
    finally:
        if client is not scheduler:
            client.close()


def _future_record(fut, x, ratio):
    """Result of a future; an executor-level failure (dead worker) becomes a failed record."""
    try:
        return fut.result()
    except Exception as err:  # noqa: BLE001 -- recorded, not dropped
        return {"x_target": float(x), "ratio": float(ratio), "status": "failed",
                "error": f"{type(err).__name__} in the executor: {err}",
                "traceback": traceback.format_exc(), "wall_time_s": float("nan")}


def run_points(points, point_fn, pressure_fn, cfg, workers=1, scheduler=None):
    """Run FE points and yield their records (:func:`run_point`) in order of completion.

    Parameters
    ----------
    points : list of (float, float)
        ``(x, ratio)`` pairs.
    point_fn, pressure_fn, cfg
        As in :func:`run_point`.
    workers : int
        Local processes (spawned; BLAS/OpenMP threads limited to ``cores // workers``);
        1 runs in this process.
    scheduler : str or dask.distributed.Client, optional
        Dask scheduler address or client; overrides ``workers``.
    """
    return executor(list(points), (point_fn, pressure_fn, cfg), workers, scheduler)


def executor(tasks, job, workers, scheduler):
    """Iterator of records of ``tasks`` ((x, ratio) pairs) run by ``job = (point_fn, pressure_fn, cfg)``."""
    if scheduler is not None:
        return _run_dask(tasks, job, scheduler)
    if workers > 1 and len(tasks) > 1:
        return _run_pool(tasks, job, min(workers, len(tasks)))
    return _run_serial(tasks, job)
