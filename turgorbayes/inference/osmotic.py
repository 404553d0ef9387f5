"""Intact cells in media of known osmolarities: each level's turgor from the osmotic balance.

The baseline puts every intact cell at ``P_phys``. Here intact cells carry the osmolarity of the
medium they were measured in (the ``medium_mOsm`` column, :mod:`turgorbayes.cells.medium`);
``P_phys`` is the turgor in the reference (growth) medium, and a cell measured at another level
sits at the turgor the osmotic balance gives from it, conserved osmolytes and the wall law
solved jointly (:func:`turgorbayes.physics.osmotic.turgor_after_shift`). The osmotically
inactive fraction ``b`` is sampled with its literature prior when there is more than one level.
Bulged cells enter as in the baseline (their bulges measure their pressures, whatever the
medium). docs/statistics.md, "Osmotic series".
"""

import dataclasses

import numpy as np

from turgorbayes.cells.medium import MEDIUM_COLUMN, medium_levels, medium_osmolarity
from turgorbayes.errors import DataError
from turgorbayes.inference import models
from turgorbayes.inference.context import LikelihoodContext
from turgorbayes.inference.likelihood import DEFAULT_NODES, CellLikelihood
from turgorbayes.inference.observations import (
    DEFAULT_LATENT,
    latent_population,
    observations_from_cells,
    sample_latent,
    stiffness_sd,
)
from turgorbayes.inference.priors import Beta
from turgorbayes.inference.reading_correlation import cell_correlations, correlated_normals, known_rho
from turgorbayes.physics import forward, osmotic
from turgorbayes.physics.parameters import P0

__all__ = [
    "B_PRIOR",
    "B_PARAMETER",
    "InactiveFraction",
    "OsmoticDesign",
    "OsmoticModel",
    "level_balance",
    "level_states",
    "level_variable",
    "osmotic_design",
    "sub_observations",
]


@dataclasses.dataclass(frozen=True)
class InactiveFraction(Beta):
    """The Beta prior of ``b`` with the bounds a least-squares start searches within."""

    lower: float = 0.01
    upper: float = 0.9


#: Prior of the osmotically inactive fraction ``b = V_b/V`` of the growth-medium volume:
#: Beta(6, 14), mean 0.30, sd 0.10. E. coli's dry matter fills about 20 % of its volume
#: (Feijó Delgado et al., PLoS ONE 8, e67590, 2013) and part of its cytoplasmic water is bound
#: (Cayley et al., Biophys. J. 78, 1748, 2000; about a fifth of it at low osmolarity, Cayley &
#: Record, Biochemistry 42, 12596, 2003): 0.2-0.4 (docs/statistics.md, "Osmotic series").
B_PRIOR = InactiveFraction(6.0, 14.0)
#: The parameter ``b`` (sampled only with more than one medium level).
B_PARAMETER = models.Parameter("b", B_PRIOR, "b_inactive", 1.0, r"$b = V_b/V$")
#: Posterior variable of the turgor at medium level ``k`` [Pa].
LEVEL_VARIABLE = "P_level"


def level_variable(k):
    """The posterior variable of the turgor at medium level index ``k`` (``P_level__k``)."""
    return f"{LEVEL_VARIABLE}__{k}"


@dataclasses.dataclass(frozen=True)
class OsmoticDesign:
    """The medium levels of a data set and how the balance is evaluated.

    Attributes
    ----------
    levels : ndarray [mOsm]
        The intact cells' distinct medium osmolarities, ascending.
    reference : float [mOsm]
        The level whose turgor is ``P_phys`` (the growth medium).
    level_of : ndarray of int (n_intact,)
        Each intact cell's level (index into ``levels``), intact cells in file order.
    temperature : float [K]
    length_model : str
        One of :data:`turgorbayes.physics.osmotic.LENGTH_MODELS`.
    """

    levels: np.ndarray
    reference: float
    level_of: np.ndarray
    temperature: float = osmotic.T_DEFAULT
    length_model: str = "wall"

    @property
    def n_levels(self):
        return int(self.levels.size)

    @property
    def ref(self):
        """Index of the reference level."""
        return int(np.flatnonzero(self.levels == self.reference)[0])

    def counts(self):
        """Intact cells per level."""
        return np.bincount(self.level_of, minlength=self.n_levels)


