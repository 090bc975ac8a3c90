"""The blind validation harness, small: one case per effect and one without, the benchmark's targets.

``make bench`` runs the same over 96 cases per campaign kind (benchmarks/diagnosis.py)."""

from __future__ import annotations

import copy
import json
import math
import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import scipy.stats

from mountid.diagnosis import campaign
from mountid.diagnosis.candidates import diagnose_effects
from mountid.diagnosis.settings import DIAGNOSIS
from mountid.effects import CATALOGUE, EFFECTS, pair
from mountid.errors import InputError
from mountid.machine import Machine
from mountid.validation import blind, blind_truth


@pytest.fixture(scope="module")
def results() -> list[blind.CaseResult]:
    return blind.run(len(blind.EFFECT_NAMES), workers=2, first_seed=1000, machines=("kid300", "rectangular"))


def test_blind_targets_on_a_small_run(results):
    """One case of every truth on two machines (seeds the benchmark and the calibration do not use): the
    targets that 44 cases can judge."""
    score = blind.score(results)
    print(score.text())
    assert score.n == 2 * len(blind.EFFECT_NAMES) and score.n_none == 2
    assert score.n_identifiable >= 10  # enough cases for the top-1 figure to mean something
    assert score.top1_identifiable >= 0.9
    assert score.truth_in_tie >= 0.9
    assert score.median_reduction >= 0.8
    assert score.confident_on_none == 0 and score.confident_outside == 0 and score.confident_and_wrong == 0
    assert score.honest_outside == 1.0


def test_the_diagnosis_is_not_told_the_truth():
    """The campaign carries measurements only; two cases that differ only in the hidden effect's seed
    produce different data, and the same seed reproduces the same campaign byte for byte."""
    a, truth = blind.make_case(7, "drive_belt")
    b, _ = blind.make_case(7, "drive_belt")
    assert a == b and "drive_belt" not in str(a) and truth.effect == "drive_belt"
    assert set(a) == {"name", "machine", "known", "modes", "sensors"}
    assert {c["name"] for c in a["sensors"]} == {f"S{k}_{axis}" for k in range(1, 5) for axis in "xyz"}


def test_campaign_kinds_measure_what_they_say():
    shapes, _ = blind.make_case(5, "damping", kind="shapes")
    freqs, _ = blind.make_case(5, "damping", kind="frequencies")
    damped, _ = blind.make_case(5, "damping", kind="damping")
    assert all("shape" in m and "damping_ratio" not in m for m in shapes["modes"].values())
    assert all(set(m) == {"frequency", "uncertainty"} for m in freqs["modes"].values())
    assert all(0 < m["damping_ratio"] < 0.5 for m in damped["modes"].values())
    # the same truth and noise in every kind
    assert [m["frequency"] for m in freqs["modes"].values()] == [m["frequency"] for m in shapes["modes"].values()]
    with pytest.raises(ValueError, match="score one campaign kind"):
        blind.score([blind.run_case(3, "none", "frequencies"), blind.run_case(3, "none", "shapes")])


def test_a_blind_case_can_start_from_identified_nominal_values():
    """make_case(nominal="identified") asks the campaign to start from the identification on its frequencies (as
    on a description without nominal unknowns); the truth and data are the same, and a clear effect is named
    first either way."""
    given, truth = blind.make_case(1, "drive_belt")
    identified, same = blind.make_case(1, "drive_belt", nominal="identified")
    assert identified == {**given, "nominal": "identified"} and same == truth
    with pytest.raises(ValueError, match="nominal 'guessed' is not one of"):
        blind.make_case(1, "drive_belt", nominal="guessed")
    a, b = blind.run_case(1, "drive_belt"), blind.run_case(1, "drive_belt", nominal="identified")
    assert a.ranked[0] == b.ranked[0] == "drive_belt" and a.confident and b.confident


def test_true_damping_ratios_of_proportional_damping_are_the_modal_ones(monkeypatch):
    """B = beta C gives zeta_k = beta omega_k / 2 exactly: the pairing of poles with shapes is right."""
    machine = blind.Machine.resolve("rectangular")
    truth = blind_truth.TruthMachine("rectangular")
    t = blind_truth.Truth("none", {}, {})
    m, c, _ = blind_truth.truth_matrices(truth, t)
    omega, _ = blind_truth.true_modes(truth, machine, t)
    monkeypatch.setattr(blind_truth, "truth_matrices", lambda tm, t: (m, c, 1e-3 * c))
    zeta = blind_truth.true_damping_ratios(truth, machine, t)
    assert zeta == pytest.approx(1e-3 * omega / 2, rel=1e-9)


def test_noise_is_at_the_stated_uncertainty():
    z = []
    for seed in range(40):
        noisy, _ = blind.make_case(seed, "none")
        clean, _ = blind.make_case(seed, "none", noise=False)
        for label, m in noisy["modes"].items():
            z.append((m["frequency"] - clean["modes"][label]["frequency"]) / m["uncertainty"])
    assert 0.8 < np.std(z) < 1.2


def test_score_counts_a_confident_verdict_on_a_case_without_an_effect():
    fake = [
        blind.CaseResult("none", ("cog_height",), ("cog_height",), True, True, False, float("nan"), "confident", 0.99),
        blind.CaseResult("cog_height", ("cog_height",), ("cog_height",), True, True, True, 0.9, "confident", 0.99),
        blind.CaseResult(
            "resilient_attachment", ("foundation",), ("foundation",), True, True, False, 0.5, "confident", 0.97
        ),
        blind.CaseResult(
            "resilient_attachment", ("added_mass",), ("added_mass",), True, False, False, 0.5, "not explained", 1.0
        ),
        # a truth of two parts: naming the part that alone explains the noise-free data is right
        blind.CaseResult(
            "isolator_scatter+cog_height",
            ("cog_height",),
            ("cog_height",),
            True,
            True,
            False,
            0.5,
            "confident",
            0.99,
            acceptable=("cog_height+isolator_scatter", "cog_height"),
        ),
        # a truth of other physics that a catalogue effect represents is right when that effect is named
        blind.CaseResult("support_frame", ("foundation",), ("foundation",), True, True, True, 0.8, "confident", 0.97),
    ]
    score = blind.score(fake)
    assert score.confident_on_none == 1 and score.confident_outside == 1 and score.confident_and_wrong == 2
    assert not score.targets_met and score.honest_outside == 0.5
    assert score.top1_identifiable == 1.0 and score.truth_in_tie == 1.0
    # the reliability table holds the verdicts that state a probability (not the 'not explained' one) on truths
    # the catalogue represents (not the resilient attachment's)
    assert sum(row[2] for row in score.reliability) == 4
    assert score.confusion["isolator_scatter+cog_height"]["cog_height"] == 1


