r"""``drift``: every stiffness reading drifts with the time it was measured.

Cause (docs/effects.md, drift): over a session of hours the cantilever's spring constant and
deflection sensitivity drift (temperature, laser alignment, a tip that picks up debris or
wears), and cells may stiffen or soften on the slide. Readings taken late then differ from
early ones by a factor that grows with time; measured in row order without a session column,
such a drift biases ``P_phys`` when bulged and intact cells were measured at different times.

Model: cell ``i`` measured at ``s_i`` (its place in the measurement scaled to
``[-0.5, 0.5]``: the optional ``time_min`` column, else the row order;
:func:`turgorbayes.cells.order.measurement_order`) has every stiffness reading (``k_c``,
``k_b``) ``exp(beta s_i)`` times the true one, as a calibration factor
(:attr:`turgorbayes.inference.context.LikelihoodContext.log_k_scale`): a bulged cell's bulge
then reports the apparent pressure and its wall is read at the true one. ``beta`` is the log
ratio of the last reading's factor to the first's; the factors' geometric mean over the cells
is 1 at the session's middle, so ``P_phys`` and ``E0t`` are those of the middle of the session.

Prior: ``beta ~ N(0, 0.2)``: drifts of a few to 30 % over a session (cantilever spring
constants drift by several percent per hour with temperature, and tips blunt over hundreds of
curves; te Riet et al., Ultramicroscopy 111, 1659, 2011, on calibration spread), rarely more
than 50 %. Realistic size ``ln 1.3``: a 30 % drift over the session.
"""

import copy

import numpy as np

from turgorbayes.cells.order import TIME_COLUMN, measurement_order
from turgorbayes.effects.base import Injection, StiffnessFactor
from turgorbayes.effects.registry import register_effect
from turgorbayes.inference.models import Parameter
from turgorbayes.inference.priors import Normal

__all__ = ["DRIFT_PRIOR", "Drift", "DriftInjection"]

#: Prior on the log ratio of the last reading's factor to the first's.
DRIFT_PRIOR = Normal(0.0, 0.2)
#: Minutes per cell of a simulated session (times drawn in random order over it).
MINUTES_PER_CELL = 2.0


class Drift(StiffnessFactor):
    """A stiffness factor ``exp(beta s_i)`` growing with measurement order (module docstring).

    The registered instance has no order; :meth:`bind` takes it from a data set, and
    :meth:`restrict` from the cells of one condition.
    """

    name = "drift"
    parameters = (Parameter("beta_drift", DRIFT_PRIOR, "beta_drift", 1.0, r"$\beta_{drift}$"),)
    size_parameter = "beta_drift"
    null_value = 0.0
    realistic_size = float(np.log(1.3))
    realistic_size_reason = ("ln 1.3: stiffnesses 30 % higher at the end of the session than at "
                             "its start (cantilever and tip drift over hours)")
    start = {"beta_drift": 0.0}
    cause = ("The stiffness readings drift with measurement order: the last readings are about "
             "{size:+.0%} (log ratio) off the first, a drifting calibration or tip, or cells "
             "changing on the slide.")
    order = None

    def cause_text(self, summary):
        beta = summary[self.parameters[0].key]["q50"]
        return ("The stiffness readings drift with measurement order: the last readings are "
                f"{np.exp(beta) - 1:+.0%} off the first (median), a drifting calibration or "
                "tip, or cells changing on the slide.")

    def bind(self, cells):
        bound = Drift()
        bound.order = measurement_order(cells)[0]
        return bound

    def restrict(self, idx):
        if self.order is None:
            return self
        out = copy.copy(self)
        out.order = self.order[np.asarray(idx, int)]
        return out

    def log_factors(self, v):
        """``beta s_i`` per walker and cell ``(W, n_cells)``."""
        return np.asarray(v["beta_drift"], float).reshape(-1, 1) * self.order[None, :]

    def is_bound(self):
        return self.order is not None

    def injection(self, size):
        return DriftInjection(self, float(size))


class DriftInjection(Injection):
    """Drift at a fixed size for :func:`turgorbayes.simulation.cells.simulate_cells`: the cells
    are measured in random order over a session (a ``time_min`` column, 2 minutes a cell) and
    every stiffness reading (``k_c``, ``k_b`` and the bulge's reported error) is
    ``exp(size s_i)`` times the true one."""

    def observations(self, obs, design, rng):
        n = len(obs["k_c"])
        minutes = rng.permutation(n) * MINUTES_PER_CELL
        s = minutes / max(np.ptp(minutes), 1.0) - 0.5 if n > 1 else np.zeros(n)
        c = np.exp(self.size * s)
        obs = dict(obs)
        for key in ("k_c", "k_b", "k_b_err"):
            obs[key] = obs[key] * c
        extra = dict(obs.get("extra") or {})
        extra[TIME_COLUMN] = tuple(f"{m:g}" for m in minutes)
        obs["extra"] = extra
        return obs


register_effect(Drift())