def osmotic_design(cells, reference_medium=None, temperature=osmotic.T_DEFAULT,
                   length_model="wall"):
    """The :class:`OsmoticDesign` of ``cells`` (the ``medium_mOsm`` column).

    Parameters
    ----------
    cells : turgorbayes.cells.table.CellData
    reference_medium : float, optional [mOsm]
        The level whose turgor is ``P_phys``; default the lowest (the growth medium, to which
        osmolytes are added).
    temperature : float [K]
    length_model : str

    Raises
    ------
    DataError
        No column, no intact cells, a reference that is not a level, a temperature that is not
        a positive number, an unknown length model.
    """
    c = medium_osmolarity(cells)
    if c is None:
        raise DataError(f"no {MEDIUM_COLUMN} column: the osmotic model needs the osmolarity of "
                        "the medium each intact cell was measured in (docs/data_format.md)",
                        path=cells.path, column=MEDIUM_COLUMN)
    if cells.n_intact == 0:
        raise DataError("no intact cells: the osmotic series is a series of intact cells",
                        path=cells.path)
    levels = medium_levels(cells)
    if reference_medium is None:
        reference = float(levels[0])
    else:
        reference = float(reference_medium)
        if not np.any(levels == reference):
            raise DataError(f"--reference-medium {reference_medium:g} mOsm is not a level of the "
                            f"intact cells ({', '.join(f'{x:g}' for x in levels)} mOsm)",
                            path=cells.path, column=MEDIUM_COLUMN, value=f"{reference_medium:g}")
    if not (np.isfinite(temperature) and temperature > 0):
        raise DataError(f"the temperature must be a positive number of kelvin, got {temperature!r}")
    if length_model not in osmotic.LENGTH_MODELS:
        raise DataError(f"length model must be one of {', '.join(osmotic.LENGTH_MODELS)}, got "
                        f"{length_model!r}")
    intact = c[~np.asarray(cells.is_bulged, bool)]
    level_of = np.searchsorted(levels, intact)
    return OsmoticDesign(levels=levels, reference=reference, level_of=level_of,
                         temperature=float(temperature), length_model=length_model)


def sub_observations(obs, idx, latent=DEFAULT_LATENT):
    """The :class:`~turgorbayes.inference.observations.CellObservations` of the cells ``idx``
    of ``obs`` (errors as pooled over the whole data set), with a latent population from their
    own bulges."""
    is_b = obs.is_bulged[idx]
    rank = np.cumsum(obs.is_bulged) - 1
    b = rank[idx[is_b]]
    log_P, sd = obs.log_P_bulge[b], obs.sd_log_P_bulge[b]
    return dataclasses.replace(
        obs, is_bulged=is_b, R_c=obs.R_c[idx], R_c_err=obs.R_c_err[idx], k_c=obs.k_c[idx],
        k_c_err=obs.k_c_err[idx], log_P_bulge=log_P, sd_log_P_bulge=sd,
        bulged=np.flatnonzero(is_b), intact=np.flatnonzero(~is_b),
        population=latent_population(log_P, sd, latent),
        rho_R_k=None if obs.rho_R_k is None else np.asarray(obs.rho_R_k)[idx])


def level_balance(v, design, P0):
    """The osmotic balance at each medium level (:func:`turgorbayes.physics.osmotic.turgor_after_shift`)
    for physical values ``v`` (``gamma``, ``E0t`` [N/m], ``R0`` [m], ``P_phys`` [Pa], ``b``
    optional, default its prior mean; arrays ``(W,)``): dict of ``(W, n_levels)`` arrays ``P``
    [Pa], ``R_c`` [m], ``s``, ``plasmolysed``."""
    g, e, r, P = (np.atleast_1d(np.asarray(v[k], float))[:, None]
                  for k in ("gamma", "E0t", "R0", "P_phys"))
    b = np.atleast_1d(np.asarray(v.get("b", B_PRIOR.a / (B_PRIOR.a + B_PRIOR.b)), float))
    return osmotic.turgor_after_shift(P, g, e, r, c_ref=design.reference,
                                      c_out=design.levels[None, :],
                                      b=np.broadcast_to(b, g.shape[:1])[:, None], P0=P0,
                                      temperature=design.temperature,
                                      length_model=design.length_model)


def level_states(v, design, P0, surrogate):
    """Each medium level's turgor, radius and stiffness for physical values ``v`` (the
    osmotic balance, :func:`turgorbayes.physics.osmotic.turgor_after_shift`).

    Parameters
    ----------
    v : dict of array_like (W,)
        ``gamma``, ``E0t`` [N/m], ``R0`` [m], ``P_phys`` [Pa] and optionally ``b`` (default
        its prior mean).
    design : OsmoticDesign
    P0 : float [Pa]
    surrogate : turgorbayes.surrogate.Surrogate

    Returns
    -------
    dict of ndarray (W, n_levels)
        ``P`` [Pa], ``R_c`` [m], ``k_c`` [N/m] (NaN where the cell has no stiffness: turgor
        0 past plasmolysis, or outside the FE table) and ``plasmolysed``.
    """
    g, e, r = (np.atleast_1d(np.asarray(v[k], float))[:, None] for k in ("gamma", "E0t", "R0"))
    st = level_balance(v, design, P0)
    turgid = st["P"] > 0
    with np.errstate(invalid="ignore", divide="ignore"):
        k = forward.stiffness_at_radius(np.where(turgid, st["P"], np.nan), st["R_c"], g, e, r,
                                        P0, surrogate)
    return {"P": st["P"], "R_c": st["R_c"], "k_c": k, "plasmolysed": st["plasmolysed"]}


