"""Frequencies repeated at other excitation levels (mountid.diagnosis.levels): the test, what a change of the
isolators' stiffness makes of the shifts, and what the diagnosis says of them."""

import math
from dataclasses import replace

import numpy as np
import pytest
import scipy.stats

from mountid.diagnosis import campaign as campaign_module
from mountid.diagnosis.candidates import diagnose_effects
from mountid.diagnosis.levels import LevelShift, LevelTest, amplitude_dependent
from mountid.machine import Machine
from mountid.validation import blind

KID300 = Machine.resolve("kid300")
KNOWN = KID300.values({}, tuple(n for n in KID300.parameters if n not in KID300.unknown))
NOMINAL = KID300.values({}, KID300.unknown)


def _frequencies(log_stiffness: np.ndarray) -> dict[str, float]:
    """kid300's frequencies [rad/s] at the log stiffnesses (c_xy, c_z)."""
    return KID300.frequencies({**KNOWN, **dict(zip(KID300.unknown, np.exp(log_stiffness), strict=True))})


def _shifts(at_level: dict[str, float], relative_std: float = 3e-4) -> LevelTest:
    base = _frequencies(np.log([NOMINAL[u] for u in KID300.unknown]))
    return LevelTest(
        tuple(
            LevelShift("soft", label, w, at_level[label], math.hypot(relative_std * w, relative_std * at_level[label]))
            for label, w in base.items()
        )
    )


def _against_stiffness(test: LevelTest):
    theta = np.log([NOMINAL[u] for u in KID300.unknown])
    return test.against_stiffness(_frequencies, theta, KID300.unknown, (theta - 2.0, theta + 2.0))


def test_the_chi2_counts_every_repeated_frequency():
    test = LevelTest((LevelShift("a", "x", 10.0, 10.3, 0.1), LevelShift("b", "z", 20.0, 19.9, 0.1)))
    assert [s.z for s in test.shifts] == pytest.approx([3.0, -1.0])
    assert test.chi2 == pytest.approx(10.0)
    assert test.p_value == pytest.approx(scipy.stats.chi2.sf(10.0, 2))
    assert test.largest.mode == "x" and test.largest.relative == pytest.approx(0.03)
    assert test.text([], 1e-3).startswith("the frequencies agree between the excitation levels (chi^2 = 10 for 2")


def test_a_change_of_the_isolators_stiffness_alone_is_absorbed_exactly():
    """Rubber 10 % softer in shear and 5 % stiffer in compression at the other level: 0.03 % frequencies move
    by hundreds of standard deviations, all of it a change of the two stiffnesses, recovered to 1e-6. Exactly:
    the linearised change leaves up to 7e-4 of the frequency (chi^2 6.2, where this leaves below 1e-6)."""
    changed = {"c_xy": NOMINAL["c_xy"] * 0.9, "c_z": NOMINAL["c_z"] * 1.05}
    test = _shifts(KID300.frequencies({**KNOWN, **changed}))
    change = _against_stiffness(test)
    assert test.p_value == 0.0
    assert change.relative["soft"]["c_xy"] == pytest.approx(-0.1, abs=1e-6)
    assert change.relative["soft"]["c_z"] == pytest.approx(0.05, abs=1e-6)
    assert change.chi2 < 1e-6 and change.dof == 4  # six repeated frequencies, two stiffnesses
    assert not amplitude_dependent(test, [change], 1e-3)
    assert "as a change of the isolators' stiffness alone makes them in the nominal model" in test.text([change], 1e-3)


def test_a_stiffening_that_differs_from_mode_to_mode_is_amplitude_dependence():
    """The same change with one mode 0.5 % stiffer still: no change of the stiffnesses makes that, and where the
    model cannot be evaluated or the repeats leave no degree of freedom the test cannot tell: amplitude dependence
    either way (no verdict is confident on it)."""
    changed = KID300.frequencies({**KNOWN, "c_xy": NOMINAL["c_xy"] * 0.9, "c_z": NOMINAL["c_z"] * 1.05})
    test = _shifts({**changed, "z": changed["z"] * 1.005})
    change = _against_stiffness(test)
    assert change.p_value < 1e-10
    assert amplitude_dependent(test, [change], 1e-3)
    assert "differently in each mode" in test.text([change], 1e-3)
    assert amplitude_dependent(test, [], 1e-3)
    two = LevelTest(test.shifts[:1])
    assert _against_stiffness(two).dof == 0 and amplitude_dependent(two, [_against_stiffness(two)], 1e-3)
    assert "too few repeated frequencies" in two.text([_against_stiffness(two)], 1e-3)
    # a model that misses the campaign's level itself cannot tell a mode-dependent amplitude dependence from its
    # own wrong sensitivities: said as such
    missing = replace(change, fits=False)
    assert amplitude_dependent(test, [missing], 1e-3)
    assert "which miss the modes at the campaign's level themselves" in test.text([missing], 1e-3)


