"""Tests of the criticism workflow (turgorbayes.criticism, report_criticism, cli.criticize).

The point are the hidden-effect tests: data simulated with one effect at a realistic size
(turgorbayes.effects, ``realistic_size`` and its reason), criticized blind, on a fixed block of
data seeds (not chosen among successes); over the block the workflow must name the effect, and
the effect size's and P_phys's 90 % intervals must cover the truth, at rates the power study
(studies/criticism_power.py) makes near-certain. Null control: data from the baseline (a
block of 3 seeds) select nothing in at least 2.
The engine parts are checked against closed forms: PSIS-LOO against the exact leave-one-out
predictive of a conjugate normal model, importance sampling against a known Gaussian posterior,
the Bayesian-bootstrap probability against its normal limit, the importance-sampling posterior
against the package's emcee sampler. Tests that need the finite-element table skip until it
is built. Runs share fits through module-scoped caches, and the hidden-effect block and the
open-world test share candidate fits through one cache folder (``fit_cache``).
"""

import dataclasses
import functools
import json
import os

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy import stats

from turgorbayes import criticism, effects, surrogate
from turgorbayes.cache import Cache
from turgorbayes.cells.table import read_cells, write_cells
from turgorbayes.inference import models
from turgorbayes.simulation import cells as synthetic
from turgorbayes.workflows import fit as results
from turgorbayes.workflows.criticize import CRITICISM_KEYS, CriticismSettings, criticism_dict, criticize

from helpers import GAUSSIAN_COV, GAUSSIAN_MEAN, GaussianModel

#: Small-but-converged settings (convergence is still checked: k <= 0.7, ESS >= 400, emcee's
#: fallback still runs to its autocorrelation rule). No re-run with 3x the steps
#: (``retry_factor=1``): an unconverged candidate is then simply not selectable; the re-run
#: path has its own fast tests below, and on membrane data the 12,000-step re-runs made one
#: criticism take > 15 min. Readings are screened for gross errors at 50 draws (CLI: 200):
#: the planted errors score 1.00 and the Monte Carlo sd of a score is <= 0.07.
SETTINGS = CriticismSettings(
    n_draws=1000, n_rep=700, max_refits=3, retry_factor=1,
    n_walkers=12, n_ensembles=4, tol=25, check_every=50,
                             max_steps=4000, progress=False, flag_draws=50)
#: The fixed block of data seeds of every hidden-effect test and of the null controls: the
#: first seeds, the same for every effect, never replaced by seeds that pass. How often an
#: effect is found is measured by the power study (README); the assertions below are on rates
#: over the block with bounds that the measured rates pass with probability >= 0.97.
BLOCK = (1, 2)
NULL_BLOCK = (1, 2, 3)
#: Effects found with power >= 0.8 at their realistic size (power study: pressure_error and
#: bad_curves 1.00, wall_softening 0.95; radius_spread at 0.02 with the example's R_c errors
#: 20 of 20 data sets, studies/results/criticism_power_radius_spread_v2.txt).
#: outer_membrane (power 0.35-0.40) has its own test.
FOUND = ("radius_spread", "pressure_error", "bad_curves", "wall_softening")
#: radius_spread is simulated with 8-12 nm radius errors (the bundled example's design): its
#: realistic spread (12.8 nm) and 15-25 nm errors would scatter the intact cells by 24 nm, more
#: than the paper's 20 nm (docs/effects.md, radius_spread).
RC_ERR = {"radius_spread": (8e-9, 12e-9)}
TRUE_P_PHYS_KPA = 29.0


#: Measurement sessions of the calibration data (a cantilever each).
N_SESSIONS = 6
#: On session data the calibration candidate needs the CLI's 2000 importance draws: with 1000,
#: importance sampling fails (Pareto k) on data without the effect (a funnel of sigma_cal and
#: the session factors near sigma_cal = 0) and the emcee fallback does not converge in 4000
#: steps (185-214 s, measured), after which the candidate is unselectable and "not invented"
#: would pass for the wrong reason. With 2000 it converges by importance sampling in ~18 s.
SESSION_SETTINGS = dataclasses.replace(SETTINGS, n_draws=2000)


def _sessions(seed):
    """Sessions of a null-block data set: the first one is measured in N_SESSIONS sessions."""
    return N_SESSIONS if seed == NULL_BLOCK[0] else None


#: Tests that share these caches carry the same ``xdist_group`` mark, so that under
#: ``pytest -n 2 --dist loadgroup`` (the README's test command) they run in one process.
@functools.cache
def _data(name, seed, n_sessions=None):
    inj = [] if name is None else [effects.get_effect(name).injection(
        effects.get_effect(name).realistic_size)]
    errors = synthetic.ErrorModel(R_c_sd=RC_ERR.get(name, synthetic.ErrorModel.R_c_sd))
    return synthetic.simulate_cells(seed=seed, surrogate=surrogate.load(), effects=inj,
                                    errors=errors, n_sessions=n_sessions)


@functools.cache
def _criticized(name, seed, n_sessions=None, cache=None):
    cells, truths = _data(name, seed, n_sessions)
    settings = SESSION_SETTINGS if n_sessions else SETTINGS
    return criticize(cells, surrogate.load(), seed=1, settings=settings, cache=cache), truths


@pytest.fixture(scope="session")
def fit_cache(tmp_path_factory):
    """One cache of candidate fits (turgorbayes.cache) for the hidden-effect block and the
    open-world test: they criticize the same data sets with the same seed and settings, and a
    candidate's fit depends on neither the other candidates nor ``settings.effects``
    (``candidate_key``), so the open-world criticism fits only the baseline (and a pair)
    again. The criticism is the same with or without the cache (tests/criticism/
    test_candidate_cache.py)."""
    return Cache(tmp_path_factory.mktemp("criticism_fits"))


