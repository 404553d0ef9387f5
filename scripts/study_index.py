"""Write studies/README.md, the index of the studies: per script its kind, what it measures
(its docstring's first line), the README/docs sections that cite it or its results, and its
result files in studies/results/ with the commit that produced each (from the file's provenance
record, else the commit that added the file, followed across the rename from benchmarks/, said
so). Removed result files are listed in studies/results/REMOVED.md, which the index links.

Run: .venv/bin/python scripts/study_index.py [--check]
"""

import argparse
import ast
import fnmatch
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BENCH = ROOT / "studies"
RESULTS = BENCH / "results"
INDEX = BENCH / "README.md"
DOCS = ["README.md", *sorted(str(p.relative_to(ROOT)) for p in (ROOT / "docs").glob("*.md")),
        "surrogates/README.md"]

STATISTICAL, FE, TIMING, FIGURE, READER = ("statistical study", "FE", "timing", "figure",
                                           "file reader")
#: Scripts whose kind is not "statistical study".
KINDS = {"compare_tables": FE, "fem_anchors": FE, "fem_convergence": FE,
         "fem_domain_corners": FE, "fem_force_curve": FE, "fem_settings_ab": FE,
         "fem_skfem_migration": FE, "fem_step_control": FE, "fem_tangent_inertia": FE,
         "fem_thickness": FE, "fem_tip_radius": FE,
         "fem_ab_timing": TIMING, "fem_point_cost": TIMING, "fem_timing": TIMING,
         "fit_large": TIMING, "fit_speed": TIMING, "lab_month": TIMING, "physics_speed": TIMING,
         "surrogate_build_timing": TIMING, "surrogate_speed": TIMING,
         "plot_coverage": FIGURE, "plot_fe_setting_bias": FIGURE, "plot_mesh_convergence": FIGURE,
         "bruker_pairs": READER, "bruker_third_party": READER}
SECTIONS = [(STATISTICAL, "Statistical studies"), (FE, "Finite-element studies"),
            (FIGURE, "Figures"), (READER, "File readers against vendors' exports"),
            (TIMING, "Timing benchmarks")]
#: Result files whose name does not start with their script's name.
MADE_BY = {"coverage_designs.txt": "coverage", "fem_ab_session7.txt": "fem_ab_timing",
           "fem_adaptive_vs_table.txt": "fem_settings_ab",
           "fem_anisotropy_order_x028.txt": "fem_force_curve",
           "fem_axial_refinement.txt": "fem_force_curve",
           "fem_corner_half_model.txt": "fem_force_curve",
           "fem_point_time_alone.txt": "fem_point_cost",
           "latent_population_independent_20x.jsonl": "latent_population_cost",
           "latent_population_independent_20x.txt": "latent_population_cost",
           "force_map_bulge_recovery.txt": "bulge_map_recovery"}
#: Result files made by the command-line tool or by FE runs without a study script.
NO_SCRIPT = {"criticize_time_verdict.txt": "`turgorbayes criticize` on the bundled example, "
                                           "timed against the commit before",
             "fem_adaptive_top_row.txt": "FE points with adaptive depth steps at x = 0.52",
             "fem_linear_stiffness_depths.txt": "`turgorbayes surrogate check --at`",
             "surrogate_heldout.json": "`turgorbayes surrogate check` (held-out FE points)",
             "surrogate_heldout.txt": "`turgorbayes surrogate check` (held-out FE points)",
             "surrogate_heldout_2026-11-23.txt": "`turgorbayes surrogate check`, the table "
                                                 "shipped until 2026-11-26",
             "surrogate_heldout_v2.json": "`turgorbayes surrogate check`, the table built "
                                          "2026-11-26 (before shipping)",
             "surrogate_heldout_v2.txt": "`turgorbayes surrogate check`, the table built "
                                         "2026-11-26 (before shipping)",
             "worked_example_seed1.txt": "the README's worked example on raw curves "
                                         "(`simulate --raw-curves`, `curves`, `fit`; seed 1)",
             "fit_vs_wls_command.txt": "paired timing, alternated: `turgorbayes fit` against `fit --model "
                                       "paper_wls` on the bundled example",
             "curves_figures_throughput.txt": "paired timing, alternated: `turgorbayes curves` with "
                                              "its default "
                                              "figures against `--figures none`",
             "curves_figures_reused.txt": "`turgorbayes curves` with every figure, with the "
                                          "default figures and with none, timed pair by pair",
             "bootstrap_time.txt": "`time bash scripts/bootstrap` on a fresh clone",
             "example_outputs.txt": "`scripts/example_outputs.py`: the example commands whose "
                                    "outputs README.md and docs/ quote between example-output "
                                    "markers (`tests/docs/test_example_outputs.py`)",
             "test_suite_time.txt": "`.ci/run` on a fresh clone (the suite's time)",
             "test_suite_time_release.txt": "`.ci/run` on a fresh clone of the release "
                                            "candidate (the suite's time)",
             "test_suite_time_faster_criticism.txt": "`.ci/run` on fresh clones before and "
                                                     "after the faster criticism",
             "test_suite_time_house.txt": "`.ci/run` on fresh clones, before and after the "
                                          "candidates' mode restarts, and the fast tier",
             "misfit_band_null.jsonl": "a script run from standard input (its provenance's "
                                       "argv is `-`): the misfit band on null data",
             "misfit_band_open_world.jsonl": "a script run from standard input (argv `-`): "
                                             "the misfit band on the open world's data",
             "misfit_band_summary.txt": "a script run from standard input (argv `-`): the "
                                        "misfit band's summary",
             "one_engine_outputs.txt": "`turgorbayes fit` and `criticize` on the bundled "
                                       "example, before and after the one posterior engine"}
