"""Pairs of candidate effects (mountid.effects.pair, mountid.diagnosis.strategies.Composite): which pairs compose,
their matrices against the blind harness's independent assembly, their analytic Jacobian against a central
difference, round trips, and the diagnosis that reports a pair when no single effect explains the data."""

from __future__ import annotations

import numpy as np
import pytest
from test_candidates import SHAPE_SIGMA, SIGMA_REL, UNKNOWN, _campaign_from, _layout

from mountid.diagnosis.campaign import parse
from mountid.diagnosis.candidate_model import CandidateModel
from mountid.diagnosis.candidates import as_good_clause, diagnose_effects, pair_starts
from mountid.diagnosis.fitting import Data, _residual_function, fit_candidate
from mountid.diagnosis.jacobian import jacobian
from mountid.diagnosis.strategies import strategy
from mountid.effects import EFFECTS, Pair, pair, pair_name
from mountid.validation import blind, blind_truth


def _pair(a: str, b: str) -> Pair:
    both = pair(EFFECTS[a], EFFECTS[b])
    assert both is not None
    return both


def _campaign(both: Pair, values: dict[str, float], isolator: int | None = None) -> dict:
    """Noise-free campaign of all six modes from the pair's own model."""
    return _campaign_from(both, values, isolator)


def _true_pair_named(
    seed: int, machine: str, variant: str, scatter: str, confident: bool = True, kind: str = "shapes"
) -> None:
    """The blind truth of a scattered isolator with the centre of mass moved (a campaign of ``kind``) is diagnosed
    as that pair at ``variant`` (confidently, where ``confident``; else the verdict's kind is not checked), with
    its ``scatter`` parameter and height within three standard deviations of the truth's."""
    data, truth = blind.make_case(seed, "isolator_scatter+cog_height", kind=kind, machine=machine)
    report = diagnose_effects(parse(data))
    best = report.best
    assert report.confident or not confident
    assert best.effect == "cog_height+isolator_scatter" and best.variant == variant
    size = truth.size["s_v" if scatter == "scatter_axial" else "s_h"]
    assert best.parameters[scatter] == pytest.approx(size, abs=3 * best.std[scatter])
    assert best.parameters["dz_com"] == pytest.approx(truth.size["dz"], abs=3 * best.std["dz_com"])


PAIRS = {
    ("cog_height", "isolator_scatter"): ({"dz_com": 0.04, "scatter_shear": 0.0, "scatter_axial": 0.25}, 1),
    ("foundation", "added_mass"): (
        {
            "m_found": 800.0,
            "k_found": 2e7,
            "found_shear": 0.4,
            "found_spread": 2.0,
            "found_aspect": 1.0,
            "found_depth": 0.15,
            "m_added": 60.0,
            "x_added": 0.2,
            "y_added": -0.1,
            "h_added": 0.3,
            "g_added": 0.1,
            "a_added": 0.0,
        },
        None,
    ),
    ("foundation", "isolator_scatter"): (
        {
            "m_found": 600.0,
            "k_found": 3e7,
            "found_shear": 0.5,
            "found_spread": 1.5,
            "found_aspect": 1.3,
            "found_depth": 0.2,
            "scatter_shear": -0.2,
            "scatter_axial": 0.3,
        },
        1,
    ),
    ("frequency_dependent", "sensor_error"): (
        {"rubber_strength": 0.2, "rubber_corner": 1.1, "sensor_yaw": 0.02, "sensor_dz": 0.08},
        None,
    ),
    ("rotational_stiffness", "drive_belt"): ({"k_bend": 3e3, "k_torsion": 2e3, "k_belt": 2e4, "h_belt": 0.2}, None),
}


def test_which_pairs_compose_and_how_they_are_named():
    assert pair(EFFECTS["isolator_scatter"], EFFECTS["cog_height"]).name == "cog_height+isolator_scatter"
    assert pair_name(["isolator_scatter", "cog_height"]) == "cog_height+isolator_scatter"
    for a, b in [("com_offset", "cog_height"), ("foundation", "rotational_stiffness"), ("damping", "drive_belt")]:
        assert pair(EFFECTS[a], EFFECTS[b]) is None, (a, b)
    assert pair(EFFECTS["drive_belt"], EFFECTS["drive_belt"]) is None
    both = _pair("foundation", "added_mass")
    support = [p.name for p in EFFECTS["foundation"].parameters]
    assert [p.name for p in both.parameters][: len(support)] == support