@pytest.fixture(scope="module")
def cli_run(table, tmp_path_factory):
    """The bundled example (simulated with radius_spread 0.035, README) through the command's
    code path (files written and read back)."""
    import importlib.resources

    from turgorbayes.cli.criticize import run_criticize_command

    tmp = tmp_path_factory.mktemp("criticize")
    cells = read_cells(str(importlib.resources.files("turgorbayes") / "data/example_cells.csv"))
    write_cells(cells, tmp / "data.csv")
    out = tmp / "out"
    messages = []
    run_criticize_command(tmp / "data.csv", out, 1, None, SETTINGS, echo=messages.append)
    return out, messages


# ----------------------------------------------------------------------------- hidden effects
def _outcome(name, seed, cache):
    """Found (selected alone, gain past the rule), size covered, P_phys covered, of one run
    (its candidate fits stored in ``cache``)."""
    result, truths = _criticized(name, seed, cache=cache)
    assert truths["effects"][0]["effect"] == name
    d = criticism_dict(result)
    e = effects.get_effect(name)
    key = next(p.key for p in e.parameters if p.name == e.size_parameter)
    cand = next(c for c in result.candidates if c["effect"] == name)
    found = (d["selected_effect"] == name and cand["convergence"]["converged"]
             and d["gain"]["delta_elpd"] == cand["delta_elpd"] > criticism.DELTA_ELPD_MIN
             and cand["p_gain"] >= criticism.P_GAIN_MIN and d["misfit_detected"])
    est = cand["estimate"][key]
    P = (d["parameters"]["extended"] or d["parameters"]["baseline"])["P_phys_kPa"]
    return {"found": bool(found), "size": bool(est["q05"] <= e.realistic_size <= est["q95"]),
            "P": bool(P["q05"] <= TRUE_P_PHYS_KPA <= P["q95"]), "selected": d["selected_effect"],
            "delta": round(cand["delta_elpd"], 1)}


@pytest.mark.slow
@pytest.mark.xdist_group("criticism_hidden")
def test_hidden_effects_are_found_over_a_fixed_block_of_seeds(table, fit_cache):
    # reference: simulated truth. Over the block (4 effects x 2 seeds = 8 data sets) with
    # powers 1.0, 1.0, 0.95, 0.83 the count found is >= 6 with probability 0.996 (at most 2
    # misses among two wall_softening and two radius_spread data sets); the 90 % intervals of
    # the size and of P_phys cover the truth in >= 5 of 8 with probability >= 0.98 (binomial,
    # p >= 0.85, the power study's lowest coverage)
    out = {(n, s): _outcome(n, s, fit_cache) for n in FOUND for s in BLOCK}
    found = [k for k, o in out.items() if o["found"]]
    assert len(found) >= 6, out
    assert sum(o["size"] for o in out.values()) >= 5, out
    assert sum(o["P"] for o in out.values()) >= 5, out
    # no data set names another effect than the simulated one (wrong rate 0.00-0.05)
    assert all(o["selected"] in (None, n) or n in effects.parse_model_name(o["selected"])
               for (n, _), o in out.items()), out


#: The open-world test hides this effect from the candidates (docs/validation.md, "When the
#: cause is not in the library"): radius_spread, the bundled example's cause, whose data the
#: generic discrepancy candidate describes as extra R_c scatter of the intact cells.
HIDDEN = "radius_spread"


@functools.cache
def _hidden_criticized(name, seed, cache=None):
    """The block's data set with ``name`` planted, criticized with every OTHER candidate (the
    candidates' fits taken from ``cache`` where the hidden-effect block stored them)."""
    cells, truths = _data(name, seed)
    others = tuple(n for n in effects.effect_names() if n != name
                   and not effects.get_effect(n).not_applicable_reason(cells))
    return criticize(cells, surrogate.load(), seed=1, cache=cache,
                     settings=dataclasses.replace(SETTINGS, effects=others)), truths


@pytest.mark.slow
# the block's group: one process, the block first (it stores the candidate fits reused here)
@pytest.mark.xdist_group("criticism_hidden")
def test_an_effect_the_candidates_do_not_know_is_not_explained(table, fit_cache):
    # reference: simulated truth (radius_spread planted at its realistic size, the same block of
    # data seeds), criticized with radius_spread left out and the generic candidate present.
    # Measured (studies/results/open_world*.jsonl, docs/validation.md): not explained in any
    # of the data sets run (every one unexplained, the generic candidate absorbing extra R_c
    # scatter), no reading called a gross error, the quoted P_phys covered in 4 of 5. Bounds: at
    # most one of the two explained (probability >= 0.97 at a true rate <= 0.17); at least one
    # quoted P_phys covered (probability 0.96 at a coverage of 0.8)
    ds = [criticism_dict(_hidden_criticized(HIDDEN, s, fit_cache)[0]) for s in BLOCK]
    statuses = [d["verdict"]["status"] for d in ds]
    assert sum(s == "explained" for s in statuses) <= 1, statuses
    for d in ds:
        assert d["verdict"]["text"]
        assert all("gross error" not in f["reason"] for f in d["flagged_cells"])
        # the model average, with the misfit band where the misfit is not explained
        # (docs/effects.md, "The misfit band")
        band = d["misfit_band"]
        widened = band is not None and band["applied"]
        assert d["headline"] == ("widened" if widened else "model_average")
        assert band is None or d["verdict"]["status"] in ("partly_explained", "unexplained")
    P = [d["parameters"][d["headline"]]["P_phys_kPa"] for d in ds]
    assert any(p["q05"] <= TRUE_P_PHYS_KPA <= p["q95"] for p in P), P


@pytest.mark.xdist_group("criticism_hidden")
@pytest.mark.skipif(not os.environ.get("TURGORBAYES_SLOW"),
                    reason="a membrane criticism falls back to emcee for most candidates and "
                           "takes 15-25 min on two cores; set TURGORBAYES_SLOW=1 (power and "
                           "wrong-selection rate: studies/criticism_power.py)")
