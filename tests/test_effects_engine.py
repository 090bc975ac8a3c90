"""Candidate effects in the engine: the generated effect_<name>() matrices against the sympy expressions at
high precision (mpmath), against an independent numpy assembly, and their limits."""

from __future__ import annotations

from pathlib import Path

import mpmath
import numpy as np
import pytest
import sympy as sp
import tomllib
from conftest import MACHINES, call, generated

from mountid.effects import CATALOGUE, EFFECT_PARAMETERS, EFFECTS, STANDARD_GRAVITY
from mountid.engine.description import load, parse
from mountid.engine.symbolic.effects import GENERATED_EFFECTS, ExtendedModel
from mountid.engine.symbolic.model import SymbolicModel
from mountid.errors import DescriptionError
from mountid.validation.blind_truth import TruthMachine, _body_mass, _jac

ROOT = Path(__file__).resolve().parents[1]
EFFECT_VALUES = {
    "dx_com": 0.03,
    "dy_com": -0.02,
    "dz_com": 0.05,
    "k_bend": 2.0e3,
    "k_torsion": 1.5e3,
    "m_found": 400.0,
    "k_found": 8.0e6,
    "found_shear": 0.3,
    "found_spread": 2.5,
    "found_aspect": 1.4,
    "found_depth": 0.2,
    "m_added": 60.0,
    "x_added": 0.25,
    "y_added": -0.15,
    "h_added": 0.4,
    "g_added": 0.1,
    "a_added": -0.3,
    "k_belt": 3.0e4,
    "h_belt": 0.2,
    "h_preload": 0.35,
}


def _values(mod) -> dict[str, float]:
    return {**{n: p["value"] for n, p in mod.PARAMETERS.items()}, **EFFECT_VALUES}


def test_catalogue_names_are_the_issues_and_every_effect_has_up_to_six_parameters():
    """The issue's effects, hardening rubber, the reversed channel (no parameter: the sign of one channel is
    wrong or it is not), two turned channels, a channel turned and off its point, and the tilted isolator (added
    last); every other effect has one to six."""
    assert [e.name for e in CATALOGUE] == [
        "com_offset",
        "cog_height",
        "isolator_scatter",
        "rotational_stiffness",
        "frequency_dependent",
        "rubber_hardening",
        "foundation",
        "added_mass",
        "drive_belt",
        "gravity_preload",
        "damping",
        "sensor_error",
        "sensor_turned",
        "sensor_misplaced",
        "sensor_reversed",
        "two_sensors_turned",
        "sensor_turned_misplaced",
        "isolator_tilted",
    ]
    assert all(1 <= len(e.parameters) <= 6 for e in CATALOGUE if e.kind != "reversal")
    assert [e.name for e in CATALOGUE if not e.parameters] == ["sensor_reversed"]
    assert all(p.plausible[0] < p.plausible[1] for e in CATALOGUE for p in e.parameters)


@pytest.mark.parametrize("machine", MACHINES)
@pytest.mark.parametrize("effect", GENERATED_EFFECTS)
def test_generated_effect_matrices_match_sympy_at_high_precision(machine, effect):
    mod = generated(machine)
    ext = ExtendedModel(SymbolicModel(load(ROOT / "derivations" / f"{machine}.toml")), EFFECTS[effect])
    values = _values(mod)
    numeric = call(mod, f"effect_{effect}", values)
    subs = {**{s: values[n] for n, s in ext.model.symbols.items()}, **{s: values[n] for n, s in ext.symbols.items()}}
    with mpmath.workdps(30):
        for name, got in zip("MCB", numeric, strict=True):
            exact = np.array(sp.Matrix(getattr(ext, name)).evalf(30, subs=subs).tolist(), dtype=float)
            scale = np.max(np.abs(exact))
            assert np.max(np.abs(got - exact)) <= 1e-13 * scale, name


@pytest.mark.parametrize("machine", MACHINES)
@pytest.mark.parametrize(
    ("each", "whole"), [("isolator_stiffness", "stiffness_matrix"), ("isolator_damping", "damping_matrix")]
)
def test_isolator_matrices_sum_to_the_machines(machine, each, whole):
    mod = generated(machine)
    values = _values(mod)
    per = call(mod, each, values)
    assert per.shape == (len(mod.ISOLATORS), 6, 6)
    total = call(mod, whole, values)
    assert np.allclose(per.sum(axis=0), total, rtol=1e-13, atol=1e-9 * np.max(np.abs(total)))