#: The list of removed result files, with the commit that last had each (not a result).
REMOVED = RESULTS / "REMOVED.md"

def removed_count():
    """How many result files REMOVED.md lists (one table row each)."""
    return len(re.findall(r"^\| `[^`]+` \|", REMOVED.read_text(), re.M))


def scripts():
    return sorted(p.stem for p in BENCH.glob("*.py"))


def script_of(name, names):
    """The study script that made result file ``name`` (None: made without one)."""
    if name in NO_SCRIPT:
        return None
    if name in MADE_BY:
        return MADE_BY[name]
    stem = name.rsplit(".", 1)[0]
    match = [s for s in names if stem == s or stem.startswith(s + "_")]
    return max(match, key=len) if match else None


def _git(*args):
    return subprocess.run(["git", "-C", str(ROOT), *args], capture_output=True, text=True,
                          check=True).stdout.strip()


def produced_at(path):
    """``commit X`` from the file's provenance record, else ``added in X`` (git)."""
    sys.path.insert(0, str(ROOT))
    from turgorbayes.provenance import read_header

    record = read_header(path)
    if record and record.get("commit"):
        return f"commit {record['commit'][:7]}" + (" (dirty)" if record.get("dirty") else "")
    added = _git("log", "--follow", "--diff-filter=A", "--format=%h", "--", str(path))
    return f"added in {added.splitlines()[-1]}"


def measures(script):
    doc = ast.get_docstring(ast.parse((BENCH / f"{script}.py").read_text())) or ""
    return doc.split("\n\n")[0].replace("\n", " ").replace("|", "/")


def slug(heading):
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


#: A citation of a result file, as tests/test_studies.py reads one: ``studies/results/NAME``
#: with ``{a,b}`` alternatives and ``*`` globs (``benchmarks/`` in the CHANGELOG's older entries).
_CITED = re.compile(r"(?:studies|benchmarks)/results/((?:[\w.*\-]|\{[\w.,*\-]*\})+)")


def expand(pattern):
    """``a{,_v2}.txt`` -> ``["a.txt", "a_v2.txt"]``."""
    m = re.search(r"\{([^{}]*)\}", pattern)
    if not m:
        return [pattern]
    return [x for alt in m.group(1).split(",")
            for x in expand(pattern[:m.start()] + alt + pattern[m.end():])]


def names(line, words):
    """Whether ``line`` names any of ``words``, literally or by a citation's glob."""
    cited = [e.rstrip(".,") for tok in _CITED.findall(line) for e in expand(tok)]
    return any(w in line or any(fnmatch.fnmatch(w, c) for c in cited) for w in words)


def citing_sections(words):
    """``[(doc, heading)]`` of the README/docs sections that name any of ``words``."""
    found = []
    for doc in DOCS:
        heading = ""
        for line in (ROOT / doc).read_text().splitlines():
            if line.startswith("#"):
                heading = line.lstrip("#").strip()
            elif names(line, words) and (doc, heading) not in found:
                found.append((doc, heading))
    return found


def claim_links(words):
    links = [f"[{doc}: {h or 'top'}](../{doc}#{slug(h)})" if h else f"[{doc}](../{doc})"
             for doc, h in citing_sections(words)]
    return "<br>".join(links) or "none cited"


def result_cell(files):
    return "<br>".join(f"`{f}` ({produced_at(RESULTS / f)})" for f in files) or "prints only"


