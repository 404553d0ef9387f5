"""Turn a surrogate build log with progress-bar frames into a readable build record.

``turgorbayes surrogate build`` draws a progress bar on the terminal; a log captured from it
holds every frame, separated by carriage returns. The record keeps every other line (settings,
one line per FE point with its time, warnings, the final "wrote ..." line) in order, and the last
frame as one line ``progress at end: N/M [elapsed<left, rate]`` (its bar drawn out).

Run: .venv/bin/python scripts/clean_build_log.py surrogates/*.log [--check]
"""

import argparse
import re
import sys
from pathlib import Path

#: One progress-bar frame: ``LABEL:  NN%|bar| n/N [times, ...]``.
FRAME = re.compile(r"[^\r\n|]*?:\s+\d+%\|[^|]*\|\s*(\d+/\d+ \[[^\]]*\])")


def _segments(text):
    """Pieces of ``text`` between carriage returns and newlines, frames cut out; the last frame."""
    kept, last = [], None
    for segment in re.split(r"\r\n|\r|\n", text):
        for m in FRAME.finditer(segment):
            last = m.group(1)
        rest = FRAME.sub("", segment).rstrip()
        if rest.strip():
            kept.append(rest)
    return kept, last


def clean(text):
    """The build record of a captured build log (unchanged if it has no frames)."""
    if not FRAME.search(text):
        return text
    kept, last = _segments(text)
    end = [f"progress at end: {last}"] if last else []
    return "\n".join(kept + end) + "\n"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("logs", nargs="+", type=Path)
    ap.add_argument("--check", action="store_true", help="exit 1 if a log still has frames")
    args = ap.parse_args(argv)
    stale = [p for p in args.logs if clean(p.read_text()) != p.read_text()]
    if args.check:
        print("\n".join(f"{p}: has progress-bar frames" for p in stale) or "all clean")
        return 1 if stale else 0
    for p in stale:
        p.write_text(clean(p.read_text()))
        print(f"cleaned {p}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