def test_hidden_outer_membrane_is_never_mistaken_for_another_effect(table):
    # reference: simulated truth (membrane at its realistic size). The rule names it in only
    # 7-8 of 20 data sets (power 0.35-0.40) but never names another effect (wrong 0.00 of 20):
    # on the first seed of the block no wrong name. One seed only: a membrane criticism costs
    # ~130 s (its importance sampler falls back to emcee); the model average's coverage
    # (0.80 over 20) is measured by studies/criticism_power.py, not here.
    res = [_criticized("outer_membrane", s)[0] for s in BLOCK[:1]]
    sel = [r.selected for r in res]
    assert all(x is None or "outer_membrane" in effects.parse_model_name(x) for x in sel), sel


@pytest.mark.slow
@pytest.mark.xdist_group("criticism_example")
def test_criticize_command_on_the_bundled_example(cli_run):
    out, messages = cli_run
    d = json.loads((out / "criticism.json").read_text())
    # criticism.json holds exactly the documented keys (docs/effects.md)
    assert list(d) == list(CRITICISM_KEYS)
    for key, sub in CRITICISM_KEYS.items():
        if key in ("checks", "candidates", "flagged_cells"):
            assert all(list(entry) == list(sub) for entry in d[key])
        elif sub and d[key] is not None:  # misfit_band is null under no_misfit and explained
            assert list(d[key]) == list(sub)
    # the example's cells sit at x = 0.06-0.17 (docs/fem.md), inside the FE table and far from
    # its buckled corner: the adopted model asks the table for nothing it lacks
    assert d["fe_table"]["cells"] == {} and d["fe_table"]["fraction_of_draws"] == 0.0
    assert d["fe_table"]["boxes"]
    fields = list(results.PARAMETER_FIELDS)
    assert all(list(v) == fields for v in d["parameters"]["baseline"].values())
    assert set(results.SUMMARY_KEYS["parameters"]) <= set(d["parameters"]["extended"])
    # every candidate records its engine's convergence (item "Convergence is part of the answer")
    for c in d["candidates"] + [{"convergence": d["baseline_convergence"]}]:
        conv = c["convergence"]
        assert conv["engine"] in ("importance", "emcee") and isinstance(conv["converged"], bool)
        assert conv["converged"] == (not conv["reasons"])
        assert isinstance(conv["laplace"]["mode_found"], bool)
    # reference: the example's sidecar (simulated with radius_spread 0.035, P_phys 29 kPa)
    assert d["selected_effect"] == "radius_spread"
    est = next(c for c in d["candidates"] if c["effect"] == "radius_spread")["estimate"]["tau_R"]
    assert est["q05"] <= 0.035 <= est["q95"], est
    assert d["gain"]["delta_elpd"] > criticism.DELTA_ELPD_MIN
    diag = json.loads((out / "criticism_diagnostics.json").read_text())
    assert next(c["p_gain"] for c in diag["candidates"]
                if c["effect"] == "radius_spread") >= criticism.P_GAIN_MIN
    P = d["parameters"]["extended"]["P_phys_kPa"]
    assert P["q05"] <= TRUE_P_PHYS_KPA <= P["q95"]
    report = (out / "report.md").read_text()
    assert "SIMULATED DATA" in report and "![misfit](misfit.png)" in report
    assert (out / "misfit.png").stat().st_size > 10_000
    assert any("best named effect: radius_spread" in m for m in messages)
    # the verdict: the example's cause is in the library and no check remains flagged under it;
    # the generic description of extra scatter fits the example about as well by LOO (84.4
    # against 85.9 nats over the baseline with the CLI's settings), and the marginal likelihood
    # credits radius_spread over it by ln BF 3.6 +- 0.03 (the CLI's settings, seed 0), past the
    # bar of ln 20 = 3.0: explained, in words that give both comparisons; a seed whose ln BF
    # fell short would leave it a description (partly_explained, "not which cause")
    v = d["verdict"]
    assert v["selected"] == "radius_spread" and v["remaining_checks"] == []
    assert v["status"] in ("explained", "partly_explained")
    assert v["status"] == "explained" or "not which cause" in v["text"]
    generic = next(c for c in diag["candidates"] if c["effect"] == "discrepancy")
    assert generic["vs_selected"]["bayes_factor"]["log_bf"] > 0  # the named cause, more probable
    assert (v["status"] == "explained") == (generic["identified_by"] is not None)
    if generic["identified_by"] == "bayes_factor":
        assert "marginal likelihood favours it" in v["text"]
    assert messages[-3].startswith("verdict: ") and messages[-2] == v["text"]
    # the headline: the model average, with the misfit band when the example is read as a
    # description (partly_explained: the cause may lie outside the library)
    assert messages[-1].startswith("quote the model average")
    assert d["headline"] == ("model_average" if v["status"] == "explained" else "widened")
    assert report.rstrip().endswith(messages[-1])
    # the adopted extension's curve bands for the report's Fig. 3: the median cell's wall is
    # the paper's, whose R_c(29 kPa) = 540.7 nm (docs/physics.md) lies inside the 95 % band
    from turgorbayes.workflows.bands import read_bands

    bands = read_bands(out / "extended_bands.json")
    lo, hi = (np.interp(np.log(29e3), np.log(bands.P), bands.R[i]) for i in (0, -1))
    assert lo < 540.7e-9 < hi and hi - lo < 30e-9
    assert diag["seed"] == 1 and diag["data_sha256"] == read_cells(out.parent / "data.csv").sha256
    # the provenance lists what was fitted (every candidate), not the empty request
    assert diag["settings"]["effects"] == [c["effect"] for c in d["candidates"]] != []