def test_pair_matrices_equal_the_blind_truths_assembly_apart_from_the_engine():
    """cog_height + one isolator's axial and shear scatter, composed from the engine's matrices, against the
    same machine assembled in numpy by the blind harness (blind_truth.truth_matrices)."""
    truth_machine = blind_truth.TruthMachine("kid300")
    size = {"dz": 0.04, "s_h": -0.1, "s_v": 0.25, "isolator": 2}
    truth = blind_truth.Truth("isolator_scatter+cog_height", size, dict(UNKNOWN))
    m, c, _ = blind_truth.truth_matrices(truth_machine, truth)
    campaign = parse(
        _campaign(_pair("cog_height", "isolator_scatter"), PAIRS[("cog_height", "isolator_scatter")][0], 2)
    )
    model = CandidateModel(campaign, _pair("cog_height", "isolator_scatter"), 2)
    values = {**model.known, **UNKNOWN, "dz_com": 0.04, "scatter_shear": -0.1, "scatter_axial": 0.25}
    m2, c2, _ = model.strategy.matrices(model, values)
    assert np.allclose(m2, m, rtol=1e-13, atol=1e-13 * np.max(np.abs(m)))
    assert np.allclose(c2, c, rtol=1e-13, atol=1e-12 * np.max(np.abs(c)))


def test_an_isolator_scatter_on_the_support_acts_between_body_and_support():
    """foundation + isolator_scatter: the scattered isolator's change of C is its stiffness between the body
    point r and the support point r - c (c the feet's centre, where the support's coordinates refer to),
    T^T dK T with T = [J(r), -J(r - c)], assembled in numpy by the blind harness's rigid-body Jacobian and
    isolator tensors (blind_truth) apart from the engine; M is the foundation's."""
    both = _pair("foundation", "isolator_scatter")
    values, isolator = PAIRS[("foundation", "isolator_scatter")]
    model = CandidateModel(parse(_campaign(both, values, isolator)), both, isolator)
    at = {**model.known, **UNKNOWN, **values}
    m, c, _ = model.strategy.matrices(model, at)
    m0, c0, _ = strategy(EFFECTS["foundation"]).matrices(model, at)
    iso = blind_truth.TruthMachine("kid300").isolators(at)
    centre = np.mean([i.point for i in iso], axis=0)
    k = iso[isolator].tensor(iso[isolator].stiffness)
    a = iso[isolator].axis
    axial = (a @ k @ a) * np.outer(a, a)
    change = values["scatter_shear"] * (k - axial) + values["scatter_axial"] * axial
    t = np.hstack([blind_truth._jac(iso[isolator].point), -blind_truth._jac(iso[isolator].point - centre)])
    assert m.shape == c.shape == (12, 12)
    assert np.array_equal(m, m0)
    assert np.allclose(c - c0, t.T @ change @ t, rtol=1e-12, atol=1e-12 * np.max(np.abs(c0)))
    assert np.max(np.abs((c - c0)[:6, 6:])) > 0.1 * np.max(np.abs(c - c0))  # the coupling to the support


@pytest.mark.parametrize("names", list(PAIRS), ids="+".join)
def test_pair_jacobian_matches_a_central_difference(names):
    both = _pair(*names)
    values, isolator = PAIRS[names]
    campaign = parse(_campaign(both, values, isolator))
    model = CandidateModel(campaign, both, isolator)
    data = Data(campaign, model.length)
    fun, _ = _residual_function(model, data, None)
    theta = model.vector({**UNKNOWN, **values}) + np.random.default_rng(5).normal(0, 0.01, len(model.parameter_names))
    analytic = jacobian(model, data, theta)
    assert analytic is not None
    # the step balances the central difference's truncation (h^2) against the residuals' rounding (amplified
    # 1/h): for the support with an added mass, the largest error relative to the largest entry is 4e-7 at
    # h = 1e-4 (truncation), 1.5e-7 at 1e-5, 1.8e-6 at 1e-6 and 8e-6 at 1e-7 (rounding, in one shape row)
    h = 1e-5
    numeric = np.column_stack([(fun(theta + h * e) - fun(theta - h * e)) / (2 * h) for e in np.eye(len(theta))])
    numeric = numeric[: len(analytic)]
    assert np.max(np.abs(analytic - numeric)) <= 1e-6 * np.max(np.abs(numeric))


