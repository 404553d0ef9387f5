"""Sphinx configuration of the documentation site (docs/README.md, "Documentation").

The source folder is the repository itself, so that README.md, docs/*.md, the notebook and the
pages they link to are one site whose relative links resolve as they do on GitHub:

    .venv/bin/sphinx-build -W -b html -c docs . build/docs
"""

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from turgorbayes import __version__  # noqa: E402

project = "turgorbayes"
author = "the turgorbayes authors"
copyright = "the turgorbayes authors, BSD-3-Clause"
release = version = __version__

extensions = ["myst_nb", "sphinx.ext.autodoc", "sphinx.ext.autosummary", "numpydoc",
              "sphinx.ext.mathjax"]
root_doc = "docs/index"
include_patterns = ["README.md", "CHANGELOG.md", "docs/*.md", "docs/*.rst", "docs/figures/*",
                    "studies/README.md", "surrogates/README.md", "notebooks/*.ipynb"]
exclude_patterns = [".venv", ".git", "build", "dist", "studies/output", "notebooks/*_outputs",
                    "**/.ipynb_checkpoints"]

# MyST: GitHub's anchors (## Your data -> #your-data), $...$ maths as on GitHub
myst_heading_anchors = 6
myst_enable_extensions = ["dollarmath", "amsmath"]
# the notebook is shown as stored (no outputs): executing it takes minutes (tests/notebooks runs it)
nb_execution_mode = "off"

autodoc_typehints = "none"
autosummary_generate = False
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False

# a fence without a language is a command's output: shown as it is, not coloured as Python
highlight_language = "none"

html_theme = "furo"
html_title = f"turgorbayes {version}"
