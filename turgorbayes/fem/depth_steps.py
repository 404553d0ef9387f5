"""The indenter's depth steps: the fixed schedule, the cut after a failed step, the adaptive
step size, and the linear stiffness read at the schedule's two small steps (docs/fem.md)."""

import math

import numpy as np

__all__ = ["EASY_ITERATIONS", "MAX_STEP_FRACTION", "REJECT_FACTOR", "adapted_step",
           "depth_schedule", "linear_slope", "next_adaptive_depth", "next_depth",
           "step_correction"]


def depth_schedule(cfg, h_end):
    """Two small steps up to linear_depth, then nominal steps of h_end / n_indent_steps."""
    h_lin = min(cfg.linear_depth, 0.25 * h_end)
    first = [0.5 * h_lin, h_lin]
    n = cfg.n_indent_steps
    rest = [h for h in np.linspace(0.0, h_end, n + 1)[1:] if h > h_lin * 1.0001]
    return first + rest


#: A depth step that converged within this many Newton iterations lets the next one grow 1.5x.
EASY_ITERATIONS = 8


def next_depth(targets, h_done, dh_max):
    """The next depth to solve for: the next scheduled one, or an intermediate depth.

    After a failed step the increment is capped at ``dh_max`` (half the failed increment) and
    only grows back by 1.5x per easily converged step, so a hard stretch of the indentation
    (contact spreading over a new ring of tip elements) is not retried at the full scheduled
    step after every success, which cost one failed Newton solve per scheduled step.
    """
    return min(targets[0], h_done + dh_max)


#: Adaptive depth steps (``CapsuleConfig.step_tolerance > 0``): the largest step, as a
#: fraction of h_end, and the factor above the tolerance at which a step is redone smaller.
MAX_STEP_FRACTION = 0.25
REJECT_FACTOR = 4.0


def step_correction(u_new, guess, u_old):
    """Newton's correction of the predictor relative to the step's increment (max norms)."""
    increment = np.max(np.abs(u_new - u_old))
    return float(np.max(np.abs(u_new - guess)) / increment) if increment > 0 else 0.0


def adapted_step(dh, e, tol):
    """Next depth step from this one's relative correction e: keeps e near tol."""
    factor = 2.0 if e <= 0 else 0.9 * math.sqrt(tol / e)
    return dh * min(2.0, max(0.5, factor))


def next_adaptive_depth(h_end, h_done, dh_adapt, dh_max):
    """Next depth of adaptive steps: ``h_done + dh_adapt``, within a cut ``dh_max`` and h_end,
    stretched to h_end rather than leaving a last step shorter than dh_adapt/4 (unless a failed
    step was cut shorter than that stretch: then cutting would otherwise never end)."""
    h = min(h_end, h_done + dh_max, h_done + dh_adapt)
    if h_end - h < 0.25 * dh_adapt and h_end - h_done <= dh_max:
        h = h_end
    return h


def linear_slope(h, w, F, depths):
    """Slope at 0 of the fit F = k w + c w^2 through the steps at the scheduled ``depths``.

    The depths are the schedule's two small steps (:func:`depth_schedule`), which every run
    reaches exactly. Steps cut shorter after a failed Newton solve come before them and are
    not used: k from ``F(w)`` depends on the depths it is read at (the contact patch under the
    tip grows with depth), so reading it at the first two *recorded* steps, as the shipped
    table's builds did, made it up to 13 % lower wherever the first step had been cut.

    Parameters
    ----------
    h, w, F : ndarray [m], [m], [N]
        Depth, mid-surface deflection under the tip and force at each converged step.
    depths : sequence of float [m]
    """
    idx = [int(np.argmin(np.abs(h - d))) for d in depths]
    if not np.allclose(h[idx], depths, rtol=1e-9, atol=0.0):
        raise RuntimeError(f"the scheduled depths {list(depths)} m are not among the steps")
    A = np.stack([w[idx], w[idx] ** 2], axis=1)
    return float(np.linalg.lstsq(A, F[idx], rcond=None)[0][0])
