"""Prototype: the bulged cells' population sampled with the wall parameters (integrated out by
Laplace's method) instead of plugged in, measured against the plug-in on the same data sets.

Why: on the hard-edged (log-uniform) design the plug-in population (an Efron deconvolution of
the bulge estimates, :mod:`turgorbayes.inference.population`) moves gamma's z-score by 0.34
posterior sds RMS at 10x the paper's cells and 0.69 at 20x (``latent_population_cost.py``),
uncertainty that the posterior does not carry. The population's spline coefficients ``beta``
(``df - 1`` of them: the direction that only shifts ``ln g`` by a constant is removed) are
integrated out here for each wall parameter set ``theta``:

    ln p(data | theta) = ln int p(bulged data | theta, beta) pi(beta) d beta + intact cells
                       ~ l(beta*) + (d/2) ln 2 pi - (1/2) ln det(-H(beta*))

with ``l(beta) = sum_i ln sum_j exp(h_ij + s_ij . beta) - n ln Z(beta) - c0 ||beta||`` the
bulged cells' log-likelihood at the latent quadrature nodes ``x_ij`` (the package's adaptive
Gauss-Hermite nodes, placed with the plug-in population as the proposal: ``h_ij`` is the log
integrand without the plug-in's ``ln g``), ``s_ij = B(x_ij) P`` the population's spline basis at
the nodes, ``Z`` its normalizer on the population grid and ``c0 ||beta||`` Efron's penalty as
the prior. ``beta*`` by damped Newton from the plug-in's coefficients, per walker.

``--check``: the Laplace marginal against importance sampling over beta (1e5 draws from a
Student-t around beta*) at a few parameter sets of one data set. ``--n``: data sets fitted with
the plug-in and with the integrated population by the criticism's posterior engine (Laplace +
PSIS importance sampling); coverage of the truth and z-scores are printed and appended to
``--out`` (JSON lines).

Run: .venv/bin/python studies/hierarchical_population.py --check --scale 10
     .venv/bin/python studies/hierarchical_population.py --scale 10 --n 20 \
         --out studies/results/hierarchical_population.jsonl
"""

import argparse
import json
import time

import numpy as np
from scipy import interpolate, special, stats

from turgorbayes import criticism, effects, provenance, surrogate
from turgorbayes.inference import models, population
from turgorbayes.inference.likelihood import CellLikelihood
from turgorbayes.physics.parameters import BASELINE
from turgorbayes.simulation import cells as synthetic
from turgorbayes.workflows import sbc
from turgorbayes.workflows.criticize import CriticismSettings

PARAMS = BASELINE  # gamma, E0t, R0, P_phys
TRUTH = synthetic.TRUTHS["paper"]

#: A smoke run: the check with 1000 draws, then one data set of the paper's size fitted both
#: ways with few draws and short chains.
SMOKE_SETTINGS = CriticismSettings(n_draws=200, ess_min=20, n_ensembles=2, tol=5, check_every=20,
                                   max_steps=40)
SMOKE_CHECK_DRAWS = 1000

#: Newton iterations for beta* (damped: a step is halved until l increases).
NEWTON = 8
#: Walkers per batch (bounds the (W, n, K, d) basis array).
CHUNK = 64


def _complement(df):
    """Orthonormal ``(df, df - 1)`` basis of the vectors orthogonal to ``(1, ..., 1)``."""
    q, _ = np.linalg.qr(np.eye(df) - 1.0 / df)
    return q[:, : df - 1]