def _stated_results(stated: np.ndarray, right: np.ndarray) -> list[blind.CaseResult]:
    return [
        blind.CaseResult("cog_height", ("cog_height" if ok else "foundation",), (), True, False, True, 0.9, "tie", p)
        for p, ok in zip(stated, right, strict=True)
    ]


def test_calibration_error_comes_with_its_sampling_noise():
    """Verdicts right as often as stated: the error is of the size of its floor (what a calibrated diagnosis
    shows at these counts) and not rejected; right far more often than stated: rejected."""
    rng = np.random.default_rng(7)
    stated = rng.uniform(0.3, 1.0, 60)
    calibrated = blind.score(_stated_results(stated, rng.random(60) < stated))
    assert calibrated.calibration_floor > 0.03 and calibrated.calibration_p > 0.05
    underconfident = blind.score(_stated_results(stated, stated > 0.1))
    assert underconfident.calibration_error > 0.1 and underconfident.calibration_p < 0.05
    assert any(m == "calib." for m in underconfident.missed())
    # a dozen calibrated verdicts: the error exceeds 0.05 by chance, and the miss says it is within noise
    few = blind.score(_stated_results(stated[:12], rng.random(12) < stated[:12]))
    assert few.calibration_error > 0.05 and few.calibration_p > 0.05
    assert any(m.startswith("calib. (within noise") for m in few.missed())


def _seed_sharing_results(rng: np.random.Generator, shift: float = 0.0, seeds: int = 40) -> list[blind.CaseResult]:
    """Six machines per seed, stated probabilities uniform in [0.3, 1), each verdict right with its stated
    probability less ``shift``; a seed's six verdicts err together (one uniform draw per seed decides them all,
    as one truth drawn for every machine does at its worst)."""
    results = []
    for seed in range(seeds):
        u = rng.random()
        for p in rng.uniform(0.3, 1.0, 6):
            ranked = ("cog_height" if u < p - shift else "foundation",)
            results.append(blind.CaseResult("cog_height", ranked, (), True, False, True, 0.9, "tie", p, seed=seed))
    return results


def test_calibration_noise_widens_where_verdicts_share_a_seed():
    """Verdicts right as often as stated, but a seed's verdicts on six machines right or wrong together: the
    independent draws call such a calibrated diagnosis miscalibrated far more often than at their 5 % level,
    the draws widened by the design effect do not; a shifted one (right 0.2 less often than stated) is still
    called miscalibrated; with a seed per verdict the design effect is 1 and the draws are the independent ones."""
    rng = np.random.default_rng(3)
    shared, alone = [], []
    for _ in range(40):
        results = _seed_sharing_results(rng)
        *_, p, widening = blind._reliability(results, draws=200)
        assert widening > 1.5
        shared.append(p < 0.05)
        apart = [replace(r, seed=i) for i, r in enumerate(results)]
        *_, p_apart, one = blind._reliability(apart, draws=200)
        assert one == 1.0
        alone.append(p_apart < 0.05)
    assert np.mean(alone) >= 0.15 and np.mean(shared) <= 0.1
    *_, p_shifted, _ = blind._reliability(_seed_sharing_results(rng, shift=0.2), draws=200)
    assert p_shifted < 0.05


def test_a_group_all_right_is_never_judged_by_narrowed_draws():
    """Pairs of verdicts sharing a seed, stated 0.9 and 0.99, all right: their centred departures cancel seed by
    seed, so the design effect's estimate is 0 (it sees only the stated probabilities' spread); narrowed by it,
    no draw would be as far from the mean stated as the observed share (p = 0, though all right is what a
    calibrated diagnosis does in 89 % x 99 % of a pair's draws). The group's p is that of independent verdicts."""
    results = [
        blind.CaseResult("drive_belt", ("drive_belt",), (), True, True, True, 0.9, "confident", p, seed=seed)
        for seed in range(12)
        for p in (0.9, 0.99)
    ]
    stated, right = blind._stated(results)
    assert blind._design_effect(stated, right, [r.seed for r in results], np.zeros(len(results), dtype=int)) < 0.01
    apart = [replace(r, seed=i) for i, r in enumerate(results)]
    group = blind._by_group(results, lambda r: r.ranked[0], draws=2000)
    assert group == blind._by_group(apart, lambda r: r.ranked[0], draws=2000)
    assert group[0][4] > 0.2


def test_what_a_campaign_can_test():
    """The rectangular machine: three unknown stiffnesses; with damping ratios three damping coefficients too."""
    assert blind.can_test("cog_height", 6, 3) and not blind.can_test("foundation", 6, 3)
    assert blind.can_test("foundation", 36, 3)  # six frequencies and five shapes of six components
    # six ratios for three damping coefficients leave the support as untested as six frequencies alone do
    assert blind.can_test("cog_height", 12, 6, 6, 3) and not blind.can_test("foundation", 12, 6, 6, 3)
    assert not blind.can_test("cog_height+isolator_scatter", 12, 6, 6, 3)  # two degrees of freedom, a pair needs 3
    assert blind.can_test("cog_height+isolator_scatter", 36, 3)  # with the mode shapes