@pytest.mark.parametrize(
    "names",
    [("cog_height", "isolator_scatter"), ("rotational_stiffness", "drive_belt"), ("foundation", "isolator_scatter")],
)
def test_a_pair_fits_its_own_data_back(names):
    """From its members' single fits (candidates.pair_starts). The rotational stiffness with a belt has a second
    minimum within the noise (chi^2 2.8 of 36 data: the belt at -0.12 m and 26 % stiffer): a fit stops at the
    noise level, so there only the fit is asserted, not the parameters."""
    both = _pair(*names)
    values, isolator = PAIRS[names]
    campaign = parse(_campaign(both, values, isolator))
    model = CandidateModel(campaign, both, isolator)
    singles = [fit_candidate(campaign, e, isolator if e.kind == "isolator" else None) for e in both.members]
    assert min(f.chi2 for f in singles) > 100  # neither member alone
    fit = fit_candidate(campaign, both, isolator, starts=list(pair_starts(model, *singles).all))
    if names == ("rotational_stiffness", "drive_belt"):
        assert fit.chi2 < 5
        return
    if names == ("foundation", "isolator_scatter"):
        # the support 16 times as stiff as the isolators: its mass barely moves the modes (the fit stops at
        # chi^2 0.001 of 36 data with it at 400 kg for 600); the isolator and its scatter are determined
        assert fit.chi2 < 0.01 and fit.variant == campaign.machine.module.ISOLATORS[isolator]
        for name in ("scatter_shear", "scatter_axial", *UNKNOWN):
            assert fit.parameters[name] == pytest.approx({**UNKNOWN, **values}[name], rel=0.02), name
        return
    assert fit.chi2 < 1e-3
    for name, value in {**UNKNOWN, **values}.items():
        assert fit.parameters[name] == pytest.approx(value, rel=1e-3, abs=1e-5), name


SCATTER_REVERSED = {"scatter_shear": -0.2, "scatter_axial": 0.3}
"""One isolator 20 % softer in shear and 30 % stiffer along its axis, beside a reversed channel (no parameter)."""


def _scatter_reversed(where: str) -> tuple[dict, int]:
    """Noise-free frequencies and shapes of kid300 with one isolator scattered (SCATTER_REVERSED) and one channel
    of the 12-channel layout reversed, the pair at ``where`` ('isolator & channel'); and that variant's index."""
    both = _pair("isolator_scatter", "sensor_reversed")
    data = _campaign_from(None, {})
    data["sensors"] = _layout()
    variant = strategy(both).variants(parse(data)).index(where)
    model = CandidateModel(parse(data), both, variant)
    pred = model.predict(model.vector({**UNKNOWN, **SCATTER_REVERSED}))
    for label, w, shape in zip(model.labels, pred.frequencies, pred.shapes, strict=True):
        s = np.array(shape, dtype=float)
        s[3:] /= model.length
        data["modes"][label].update(frequency=float(w), uncertainty=SIGMA_REL * float(w), shape=s.tolist())
    return data, variant


def test_a_scattered_isolator_beside_a_reversed_channel_acts_at_its_isolator_and_its_channel():
    """Both members act per variant (Composite, MemberView): the pair's variants are every isolator with every
    channel, and at one of them its stiffness is the scattered isolator's alone at that isolator, its shapes the
    layout read with that channel reversed, each member at its own variant."""
    both = _pair("isolator_scatter", "sensor_reversed")
    data, variant = _scatter_reversed("corner[+x-y] & S3_y")
    campaign = parse(data)
    composite = strategy(both)
    isolators = campaign.machine.module.ISOLATORS
    channels = [c.name for c in campaign.sensors]
    assert composite.variants(campaign) == tuple(f"{i} & {c}" for i in isolators for c in channels)
    isolator, channel = isolators.index("corner[+x-y]"), channels.index("S3_y")
    assert composite.member_variants(campaign, variant) == (isolator, channel)
    model = CandidateModel(campaign, both, variant)
    alone = CandidateModel(campaign, EFFECTS["isolator_scatter"], isolator)
    reversed_alone = CandidateModel(campaign, EFFECTS["sensor_reversed"], channel)
    values = {**model.known, **UNKNOWN, **SCATTER_REVERSED}
    m, c, _ = model.strategy.matrices(model, values)
    m1, c1, _ = alone.strategy.matrices(alone, values)
    assert np.array_equal(m, m1)
    assert np.allclose(c, c1, rtol=1e-13, atol=1e-13 * np.max(np.abs(c1)))
    vectors = np.random.default_rng(3).normal(size=(6, 6))
    shapes = model.strategy.shapes(model, values, vectors)
    assert np.array_equal(shapes, reversed_alone.strategy.shapes(reversed_alone, values, vectors))
    assert not np.allclose(shapes, vectors, atol=0.1)  # the reversal reads otherwise than the body moves


