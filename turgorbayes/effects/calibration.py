r"""``calibration``: each measurement session's stiffnesses share one unknown scale factor.

Cause (docs/effects.md, calibration): an AFM force is the cantilever's deflection times its
spring constant, calibrated once per cantilever (thermal tune, Sader method) with an error of
about 5-20 %. Every stiffness measured with one cantilever, in one session, is therefore off
by the same factor: ``k_c`` and ``k_b`` alike, so also the bulge pressures read from ``k_b``.

Model: session ``s`` (the optional ``session`` column of the cell-data file) has the factor
``c_s = exp(sigma_cal z_s)``, ``z_s ~ N(0, 1)`` (non-centred, ``S`` sessions): every reading
``k_c``, ``k_b`` of its cells is ``c_s`` times the true stiffness. A bulged cell's latent
pressure becomes the apparent one ``P' = c_s P`` (what its bulge reports, and what the
population prior is estimated from); its wall is evaluated at ``P'/c_s`` and its ``k_c``
reading predicted as ``c_s k_c(P'/c_s)``; an intact cell's ``k_c`` as ``c_s k_c(P_phys)``
(:attr:`turgorbayes.inference.context.LikelihoodContext.log_k_scale`).

Identifiability: a factor common to every session is not identifiable from the data (with
``E0t`` and ``P_phys`` it rescales the whole experiment). The likelihood therefore sees only
the sessions' factors relative to their geometric mean, ``sigma_cal (z_s - mean z)``; the
sampled ``P_phys``, ``E0t`` are in that apparent scale. The common part ``delta = sigma_cal
mean(z)`` has its prior ``N(0, sigma_cal^2/S)`` as its posterior, and the reported
``P_phys``, ``E0t`` and moduli are divided by it (:meth:`Calibration.log_common_scale`,
:meth:`turgorbayes.effects.ExtendedModel.derived`): their intervals include the uncertainty of
the cantilevers' average calibration. (Letting the mean enter the likelihood instead made a
curved ridge with ``E0t`` and ``P_phys`` that neither importance sampling, Pareto k 0.89, nor
emcee followed.)

Prior: ``sigma_cal ~ HalfNormal(0.12)`` (95 % below 0.24): thermal-tune calibrations scatter
by 10-20 % between cantilevers and laboratories (te Riet et al., Ultramicroscopy 111, 1659,
2011, an interlaboratory round robin). Without a ``session`` column (or with one session) the
effect is not a candidate.
"""

import copy

import numpy as np

from turgorbayes.effects.base import Injection, SqrtCoordinate, StiffnessFactor
from turgorbayes.effects.registry import OWN_STIFFNESS_FACTOR, register_effect
from turgorbayes.errors import DataError
from turgorbayes.inference.models import Parameter
from turgorbayes.inference.priors import HalfNormal, Normal

__all__ = ["SESSION_COLUMN", "SIGMA_CAL_PRIOR", "Calibration", "CalibrationInjection",
           "session_labels"]

#: Prior on the session-to-session log-sd of the spring-constant calibration.
SIGMA_CAL_PRIOR = HalfNormal(0.12)
#: The optional cell-data column naming each cell's measurement session.
SESSION_COLUMN = "session"


def session_labels(cells):
    """Each cell's session label (tuple of str), or None without a ``session`` column.

    Raises
    ------
    DataError
        A cell with an empty session.
    """
    labels = dict(cells.extra).get(SESSION_COLUMN)
    if labels is None:
        return None
    labels = tuple(str(x).strip() for x in labels)
    empty = [cells.cell_id[i] for i, x in enumerate(labels) if not x]
    if empty:
        raise DataError(f"column {SESSION_COLUMN!r} is empty for {len(empty)} cell(s) "
                        f"({', '.join(empty[:5])}); give every cell its measurement session "
                        "or drop the column", path=cells.path, column=SESSION_COLUMN,
                        value=empty[0])
    return labels


