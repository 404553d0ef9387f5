"""A fit that cannot start names the cells the model cannot produce, never a traceback; one
the published least squares cannot start starts from the robust least squares.

Reference (simulated truth): the bundled example (P_phys = 29 kPa, its header) with one cell
corrupted on purpose, b004's k_b x1000, which implies a bulge pressure of 2.66 MPa (1000x its
simulated one). The file passes the door only with allow_unusual; that cell, and only it, must
be named.
"""

import csv
import json

import numpy as np
import pytest

from turgorbayes.cells.table import example_path, read_cells
from turgorbayes.cli import main
from turgorbayes.errors import DataError, TurgorBayesError
from turgorbayes.inference import models, sampling
from turgorbayes.inference.start_check import start_error
from turgorbayes.physics import forward


def _corrupt(tmp_path, factor):
    """The bundled example with b004's k_b and its error x ``factor``."""
    lines = example_path().read_text().splitlines()
    rows = list(csv.reader(s for s in lines if not s.startswith("#")))
    header = rows[0]
    for row in rows[1:]:
        if row[0] == "b004":
            for c in ("kb_N_per_m", "kb_err_N_per_m"):
                row[header.index(c)] = repr(float(row[header.index(c)]) * factor)
    path = tmp_path / "cells.csv"
    with path.open("w", newline="") as f:
        f.write("\n".join(s for s in lines if s.startswith("#")) + "\n")
        csv.writer(f, lineterminator="\n").writerows(rows)
    return path


@pytest.fixture
def corrupted(tmp_path):
    """b004's k_b x1000 (pN/nm entered as N/m): a pressure the model can produce (2661 kPa)."""
    return _corrupt(tmp_path, 1e3)


@pytest.fixture
def unreachable(tmp_path):
    """b004's k_b x10^4: a bulge pressure (26,610 kPa) whose cell lies outside the FE table at
    the least-squares wall, so the fit has no finite starting point there."""
    return _corrupt(tmp_path, 1e4)


@pytest.fixture
def impossible(tmp_path):
    """b004's k_b x10^6: a bulge pressure (2.66e6 kPa) no wall of the prior
    produces, so neither least-squares start is finite."""
    return _corrupt(tmp_path, 1e6)


def _finite(model, values):
    ll = model.pointwise_log_likelihood(model.to_u(values)[0][None])[0]
    return np.isfinite(ll)


def test_a_start_the_least_squares_leave_impossible_is_the_robust_fits(unreachable, table):
    # at x10^4 the published fit is pulled to where b004 is impossible (the test below); its
    # soft-L1 fit is not pulled (b004's residuals count linearly), and the fit starts there:
    # every cell finite and P_phys near the example's simulated 29 kPa
    with pytest.warns(UserWarning):
        cells = read_cells(unreachable, allow_unusual=True)
    model = models.BaselineModel(cells, table)
    wls = models.PaperWLS(cells, table)
    assert not _finite(model, wls.fit().estimate).all()
    guess = model.start_guess()
    assert _finite(model, guess).all()
    assert guess == wls.fit(loss=models.ROBUST_LOSS).estimate
    assert abs(guess["P_phys"] / 29e3 - 1) < 0.1


def test_a_finite_least_squares_start_is_kept(table):
    # on the clean example the published estimate is the start, unchanged
    cells = read_cells(example_path())
    model = models.BaselineModel(cells, table)
    estimate = models.PaperWLS(cells, table).fit().estimate
    assert model.start_guess() == estimate
    assert model.start_guess(estimate) == estimate


def test_gross_errors_that_pull_the_least_squares_off_still_start(table):
    # simulated truth: the planted outliers effect at seed 3011 (P_phys 29 kPa); its published
    # fit went to P_phys 41 kPa, where 43 of 114 cells are impossible, and criticize stopped
    from turgorbayes.physics.parameters import PUBLISHED
    from turgorbayes.simulation.planted import planted_cells

    cells = planted_cells("outliers", 3011, table, 72, 42)
    model = models.BaselineModel(cells, table)
    assert (~_finite(model, models.PaperWLS(cells, table).fit().estimate)).sum() > 10
    guess = model.start_guess()
    assert _finite(model, guess).all()
    assert abs(guess["P_phys"] / PUBLISHED["P_phys"] - 1) < 0.1


