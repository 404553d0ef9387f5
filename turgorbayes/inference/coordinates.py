"""Sampler coordinates of a model's parameters and the physical values they stand for.

Each parameter is sampled in its prior's own coordinate (:mod:`turgorbayes.inference.priors`:
``u = x/scale``, ``ln x``, ``logit x``); a model that names wall references samples the wall at
its reference turgor instead (:mod:`turgorbayes.inference.wall_reference`), with the Jacobian
of that change in its log prior (docs/statistics.md, "Osmotic series: coordinates").
"""

from dataclasses import dataclass

import numpy as np

from turgorbayes.inference import wall_reference
from turgorbayes.inference.priors import BASELINE_PRIORS
from turgorbayes.physics.parameters import BASELINE, QUANTITIES

__all__ = ["BASELINE_PARAMETERS", "Coordinates", "Parameter", "log_u_slope"]


@dataclass(frozen=True)
class Parameter:
    """A global model parameter.

    Attributes
    ----------
    name : str
        Name in code and in posterior.nc (SI units).
    prior : object
        A prior of :mod:`turgorbayes.inference.priors`.
    key : str
        Name in summary.json (with its display unit).
    factor : float
        SI value / display value (1e-9 for nm, 1e3 for kPa).
    label : str
        Axis label with unit.
    """

    name: str
    prior: object
    key: str
    factor: float
    label: str


#: The baseline's parameters: names, keys, factors and labels from
#: :data:`turgorbayes.physics.parameters.QUANTITIES`, priors from :mod:`turgorbayes.inference.priors`.
BASELINE_PARAMETERS = tuple(
    Parameter(name, BASELINE_PRIORS[name], QUANTITIES[name].key, QUANTITIES[name].factor,
              QUANTITIES[name].tex)
    for name in BASELINE)


def log_u_slope(prior, x):
    """``ln |d u/d x|`` of ``prior``'s coordinate at ``x`` (central difference, relative step
    1e-6; exact for the linear and logarithmic coordinates of :mod:`~turgorbayes.inference.priors`)."""
    h = 1e-6 * np.abs(x)
    with np.errstate(all="ignore"):
        return np.log(np.abs(prior.to_u(x + h) - prior.to_u(x - h)) / (2 * h))


class Coordinates:
    """Sampler coordinates <-> physical values for a model's :attr:`parameters`.

    A model whose :attr:`wall_references` names groups ``(gamma, E0t, R0, P_phys)`` of its
    parameters is sampled with ``E_perp t`` and ``R_c`` at ``P_phys`` in the slots of ``E0t``
    and ``R0`` (:mod:`turgorbayes.inference.wall_reference`); the priors stay on the physical
    parameters, with the Jacobian of the change in :meth:`log_prior`.
    """

    parameters = BASELINE_PARAMETERS
    #: Groups of parameter names ``(gamma, E0t, R0, P_phys)`` sampled at their reference
    #: turgor (default none: every parameter in its prior's own coordinate).
    wall_references = ()

    @property
    def names(self):
        return tuple(p.name for p in self.parameters)

    @property
    def ndim(self):
        return len(self.parameters)

    def to_physical(self, u):
        """Sampler coordinates ``(W, ndim)`` -> dict of physical arrays ``(W,)`` (SI)."""
        return self._physical_and_log_jacobian(u)[0]

    _last = (None, None, None)  # the last coordinates with wall references, and their values

    def _physical_and_log_jacobian(self, u):
        """Physical values and ``ln |d u_physical/d u|`` (0 without wall references); the
        last call's result is kept, as the prior and the likelihood ask for the same ``u``."""
        u = np.atleast_2d(np.asarray(u, float))
        v = {p.name: p.prior.to_physical(u[:, i]) for i, p in enumerate(self.parameters)}
        log_jac = np.zeros(u.shape[0])
        if not self.wall_references:
            return v, log_jac
        key = (u.shape, u.tobytes())
        if self._last[0] == key:
            return dict(self._last[1]), self._last[2]
        priors = {p.name: p.prior for p in self.parameters}
        for g, e, r, P in self.wall_references:
            E_ref, R_ref = v[e], v[r]
            v[e], v[r], dR0 = wall_reference.wall_from_reference(v[P], v[g], E_ref, R_ref,
                                                                 self.P0)
            with np.errstate(all="ignore"):
                log_jac = log_jac + (  # d u_E0t/d u_E_ref, then d u_R0/d u_R_ref
                    log_u_slope(priors[e], v[e]) + np.log(v[e] / E_ref)
                    - log_u_slope(priors[e], E_ref) + log_u_slope(priors[r], v[r])
                    + np.log(np.abs(dR0)) - log_u_slope(priors[r], R_ref))
        self._last = (key, dict(v), log_jac)
        return v, log_jac

    def to_u(self, values):
        """Dict of physical values (SI) -> sampler coordinates ``(W, ndim)``."""
        values = dict(values)
        for g, e, r, P in self.wall_references:
            values[e], values[r] = wall_reference.reference_from_wall(
                values[P], values[g], values[e], values[r], self.P0)
        return np.stack([np.atleast_1d(p.prior.to_u(values[p.name])) for p in self.parameters],
                        axis=-1)

    def log_prior(self, u):
        """Log prior density of the sampler coordinates ``(W, ndim) -> (W,)`` (``-inf`` where
        the coordinates have no physical wall)."""
        u = np.atleast_2d(np.asarray(u, float))
        if not self.wall_references:
            return sum(p.prior.log_density_u(u[:, i]) for i, p in enumerate(self.parameters))
        v, log_jac = self._physical_and_log_jacobian(u)
        with np.errstate(all="ignore"):
            out = log_jac + sum(p.prior.log_density_u(p.prior.to_u(v[p.name]))
                                for p in self.parameters)
        return np.where(np.isnan(out), -np.inf, out)
