"""Full-accuracy verification anchors of the FE model; prints FE vs reference side by side.

1. Pinched cylinder (Lindberg, Olson & Cowper 1969): w E t / F = 164.24.
2. Pressurized sphere, point load at the pole: Vella et al. (2012) linear stiffness, for
   tau = 0 and values on both sides of 1, with two load-patch radii (t/2 and t) and the
   load through the thickness (the shell's point load).
3. Capsule inflation: FE radius vs the wall law's analytic radius at small and large x.
4. Symmetry: the quadrant model against the half model (whole circumference) at one point.

Usage: ``python studies/fem_anchors.py``
"""

import argparse
import math
import time

import numpy as np

from turgorbayes import provenance
from turgorbayes.fem import (
    CapsuleConfig,
    fe_inflated_radius,
    indentation_point,
    inflated_radius,
)
from turgorbayes.fem import pressure_for_inflation_number as pressure_for
from turgorbayes.fem.anchors import (
    PINCHED_CYLINDER_REFERENCE,
    pinched_cylinder,
    sphere_point_stiffness,
)

#: The full-accuracy anchors' meshes and points, and a smoke run's (one coarse case each).
FULL = {"pinched": ((5.0, 25.0, 1), (2.5, 12.5, 1), (2.5, 12.5, 2)),
        "taus": (0.0, 0.45, 0.85, 1.8, 4.0), "sphere_mesh": {}, "inflation": (0.005, 0.05, 0.2, 0.5),
        "capsule": {}, "symmetry_scale": 2.0}
SMOKE = {"pinched": ((5.0, 25.0, 1),), "taus": (0.85,),
         "sphere_mesh": {"h_min": 12e-9, "h_max": 160e-9}, "inflation": (0.05,),
         "capsule": {"mesh_scale": 10.0, "growth": 0.5, "n_indent_steps": 1}, "symmetry_scale": 10.0}


def pinched(meshes=FULL["pinched"]):
    print("pinched cylinder: w E t / F (reference 164.24)")
    for h_min, h_max, n_thick in meshes:
        t0 = time.perf_counter()
        v = pinched_cylinder(h_min=h_min, h_max=h_max, n_thick=n_thick)
        print(f"  h_min={h_min:<4} h_max={h_max:<5} n_thick={n_thick}: {v:8.3f} "
              f"({100 * (v / PINCHED_CYLINDER_REFERENCE - 1):+.2f}%)  {time.perf_counter() - t0:.1f}s")


def sphere(taus=FULL["taus"], mesh=FULL["sphere_mesh"]):
    E, t, R = 20e6, 6e-9, 500e-9
    root = E * t**2 / math.sqrt(12.0)
    print("pressurized sphere: k_FE / k_Vella - 1 (R = 500 nm, t = 6 nm, E = 20 MPa, nu = 0)")
    for tau in taus:
        P = 4 * tau * root / R**2
        cells = []
        for load_radius in (0.5 * t, t, None):
            out = sphere_point_stiffness(P, R, t, E, load_radius=load_radius, **mesh)
            cells.append(f"{100 * (out['k'] / out['k_vella'] - 1):+6.2f}%")
        print(f"  tau={out['tau']:.3f}  patch t/2: {cells[0]}  patch t: {cells[1]}  "
              f"through-thickness: {cells[2]}  (dofs {out['dofs']})")


def inflation(xs=FULL["inflation"], settings=FULL["capsule"]):
    cfg = CapsuleConfig(**settings)
    print(f"capsule inflation, production mesh{' with ' + str(settings) if settings else ''}: "
          "ln(R/R0) FE vs analytic (infinite cylinder)")
    for x in xs:
        for ratio in (1.0, 0.3):
            P = pressure_for(x, ratio, cfg)
            fe = math.log(fe_inflated_radius(P, ratio, cfg) / cfg.R0)
            an = math.log(inflated_radius(P, ratio, cfg) / cfg.R0)
            print(f"  x={x:<6} ratio={ratio}: FE {fe:.5f}  law {an:.5f}  ({100 * (fe / an - 1):+.2f}%)")


def symmetry(mesh_scale=FULL["symmetry_scale"], settings=FULL["capsule"]):
    print(f"quadrant vs half model (mesh_scale {mesh_scale}, x = 0.1, ratio 0.5)")
    for half in (False, True):
        cfg = CapsuleConfig(**{**settings, "mesh_scale": mesh_scale, "half_model": half})
        r = indentation_point(pressure_for(0.1, 0.5, cfg), 0.5, cfg)
        print(f"  {'half    ' if half else 'quadrant'}: k/PR={r.k_over_PR:.6f} "
              f"klin/PR={r.k_linear_over_PR:.6f} dofs={r.mesh_dofs}")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    args = provenance.add_output_options(parser).parse_args()
    cases = SMOKE if args.smoke else FULL  # smoke: one coarse case of each anchor
    provenance.tee_stdout(args, "fem_anchors.txt")
    print(provenance.header_line(), flush=True)
    np.set_printoptions(precision=4)
    pinched(cases["pinched"])
    sphere(cases["taus"], cases["sphere_mesh"])
    inflation(cases["inflation"], cases["capsule"])
    symmetry(cases["symmetry_scale"], cases["capsule"])