@pytest.mark.slow
@pytest.mark.xdist_group("criticism_null")
def test_null_data_select_nothing(table):
    # reference: simulated truth (no effect). False selection <= 0.1 (0.00 of 20 measured):
    # at most 1 of 3 selects something (probability >= 0.97); P_phys covered in >= 2 of 3
    # (coverage 0.90: probability 0.97)
    # (the first data set in measurement sessions: the same cells, and calibration a candidate)
    ds = [criticism_dict(_criticized(None, s, _sessions(s))[0]) for s in NULL_BLOCK]
    assert sum(d["selected_effect"] is not None for d in ds) <= 1, [d["cause"] for d in ds]
    for s, d in zip(NULL_BLOCK, ds, strict=True):
        if d["selected_effect"] is None:
            assert d["gain"] == {"delta_elpd": 0.0, "se": 0.0}
            assert d["parameters"]["extended"] is None
            # every effect (calibration only with sessions; own_wall never: one condition;
            # osmoadaptation never: one medium) and no pair is tried
            n = len(effects.EFFECTS) - (_sessions(s) is None) - 2
            assert len(d["candidates"]) == n
            assert not {"own_wall", "osmoadaptation"} & {c["effect"] for c in d["candidates"]}
    P = [d["parameters"]["baseline"]["P_phys_kPa"] for d in ds]
    assert sum(p["q05"] <= TRUE_P_PHYS_KPA <= p["q95"] for p in P) >= 2, P
    # the verdict: no misfit in at least 2 of 3 (the checks flag a correct model with
    # probability <= 0.05 by their Bonferroni level, and nothing is selected; docs/validation.md
    # measures the rate on 40 null data sets); a status other than no_misfit never names a cause
    assert sum(d["verdict"]["status"] == "no_misfit" for d in ds) >= 2, [d["verdict"] for d in ds]
    assert all(d["verdict"]["status"] != "explained" or d["selected_effect"] for d in ds)


def _tip_tables_installed():
    from importlib.resources import files

    from turgorbayes.surrogate.axes import TIP_RADIUS

    root = files("turgorbayes") / "data"
    return all((root / f).is_file() for f in [*TIP_RADIUS.files.values(), TIP_RADIUS.reference_file])


#: The design on which a 20 nm tip is found: 6x the paper's cells (432 bulged at 1-25 kPa, 252
#: intact), with the two effects that change every stiffness by a near-common factor (the
#: nearest rivals of each other) as candidates. Power study (README, effects power table;
#: studies/results/criticism_power_fe_settings.txt): at the paper's size a 20 nm tip is found
#: in 6 of 20 data sets (never another effect; its interval covered 20 nm in all 6); at 6x in 5
#: of 6, the sixth named wall_thickness.
TIP_DESIGN = {"n_bulged": 432, "n_intact": 252}
TIP_SETTINGS = dataclasses.replace(SETTINGS, effects=("tip_radius", "wall_thickness"))


@functools.cache
def _tip_criticized(size, seed):
    inj = [] if size is None else [effects.get_effect("tip_radius").injection(size)]
    cells, _ = synthetic.simulate_cells(seed=seed, surrogate=surrogate.load(), effects=inj,
                                        **TIP_DESIGN)
    return criticism_dict(criticize(cells, surrogate.load(), seed=1,
                                                        settings=TIP_SETTINGS))


@pytest.mark.slow
@pytest.mark.xdist_group("criticism_tip")
@pytest.mark.skipif(not _tip_tables_installed(), reason="tip-radius tables not installed")
def test_a_blunt_tip_is_named_and_its_radius_covered(table):
    # reference: simulated truth, a 20 nm tip (the FE's is 7.5 nm), over the block of seeds.
    # With power 5/6 per data set, at least one of two is found with probability 0.97; the 90 %
    # interval of a found tip covers 20 nm in at least one of them (at the paper's size 6 of 6
    # covered; on one block data set at 6x it reached 12.3-19.6 nm: an interval misses 1 in 10)
    ds = [_tip_criticized(20e-9, s) for s in BLOCK]
    found = [d for d in ds if d["selected_effect"] == "tip_radius"]
    assert found, [d["cause"] for d in ds]
    est = [d["parameters"]["extended"]["tip_radius_nm"] for d in found]
    assert any(e["q05"] <= 20.0 <= e["q95"] for e in est), est
    assert all("blunter" in d["cause"] for d in found)
    assert all(d["selected_effect"] in ("tip_radius", "wall_thickness") for d in ds)


@pytest.mark.slow
@pytest.mark.xdist_group("criticism_tip")
@pytest.mark.skipif(not _tip_tables_installed(), reason="tip-radius tables not installed")
def test_the_tip_is_not_questioned_on_data_with_the_fe_tip(table):
    # reference: simulated truth, the FE's own 7.5 nm tip, the same design (first seed); false
    # selection with every effect a candidate: 0 of 20 at the paper's size
    d = _tip_criticized(None, BLOCK[0])
    assert d["selected_effect"] is None, d["cause"]


def _contaminated(cells):
    """The cells with two gross errors: b004's k_b x5 (its bulge pressure 5x too high) and
    i009's R_c x1.4 (a width measured on a dividing pair); reported errors unchanged."""
    ids = list(cells.cell_id)
    k_b, R_c = cells.k_b.copy(), cells.R_c.copy()
    k_b[ids.index("b004")] *= 5
    R_c[ids.index("i009")] *= 1.4
    return dataclasses.replace(cells, k_b=k_b, R_c=R_c)