def test_every_truth_names_the_catalogue_effect_that_represents_it():
    names = {e.name for e in CATALOGUE}
    for truth in blind.EFFECT_NAMES:
        expected = blind_truth.represented_by(truth)
        assert expected is None or expected == "none" or set(expected.split("+")) <= names, truth
    assert set(blind_truth.OUT_OF_CATALOGUE) == {"resilient_attachment"}
    assert blind_truth.represented_by("sensor_turned+sensor_turned") == "two_sensors_turned"
    assert blind_truth.represented_by("sensor_turned+sensor_misplaced") == "sensor_turned_misplaced"
    assert blind_truth.represented_by("isolator_scatter+cog_height") == "cog_height+isolator_scatter"
    assert blind_truth.represented_by("support_frame+isolator_scatter") == "isolator_scatter+foundation"


def test_the_truths_beside_the_cycle_are_a_study_of_their_own():
    """A reversed channel beside a physical effect (REVERSED_BESIDE) stays out of the benchmark's cycle (its seeds
    keep their truths); each is represented by its pair, the one beside a scattered isolator too (fitted at each
    isolator with each of the reversal's screened channels)."""
    assert not set(blind_truth.REVERSED_BESIDE) & set(blind.EFFECT_NAMES)
    assert blind_truth.represented_by("isolator_scatter+sensor_reversed") == "isolator_scatter+sensor_reversed"
    assert blind_truth.represented_by("cog_height+sensor_reversed") == "cog_height+sensor_reversed"
    names = {e.name for e in CATALOGUE}
    for truth, expected in blind_truth.REVERSED_BESIDE.items():
        assert expected is None or set(expected.split("+")) <= names, truth
    todo = blind.cases(5, 7, truths=tuple(blind_truth.REVERSED_BESIDE))
    assert [c[:2] for c in todo] == [(7 + i, list(blind_truth.REVERSED_BESIDE)[i % 4]) for i in range(5)]
    with pytest.raises(InputError, match="truths.*no blind truth tilted_floor"):
        blind.cases(1, truths=("tilted_floor",))


def test_the_confusion_columns_name_every_candidate_apart():
    heads = [blind._short(e.name) for e in CATALOGUE]
    assert len(set(heads)) == len(heads) and all(len(h) <= 6 for h in heads)
    assert blind._short("sensor_turned_misplaced") == "setumi" and blind._short("sensor_turned") == "sentur"


def test_truths_outside_the_catalogue_beside_the_cycle():
    """Two channels off their stated points, a scattered isolator with a turned channel, and a tilted isolator with
    a higher centre of mass (OUTSIDE_BESIDE): outside the benchmark's cycle, represented by no candidate (the pair
    of a scattered isolator and a turned channel is not composed: PAIR_EXCLUSIONS; a tilted isolator is never part
    of a pair), each part drawn as its truth alone, the misplaced ones at two different channels."""
    assert blind_truth.OUTSIDE_BESIDE == (
        "sensor_misplaced+sensor_misplaced",
        "isolator_scatter+sensor_turned",
        "isolator_tilted+cog_height",
    )
    for truth in blind_truth.OUTSIDE_BESIDE:
        assert truth in blind.TRUTHS and truth not in blind.EFFECT_NAMES
        assert blind_truth.represented_by(truth) is None
    assert pair(EFFECTS["isolator_scatter"], EFFECTS["sensor_turned"]) is None
    assert all(pair(EFFECTS["isolator_tilted"], e) is None for e in CATALOGUE)
    for seed in range(6):
        _, t = blind.make_case(seed, "sensor_misplaced+sensor_misplaced", machine="screen6")
        assert t.size["channel"] != t.size["channel_2"]
        _, t = blind.make_case(seed, "isolator_scatter+sensor_turned", machine="screen6")
        assert {"s_h", "s_v", "isolator", "channel", "angle", "about"} == set(t.size)
        _, t = blind.make_case(seed, "isolator_tilted+cog_height", machine="screen6")
        assert {"isolator", "tilt", "about", "dz"} == set(t.size)
        assert 0.05 <= t.size["tilt"] <= 0.25 and t.size["isolator"] in range(6)


def test_a_tilted_isolator_is_a_truth_beside_the_cycle_its_candidate_represents():
    """The tilted isolator (REPRESENTED_BESIDE), written outside the catalogue before the catalogue had one, is
    represented by the catalogue's isolator_tilted and stays beside the benchmark's cycle, which keeps its truths
    (the candidate is not in the cycle either)."""
    assert blind_truth.represented_by("isolator_tilted") == "isolator_tilted"
    assert "isolator_tilted" in blind.TRUTHS and "isolator_tilted" not in blind.EFFECT_NAMES
    assert len(blind.EFFECT_NAMES) == 23 and blind.EFFECT_NAMES[-1] == "sensor_turned+sensor_misplaced"
    for seed in range(6):
        _, t = blind.make_case(seed, "isolator_tilted", machine="screen6")
        assert 0.05 <= t.size["tilt"] <= 0.25 and t.size["isolator"] in range(6)


def test_a_tilted_isolator_with_damping_ratios_is_named_where_its_turned_damping_fits():
    """Held-out kid300 cases with damping ratios (the study of 2026-12-02, docs/validation.md "Its damping turned
    too"): the truth turns the whole mount, damping too. With the candidate turning the isolator's damping with its
    stiffness, seed 3002 is named confidently and seed 3001 is a tie of the tilted isolator alone; while it turned
    the stiffness alone, the first was a tie and the second 'not explained'."""
    confident = blind.run_case(3002, "isolator_tilted", kind="damping", machine="kid300")
    assert confident.kind == "confident" and confident.ranked[0] == "isolator_tilted"
    alone = blind.run_case(3001, "isolator_tilted", kind="damping", machine="kid300")
    assert alone.kind == "tie" and alone.tie == ("isolator_tilted",)


