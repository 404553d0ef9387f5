"""The studies in studies/: every study runs in smoke mode, no study imports another, every
cited result exists and every result is cited, every script is in the index, no package or
test code reads the results (the lab notebook), and the surrogate build records are readable."""

import ast
import fnmatch
import hashlib
import importlib.util
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
BENCH = ROOT / "studies"
RESULTS = BENCH / "results"
#: The pages whose citations keep a result file in the tree (studies/results/REMOVED.md).
CITING = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md")), ROOT / "surrogates" / "README.md",
          ROOT / "CHANGELOG.md"]
#: Pages that name the folder by its name since the rename (the CHANGELOG's older entries keep
#: ``benchmarks/``, the folder's name when they were written).
CURRENT = CITING[:-1]
#: Result files scripts/fill_mesh_convergence.py reads (kept uncited: package data comes from them).
_READ_BY_SCRIPT = re.compile(r'results / "([\w.\-]+)"')

#: A citation of a result file: ``results/NAME`` with ``{a,b}`` alternatives and ``*`` globs
#: (``benchmarks/results/NAME`` in the CHANGELOG's entries before the rename).
_CITED = re.compile(r"(?:studies|benchmarks)/results/((?:[\w.*\-]|\{[\w.,*\-]*\})+)")


def study_names():
    return sorted(p.stem for p in BENCH.glob("*.py"))


def imported_modules(source):
    """Top-level names of every module ``source`` imports (also inside functions)."""
    names = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            names |= {a.name.split(".")[0] for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            names.add("." if node.level else node.module.split(".")[0])
    return names


def sibling_imports(path, studies):
    """The sibling studies (or the ``studies`` folder as a package, or a relative import) that
    ``path`` imports."""
    found = imported_modules(path.read_text())
    return sorted(found & (set(studies) | {"studies", "."}))


def expand(pattern):
    m = re.search(r"\{([^{}]*)\}", pattern)
    if not m:
        return [pattern]
    return [x for alt in m.group(1).split(",")
            for x in expand(pattern[:m.start()] + alt + pattern[m.end():])]


def cited_results(text):
    """The result-file names (or globs) ``text`` cites."""
    return {e.rstrip(".,") for tok in _CITED.findall(text) for e in expand(tok)}


def missing_citations(texts, present):
    """``(source, citation)`` of citations that match no file in ``present``."""
    return sorted((src, c) for src, text in texts.items() for c in cited_results(text)
                  if not fnmatch.filter(present, c))


def indexed_scripts(index_text):
    return set(re.findall(r"^\| \[(\w+)\.py\]\(\1\.py\)", index_text, re.M))


def test_no_study_imports_another():
    studies = study_names()
    offenders = {p.name: sibling_imports(p, studies) for p in BENCH.glob("*.py")}
    assert {k: v for k, v in offenders.items() if v} == {}


def test_the_import_check_sees_a_sibling_import(tmp_path):
    path = tmp_path / "study.py"
    path.write_text("import numpy\n\ndef f():\n    from latent_population_cost import TRUTH\n")
    assert sibling_imports(path, ["latent_population_cost", "study"]) == ["latent_population_cost"]
    path.write_text("from . import coverage\nfrom studies.sbc import run\n")
    assert sibling_imports(path, ["coverage"]) == [".", "studies"]


def result_files():
    """The result files in the tree (REMOVED.md, the list of those taken out, aside)."""
    return sorted(p.name for p in RESULTS.iterdir() if p.suffix != ".md")


def test_every_result_cited_in_readme_and_docs_exists():
    texts = {str(p.relative_to(ROOT)): p.read_text() for p in CITING}
    assert missing_citations(texts, result_files()) == []


def uncited(present, texts, needed=()):
    """The files of ``present`` that no text cites and no script needs."""
    patterns = {c for text in texts for c in cited_results(text)} | set(needed)
    return sorted(f for f in present if not any(fnmatch.fnmatch(f, c) for c in patterns))


def test_the_tree_keeps_only_cited_results():
    # reference: the rule of studies/results/REMOVED.md: a result stays if a page cites it or
    # scripts/fill_mesh_convergence.py reads it; git keeps the others
    needed = _READ_BY_SCRIPT.findall((ROOT / "scripts" / "fill_mesh_convergence.py").read_text())
    assert len(needed) == 3  # fem_convergence_tip_mesh.txt, fem_domain_corners_fine.txt, tip radius
    assert uncited(result_files(), [p.read_text() for p in CITING], needed) == []


def test_the_uncited_check_sees_globs_alternatives_and_scripts_inputs():
    # reference: hand-made names; only d.txt is neither cited nor read
    text = "`studies/results/a_*.txt`, `benchmarks/results/b.{txt,json}`"
    present = ["a_1.txt", "b.txt", "b.json", "c.txt", "d.txt"]
    assert uncited(present, [text], ["c.txt"]) == ["d.txt"]


def test_no_current_page_names_the_old_folder():
    # reference: the rename (CHANGELOG.md): only the CHANGELOG's older entries say benchmarks/
    assert [str(p.relative_to(ROOT)) for p in CURRENT if "benchmarks/" in p.read_text()] == []


def _removed_rows():
    """``(name, commit, folder)`` of each row of studies/results/REMOVED.md."""
    text = (RESULTS / "REMOVED.md").read_text()
    return re.findall(r"^\| `([\w.\-]+)` \|.*`git show (\w+):(\w+)/results/\1 > ", text, re.M)


def test_removed_results_are_gone_and_their_recipes_name_a_commit_that_has_them():
    # reference: git itself (cat-file -e COMMIT:PATH); the commits are this repository's history
    rows = _removed_rows()
    assert len(rows) == 28  # 21 at the rename (4 restored, cited by the docs since), 11 before
    assert {name for name, _, _ in rows} & set(result_files()) == set()
    shallow = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--is-shallow-repository"],
                             capture_output=True, text=True)
    if shallow.returncode or shallow.stdout.strip() != "false":
        pytest.skip("not a git checkout with its whole history: the recipes need it")
    missing = [f"{c}:{folder}/results/{name}" for name, c, folder in rows
               if subprocess.run(["git", "-C", str(ROOT), "cat-file", "-e",
                                  f"{c}:{folder}/results/{name}"], capture_output=True).returncode]
    assert missing == []


