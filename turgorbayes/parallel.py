"""Map a function over independent items on every core, or on a Dask cluster, in order.

:func:`ordered_map` is the one way the package spreads independent work (the curves of a
manifest; docs/curves.md, "On every core"): the results come back in the items' order, so the
output does not depend on the number of workers, and a worker's exception is raised in the
caller as it would be serially.

:func:`task_pool` is the other way, for work that comes in unequal pieces (the criticism's
candidate models, docs/effects.md, "Workflow"): threads of this process
each fit one model and hand every heavy step of it (:func:`pool_map`) to the same forked
workers, so no worker idles while another model is still being fitted.
"""

import itertools
import os
import pickle
import threading
from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor
from contextlib import contextmanager, nullcontext
from multiprocessing import get_context

__all__ = ["PoolClosed", "default_workers", "ordered_imap", "ordered_map", "pool_map", "pool_open",
           "task_pool", "threaded_imap"]


def default_workers():
    """The cores this process may use (``os.sched_getaffinity``, else ``os.cpu_count``)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def ordered_map(fn, items, workers=1, scheduler=None, chunksize=None):
    """``[fn(item) for item in items]``, on ``workers`` processes or a Dask cluster.

    Parameters
    ----------
    fn : callable
        A module-level function (it is pickled to the workers).
    items : sequence
        Independent inputs.
    workers : int
        Processes of a local pool (1: in this process, no pool).
    scheduler : str, optional
        Address of a Dask scheduler (``tcp://...``) or ``"local"`` for a
        ``dask.distributed.LocalCluster`` of ``workers`` processes; ``workers`` is then ignored
        for remote clusters.
    chunksize : int, optional
        Items per task of the pool (default: about four tasks per worker).

    Returns
    -------
    list
        The results, in the order of ``items``.
    """
    return list(ordered_imap(fn, items, workers, scheduler, chunksize))


def ordered_imap(fn, items, workers=1, scheduler=None, chunksize=None):
    """:func:`ordered_map` as a generator: each result as soon as it and those before it are
    done (for a progress bar)."""
    items = list(items)
    if scheduler is not None:
        yield from _dask_map(fn, items, workers, scheduler)
        return
    if workers <= 1 or len(items) <= 1:
        yield from (fn(item) for item in items)
        return
    workers = min(workers, len(items))
    chunksize = chunksize or max(1, len(items) // (4 * workers))
    with ProcessPoolExecutor(workers, mp_context=get_context("fork")) as pool:
        yield from pool.map(fn, items, chunksize=chunksize)


def _dask_map(fn, items, workers, scheduler):
    from dask.distributed import Client, LocalCluster

    if scheduler == "local":
        with LocalCluster(n_workers=max(1, workers), threads_per_worker=1, processes=True,
                          dashboard_address=None) as cluster, Client(cluster) as client:
            return _gather_chunks(client, fn, items, len(cluster.workers))
    with Client(scheduler) as client:
        return _gather_chunks(client, fn, items, len(client.scheduler_info()["workers"]))


def _gather_chunks(client, fn, items, workers):
    """Results of ``fn`` over ``items`` in about four tasks per worker: a task per item costs
    the scheduler a round trip each (measured: studies/results/curves_workers.txt)."""
    size = max(1, len(items) // (4 * max(1, workers)))
    chunks = [items[i:i + size] for i in range(0, len(items), size)]
    futures = client.map(_apply_chunk, [fn] * len(chunks), chunks, pure=False)
    return [r for chunk in client.gather(futures) for r in chunk]


def _apply_chunk(fn, chunk):
    return [fn(item) for item in chunk]


# ------------------------------------------------------------------------------ task pool
#: The open :func:`task_pool` (this process only: its workers are forked before it is set, so
#: they never see it and never nest) and the models shipped to it.
_POOL = {}
_LOCK = threading.Lock()
_TOKENS = itertools.count()
#: In a worker: the models received, by token (the last :data:`_KEPT_MODELS`), so a model is
#: unpickled, and its caches filled, once per worker rather than once per task.
_WORKER_MODELS = {}
_KEPT_MODELS = 16


@contextmanager
def task_pool(workers):
    """Keep ``workers`` forked processes open for :func:`pool_map` within the block.

    The processes are forked on entry, before any thread of :func:`threaded_imap` starts.
    """
    with ProcessPoolExecutor(workers, mp_context=get_context("fork")) as pool:
        pool.submit(int).result()  # a fork pool starts all its processes at the first task
        _POOL.update(pool=pool, models={})
        try:
            yield pool
        finally:
            _POOL.clear()


def pool_open():
    """Whether a :func:`task_pool` is open in this process."""
    return "pool" in _POOL


class PoolClosed(RuntimeError):
    """:func:`pool_map` in a thread whose work was abandoned (:func:`threaded_imap`)."""


def pool_map(fn, model, args):
    """``[fn(model, *a) for a in args]``, on the open :func:`task_pool`'s workers when there is
    one (``model`` pickled once; each worker keeps it), else here. In order either way, and the
    same values: each call is the same function of the same inputs."""
    pool = _POOL.get("pool")
    if pool is None:
        return [fn(model, *a) for a in args]
    if _POOL.get("closing"):
        raise PoolClosed("the work this step belongs to was abandoned (an interrupt or an error)")
    token, blob = _shipped(model)
    futures = [pool.submit(_call_with_model, fn, token, blob, a) for a in args]
    return [f.result() for f in futures]


def _shipped(model):
    """``(token, pickled model)`` of ``model`` in the open pool (made once per model; the pool
    holds the model, so its ``id`` is not reused while the pool is open)."""
    with _LOCK:
        entry = _POOL["models"].get(id(model))
        if entry is None:
            entry = _POOL["models"][id(model)] = (model, next(_TOKENS), pickle.dumps(model))
    return entry[1], entry[2]


def _call_with_model(fn, token, blob, args):
    """A :func:`pool_map` task in a worker: ``fn(model, *args)``, the model from its token."""
    model = _WORKER_MODELS.get(token)
    if model is None:
        model = _WORKER_MODELS[token] = pickle.loads(blob)
        while len(_WORKER_MODELS) > _KEPT_MODELS:
            _WORKER_MODELS.pop(next(iter(_WORKER_MODELS)))
    return fn(model, *args)


def threaded_imap(fn, items, workers):
    """``fn(item)`` for each item, in at most ``2 * workers`` threads, its heavy steps on a
    :func:`task_pool` of ``workers`` processes (the one open, if any); the results in order,
    each as soon as it and those before it are done. ``fn`` must send its heavy work through :func:`pool_map` (what
    runs in the threads themselves shares this process's one interpreter)."""
    items = list(items)
    if not items:
        return
    with (nullcontext() if pool_open() else task_pool(workers)), \
            ThreadPoolExecutor(min(len(items), 2 * workers)) as threads:
        futures = [threads.submit(fn, item) for item in items]
        try:
            for future in futures:
                yield future.result()
        except BaseException:  # an interrupt, an error, or the caller stopped early
            if not all(future.done() for future in futures):
                _abandon(futures)
            raise


def _abandon(futures):
    """Stop an abandoned :func:`threaded_imap` soon rather than after its running items: the
    items not started never start, the pool's queued tasks are dropped, and a running item's
    next :func:`pool_map` raises :class:`PoolClosed`."""
    for future in futures:
        future.cancel()
    pool = _POOL.get("pool")
    if pool is not None:
        _POOL["closing"] = True
        pool.shutdown(wait=False, cancel_futures=True)