def test_the_evidence_check_takes_every_truth_make_case_draws():
    """benchmarks/evidence.py (the Laplace evidence against the integral, on named blind cases) accepts a truth
    beside the cycle as blind.cases does, and names the truths where it is given another."""
    from benchmarks.evidence import parse_case

    title, camp, names = parse_case("3:cog_height+sensor_reversed:shapes:kid300:cog_height")
    assert title == "kid300 seed 3, cog_height+sensor_reversed, shapes:" and names == ["cog_height"]
    beside = (*blind_truth.REVERSED_BESIDE, *blind_truth.OUTSIDE_BESIDE, *blind_truth.REPRESENTED_BESIDE)
    assert camp.modes and blind.TRUTHS[-len(beside) :] == beside
    assert parse_case("5:sensor_misplaced+sensor_misplaced:shapes:kid300:cog_height")[2] == ["cog_height"]
    with pytest.raises(ValueError, match=r"truth 'tilted_floor' is not one of none, .*, drive_belt\+sensor_reversed"):
        parse_case("3:tilted_floor:shapes:kid300:cog_height")


def test_a_reversed_channel_beside_a_physical_effect_is_not_confident_and_wrong():
    """One case of each truth beside the cycle on kid300 with shapes (seeds 0-3 of the study in make bench): a
    drive belt with a reversed channel is named confidently; beside a scattered isolator too, at the truth's
    channel S1_x and isolator corner[-x-y] (its mirror image across as good; "not explained" while the pair was
    not composed); an attached body with a reversed channel is a tie of a support and the reversed channel, the
    true pair named in the verdict as not ruled out (screened: one step from its members' fits promises chi^2
    26, not fitted)."""
    results = {r.truth: r for r in blind.run(4, workers=2, truths=tuple(blind_truth.REVERSED_BESIDE))}
    assert not any(r.confident_and_wrong for r in results.values())
    belt = results["drive_belt+sensor_reversed"]
    assert belt.confident and belt.right
    scatter = results["isolator_scatter+sensor_reversed"]
    assert scatter.confident and scatter.right
    assert "isolator_scatter+sensor_reversed at corner[-x-y] & S1_x" in scatter.verdict
    assert "as good: corner[+x+y] & S1_x" in scatter.verdict
    body = results["added_mass+sensor_reversed"]
    assert body.kind == "tie" and body.tie == ("foundation+sensor_reversed",) and not body.confident
    assert "not ruled out: the pairs added_mass+sensor_reversed (screened, not fitted" in body.verdict
    text = blind.score(list(results.values())).text()
    assert "0 outside the catalogue" in text and "isolator_scatter+sensor_rev" in text


def test_a_scattered_isolator_beside_a_reversed_channel_is_not_named_confidently():
    """Found by `make bench-blind BLIND_CASES=264` on d3c59c6 (the study of a reversed channel beside an effect,
    seed 7, screen6 with shapes), the first run after the truth's shapes took their nominal modes' sign: isolator
    middle[-y] 25 % softer along its axis and in shear, channel 3 reversed. While the catalogue did not compose a
    scattered isolator with a reversed channel, an attached body of 103 kg 0.44 m out on the -y side with a
    reversed channel fitted the 36 data at chi^2 28.4 on 27 degrees of freedom (the next candidate 205) and was
    named with probability 1.00: confident and wrong (a strict xfail). With the pair fitted at each isolator with
    each of the reversal's screened channels, the true pair stands first and the attached body beside it fits
    within the uncertainty: a tie."""
    result = blind.run_case(7, "isolator_scatter+sensor_reversed", "shapes", "screen6")
    assert not result.confident and result.kind == "tie"
    assert result.tie[:2] == ("isolator_scatter+sensor_reversed", "added_mass+sensor_reversed")
    assert result.right


def test_two_turned_channels_are_not_named_a_misplaced_one_confidently():
    """Found on held-out seeds 528-791 (kid300 and kid300axes with shapes, 2026-12-01, e8cd3fe and later): seed 779
    on kid300axes, channels S3_x and S4_x turned by 0.33 and 0.28 rad, neither alone explaining the noise-free
    data. One channel misplaced at S3_x (its point 0.09 and 0.26 m off) fits the 36 data at chi^2 43.9 on 32
    degrees of freedom (p 0.08), and was named with probability 1.00 while the catalogue held no second channel
    of the same kind: confident and wrong (a strict xfail until two_sensors_turned). With two turned channels in
    the catalogue they fit at 32.5 on 30 at S3_x & S4_x, turns to 0.01 rad, and the verdict is a tie of the two
    (0.89 and 0.11, a pair's prior odds on the two turns); with one channel turned and off its point in the
    catalogue as well, that joins the tie (the misplaced channel first at 0.84)."""
    result = blind.run_case(779, "sensor_turned+sensor_turned", "shapes", "kid300axes")
    assert not result.confident_and_wrong
    assert result.tie == ("sensor_misplaced", "two_sensors_turned", "sensor_turned_misplaced")
    assert not result.confident


def test_a_support_frame_of_other_geometry_is_not_a_confident_wrong_verdict():
    """A frame on ground springs on the axes below isolators on the diagonals: the widened foundation
    represents it (its ground springs spread out and below), and the diagnosis ranks it in the tie."""
    data, truth = blind.make_case(12, "support_frame")
    report = diagnose_effects(campaign.parse(data))
    assert blind_truth.represented_by(truth.effect) == "foundation"
    assert report.significant and "foundation" in report.tie
    assert not report.confident or report.best.effect == "foundation"


def test_a_foundation_truth_built_apart_from_the_engine_is_diagnosed():
    data, truth = blind.make_case(18, "foundation")
    report = diagnose_effects(campaign.parse(data))
    assert report.significant and "foundation" in report.tie