class IntegratedPopulation:
    """The plug-in population's spline family, for integrating its coefficients out."""

    def __init__(self, pop, penalty=population.PENALTY):
        k, df = 3, pop.df
        self.grid, self.step, self.penalty = pop.grid, pop.step, penalty
        inner = np.linspace(pop.grid[0], pop.grid[-1], df - k + 1)
        self.knots = np.concatenate([[pop.grid[0]] * k, inner, [pop.grid[-1]] * k])
        self.P = _complement(df)
        self.S_grid = self.basis(pop.grid)  # (m, d)
        # the plug-in's coefficients: least squares of its ln g on the grid (exact up to the
        # additive constant, since the plug-in's ln g is in the same spline space)
        A = np.column_stack([self.S_grid, np.ones(len(pop.grid))])
        self.beta_hat = np.linalg.lstsq(A, pop.log_mass, rcond=None)[0][:-1]

    @property
    def d(self):
        return self.P.shape[1]

    def basis(self, x):
        """``B(x) P`` ``(..., d)``, the spline basis at ``x`` inside the grid."""
        x = np.clip(np.asarray(x, float), self.grid[0], self.grid[-1])
        B = interpolate.BSpline.design_matrix(x.ravel(), self.knots, 3).toarray()
        return (B @ self.P).reshape(x.shape + (self.d,))

    def log_z(self, beta):
        """``ln sum_m exp(S_m beta)`` ``(W,)`` and the grid probabilities ``(W, m)``."""
        a = beta @ self.S_grid.T
        lz = special.logsumexp(a, axis=-1)
        return lz, np.exp(a - lz[:, None])

    def objective(self, h, S, beta):
        """``l(beta)``, gradient and Hessian per walker; ``h (W, n, K)``, ``S (W, n, K, d)``."""
        a = h + np.einsum("wnkd,wd->wnk", S, beta)
        lse = special.logsumexp(a, axis=-1)
        p = np.exp(a - lse[..., None])
        Eb = np.einsum("wnk,wnkd->wnd", p, S)
        n = h.shape[1]
        lz, g = self.log_z(beta)
        Eg = g @ self.S_grid
        norm = np.sqrt(np.sum(beta**2, axis=-1) + 1e-12)
        ell = lse.sum(axis=1) - n * lz - self.penalty * norm
        grad = Eb.sum(axis=1) - n * Eg - self.penalty * beta / norm[:, None]
        H = (np.einsum("wnk,wnkd,wnke->wde", p, S, S) - np.einsum("wnd,wne->wde", Eb, Eb)
             - n * (np.einsum("wm,md,me->wde", g, self.S_grid, self.S_grid)
                    - Eg[:, :, None] * Eg[:, None, :]))
        u = beta / norm[:, None]
        eye = np.eye(self.d)
        H = H - self.penalty * (eye - u[:, :, None] * u[:, None, :]) / norm[:, None, None]
        return ell, grad, H, lse

    def laplace(self, h, S):
        """Per walker: ``ln int exp(l(beta)) d beta`` by Laplace, ``beta*``, ``l(beta*)`` and
        the per-cell ``ln sum_j exp(h_ij + s_ij beta*) - ln Z(beta*)``."""
        W = h.shape[0]
        beta = np.tile(self.beta_hat, (W, 1))
        ell, grad, H, lse = self.objective(h, S, beta)
        for _ in range(NEWTON):
            step = np.linalg.solve(-H, grad[..., None])[..., 0]
            t = np.ones(W)
            for _ in range(20):
                new = beta + t[:, None] * step
                e2, g2, H2, l2 = self.objective(h, S, new)
                worse = ~(e2 >= ell - 1e-12)
                if not worse.any():
                    break
                t = np.where(worse, t / 2, t)
            ok = e2 >= ell - 1e-12
            beta = np.where(ok[:, None], new, beta)
            ell = np.where(ok, e2, ell)
            grad = np.where(ok[:, None], g2, grad)
            H = np.where(ok[:, None, None], H2, H)
            lse = np.where(ok[:, None], l2, lse)
        sign, logdet = np.linalg.slogdet(-H)
        log_marg = ell + 0.5 * self.d * np.log(2 * np.pi) - 0.5 * logdet
        log_marg = np.where(sign > 0, log_marg, -np.inf)
        lz, _ = self.log_z(beta)
        return log_marg, beta, ell, lse - lz[:, None]