@pytest.mark.slow
@pytest.mark.xdist_group("criticism_gross")
def test_two_gross_outliers_are_named_and_the_outliers_effect_selected(table):
    # reference: simulated truth (baseline data of the null block's first seed) with two
    # readings corrupted by hand. The outliers effect (alone or paired) must be adopted and
    # both readings named with the right quantity; at most one other reading may be flagged
    # (20 clean data sets: 1 false flag in 6840 readings, docs/effects.md, outliers)
    clean = _data(None, NULL_BLOCK[0])[0]
    d = criticism_dict(criticize(_contaminated(clean), surrogate.load(),
                                 seed=1, settings=SETTINGS))
    assert d["selected_effect"] and "outliers" in effects.parse_model_name(
        d["selected_effect"]), d["cause"]
    named = {(f["cell_id"], f["quantity"]) for f in d["flagged_cells"]}
    assert {("b004", "k_b/R_b"), ("i009", "R_c")} <= named and len(named) <= 3, named
    # with the gross errors down-weighted, P_phys is what the clean data give: the adopted
    # model's median within half a posterior sd of the clean data's baseline median (reference:
    # the baseline posterior of the uncorrupted cells)
    model = effects.ExtendedModel(clean, surrogate.load(), [])
    wls = models.PaperWLS(clean, surrogate.load()).fit()
    post = criticism.fit_posterior(model, model.start_values(wls.estimate), 1, SETTINGS)
    P_clean = post.summary(np.random.default_rng(0))["P_phys_kPa"]
    P = d["parameters"]["extended"]["P_phys_kPa"]
    assert abs(P["q50"] - P_clean["q50"]) < 0.5 * P_clean["sd"], (P, P_clean)


@pytest.mark.slow
@pytest.mark.xdist_group("criticism_null")
def test_calibration_is_not_invented_on_session_data_without_it(table):
    # reference: simulated truth without the effect (the null block's first data set, measured
    # in 6 sessions): calibration is a candidate and is not adopted (false selection over 20
    # data sets: studies/criticism_power.py --n-sessions 6)
    d = criticism_dict(_criticized(None, NULL_BLOCK[0], N_SESSIONS)[0])
    (cal,) = [c for c in d["candidates"] if c["effect"] == "calibration"]
    assert cal["convergence"]["converged"], cal["convergence"]  # not selectable otherwise
    sel = d["selected_effect"]
    assert sel is None or "calibration" not in effects.parse_model_name(sel), d["cause"]


@pytest.mark.slow
@pytest.mark.xdist_group("criticism_null")
def test_calibration_is_found_in_sessions(table):
    # reference: simulated truth, 6 sessions of 19 cells, the realistic calibration error
    # (sigma_cal 0.15), on the fixed block of seeds. Calibration is the only candidate (the
    # full candidate list on session data is the test above): the question here is whether its
    # gain passes the selection rule. The power study found it in 6 of 7 data sets (seeds
    # 1000-1006, all candidates), so at least 1 of 2 is found with probability ~0.98; where it
    # is found, its 90 % interval of sigma_cal covers 0.15
    only = dataclasses.replace(SESSION_SETTINGS, effects=("calibration",))
    ds = []
    for seed in BLOCK:
        cells, truths = _data("calibration", seed, N_SESSIONS)
        assert truths["effects"][0]["size"] == 0.15
        ds.append(criticism_dict(criticize(cells, surrogate.load(), seed=1,
                                                               settings=only)))
    found = [d for d in ds if d["selected_effect"] == "calibration"]
    assert found, [d["cause"] for d in ds]
    for d in found:
        est = d["candidates"][0]["estimate"]["sigma_cal"]
        assert est["q05"] <= 0.15 <= est["q95"], est


@pytest.mark.slow
@pytest.mark.xdist_group("criticism_hidden")
def test_model_average_weights_the_converged_models(table, fit_cache):
    # stacking weights are a distribution over the baseline and the converged extensions
    # (radius_spread data: its criticism is cached from the hidden-effect block; membrane data
    # would cost 15-25 min, see the skipped test above)
    result, _ = _criticized("radius_spread", BLOCK[0], cache=fit_cache)
    w = result.stacking["weights"]
    assert set(w) == {n for n, p in result.posteriors.items() if n == "baseline" or p.converged}
    assert_allclose(sum(w.values()), 1.0, atol=1e-9)
    from turgorbayes.report import criticism as report_criticism

    assert "model average (stacking)" in report_criticism.render_report(result)


@pytest.mark.slow
# ----------------------------------------------------------------------------- engine
@pytest.mark.xdist_group("criticism_null")
def test_importance_sampling_agrees_with_emcee(table):
    # reference: the package's emcee sampler (independent ensembles, autocorrelation rule) on
    # the same baseline posterior; means within 4 Monte Carlo standard errors, sds within 15 %
    cells, _ = _data(None, NULL_BLOCK[0])
    model = effects.ExtendedModel(cells, table)
    guess = models.PaperWLS(cells, table).fit().estimate
    u_map, cov = criticism.laplace(model, guess)
    post_is = criticism.importance_posterior(model, u_map, cov, 3, SETTINGS)
    post_mc = criticism.mcmc_posterior(model, u_map, cov, 4, SETTINGS)
    assert post_is.converged and post_mc.converged, (post_is.reasons, post_mc.reasons)
    for i in range(model.ndim):
        m1, m2 = post_is.weights @ post_is.u[:, i], np.mean(post_mc.u[:, i])
        s1 = np.sqrt(post_is.weights @ (post_is.u[:, i] - m1) ** 2)
        s2 = np.std(post_mc.u[:, i])
        ess_mc = post_mc.diagnostics["chain"][model.names[i]]["ess_bulk"]
        assert abs(m1 - m2) < 4 * np.sqrt(s1**2 / post_is.ess + s2**2 / ess_mc)
        assert_allclose(s1, s2, rtol=0.15)


def test_importance_sampling_recovers_a_known_gaussian():
    # reference: the exact mean and covariance; the proposal starts off-centre and too narrow,
    # so the moment-matching round is exercised
    mean, cov = GAUSSIAN_MEAN, GAUSSIAN_COV
    model = GaussianModel(mean, cov)
    settings = CriticismSettings(n_draws=4000)
    post = criticism.importance_posterior(model, mean + 0.5, 0.3 * cov, 1, settings)
    assert post.converged and post.diagnostics["k_hat"] < 0.7
    w = post.weights
    m = w @ post.u
    c = (post.u - m).T @ ((post.u - m) * w[:, None])
    se = np.sqrt(np.diag(cov) / post.ess)
    assert np.all(np.abs(m - mean) < 4 * se)
    assert_allclose(c, cov, atol=0.12)