@pytest.mark.parametrize("machine", MACHINES)
def test_isolator_points_are_the_descriptions_at_high_precision(machine):
    """isolator_points() against each isolator's position (the description's mirrored points) at 30 digits,
    support_feet() against them about their mean, and isolator_points against the stiffness they carry: the
    isolator's stiffness matrix is J(r)^T K J(r) at that point."""
    mod = generated(machine)
    model = SymbolicModel(load(ROOT / "derivations" / f"{machine}.toml"))
    values = _values(mod)
    points = call(mod, "isolator_points", values)
    assert points.shape == (3, len(mod.ISOLATORS))
    subs = {s: values[n] for n, s in model.symbols.items()}
    with mpmath.workdps(30):
        for k, iso in enumerate(model.isolators):
            exact = np.array([float(v.evalf(30, subs=subs)) for v in iso.position])
            assert np.allclose(points[:, k], exact, rtol=1e-14, atol=1e-15)
    # a support below the isolators refers its coordinates to the mean of the isolator points
    feet = call(mod, "support_feet", values)
    assert np.allclose(feet, points - points.mean(axis=1, keepdims=True), rtol=1e-14, atol=1e-14)
    for function, field in (("isolator_stiffness", "stiffness"), ("isolator_damping", "damping")):
        per = call(mod, function, values)
        for k, iso in enumerate(model.isolators):
            tensor = np.array(getattr(iso, field).evalf(subs=subs).tolist(), dtype=float)
            j = _jac(points[:, k])
            assert np.allclose(j.T @ tensor @ j, per[k], rtol=1e-12, atol=1e-9 * np.abs(per[k]).max())


def test_kid300_effects_match_an_independent_numpy_assembly():
    """Built from u = t + w x r in numpy (the blind harness's truth code), not from the engine."""
    mod = generated("kid300")
    v = _values(mod)
    m0 = mod.mass_matrix(v["m"], v["J_xy"], v["J_z"])
    c0 = mod.stiffness_matrix(v["L_xy"], v["L_z"], v["c_xy"], v["c_z"])
    inertia = np.diag([v["J_xy"], v["J_xy"], v["J_z"]])

    def effect(name):
        return call(mod, f"effect_{name}", v)

    m, _, _ = effect("com_offset")
    assert np.allclose(m, _body_mass(v["m"], inertia, np.array([v["dx_com"], v["dy_com"], 0.0])), rtol=1e-13)
    m, _, _ = effect("added_mass")
    where = np.array([v["x_added"], v["y_added"], v["h_added"]])
    own = v["m_added"] * v["g_added"] ** 2 * np.diag([1 + v["a_added"], 1 - v["a_added"], 1.0])
    assert np.allclose(m, m0 + _body_mass(v["m_added"], own, where), rtol=1e-13)
    _, c, _ = effect("drive_belt")
    row = np.array([1.0, 0, 0]) @ _jac(np.array([0, 0, v["h_belt"]]))
    assert np.allclose(c, c0 + v["k_belt"] * np.outer(row, row), rtol=1e-13)
    _, c, _ = effect("gravity_preload")
    expected = c0.copy()
    expected[3, 3] -= v["m"] * STANDARD_GRAVITY * v["h_preload"]
    expected[4, 4] -= v["m"] * STANDARD_GRAVITY * v["h_preload"]
    assert np.allclose(c, expected, rtol=1e-13)
    _, c, _ = effect("rotational_stiffness")
    expected = c0.copy()
    expected[3:, 3:] += 4 * np.diag([v["k_bend"], v["k_bend"], v["k_torsion"]])
    assert np.allclose(c, expected, rtol=1e-13)
    m, c, b = effect("foundation")
    assert m.shape == c.shape == b.shape == (12, 12)
    # body and support assembled here from u = t + w x r: the support's coordinates refer to the feet's
    # centre (z = -L_z), its centre of mass and ground springs found_depth below, the springs found_spread
    # times as far out along x as the feet and found_spread found_aspect times along y
    length = float(call(mod, "effect_scales", v)["length"])
    depth, spread, aspect = v["found_depth"], v["found_spread"], v["found_aspect"]
    m_want = np.zeros((12, 12))
    m_want[:6, :6] = m0
    own = v["m_found"] * length**2 * np.eye(3)
    m_want[6:, 6:] = _body_mass(v["m_found"], own, np.array([0.0, 0.0, -depth]))
    assert np.allclose(m, m_want, rtol=1e-13)
    a = v["L_xy"] / np.sqrt(2)
    feet = [np.array([sx * a, sy * a, -v["L_z"]]) for sx in (1, -1) for sy in (1, -1)]
    k_iso = np.diag([v["c_xy"], v["c_xy"], v["c_z"]])
    spring = np.diag([v["found_shear"], v["found_shear"], 1.0]) * v["k_found"] / 4
    c_want = np.zeros((12, 12))
    for r in feet:
        foot = r - np.array([0.0, 0.0, -v["L_z"]])
        rel = np.hstack([_jac(r), -_jac(foot)])
        ground = np.hstack([np.zeros((3, 6)), _jac(np.array([spread * foot[0], spread * aspect * foot[1], -depth]))])
        c_want += rel.T @ k_iso @ rel + ground.T @ spring @ ground
    assert np.allclose(c, c_want, rtol=1e-12, atol=1e-6 * np.abs(c_want).max())


