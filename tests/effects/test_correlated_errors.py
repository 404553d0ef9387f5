"""The ``correlated_errors`` effect (docs/effects.md, correlated_errors): one correlation of
every cell's R_c and k_c errors where the data do not give it.

References: simulated truths (64 bulged + 48 intact cells at 33 kPa, the paper's wall; errors
correlated at -0.7 by the effect's injection, or independent for the null), the selection
rule's own thresholds (4 nats, gain probability 0.975), and the column's values (the effect
has nothing to estimate when every cell has one).
"""

import numpy as np
import pytest

from turgorbayes import effects
from turgorbayes.cells.correlation import with_error_correlation
from turgorbayes.criticism.loo import compare, psis_loo
from turgorbayes.criticism.selection import DELTA_ELPD_MIN, P_GAIN_MIN
from turgorbayes.effects import ExtendedModel
from turgorbayes.inference import models
from turgorbayes.inference.engine import fit_posterior
from turgorbayes.simulation import cells as synthetic
from turgorbayes.workflows.criticize import CriticismSettings

SETTINGS = CriticismSettings(n_draws=1000, n_rep=700, max_refits=0, retry_factor=1,
                             n_walkers=12, n_ensembles=4, tol=25, check_every=50,
                             max_steps=4000, flag_draws=50)
TRUTH = synthetic.Truth(P_phys=33e3)
RHO = -0.7


def _cells(rho, seed, table):
    inj = [effects.get_effect("correlated_errors").injection(rho)] if rho else []
    return synthetic.simulate_cells(64, 48, truth=TRUTH, seed=seed, surrogate=table,
                                    effects=inj)[0]


def test_planted_errors_are_correlated(table):
    # the injection draws each cell's two errors with the planted correlation (sample of
    # 4000 cells: sd of the correlation (1 - 0.49)/sqrt(4000) = 0.008)
    inj = [effects.get_effect("correlated_errors").injection(RHO)]
    cells, truths = synthetic.simulate_cells(2000, 2000, seed=3, surrogate=table, effects=inj)
    e_R = (cells.R_c - np.array(truths["cells"]["R_c_true_nm"]) * 1e-9) / cells.R_c_err
    e_k = cells.k_c / np.array(truths["cells"]["k_c_true_N_per_m"]) - 1
    assert abs(np.corrcoef(e_R, e_k)[0, 1] - RHO) < 0.03


def test_not_a_candidate_when_every_cell_has_its_correlation(table):
    cells = _cells(0.0, 1, table)
    effect = effects.get_effect("correlated_errors")
    assert effect.applicable(cells)
    assert "every cell's error correlation is given" in effect.not_applicable_reason(
        with_error_correlation(cells, 0.1))
    # one cell without a known correlation leaves something to estimate
    assert effect.applicable(with_error_correlation(cells, [np.nan] + [0.1] * (len(cells) - 1)))


def _gain(cells, table, seed):
    """LOO gain of the effect over the baseline, its probability, and the rho_e summary."""
    guess = models.PaperWLS(cells, table).fit().estimate
    out = []
    for names in ((), ("correlated_errors",)):
        model = ExtendedModel(cells, table, names)
        post = fit_posterior(model, model.start_values(guess), seed, SETTINGS)
        assert post.converged, post.reasons
        out.append(post)
    delta, _, p_gain = compare(psis_loo(out[1].log_lik, out[1].log_w),
                               psis_loo(out[0].log_lik, out[0].log_w), seed)
    return delta, p_gain, out[1].summary(np.random.default_rng(seed))["rho_e"]


@pytest.mark.slow
def test_found_where_planted_and_measured(table):
    delta, p_gain, rho = _gain(_cells(RHO, 1, table), table, 1)
    assert delta > DELTA_ELPD_MIN and p_gain >= P_GAIN_MIN, (delta, p_gain)
    assert rho["q05"] <= RHO <= rho["q95"], rho


@pytest.mark.slow
def test_quiet_on_independent_errors(table):
    delta, p_gain, rho = _gain(_cells(0.0, 1, table), table, 1)
    assert not (delta > DELTA_ELPD_MIN and p_gain >= P_GAIN_MIN), (delta, p_gain)
    assert rho["q05"] <= 0.0 <= rho["q95"], rho
