"""Weighted least squares of the osmotic model: the start of its fit and the report's
least-squares column (:class:`OsmoticWLS`).

As the published method (:class:`turgorbayes.inference.models.PaperWLS`): bulge pressures
plugged in as exact, intact cells at their medium level's turgor
(:meth:`turgorbayes.inference.osmotic.OsmoticModel.level_states`), ``R_c`` and ``k_c`` weighted
by their reported errors; the inactive fraction ``b`` enters with its prior as one
pseudo-observation ``(b - mean)/sd`` (docs/statistics.md, "Osmotic series").
"""

import numpy as np

from turgorbayes.inference import models
from turgorbayes.inference.observations import observations_from_cells
from turgorbayes.physics import forward

__all__ = ["OsmoticWLS"]


class OsmoticWLS(models.PaperWLS):
    """Weighted least squares of an :class:`~turgorbayes.inference.osmotic.OsmoticModel`.

    Parameters
    ----------
    model : turgorbayes.inference.osmotic.OsmoticModel
    """

    name = "osmotic_wls"

    def __init__(self, model):
        self.model = model
        self.cells, self.surrogate, self.P0 = model.cells, model.surrogate, model.P0
        self.parameters = model.parameters
        self.obs = observations_from_cells(model.cells, relative_errors="reported")
        self._P_bulge = np.exp(self.obs.log_P_bulge)
        prior = next((p.prior for p in self.parameters if p.name == "b"), None)
        self._b_prior = None if prior is None else (
            prior.a / (prior.a + prior.b),
            np.sqrt(prior.a * prior.b / ((prior.a + prior.b) ** 2 * (prior.a + prior.b + 1))))

    def residuals(self, u):
        """Weighted residuals ``(obs - model)/err`` of R_c then k_c, all cells, then ``b``'s."""
        v = {k: a[:1] for k, a in self.to_physical(u).items()}
        r = self.reading_residuals(v)
        if self._b_prior is not None:
            r = np.append(r, self.b_residual(v))
        return r

    def b_residual(self, v):
        """``b``'s prior as one pseudo-observation ``(b - mean)/sd``."""
        return (v["b"][0] - self._b_prior[0]) / self._b_prior[1]

    def reading_residuals(self, v):
        """The readings' weighted residuals (R_c then k_c, all cells; the penalty where the
        model is undefined) at physical values ``v`` (arrays of one value)."""
        o = self.obs
        R, k = np.empty(o.n_cells), np.empty(o.n_cells)
        if o.bulged.size:
            R[o.bulged], k[o.bulged] = forward.cell_radius_and_stiffness(
                self._P_bulge, v["gamma"], v["E0t"], v["R0"], self.P0, self.surrogate)
        st = self.model.level_states(v)
        lev = self.model.design.level_of
        R[o.intact], k[o.intact] = st["R_c"][0, lev], st["k_c"][0, lev]
        r = np.concatenate([(o.R_c - R) / o.R_c_err, (o.k_c - k) / o.k_c_err])
        return np.where(np.isfinite(r), r, self._PENALTY)

    def _starts(self):
        """Starts from the reference level's readings and the change of radius and stiffness
        to the level farthest from it, for a few stiffening exponents."""
        o, d = self.obs, self.model.design
        lev = d.level_of
        i = o.intact
        R_ref, k_ref = np.mean(o.R_c[i][lev == d.ref]), np.mean(o.k_c[i][lev == d.ref])
        P_phys = float(np.clip(k_ref / R_ref, 2e3, 150e3))  # k/(PR) is about 1 (docs/physics.md)
        far = int(np.argmax(np.abs(d.levels - d.reference)))
        slope = 0.08  # d ln R/d ln P at the paper's values (x = 0.07)
        if far != d.ref:
            R_far, k_far = np.mean(o.R_c[i][lev == far]), np.mean(o.k_c[i][lev == far])
            P_far = P_phys * (k_far / R_far) / (k_ref / R_ref)
            if P_far > 0 and abs(np.log(P_far / P_phys)) > 0.05:
                slope = float(np.clip(np.log(R_ref / R_far) / np.log(P_phys / P_far), 0.01, 0.5))
        x = slope / (1 + slope)  # d ln R/d ln P = x/(1 - x)
        for gamma in (0.5, 1.0, 1.5, 2.2):
            E_t = P_phys * R_ref / x
            R0 = R_ref * (self.P0 / P_phys) ** slope
            yield {"gamma": gamma, "E0t": float(np.clip(E_t * (self.P0 / P_phys) ** gamma, 2e-3,
                                                        0.5)),
                   "R0": float(np.clip(R0, 250e-9, 950e-9)), "P_phys": P_phys,
                   **({"b": self._b_prior[0]} if self._b_prior is not None else {})}