def test_hardening_isolators_a_belt_mimics_are_not_named_a_belt_at_a_second_hit_level():
    """Fresh seed 4179, rectangular with shapes: the hardening isolators a belt mimics confidently from one
    excitation level (test_blind, the strict xfail). Hit again at half the force, their frequencies drop by up to
    3.6 % (87 standard deviations), beyond what any change of the isolators' stiffness makes of them: the verdict
    says so and is not confident."""
    result = blind.run_case(4179, "nonlinear_isolator", "shapes", "rectangular", level=0.5)
    assert not result.confident and not result.confident_and_wrong
    assert "the frequencies move with the excitation level" in result.verdict
    assert "beyond any change of the isolators' stiffness" in result.verdict


def test_a_belt_stays_confident_where_the_rubber_is_softer_at_a_second_level():
    """Seed 5, kid300 with shapes, a drive belt: the same campaign hit again at half the force, its rubber 5-10 %
    stiffer or softer per direction (blind.LEVEL_RUBBER), alike in every mode. The fitted stiffnesses absorb the
    shifts and the verdict is the one of the campaign without them."""
    data, _ = blind.make_case(5, "drive_belt", kind="shapes", machine="kid300", level=0.5)
    with_level = diagnose_effects(campaign_module.parse(data))
    without = diagnose_effects(campaign_module.parse({k: v for k, v in data.items() if k != "levels"}))
    assert with_level.confident and with_level.verdict == without.verdict and not with_level.levels_move
    assert any(
        "frequencies move with the excitation level" in n and "alike in every mode" in n for n in with_level.notes
    )


def test_the_reports_json_lists_each_shift():
    from mountid.diagnosis.gap import diagnose

    data, _ = blind.make_case(5, "drive_belt", kind="frequencies", machine="kid300", level=0.5)
    out = diagnose(campaign_module.parse(data)).to_dict()
    assert [s["mode"] for s in out["levels"]] == list(data["modes"])
    first = out["levels"][0]
    assert first["at_level"] == data["levels"][0]["modes"]["x"]["frequency"]
    assert first["z"] == pytest.approx((first["at_level"] - first["frequency"]) / first["std"])


def test_a_second_level_leaves_the_rest_of_a_blind_campaign_as_it_was():
    """The level's noise is drawn apart: the campaign without its ``levels`` is the one make_case gives without
    a level (the benchmark's seeds keep their cases). Its modes are paired with the campaign's by their shapes
    (blind.same_modes): kid300 seed 4003, one isolator stiffer, splits x from y and psi from theta, and labelling
    each test apart by the nominal model swapped them (psi +6.8 % and theta +3.2 % for rubber at most 5 % off)."""
    with_level, _ = blind.make_case(4003, "isolator_scatter", kind="shapes", machine="kid300", level=0.5)
    without, _ = blind.make_case(4003, "isolator_scatter", kind="shapes", machine="kid300")
    assert {k: v for k, v in with_level.items() if k != "levels"} == without
    shifts = campaign_module.parse(with_level).levels.shifts
    assert max(abs(s.relative) for s in shifts) < math.exp(blind.LEVEL_RUBBER / 2) - 1 + 2e-3


def test_modes_are_paired_by_their_shapes():
    rng = np.random.default_rng(3)
    shapes = rng.standard_normal((6, 6))
    order = rng.permutation(6)
    other = 1.7 * shapes[:, order] + 0.01 * rng.standard_normal((6, 6))
    assert np.array_equal(order[blind.same_modes(shapes, other)], np.arange(6))


def test_the_levels_pick_the_root_of_an_effect_one_level_fits_alike():
    """Fresh seed 4261, kid300 with damping ratios, a drive belt 50.5 kN/m at 0.28 m below the centre of mass:
    the six frequencies fit as well with 25.8 kN/m at 0.48 m above, the root fitted. The rubber's change between
    the levels is absorbed only at the true root: the verdict stays confident and says the levels pick it (with
    the fitted root alone it was a tie, the shifts beyond a change of stiffness)."""
    result = blind.run_case(4261, "drive_belt", "damping", "kid300", level=0.5)
    assert result.confident and result.ranked[0] == "drive_belt"
    picked = result.verdict.split("at its other solution (")[1]
    assert picked.startswith("k_belt = 5.08e+04, h_belt = -0.283)")
    assert "the levels pick that solution of the effect" in result.verdict


def test_the_readme_example_of_a_second_level_is_the_blind_case():
    import json
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "examples" / "rectangular-blind-two-levels.json"
    data = json.loads(path.read_text(encoding="utf-8"))
    made = blind.example(4179, "nonlinear_isolator", "rectangular", level=0.5)
    assert data["known"] == made["known"] and data["levels"][0]["name"] == made["levels"][0]["name"]
    for label, mode in data["levels"][0]["modes"].items():  # equal up to the rounding of another BLAS build
        assert mode["frequency"] == pytest.approx(made["levels"][0]["modes"][label]["frequency"], rel=1e-12)
    for label, mode in data["modes"].items():
        assert mode["frequency"] == pytest.approx(made["modes"][label]["frequency"], rel=1e-12)