def test_the_citation_check_expands_and_reports():
    text = ("see `studies/results/a{,_v2}.{txt,jsonl}` and studies/results/b_*.txt, "
            "studies/results/c.txt.")
    assert cited_results(text) == {"a.txt", "a.jsonl", "a_v2.txt", "a_v2.jsonl", "b_*.txt",
                                   "c.txt"}
    present = ["a.txt", "a.jsonl", "a_v2.txt", "b_1.txt", "c.txt"]
    assert missing_citations({"doc": text}, present) == [("doc", "a_v2.jsonl")]


def test_every_study_is_in_the_index():
    indexed = indexed_scripts((BENCH / "README.md").read_text())
    assert set(study_names()) - indexed == set()
    assert indexed - set(study_names()) == set()  # no row for a script that is gone


def test_the_index_check_reads_table_rows_only():
    text = "| [a.py](a.py) | timing |\nsee [b.py](b.py)\n| [c.py](c.py) | FE |\n"
    assert indexed_scripts(text) == {"a", "c"}


#: A path into the results folder written in one string (``"studies/results/x.txt"``).
_RESULTS_STRING = re.compile(r"(?:studies|benchmarks)[/\\]results")
#: Package and test code allowed to name the results folder, and how: provenance.py defines it as
#: the destination of ``--update`` (writes, never reads); test_provenance.py checks that
#: destination and that git tracks it (opens no result file).
_MAY_NAME_RESULTS = {"turgorbayes/provenance.py": {"path part", "STUDY_RESULTS"},
                     "tests/test_provenance.py": {"STUDY_RESULTS"}}


def _string(node):
    return node.value if isinstance(node, ast.Constant) and isinstance(node.value, str) else None


