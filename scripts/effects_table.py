"""Write the effects table of docs/effects.md ("The effects") from the registry.

Run after adding or changing an effect: ``.venv/bin/python scripts/effects_table.py``. The
table sits between the ``<!-- effects-table`` and ``<!-- /effects-table -->`` markers;
tests/effects/test_effects.py fails when it differs from ``turgorbayes.effects.effects_table()``.
"""

import re
from pathlib import Path

from turgorbayes.effects import effects_table

DOC = Path(__file__).resolve().parents[1] / "docs" / "effects.md"
BLOCK = re.compile(r"(<!-- effects-table[^\n]*-->\n).*?(<!-- /effects-table -->)", re.S)


def main():
    text = DOC.read_text()
    if not BLOCK.search(text):
        raise SystemExit(f"{DOC}: no <!-- effects-table ... --> block to fill")
    table = "\n".join(effects_table()) + "\n"
    DOC.write_text(BLOCK.sub(lambda m: m.group(1) + table + m.group(2), text))
    print(f"wrote the effects table of {DOC}")


if __name__ == "__main__":
    main()
