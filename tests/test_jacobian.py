"""The analytic Jacobian of candidate fits (mountid.diagnosis.jacobian) and the perturbation formulas under
it: eigenvector derivatives checked against the differentiated eigen-equations (exact) and a central
difference, damped-pole derivatives against a central difference, and the residual Jacobian of every
candidate against a central difference of the residuals it differentiates."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg
from test_candidates import ROUND_TRIP, UNKNOWN, _campaign_from

from mountid.diagnosis.campaign import parse
from mountid.diagnosis.candidate_model import DEGENERATE, CandidateModel
from mountid.diagnosis.fitting import Data, _residual_function, fit_candidate
from mountid.diagnosis.jacobian import _off_span_derivative, _span_factors, jacobian
from mountid.diagnosis.strategies import stacked_rows, strategy, turned_axis
from mountid.effects import EFFECTS, pair
from mountid.identification.from_records import pole_frequencies, pole_frequency_derivatives
from mountid.machine import Machine, damped_pole_derivatives
from mountid.runtime import EQUAL_EIGENVALUES, eigen_derivatives, eigenvalue_derivatives
from mountid.validation.blind import make_case
from mountid.validation.blind_truth import _turned
from mountid.validation.paper import TABLE_1


def _random_problem(seed: int, n: int = 6):
    rng = np.random.default_rng(seed)
    a = rng.normal(size=(n, n))
    b = rng.normal(size=(n, n))
    mass, stiffness = a @ a.T + n * np.eye(n), b @ b.T + np.eye(n)
    d = rng.normal(size=(3, 2, n, n))
    d = d + np.swapaxes(d, -1, -2)
    return mass, stiffness, d[:, 0], d[:, 1]


@pytest.mark.parametrize("seed", range(4))
def test_eigen_derivatives_solve_the_differentiated_eigen_equations(seed):
    """(C - lam M) dphi = -(C' - lam' M - lam M') phi and phi^T M dphi = -phi^T M' phi / 2, exactly; the
    eigenvalues' part is eigenvalue_derivatives' to the bit and a central difference's."""
    mass, stiffness, d_m, d_c = _random_problem(seed)
    lam, phi = scipy.linalg.eigh(stiffness, mass)
    d_lam, d_phi = eigen_derivatives(d_m, d_c, phi, lam)
    assert np.array_equal(d_lam, eigenvalue_derivatives(d_m, d_c, phi, lam))  # to the bit
    for p in range(len(d_m)):
        for k in range(len(lam)):
            lhs = (stiffness - lam[k] * mass) @ d_phi[p, :, k]
            rhs = -(d_c[p] - d_lam[p, k] * mass - lam[k] * d_m[p]) @ phi[:, k]
            assert np.allclose(lhs, rhs, rtol=0, atol=1e-11 * np.max(np.abs(rhs)))
            assert np.isclose(phi[:, k] @ mass @ d_phi[p, :, k], -0.5 * phi[:, k] @ d_m[p] @ phi[:, k], atol=1e-12)
    h = 1e-6
    lam_up, up = scipy.linalg.eigh(stiffness + h * d_c[0], mass + h * d_m[0])
    lam_down, down = scipy.linalg.eigh(stiffness - h * d_c[0], mass - h * d_m[0])
    assert np.allclose((lam_up - lam_down) / (2 * h), d_lam[0], rtol=1e-7, atol=0)
    up *= np.sign(np.sum(up * phi, axis=0))
    down *= np.sign(np.sum(down * phi, axis=0))
    assert np.allclose((up - down) / (2 * h), d_phi[0], atol=1e-7 * np.max(np.abs(d_phi[0])))


@pytest.mark.parametrize("seed", range(3))
def test_damped_pole_derivatives_match_a_central_difference(seed):
    mass, stiffness, d_m, d_c = _random_problem(seed)
    damping = 0.05 * stiffness + 0.02 * mass
    d_b = 0.1 * (d_c + d_m)
    lam = scipy.linalg.eigh(stiffness, mass)[0]
    poles, d_p = damped_pole_derivatives(mass, stiffness, damping, lam, d_m, d_c, d_b)
    h = 1e-7
    for q in range(len(d_m)):
        shifted = [
            damped_pole_derivatives(
                mass + s * h * d_m[q], stiffness + s * h * d_c[q], damping + s * h * d_b[q], lam, d_m, d_c, d_b
            )[0]
            for s in (1, -1)
        ]
        numeric = (shifted[0] - shifted[1]) / (2 * h)
        assert np.allclose(d_p[q], numeric, rtol=1e-6, atol=1e-8 * np.max(np.abs(poles)))


TRUTHS = {
    **ROUND_TRIP,
    "isolator_scatter": {"scatter_shear": 0.1, "scatter_axial": 0.2},
    "isolator_tilted": {"tilt_1": 0.12, "tilt_2": -0.05},
    "sensor_error": {"sensor_yaw": 0.03, "sensor_dz": 0.1},
    None: {},
}
CASES = [(name, name) for name in TRUTHS] + [("drive_belt", None), ("added_mass", "drive_belt")]


@pytest.mark.parametrize(("truth", "fitted"), CASES, ids=str)
def test_candidate_jacobian_matches_a_central_difference_of_the_residuals(truth, fitted):
    """At a point beside the truth (every shape residual form: single modes, exact twins, blended twins),
    with the labelling the same on both sides of every step (it is held fixed by the derivative)."""
    isolator = 0 if fitted in ("isolator_scatter", "isolator_tilted") else None
    values = TRUTHS[fitted] if fitted == truth else {"k_belt": 1e4, "h_belt": 0.3} if fitted else {}
    truth_values = TRUTHS[truth]
    campaign = parse(_campaign_from(truth, truth_values, isolator))
    model = CandidateModel(campaign, EFFECTS[fitted] if fitted else None, isolator)
    data = Data(campaign, model.length)
    fun, _ = _residual_function(model, data, None)
    rng = np.random.default_rng(3)
    theta = model.vector({**UNKNOWN, **values}) + rng.normal(0, 0.01, len(model.parameter_names))
    analytic = jacobian(model, data, theta)
    assert analytic is not None
    h = 1e-6
    columns = []
    for i in range(len(theta)):
        step = h * np.eye(len(theta))[i]
        for s in (step, -step):
            _assert_same_labelling(model.evaluate(theta), model.evaluate(theta + s))
        columns.append((fun(theta + step) - fun(theta - step)) / (2 * h))
    numeric = np.column_stack(columns)[: len(analytic)]
    assert np.max(np.abs(analytic - numeric)) <= 1e-6 * np.max(np.abs(numeric))


def residual_difference(model: CandidateModel, theta: np.ndarray, step: float = 1e-6) -> np.ndarray:
    """d(residuals)/d(theta) of ``model``'s fit at ``theta`` by central differences, a column per parameter: the
    residuals as the fit sees them (fitting._residual_function, every row of the data, then the prior rows, which
    the analytic Jacobian does not hold: compare its first len(jacobian) rows)."""
    fun, _ = _residual_function(model, Data(model.campaign, model.length), None)
    return np.column_stack([(fun(theta + step * e) - fun(theta - step * e)) / (2 * step) for e in np.eye(len(theta))])


@pytest.mark.parametrize(
    "turn", [(0.0, 0.0), (1e-9, 0.0), (0.004, -0.007), (0.0099, 0.0014), (0.0101, 0.0), (0.3, -0.1), (-0.2, 0.25)]
)
def test_a_turned_axis_is_the_blind_truths_rotation_and_its_derivative_a_central_difference(turn):
    """strategies.turned_axis: the channel's axis turned by the rotation vector ``turn`` across it is the blind
    harness's Rodrigues rotation by the angle |turn| (so the fitted turn is the angle, in rad), on both sides of
    SMALL_TURN where its sin(a)/a switches to the series; its derivatives match central differences."""
    d = np.array([0.36, 0.48, 0.8])
    e1 = np.cross([0.0, 0.0, 1.0], d)  # as Channel._layout builds it (|d_z| < 0.9)
    e1 /= np.linalg.norm(e1)
    across = np.column_stack([e1, np.cross(d, e1)])
    t = np.array(turn)
    axis, d_axis = turned_axis(d, across, t)
    angle = math.hypot(*turn)
    about = math.atan2(t[0], -t[1])  # the harness turns d toward (sin(about), -cos(about)) in (e1, e2)
    assert np.allclose(axis, _turned(d, angle, about), rtol=0, atol=1e-15)
    h = 1e-6
    numeric = [
        (turned_axis(d, across, t + h * e)[0] - turned_axis(d, across, t - h * e)[0]) / (2 * h) for e in np.eye(2)
    ]
    assert np.allclose(d_axis, numeric, rtol=0, atol=1e-9)


def test_turned_channel_jacobian_matches_a_central_difference():
    from test_candidates import _turned_campaign

    campaign = parse(_turned_campaign(7, (0.1, 0.04)))
    model = CandidateModel(campaign, EFFECTS["sensor_turned"], 7)
    theta = model.vector({**UNKNOWN, "turn_1": 0.08, "turn_2": 0.03})
    analytic = jacobian(model, Data(campaign, model.length), theta)
    numeric = residual_difference(model, theta)
    assert np.max(np.abs(analytic - numeric[: len(analytic)])) <= 1e-6 * np.max(np.abs(numeric))


def test_misplaced_channel_jacobian_matches_a_central_difference():
    from test_candidates import _misplaced_campaign

    campaign = parse(_misplaced_campaign(5, (0.1, 0.2, -0.1))[0])
    model = CandidateModel(campaign, EFFECTS["sensor_misplaced"], 5)
    theta = model.vector({**UNKNOWN, "offset_1": 0.05, "offset_2": -0.12})
    analytic = jacobian(model, Data(campaign, model.length), theta)
    numeric = residual_difference(model, theta)
    assert np.max(np.abs(analytic - numeric[: len(analytic)])) <= 1e-6 * np.max(np.abs(numeric))


def test_two_turned_channels_jacobian_matches_a_central_difference():
    from test_candidates import _two_turned_campaign

    campaign = parse(_two_turned_campaign("S1_z & S3_y", (0.1, 0.04, -0.2, 0.05)))
    effect = EFFECTS["two_sensors_turned"]
    model = CandidateModel(campaign, effect, strategy(effect).variants(campaign).index("S1_z & S3_y"))
    theta = model.vector({**UNKNOWN, "turn_1": 0.08, "turn_2": 0.03, "turn_3": -0.15, "turn_4": 0.1})
    analytic = jacobian(model, Data(campaign, model.length), theta)
    numeric = residual_difference(model, theta)
    assert np.max(np.abs(analytic - numeric[: len(analytic)])) <= 1e-6 * np.max(np.abs(numeric))


def test_turned_and_misplaced_channel_jacobian_matches_a_central_difference():
    from test_candidates import _turned_misplaced_campaign

    campaign = parse(_turned_misplaced_campaign("S2_y", (0.1, -0.05, 0.2, 0.1)))
    effect = EFFECTS["sensor_turned_misplaced"]
    model = CandidateModel(campaign, effect, strategy(effect).variants(campaign).index("S2_y"))
    theta = model.vector({**UNKNOWN, "turn_1": 0.08, "turn_2": -0.03, "offset_1": 0.15, "offset_2": 0.12})
    analytic = jacobian(model, Data(campaign, model.length), theta)
    numeric = residual_difference(model, theta)
    assert np.max(np.abs(analytic - numeric[: len(analytic)])) <= 1e-6 * np.max(np.abs(numeric))


DAMPED = ["damping", "drive_belt", "isolator_scatter", "isolator_tilted", "foundation", "frequency_dependent", None]


@pytest.mark.parametrize("fitted", DAMPED, ids=str)
def test_jacobian_rows_of_measured_damping_ratios_match_a_central_difference(fitted):
    """A campaign with damping ratios and no damping parameters known: b_xy and b_z are fitted with the
    stiffnesses, and the damping-ratio rows (damped-pole derivatives) match a central difference."""
    isolator = 0 if fitted in ("isolator_scatter", "isolator_tilted") else None
    data = _campaign_from(fitted, TRUTHS[fitted], isolator)
    known = {k: v for k, v in data["known"].items() if not k.startswith("b_")}
    for i, mode in enumerate(data["modes"].values()):
        mode["damping_ratio"] = 0.03 + 0.01 * i
    campaign = parse({**data, "known": known})
    model = CandidateModel(campaign, EFFECTS[fitted] if fitted else None, isolator)
    assert model.damping_unknown == ("b_xy", "b_z") and model.parameter_names[2:4] == ("b_xy", "b_z")
    rows = Data(campaign, model.length)
    rng = np.random.default_rng(4)
    theta = model.vector({**UNKNOWN, "b_xy": 400.0, "b_z": 900.0, **TRUTHS[fitted]})
    theta += rng.normal(0, 0.01, len(theta))
    analytic = jacobian(model, rows, theta)
    assert analytic is not None and analytic.shape[0] == rows.n_rows
    numeric = residual_difference(model, theta)[: len(analytic)]
    zeta_rows = slice(rows.n_rows - len(rows.damping_labels), rows.n_rows)
    assert np.max(np.abs(analytic[zeta_rows] - numeric[zeta_rows])) <= 1e-6 * np.max(np.abs(numeric[zeta_rows]))
    assert np.max(np.abs(analytic - numeric)) <= 1e-6 * np.max(np.abs(numeric))


def test_damping_rows_where_the_described_damping_follows_a_stiffness(tmp_path):
    """A description whose isolator damping is proportional to the unknown stiffness (b c / c_ref, rectangular):
    the description's B depends on the unknowns, and an isolator's candidate (alone and beside another effect)
    keeps its derivative. Its damping-ratio columns of c_x, c_y, c_z were 94-100 % off (B's derivative dropped).
    A tilted isolator turns its own damping, which follows the stiffness too (isolator_damping_gradient())."""
    text = Path("derivations/rectangular.toml").read_text(encoding="utf-8")
    text = text.replace(
        'damping = ["b_x", "b_y", "b_z"]', 'damping = ["b_x * c_x / k_x", "b_y * c_y / k_y", "b_z * c_z / k_z"]'
    )
    references = {"k_x": 2.0e5, "k_y": 1.4e5, "k_z": 9.0e5}
    lines = "".join(f'{k} = {{ kind = "stiffness", role = "known", value = {v} }}\n' for k, v in references.items())
    text = text.replace("[body]", lines + "\n[body]").replace(
        'name = "rectangular"', 'name = "rectangular_proportional"', 1
    )
    (tmp_path / "proportional.toml").write_text(text, encoding="utf-8")
    data, _ = make_case(5, "cog_height", machine="rectangular", kind="damping", noise=False)
    campaign = parse({**data, "machine": str(tmp_path / "proportional.toml"), "known": {**data["known"], **references}})
    effects = (EFFECTS["isolator_scatter"], pair(EFFECTS["cog_height"], EFFECTS["isolator_scatter"]))
    for effect in (*effects, EFFECTS["isolator_tilted"]):
        model = CandidateModel(campaign, effect, 1)
        rows = Data(campaign, model.length)
        theta = model.start()[0] + np.random.default_rng(5).normal(0, 0.01, len(model.parameter_names))
        analytic = jacobian(model, rows, theta)
        numeric = residual_difference(model, theta)
        zeta = slice(rows.n_rows - len(rows.damping_labels), rows.n_rows)
        stiffness = [model.parameter_names.index(u) for u in ("c_x", "c_y", "c_z")]
        assert np.max(np.abs(numeric[zeta][:, stiffness])) > 1e-3 * np.max(np.abs(numeric[zeta]))  # B follows c
        assert np.max(np.abs(analytic[zeta] - numeric[zeta])) <= 1e-6 * np.max(np.abs(numeric[zeta]))


def test_jacobian_of_the_damping_candidate_on_pole_frequencies_matches_a_central_difference():
    """A campaign of poles' |p| (converted to undamped frequencies): the damping candidate's frequency rows are
    the undamped model's (no column in damping_scale), its damping-ratio rows carry the scale."""
    data = _campaign_from("damping", TRUTHS["damping"], None)
    for i, mode in enumerate(data["modes"].values()):
        mode["damping_ratio"] = 0.03 + 0.01 * i
        mode["damping_uncertainty"] = 1e-3
    campaign = parse({**data, "frequency_type": "pole"})
    model = CandidateModel(campaign, EFFECTS["damping"], None)
    rows = Data(campaign, model.length)
    theta = model.vector({**UNKNOWN, **TRUTHS["damping"]})
    analytic = jacobian(model, rows, theta)
    numeric = residual_difference(model, theta)[: len(analytic)]
    assert np.max(np.abs(analytic - numeric)) <= 1e-6 * np.max(np.abs(numeric))
    scale = model.parameter_names.index("damping_scale")
    assert (
        not analytic[: len(rows.sigma), scale].any() and np.abs(analytic[-len(rows.damping_labels) :, scale]).min() > 0
    )


def _assert_same_labelling(here, there) -> None:
    """Each label on the same model mode, or on its exact twin (then the residuals see only their span)."""
    for a, b in zip(here.index, there.index, strict=True):
        assert a == b or abs(here.lam[a] - here.lam[b]) <= 1e-6 * here.lam[a]


def test_a_parameter_that_splits_twins_falls_back_to_differences():
    """At scatter = 0 the x/y twins of kid300 are exactly equal and one isolator's scatter splits them: the
    frequencies are not differentiable in that scatter there, the Jacobian says so for that column alone (the
    others move the twins together: their columns stay analytic and match a central difference), and the fit
    still converges."""
    truth = {"scatter_shear": 0.2, "scatter_axial": 0.2}
    campaign = parse(_campaign_from("isolator_scatter", truth, 0))
    model = CandidateModel(campaign, EFFECTS["isolator_scatter"], 0)
    data = Data(campaign, model.length)
    theta = model.vector({**UNKNOWN, "scatter_shear": 0.0, "scatter_axial": 0.0})
    analytic = jacobian(model, data, theta)
    split = np.all(np.isnan(analytic), axis=0)
    # axial scatter at one isolator splits the rocking twins; the shear scatter of an isolator with equal
    # shear stiffness in its two directions moves them together to first order, as the unknowns do
    assert [n for n, s in zip(model.parameter_names, split, strict=True) if s] == ["scatter_axial"]
    fun, _ = _residual_function(model, data, None)
    h = 1e-6
    for i in np.flatnonzero(~split):
        step = h * np.eye(len(theta))[i]
        numeric = ((fun(theta + step) - fun(theta - step)) / (2 * h))[: len(analytic)]
        assert np.max(np.abs(analytic[:, i] - numeric)) <= 1e-6 * np.max(np.abs(numeric))
    fit = fit_candidate(campaign, EFFECTS["isolator_scatter"], 0)
    assert fit.parameters["scatter_shear"] == pytest.approx(0.2, rel=1e-4)
    assert fit.parameters["scatter_axial"] == pytest.approx(0.2, rel=1e-4)


@pytest.mark.parametrize("scatter", [3e-6, 1e-5, -1e-5])
def test_twins_a_small_asymmetry_parts_keep_analytic_columns(scatter):
    """A small axial scatter parts kid300's rocking twins by 2e-7 to 6e-7 of their eigenvalue: within DEGENERATE
    (the residuals compare the measured shapes with their span) but distinct, so every parameter has its
    derivative, also the one that parts them. The labels of such twins may swap under a step of 1e-9 (their
    frequencies differ by the gap), so the check holds each labelled mode by its index: the frequency rows
    against a central difference of those modes' frequencies, the shape rows (spans, whichever label) against
    one of the residuals."""
    truth = {"scatter_shear": 0.2, "scatter_axial": 0.2}
    campaign = parse(_campaign_from("isolator_scatter", truth, 0))
    model = CandidateModel(campaign, EFFECTS["isolator_scatter"], 0)
    data = Data(campaign, model.length)
    theta = model.vector({**UNKNOWN, "scatter_shear": 0.0, "scatter_axial": scatter})
    e = model.evaluate(theta)
    parted = [np.ptp(e.lam[group]) / e.lam[members[0]] for group, members in e.twins]
    assert any(EQUAL_EIGENVALUES < g <= DEGENERATE for g in parted)
    analytic = jacobian(model, data, theta)
    assert not np.isnan(analytic).any()
    fun, _ = _residual_function(model, data, None)
    h, n_f = 1e-7, len(data.sigma)
    steps = [h * v for v in np.eye(len(theta))]

    def omega(x: np.ndarray) -> np.ndarray:
        return np.sqrt(model.evaluate(x).lam[e.index])

    frequency = np.column_stack([-(omega(theta + s) - omega(theta - s)) / (2 * h) / data.sigma for s in steps])
    shapes = np.column_stack([(fun(theta + s) - fun(theta - s)) / (2 * h) for s in steps])[n_f : len(analytic)]
    assert np.max(np.abs(analytic[:n_f] - frequency)) <= 1e-6 * np.max(np.abs(frequency))
    assert np.max(np.abs(analytic[n_f:] - shapes)) <= 1e-6 * np.max(np.abs(shapes))


@pytest.mark.parametrize("columns", [2, 3])
@pytest.mark.parametrize("closeness", [1.0, 1e-3, 1e-7])
def test_span_factors_and_the_span_derivative_hold_for_nearly_parallel_partners(columns, closeness):
    """The partners' Gram-Schmidt factors give orthonormal columns of their span and its pseudo-inverse (against
    numpy's SVD-based pinv, relative to the condition of the shapes), the derivative of the part of s off their
    span matches the dense formula and a central difference, and parallel partners are refused (None)."""
    rng = np.random.default_rng(columns)
    base = rng.normal(size=(6, columns))
    base[:, 1] = base[:, 0] + closeness * rng.normal(size=6)
    direction = rng.normal(size=(6, columns))
    s = rng.normal(size=6)

    def unit(t: float) -> np.ndarray:
        u = base + t * direction
        return u / np.linalg.norm(u, axis=0)

    u = unit(0.0)
    q, pinv = _span_factors(u)
    condition = np.linalg.cond(u)
    assert np.max(np.abs(q.T @ q - np.eye(columns))) <= 1e-14
    assert np.max(np.abs(pinv - np.linalg.pinv(u))) <= 1e-14 * condition * np.max(np.abs(pinv))
    h = 1e-6 * closeness
    d_u = (unit(h) - unit(-h)) / (2 * h)

    def off(t: float) -> np.ndarray:
        w = unit(t)
        return s - w @ np.linalg.lstsq(w, s, rcond=None)[0]

    analytic = _off_span_derivative(s, q, pinv, s - q @ (q.T @ s), d_u[None])[0]
    # dP = (I - P) dU U^+ + its transpose, formed densely from numpy's pinv
    full = np.linalg.pinv(u)
    rest = np.eye(6) - u @ full
    d_p = rest @ d_u @ full
    dense = -(d_p + d_p.T) @ s
    assert np.max(np.abs(analytic - dense)) <= 1e-13 * condition * np.max(np.abs(dense))
    if closeness >= 1e-3:  # a central difference of nearly parallel partners is rounding alone
        numeric = (off(h) - off(-h)) / (2 * h)
        assert np.max(np.abs(analytic - numeric)) <= 1e-5 * np.max(np.abs(numeric))
    parallel = u.copy()
    parallel[:, 1] = parallel[:, 0]
    assert _span_factors(parallel) is None


@pytest.mark.parametrize("damping_factor", [1.0, 30.0])
def test_pole_frequency_derivatives_match_a_central_difference(damping_factor):
    """The damped branch of fit_stiffness: d|p| / d(unknown) of kid300 at the paper's damping and at a
    heavily damped mount."""
    machine = Machine.resolve("kid300")
    values = machine.values(
        {**TABLE_1, "b_xy": 337.2 * damping_factor, "b_z": 1039.0 * damping_factor, **UNKNOWN},
        tuple(machine.parameters),
    )
    analytic = pole_frequency_derivatives(machine, values, machine.unknown)
    for k, u in enumerate(machine.unknown):
        h = 1e-6 * values[u]
        up = pole_frequencies(machine, {**values, u: values[u] + h})
        down = pole_frequencies(machine, {**values, u: values[u] - h})
        assert np.allclose(analytic[k], (up - down) / (2 * h), rtol=1e-6, atol=1e-12), u


def test_stacked_rows_hand_each_caller_its_own_rows_and_flags():
    """stacked_rows keeps its bookkeeping per tuple of names (strategies._stacking) but every call returns fresh
    arrays: Isolator.derivatives and Composite set flags and add rows in place, and a kept array changed that
    way would leak into the next fit. The stack against a loop over the names."""
    rows = ("c_xy", "c_z", "k_bend")
    names = ("c_z", "dz_com", "k_bend", "c_xy")
    d = np.arange(3 * 3 * 6 * 6, dtype=float).reshape(3, 3, 6, 6)
    out, present = stacked_rows(d, rows, names, 12, keep=("c_z", "k_bend", "c_xy"))
    assert present.tolist() == [True, False, True, True]
    for j, q in enumerate(names):
        expected = np.zeros((3, 12, 12))
        if q in rows:
            expected[:, :6, :6] = d[rows.index(q)]
        assert np.array_equal(out[:, j], expected)
    present[1] = True
    out[1, 0] += 1.0
    again, flags = stacked_rows(d, rows, names, 12, keep=("c_z", "k_bend", "c_xy"))
    assert flags.tolist() == [True, False, True, True]
    assert flags.flags.writeable and again.flags.writeable
    assert np.array_equal(again[1, 0, :6, :6], d[1, 1])
    assert stacked_rows(d, rows, names, 6, keep=("c_z",))[1].tolist() == [True, False, False, False]