@pytest.mark.parametrize("machine", MACHINES)
def test_effects_vanish_at_their_neutral_values(machine):
    mod = generated(machine)
    v = {**_values(mod), **{p: 0.0 for p in EFFECT_PARAMETERS}}
    nominal = (call(mod, "mass_matrix", v), call(mod, "stiffness_matrix", v), call(mod, "damping_matrix", v))
    for name in GENERATED_EFFECTS:
        if name == "foundation":
            continue
        for got, want in zip(call(mod, f"effect_{name}", v), nominal, strict=True):
            assert np.array_equal(got, want), name


def test_a_rigid_heavy_foundation_leaves_the_machine_frequencies():
    mod = generated("kid300")
    v = {**_values(mod), "k_found": 1e13, "m_found": 1e4}
    m, c, _ = call(mod, "effect_foundation", v)
    lam = np.sort(np.linalg.eigvals(np.linalg.solve(m, c)).real)[:6]
    nominal = mod.frequencies(*(v[a] for a in mod.FORWARD_ARGUMENTS))
    assert np.allclose(np.sqrt(lam), np.sort(nominal), rtol=1e-6)


def test_a_description_may_not_use_an_effect_parameter_name():
    text = (ROOT / "derivations" / "kid300.toml").read_text().replace("L_z ", "h_belt ").replace("L_z", "h_belt")
    with pytest.raises(DescriptionError, match="parameters.h_belt: is reserved"):
        parse(tomllib.loads(text))


@pytest.mark.parametrize("machine", MACHINES)
@pytest.mark.parametrize("effect", GENERATED_EFFECTS)
def test_generated_effect_derivatives_match_sympy_at_high_precision(machine, effect):
    """effect_<name>_derivatives() against sympy's derivative of the extended M, C, B at 30 digits."""
    mod = generated(machine)
    ext = ExtendedModel(SymbolicModel(load(ROOT / "derivations" / f"{machine}.toml")), EFFECTS[effect])
    values = _values(mod)
    numeric = call(mod, f"effect_{effect}_derivatives", values)
    names = mod.EFFECT_DERIVATIVE_PARAMETERS[effect]
    assert names[-len(ext.symbols) :] == tuple(ext.symbols)
    damping = {n for n, p in mod.PARAMETERS.items() if p["kind"] == "damping"}
    assert set(names[: -len(ext.symbols)]) <= set(mod.UNKNOWN) | damping
    symbols = {**ext.model.symbols, **ext.symbols}
    subs = {s: values[n] for n, s in symbols.items()}
    with mpmath.workdps(30):
        for k, p in enumerate(names):
            for i, name in enumerate("MCB"):
                exact = np.array(getattr(ext, name).diff(symbols[p]).evalf(30, subs=subs).tolist(), dtype=float)
                scale = max(np.max(np.abs(exact)), np.max(np.abs(numeric[k, i])), 1e-300)
                assert np.max(np.abs(numeric[k, i] - exact)) <= 1e-13 * scale, (p, name)


ISOLATOR_FUNCTIONS = [
    "isolator_stiffness",
    "isolator_axial_stiffness",
    "isolator_stiffness_on_foundation",
    "isolator_axial_stiffness_on_foundation",
]


