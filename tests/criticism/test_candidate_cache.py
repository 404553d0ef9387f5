"""``criticize`` keeps each candidate's fit in a cache (turgorbayes.cache): a re-run with more
candidates, or after a kill, fits only the candidates missing there, and the criticism is the
uncached one (criticism.json equal; it holds no timing); a damaged entry is reported in one
line and fitted again (docs/outputs.md, "The cache").

Reference: the same criticism without a cache; the candidates fitted are counted on the
workflow's worker task.
"""

import dataclasses

import pytest
from numpy.testing import assert_array_equal

from turgorbayes.cache import Cache
from turgorbayes.simulation import cells as synthetic
from turgorbayes.workflows import criticize as workflow
from turgorbayes.workflows.criticize import CriticismSettings, criticism_dict, criticize

SETTINGS = CriticismSettings(
    n_draws=1000, n_rep=200, max_refits=0, retry_factor=1, flag_draws=50, n_walkers=12,
    n_ensembles=4, tol=25, check_every=50, max_steps=4000)
ALL = ("pressure_error", "turgor_spread", "bad_curves")


@pytest.fixture(scope="module")
def cells(table):
    return synthetic.simulate_cells(n_bulged=12, n_intact=8, seed=5, surrogate=table)[0]


@pytest.fixture(scope="module")
def reference(cells, table):
    """The criticism of every candidate, without a cache."""
    return criticize(cells, table, seed=2, settings=dataclasses.replace(SETTINGS, effects=ALL))


def _counting(monkeypatch):
    """The candidates fitted from now on (their names)."""
    fitted, fit = [], workflow._fit_candidate

    def counted(job):
        fitted.append(job[2])
        return fit(job)

    monkeypatch.setattr(workflow, "_fit_candidate", counted)
    return fitted


def _same(result, reference):
    assert criticism_dict(result) == criticism_dict(reference)
    for name in ALL:
        assert_array_equal(result.posteriors[name].u, reference.posteriors[name].u, err_msg=name)
        assert_array_equal(result.loo[name]["elpd_i"], reference.loo[name]["elpd_i"])


@pytest.mark.slow
def test_an_added_candidate_is_the_only_one_fitted(cells, table, reference, tmp_path,
                                                   monkeypatch):
    cache = Cache(tmp_path)
    criticize(cells, table, seed=2, settings=dataclasses.replace(SETTINGS, effects=ALL[:2]),
              cache=cache)
    assert len(list(tmp_path.glob("*.pkl"))) == 2
    fitted = _counting(monkeypatch)
    messages = []
    cache = Cache(tmp_path)
    result = criticize(cells, table, seed=2, settings=dataclasses.replace(SETTINGS, effects=ALL),
                       progress=messages.append, cache=cache)
    assert fitted == ["bad_curves"] and cache.hits == 2
    assert f"2 of 3 candidates from the cache {tmp_path}" in messages
    _same(result, reference)
    # another seed is another key: every candidate fitted again
    fitted.clear()
    criticize(cells, table, seed=3, settings=dataclasses.replace(SETTINGS, effects=ALL[:1]),
              cache=Cache(tmp_path))
    assert fitted == ["pressure_error"]


@pytest.mark.slow
def test_a_damaged_entry_is_reported_and_fitted_again(cells, table, reference, tmp_path,
                                                      monkeypatch):
    criticize(cells, table, seed=2, settings=dataclasses.replace(SETTINGS, effects=ALL),
              cache=Cache(tmp_path))
    entries = sorted(tmp_path.glob("*.pkl"))
    assert len(entries) == 3
    entries[0].write_bytes(entries[0].read_bytes()[:100])  # as a full disk could leave it
    fitted, lines = _counting(monkeypatch), []
    result = criticize(cells, table, seed=2, settings=dataclasses.replace(SETTINGS, effects=ALL),
                       cache=Cache(tmp_path, report=lines.append))
    assert len(fitted) == 1
    assert len(lines) == 1 and lines[0].startswith(f"warning: damaged cache entry {entries[0]} (")
    assert lines[0].endswith("); computing it again")
    _same(result, reference)


def test_the_key_holds_what_reaches_a_candidates_fit_and_nothing_else(cells, table):
    # reference: what a candidate's fit reads (_fit_candidate: the data, the surrogate, its
    # name, its start, its seed and the engine's settings). The other candidates
    # (settings.effects), the processes or cluster that fit it, the progress bar and the
    # checks' and screen's draws (n_rep, flag_draws: not used by a candidate's fit) leave the
    # key unchanged, so re-running criticize with one candidate added refits only that one
    from turgorbayes.workflows.criticism_candidates import NOT_IN_FIT, candidate_key

    guess = {"P_phys": 29e3}

    def key(cells=cells, name="pressure_error", guess=guess, seed=2, **changes):
        return candidate_key(cells, table, name, guess, seed,
                             dataclasses.replace(SETTINGS, **changes))

    same = key()
    assert set(NOT_IN_FIT) == {"workers", "scheduler", "progress", "effects", "n_rep",
                               "flag_draws"}
    for changes in ({"effects": ALL}, {"effects": ALL[:1]}, {"workers": 4},
                    {"scheduler": "tcp://127.0.0.1:8786"}, {"progress": True},
                    {"n_rep": 1000}, {"flag_draws": 200}):
        assert key(**changes) == same, changes
    other = dataclasses.replace(cells, R_c=cells.R_c * (1 + 1e-12))  # one bit-level change
    differ = [key(name="bad_curves"), key(seed=3), key(guess={"P_phys": 30e3}), key(cells=other),
              key(n_draws=2000), key(max_refits=1), key(max_steps=8000), key(n_walkers=16)]
    assert len({same, *differ}) == 1 + len(differ)
