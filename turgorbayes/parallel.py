"""Map a function over independent items on every core, or on a Dask cluster, in order.

:func:`ordered_map` is the one way the package spreads independent work (the curves of a
manifest; docs/curves.md, "On every core"): the results come back in the items' order, so the
output does not depend on the number of workers, and a worker's exception is raised in the
caller as it would be serially.
"""

import os
from concurrent.futures import ProcessPoolExecutor
from multiprocessing import get_context

__all__ = ["default_workers", "ordered_imap", "ordered_map"]


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