def _assert_gradient_is_the_central_difference(mod, function: str, parameters: tuple[str, ...], n: int) -> np.ndarray:
    """``function``_gradient() of per-isolator matrices (n x n) by ``parameters`` against the central difference of
    ``function``(), exact up to rounding for matrices linear in them; returns the gradient."""
    values = _values(mod)
    grad = call(mod, f"{function}_gradient", values)
    assert grad.shape == (len(parameters), len(mod.ISOLATORS), n, n)
    for k, p in enumerate(parameters):
        h = 1e-3 * values[p]
        up = call(mod, function, {**values, p: values[p] + h})
        down = call(mod, function, {**values, p: values[p] - h})
        numeric = (up - down) / (2 * h)
        assert np.allclose(grad[k], numeric, rtol=1e-9, atol=1e-9 * max(np.max(np.abs(numeric)), 1e-300)), p
    return grad


@pytest.mark.parametrize("machine", MACHINES)
@pytest.mark.parametrize("function", ISOLATOR_FUNCTIONS)
def test_isolator_stiffness_gradient_matches_a_central_difference(machine, function):
    """Each isolator's stiffness (and its axial part, on the ground or on the foundation's support) is linear in
    the unknown stiffnesses: the central difference is exact up to rounding."""
    mod = generated(machine)
    _assert_gradient_is_the_central_difference(
        mod, function, mod.UNKNOWN, 12 if function.endswith("_on_foundation") else 6
    )


@pytest.mark.parametrize("machine", MACHINES)
def test_isolator_damping_gradient_matches_a_central_difference(machine):
    """Each isolator's damping matrix by the parameters a fit may vary (FITTED_PARAMETERS: the unknowns, then the
    damping parameters), linear in them: the central difference is exact up to rounding, and the damping
    parameters move it."""
    mod = generated(machine)
    grad = _assert_gradient_is_the_central_difference(mod, "isolator_damping", mod.FITTED_PARAMETERS, 6)
    damping = [k for k, p in enumerate(mod.FITTED_PARAMETERS) if p not in mod.UNKNOWN]
    assert damping and all(np.abs(grad[k]).max() > 0 for k in damping)


@pytest.mark.parametrize("machine", MACHINES)
def test_isolator_axial_stiffness_is_the_axial_spring_of_an_independent_assembly(machine):
    """isolator_axial_stiffness() against k_a J^T a a^T J at each isolator of the description assembled in numpy
    apart from the engine (the blind harness's truth machine: a the isolator's own axis, k_a its axial
    stiffness), and no larger than the isolator's whole stiffness."""
    mod = generated(machine)
    truth = TruthMachine(machine)
    values = {**truth.nominal}
    axial = call(mod, "isolator_axial_stiffness", values)
    whole = call(mod, "isolator_stiffness", values)
    for k, iso in enumerate(truth.isolators(values)):
        row = iso.axis @ _jac(iso.point)
        want = iso.stiffness[2] * np.outer(row, row)
        assert np.allclose(axial[k], want, rtol=1e-12, atol=1e-12 * np.max(np.abs(want)))
        assert np.all(np.linalg.eigvalsh(whole[k] - axial[k]) >= -1e-9 * np.max(np.abs(whole[k])))


@pytest.mark.parametrize("machine", MACHINES)
def test_isolators_on_the_support_make_the_foundations_stiffness_but_its_ground_springs(machine):
    """isolator_stiffness_on_foundation(): summed over the isolators, the foundation's C in every entry that
    involves the body (the ground springs act on the support alone); each isolator's body block is its
    stiffness on the ground, and its axial part on the support is no larger than the whole."""
    mod = generated(machine)
    values = _values(mod)
    on = call(mod, "isolator_stiffness_on_foundation", values)
    axial = call(mod, "isolator_axial_stiffness_on_foundation", values)
    c = call(mod, "effect_foundation", values)[1]
    total = on.sum(axis=0)
    scale = np.max(np.abs(c))
    assert np.allclose(total[:6], c[:6], rtol=0, atol=1e-12 * scale)
    assert np.max(np.abs((c - total)[6:, 6:])) > 1e-3 * scale  # the ground springs
    assert np.allclose(on[:, :6, :6], call(mod, "isolator_stiffness", values), rtol=0, atol=1e-12 * scale)
    for k in range(len(mod.ISOLATORS)):
        assert np.all(np.linalg.eigvalsh(on[k] - axial[k]) >= -1e-9 * np.max(np.abs(on[k])))
