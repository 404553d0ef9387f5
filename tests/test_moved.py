"""Old module paths keep working after the move into subpackages, with a DeprecationWarning."""

import importlib
import sys
import warnings

import pytest

from turgorbayes._moved import MOVED


@pytest.mark.parametrize("old", sorted(MOVED))
def test_old_path_is_the_new_module_and_warns(old):
    new = importlib.import_module(MOVED[old])
    sys.modules.pop(old, None)
    with pytest.warns(DeprecationWarning, match=MOVED[old]):
        aliased = importlib.import_module(old)
    # the same module object, so attributes and monkeypatches agree between the two names
    assert aliased is new
    # the alias must not overwrite the real module's identity (its spec keeps the new name)
    assert new.__spec__.name == MOVED[old]


def test_from_import_of_an_old_name_warns_at_the_callers_line():
    import turgorbayes

    sys.modules.pop("turgorbayes.report_fit", None)
    # an earlier import of the old path leaves it as an attribute of the package
    turgorbayes.__dict__.pop("report_fit", None)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        from turgorbayes import report_fit  # noqa: F401
    deprecations = [w for w in caught if issubclass(w.category, DeprecationWarning)]
    assert len(deprecations) == 1
    # the warning points at this file, not into importlib's frames
    assert deprecations[0].filename == __file__


def test_new_paths_import_without_warnings():
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)
        for new in MOVED.values():
            importlib.import_module(new)
