"""turgorbayes.parallel: results in the items' order whatever spreads the work.
Reference: the serial list comprehension ``[fn(item) for item in items]``."""

import operator
import os

import pytest

from turgorbayes.parallel import ordered_map, pool_map, pool_open, task_pool, threaded_imap

ITEMS = [(i, 3 * i - 50) for i in range(37)]  # 37 items: chunks of unequal size on 2 workers


def test_a_process_pool_returns_the_serial_results_in_order():
    assert ordered_map(_product, ITEMS, workers=2) == [_product(x) for x in ITEMS]


def test_a_local_dask_cluster_returns_the_serial_results_in_order():
    # the items travel in chunks (about four per worker); their results come back flattened
    assert ordered_map(_product, ITEMS, workers=2, scheduler="local") == [
        _product(x) for x in ITEMS]


def _product(pair):
    return operator.mul(*pair)


# -- the task pool: threads fit, forked workers compute ------------------------------------
class _Model:
    """A model that counts, in each process, how often it was unpickled."""

    def __init__(self, scale):
        self.scale = scale

    def __setstate__(self, state):
        self.__dict__.update(state)
        _UNPICKLED.append(os.getpid())


_UNPICKLED = []


def _scaled(model, x):
    return model.scale * x, os.getpid(), _UNPICKLED.count(os.getpid())


def test_a_task_pool_computes_on_its_workers_and_keeps_each_model():
    # reference: the serial products; a worker that unpickled the model for every task would
    # count as many unpickles as tasks (12 tasks on 2 workers), one that keeps it counts 1
    model, args = _Model(3), [(x,) for x in range(12)]
    with task_pool(2):
        assert pool_open()
        out = pool_map(_scaled, model, args)
    assert not pool_open()
    assert [o[0] for o in out] == [3 * x for x in range(12)]
    assert os.getpid() not in {o[1] for o in out}
    assert max(o[2] for o in out) == 1


def test_without_a_task_pool_the_work_stays_here():
    out = pool_map(_scaled, _Model(2), [(5,)])
    assert out[0][:2] == (10, os.getpid())


def _maybe_fail(x):
    if x == 3:
        raise ArithmeticError(f"item {x}")
    return pool_map(_scaled, _Model(x), [(2,), (4,)])[1][0]


def test_threads_on_a_task_pool_return_in_order_and_raise_where_serial_would():
    # reference: the serial loop, which returns 4 x for x < 3 and raises at item 3
    results = []
    with pytest.raises(ArithmeticError, match="item 3"):
        for r in threaded_imap(_maybe_fail, range(7), workers=2):
            results.append(r)
    assert results == [0, 4, 8]
    assert not pool_open()


def _logged_step(model, path, i):
    with open(path, "a") as f:
        f.write(f"{i}\n")
    return i


def _long_item(job):
    path, x = job
    # 30 steps on the pool; the first item returns after its first step
    steps = 1 if x == 0 else 30
    return [pool_map(_logged_step, _Model(1), [(path, i)])[0] for i in range(steps)]


def test_an_abandoned_threaded_map_stops_its_running_items(tmp_path):
    # reference: the items' own step count; had the running items gone on after the caller
    # stopped, the log would hold 1 + 3 x 30 steps (2 workers: 4 threads, items 1-3 running)
    path = tmp_path / "steps.txt"
    for _ in threaded_imap(_long_item, [(path, x) for x in range(6)], workers=2):
        break  # the caller stops after the first result
    steps = len(path.read_text().splitlines())
    assert 1 <= steps < 30, steps
    assert not pool_open()