@pytest.mark.parametrize(
    ("example", "kind", "seed", "truth"),
    [
        ("kid300-blind-belt.json", "confident", 20, "drive_belt"),
        ("kid300-blind-pair.json", "confident", 14, "isolator_scatter+cog_height"),
        ("kid300-blind-tie.json", "tie", 28, "support_frame"),
        ("kid300-blind-not-explained.json", "not explained", 16, "resilient_attachment"),
    ],
)
def test_the_readme_worked_examples_give_their_verdict_kinds(example, kind, seed, truth):
    """The README's examples of each verdict kind on a blind case (the paper's four frequencies, the fourth
    kind, 'no significant gap', are tested with the command line): campaigns as blind.example writes them."""
    path = Path(__file__).resolve().parents[1] / "examples" / example
    data = json.loads(path.read_text(encoding="utf-8"))
    made = blind.example(seed, truth)
    assert data["known"] == made["known"] and data["modes"].keys() == made["modes"].keys()
    assert data["sensors"] == made["sensors"]
    for label, mode in data["modes"].items():  # equal up to the rounding of another BLAS build
        assert mode["frequency"] == pytest.approx(made["modes"][label]["frequency"], rel=1e-12)
        assert mode["shape"] == pytest.approx(made["modes"][label]["shape"], abs=1e-9)
    report = diagnose_effects(campaign.parse(data))
    assert report.kind == kind
    if kind == "confident":
        assert report.best.effect == blind_truth.represented_by(truth)
    if kind == "tie":  # the support (the truth) fits as well as rotational stiffness, ranked first by its priors
        assert report.best.effect == "rotational_stiffness"
        assert "foundation" in [s.rival for s in report.alike()]
        assert any(note.startswith("the data fit frequency_dependent, foundation,") for note in report.notes)
    if kind == "not explained":  # its probabilities do not apply: no rival is said to fit as well (the pair
        # isolator_scatter+foundation would be by the fit alone)
        assert report.alike() == () and not any(note.startswith("the data fit") for note in report.notes)


def test_a_rival_whose_parameter_the_data_leave_undetermined_is_not_ruled_out():
    """Blind case (seed 218 with a support, genset8, shapes): a slab of 6300 kg on pads 330 MN/m. The support
    fits (chi^2 32.6 on 26 degrees of freedom) with its pads' shear ratio at 6 +- 200 (range 0.1-2): beyond the
    range, but not placed there by the data. Such a fit counted as ruled out, and the gravity preload (chi^2
    33.6) was named confidently; now both are in the tie. (Seed 182, a slab of 3300 kg, was the case until the
    truth's shapes took their nominal modes' sign: with its noise drawn on the other sign the support fits within
    its ranges.)"""
    data, _ = blind.make_case(218, "foundation", machine="genset8")
    report = diagnose_effects(campaign.parse(data))
    foundation = next(f for f in report.ranked if f.effect == "foundation")
    assert foundation.outside_range == ("found_shear",) and not foundation.placed_outside
    assert not report.confident and "foundation" in report.tie


def test_a_rival_that_fits_only_beyond_its_range_leaves_a_tie():
    """Fresh seed 4049, rectangular with frequencies only: one isolator scattered. A drive belt fits within the
    uncertainty (chi^2 6.4 for 1 degree of freedom) only with its stiffness and height beyond their plausible
    ranges, where the data leave them undetermined; held within them it misses (chi^2 12.3). It held a share of
    the tie's probability; now it is ruled out (probability 0, marked implausible, said in a note) and the truth
    stays in the tie."""
    data, _ = blind.make_case(4049, "isolator_scatter", kind="frequencies", machine="rectangular")
    report = diagnose_effects(campaign.parse(data))
    belt = next(f for f in report.ranked if f.effect == "drive_belt")
    quantile = scipy.stats.chi2.ppf(1 - DIAGNOSIS.fit_p_value, belt.n_data - belt.n_parameters)
    assert belt.outside_range and not belt.placed_outside and belt.chi2 < quantile  # fits within the uncertainty
    assert belt.probability == 0 and not belt.plausible and "held within it" in belt.implausible_reason
    assert "drive_belt" not in report.tie and "isolator_scatter" in report.tie
    assert any(note.startswith("drive_belt fits within the uncertainty only with") for note in report.notes)


def test_the_first_place_keeps_its_lead_though_it_fits_only_beyond_its_range():
    """Blind seed 6, skid1plane with damping ratios: a compliant support outside the catalogue support's ranges.
    The support fits within the uncertainty only beyond them and misses the data within them: the verdict is "not
    explained", with the support as its closest candidate (the right lead). Ruled out as its rivals are, it gave
    its place to a scattered isolator (tried, 4b4d64d, and taken back): the rule asks the rivals only."""
    data, _ = blind.make_case(6, "foundation", kind="damping", machine="skid1plane")
    report = diagnose_effects(campaign.parse(data))
    assert report.kind == "not explained" and report.best.effect == "foundation"
    assert report.best.outside_range and report.best.plausible


def test_a_rival_that_fits_only_beyond_its_range_leaves_the_tie():
    """Fresh seed 4048, skid1plane with damping ratios: the centre of mass higher. A support fits (chi^2 1.8
    for 2 degrees of freedom) only with its mass beyond its plausible range; held within it, chi^2 29. It kept
    the verdict a tie (cog_height 0.94): ruled out in the tie now, the verdict was confident and right. Since the
    catalogue has a tilted isolator (2026-12-02) that rival stays in the tie at 0.03 (chi^2 9.9 against 3.2 for
    cog_height): a tie with the truth first, the support still ruled out."""
    data, _ = blind.make_case(4048, "cog_height", kind="damping", machine="skid1plane")
    report = diagnose_effects(campaign.parse(data))
    assert report.best.effect == "cog_height" and report.best.probability > 0.95
    assert report.tie == ["cog_height", "isolator_tilted"] and report.kind == "tie"
    assert "foundation" not in report.tie
    assert any(note.startswith("foundation fits within the uncertainty only with") for note in report.notes)


