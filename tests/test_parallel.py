"""turgorbayes.parallel: results in the items' order whatever spreads the work.
Reference: the serial list comprehension ``[fn(item) for item in items]``."""

import operator

from turgorbayes.parallel import ordered_map

ITEMS = [(i, 3 * i - 50) for i in range(37)]  # 37 items: chunks of unequal size on 2 workers


def test_a_process_pool_returns_the_serial_results_in_order():
    assert ordered_map(_product, ITEMS, workers=2) == [_product(x) for x in ITEMS]


def test_a_local_dask_cluster_returns_the_serial_results_in_order():
    # the items travel in chunks (about four per worker); their results come back flattened
    assert ordered_map(_product, ITEMS, workers=2, scheduler="local") == [
        _product(x) for x in ITEMS]


def _product(pair):
    return operator.mul(*pair)
