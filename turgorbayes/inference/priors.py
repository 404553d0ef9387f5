"""Prior distributions of the global parameters and the coordinates the sampler moves in.

Each prior knows the unconstrained-ish coordinate ``u`` that emcee samples (``x / scale``
for location priors, ``ln x`` for positive ones, ``logit x`` for fractions) and returns
the log density *of u* (Jacobian included), so ``log_posterior(u) = log_prior(u) + log_lik``
needs no further bookkeeping. All methods broadcast over numpy arrays.

The baseline's priors (documented in :data:`BASELINE_PRIORS`) are flat in the sampled
coordinate, which keeps the posterior's shape the likelihood's shape (weakly informative:
they only cut off physically absurd values).
"""

from dataclasses import dataclass

import numpy as np
from scipy import special, stats

__all__ = [
    "BASELINE_PRIORS",
    "Beta",
    "HalfNormal",
    "LogNormal",
    "LogUniform",
    "Normal",
    "Uniform",
]


@dataclass(frozen=True)
class Uniform:
    """Uniform prior on ``[lower, upper]`` (physical units); sampled as ``u = x / scale``."""

    lower: float
    upper: float
    scale: float = 1.0

    def to_physical(self, u):
        return np.asarray(u, dtype=float) * self.scale

    def to_u(self, x):
        return np.asarray(x, dtype=float) / self.scale

    def log_density_u(self, u):
        x = self.to_physical(u)
        inside = (x >= self.lower) & (x <= self.upper)
        return np.where(inside, -np.log((self.upper - self.lower) / self.scale), -np.inf)

    def sample(self, rng, size=None):
        return rng.uniform(self.lower, self.upper, size)

    def describe(self, unit="", factor=1.0):
        return f"uniform on [{self.lower / factor:g}, {self.upper / factor:g}] {unit}".strip()


@dataclass(frozen=True)
class LogUniform:
    """Log-uniform prior on ``[lower, upper]`` (> 0); sampled as ``u = ln x`` (flat in u)."""

    lower: float
    upper: float

    def to_physical(self, u):
        return np.exp(np.asarray(u, dtype=float))

    def to_u(self, x):
        return np.log(np.asarray(x, dtype=float))

    def log_density_u(self, u):
        u = np.asarray(u, dtype=float)
        lo, hi = np.log(self.lower), np.log(self.upper)
        return np.where((u >= lo) & (u <= hi), -np.log(hi - lo), -np.inf)

    def sample(self, rng, size=None):
        return np.exp(rng.uniform(np.log(self.lower), np.log(self.upper), size))

    def describe(self, unit="", factor=1.0):
        return f"log-uniform on [{self.lower / factor:g}, {self.upper / factor:g}] {unit}".strip()


@dataclass(frozen=True)
class Normal:
    """Normal prior N(mu, sd); sampled as ``u = x / scale``."""

    mu: float
    sd: float
    scale: float = 1.0

    def to_physical(self, u):
        return np.asarray(u, dtype=float) * self.scale

    def to_u(self, x):
        return np.asarray(x, dtype=float) / self.scale

    def log_density_u(self, u):
        return stats.norm.logpdf(self.to_physical(u), self.mu, self.sd) + np.log(self.scale)

    def sample(self, rng, size=None):
        return rng.normal(self.mu, self.sd, size)

    def describe(self, unit="", factor=1.0):
        return f"normal({self.mu / factor:g}, sd {self.sd / factor:g}) {unit}".strip()


@dataclass(frozen=True)
class LogNormal:
    """Lognormal prior: ``ln x ~ N(ln median, sigma)``; sampled as ``u = ln x``."""

    median: float
    sigma: float

    def to_physical(self, u):
        return np.exp(np.asarray(u, dtype=float))

    def to_u(self, x):
        return np.log(np.asarray(x, dtype=float))

    def log_density_u(self, u):
        return stats.norm.logpdf(np.asarray(u, dtype=float), np.log(self.median), self.sigma)

    def sample(self, rng, size=None):
        return np.exp(rng.normal(np.log(self.median), self.sigma, size))

    def describe(self, unit="", factor=1.0):
        return f"lognormal(median {self.median / factor:g} {unit}, log-sd {self.sigma:g})"


@dataclass(frozen=True)
class HalfNormal:
    """Half-normal prior with scale ``sd`` on x > 0; sampled as ``u = ln x``."""

    sd: float

    def to_physical(self, u):
        return np.exp(np.asarray(u, dtype=float))

    def to_u(self, x):
        return np.log(np.asarray(x, dtype=float))

    def log_density_u(self, u):
        u = np.asarray(u, dtype=float)
        x = np.exp(u)
        # density of x times the Jacobian dx/du = x
        return np.log(2.0) + stats.norm.logpdf(x, 0.0, self.sd) + u

    def sample(self, rng, size=None):
        return np.abs(rng.normal(0.0, self.sd, size))

    def describe(self, unit="", factor=1.0):
        return f"half-normal(scale {self.sd / factor:g}) {unit}".strip()


@dataclass(frozen=True)
class Beta:
    """Beta(a, b) prior on a fraction; sampled as ``u = logit x``."""

    a: float
    b: float

    def to_physical(self, u):
        return special.expit(np.asarray(u, dtype=float))

    def to_u(self, x):
        return special.logit(np.asarray(x, dtype=float))

    def log_density_u(self, u):
        u = np.asarray(u, dtype=float)
        # ln x = -softplus(-u), ln(1-x) = -softplus(u); Jacobian dx/du = x (1 - x)
        log_x = -np.logaddexp(0.0, -u)
        log_1mx = -np.logaddexp(0.0, u)
        return (self.a * log_x + self.b * log_1mx) - special.betaln(self.a, self.b)

    def sample(self, rng, size=None):
        return rng.beta(self.a, self.b, size)

    def describe(self, unit="", factor=1.0):
        return f"beta({self.a:g}, {self.b:g})"


#: Priors of the baseline model's four global parameters, in SI units.
#:
#: - ``gamma`` ~ U(0, 3): 0 is a linear (Hookean) wall; the paper finds 1.22 +- 0.12 and
#:   polymer networks rarely stiffen faster than cubically. Softening walls (gamma < 0) are
#:   excluded because the anisotropy formula (docs/physics.md, Anisotropy) assumes stiffening.
#: - ``E0t`` log-uniform on [1e-3, 1] N/m: E between ~1 and 100 MPa times t between ~3 and
#:   10 nm spans three decades; log-uniform because only the order of magnitude is known.
#: - ``R0`` ~ U(200, 1000) nm: every rod-shaped bacterium of E. coli's size class.
#: - ``P_phys`` log-uniform on [1, 200] kPa: published turgor estimates span 10-300 kPa
#:   (Deng et al. 2011, introduction); scale-free because its order is what is unknown.
BASELINE_PRIORS = {
    "gamma": Uniform(0.0, 3.0),
    "E0t": LogUniform(1e-3, 1.0),
    "R0": Uniform(200e-9, 1000e-9, scale=1e-9),
    "P_phys": LogUniform(1e3, 200e3),
}