def rows(kind, names, by_script):
    out = []
    for s in names:
        if KINDS.get(s, STATISTICAL) != kind:
            continue
        files = by_script.get(s, [])
        words = [f"{s}.py", *files]
        out.append(f"| [{s}.py]({s}.py) | {kind} | {measures(s)} | {claim_links(words)} | "
                   f"{result_cell(files)} |")
    return out


HEAD = """# Studies

Each script here is a study: run by hand for its numbers, it prints or writes its result and
records how: every result it writes carries `turgorbayes.provenance.run_record` (commit,
uncommitted changes, arguments, date, machine, Python, package version) as a
`# provenance: {...}` first line of text output or a `"provenance"` key of JSON and of each
JSON line. Results written before this record existed say which commit added them instead.
No study imports another; what two studies share is a package function. Timing benchmarks
(their own section) measure speed, the rest measure accuracy, calibration or power.

The test suite runs every study with `--smoke` (`tests/test_studies.py`,
`test_every_study_runs_in_smoke_mode`): each step at the smallest size, into a temporary
folder, so no study rots between the runs that produce its numbers. A smoke run must exit 0
and write no empty file; a study whose data are absent (the vendors' exports, an environment
variable) says why and exits 0. A smoke run's numbers mean nothing: `--smoke` refuses `--update`.
Each runs as `python SCRIPT --smoke` would (as `__main__`, its folder first on `sys.path`, the
repository's root as cwd and `PYTHONPATH`), in a process forked from a server that has
numpy, scipy, matplotlib, ArviZ, scikit-fem and the package imported: a study pays for its own
work, not for the imports again.

A study that writes result files writes them into `studies/output/` (git-ignored; another
folder with `--output-dir DIR`) and into the tracked `studies/results/` only when run with
`--update`, so a re-run never rewrites a quoted result silently
(`turgorbayes.provenance.add_output_options` and `study_path`, one place for every study).

`studies/results/` keeps only the results that README.md, docs/, surrogates/README.md or
CHANGELOG.md cite, and those `scripts/fill_mesh_convergence.py` reads; the others are listed,
with a recipe to restore each from git, in `results/REMOVED.md`. Package and
test code read no result: the tests compare with copies in `tests/data/study_results/`.

This file is written by `scripts/study_index.py` (run it after adding a study or a result);
`tests/test_studies.py` fails if a script is missing here, if a study imports another, if a
cited result file is missing, if a result file is cited nowhere, or if package or test code
opens a result file.

Package data filled from results: `turgorbayes/surrogate/_mesh_points.py` (the measured points
of `turgorbayes.surrogate.mesh_convergence`) is written by `scripts/fill_mesh_convergence.py`
from `fem_convergence_tip_mesh.txt`, `fem_domain_corners_fine.txt` and `fem_tip_radius.jsonl`.
"""

TABLE = ["| script | kind | what it measures | claim it backs | result files (produced at) |",
         "|---|---|---|---|---|"]


def render():
    names = scripts()
    files = sorted(p.name for p in RESULTS.iterdir() if p.is_file() and p != REMOVED)
    by_script, loose = {}, []
    for f in files:
        s = script_of(f, names)
        (by_script.setdefault(s, []) if s else loose).append(f)
    lines = [HEAD]
    for kind, title in SECTIONS:
        lines += [f"## {title}", "", *TABLE, *rows(kind, names, by_script), ""]
    lines += ["## Results made without a study script", "",
              "| result file | made by | claim it backs | produced at |", "|---|---|---|---|"]
    lines += [f"| `{f}` | {NO_SCRIPT.get(f, 'unknown')} | {claim_links([f])} | "
              f"{produced_at(RESULTS / f)} |" for f in loose]
    lines += ["", "## Removed", "",
              f"{removed_count()} result files were removed (cited nowhere, or superseded): "
              "`results/REMOVED.md` lists each with the commit that last "
              "had it and the `git show` that restores it."]
    counts = {k: sum(KINDS.get(s, STATISTICAL) == k for s in names) for k, _ in SECTIONS}
    lines += ["", f"{len(names)} scripts (" + ", ".join(f"{n} {k}" for k, n in counts.items())
              + f"), {len(files)} result files, {removed_count()} removed.", ""]
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="exit 1 if the index is out of date")
    args = ap.parse_args(argv)
    text = render()
    if args.check:
        same = INDEX.read_text() == text
        print("studies/README.md " + ("up to date" if same else "is out of date"))
        return 0 if same else 1
    INDEX.write_text(text)
    print(f"wrote {INDEX.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
