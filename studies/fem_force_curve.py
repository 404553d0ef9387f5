"""The secant stiffness curve F(h)/(h P R_c) of one FE point, to see snaps (force drops).

Prints k/PR at h = R/20 and F/(h P R_c) at every indentation step, labelled by the depth in
units of R/20. Usage::

    python studies/fem_force_curve.py X RATIO [--mesh-scale S] [--h-min H] [--steps N]
                                         [--axial-refinement F] [--axial-stretch-mesh]
                                         [--half-model [--tip-offset DY]]

The FE settings are the shipped table's (read from its metadata: mesh scale 3, 1e-9 m under
the tip before scaling, 24 steps); the options override them (``--mesh-scale 1.5`` halves
every element). ``--axial-refinement F`` divides only the axial (meridional) element size at
the crest by F (an experiment: the inflated wall stretches axially by exp(x / (2 ratio)), so
an axially soft wall's elements under the tip are longer than the tip can resolve);
``--axial-stretch-mesh`` divides it by that stretch (``CapsuleConfig.axial_stretch_mesh``).
``--half-model`` drops the symmetry plane through the axis and the indenter
(``CapsuleConfig.half_model``): a buckle under the tip that breaks that symmetry is then free
to form, which the quadrant forbids. A symmetric start stays on the symmetric path under Newton's
method, so ``--tip-offset DY`` (half model only) also moves the indenter's axis by DY metres
across that plane: a small imperfection that lets an asymmetric or imperfection-sensitive
post-buckling path show itself.
"""

import argparse
import dataclasses

import numpy as np

from turgorbayes import fem, provenance, surrogate
from turgorbayes.fem import indentation, indentation_point, pressure_for_inflation_number
from turgorbayes.surrogate.build import config_from_metadata

#: A smoke run's FE settings: a coarse mesh, one nominal depth step (about 1 s a point).
SMOKE_FE = {"mesh_scale": 10.0, "h_min": 3e-9, "h_bottom": 12e-9, "h_max": 80e-9, "growth": 0.5,
            "n_indent_steps": 1, "step_tolerance": 0.0}


def _shift_indenter(dy):
    """Move the indenter's axis to y = dy (the nodes are shifted by -dy in its frame)."""
    contact = indentation.indenter_contact

    def shifted(x, *args, **kw):
        x = x.copy()
        x[:, 1] -= dy
        return contact(x, *args, **kw)

    indentation.indenter_contact = shifted


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("x", type=float, nargs="?")
    parser.add_argument("ratio", type=float, nargs="?")
    parser.add_argument("--mesh-scale", type=float, default=None)
    parser.add_argument("--h-min", type=float, default=None)
    parser.add_argument("--steps", type=int, default=None)
    parser.add_argument("--axial-refinement", type=float, default=None)
    parser.add_argument("--axial-stretch-mesh", action="store_true")
    parser.add_argument("--half-model", action="store_true")
    parser.add_argument("--tip-offset", type=float, default=0.0, metavar="DY")
    args = provenance.add_output_options(parser).parse_args()
    if args.smoke:  # the paper's point on a coarse mesh
        args.x = 0.0706 if args.x is None else args.x
        args.ratio = 0.457 if args.ratio is None else args.ratio
    if args.x is None or args.ratio is None:
        parser.error("give X and RATIO")
    provenance.tee_stdout(args, "fem_force_curve.txt")
    print(provenance.header_line(), flush=True)
    if args.tip_offset:
        if not args.half_model:
            parser.error("--tip-offset needs --half-model (the quadrant's y = 0 plane is a symmetry "
                         "plane through the indenter's axis)")
        _shift_indenter(args.tip_offset)
    if args.axial_refinement:  # a fixed factor instead of the stretch: route it through the option
        indentation.axial_stretch = lambda P, ratio, cfg=None: args.axial_refinement
    cfg = config_from_metadata(surrogate.load().metadata["fe_config"], fem.CapsuleConfig)
    if args.smoke:
        cfg = dataclasses.replace(cfg, **SMOKE_FE)
    overrides = {"mesh_scale": args.mesh_scale, "h_min": args.h_min, "n_indent_steps": args.steps,
                 "axial_stretch_mesh": True if (args.axial_stretch_mesh or args.axial_refinement)
                 else None, "half_model": True if args.half_model else None}
    cfg = dataclasses.replace(cfg, **{k: v for k, v in overrides.items() if v is not None})
    P = pressure_for_inflation_number(args.x, args.ratio, cfg)
    r = indentation_point(P, args.ratio, cfg)
    h, F = np.asarray(r.h_m)[1:], np.asarray(r.F_N)[1:]
    print(f"x={args.x} ratio={args.ratio} mesh_scale={cfg.mesh_scale} steps={cfg.n_indent_steps} "
          f"axial refinement {args.axial_refinement or args.axial_stretch_mesh} half {cfg.half_model} "
          f"tip offset {args.tip_offset:g} m "
          f"DOF={r.mesh_dofs} k/PR={r.k_over_PR:.5f} {r.wall_time_s:.0f} s")
    print(" ".join(f"{a * 20 / r.R_c_m:.2f}:{b / (a * P * r.R_c_m):.3f}"
                   for a, b in zip(h, F, strict=True)))


if __name__ == "__main__":
    main()
