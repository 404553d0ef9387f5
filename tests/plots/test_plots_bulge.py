"""The Fig. 2b function draws the bulge model's curve (checked against the model's own closed form)."""

import numpy as np
from numpy.testing import assert_allclose

from turgorbayes.physics import bulge
from turgorbayes.plots.bulge import plot_bulge_response


def test_bulge_figure_curves_and_labels(tmp_path):
    path = tmp_path / "fig2b.png"
    ax = plot_bulge_response(path=path)
    assert path.stat().st_size > 10_000
    assert "h/R_b" in ax.get_xlabel() and "F/(P R_b^2)" in ax.get_ylabel()
    (line,) = ax.get_lines()
    y, f = line.get_data()
    # The paper's Fig. 2b: F/(P R_b^2) = 0.1 at h/R_b ~ 0.27 (docs/physics.md, Bulge model).
    assert_allclose(np.interp(0.1, f, y), 0.2665, atol=2e-3)
    inset = ax.child_axes[0]
    (kline,) = inset.get_lines()
    yk, k = kline.get_data()
    # the inset is the secant stiffness f/(h/R_b), inside the quoted 0.35-0.38 band at h/R_b = 0.2
    assert 0.35 < np.interp(0.2, yk, k) < 0.38
    assert_allclose(k, bulge.reduced_stiffness(yk), rtol=1e-8)