def test_importance_sampling_short_of_ess_is_rerun_with_more_draws():
    # the ESS never exceeds the draws, and a round whose ESS reaches half its draws ends the
    # adaptation: 300 draws cannot give an ESS of 500. The Pareto k of a Gaussian target is
    # small, so the re-run with 3 x 300 draws (ESS ~0.75 x 900 here) converges; the record
    # says so
    model = GaussianModel(GAUSSIAN_MEAN, GAUSSIAN_COV)
    settings = CriticismSettings(n_draws=300, ess_min=500)
    post = criticism.fit_posterior(model, dict(zip(model.names, GAUSSIAN_MEAN + 0.2, strict=True)), 1, settings)
    assert post.converged and post.engine == "importance", post.reasons
    assert len(post.attempts) == 1 and post.attempts[0]["effort"] == "300 draws per round"
    assert "importance-sampling ESS" in post.attempts[0]["reasons"][0]
    assert post.diagnostics["n_draws"] >= 900
    rec = post.convergence()
    assert rec["converged"] and rec["laplace"]["mode_found"] and rec["attempts"] == post.attempts
    # without a retry factor the re-run still takes the draws the shortfall asks for:
    # 1.3 x 500 / (the first ESS) times 300, which converges here (ESS ~0.75 x the draws)
    one = dataclasses.replace(settings, retry_factor=1.0)
    post = criticism.fit_posterior(model, dict(zip(model.names, GAUSSIAN_MEAN + 0.2, strict=True)),
                                   1, one)
    assert post.converged and post.engine == "importance", post.reasons
    first_ess = float(post.attempts[0]["reasons"][0].split()[2])
    assert post.diagnostics["n_draws"] >= 300 * 1.3 * 500 / (first_ess + 0.5) - 1  # ESS printed


def _fail_first_mode_search(monkeypatch):
    """Make the first mode search return its start as a failure (later ones run normally);
    returns the list of starting points, one per search."""
    from turgorbayes.inference import mode

    calls, original = [], mode.mode_search

    def failing_once(model, u0, maxiter=None, method="BFGS"):
        calls.append(np.array(u0))
        if len(calls) == 1:
            return mode.ModeSearch(np.array(u0), float(model.log_posterior(u0[None])[0]), False,
                                   "simulated failure")
        return original(model, u0, maxiter, method)

    monkeypatch.setattr(mode, "mode_search", failing_once)
    return calls


def test_mode_search_is_restarted_from_a_draw_that_beats_the_mode(monkeypatch):
    # a mode search that fails (returns its start 2 sds off the mean) must be caught by the
    # draws: the best draw beats it by > 1 nat, the search restarts there and u_map becomes
    # the mean (reference: the mode of N(mean, cov) is its mean)
    from turgorbayes.inference import engine as posterior

    calls = _fail_first_mode_search(monkeypatch)
    model = GaussianModel(GAUSSIAN_MEAN, GAUSSIAN_COV)
    start = GAUSSIAN_MEAN + 2 * np.sqrt(np.diag(GAUSSIAN_COV))
    post = posterior.fit_posterior(model, dict(zip(model.names, start, strict=True)), 2,
                                   CriticismSettings(n_draws=2000))
    assert len(calls) == 2 and np.all(calls[1] != start)
    assert_allclose(post.u_map, GAUSSIAN_MEAN, atol=0.05)
    assert "a draw beat the mode by" in post.laplace["notes"][0]
    assert post.converged


def _conjugate(rng, n=30, S=16000):
    y = rng.normal(0.0, 1.0, n)
    y[0] = 3.5  # a mild outlier: the LOO ratios of that point have the heaviest tail
    theta = rng.normal(y.mean(), np.sqrt(1 / n), S)
    ll = stats.norm.logpdf(y[None, :], theta[:, None], 1.0)
    y_rest = (y.sum() - y) / (n - 1)
    exact = stats.norm.logpdf(y, y_rest, np.sqrt(1 + 1 / (n - 1)))
    return y, theta, ll, exact


def test_psis_loo_matches_the_exact_conjugate_loo(rng):
    # reference: y_i ~ N(theta, 1), flat prior: p(y_i | y_-i) = N(y_i; mean(y_-i), 1 + 1/(n-1))
    y, theta, ll, exact = _conjugate(rng)
    loo = criticism.psis_loo(ll, np.full(ll.shape[0], -np.log(ll.shape[0])))
    assert_allclose(loo["elpd_i"], exact, atol=0.01)
    assert loo["n_bad"] == 0 and loo["good_k"] == pytest.approx(min(1 - 1 / np.log10(16000), 0.7))
    # the same from importance-weighted draws of a wider t proposal
    q = stats.t(df=5, loc=y.mean(), scale=2 / np.sqrt(y.size))
    th = q.rvs(size=8000, random_state=rng)
    log_post = stats.norm.logpdf(th, y.mean(), np.sqrt(1 / y.size))
    log_w = log_post - q.logpdf(th)
    log_w -= np.log(np.sum(np.exp(log_w - log_w.max()))) + log_w.max()
    ll_w = stats.norm.logpdf(y[None, :], th[:, None], 1.0)
    assert_allclose(criticism.psis_loo(ll_w, log_w)["elpd_i"], exact, atol=0.02)


def test_gain_probability_is_the_normal_limit(rng):
    # reference: for normal pointwise differences P(sum > 0) -> Phi(delta / se)
    for mu in (0.0, 0.02, 0.05):
        d = rng.normal(mu, 0.25, 114)
        se = np.sqrt(d.size * np.var(d))
        p = criticism.gain_probability(d, np.random.default_rng(1), n_boot=20000)
        assert_allclose(p, stats.norm.cdf(d.sum() / se), atol=0.02)
    # gains concentrated in a few cells: the normal approximation says unclear, the bootstrap
    # says clear (3 cells gain 10 nats, the rest lose 0.02; P(Gamma(3) < 0.22) ~ 0.002)
    d = np.r_[np.full(3, 10.0), np.full(111, -0.02)]
    assert d.sum() < 2 * np.sqrt(d.size * np.var(d))
    assert criticism.gain_probability(d, np.random.default_rng(2)) > 0.99


