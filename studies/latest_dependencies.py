"""The test suite on the newest releases pyproject.toml allows: what moved against the lock.

``scripts/bootstrap --latest`` into a fresh virtual environment (outside the checkout's
``.venv``), then the README's test command there (ruff and pytest). Writes one text file: the
provenance of this run, every distribution whose version differs from
``requirements/lock.txt`` (lock -> latest), the packages the lock does not hold, pytest's
summary line and its failures, if any. The locked versions are what CI runs; this study says
whether the next ``bash scripts/lock`` can be committed as it is (docs/README.md,
"Reproducible installs").

Run: .venv/bin/python studies/latest_dependencies.py [--update] [--venv DIR] [--workers 2]
(about 2 minutes of installing, then the suite: 16-20 minutes on 2 cores)
"""

import argparse
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from turgorbayes.provenance import LOCK_FILE, add_output_options, header_line, study_path  # noqa: E402

#: pytest's last line: "1865 passed, 11 skipped, 2 xfailed in 938.1s".
SUMMARY = re.compile(r"^=*\s*(\d+ (?:passed|failed).*) in [\d.]+s")
#: A smoke run: no install (the running environment stands for the newest releases), ruff on
#: this file and pytest on one small test module.
SMOKE_RUFF, SMOKE_TESTS = ["studies/latest_dependencies.py"], ["tests/test_progress.py"]


def frozen(text):
    """``{normalized name: version}`` of ``pip freeze`` lines (comments and editables skipped)."""
    out = {}
    for line in text.splitlines():
        line = line.strip()
        if not line or line.startswith(("#", "-e")) or "==" not in line:
            continue
        name, version = line.split("==", 1)
        out[re.sub(r"[-_.]+", "-", name).lower()] = version.strip()
    return out


def moved(lock, latest):
    """Lines ``name lock -> latest`` for every version that differs, then the new packages."""
    lines = [f"{n} {lock[n]} -> {latest[n]}" for n in sorted(lock) if n in latest
             and latest[n] != lock[n]]
    lines += [f"{n} (not in the lock) {latest[n]}" for n in sorted(set(latest) - set(lock))]
    lines += [f"{n} {lock[n]} -> (not installed)" for n in sorted(set(lock) - set(latest))]
    return lines


def _run(cmd, **kw):
    print("+", " ".join(map(str, cmd)), flush=True)
    return subprocess.run(cmd, cwd=ROOT, text=True, capture_output=True, check=False, **kw)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--venv", default=None,
                        help="environment folder (default: a temporary one, removed after)")
    parser.add_argument("--workers", default="2", help="pytest-xdist workers (-n)")
    add_output_options(parser)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        venv = Path(args.venv or Path(tmp) / "venv")
        t0 = time.time()
        if args.smoke:
            venv = Path(sys.executable).parents[1]
            print(f"smoke: no install; the running environment {venv} stands for the newest")
        else:
            boot = _run(["bash", "scripts/bootstrap", "--latest"],
                        env={**os.environ, "VENV": str(venv)})
            if boot.returncode:
                raise SystemExit(f"bootstrap --latest failed:\n{boot.stderr[-3000:]}")
        installed = time.time() - t0
        latest = frozen(_run([venv / "bin" / "python", "-m", "pip", "freeze"]).stdout)
        ruff = _run([venv / "bin" / "ruff", "check", *(SMOKE_RUFF if args.smoke else ["."])])
        t1 = time.time()
        tests = _run([venv / "bin" / "python", "-m", "pytest", "-q", "-p", "no:cacheprovider",
                      *(SMOKE_TESTS if args.smoke else ["-n", args.workers])])
        suite = time.time() - t1
    lock = frozen(LOCK_FILE.read_text())
    tail = tests.stdout.strip().splitlines()
    summary = next((m.group(1) for line in reversed(tail) if (m := SUMMARY.match(line))),
                   tail[-1] if tail else "(no output)")
    failures = [line for line in tail if line.startswith(("FAILED", "ERROR"))]
    path = study_path(args, "latest_dependencies.txt")
    with open(path, "w") as f:
        print(header_line(), file=f)
        print(f"installed the newest releases in {installed:.0f} s; the suite ran in {suite:.0f} s "
              f"with -n {args.workers}", file=f)
        print(f"versions that moved against {LOCK_FILE.relative_to(ROOT)} "
              f"({len(moved(lock, latest))}):", file=f)
        for line in moved(lock, latest):
            print(f"  {line}", file=f)
        print(f"ruff check: {'clean' if ruff.returncode == 0 else ruff.stdout.strip()[-2000:]}",
              file=f)
        print(f"RESULT pytest on the newest releases: {summary}", file=f)
        for line in failures:
            print(f"  {line}", file=f)
    print(Path(path).read_text())
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
