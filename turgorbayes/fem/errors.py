"""Errors of the finite-element code."""

from turgorbayes.errors import TurgorBayesError

__all__ = ["FEConfigError", "FEConvergenceError"]


class FEConfigError(TurgorBayesError, ValueError):
    """A finite-element setting or an indentation input is out of its allowed range."""


class FEConvergenceError(TurgorBayesError, RuntimeError):
    """Newton's method failed; the attributes say where.

    Parameters
    ----------
    stage : str
        ``"inflation"`` or ``"indentation"`` (or the name of another load sequence).
    step : int
        Load step (0-based) that failed.
    load : float
        Load level reached when it failed (pressure [Pa] or indentation depth [m]).
    residual : float
        Relative residual norm of the last iterate.
    detail : str
        What happened (diverged, iteration limit, step below the minimum, singular matrix).
    """

    def __init__(self, stage, step, load, residual, detail):
        self.stage, self.step, self.load = stage, step, load
        self.residual, self.detail = residual, detail
        super().__init__(
            f"Newton failed in {stage} step {step} at load {load:.6g} "
            f"(relative residual {residual:.3g}): {detail}"
        )