def test_selection_rule():
    c = [{"effect": "a", "delta_elpd": 10.0, "delta_se": 2.0, "p_gain": 0.999, "converged": True},
         {"effect": "b", "delta_elpd": 3.0, "delta_se": 1.0, "p_gain": 0.999, "converged": True}]
    best, runner = criticism.select(c)
    assert best["effect"] == "a" and runner["effect"] == "b"
    assert criticism.select([dict(c[0], p_gain=0.97), c[1]])[0] is None  # not clear
    assert criticism.select([dict(c[0], delta_elpd=3.9), c[1]])[0] is None  # too small
    assert criticism.select([]) == (None, None)


def test_selection_ignores_unconverged_candidates():
    # the rule: an unconverged posterior's gain is unknown, so it is neither selected nor the
    # runner-up; the best converged one is (6 nats, clear)
    c = [{"effect": "a", "delta_elpd": 10.0, "p_gain": 1.0, "converged": False},
         {"effect": "b", "delta_elpd": 6.0, "p_gain": 0.999, "converged": True},
         {"effect": "c", "delta_elpd": 1.0, "p_gain": 0.7, "converged": True}]
    best, runner = criticism.select(c)
    assert best["effect"] == "b" and runner["effect"] == "c"
    assert criticism.select(c[:1]) == (None, None)
    with pytest.raises(ValueError, match="candidate 'a' needs a boolean 'converged'"):
        criticism.select([{"effect": "a", "delta_elpd": 10.0, "p_gain": 1.0}])


def test_cause_names_weak_evidence_only_above_two_nats():
    # the rule: nothing selected; a best gain of 3 nats is named as weak evidence, 1.5 is not
    from types import SimpleNamespace

    def cands(d, conv=True):
        return [{"effect": "outer_membrane", "delta_elpd": d, "delta_se": 1.8, "converged": conv},
                {"effect": "bad_curves", "delta_elpd": -0.5, "delta_se": 0.3, "converged": True}]
    weak = criticism.cause_sentence(SimpleNamespace(selected=None, candidates=cands(3.0)))
    none = criticism.cause_sentence(SimpleNamespace(selected=None, candidates=cands(1.5)))
    assert weak.startswith("No cause found") and "Weak evidence for outer_membrane" in weak
    assert "3.0 +- 1.8" in weak
    assert "Weak evidence" not in none
    # an unconverged candidate is not named as evidence, but as left out
    left = criticism.cause_sentence(SimpleNamespace(selected=None, candidates=cands(3.0, False)))
    assert "Weak evidence" not in left and "not converged after the re-runs): outer_membrane" in left


@pytest.mark.slow
@pytest.mark.xdist_group("criticism_null")
def test_exact_refit_agrees_with_psis_where_psis_is_reliable(table):
    # reference: PSIS-LOO is accurate for cells with small Pareto k (the conjugate test above),
    # so the exact refit of such a cell must give the same elpd within Monte Carlo error
    result, _ = _criticized(None, NULL_BLOCK[0], N_SESSIONS)  # cached from the null block
    post = result.posteriors["baseline"]
    cells, _ = _data(None, NULL_BLOCK[0], N_SESSIONS)
    loo = criticism.exact_loo(post, cells, table, 5, SETTINGS, force=(0, 80))
    assert loo["refitted"][:2] == [0, 80]
    psis = criticism.psis_loo(post.log_lik, post.log_w)
    assert psis["pareto_k"][[0, 80]].max() < 0.5
    assert_allclose(loo["elpd_i"][[0, 80]], psis["elpd_i"][[0, 80]], atol=0.03)


@pytest.mark.slow
@pytest.mark.xdist_group("criticism_null")
def test_leave_one_out_refit_uses_the_full_data_population(table, rng):
    # reference: the full model's per-cell log-likelihood of the other cells. Read as the
    # full data read them (population, pooled errors), the refit model without cell i must
    # reproduce it exactly; with its observations re-estimated without cell i (what the refit
    # had before) it differs
    cells, _ = _data(None, NULL_BLOCK[0])
    full = effects.ExtendedModel(cells, table)
    i = int(full.obs.bulged[5])
    keep = np.arange(full.obs.n_cells) != i
    u = full.to_u(models.PaperWLS(cells, table).fit().estimate)
    u = u + 0.01 * rng.standard_normal((4, u.shape[1]))
    own = effects.ExtendedModel(cells.take(keep), table)
    sub = criticism.loo.with_full_data_observations(
        effects.ExtendedModel(cells.take(keep), table), full.obs, keep)
    ref = full.pointwise_log_likelihood(u)[:, keep]
    assert_allclose(sub.pointwise_log_likelihood(u), ref, rtol=0, atol=1e-10)
    assert np.max(np.abs(own.pointwise_log_likelihood(u) - ref)) > 1e-6


def test_settings_are_validated():
    with pytest.raises(ValueError, match="engine must be 'importance' or 'emcee', got 'mcmc'"):
        CriticismSettings(engine="mcmc")
    with pytest.raises(ValueError, match="n_draws must be an integer >= 2, got 1"):
        CriticismSettings(n_draws=1)
    with pytest.raises(ValueError, match="retry_factor must be >= 1 .*got 0.5"):
        CriticismSettings(retry_factor=0.5)


def test_criticize_command_refuses_unknown_effects(tmp_path, capsys):
    from turgorbayes.cli import main

    with pytest.raises(SystemExit) as exit_info:
        main(["criticize", "--effects", "radius_spread,nope", "--out", str(tmp_path)])
    assert exit_info.value.code == 2
    assert "unknown effect(s) nope" in capsys.readouterr().err