class IntegratedLikelihood(CellLikelihood):
    """:class:`CellLikelihood` whose bulged cells' population is integrated out (baseline
    context only). Per cell it returns the cell's term at ``beta*`` plus an equal share of the
    terms that belong to no cell (prior, Laplace volume), so the sum is the marginal."""

    def __init__(self, obs, table, **kw):
        super().__init__(obs, table, **kw)
        self.ip = IntegratedPopulation(obs.population)

    def bulged(self, gamma, E0t, R0, extra_log_sd=0.0, aux_log_w=None, obs_logpdf=None,
               grid=None):
        if aux_log_w is not None or obs_logpdf is not None or np.any(extra_log_sd):
            raise NotImplementedError("prototype: baseline context only")
        log_P, f = self._bulged_integrand(gamma, E0t, R0, grid=grid)
        with np.errstate(invalid="ignore"):
            h = f - self.obs.population.log_pdf(log_P) - np.log(self.ip.step)
        h = np.where(np.isfinite(f), h, -np.inf)
        out = np.empty(h.shape[:2])
        for lo in range(0, h.shape[0], CHUNK):
            sl = slice(lo, lo + CHUNK)
            log_marg, _, _, per_cell = self.ip.laplace(h[sl], self.ip.basis(log_P[sl]))
            rest = log_marg - per_cell.sum(axis=1)
            out[sl] = per_cell + rest[:, None] / per_cell.shape[1]
        return out


def model_for(cells, table, kind):
    model = effects.ExtendedModel(cells, table, [])
    if kind == "integrated":
        model.lik = IntegratedLikelihood(model.obs, table, n_nodes=model.lik.n_nodes,
                                         P0=model.lik.P0)
    return model