def test_a_pair_that_fits_only_beyond_its_range_is_ruled_out_as_a_single_effect_is():
    """Fresh seed 4040, screen6 with shapes: a scattered isolator and the centre of mass moved. The pair of a
    scattered isolator and a support fits (chi^2 38.5 for 25 degrees of freedom) only with the support's mass
    beyond its plausible range; held within it, chi^2 52.6 (with the truth's shapes on LAPACK's sign: its depth,
    38.1 and 53.4). Pairs were not refitted within their ranges, so it kept the verdict a tie (the true pair at
    0.9996): ruled out now, the verdict is confident and right."""
    data, _ = blind.make_case(4040, "isolator_scatter+cog_height", kind="shapes", machine="screen6")
    report = diagnose_effects(campaign.parse(data))
    assert report.kind == "confident" and report.best.effect == "cog_height+isolator_scatter"
    ruled = "isolator_scatter+foundation fits within the uncertainty only with m_found beyond the plausible range"
    assert any(note.startswith(ruled) for note in report.notes)
    held = next(f for f in report.ranked if f.effect == "isolator_scatter+foundation")
    assert not held.plausible and held.probability == 0


def test_a_part_that_alone_explains_the_noise_free_data_is_found_by_a_full_search():
    """Blind case (seed 195, screen6, shapes): a support frame with one isolator 7 % stiffer in shear. Alone,
    the support explains the noise-free data within their uncertainty, and the harness counts it right, but
    only from a fit that searches the spread starts again: refitted warm from the noisy fit without them, it
    stopped in a worse basin (tried for speed and taken back, since it moved truth in the tie on screen6 from
    97.9 to 97.4 %)."""
    result = blind.run_case(195, "support_frame+isolator_scatter", "shapes", "screen6")
    assert result.acceptable == ("isolator_scatter+foundation", "foundation")
    assert result.ranked[0] == "foundation" and result.right


# Found on held-out seeds (`make bench-blind BLIND_CASES=264 BLIND_FIRST_SEED=264`, 2026-11-25): the four
# confident and wrong verdicts of 4752 cases the diagnosis was not developed on (seeds 0-263 gave none). Pinned
# so the limits stay visible. The fourth, a stiff heavy slab under genset8 (seed 314) named a gravity preload,
# is mended: test_candidates.py,
# test_a_support_whose_free_fit_leaves_its_range_is_refitted_within_it_and_stays_a_rival; two are mended by the
# confident verdict's stricter goodness of fit (DiagnosisSettings.confident_p_value, the tests below); the
# third, hardening isolators named a belt (seed 325), is a tie since the catalogue has hardening rubber.
@pytest.mark.parametrize(
    ("seed", "tie"),
    [
        (325, ("rubber_hardening", "drive_belt", "added_mass", "foundation")),
        (4179, ("rubber_hardening", "drive_belt")),
        (225, ("rubber_hardening", "drive_belt")),
    ],
)
def test_hardening_isolators_of_one_level_are_a_tie_with_the_belt_that_mimics_them(seed, tie):
    """Rectangular with shapes, gently hardening isolators (gamma 0.05-0.11). Before the catalogue had hardening
    rubber they were outside it and a drive belt fitted at noise level: held-out seed 325 (chi^2 34 on 31) was
    named a belt confidently until the support became its rival; fresh seed 4179 (chi^2 43.9 on 31, p = 0.063:
    `blind.run` of seeds 4000-4299, the one confident and wrong verdict of 5400) and seed 225 (chi^2 17.3 on 31,
    its support rival ruled out by the tie rule: `make bench-blind BLIND_CASES=264` on e64daf6, the one of 4752)
    were confident and wrong, pinned as strict xfails. Hardening rubber (rubber_hardening) now fits them at noise
    level as well: a tie, hardening first, never confident, as one excitation level allows (the amplitude that
    would tell them apart is not in the campaign; test_levels)."""
    result = blind.run_case(seed, "nonlinear_isolator", "shapes", "rectangular")
    assert result.kind == "tie" and not result.confident
    assert result.right and result.tie == tie


def test_a_part_that_fits_only_marginally_is_not_named_confidently_and_the_pair_is_fitted():
    """Held-out seed 390, kid300 with damping ratios: one isolator scattered and the centre of mass higher. The
    height alone fits at chi^2 18.3 on 7 degrees of freedom (p = 0.011): not rejected, but no fit to be named
    confidently on; the pairs are fitted beside it and the true pair enters the tie (it was confident and wrong
    with the lenient test alone)."""
    result = blind.run_case(390, "isolator_scatter+cog_height", "damping", "kid300")
    assert result.kind == "tie" and not result.confident
    assert result.ranked[0] == "cog_height"
    assert "cog_height+isolator_scatter" in result.tie


def test_a_turned_and_misplaced_channel_is_not_named_turned_confidently():
    """Held-out seed 307, genset8 with shapes: channel S1_x turned by 0.29 rad and mounted 24 cm off its point.
    The turn alone fits at chi^2 46.4 on 30 degrees of freedom (p = 0.029), the turn at the edge of its range:
    the verdict names the channel's turn first, not confidently (it was confident with the lenient test alone),
    and the two slips on the channel (sensor_turned_misplaced, in the catalogue since) are in the tie."""
    result = blind.run_case(307, "sensor_turned+sensor_misplaced", "shapes", "genset8")
    assert result.kind == "tie" and not result.confident
    assert result.ranked[0] == "sensor_turned" and "sensor_turned_misplaced" in result.tie


def test_reliability_per_first_ranked_candidate_finds_the_candidate_whose_probabilities_miss():
    """Two candidates ranked first at 0.8: one right as often as stated, one never: the pooled table sees a
    miss, the per-candidate rows say whose (p nil for the one never right, large for the calibrated one)."""
    rng = np.random.default_rng(3)
    calibrated = [
        blind.CaseResult("cog_height" if ok else "com_offset", ("cog_height",), (), True, False, True, 0.9, "tie", 0.8)
        for ok in rng.random(40) < 0.8
    ]
    never = [
        blind.CaseResult("support_frame", ("rotational_stiffness",), (), True, False, True, 0.9, "tie", 0.8)
        for _ in range(20)
    ]
    rows = {row[0]: row for row in blind.score(calibrated + never).by_candidate}
    assert rows["rotational_stiffness"][1:4] == pytest.approx((20, 0.8, 0.0)) and rows["rotational_stiffness"][4] == 0
    name, count, stated, observed, p = rows["cog_height"]
    assert count == 40 and stated == pytest.approx(0.8) and abs(observed - 0.8) < 0.15 and p > 0.05
    # a 'not explained' verdict states no probability and is not counted
    quiet = blind.CaseResult("cog_height", ("cog_height",), (), True, False, True, 0.9, "not explained", 0.3)
    assert [row[:2] for row in blind.score([*never, quiet]).by_candidate] == [("rotational_stiffness", 20)]
    assert "rotational_stiffness" in blind.score(calibrated + never).text()