def _path_parts(tree):
    """The string constants used as path parts: operands of ``/`` and arguments of a call."""
    for node in ast.walk(tree):
        if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Div):
            yield from (n for n in (node.left, node.right) if _string(n) is not None)
        elif isinstance(node, ast.Call):
            yield from (n for n in node.args if _string(n) is not None)


def _documentation(tree):
    """The string constants that are statements of their own (docstrings): they open nothing."""
    return {id(node.value) for node in ast.walk(tree)
            if isinstance(node, ast.Expr) and _string(node.value) is not None}


def results_references(source):
    """``(line, kind)`` of every way ``source`` could open a file of the studies' results.

    Kinds: ``"string"`` (a string naming ``studies/results`` or ``benchmarks/results``,
    docstrings and comments aside, so they may cite a result), ``"path part"`` (``"results"``
    as a path part, ``/ "results"`` or ``Path(..., "results")``, in a file that also uses
    ``"studies"`` or ``"benchmarks"`` so) and ``"STUDY_RESULTS"`` (the provenance constant).
    """
    tree = ast.parse(source)
    docs, found = _documentation(tree), set()
    for node in ast.walk(tree):
        text = _string(node)
        if text is not None and id(node) not in docs and _RESULTS_STRING.search(text):
            found.add((node.lineno, "string"))
        name = (node.id if isinstance(node, ast.Name) else node.attr
                if isinstance(node, ast.Attribute) else node.name
                if isinstance(node, ast.alias) else None)
        if name == "STUDY_RESULTS":
            found.add((getattr(node, "lineno", 0), "STUDY_RESULTS"))
    parts = list(_path_parts(tree))
    if any(_string(n) in ("studies", "benchmarks") for n in parts):
        found |= {(n.lineno, "path part") for n in parts if _string(n) == "results"}
    return sorted(found)


def test_no_package_or_test_code_reads_the_studies_results():
    # reference: the rule itself: tests read copies in tests/data/study_results (whose README
    # names the study and commit of each), the package reads nothing there
    files = [p for folder in ("turgorbayes", "tests") for p in sorted((ROOT / folder).rglob("*.py"))
             if p != Path(__file__).resolve()]
    assert len(files) > 100  # the whole package and suite were scanned
    offenders = {}
    for path in files:
        name = str(path.relative_to(ROOT))
        refs = [r for r in results_references(path.read_text(encoding="utf-8"))
                if r[1] not in _MAY_NAME_RESULTS.get(name, set())]
        if refs:
            offenders[name] = refs
    assert offenders == {}


def test_the_results_scan_sees_each_way_of_opening_and_spares_citations():
    # reference: hand-made sources, one construction per line; their line numbers by reading
    opening = ('from pathlib import Path\n'
               'from turgorbayes.provenance import STUDY_RESULTS\n'
               'a = open("studies/results/x.txt")\n'
               'b = Path(__file__).parents[1] / "studies" / "results" / "x.txt"\n'
               'c = Path("benchmarks", "results", "x.txt")\n'
               'd = f"benchmarks/results/{a}"\n'
               'e = STUDY_RESULTS / "x.txt"\n')
    assert results_references(opening) == [
        (2, "STUDY_RESULTS"), (3, "string"), (4, "path part"), (5, "path part"), (6, "string"),
        (7, "STUDY_RESULTS")]
    citing = ('"""Measured in studies/results/x.txt."""\n'
              '# see studies/results/x.txt\n'
              'def f():\n'
              '    """As in benchmarks/results/y.txt."""\n'
              '    return Path("out") / "results"  # another folder of that name\n')
    assert results_references(citing) == []


#: Seconds a study may take with ``--smoke`` (its every step at the smallest size).
SMOKE_TIMEOUT = 120
#: What every study imports, loaded once by the fork server that starts each smoke run, so that
#: a run pays for its own work and not for the imports again.
PRELOAD = ["numpy", "scipy.stats", "scipy.optimize", "scipy.interpolate", "matplotlib",
           "matplotlib.pyplot", "arviz", "xarray", "skfem", "emcee", "turgorbayes.workflows.fit",
           "turgorbayes.workflows.criticize", "turgorbayes.curves", "turgorbayes.fem"]


