"""The marginal likelihood of a fitted model, and the Bayes factor that credits a named cause
for predicting what a description that names no cause only fits (docs/statistics.md, "Naming
a cause the generic description also fits").

Leave-one-out elpd scores each cell's prediction from the others; once the data are many, it
penalizes a model's freedom by about one nat per parameter. The generic ``discrepancy``
description, with an extra scatter for each channel (R_c and k_c, bulged and intact cells),
can take on any pattern of scatter; a named cause such as ``radius_spread`` predicts one
pattern (extra R_c scatter in every cell, R_c and k_c moving together) from one parameter.
Where the data show that very pattern both fit equally well and LOO cannot tell them apart.
The marginal likelihood ``Z = integral p(y|u) p(u) du`` can: it pays for every direction of
the prior the data did not need (the Occam factor), so the generic description loses the
prior volume of the scatters it fitted, and the named cause keeps its prediction's credit.
"""

import numpy as np

from turgorbayes.inference.engines import K_MAX

__all__ = ["LOG_BF_MIN", "bayes_factor", "log_evidence"]

#: Log Bayes factor a named cause needs over the generic description to be credited with the
#: pattern they both fit (ln 20: "strong" on Kass & Raftery's scale, JASA 90, 773, 1995).
LOG_BF_MIN = float(np.log(20.0))


def log_evidence(post):
    """``ln Z`` of a fitted model: ``{"value", "se", "method"}``.

    From the importance weights (:func:`turgorbayes.inference.engines.importance_log_evidence`)
    when the posterior is an importance-sampled one with Pareto ``k_hat <= K_MAX``; otherwise
    the Laplace approximation at the mode, ``ln p(y, u*) + d/2 ln 2 pi + 1/2 ln det Sigma``
    (``se`` None: its error is not known); None when neither is available.
    """
    diag = post.diagnostics or {}
    if (post.engine == "importance" and "log_evidence" in diag
            and diag.get("k_hat", np.inf) <= K_MAX):
        return {"value": float(diag["log_evidence"]), "se": float(diag["log_evidence_se"]),
                "method": "importance"}
    if post.u_map is None or post.cov is None:
        return None
    lp = float(np.asarray(post.model.log_posterior(np.asarray(post.u_map)[None]))[0])
    sign, logdet = np.linalg.slogdet(np.asarray(post.cov, float))
    if not np.isfinite(lp) or sign <= 0:
        return None
    d = len(post.u_map)
    return {"value": lp + 0.5 * d * np.log(2 * np.pi) + 0.5 * logdet, "se": None,
            "method": "laplace"}


def bayes_factor(named, generic):
    """``ln Z_named - ln Z_generic`` of two fitted models and whether it credits the named one.

    Returns
    -------
    dict or None
        ``log_bf``, its ``se`` (None unless both are importance estimates), the two
        ``methods`` and ``credits`` (``log_bf - 2 se >= LOG_BF_MIN``; a Laplace estimate is
        taken at face value); None when either evidence is unavailable.
    """
    a, b = log_evidence(named), log_evidence(generic)
    if a is None or b is None:
        return None
    log_bf = a["value"] - b["value"]
    se = None if a["se"] is None or b["se"] is None else float(np.hypot(a["se"], b["se"]))
    return {"log_bf": float(log_bf), "se": se, "methods": [a["method"], b["method"]],
            "credits": bool(log_bf - 2 * (se or 0.0) >= LOG_BF_MIN)}
