r"""``radius_spread``: the reference radius ``R0`` varies from cell to cell.

Cause (docs/effects.md, radius_spread): the baseline fits one ``R0`` for all cells, yet real *E. coli*
widths vary from cell to cell by about 4-7 % (mother-machine measurements,
:mod:`turgorbayes.inference.width_prior`).

Model: cell ``i`` has :math:`\ln R_{0,i} = \ln R_0 + \tau_R\eta_i`, :math:`\eta_i\sim N(0,1)`
(lognormal, spread ``tau_R`` fitted), the other wall parameters shared. ``R0`` becomes the
median cell's radius at ``P0``. Prior: ``tau_R ~ HalfNormal(0.0352)``
(:data:`turgorbayes.inference.width_prior.TAU_R_PRIOR`: 95 % of its mass below the largest robust log-width
spread of three real mother-machine data sets, 0.069; see that module for how).

Integrating each cell's ``eta_i`` out by quadrature
--------------------------------------------------
For every walker and every latent-pressure node the wall model is evaluated at three radii,
:math:`R_0e^{\delta}` with :math:`\delta = -\Delta, 0, \Delta` (:data:`DELTA` = 0.05), as
wall variants of the shared grid (:class:`turgorbayes.effects.LikelihoodContext`), and
:math:`\ln R_c`, :math:`\ln k_c` are represented as quadratics in :math:`\delta` through them
(:math:`\ln R_c` is nearly linear in :math:`\delta`: :math:`\ln R_c = \ln R_0 + \delta +
s(pe^{\delta})` with :math:`s` the wall strain, whose dependence on :math:`\ln p` is weak).
The integral over :math:`\eta_i` is then adaptive Gauss-Hermite: the nodes are centred on the
conditional mode of :math:`\eta_i` (two Gauss-Newton steps on the two observables and the
N(0, 1) prior) and scaled by its conditional sd, with the importance correction of the prior
(Liu & Pierce, Biometrika 81, 624, 1994):

.. math::

    p(y_i\mid x, \theta) = \sum_q w_q \frac{\phi(\hat\eta + \hat s z_q)}{\phi(z_q)}\hat s\;
        p_R\!\left(R_{obs}\mid R(x, \tau_R\eta_q)\right) p_k\!\left(k_{obs}\mid k(x, \tau_R\eta_q)\right),

:data:`N_ETA_NODES` = 5 nodes. Against a dense quadrature with the exact forward model the
per-cell log-likelihood is right to about 2e-4 for ``tau_R`` up to 0.07 (tests), far below what
matters for the fit or for LOO. Intact cells: the same at ``P_phys``. Both groups carry the
spread.
"""

import numpy as np

from turgorbayes.effects.base import Effect, SqrtCoordinate
from turgorbayes.effects.registry import register_effect
from turgorbayes.inference.context import reading_logpdf, walker_column
from turgorbayes.inference.models import Parameter
from turgorbayes.inference.quadrature import hermite_rule
from turgorbayes.inference.reading_correlation import centre_terms, readings
from turgorbayes.inference.width_prior import TAU_R_PRIOR

__all__ = ["DELTA", "MAX_ETA", "N_ETA_NODES", "RadiusSpread", "eta_integral"]

#: Offsets ``+-DELTA`` in ln R0 of the two extra wall variants (0.05 minimizes the error of the
#: quadratic representation over the prior range of tau_R; 0.1 doubles it).
DELTA = 0.05
#: Gauss-Hermite nodes of the adaptive eta integral.
N_ETA_NODES = 5
#: The adaptive centre stays within this many prior sds.
MAX_ETA = 6.0
_GN_STEPS = 2


def _quadratic(a):
    """Taylor coefficients in delta from values at ``(-DELTA, 0, DELTA)`` on axis 1."""
    lo, mid, hi = a[:, 0], a[:, 1], a[:, 2]
    return mid, (hi - lo) / (2 * DELTA), (hi - 2 * mid + lo) / DELTA**2


def _at(coef, d):
    return coef[0] + d * (coef[1] + 0.5 * d * coef[2])


def _slope(coef, d):
    return coef[1] + d * coef[2]


