"""The one seed scheme of every random draw: numbered streams of one seed, named things keyed
by their names (docs/statistics.md, "One posterior engine")."""

import hashlib

import numpy as np

__all__ = ["STREAMS", "stable_key", "stream_rng", "stream_seed"]

#: The random streams of one seed (:func:`stream_rng`): a new use takes a new number, so adding
#: one does not change the draws of the others; a stream of named things (candidate models,
#: cells) keys each by its name (:func:`stable_key`), never by its position in a list, so adding
#: or reordering them does not change the draws of the others either. The sampler's own
#: streams are ``SeedSequence(seed).spawn(n_ensembles)``
#: (:func:`turgorbayes.inference.sampling.ensemble_seeds`).
STREAMS = {
    7: "importance sampling (importance_posterior)",
    8: "derived moduli of the emcee diagnostics (mcmc_posterior)",
    9: "draws of the Laplace approximation (laplace_posterior)",
    11: "criticism: predictive checks",
    13: "criticism: parameter summaries",
    14: "criticism: stacking",
    15: "criticism and fit: draws screened for gross errors (flag_cells)",
    16: "criticism: FE-table check",
    17: "criticism: Bayesian bootstrap of the LOO comparison",
    18: "criticism: the fit of a single-effect candidate (stream_seed keyed by the effect's name)",
    19: "criticism: the exact leave-one-out refit of a cell (stream_seed of the model's own "
        "fit seed, keyed by the cell's cell_id)",
    20: "criticism: the fit of the selected effect with the runner-up (stream_seed keyed by "
        "both names, selected first)",
    21: "criticism: the misfit band's offsets and derived moduli (turgorbayes.criticism."
        "misfit_band)",
    22: "criticism: starts of a model's mode search drawn from its effects' priors when the "
        "first search ends off a mode (turgorbayes.workflows.criticism_candidates."
        "candidate_laplace; of the model's own fit seed)",
    1000: "fit: derived quantities, replicates (1000 + 0)",
    1003: "fit: the population noise carried into the draws (1000 + 3)",
    2718: "fit: bootstrap of the plug-in latent population (population_noise, which spells "
          "out [seed, 2718] itself; with several conditions keyed by the condition's label)",
}


def stable_key(name):
    """The key of a named thing in a random stream (:func:`stream_rng`): the first 4 bytes of
    the SHA-256 of ``str(name)`` (UTF-8), as a big-endian integer in ``[0, 2**32)``.

    The same on every machine and run (unlike Python's ``hash``, salted per process), and
    one word of a :class:`numpy.random.SeedSequence`'s entropy, like a stream number.
    """
    return int.from_bytes(hashlib.sha256(str(name).encode("utf-8")).digest()[:4], "big")


def _entropy(seed, stream):
    """``[seed, *stream]`` as integers: stream numbers as given, names by :func:`stable_key`."""
    return [int(seed), *(stable_key(s) if isinstance(s, str) else int(s) for s in stream)]


def stream_rng(seed, *stream):
    """The generator of one random stream of a seed (each use has its own stream number,
    :data:`STREAMS`): ``default_rng(SeedSequence([seed, *stream]))``, where a ``str`` in
    ``stream`` (a model's or a cell's name) enters as its :func:`stable_key`."""
    return np.random.default_rng(np.random.SeedSequence(_entropy(seed, stream)))


def stream_seed(seed, *stream):
    """The integer seed of one random stream of a seed, for a function that takes a seed
    (:func:`fit_posterior`, whose engines draw from their own streams of it: :data:`STREAMS`
    7-9 and the sampler's ``SeedSequence(seed).spawn``).

    ``SeedSequence([seed, *stream]).generate_state(1)[0]`` (a ``uint32``, as
    :func:`turgorbayes.inference.sampling.ensemble_seeds`), with names keyed as in
    :func:`stream_rng`. A candidate model's fit is ``stream_seed(seed, 18, name)``: the same
    draws whatever other candidates are fitted, and in whatever order.
    """
    state = np.random.SeedSequence(_entropy(seed, stream)).generate_state(1, dtype=np.uint32)
    return int(state[0])