def _verdicts(stated: float, right: int, wrong: int, alike: tuple[str, ...] = ()) -> list[blind.CaseResult]:
    """Tie verdicts naming the height of the centre of mass at ``stated``: right on ``right`` of them; ``alike``:
    the rivals the data fit as well."""
    return [
        blind.CaseResult(truth, ("cog_height",), (), True, False, True, 0.9, "tie", stated, alike=alike)
        for truth in ["cog_height"] * right + ["com_offset"] * wrong
    ]


def test_the_reliability_by_what_the_first_place_rests_on_splits_the_verdicts_where_a_rival_fits_alike():
    """Verdicts with a rival the data fit as well (CaseResult.alike) and verdicts without, scored apart: counts,
    mean stated, share right by hand, and the rows printed under the reliability table."""
    on_priors = _verdicts(0.8, 6, 4, alike=("com_offset",))
    on_data = _verdicts(0.99, 20, 0)
    score = blind.score(on_priors + on_data)
    rows = {row[0]: row[1:4] for row in score.by_basis}
    assert rows[blind.BASIS_PRIORS] == (10, pytest.approx(0.8), pytest.approx(0.6))
    assert rows[blind.BASIS_DATA] == (20, pytest.approx(0.99), pytest.approx(1.0))
    assert [row[0] for row in score.by_basis] == [blind.BASIS_DATA, blind.BASIS_PRIORS]  # most verdicts first
    assert blind.BASIS_PRIORS in score.text() and "first place rests on" in score.text()


def test_the_reliability_diagram_draws_the_reliability_tables_verdicts_per_kind_split_by_basis(tmp_path):
    """reliability_panels takes the verdicts the reliability table scores (truths the catalogue represents,
    verdicts that state a probability) per campaign kind and splits them as by_basis does; the diagram of them is
    written (make bench draws it under out/bench)."""
    from mountid.report.figures import reliability_figure

    on_priors = _verdicts(0.8, 6, 4, alike=("com_offset",))
    on_data = _verdicts(0.99, 20, 0)
    frequencies = [replace(r, campaign="frequencies") for r in _verdicts(0.6, 3, 2)]
    left_out = [
        replace(on_data[0], truth="resilient_attachment"),  # outside the catalogue: scored by honesty
        replace(on_data[0], kind="not explained"),  # states no probability
    ]
    panels = blind.reliability_panels(on_priors + on_data + frequencies + left_out, "all, ")
    assert list(panels) == ["all, shapes", "all, frequencies"]
    stated, right = panels["all, shapes"][blind.BASIS_PRIORS]
    assert len(stated) == 10 and stated.mean() == pytest.approx(0.8) and right.sum() == 6
    stated, right = panels["all, shapes"][blind.BASIS_DATA]
    assert len(stated) == 20 and right.sum() == 20
    stated, right = panels["all, frequencies"][blind.BASIS_DATA]
    assert len(stated) == 5 and right.sum() == 3 and not len(panels["all, frequencies"][blind.BASIS_PRIORS][0])
    path = reliability_figure(panels, tmp_path / "reliability.png", blind.RELIABILITY_BINS, "hand-made verdicts")
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_proper_scores_prefer_sharp_calibrated_probabilities_to_a_flat_statement_the_bins_cannot_fault():
    """Half the verdicts stated at 0.95 and right in 0.9, half at 0.55 and right in 0.6: binned error 0.05. The
    same verdicts all stated at 0.75 (right in 0.75): binned error 0, yet they say less; the log loss and the
    Brier score (hand-computed here) rank the sharp ones better."""
    sharp = blind.score(_verdicts(0.95, 45, 5) + _verdicts(0.55, 30, 20))
    flat = blind.score(_verdicts(0.75, 75, 25))
    assert sharp.calibration_error == pytest.approx(0.05) and flat.calibration_error == pytest.approx(0.0)
    assert sharp.log_loss == pytest.approx(
        -(45 * math.log(0.95) + 5 * math.log(0.05) + 30 * math.log(0.55) + 20 * math.log(0.45)) / 100
    )
    assert flat.log_loss == pytest.approx(-(75 * math.log(0.75) + 25 * math.log(0.25)) / 100)
    assert sharp.brier == pytest.approx((45 * 0.05**2 + 5 * 0.95**2 + 30 * 0.45**2 + 20 * 0.55**2) / 100)
    assert flat.brier == pytest.approx(0.75 * 0.25)
    assert sharp.log_loss < flat.log_loss and sharp.brier < flat.brier
    assert f"log loss {sharp.log_loss:.3f}, Brier {sharp.brier:.3f}" in sharp.text()
    # a verdict stated at 1 and wrong costs ln(1 / LOG_LOSS_FLOOR), not infinity; no verdict, no score
    assert blind.score(_verdicts(1.0, 0, 1)).log_loss == pytest.approx(-math.log(blind.LOG_LOSS_FLOOR))
    assert math.isnan(blind.score([]).log_loss)


def test_a_score_without_an_identifiable_case_says_so_and_prints_no_nan():
    """genset8 with frequencies only has no identifiable case: the score's text and the bench's row say that the
    top-1 target cannot be shown (they printed nan%)."""
    import re

    from benchmarks.diagnosis import _row

    results = [blind.CaseResult("cog_height", ("cog_height",), (), True, False, False, 0.9, "tie", 0.8)] * 3
    score = blind.score(results)
    assert score.n_identifiable == 0 and "top-1 (no case)" in score.missed()
    assert "none is identifiable" in score.text()
    assert not re.search(r"\bnan\b", _row("genset8", "frequencies", score).split("missed")[0])