def test_a_scattered_isolator_beside_a_reversed_channel_jacobian_matches_a_central_difference():
    both = _pair("isolator_scatter", "sensor_reversed")
    data, variant = _scatter_reversed("corner[-x+y] & S2_z")
    campaign = parse(data)
    model = CandidateModel(campaign, both, variant)
    fit_data = Data(campaign, model.length)
    fun, _ = _residual_function(model, fit_data, None)
    theta = model.vector({**UNKNOWN, **SCATTER_REVERSED}) + np.random.default_rng(6).normal(0, 0.01, 4)
    analytic = jacobian(model, fit_data, theta)
    assert analytic is not None
    h = 1e-6
    numeric = np.column_stack([(fun(theta + h * e) - fun(theta - h * e)) / (2 * h) for e in np.eye(len(theta))])
    assert np.max(np.abs(analytic - numeric[: len(analytic)])) <= 1e-6 * np.max(np.abs(numeric))


def test_a_scattered_isolator_beside_a_reversed_channel_fits_its_own_data_back():
    """At its isolator and channel from its members' single fits there (candidates.pair_starts takes each
    member's fit at its own part of the pair's variant); neither member alone fits."""
    both = _pair("isolator_scatter", "sensor_reversed")
    where = "corner[-x+y] & S2_z"
    data, variant = _scatter_reversed(where)
    campaign = parse(data)
    model = CandidateModel(campaign, both, variant)
    channel = [c.name for c in campaign.sensors].index("S2_z")
    scatter = fit_candidate(campaign, EFFECTS["isolator_scatter"], 1)
    reversal = fit_candidate(campaign, EFFECTS["sensor_reversed"], channel)
    assert min(scatter.chi2, reversal.chi2) > 100
    fit = fit_candidate(campaign, both, variant, starts=list(pair_starts(model, scatter, reversal, where).all))
    assert fit.variant == where and fit.chi2 < 1e-3
    for name, value in {**UNKNOWN, **SCATTER_REVERSED}.items():
        assert fit.parameters[name] == pytest.approx(value, rel=1e-3, abs=1e-5), name


def test_the_diagnosis_reports_a_pair_when_no_single_effect_explains():
    """A centre of mass 4 cm high and one isolator 25 % stiffer along its axis: no single candidate fits, the
    pair does, at the right isolator, and the verdict names both."""
    both = _pair("cog_height", "isolator_scatter")
    values, isolator = PAIRS[("cog_height", "isolator_scatter")]
    data = _campaign(both, values, isolator)
    rng = np.random.default_rng(8)
    for m in data["modes"].values():
        m["frequency"] *= 1 + SIGMA_REL * rng.standard_normal()
        m["shape"] = (np.array(m["shape"]) + SHAPE_SIGMA * rng.standard_normal(6)).tolist()
    report = diagnose_effects(parse(data))
    best = report.best
    assert best.effect == "cog_height+isolator_scatter" and best.variant == "corner[-x+y]"
    assert report.confident and "cog_height+isolator_scatter" in report.verdict
    assert best.parameters["scatter_axial"] == pytest.approx(0.25, abs=3 * best.std["scatter_axial"])


def test_a_softer_isolator_elsewhere_than_the_best_single_fit_is_found_in_a_pair():
    """Blind case (seed 116, rectangular, shapes): the centre of mass 4 cm low and isolator corner[-x-y] 37 %
    softer along its axis. The scatter alone fits best 42 % stiffer at corner[-x+y]; the other isolators started
    from that fit stayed stiffer (corner[-x-y]: chi^2 13309), and the pair screened there from it promised
    nothing. Started from the better of that fit and its mirror image, corner[-x-y] fits softer (chi^2 1229)
    and the pair, screened from it, is found and fitted at noise level."""
    data, truth = blind.make_case(116, "isolator_scatter+cog_height", machine="rectangular")
    report = diagnose_effects(parse(data))
    single = next(f for f in report.ranked if f.effect == "isolator_scatter")
    at = dict(zip(single.state.variants_by_fit, single.state.variant_parameters, strict=True))
    assert at["corner[-x-y]"]["scatter_axial"] < 0
    best = report.best
    assert best.effect == "cog_height+isolator_scatter" and best.variant == "corner[-x-y]"
    assert best.parameters["scatter_axial"] == pytest.approx(truth.size["s_v"], abs=3 * best.std["scatter_axial"])


