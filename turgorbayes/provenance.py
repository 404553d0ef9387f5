"""Provenance of a run: the commit of the source tree, its uncommitted changes, the arguments,
the date, the machine and the package version.

Every study in ``studies/`` writes :func:`run_record` into its result file (a
``# provenance: {...}`` line at the top of text output, a ``"provenance"`` key in JSON and in
each JSON line), so a number quoted from a result file can be traced to the code that made it.
The surrogate builder's table attributes use :func:`git_state` for their git fields.
"""

import hashlib
import json
import platform
import subprocess
import sys
from datetime import UTC, datetime
from pathlib import Path

import turgorbayes

__all__ = ["DEPENDENCIES", "HEADER_PREFIX", "LOCK_FILE", "STUDY_OUTPUT", "STUDY_RESULTS",
           "add_output_options", "dependency_versions", "git_state", "header_line", "read_header",
           "run_record", "source_digest", "study_path", "utc_now"]

#: Start of the provenance line of a text result file.
HEADER_PREFIX = "# provenance: "

#: The source tree the package was imported from (its git checkout, when it is one).
PACKAGE_DIR = Path(__file__).resolve().parent

#: The tracked result files of the studies: written only when a run is given ``--update``.
STUDY_RESULTS = PACKAGE_DIR.parent / "studies" / "results"
#: Where a study writes otherwise (git-ignored), unless given ``--output-dir``.
STUDY_OUTPUT = PACKAGE_DIR.parent / "studies" / "output"

#: The distributions whose versions change our numbers (recorded by every run).
DEPENDENCIES = ("numpy", "scipy", "arviz", "arviz-base", "arviz-stats", "emcee", "scikit-fem",
                "xarray", "matplotlib")
#: The lock of exact versions that scripts/bootstrap installs (in a source checkout).
LOCK_FILE = PACKAGE_DIR.parent / "requirements" / "lock.txt"


def utc_now():
    """Current UTC time, ISO 8601 to the second."""
    return datetime.now(UTC).isoformat(timespec="seconds")


def _git(directory, *args):
    return subprocess.run(["git", "-C", str(directory), *args], capture_output=True, text=True,
                          timeout=30, check=True).stdout


def git_state(directory=PACKAGE_DIR, pathspec=None, untracked=False):
    """Commit checked out at ``directory`` and the uncommitted changes to tracked files.

    Parameters
    ----------
    directory : path-like
        Any directory inside the checkout (default: the package's sources).
    pathspec : path-like, optional
        Only changes under this path count (default: the whole checkout).
    untracked : bool
        Whether untracked files count as changes (default: only tracked files).

    Returns
    -------
    dict or None
        ``{"commit", "top", "changes"}`` (full hash, checkout root, ``git status --porcelain``
        lines), or None when ``directory`` is not in a git checkout or git is missing.
    """
    spec = ["--", str(pathspec)] if pathspec is not None else []
    flag = "--untracked-files=" + ("normal" if untracked else "no")
    try:
        commit = _git(directory, "rev-parse", "HEAD").strip()
        top = Path(_git(directory, "rev-parse", "--show-toplevel").strip())
        changes = _git(directory, "status", "--porcelain", flag, *spec)
    except (OSError, subprocess.SubprocessError):
        return None
    return {"commit": commit, "top": top, "changes": changes.splitlines()}


def source_digest(directory=PACKAGE_DIR):
    """The commit of the package's sources and a sha256 of their uncommitted changes.

    Two runs of the same commit with different edits (tracked or new files under
    ``directory``) get different digests, so a cache keyed by it never hands one code's
    results to another's (:mod:`turgorbayes.cache`).

    Returns
    -------
    str or None
        ``"<commit>"`` or ``"<commit>+<sha256 of the changes>"``; None outside a git checkout
        (an installed release: its version is the record).
    """
    state = git_state(directory, pathspec=directory, untracked=True)
    if state is None:
        return None
    if not state["changes"]:
        return state["commit"]
    digest = hashlib.sha256(_git(directory, "diff", "HEAD", "--", str(directory)).encode())
    for line in sorted(state["changes"]):
        if line.startswith("??"):  # a new file: its name and content
            path = state["top"] / line[3:].strip()
            digest.update(line.encode())
            digest.update(path.read_bytes() if path.is_file() else b"")
    return f"{state['commit']}+{digest.hexdigest()}"


def dependency_versions(lock=LOCK_FILE):
    """Installed versions of :data:`DEPENDENCIES` and the sha256 of the lock file.

    Returns
    -------
    dict
        ``{"numpy": "2.5.5", ..., "lock_sha256": hex or None}``: None for a distribution that
        is not installed, and for the lock outside a source checkout (an installed wheel has
        none; its versions above are then the record).
    """
    from importlib.metadata import PackageNotFoundError, version

    out = {}
    for name in DEPENDENCIES:
        try:
            out[name] = version(name)
        except PackageNotFoundError:
            out[name] = None
    lock = Path(lock)
    out["lock_sha256"] = hashlib.sha256(lock.read_bytes()).hexdigest() if lock.is_file() else None
    return out


