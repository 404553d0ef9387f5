"""A candidate's mode search that ends off a mode is searched again from starts drawn from its
effects' priors (``workflows.criticism_candidates.candidate_laplace``; docs/statistics.md,
"Posterior engines of the criticism").

Reference: a two-dimensional posterior with a known shape, ``x`` standard normal times a
mixture in ``u = ln r_tip`` of two narrow bumps, a low one at 3.5 nm and a high one (5 nats
higher) at 15 nm, with the valley between them found here by a bounded scalar search: the
global mode is the high bump's centre (to well below 1e-3 in ``u``: the low bump's tail adds
about exp(-300) there). The tip radius's prior (log-uniform on 3-30 nm) is the effect's own.
"""

import numpy as np
import pytest
from scipy import optimize
from scipy.special import logsumexp

from turgorbayes.inference.mode import Clipping, LaplaceFit, ModeSearch, laplace_fit
from turgorbayes.inference.streams import stream_rng
from turgorbayes.workflows.criticism_candidates import MODE_STARTS, candidate_laplace

LOW, HIGH, WIDTH, GAP = np.log(3.5e-9), np.log(15e-9), 0.1, 5.0
SEED = 1


class _TwoBumps:
    """The toy posterior in sampler coordinates ``(x, ln r_tip)``."""

    name = "two_bumps"

    def to_u(self, values):
        return np.array([[values["x"], np.log(values["tip_radius"])]])

    def log_posterior(self, u):
        u = np.atleast_2d(u)
        bumps = [-0.5 * ((u[:, 1] - LOW) / WIDTH) ** 2,
                 GAP - 0.5 * ((u[:, 1] - HIGH) / WIDTH) ** 2]
        return -0.5 * u[:, 0] ** 2 + logsumexp(bumps, axis=0)


def _valley():
    model = _TwoBumps()
    res = optimize.minimize_scalar(lambda t: model.log_posterior([[0.0, t]])[0],
                                   bounds=(LOW, HIGH), method="bounded",
                                   options={"xatol": 1e-12})
    return float(res.x)


def test_a_search_stuck_off_a_mode_is_restarted_from_the_prior_and_finds_the_higher_mode(
        monkeypatch):
    # the first search is made to end at the valley between the bumps, as BFGS does on a
    # crease (tests/criticism cannot build one that traps it reliably): a point that is not a
    # mode, its Hessian with a negative eigenvalue; the restarts run the real search
    from turgorbayes.workflows import criticism_candidates

    model, valley = _TwoBumps(), _valley()
    start = {"x": 0.0, "tip_radius": float(np.exp(valley))}
    u = model.to_u(start)[0]
    stuck = LaplaceFit(u, np.eye(2), ModeSearch(u, float(model.log_posterior(u)[0]), False, ""),
                       Clipping(1, -1.0, 1e-3), [])
    calls = []

    def first_stuck(m, u0):
        calls.append(u0)
        return stuck if len(calls) == 1 else laplace_fit(m, u0)

    monkeypatch.setattr(criticism_candidates, "laplace_fit", first_stuck)
    # precondition on the seed: a draw of stream 22 lands in the high bump's basin (the
    # log-uniform prior's draw is exp of a uniform draw of ln r)
    rng = stream_rng(SEED, 22)
    draws = [rng.uniform(np.log(3e-9), np.log(30e-9)) for _ in range(MODE_STARTS)]  # ln r
    assert max(draws) > valley, draws
    lap = candidate_laplace(model, ["tip_radius"], start, SEED)
    assert len(calls) == 1 + MODE_STARTS
    assert lap.u_map == pytest.approx([0.0, HIGH], abs=1e-3)
    assert lap.mode.log_post == pytest.approx(GAP, abs=1e-6)
    assert lap.notes[0].startswith("the first mode search ended off a mode")


def test_a_search_that_ends_at_a_mode_is_not_second_guessed():
    # the low bump is a mode (Hessian positive definite): the search from it stands, though
    # the prior's draws would find the higher one
    model = _TwoBumps()
    start = {"x": 0.0, "tip_radius": 3.5e-9}
    lap = candidate_laplace(model, ["tip_radius"], start, SEED)
    assert lap.clipping.smallest > 0
    assert lap.u_map == pytest.approx([0.0, LOW], abs=1e-3)
    assert not any("ended off a mode" in n for n in lap.notes)
