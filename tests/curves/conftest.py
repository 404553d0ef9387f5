"""Fixtures of the curve tests: write synthetic curves through afmformats."""

import functools

import pytest

from turgorbayes.simulation.curves import DEFAULT_ACQUISITION, bulge_force, cell_force, synthetic_curve, write_curve


def cell_curve(path, k_c, R_c, seed, acquisition=DEFAULT_ACQUISITION, depth_factor=2.0, **kw):
    """Write a cell-body curve whose secant at R_c/20 is k_c; returns the SyntheticCurve."""
    law = functools.partial(cell_force, k_c=k_c, h_ref=R_c / 20, a=0.1)
    curve = synthetic_curve(law, depth_factor * R_c / 20, acquisition, seed, **kw)
    write_curve(curve, path)
    return curve


def bulge_curve(path, P, R_b, h_b, seed, acquisition=DEFAULT_ACQUISITION, **kw):
    """Write a bulge curve indented to h_b; returns the SyntheticCurve."""
    law = functools.partial(bulge_force, P=P, R_b=R_b)
    curve = synthetic_curve(law, h_b, acquisition, seed, **kw)
    write_curve(curve, path)
    return curve


@pytest.fixture
def write_cell_curve():
    """:func:`cell_curve`."""
    return cell_curve


@pytest.fixture
def write_bulge_curve():
    """:func:`bulge_curve`."""
    return bulge_curve