def _machine():
    return f"{platform.node()} {platform.machine()} {platform.processor()}".strip()


def run_record(argv=None, directory=PACKAGE_DIR):
    """Commit, arguments, date, machine and version of this run.

    Parameters
    ----------
    argv : sequence of str, optional
        The command line (default: ``sys.argv``).
    directory : path-like
        Where the code's checkout is (default: the package's sources).

    Returns
    -------
    dict
        ``commit`` (None outside a git checkout), ``dirty`` (tracked files changed since the
        commit; None outside a checkout), ``argv``, ``date`` (UTC), ``machine``, ``python``,
        ``version`` (of turgorbayes), ``dependencies`` (:func:`dependency_versions`).
    """
    state = git_state(directory)
    return {"commit": state and state["commit"], "dirty": state and bool(state["changes"]),
            "argv": list(sys.argv if argv is None else argv), "date": utc_now(),
            "machine": _machine(), "python": platform.python_version(),
            "version": turgorbayes.__version__, "dependencies": dependency_versions()}


def header_line(record=None):
    """The provenance line of a text result file: ``# provenance: {json}``."""
    return HEADER_PREFIX + json.dumps(run_record() if record is None else record)


def read_header(path):
    """The provenance record of a result file, or None if it has none.

    The first ``# provenance:`` line (any text file, JSON lines printed by a study too);
    ``.json``: the ``"provenance"`` key; ``.jsonl``: also the ``"provenance"`` key of the first
    row that has one.
    """
    path = Path(path)
    with path.open() as f:
        if path.suffix == ".json":
            return json.load(f).get("provenance")
        for line in f:
            if line.startswith(HEADER_PREFIX):
                return json.loads(line[len(HEADER_PREFIX):])
            if path.suffix == ".jsonl" and line.startswith("{"):
                row = json.loads(line)
                if "provenance" in row:
                    return row["provenance"]
    return None


def add_output_options(parser):
    """Add ``--update``, ``--output-dir DIR`` and ``--smoke`` to a study's argument parser.

    A study writes into ``--output-dir`` (default :data:`STUDY_OUTPUT`, git-ignored), so a
    re-run never rewrites the tracked results silently; ``--update`` writes into
    :data:`STUDY_RESULTS` instead, as the quoted results were written. ``--smoke`` runs the
    study's every step at the smallest size (a few seconds; the test suite runs each study so,
    so none rots); its numbers mean nothing, so it cannot be combined with ``--update``.
    """
    parser.add_argument("--update", action="store_true",
                        help=f"write into the tracked results ({STUDY_RESULTS}) instead of "
                             "--output-dir")
    parser.add_argument("--output-dir", default=str(STUDY_OUTPUT),
                        help="folder of the result files without --update "
                             "(default: %(default)s, git-ignored)")
    parser.add_argument("--smoke", action="store_true",
                        help="run every step at the smallest size, in seconds (the test suite's "
                             "check that the study still runs; its numbers mean nothing)")
    return parser


def study_path(args, name):
    """The result file ``name`` of a study run with ``args`` (:func:`add_output_options`):
    in :data:`STUDY_RESULTS` with ``--update``, else in ``--output-dir`` (created).

    Parameters
    ----------
    args : argparse.Namespace
    name : str
        File name inside the folder (``curve_recovery.txt``).

    Returns
    -------
    pathlib.Path
    """
    if args.update and getattr(args, "smoke", False):
        raise SystemExit("--smoke and --update together: a smoke run's numbers mean nothing, "
                         "so they never replace a tracked result")
    folder = STUDY_RESULTS if args.update else Path(args.output_dir)
    folder.mkdir(parents=True, exist_ok=True)
    return folder / name


class _Tee:
    """A text stream that writes to ``stream`` and, line-buffered, to the file ``path``."""

    def __init__(self, stream, path, mode):
        self.stream, self.file = stream, open(path, mode, buffering=1)

    def write(self, text):
        self.stream.write(text)
        return self.file.write(text)

    def flush(self):
        self.stream.flush()
        self.file.flush()


def tee_stdout(args, name, append=False):
    """Copy everything a study prints from now on into its result file ``name``
    (:func:`study_path`), for studies whose result is what they print.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed with :func:`add_output_options`.
    name : str
        Result file name.
    append : bool
        Append to the file (a study whose documented runs add to one file), else overwrite.

    Returns
    -------
    pathlib.Path
        The file.
    """
    import sys

    path = study_path(args, name)
    sys.stdout = _Tee(sys.stdout, path, "a" if append else "w")
    return path

