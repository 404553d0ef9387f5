"""Build the INTERIM bundled example ``turgorbayes/data/example_cells.csv`` (seed 0).

Illustrative simulated data only, until ``turgorbayes simulate`` replaces the file:
72 bulged cells with pressures log-uniform in 1-25 kPa, 42 intact cells at 29 kPa; wall model
at the paper's fit (E0t = 0.026 N/m, gamma = 1.22, R0 = 464.2 nm, P0 = 5 kPa); bulge radius
500 nm +- 10 % (sd), h_b = 0.2 R_b, k_b from the exact bulge model; k_c = 0.9 P R_c (the paper's
quoted k/PR, NOT the FE surrogate). Gaussian noise: 2 % on radii, 10 % on stiffnesses, with
the reported errors equal to those fractions of the observed values; h_b is exact.

Run: ``.venv/bin/python scripts/make_interim_example.py [OUT.csv]``
"""

import sys
from pathlib import Path

import numpy as np

from turgorbayes.cells.table import CellData, write_cells
from turgorbayes.physics.bulge import reduced_stiffness
from turgorbayes.physics.wall import radius_at_pressure

__all__ = []

SEED = 0
N_BULGED, N_INTACT = 72, 42
E0T, GAMMA, R0 = 0.026, 1.22, 464.2e-9  # paper's fit (docs/physics.md, Published values)
P_INTACT = 29e3  # [Pa]
K_OVER_PR_CELL = 0.9  # the paper's quoted k/(P R) for cells
R_REL_ERR, K_REL_ERR = 0.02, 0.10
COMMENTS = (
    "# INTERIM ILLUSTRATIVE DATA: simulated, not measurements (scripts/make_interim_example.py, "
    "seed 0).",
    "# 72 bulged cells (P log-uniform 1-25 kPa), 42 intact cells (P = 29 kPa); wall model at "
    "E0t = 0.026 N/m, gamma = 1.22, R0 = 464.2 nm.",
    "# k_c uses the paper's quoted k/(P R) ~ 0.9 instead of the FE surrogate; noise 2 % on "
    "radii, 10 % on stiffnesses; h_b exact.",
    "# This file will be replaced by `turgorbayes simulate` output.",
)


def _nm(values_m, decimals=1):
    """Round to ``decimals`` in nm and convert back by an exact decimal shift (as the loader)."""
    return np.array([float(f"{float(v)!r}e-9") for v in np.round(values_m * 1e9, decimals)])


def _sig(values, digits=4):
    return np.array([float(f"{v:.{digits}g}") for v in values])


def _observe(rng, true, rel_err, rounder):
    observed = rounder(true * (1 + rel_err * rng.standard_normal(true.shape)))
    return observed, rounder(rel_err * observed)


def simulate(rng):
    """The interim data set as a :class:`CellData` (random draws in a fixed order)."""
    P = np.concatenate([np.exp(rng.uniform(np.log(1e3), np.log(25e3), N_BULGED)),
                        np.full(N_INTACT, P_INTACT)])
    R_c = radius_at_pressure(P, GAMMA, E0T, R0)
    k_c = K_OVER_PR_CELL * P * R_c
    R_b = 500e-9 * (1 + 0.1 * rng.standard_normal(N_BULGED))
    h_b = _nm(0.2 * R_b)
    k_b = reduced_stiffness(h_b / R_b) * P[:N_BULGED] * R_b
    R_c_obs, R_c_err = _observe(rng, R_c, R_REL_ERR, _nm)
    k_c_obs, k_c_err = _observe(rng, k_c, K_REL_ERR, _sig)
    R_b_obs, R_b_err = _observe(rng, R_b, R_REL_ERR, _nm)
    k_b_obs, k_b_err = _observe(rng, k_b, K_REL_ERR, _sig)
    pad = np.full(N_INTACT, np.nan)
    return CellData(
        cell_id=[f"b{i + 1:03d}" for i in range(N_BULGED)] + [f"i{i + 1:03d}" for i in
                                                              range(N_INTACT)],
        group=["bulged"] * N_BULGED + ["intact"] * N_INTACT,
        R_c=R_c_obs, R_c_err=R_c_err, k_c=k_c_obs, k_c_err=k_c_err,
        R_b=np.concatenate([R_b_obs, pad]), R_b_err=np.concatenate([R_b_err, pad]),
        k_b=np.concatenate([k_b_obs, pad]), k_b_err=np.concatenate([k_b_err, pad]),
        h_b=np.concatenate([h_b, pad]),
        extra={"P_true_kPa": [f"{p / 1e3:.4g}" for p in P]},
        comments=COMMENTS,
    )


def main(out=None):
    out = Path(out or Path(__file__).parents[1] / "turgorbayes" / "data" / "example_cells.csv")
    write_cells(simulate(np.random.default_rng(SEED)), out)
    print(f"wrote {out}")


if __name__ == "__main__":
    main(*sys.argv[1:])
