import numpy as np
import pytest


@pytest.fixture
def rng():
    """A fixed-seed generator: tests are reproducible."""
    return np.random.default_rng(20111014)


@pytest.fixture(scope="session")
def table():
    """The shipped k/(PR) surrogate table (tests that need it skip until it is built)."""
    from turgorbayes import surrogate

    if not surrogate.default_path().is_file():
        pytest.skip("shipped surrogate table not built yet")
    return surrogate.load()