def _smoke_child(script, out_dir, log):
    """In the forked child: what ``python SCRIPT --smoke --output-dir OUT_DIR`` would do, with
    the repository's root as cwd and ``PYTHONPATH``, stdout and stderr into ``log``."""
    import runpy

    fd = os.open(log, os.O_WRONLY | os.O_CREAT | os.O_TRUNC)
    for stream in (sys.stdout, sys.stderr):
        stream.flush()
    os.dup2(fd, 1)
    os.dup2(fd, 2)
    os.chdir(ROOT)
    os.environ["PYTHONPATH"] = str(ROOT)
    sys.path[:0] = [str(Path(script).parent), str(ROOT)]
    sys.argv = [str(script), "--smoke", "--output-dir", str(out_dir)]
    try:
        runpy.run_path(str(script), run_name="__main__")
    finally:
        sys.stdout.flush()
        sys.stderr.flush()


def _smoke_context():
    import multiprocessing

    context = multiprocessing.get_context("forkserver")
    context.set_forkserver_preload(PRELOAD)
    return context


def run_smoke(script, out_dir, timeout=SMOKE_TIMEOUT):
    """Run ``python SCRIPT --smoke --output-dir OUT_DIR`` as the suite does; what went wrong.

    In a process forked from a server that has the common modules imported (``PRELOAD``), as
    ``python SCRIPT`` would run it: ``__name__ == "__main__"``, the script's folder first on
    ``sys.path``, the repository's root as cwd and ``PYTHONPATH`` (the package as checked out).
    A study whose data are absent must say so and exit 0 itself.

    Returns
    -------
    list of str
        Empty when it exited 0 within ``timeout`` seconds and wrote no empty file into
        ``out_dir``; else one line per fault (a failure's output tail included).
    """
    out_dir = Path(out_dir)
    log = out_dir.parent / f"{out_dir.name}.log"
    run = _smoke_context().Process(target=_smoke_child, args=(str(script), str(out_dir), str(log)))
    run.start()
    run.join(timeout)
    if run.exitcode is None:
        run.kill()
        run.join()
        return [f"{Path(script).name}: no exit within {timeout} s"]
    output = log.read_text(errors="replace") if log.exists() else ""
    faults = [f"{Path(script).name} exited {run.exitcode}:\n{output[-3000:]}"
              ] if run.exitcode else []
    written = sorted(p for p in out_dir.rglob("*") if p.is_file()) if out_dir.is_dir() else []
    return faults + [f"{Path(script).name} wrote an empty {p.relative_to(out_dir)}"
                     for p in written if p.stat().st_size == 0]


#: Studies whose smoke run takes over ~15 s (the ``slow`` marker's bound, pyproject.toml): each
#: runs the command line end to end several times (measured on -n 2 at 971c270: fit_large
#: 28 s, raw_curves_end_to_end 25 s, criticize_workers 16 s, fem_tip_radius 15 s). They run in
#: the full suite (CI), not in the fast tier.
SLOW_SMOKE = {"fit_large", "raw_curves_end_to_end", "criticize_workers", "fem_tip_radius"}


def _smoke_params():
    return [pytest.param(n, marks=pytest.mark.slow) if n in SLOW_SMOKE else n
            for n in study_names()]


@pytest.mark.parametrize("name", _smoke_params())
def test_every_study_runs_in_smoke_mode(name, tmp_path):
    # reference: the study itself at its smallest size: it must run to the end (exit 0) and
    # every file it writes must hold something
    assert run_smoke(BENCH / f"{name}.py", tmp_path / "out") == []


def _throwaway(tmp_path, body):
    script = tmp_path / "study.py"
    script.write_text("import os, sys, time\nfrom pathlib import Path\n"
                      "out = Path(sys.argv[sys.argv.index('--output-dir') + 1])\n" + body)
    return script


