"""Adding an effect is one file: a toy effect registered in a test reaches every list of
effects (docs/effects.md, "Adding an effect"): the command line's help, the docs table,
``simulate`` and the candidates of ``criticize``.

Reference: the toy effect's own declaration (its name, its size parameter and prior) must
appear wherever the registry is read; nothing else is edited.
"""

import json

import numpy as np
import pytest

from turgorbayes import effects
from turgorbayes.effects.base import Effect, SqrtCoordinate
from turgorbayes.inference.models import Parameter
from turgorbayes.inference.priors import HalfNormal


class ToyScale(Effect):
    """Every intact cell's k_c reading off by a common factor exp(toy_shift) (a toy)."""

    name = "toy_scale"
    parameters = (Parameter("toy_shift", SqrtCoordinate(HalfNormal(0.07)), "toy_shift", 1.0,
                            r"$\delta_{toy}$"),)
    size_parameter = "toy_shift"
    null_value = 0.0
    realistic_size = 0.2
    realistic_size_reason = "a toy"
    start = {"toy_shift": 0.05}
    cause = "A toy factor of {size:.0%} on every intact cell's stiffness."

    def observe_k(self, k_obs, k_true, v, is_cell, rng):
        return k_obs * np.exp(v["toy_shift"])


@pytest.fixture
def toy(monkeypatch):
    monkeypatch.setitem(effects.EFFECTS, ToyScale.name, ToyScale())
    return ToyScale.name


def test_a_registered_effect_reaches_every_list(toy, table, tmp_path, capsys):
    from turgorbayes.cli import main

    # the docs table (scripts/effects_table.py writes it from this function)
    assert any(row.startswith("| `toy_scale` | $\\delta_{toy}$ | half-normal(scale 0.07)")
               for row in effects.effects_table())
    # the command line's help
    with pytest.raises(SystemExit):
        main(["simulate", "--help"])
    assert "toy_scale: toy_shift" in " ".join(capsys.readouterr().out.split())
    # simulate plants it: every stiffness exp(0.2) times the same seed's without it
    out = tmp_path / "toy.csv"
    for args, path in ((["--effect", toy, "--effect-size", "0.2"], out), ([], tmp_path / "b.csv")):
        with pytest.raises(SystemExit) as exc:
            main(["simulate", "--out", str(path), "--seed", "3", "--n-bulged", "8",
                  "--n-intact", "6", *args])
        assert exc.value.code == 0
    truths = json.loads(out.with_suffix(".json").read_text())
    assert truths["effects"][0]["effect"] == toy
    from turgorbayes.cells.table import read_cells

    planted, plain = read_cells(out), read_cells(tmp_path / "b.csv")
    np.testing.assert_allclose(planted.k_c / plain.k_c, np.exp(0.2), rtol=1e-3)
    # the candidates of criticize: every registered effect that applies
    from turgorbayes.workflows.criticize import CriticismSettings, criticize

    seen = []
    settings = CriticismSettings(n_draws=300, n_rep=100, max_refits=0, flag_draws=20,
                                 effects=None)
    with pytest.raises(_Stop):
        criticize(planted, table, seed=1, settings=settings, progress=_stop_at_list(seen))
    assert seen[-1].startswith("candidates (") and toy in seen[-1].split(": ", 1)[1].split(", ")


class _Stop(Exception):
    pass


def _stop_at_list(seen):
    """A progress callback that records the messages and stops once the candidates are listed
    (before any fit: cheaper than fitting them all)."""
    def say(message):
        seen.append(message)
        if message.startswith("candidates ("):
            raise _Stop
    return say
