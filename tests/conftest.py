import numpy as np
import pytest


@pytest.fixture
def rng():
    """A fixed-seed generator: tests are reproducible."""
    return np.random.default_rng(20111014)