def test_start_error_names_the_cell_the_model_cannot_produce(unreachable, table):
    with pytest.warns(UserWarning):
        cells = read_cells(unreachable, allow_unusual=True)
    model = models.BaselineModel(cells, table)
    # the fit's first point: the least-squares estimate (where b004 is -inf, as in the CLI run)
    u = model.to_u(models.PaperWLS(cells, table).fit().estimate)[0]
    ll = model.pointwise_log_likelihood(u[None])[0]
    assert np.flatnonzero(~np.isfinite(ll)).tolist() == [3]  # b004, the corrupted cell
    err = start_error(model, u)
    assert isinstance(err, DataError) and err.value == "b004"
    assert "1 of 114 cells" in str(err) and "'b004'" in str(err)
    # the reason is forward.REASONS' for its bulge pressure at that wall
    assert forward.REASONS[forward.OUTSIDE_SURROGATE] in str(err)
    assert "2.661e+04 kPa" in str(err)  # 10x the 2661 kPa of the x1000 slip (P_b ~ k_b)


def test_sampler_start_failure_is_a_package_error_with_the_positions():
    def log_prob(p):
        return np.full(len(p), -np.inf)

    with pytest.raises(sampling.StartError, match="finite starting log probabilities") as info:
        sampling.run_ensembles(log_prob, lambda rng: rng.normal(size=(10, 2)), 0, n_walkers=10,
                               n_ensembles=1, progress=False)
    assert isinstance(info.value, TurgorBayesError) and isinstance(info.value, RuntimeError)
    assert info.value.positions.shape == (10, 2) and info.value.n_bad == 10


def test_criticize_names_the_cell_instead_of_a_traceback(impossible, table, capsys):
    with pytest.raises(SystemExit) as info:
        main(["criticize", str(impossible), "--allow-unusual", "--out",
              str(impossible.parent / "out")])
    assert info.value.code == 2
    captured = capsys.readouterr()
    assert "warning:" in captured.out and "kb_N_per_m" in captured.out  # never silently
    assert "cell_id 'b004'" in captured.err and "Traceback" not in captured.err


def test_fit_names_the_corrupted_cell_as_a_gross_error(corrupted, table, capsys):
    # with pooled relative errors b004's likelihood is finite, so the fit runs (exit 0); the
    # corrupted bulge (1000x its simulated pressure) must then be named on the command line
    # and in summary.json, first (most certain) and as its bulge; the other readings flagged
    # are widths, which the example's simulated cell-to-cell width spread (radius_spread, not
    # in the baseline) puts outside the baseline's prediction
    out = corrupted.parent / "out"
    try:
        main(["fit", str(corrupted), "--allow-unusual", "--quiet", "--ensembles", "1",
              "--walkers", "10", "--max-steps", "200", "--out", str(out)])
    except SystemExit as stop:
        assert stop.code in (0, None)
    captured = capsys.readouterr()
    assert "Traceback" not in captured.err
    assert "far outside what the model predicts" in captured.out
    assert "b004     k_b/R_b" in captured.out
    flagged = json.loads((out / "summary.json").read_text())["flagged_cells"]
    assert (flagged[0]["cell_id"], flagged[0]["quantity"]) == ("b004", "k_b/R_b")
    assert flagged[0]["score"] > 0.99
    assert {f["quantity"] for f in flagged[1:]} <= {"R_c"}
    # paper_wls cannot reach b004's pressure (a penalty residual at its best point): the
    # report says so instead of comparing against a failed fit (it once ended in a traceback)
    assert "paper_wls did not fit these data" in (out / "report.md").read_text()
