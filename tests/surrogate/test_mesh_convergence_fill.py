"""The surrogate package's mesh-convergence points are what scripts/fill_mesh_convergence.py
derives from the committed result files (package data filled by a script, not by hand)."""

import importlib.util
import shutil
from pathlib import Path

import pytest

from turgorbayes.surrogate._mesh_points import MEASURED
from turgorbayes.surrogate.mesh_convergence import MESH_CONVERGENCE

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def fill():
    spec = importlib.util.spec_from_file_location("fill_mesh_convergence",
                                                  ROOT / "scripts" / "fill_mesh_convergence.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_package_points_are_derived_from_the_committed_results(fill):
    assert fill.derive() == MEASURED
    assert fill.TARGET.read_text() == fill.render(fill.derive())
    for section, points in MEASURED.items():
        assert MESH_CONVERGENCE[section]["points"] is points


def test_known_values(fill):
    # fem_convergence_tip_mesh.txt: scale_1.5_tip 2.46943 against scale_3_tip 2.49685 at x = 0.005
    assert MEASURED["surrogate_mesh"][0]["rel_diff_k"] == round(2.46943 / 2.49685 - 1, 3)
    # fem_domain_corners_fine.txt: half-size 5.09722 against 5.12609 at x = 0.001
    assert MEASURED["table_mesh"][0] == {"x": 0.001, "ratio": 1.0, "rel_diff_k": -0.00563,
                                         "rel_diff_k_linear": 0.0126}


def test_a_changed_result_changes_the_points(fill, tmp_path):
    for name in ("fem_convergence_tip_mesh.txt", "fem_domain_corners_fine.txt",
                 "fem_tip_radius.jsonl"):
        shutil.copy(fill.RESULTS / name, tmp_path / name)
    path = tmp_path / "fem_convergence_tip_mesh.txt"
    path.write_text(path.read_text().replace("k/PR=2.46943", "k/PR=2.40000"))
    changed = fill.derive(tmp_path)
    assert changed["surrogate_mesh"][0]["rel_diff_k"] == round(2.4 / 2.49685 - 1, 4)
    assert changed != MEASURED and changed["table_mesh"] == MEASURED["table_mesh"]