def _exp_at_nodes(coef, d):
    """``exp(_at(coef, d))`` for coefficients ``(W, ...)`` and offsets ``d (W, Q, ...)`` at
    ``Q`` nodes (the coefficients broadcast along the node axis), computed in place in the
    same order as :func:`_at`."""
    out = 0.5 * d
    out *= coef[2][:, None]
    out += coef[1][:, None]
    out *= d
    out += coef[0][:, None]
    return np.exp(out, out=out)


def eta_integral(ctx, lnR, lnk, obs, tau, n_nodes=N_ETA_NODES):
    r"""``ln`` of the cell density integrated over the cell's radius offset ``eta``.

    Parameters
    ----------
    ctx : turgorbayes.effects.LikelihoodContext
        For ``R_logpdf`` and ``k_logpdf`` (other effects may have changed them).
    lnR, lnk : ndarray (W, 3, n, K)
        Model ``ln R_c``, ``ln k_c`` at ``R0 e^delta``, ``delta = -DELTA, 0, DELTA``.
    obs : tuple of ndarray (n, 1)
        ``R_obs, R_err, k_obs, k_err`` [m, m, N/m, N/m].
    tau : ndarray (W,)
        Spread ``tau_R`` of ``ln R0``.
    n_nodes : int
        Gauss-Hermite nodes.

    Returns
    -------
    ndarray (W, n, K)

    Notes
    -----
    The nodes are the second axis of the integrand, ``(W, Q, n, K)`` (walkers first, as the
    observables' densities expect): every operation then runs over the contiguous ``(n, K)``
    block, and the sum over the nodes is the sequential one :func:`numpy.sum` does over a
    last axis shorter than 8 (the same value, bit for bit, as on a ``(W, n, K, Q)`` layout).
    """
    R_obs, R_err, k_obs, k_err, rho = readings(obs)
    cR, ck = _quadratic(lnR), _quadratic(lnk)
    t = walker_column(tau, lnR.ndim - 1)
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        m, sd = _eta_centre(cR, ck, t, obs, ctx.rho(rho, lnR.ndim - 1))
        z, log_w = hermite_rule(n_nodes)
        node = (1, z.size) + (1,) * (m.ndim - 1)
        eta = m[:, None] + sd[:, None] * z.reshape(node)
        d = t[:, None] * eta
        f = reading_logpdf(ctx, R_obs, _exp_at_nodes(cR, d), R_err, k_obs,
                           _exp_at_nodes(ck, d), k_err, ctx.rho(rho, lnR.ndim))
        prior = np.square(eta, out=eta)
        prior *= 0.5
        f += np.subtract((log_w + 0.5 * z**2).reshape(node), prior, out=prior)
        f += np.log(sd)[:, None]
    f[np.isnan(f)] = -np.inf
    mx = np.max(f, axis=1)
    mx[~np.isfinite(mx)] = 0.0
    f -= mx[:, None]
    with np.errstate(divide="ignore"):
        return np.log(_node_sum(np.exp(f, out=f))) + mx


def _node_sum(e):
    """Sum over the node axis (1) of ``e (W, Q, ...)`` in :func:`numpy.sum`'s order over a
    contiguous last axis of length ``Q``: sequential below 8 nodes (pairwise above)."""
    if e.shape[1] >= 8:
        return np.sum(np.ascontiguousarray(np.moveaxis(e, 1, -1)), axis=-1)
    total = e[:, 0] + e[:, 1] if e.shape[1] > 1 else e[:, 0].copy()
    for q in range(2, e.shape[1]):
        total += e[:, q]
    return total