def check(seed, scale, table, n_draws=100_000):
    """Laplace marginal against importance sampling over beta at three parameter sets."""
    cells, _ = synthetic.simulate_cells(72 * scale, 42 * scale, seed=seed, truth=TRUTH,
                                        surrogate=table,
                                        design_kwargs={"P_distribution": "loguniform"})
    model = model_for(cells, table, "integrated")
    lik, ip = model.lik, model.lik.ip
    rng = np.random.default_rng(seed)
    print(f"{scale}x: {cells.is_bulged.sum()} bulged cells, df {ip.d + 1}")
    for gamma, E0t, R0 in ((TRUTH.gamma, TRUTH.E0t, TRUTH.R0),
                           (TRUTH.gamma * 1.1, TRUTH.E0t * 0.9, TRUTH.R0 * 1.01),
                           (TRUTH.gamma * 0.9, TRUTH.E0t * 1.1, TRUTH.R0 * 0.99)):
        g, e, r = (np.array([v]) for v in (gamma, E0t, R0))
        log_P, f = lik._bulged_integrand(g, e, r)
        h = np.where(np.isfinite(f), f - model.obs.population.log_pdf(log_P)
                     - np.log(ip.step), -np.inf)
        S = ip.basis(log_P)
        log_marg, beta, _, _ = ip.laplace(h, S)
        _, _, H, _ = ip.objective(h, S, beta)
        cov = np.linalg.inv(-H[0])
        nu = 5.0
        z = stats.multivariate_t(beta[0], cov, df=nu).rvs(n_draws, random_state=rng)
        log_q = stats.multivariate_t(beta[0], cov, df=nu).logpdf(z)
        ells = np.concatenate([ip.objective(np.broadcast_to(h, (len(c),) + h.shape[1:]),
                                            np.broadcast_to(S, (len(c),) + S.shape[1:]), c)[0]
                               for c in np.array_split(z, n_draws // 500)])
        lw = ells - log_q
        exact = special.logsumexp(lw) - np.log(n_draws)
        ess = np.exp(2 * special.logsumexp(lw) - special.logsumexp(2 * lw))
        print(f"  theta ({gamma:.3g}, {E0t:.3g}, {R0:.3g}): Laplace {log_marg[0]:.3f}, "
              f"importance sampling {exact:.3f} (ESS {ess:.0f} of {n_draws}), "
              f"difference {log_marg[0] - exact:+.3f}")


def one(seed, table, design, scale, settings=None):
    cells, _ = synthetic.simulate_cells(72 * scale, 42 * scale, seed=seed, truth=TRUTH,
                                        surrogate=table, design_kwargs={"P_distribution": design})
    guess = models.PaperWLS(cells, table).fit().estimate
    row = {"seed": seed, "design": design, "scale": scale}
    for kind in ("plug_in", "integrated"):
        model = model_for(cells, table, kind)
        t0 = time.perf_counter()
        post = criticism.fit_posterior(model, model.start_values(guess), seed,
                                       settings or CriticismSettings())
        row[kind] = sbc.truth_summary(model, post, TRUTH, PARAMS) | {"time_s": time.perf_counter() - t0,
                                             "engine": post.engine}
    return row


def report(rows):
    lines = [f"{len(rows)} data sets",
             f"{'parameter':<9}{'cover90 plug-in':>17}{'integrated':>12}{'sd(z) plug-in':>15}"
             f"{'integrated':>12}{'sd ratio':>10}"]
    for p in PARAMS:
        c = [np.mean([r[k][p]["cover90"] for r in rows]) for k in ("plug_in", "integrated")]
        s = [np.std([r[k][p]["z"] for r in rows]) for k in ("plug_in", "integrated")]
        ratio = np.median([r["integrated"][p]["sd"] / r["plug_in"][p]["sd"] for r in rows])
        lines.append(f"{p:<9}{c[0]:>17.3f}{c[1]:>12.3f}{s[0]:>15.2f}{s[1]:>12.2f}"
                     f"{ratio:>10.3f}")
    t = [np.median([r[k]["time_s"] for r in rows]) for k in ("plug_in", "integrated")]
    lines.append(f"median time per fit: plug-in {t[0]:.1f} s, integrated {t[1]:.1f} s")
    return lines


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--design", choices=("lognormal", "loguniform"), default="loguniform")
    ap.add_argument("--scale", type=int, default=10)
    ap.add_argument("--n", type=int, default=20)
    ap.add_argument("--first-seed", type=int, default=1000)
    ap.add_argument("--check", action="store_true")
    ap.add_argument("--out", default=None,
                    help="JSON-lines file (default: hierarchical_population.jsonl in --output-dir, or in "
                         "studies/results with --update)")
    provenance.add_output_options(ap)
    ap.add_argument("--summarize", action="store_true", help="print the table of --out only")
    args = ap.parse_args()
    args.out = args.out or str(provenance.study_path(args, "hierarchical_population.jsonl"))
    record = provenance.run_record()
    print(provenance.header_line(record), flush=True)
    table = surrogate.load()
    settings = None
    if args.smoke:  # see SMOKE_SETTINGS; a fresh file in --output-dir
        args.scale, args.n, args.summarize, settings = 1, 1, False, SMOKE_SETTINGS
        open(args.out, "w").close()
        check(args.first_seed, args.scale, table, SMOKE_CHECK_DRAWS)
    if args.check:
        check(args.first_seed, args.scale, table)
        return
    if not args.summarize:
        with open(args.out, "a") as f:
            for seed in range(args.first_seed, args.first_seed + args.n):
                row = one(seed, table, args.design, args.scale, settings)
                f.write(json.dumps(dict(row, provenance=record)) + "\n")
                f.flush()
                print(seed, {k: [round(row[k][p]["z"], 2) for p in PARAMS]
                             for k in ("plug_in", "integrated")},
                      f"{row['integrated']['time_s']:.0f} s", flush=True)
    with open(args.out) as f:
        rows = [json.loads(line) for line in f if line.strip()]
    rows = [r for r in rows if r["design"] == args.design and r["scale"] == args.scale]
    print("\n".join(report(rows)))


if __name__ == "__main__":
    main()