class Calibration(StiffnessFactor):
    """A per-session factor on every stiffness reading (module docstring).

    The registered instance has only ``sigma_cal``; :meth:`bind` gives the instance for one
    data set, with one standardized log factor ``z_cal_j`` per session (sessions sorted by
    label, ``j = 1 ... S``).
    """

    family = OWN_STIFFNESS_FACTOR
    name = "calibration"
    parameters = (Parameter("sigma_cal", SqrtCoordinate(SIGMA_CAL_PRIOR), "sigma_cal", 1.0,
                            r"$\sigma_{cal}$"),)
    size_parameter = "sigma_cal"
    null_value = 0.0
    realistic_size = 0.15
    #: A calibration error needs cantilevers to differ: six measurement sessions.
    realistic_design = {"n_sessions": 6}
    realistic_size_reason = (
        "sigma_cal = 0.15 (spring constants off by about 15 % between cantilevers): the "
        "scatter of thermal-tune calibrations in an interlaboratory comparison (te Riet et al. "
        "2011)")
    start = {"sigma_cal": 0.05}
    cause = ("The AFM calibration differs between measurement sessions: the stiffnesses of "
             "one session share a common error of about {size:.0%} (cantilever spring "
             "constants), which also shifts that session's bulge pressures.")
    sessions = ()
    index = None

    def not_applicable_reason(self, cells):
        labels = session_labels(cells)
        if labels is None or len(set(labels)) < 2:
            return (f"the calibration effect needs a {SESSION_COLUMN!r} column naming at least "
                    "two measurement sessions")
        return None

    def bind(self, cells):
        reason = self.not_applicable_reason(cells)
        if reason:
            raise DataError(reason, path=cells.path, column=SESSION_COLUMN)
        labels = session_labels(cells)
        bound = Calibration()
        bound.sessions = tuple(sorted(set(labels)))
        where = {s: j for j, s in enumerate(bound.sessions)}
        bound.index = np.array([where[x] for x in labels])
        names = [f"z_cal_{j + 1}" for j in range(len(bound.sessions))]
        bound.parameters = self.parameters + tuple(
            Parameter(n, Normal(0.0, 1.0), n, 1.0, f"$z_{{{j + 1}}}$")
            for j, n in enumerate(names))
        bound.start = dict(self.start, **{n: 0.0 for n in names})
        return bound

    def restrict(self, idx):
        """The factors of the cells ``idx``: the same sessions and parameters (a session may
        hold cells of several conditions)."""
        if self.index is None:
            return self
        out = copy.copy(self)
        out.index = self.index[np.asarray(idx, int)]
        return out

    def _z(self, v):
        """``(W, S)`` standardized session factors."""
        return np.stack([np.asarray(v[f"z_cal_{j + 1}"], float).reshape(-1)
                         for j in range(len(self.sessions))], axis=-1)

    def log_factors(self, v):
        """Apparent ``ln c`` per walker and cell, ``(W, n_cells)``: ``sigma_cal (z_s - mean
        z)``, the factors relative to their geometric mean (module docstring)."""
        z = self._z(v)
        contrast = z - z.mean(axis=1, keepdims=True)
        return np.asarray(v["sigma_cal"], float).reshape(-1, 1) * contrast[:, self.index]

    def log_common_scale(self, v):
        """``sigma_cal mean(z)`` per walker ``(W,)``: the log geometric-mean factor of the
        sessions, which the data cannot see (module docstring)."""
        if self.index is None:
            return None
        return np.asarray(v["sigma_cal"], float).reshape(-1) * self._z(v).mean(axis=1)

    def is_bound(self):
        return self.index is not None

    def injection(self, size):
        return CalibrationInjection(self, float(size))


class CalibrationInjection(Injection):
    """Calibration at a fixed size for :func:`turgorbayes.simulation.cells.simulate_cells`: one
    factor ``exp(size eps_s)`` per session multiplies ``k_c``, ``k_b`` and their reported
    errors (a lab's error bars scale with its calibration); needs simulated sessions
    (``n_sessions``)."""

    def observations(self, obs, design, rng):
        labels = dict(obs.get("extra") or {}).get(SESSION_COLUMN)
        if labels is None:
            raise ValueError("the calibration effect needs sessions: simulate with n_sessions "
                             "(turgorbayes simulate --n-sessions N)")
        sessions = sorted(set(labels))
        self.log_factors = dict(zip(sessions, self.size * rng.standard_normal(len(sessions)),
                                    strict=True))
        c = np.exp([self.log_factors[x] for x in labels])
        obs = dict(obs)
        for key in ("k_c", "k_c_err", "k_b", "k_b_err"):
            obs[key] = obs[key] * c
        return obs

    def describe(self):
        out = super().describe()
        out["log_factors"] = {s: float(f) for s, f in getattr(self, "log_factors", {}).items()}
        return out


register_effect(Calibration())
