"""Write the measured mesh-convergence points of the surrogate package from the result files.

``turgorbayes/surrogate/mesh_convergence.py`` records how far the FE settings of the surrogate
tables are from refined meshes. Its measured points are derived here from the committed result
files of ``studies/fem_convergence.py``, ``studies/fem_domain_corners.py`` and
``studies/fem_tip_radius.py`` and written to ``turgorbayes/surrogate/_mesh_points.py``;
``rel_diff_*`` is ``refined / production - 1`` to three significant figures.

Run: .venv/bin/python scripts/fill_mesh_convergence.py [--check]
"""

import argparse
import json
import pprint
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "studies" / "results"
TARGET = ROOT / "turgorbayes" / "surrogate" / "_mesh_points.py"

#: A line of fem_convergence_tip_mesh.txt: x, variant, k/PR, linear k/PR.
_CONVERGENCE = re.compile(r"^x=(\S+)\s+(\S+)\s+k/PR=(\S+) \(\S+\) klin/PR=(\S+)")
#: A row of fem_domain_corners*.txt: x, ratio | k table, half | linear table, half.
_CORNER = re.compile(r"^\s*(\S+)\s+(\S+) \|\s+(\S+)\s+(\S+)\s+\S+ \|\s+(\S+)\s+(\S+)\s+\S+ \|")

#: (x, production variant, refined variant, best variant or None) of fem_convergence_tip_mesh.txt.
SURROGATE_MESH = [(0.005, "scale_3_tip", "scale_1.5_tip", "tip_mesh_half"),
                  (0.01, "scale_3_tip", "scale_1.5_tip", None),
                  (0.0706, "scale_3_tip", "scale_1.5_tip", "tip_mesh_half"),
                  (0.52, "scale_3_tip", "scale_1.5_tip", "tip_mesh_half")]
TABLE_MESH_X = (0.005, 0.0706, 0.52)
#: Tip radii [nm] of the tip-radius tables' check (x = 0.0706, ratio 0.457, t = 6 nm).
TIP_NM = (3.0, 30.0)

HEADER = '''"""Measured points of :data:`turgorbayes.surrogate.mesh_convergence.MESH_CONVERGENCE`.

Written by ``scripts/fill_mesh_convergence.py`` from studies/results/ (do not edit by hand).
"""

MEASURED = '''


def _sig(v):
    return float(f"{v:.3g}")


def _diffs(base, refined, suffix=""):
    """``rel_diff_k`` and ``rel_diff_k_linear`` of ``refined`` against ``base`` ((k, k_lin))."""
    return {f"rel_diff_k{suffix}": _sig(refined[0] / base[0] - 1),
            f"rel_diff_k_linear{suffix}": _sig(refined[1] / base[1] - 1)}


def convergence_runs(text):
    """``{(x, variant): (k/PR, linear k/PR)}`` of fem_convergence.py's lines (the last run of
    each)."""
    runs = {}
    for line in text.splitlines():
        m = _CONVERGENCE.match(line)
        if m:
            runs[(float(m[1]), m[2])] = (float(m[3]), float(m[4]))
    return runs


def corner_rows(text):
    """``[(x, ratio, (k, k_lin) production, (k, k_lin) half size)]`` of fem_domain_corners.py."""
    return [(float(m[1]), float(m[2]), (float(m[3]), float(m[5])), (float(m[4]), float(m[6])))
            for m in map(_CORNER.match, text.splitlines()) if m]


def surrogate_mesh_points(runs):
    out = []
    for x, base, refined, best in SURROGATE_MESH:
        point = {"x": x, "ratio": 1.0, **_diffs(runs[(x, base)], runs[(x, refined)])}
        if best:
            point |= _diffs(runs[(x, base)], runs[(x, best)], "_best")
        out.append(point)
    return out


def table_mesh_points(runs, corners):
    out = [{"x": x, "ratio": r, **_diffs(a, b)} for x, r, a, b in corners if r == 1.0]
    return out + [{"x": x, "ratio": 1.0, **_diffs(runs[(x, "tip_mesh")], runs[(x, "tip_mesh_half")])}
                  for x in TABLE_MESH_X]


def tip_points(rows):
    out = []
    for tip in TIP_NM:
        at = [r for r in rows if r["tip_nm"] == tip and r["x_target"] == 0.0706
              and r["ratio"] == 0.457 and r.get("thickness_nm", 6.0) == 6.0]
        kind = {r["variant"]: (r["k_over_PR"], r["k_linear_over_PR"]) for r in reversed(at)}
        out.append({"x": 0.0706, "ratio": 0.457, "tip_radius": tip / 1e9,
                    **_diffs(kind["tip_half"], kind["tip_quarter"])})
    return out


def derive(results=RESULTS):
    """The measured points per section, from the result files in ``results``."""
    runs = convergence_runs((results / "fem_convergence_tip_mesh.txt").read_text())
    corners = corner_rows((results / "fem_domain_corners_fine.txt").read_text())
    tips = [json.loads(line) for line in (results / "fem_tip_radius.jsonl").read_text().splitlines()
            if line.startswith("{")]
    return {"surrogate_mesh": surrogate_mesh_points(runs),
            "table_mesh": table_mesh_points(runs, corners),
            "tip_tables_mesh": tip_points(tips)}


def render(points):
    """The text of ``_mesh_points.py``."""
    return HEADER + pprint.pformat(points, width=99, sort_dicts=False) + "\n"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true",
                    help="exit 1 if the package's points differ from the result files'")
    args = ap.parse_args(argv)
    text = render(derive())
    if args.check:
        same = TARGET.read_text() == text
        print(f"{TARGET.relative_to(ROOT)}: {'up to date' if same else 'differs'}")
        return 0 if same else 1
    TARGET.write_text(text)
    print(f"wrote {TARGET.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