class OsmoticModel(models.BaselineModel):
    """The baseline with each intact cell at its medium level's turgor (module docstring).

    Parameters
    ----------
    cells : turgorbayes.cells.table.CellData
        Intact cells with ``medium_mOsm``; bulged cells optional.
    surrogate : turgorbayes.surrogate.Surrogate
    design : OsmoticDesign
    n_nodes : int
    P0 : float [Pa]
    latent : str
    """

    name = "osmotic"
    #: Sampled at the reference turgor (:mod:`turgorbayes.inference.wall_reference`): a series
    #: measures the wall between its levels, not at ``P0``.
    wall_references = (("gamma", "E0t", "R0", "P_phys"),)

    def __init__(self, cells, surrogate, design, n_nodes=DEFAULT_NODES, P0=P0,
                 latent=DEFAULT_LATENT):
        if cells.n_intact == 0:
            raise DataError("no intact cells: the osmotic model fits intact cells in media of "
                            "known osmolarity", path=cells.path)
        if design.n_levels < 2 and cells.n_bulged == 0:
            raise DataError(
                f"the intact cells were all measured at {design.levels[0]:g} mOsm and there are "
                "no bulged cells: one medium level cannot tell the wall from the turgor (two "
                "readings, R_c and k_c, at one unknown turgor); measure intact cells at two or "
                "more osmolarities, or bulged cells", path=cells.path, column=MEDIUM_COLUMN)
        self.cells, self.surrogate, self.P0 = cells, surrogate, float(P0)
        self.design = design
        self.latent = latent
        self.obs = observations_from_cells(cells, latent=latent)
        self.lik = CellLikelihood(self.obs, surrogate, n_nodes=n_nodes, P0=P0)
        self.parameters = models.BASELINE_PARAMETERS + (
            (B_PARAMETER,) if design.n_levels > 1 else ())
        i = self.obs.intact
        self._readings = (self.obs.R_c[i], self.obs.R_c_err[i], self.obs.k_c[i],
                          self.obs.k_c_err[i])
        self._rho = known_rho(cell_correlations(self.obs)[i])

    # ------------------------------------------------------------------ the balance
    def level_states(self, v):
        """Each medium level's turgor, radius and stiffness for physical values ``v``
        (:func:`level_states`)."""
        return level_states(v, self.design, self.P0, self.surrogate)

    def intact_log_likelihood(self, v):
        """``(W, n_intact)``: each intact cell's readings at its level's radius and stiffness."""
        st = self.level_states(v)
        R, k = st["R_c"][:, self.design.level_of], st["k_c"][:, self.design.level_of]
        with np.errstate(invalid="ignore", over="ignore"):
            f = CellLikelihood._obs_logpdf(None, R, k, *self._readings, self._rho)
        return np.where(np.isnan(f), -np.inf, f)

    # ------------------------------------------------------------------ likelihood
    def pointwise_log_likelihood(self, u):
        """``(W, n_cells)``: bulged cells as the baseline's, intact cells at their levels."""
        return self.log_likelihood_at(self.to_physical(u))

    def log_likelihood_at(self, v):
        """:meth:`pointwise_log_likelihood` at physical values ``v`` (``gamma``, ``E0t``,
        ``R0``, ``P_phys`` [SI] and optionally ``b``, arrays ``(W,)``)."""
        W = len(v["gamma"])
        bulged = (self.lik.bulged(v["gamma"], v["E0t"], v["R0"]) if self.obs.bulged.size
                  else np.empty((W, 0)))
        return self.lik.assemble(bulged, self.intact_log_likelihood(v))

    def cell_pressures(self, u):
        """``(W, n_cells)``: E[P_i | data_i, theta] (bulged), the level's turgor (intact) [Pa]."""
        return self.cell_pressures_at(self.to_physical(u))

    def cell_pressures_at(self, v):
        """:meth:`cell_pressures` at physical values ``v``."""
        out = np.empty((len(v["gamma"]), self.obs.n_cells))
        if self.obs.bulged.size:
            out[:, self.obs.bulged] = self.lik.latent_pressure_mean(v["gamma"], v["E0t"], v["R0"])
        out[:, self.obs.intact] = self.level_states(v)["P"][:, self.design.level_of]
        return out

    def posterior_predictive(self, u, rng):
        """Replicated ``R_c``, ``k_c`` ``(W, n_cells)``: bulged cells as the baseline's, intact
        cells at their level's state, with the reported errors (correlated where known)."""
        return self.posterior_predictive_at(self.to_physical(u), rng)

    def posterior_predictive_at(self, v, rng):
        """:meth:`posterior_predictive` at physical values ``v``."""
        W, o = len(v["gamma"]), self.obs
        R, k = np.empty((W, o.n_cells)), np.empty((W, o.n_cells))
        if o.bulged.size:
            log_P = sample_latent(o, rng, W)
            R[:, o.bulged], k[:, o.bulged] = self.lik.forward(log_P, v["gamma"], v["E0t"],
                                                              v["R0"], walker_axis=True)
        st = self.level_states(v)
        R[:, o.intact] = st["R_c"][:, self.design.level_of]
        k[:, o.intact] = st["k_c"][:, self.design.level_of]
        z_R, z_k = correlated_normals(rng, R.shape, known_rho(cell_correlations(o)))
        return {"R_c": R + o.R_c_err * z_R, "k_c": k + stiffness_sd(k, o.k_c, o.k_c_err) * z_k}

    def derived(self, u, rng):
        """The baseline's moduli at ``P_phys``, each level's turgor (``P_level__k`` [Pa]) and the
        buffering factor at ``P_phys`` (:func:`turgorbayes.physics.osmotic.buffering_factor`)."""
        out = super().derived(u, rng)
        out.update(self.series_at(self.to_physical(u)))
        return out

    def series_at(self, v, suffix=""):
        """Each level's turgor ``P_level__k`` [Pa] and the buffering factor ``buffering`` at
        physical values ``v``, every name followed by ``suffix``."""
        P = self.level_states(v)["P"]
        out = {level_variable(k) + suffix: P[:, k] for k in range(self.design.n_levels)}
        d = self.design
        b = v.get("b", np.full(len(v["gamma"]), B_PRIOR.a / (B_PRIOR.a + B_PRIOR.b)))
        out["buffering" + suffix] = osmotic.buffering_factor(
            v["P_phys"], v["gamma"], v["E0t"], v["R0"], c_out=d.reference, b=b, P0=self.P0,
            temperature=d.temperature, length_model=d.length_model)
        return out

    # ------------------------------------------------------------------ hooks
    def least_squares(self):
        """The weighted least-squares fit of this model, the fit's start
        (:class:`turgorbayes.inference.osmotic_wls.OsmoticWLS`)."""
        from turgorbayes.inference.osmotic_wls import OsmoticWLS

        return OsmoticWLS(self)

    def start_values(self, guess):
        """Every parameter's start; ``b`` at its prior mean unless the guess has it."""
        out = dict(guess)
        out.setdefault("b", B_PRIOR.a / (B_PRIOR.a + B_PRIOR.b))
        return {p.name: out[p.name] for p in self.parameters}

    def flag_cells(self, draws, cell_ids, n_draws, screen_cells):
        """The gross-error screen with each intact cell at its level's turgor: bulged cells,
        then each level's intact cells, screened on their own (every cell's screen depends
        only on its own readings and the parameters)."""
        from turgorbayes.inference import sampling

        flat = {n: np.asarray(draws[n]).reshape(-1) for n in self.names}
        keep = sampling.evenly_spaced(next(iter(flat.values())).size, n_draws)
        v = {n: a[keep] for n, a in flat.items()}
        P = self.level_states(v)["P"]
        o, flags = self.obs, []
        groups = [(o.bulged, v["P_phys"])] if o.bulged.size else []
        groups += [(o.intact[self.design.level_of == k], P[:, k])
                   for k in range(self.design.n_levels)]
        for idx, pressure in groups:
            if not idx.size:
                continue
            part = _Screened(sub_observations(o, idx, self.latent), self.surrogate, self.P0,
                             self.lik.n_nodes)
            flags += screen_cells(part, dict(v, P_phys=pressure), [cell_ids[i] for i in idx])
        return sorted(flags, key=lambda d: -d["score"])


class _Screened:
    """Some cells of a model and their likelihood, for the gross-error screen."""

    effects = ()

    def __init__(self, obs, surrogate, P0, n_nodes):
        self.obs = obs
        self.lik = CellLikelihood(obs, surrogate, n_nodes=n_nodes, P0=P0)

    def context(self, v, skip=()):
        """The context no effect changed (:meth:`BaselineModel.context`)."""
        return LikelihoodContext(v, v)