def test_pairs_are_screened_by_the_promise_with_its_parameters_counted():
    """Blind case (seed 136, genset8, shapes): the centre of mass 3 cm low and one isolator 6 % stiffer in
    shear. Ten pairs promise chi^2 25-31, most of them with the added mass (10-14 parameters); the true pair
    (7 parameters) promised 28.8 and ranked sixth of five fitted. Ranked by the promise's BIC it is fitted, and
    it is first."""
    data, _ = blind.make_case(136, "isolator_scatter+cog_height", machine="genset8")
    report = diagnose_effects(parse(data))
    assert report.best.effect == "cog_height+isolator_scatter" and "cog_height+isolator_scatter" in report.tie


def test_a_pair_is_screened_from_all_its_starts_and_fitted_past_a_minimum_above_noise_level():
    """Blind case (seed 76, kid300, frequencies and damping ratios): the centre of mass 2 cm high and isolator
    corner[-x-y] 21 % softer along its axis. Screened from its members' fits alone the pair promised chi^2 185
    and was not fitted, and the scatter with stiffening rubber (chi^2 8.2) was named confidently, probability
    1.0. Both members' fitted values together promise chi^2 3.4: screened from all its starts, the pair is
    fitted. Its first start stops at chi^2 26 on five degrees of freedom, which passed for noise level while
    every residual row counted (fitting.noise_level); the next start reaches the truth."""
    data, truth = blind.make_case(76, "isolator_scatter+cog_height", kind="damping")
    report = diagnose_effects(parse(data))
    best = report.best
    assert best.effect == "cog_height+isolator_scatter" and best.chi2 < 10
    assert best.parameters["scatter_axial"] == pytest.approx(truth.size["s_v"], abs=3 * best.std["scatter_axial"])
    assert best.parameters["dz_com"] == pytest.approx(truth.size["dz"], abs=3 * best.std["dz_com"])


def test_a_confident_pair_stands_only_once_every_leaner_screened_pair_is_fitted():
    """Blind case (seed 214, screen6, shapes): isolator corner[+x-y] 5.5 % stiffer along its axis and the centre
    of mass 6.7 cm high. The true pair promised chi^2 1204 from its members' fits (the scatter alone runs to the
    edge of its range) and was not fitted; the centre of mass with an added mass (9 parameters, chi^2 37) was
    named confidently, probability 1.0. Fitted after all, the true pair (6 parameters) reaches chi^2 29: a tie."""
    data, truth = blind.make_case(214, "isolator_scatter+cog_height", machine="screen6")
    report = diagnose_effects(parse(data))
    assert not report.confident and "cog_height+isolator_scatter" in report.tie
    fit = next(f for f in report.ranked if f.effect == "cog_height+isolator_scatter")
    assert fit.variant == "corner[+x-y]" and fit.chi2 < 35
    assert fit.parameters["scatter_axial"] == pytest.approx(truth.size["s_v"], abs=3 * fit.std["scatter_axial"])


def test_a_pair_goes_on_at_the_next_isolator_its_promise_ranks_where_the_first_stops_far_from_noise():
    """Blind case (seed 148, kid300, shapes): the centre of mass 8.8 cm high and isolator corner[+x+y] 23 %
    softer along its axis. The true pair promises chi^2 211 at the mirror image corner[-x-y] and 849 at the true
    isolator; with the scatter on the support also screened, only the mirror image was among the pairs fitted,
    and the pair stopped there at chi^2 1989: 'not explained'. A pair fitted goes on at its next screened
    isolator while that one promises less than the fit reached; at the true isolator it fits to 28."""
    _true_pair_named(148, "kid300", "corner[+x+y]", "scatter_axial")


