"""Simulation-based calibration smoke test (turgorbayes.workflows.sbc; docs/validation.md).

Reference: under a correct pipeline the rank of the truth among the posterior draws is uniform
(Talts et al. 2018); a pipeline whose simulator and likelihood disagree piles the ranks at one
end. Both halves are asserted, so the test shows that the check can fail.
"""

import numpy as np
import pytest

from turgorbayes.workflows import sbc


class _MiscalibratedCantilever:
    """Every cell stiffness read 25 % high, which the baseline does not model."""

    def observations(self, obs, design, rng):
        return {**obs, "k_c": 1.25 * obs["k_c"]}


def test_rank_uniformity_rejects_piled_ranks_only():
    # closed form: ranks spread evenly over 0..19 give chi-square 0 (p = 1); all in the top
    # bin give chi-square 3 n (p ~ 0) for 4 equal bins
    even = np.arange(20)[:, None]
    assert sbc.rank_uniformity(even, 19)[0] == 1.0
    assert sbc.rank_uniformity(np.full((20, 1), 19), 19)[0] < 1e-10


@pytest.mark.slow
def test_sbc_accepts_the_baseline_and_rejects_a_biased_pipeline(table):
    ok = sbc.run_sbc(table, 20, first_seed=300, n_draws=19)
    assert np.all(ok.p_values() > 1e-3), ok.p_values()
    bad = sbc.run_sbc(table, 12, first_seed=300, n_draws=19,
                      simulate_kwargs={"effects": [_MiscalibratedCantilever()]})
    p = bad.p_values(n_bins=2)
    # a 25 % stiffness error pushes E0t far above its truth in every replication
    assert p[bad.names.index("E0t")] < 1e-3, p
    assert np.all(bad.ranks[:, bad.names.index("E0t")] <= 1)


def test_sbc_model_with_an_effect_keeps_its_prior_and_the_calibration_priors():
    # reference: SBC requires the fit's prior to be the one the truths are drawn from: the
    # baseline parameters get SBC_PRIORS, the effect's size keeps its own (docs/validation.md)
    from turgorbayes.effects import get_effect

    cls = sbc.sbc_model(effects=["radius_spread"])
    by_name = {p.name: p.prior for p in cls.parameters}
    assert list(by_name) == ["gamma", "E0t", "R0", "P_phys", "tau_R"]
    for name, prior in sbc.SBC_PRIORS.items():
        assert by_name[name] is prior
    assert by_name["tau_R"] is get_effect("radius_spread").parameters[0].prior
    assert cls.effect_names == ("radius_spread",)