def test_a_confident_verdict_does_not_follow_rounding():
    """kid300axes seed 1 with damping ratios, the centre of mass off the axis: confident and right as made; with
    every measured frequency moved by 4 eps (benchmarks.rounding) an attached mass, fitted with 8 parameters to
    12 data, stopped at 381 +- 549 kg (beyond its plausible range, undetermined), fitted within the uncertainty and
    kept the verdict a tie (as made, its fit stopped at chi^2 318 and was rejected). Held within its range it fits
    at chi^2 96: ruled out (candidates._fits_only_beyond_range), and both runs are confident and right. It failed
    as a strict xfail before (docs/validation.md, "Verdicts under rounding")."""
    from benchmarks.rounding import verdicts

    made, rounded = verdicts(1, "com_offset", "damping", "kid300axes")
    assert made[:2] == ("confident", "com_offset")
    assert rounded[:2] == made[:2]


def test_a_candidate_the_frequencies_cannot_test_is_not_named_confidently():
    """kid300axes seed 180 with damping ratios, a body of 74 kg on its own springs (43.7 rad/s, outside the
    catalogue): the attached mass (six parameters, with the two stiffnesses eight) fits the six frequencies by
    construction and the ratios within their noise, at probability 1.00. The frequencies cannot test it
    (candidates.tested): a verdict that names it, never confidently, and says why."""
    r = blind.run_case(180, "resilient_attachment", "damping", "kid300axes")
    assert r.ranked[0] == "added_mass" and r.probability > 0.99
    assert r.kind == "tie" and not r.confident_and_wrong
    assert "cannot test added_mass" in r.verdict


def test_the_harness_draws_blind_cases_on_a_description_of_ones_own():
    """A description file in place of a shipped machine (benchmarks.diagnosis --machines, BLIND_MACHINES): its
    truths are assembled from the file apart from the engine, and the diagnosis is scored on it. central5 (a
    central isolator whose vertical stiffness moves z alone) with its centre of mass off the axes, measured with
    shapes: named confidently and right; the bench's table names it by its file's stem."""
    from benchmarks.diagnosis import _row

    path = str(Path(__file__).parent / "data" / "central5.toml")
    truth = blind_truth.TruthMachine.of(path)
    assert truth.name == path and truth.unknown == ("c_h", "c_v", "c_c")
    assert blind_truth.TruthMachine.of("kid300").unknown == blind_truth.TruthMachine("kid300").unknown
    result = blind.run_case(1, "com_offset", "shapes", path)
    assert result.kind == "confident" and result.ranked[0] == "com_offset" and result.identifiable
    assert _row(path, "shapes", blind.score([result])).startswith("central5    shapes")


def test_a_machine_without_damping_has_no_campaigns_of_damping_ratios(capsys):
    """tests/data/press.toml describes no damping: its every true damping ratio is zero (rounding made one
    -4e-18, which the campaign's schema refused mid-run). The harness draws no such campaign on it, and asked for
    one says why, as the benchmark's table does."""
    from benchmarks.diagnosis import _table

    path = str(Path(__file__).parent / "data" / "press.toml")
    assert not blind.measures_kind(path, "damping") and blind.measures_kind(path, "shapes")
    assert blind.measures_kind("kid300", "damping")
    drawn = blind.cases(2, 0, blind.CAMPAIGN_KINDS, ("kid300", path))
    assert {(m, k) for _, _, k, m in drawn} == {
        *(("kid300", k) for k in blind.CAMPAIGN_KINDS),
        *((path, k) for k in blind.CAMPAIGN_KINDS if k != "damping"),
    }
    with pytest.raises(InputError, match=r"^kind: .*press.toml: the machine has no damping: a campaign of damping"):
        blind.make_case(0, "none", kind="damping", machine=path)
    assert _table([], ("damping",), (path,)) == {}
    assert capsys.readouterr().out.splitlines()[1] == (
        "press       damping     no cases: the machine has no damping: a campaign of damping ratios would measure zeros"
    )


def test_a_machine_with_as_many_unknowns_as_distinct_modes_is_refused_before_any_case(monkeypatch):
    """A diagnosis fits the unknowns and holds one frequency out in turn, so it needs one distinct frequency more
    than unknowns: on tests/data/plant16.toml (six unknowns, six distinct modes) the benchmark timed kid300 and then
    stopped with a traceback in plant16's warm-up (campaign.parse: '7 needed'). The harness and the benchmark now
    refuse such a machine up front, saying why, and a campaign on it names the way out: the frequencies to fit
    and mode shapes to test the model (here kid300 with its two lengths taken unknown beside its stiffnesses)."""
    from benchmarks import diagnosis as bench

    kid300 = Machine.resolve("kid300")
    assert blind.undiagnosable_because(kid300) is None and bench._refused("kid300") is None
    square = copy.copy(kid300)
    square.unknown = ("c_xy", "c_z", "L_xy", "L_z")
    reason = (
        "kid300 has 4 distinct modes for 4 unknowns: the blind campaigns hold one frequency out of the fit in turn "
        '(5 needed); only a campaign that names the frequencies to fit ("fit") can be diagnosed on it, from its '
        "mode shapes"
    )
    assert blind.undiagnosable_because(square) == reason
    monkeypatch.setattr(Machine, "resolve", classmethod(lambda cls, name: square))
    assert bench._refused("kid300") == reason
    with pytest.raises(InputError, match=f"^machine: {re.escape(reason)}$"):
        blind.make_case(0, "none", machine="kid300")
    paper = json.loads((Path(__file__).parents[1] / "examples" / "kid300-paper.json").read_text())
    del paper["fit"], paper["known"]["L_xy"], paper["known"]["L_z"]
    with pytest.raises(InputError, match="^modes: .*5 needed; kid300 has no more distinct modes: name the freq"):
        campaign.parse(paper)
    monkeypatch.undo()
    assert bench._refused("no_such_machine").startswith("machine: unknown machine 'no_such_machine'")