def test_a_pair_far_down_the_promise_is_fitted_when_its_short_fit_beats_every_fitted_pair():
    """Blind case (seed 170, screen6, shapes): isolator corner[-x+y] 30 % softer along its axis and the centre of
    mass 9.4 cm high. From its members' fits (each absorbed part of the other's effect) the true pair promised
    chi^2 1153 and was not among the five fitted; none of those fitted within the uncertainty (the best 315), and
    the verdict was 'not explained' with the truth outside the tie. The pairs next in promise go on by a short
    fit (candidates.SCREEN_EVALUATIONS): the true one reaches less than the best fitted pair and, fitted from
    there, explains the data."""
    _true_pair_named(170, "screen6", "corner[-x+y]", "scatter_axial")


def test_a_pair_that_fits_only_beyond_its_plausible_range_sets_no_bar_for_the_pairs_next_in_promise():
    """Blind case (seed 6, screen6, frequencies and damping ratios): a support of 2645 kg on 72 MN/m. The five most
    promising (pair, isolator) combinations are two pairs with a gravity preload, both fitted beyond its plausible
    range (probability 0). The better of them (chi^2 682 + 8 ln 12) was the bar the pairs next in promise had to
    pass after their short fit: none did, and the tempered variances then ranked a scattered isolator first. The
    bar is now the best plausible fitted pair (none here): the pairs next in promise are fitted (the isolators
    stiff in rotation with the centre of mass higher, chi^2 326, plausible), the variances are scaled by that
    smaller misfit and the support is ranked first, not confidently."""
    data, _ = blind.make_case(6, "foundation", kind="damping", machine="screen6")
    report = diagnose_effects(parse(data))
    fitted = {f.effect for f in report.ranked}
    assert "cog_height+rotational_stiffness" in fitted
    assert report.best.effect == "foundation" and not report.confident


def test_a_better_pair_further_down_the_promise_is_fitted_where_a_fitted_pair_already_fits():
    """Held-out blind case (seed 1038, screen6, shapes): isolator corner[-x-y] 11 % softer in shear and the centre of
    mass 4.2 cm low. The true pair promised chi^2 58.5 from its members' fits (a scattered isolator alone fits to
    6111) and was not among the five fitted; a higher centre of mass with an added mass fitted within the
    uncertainty (38.1 on 26 degrees of freedom), so the pairs next in promise went no further, and the truth was
    outside the reported tie. The next pairs go on by a short fit whether or not a fitted pair fits: the true one
    reached 23 and, fitted, 21.8, ahead of every other candidate. Since the truth's shapes take their nominal
    modes' sign (not LAPACK's, which differs between BLAS kernels), the same truth's noise lies the other way:
    the scattered isolator alone ranks corner[+x+y] first (6141), and the pair's promises at its six screened
    isolators (54-80) do not rank them; its short fits at middle[+y], corner[+x+y] and corner[-x+y] reached
    54.4-1061, above the bar of a support with a higher centre of mass (37.6), and the truth was outside the tie
    (a strict xfail from 2026-11-29 to 2026-12-01). The most promising start is now short-fitted at every screened
    isolator: at the truth's it reaches 21.5, and the pair, fitted, 20.1, first."""
    _true_pair_named(1038, "screen6", "corner[-x-y]", "scatter_shear", confident=False)


def test_a_pair_next_in_promise_is_short_fitted_at_the_isolator_its_member_ranks_first_too():
    """Blind case (seed 2063, screen6, shapes; first run 2026-11-29): isolator corner[-x-y] 25 % stiffer in shear
    and along its axis, the centre of mass 9.5 cm low. The true pair was not among the five fitted; its one-step
    promise was smallest at a neighbouring isolator (901), where the short fit reaches 1077, above the bar of the
    best fitted pair (an attached body on a support beyond its plausible range, 733 + 15 ln 36), and the verdict
    was "not explained" with the truth outside the tie. At the isolator the scatter's single fit ranks first, the
    truth's, the promise is 1425 and the short fit reaches 30: the pairs next in promise are short-fitted there
    too, and the true pair, fitted, explains the data."""
    _true_pair_named(2063, "screen6", "corner[-x-y]", "scatter_axial")


