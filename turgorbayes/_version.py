"""The package's version: the one place it is written.

pyproject.toml reads it (``[tool.setuptools.dynamic]``) for the wheel's and the sdist's
metadata, and ``turgorbayes.__version__`` imports it, so an editable install reports the source
tree's version even before it is reinstalled. The top section of CHANGELOG.md is headed by the
same version (``tests/test_release.py``). A ``.devN`` suffix marks work towards that release;
releasing drops it here and in the heading.
"""

__version__ = "0.3.0.dev0"