def test_the_smoke_harness_passes_a_study_that_runs_and_says_how_it_was_run(tmp_path):
    # reference: the throwaway study writes what it was given; the harness's contract (the
    # brief of tests/test_studies.py: --smoke, --output-dir, the root as cwd and PYTHONPATH)
    script = _throwaway(tmp_path, "out.mkdir(parents=True)\n(out / 'seen.txt').write_text("
                                  "repr([sys.argv[1:], os.getcwd(), os.environ['PYTHONPATH'], "
                                  "sys.executable, __name__, sys.path[0]]))\n")
    out = tmp_path / "out"
    assert run_smoke(script, out) == []
    argv, cwd, pythonpath, python, name, path0 = ast.literal_eval((out / "seen.txt").read_text())
    assert argv == ["--smoke", "--output-dir", str(out)]
    assert cwd == str(ROOT) and pythonpath == str(ROOT) and python == sys.executable
    assert name == "__main__" and path0 == str(script.parent)


def test_the_smoke_harness_reports_a_failure_with_its_stderr(tmp_path):
    # reference: a throwaway study that exits 1 after a message on stderr
    script = _throwaway(tmp_path, "print('no such file: data.csv', file=sys.stderr)\nsys.exit(1)\n")
    (fault,) = run_smoke(script, tmp_path / "out")
    assert fault.startswith("study.py exited 1:") and "no such file: data.csv" in fault


def test_the_smoke_harness_reports_an_empty_file_and_a_hang(tmp_path):
    # reference: throwaway studies: one writes a result and an empty file, one never ends
    empty = _throwaway(tmp_path, "(out / 'sub').mkdir(parents=True)\n"
                                 "(out / 'full.txt').write_text('1')\n(out / 'sub' / 'e.txt').touch()\n")
    assert run_smoke(empty, tmp_path / "out") == [f"study.py wrote an empty {Path('sub', 'e.txt')}"]
    hang = _throwaway(tmp_path, "time.sleep(30)\n")
    assert run_smoke(hang, tmp_path / "out2", timeout=1) == ["study.py: no exit within 1 s"]


def _clean_build_log():
    spec = importlib.util.spec_from_file_location("clean_build_log",
                                                  ROOT / "scripts" / "clean_build_log.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.clean


def test_build_logs_have_no_progress_bar_frames():
    logs = sorted((ROOT / "surrogates").glob("*.log"))
    assert logs
    assert [p.name for p in logs if "\r" in p.read_text()] == []


def test_clean_build_log_keeps_the_record_and_drops_the_frames():
    clean = _clean_build_log()
    raw = ("sweep: 2 points, workers=1\n"
           "\rFE points:   0%|          | 0/2 [00:00<?, ?pt/s]"
           "\rFE points:  50%|#####     | 1/2 [00:10<00:10, 10.0s/pt]\r          \n"
           "ok     x=0.1  k/PR=1.0   10.0 s\n"
           "\rFE points: 100%|##########| 2/2 [00:20<00:00, 10.0s/pt]/x.py:1: UserWarning: w\n"
           "ok     x=0.2  k/PR=0.9   10.0 s\nwrote t.nc: 2 points run\n")
    assert clean(raw) == ("sweep: 2 points, workers=1\nok     x=0.1  k/PR=1.0   10.0 s\n"
                          "/x.py:1: UserWarning: w\nok     x=0.2  k/PR=0.9   10.0 s\n"
                          "wrote t.nc: 2 points run\nprogress at end: 2/2 [00:20<00:00, "
                          "10.0s/pt]\n")
    assert clean(clean(raw)) == clean(raw)


def _sha256(path):
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.mark.parametrize("shipped", sorted((ROOT / "turgorbayes" / "data").glob("*.nc")),
                         ids=lambda p: p.name)
def test_no_copy_of_a_shipped_table_in_surrogates(shipped):
    copies = [p.name for p in (ROOT / "surrogates").glob("*.nc")
              if _sha256(p) == _sha256(shipped)]
    assert copies == []
