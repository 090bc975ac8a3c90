"""The effect registry (mountid.effects): every registered effect has what the layers need of it, so that
adding an effect is one registry entry plus its energy (for the generated kind) and its blind truth."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from mountid.diagnosis.strategies import STRATEGIES, strategy
from mountid.effects import CATALOGUE, EFFECT_KINDS, Effect
from mountid.engine.symbolic.effects import ENERGIES, GENERATED_EFFECTS
from mountid.machine import Machine
from mountid.validation import blind_truth

ROOT = Path(__file__).resolve().parents[1]
DOCUMENTED = set(re.findall(r"^## (\w+):", (ROOT / "docs" / "effects.md").read_text(encoding="utf-8"), re.M))


def test_every_kind_has_its_strategy():
    assert set(STRATEGIES) == set(EFFECT_KINDS)


@pytest.mark.parametrize("effect", CATALOGUE, ids=lambda e: e.name)
def test_every_effect_has_its_energy_strategy_truth_and_page(effect: Effect):
    assert isinstance(strategy(effect), type(STRATEGIES[effect.kind]))
    if effect.kind == "generated":
        assert effect.name in ENERGIES and effect.name in GENERATED_EFFECTS
        assert hasattr(Machine.resolve("kid300").module, f"effect_{effect.name}")
    assert effect.name in DOCUMENTED, f"docs/effects.md has no section '## {effect.name}: ...'"
    # the blind truth (its own, or the truth of other physics it is drawn as): a size for it, and physics that
    # changes the modes at that size
    drawn = blind_truth.DRAWN_AS.get(effect.name, effect.name)
    assert blind_truth.represented_by(drawn) == effect.name
    machine = Machine.resolve("kid300")
    truth = blind_truth.TruthMachine("kid300")
    size = blind_truth.sample(np.random.default_rng(3), drawn, truth)
    with_effect = blind_truth.true_modes(truth, machine, blind_truth.Truth(drawn, size, {}))
    without = blind_truth.true_modes(truth, machine, blind_truth.Truth("none", {}, {}))
    changed = [not np.allclose(a, b, rtol=1e-9, atol=1e-12) for a, b in zip(with_effect, without, strict=True)]
    assert any(changed), f"the blind truth of {effect.name} does not change the modes"


def test_energies_only_for_generated_effects():
    assert set(ENERGIES) == set(GENERATED_EFFECTS)


def test_an_effect_of_unknown_kind_is_refused():
    with pytest.raises(ValueError, match="kind 'magic' is not one of"):
        Effect("levitation", "magic", "a made-up effect", (), "nothing")


def test_an_effect_without_a_blind_truth_is_named():
    with pytest.raises(ValueError, match="no blind truth for the effect 'levitation'"):
        blind_truth.sample(np.random.default_rng(0), "levitation", blind_truth.TruthMachine("kid300"))