@pytest.mark.parametrize(
    ("seed", "variant", "scatter", "confident"),
    [(2040, "corner[+x+y]", "scatter_axial", False), (148, "corner[-x+y]", "scatter_axial", True)],
)
def test_each_start_of_a_pair_goes_on_at_the_isolator_it_promises_least_at(seed, variant, scatter, confident):
    """Blind cases on screen6 with shapes, a scattered isolator with the centre of mass lower (seed 2040: corner
    [+x+y] 5.5 % softer, 3.7 cm; "not explained" before) or higher (seed 148: corner[-x+y] 23 % softer along its
    axis, 8.8 cm; "not explained" before). The pair's most promising start, the scatter's fit with the height nil,
    promised least at a wrong isolator, and from there no short fit came near the truth; the height's fit with the
    scatter nil, the same point at every isolator, promised least at the truth's (357 and 5626, against 430-2710
    and 5900-8500 elsewhere) and its short fit there reaches 47 and 50, the truth's minimum. Each start now goes
    on at the isolator it promises least at. Seed 2040 fits only marginally (chi^2 46.7 on 30 degrees of freedom,
    p = 0.027): the pair is first, not confidently."""
    _true_pair_named(seed, "screen6", variant, scatter, confident)


def test_a_pair_starts_a_lopsided_scatter_beside_the_other_members_fit_on_the_softer_side():
    """Held-out blind case (seed 1040, kid300, frequencies and damping ratios): isolator corner[+x+y] 22 % softer
    along its axis and the centre of mass 6.8 cm high. From the pair's screened starts (the height's fit with the
    scatter nil, the scatter's fit of -0.85 in shear with the height nil, both) the short fits stop at 45.9 and
    349.5, the first in the basin of a stiffer isolator (+0.22 along its axis, 31.3 fitted on), above the bar of
    isolator_scatter+frequency_dependent: "not explained" (found before only by SkylakeX's rounding of a tie). The
    scatter's single fit starts at the middle of its lopsided range and at its mirror image through zero
    (CandidateModel.start); the pair now starts there too beside the other member's fit (PairStarts.mirrored):
    the short fit from the height's fit with the scatter at -0.25 reaches 3.1, the pair fitted 2.9, confident,
    with the truth's scatter and height. Without mode shapes the four corners fit alike (labelled in the order of
    frequency): the corner named is one of them, the verdict names the others as good (candidates
    ._at_other_isolators), and the pair at the truth's corner from the values named fits the same."""
    data, truth = blind.make_case(1040, "isolator_scatter+cog_height", kind="damping", machine="kid300")
    campaign = parse(data)
    report = diagnose_effects(campaign)
    best = report.best
    assert report.confident and best.effect == "cog_height+isolator_scatter" and best.chi2 < 5
    assert best.parameters["scatter_axial"] == pytest.approx(truth.size["s_v"], abs=3 * best.std["scatter_axial"])
    assert best.parameters["dz_com"] == pytest.approx(truth.size["dz"], abs=3 * best.std["dz_com"])
    both = _pair("cog_height", "isolator_scatter")
    corner = strategy(both).variants(campaign).index("corner[+x+y]")
    model = CandidateModel(campaign, both, corner)
    there = fit_candidate(campaign, both, corner, start=model.vector(best.parameters))
    assert there.chi2 == pytest.approx(best.chi2, rel=1e-6)
    assert {best.variant, *best.as_good} == {"corner[+x+y]", "corner[-x+y]", "corner[+x-y]", "corner[-x-y]"}
    clause = as_good_clause(best)
    assert (
        clause.startswith(f"as good: {', '.join(best.as_good)} (which one needs mode shapes")
        and clause in report.verdict
    )


def test_an_attached_body_with_a_negative_radius_of_gyration_is_the_same_body():
    """The attached body's inertia is m g^2: the generated model is even in g, and the fit searches g >= 0
    (EffectParameter.floor), where it fitted -0.13 m at the truth's minimum and was called implausible (seed 9
    of the study beside: 57 kg 0.28 m high beside a reversed channel, "not explained" for it)."""
    campaign = parse(blind.make_case(9, "added_mass+sensor_reversed")[0])  # kid300 with shapes
    model = CandidateModel(campaign, EFFECTS["added_mass"])
    g = model.parameter_names.index("g_added")
    theta = model.start()[0].copy()
    theta[g] = 0.2
    mirrored = theta.copy()
    mirrored[g] = -0.2
    assert np.array_equal(model.predict(theta).frequencies, model.predict(mirrored).frequencies)
    assert model.bounds()[0][g] == 0.0
    report = diagnose_effects(campaign)
    fit = next(f for f in report.ranked if f.effect == "added_mass+sensor_reversed")
    assert fit.plausible and fit.parameters["g_added"] >= 0
    assert report.best.effect == "added_mass+sensor_reversed" and "added_mass+sensor_reversed" in report.tie
