"""The documentation site builds with warnings as errors (docs/README.md, "Documentation"):
Sphinx on the repository (README, docs/*.md, the API reference from the numpydoc docstrings,
the notebook as stored), into a temporary folder, exactly as the documented command does.

References: the pages the toctrees of docs/index.md list, and the public face's names
(``turgorbayes.__all__``), which the API page must document.
"""

import re
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("sphinx")
pytest.importorskip("myst_nb")
pytest.importorskip("numpydoc")

import turgorbayes  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]


def documented_command():
    """The build command docs/README.md gives (the fenced line after its "Documentation")."""
    text = (ROOT / "docs" / "README.md").read_text(encoding="utf-8")
    section = text.split("## Documentation", 1)[1]
    return re.search(r"```bash\n(.*?)\n```", section, re.S).group(1).strip()


def test_the_documented_command_is_a_warnings_as_errors_build():
    cmd = documented_command().split()
    assert cmd[0].endswith("sphinx-build") and "-W" in cmd and cmd[cmd.index("-b") + 1] == "html"
    assert cmd[cmd.index("-c") + 1] == "docs" and cmd[-2] == "."  # conf in docs/, source: the repository


@pytest.mark.slow
def test_the_site_builds_without_a_warning(tmp_path):
    out = tmp_path / "html"
    # the documented command, with the output and the doctree cache in tmp_path (nothing is
    # written into the repository)
    run = subprocess.run([sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html",
                          "-c", str(ROOT / "docs"), "-d", str(tmp_path / "doctrees"), str(ROOT),
                          str(out)], capture_output=True, text=True, timeout=600)
    warnings = [line for line in run.stderr.splitlines() if "WARNING" in line or "ERROR" in line]
    assert run.returncode == 0 and not warnings, "\n".join(warnings) or run.stderr[-3000:]
    # every page of the toctrees was written, the notebook and the landing page included
    index = (ROOT / "docs" / "index.md").read_text(encoding="utf-8")
    listed = re.findall(r"^(/?[\w/]+)$", "\n".join(re.findall(r"```\{toctree\}(.*?)```", index, re.S)),
                        re.M)
    assert len(listed) >= 15, listed
    for name in listed:
        page = out / (name[1:] if name.startswith("/") else f"docs/{name}")
        assert page.with_suffix(".html").is_file(), name
    # the API reference documents the whole public face, from its numpydoc docstrings
    api = (out / "docs" / "api.html").read_text(encoding="utf-8")
    for name in turgorbayes.__all__:
        if name != "__version__":
            assert f'id="turgorbayes.{name}"' in api, name
    assert "Parameters" in api and "Returns" in api
    # README's relative links point into the site (docs/guide.md -> docs/guide.html)
    assert 'href="docs/guide.html#what-you-get"' in (out / "README.html").read_text(encoding="utf-8")