def test_laplace_at_the_edge_of_the_domain_falls_back_to_a_diagonal_covariance(caplog):
    # a half-Gaussian: log density -u^2/2 for u >= 0, undefined (-inf) below; the mode u = 0
    # sits on the edge, so no central-difference Hessian is finite at any step size. The
    # documented fallback: the mode and a diagonal covariance of (0.01 max(|u|, 1))^2
    class Edge:
        name = "edge"

        @staticmethod
        def to_u(values):
            return np.array([[values["a"]]])

        @staticmethod
        def log_posterior(u):
            u = np.atleast_2d(u)[:, 0]
            return np.where(u >= 0, -0.5 * u * u, -np.inf)

    u_map, cov = criticism.laplace(Edge(), {"a": 0.0})
    assert_allclose(u_map, [0.0], atol=1e-12)
    assert_allclose(cov, [[1e-4]], rtol=1e-12)
    assert "no finite Hessian" in caplog.text


def test_a_beaten_mode_is_restarted_before_emcee_runs(monkeypatch):
    # a mode search that ends 8 sds off the mean: importance sampling around it fails (Pareto
    # k), but its best draw beats that "mode" by far more than 1 nat, so the search restarts
    # from the draw and importance sampling converges around the true mode (reference: the
    # mode of N(mean, cov) is its mean) without the emcee fallback ever running
    from turgorbayes.inference import engine as posterior

    calls = _fail_first_mode_search(monkeypatch)
    def no_emcee(*args, **kwargs):
        raise AssertionError("emcee ran from a mode the draws had beaten")

    monkeypatch.setattr(posterior, "mcmc_posterior", no_emcee)
    model = GaussianModel(GAUSSIAN_MEAN, GAUSSIAN_COV)
    start = GAUSSIAN_MEAN + 8 * np.sqrt(np.diag(GAUSSIAN_COV))
    post = posterior.fit_posterior(model, dict(zip(model.names, start, strict=True)), 2,
                                   CriticismSettings(n_draws=2000))
    assert post.converged and post.engine == "importance", post.reasons
    assert len(calls) == 2
    assert_allclose(post.u_map, GAUSSIAN_MEAN, atol=0.05)
    assert [a["engine"] for a in post.attempts] == ["importance"] * len(post.attempts) != []
    assert post.laplace["notes"][0].startswith("a draw beat the mode by")


def test_emcee_runs_again_after_one_restart_at_most(monkeypatch):
    # an unconverged emcee run whose draws always beat the mode (here: a mode search that
    # never leaves its start, and draws at the true mean) restarts the search once and runs
    # emcee once more, not MAX_MODE_RESTARTS times: emcee is the expensive engine
    from turgorbayes.inference import engine as posterior
    from turgorbayes.inference import mode

    def never_moves(model, u0, maxiter=None, method="BFGS"):
        u0 = np.array(u0) + 3.0  # the "mode" is always 3 sds away from where it started
        return mode.ModeSearch(u0, float(model.log_posterior(u0[None])[0]), False, "stuck")

    runs = []

    def unconverged_emcee(model, u_map, cov, seed, settings):
        runs.append(np.array(u_map))
        u = GAUSSIAN_MEAN + 0.1 * np.random.default_rng(len(runs)).standard_normal((50, 3))
        ll, _ = posterior.log_lik_and_prior(model, u, 100)
        return posterior.Posterior(model=model, u=u, log_w=np.full(50, -np.log(50)), log_lik=ll,
                                   engine="emcee", converged=False, reasons=["simulated"],
                                   diagnostics={}, u_map=np.asarray(u_map), cov=np.asarray(cov))

    monkeypatch.setattr(mode, "mode_search", never_moves)
    monkeypatch.setattr(posterior, "mcmc_posterior", unconverged_emcee)
    model = GaussianModel(GAUSSIAN_MEAN, GAUSSIAN_COV)
    settings = CriticismSettings(engine="emcee", retry_factor=1.0)
    post = posterior.fit_posterior(model, dict(zip(model.names, GAUSSIAN_MEAN, strict=True)), 3,
                                   settings)
    assert len(runs) == 2 and not post.converged
    assert post.laplace["notes"][0].startswith("a draw beat the mode by")


@pytest.mark.parametrize(("stuck", "expected_runs"), [([0, 2], 1), ([], 2)])
def test_stuck_emcee_is_not_run_again_with_more_steps(monkeypatch, stuck, expected_runs):
    # an unconverged emcee run is run again with retry_factor x max_steps and the same seed,
    # which repeats it and continues: pointless when its walkers were stuck (the longer run
    # would repeat them). Reference: the ladder's rule, 1 run when stuck, 2 otherwise
    from turgorbayes.inference import engine as posterior

    runs = []

    def unconverged_emcee(model, u_map, cov, seed, settings):
        runs.append(settings.max_steps)
        u = GAUSSIAN_MEAN + 0.01 * np.random.default_rng(len(runs)).standard_normal((50, 3))
        ll, _ = posterior.log_lik_and_prior(model, u, 100)
        return posterior.Posterior(model=model, u=u, log_w=np.full(50, -np.log(50)), log_lik=ll,
                                   engine="emcee", converged=False, reasons=["simulated"],
                                   diagnostics={"stuck": stuck}, u_map=np.asarray(u_map),
                                   cov=np.asarray(cov))

    monkeypatch.setattr(posterior, "mcmc_posterior", unconverged_emcee)
    model = GaussianModel(GAUSSIAN_MEAN, GAUSSIAN_COV)
    settings = CriticismSettings(engine="emcee", retry_factor=3.0)
    post = posterior.fit_posterior(model, dict(zip(model.names, GAUSSIAN_MEAN, strict=True)), 3,
                                   settings)
    assert not post.converged
    max_steps = settings.max_steps
    assert runs == [max_steps, 3 * max_steps][:expected_runs]