def _eta_centre(cR, ck, t, obs, rho=None):
    """Conditional mode and sd of ``eta`` (Gauss-Newton from 0, :data:`_GN_STEPS` steps;
    ``rho``: the readings' error correlation, None for independent readings)."""
    R_obs, R_err, k_obs, k_err = obs[:4]
    iR2, rel = 1 / R_err**2, k_err / k_obs
    m = np.zeros(cR[0].shape)
    prec = np.ones(cR[0].shape)
    for _ in range(_GN_STEPS):
        d = t * m
        R, ratio = np.exp(_at(cR, d)), k_obs / np.exp(_at(ck, d))
        R1, dlnk = R * _slope(cR, d) * t, _slope(ck, d) * t  # d/d eta
        # relative stiffness error (turgorbayes.inference.observations.stiffness_sd): residual
        # (k_obs/k - 1)/rel with slope -(k_obs/k) dlnk/rel; -ln(rel k) adds the gradient -dlnk
        J_k = ratio * dlnk / rel
        if rho is None:
            new_prec = 1 + R1 * R1 * iR2 + J_k * J_k
            num = R1 * (R_obs - R + R1 * m) * iR2 + J_k * (J_k * m + (ratio - 1) / rel) - dlnk
        else:  # correlated readings (turgorbayes.inference.reading_correlation)
            p, q = centre_terms(R1 / R_err, (R_obs - R + R1 * m) / R_err, J_k,
                                J_k * m + (ratio - 1) / rel, rho)
            new_prec, num = 1 + p, q - dlnk
        new_m = np.clip(num / new_prec, -MAX_ETA, MAX_ETA)
        ok = np.isfinite(new_m) & np.isfinite(new_prec)
        m = np.where(ok, new_m, m)
        prec = np.where(ok, new_prec, prec)
    return m, np.minimum(1 / np.sqrt(prec), 1.0)


class RadiusSpread(Effect):
    """Lognormal cell-to-cell spread ``tau_R`` of ``R0``, integrated out per cell (module docstring)."""

    name = "radius_spread"
    changes_wall = True
    default_radius_errors_warning = (
        "the measurement errors alone already give the paper's whole 20 nm scatter of R_c, so "
        "the width spread adds scatter real data do not show; give smaller errors (e.g. "
        "--Rc-err-nm 8 12, as in the bundled example)")
    parameters = (Parameter("tau_R", SqrtCoordinate(TAU_R_PRIOR), "tau_R", 1.0, r"$\tau_R$"),)
    size_parameter = "tau_R"
    null_value = 0.0
    realistic_size = 0.02
    realistic_size_reason = (
        "tau_R = 0.02: the AFM paper's intact cells scatter by 20 nm in R_c (0.55 +- 0.02 um) "
        "with measurement errors of 15-25 nm, which leaves at most sqrt(20^2 - 15^2) = 13.2 nm, "
        "2.4 % of R_c = 541 nm, for the cells' own spread; dlnR_c/dlnR0 = 1.18 at 29 kPa, so "
        "tau_R <= 0.024/1.18 = 0.021 (0.02: 12.8 nm, with 15 nm of error 19.7 nm in all). The "
        "mother-machine widths allow more (robust log-width spread 0.037-0.042 within a "
        "channel, an upper bound: segmentation noise adds to it), so the paper sets the size")
    start = {"tau_R": 0.02}
    #: Its realistic size hides in the default 15-25 nm radius errors (the warning above).
    realistic_design = {"R_c_err_nm": (8.0, 12.0)}
    cause = ("Cells differ in width: each cell has its own radius (spread about {size:.1%} from "
             "cell to cell), which the baseline's single radius for all cells cannot describe.")

    def apply(self, ctx, v):
        deltas = np.array([-DELTA, 0.0, DELTA])
        for group in ("bulged", "intact"):
            if next(iter(ctx.walls[group].values())).shape[1] != 1:
                raise ValueError("radius_spread must be the only effect with wall variants")

            def update(walls, q, deltas=deltas):
                walls = dict(walls)
                walls["R0"] = walls["R0"] * np.exp(deltas[q])
                return walls

            ctx.add_variants(group, update, np.zeros((1, 3)))
        tau = np.asarray(v["tau_R"], float)

        def cell_logpdf(ctx_, lnR, lnk, obs, log_w):
            return eta_integral(ctx_, lnR, lnk, obs, tau)

        ctx.cell_logpdf = cell_logpdf

    def cell_walls(self, walls, v, is_bulged, rng):
        if rng is None:
            return walls
        walls = dict(walls)
        R0 = np.asarray(walls["R0"], float)
        shape = np.broadcast_shapes(R0.shape, np.shape(v["tau_R"]), is_bulged.shape)
        walls["R0"] = R0 * np.exp(v["tau_R"] * rng.standard_normal(shape))
        return walls


register_effect(RadiusSpread())
