"""The blind harness's truth machines (mountid.validation.blind_truth): assembled in numpy from the description
files alone, they agree with the engine's generated modules where both describe the same physics, and their
twin modes do not depend on the basis LAPACK returns."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import MACHINES

from mountid.machine import Machine, call, matrices
from mountid.machine.symmetry import MIRRORS
from mountid.validation import blind, blind_truth

PRODUCTS = """
name = "skewed_press"
symmetry = []

[parameters]
m    = { kind = "mass",      role = "known",   value = 1800.0 }
J_x  = { kind = "inertia",   role = "known",   value = 300.0 }
J_y  = { kind = "inertia",   role = "known",   value = 520.0 }
J_z  = { kind = "inertia",   role = "known",   value = 610.0 }
P_xy = { kind = "inertia",   role = "known",   value = 25.0 }
P_xz = { kind = "inertia",   role = "known",   value = 45.0 }
P_yz = { kind = "inertia",   role = "known",   value = 15.0 }
a    = { kind = "length",    role = "known",   value = 0.8 }
b    = { kind = "length",    role = "known",   value = 0.5 }
h    = { kind = "length",    role = "known",   value = 0.4 }
tilt = { kind = "angle",     role = "known",   value = 0.2 }
c_h  = { kind = "stiffness", role = "unknown", value = 2.0e5 }
c_z  = { kind = "stiffness", role = "unknown", value = 8.0e5 }

[body]
mass = "m"
inertia = ["J_x", "J_y", "J_z"]
products_of_inertia = ["P_xy", "P_xz", "-P_yz"]
centre_of_mass = ["h/8", "-h/10", "h/10"]

[[isolators]]
name = "a"
point = ["a", "b", "-h"]
stiffness = ["c_h", "0.8*c_h", "c_z"]
inclination = ["tilt", "tilt/2", 0]

[[isolators]]
name = "b"
point = ["-a", "b*cos(pi/6)", "-h"]
stiffness = ["c_h", "c_h", "c_z"]

[[isolators]]
name = "c"
point = ["-a", "-b", "-h"]
stiffness = ["c_h", "c_h", "c_z"]
inclination = [0, 0, "tilt"]

[[isolators]]
name = "d"
point = ["a", "-b", "-1.1*h"]
stiffness = ["c_h", "c_h", "1.2*c_z"]
"""


def _compare(truth: blind_truth.TruthMachine, machine: Machine) -> None:
    values = dict(truth.nominal)
    m, c, b = blind_truth.truth_matrices(truth, blind_truth.Truth("none", {}, {}, truth.name))
    for mine, generated in zip((m, c, b), matrices(machine.module, values), strict=True):
        scale = max(np.max(np.abs(generated)), 1e-300)
        assert np.max(np.abs(mine - generated)) <= 1e-13 * scale
    points = np.asarray(call(machine.module, "isolator_points", values))
    assert np.array([i.point for i in truth.isolators(values)]).T == pytest.approx(points, abs=1e-14)
    assert truth.length == pytest.approx(float(call(machine.module, "effect_scales", values)["length"]), rel=1e-14)


@pytest.mark.parametrize("name", sorted(set(MACHINES) | set(blind.MACHINES)))
def test_every_shipped_machine_assembled_apart_from_the_engine_agrees_with_it(name):
    """M, C, B, the isolators in the generated order and the length scale."""
    _compare(blind_truth.TruthMachine(name), Machine.resolve(name))


def test_products_of_inertia_inclined_isolators_and_an_offset_centre_agree(tmp_path):
    """Products of inertia in the documented order [J_xy, J_xz, J_yz] (the engine read them in the reverse
    order until this test), isolators inclined about two axes and turned, no plane of symmetry."""
    path = tmp_path / "skewed_press.toml"
    path.write_text(PRODUCTS, encoding="utf-8")
    truth = blind_truth.TruthMachine("skewed_press", path)
    assert truth.inertia(truth.nominal)[0, 1] == -25.0 and truth.inertia(truth.nominal)[1, 2] == 15.0
    _compare(truth, Machine.resolve(str(path)))


def test_twin_modes_do_not_depend_on_the_eigenvector_basis(monkeypatch):
    """A support frame below isolators on the diagonals keeps the x/y and psi/theta twins exactly equal: any
    rotation of each twin pair is a solution of the eigenproblem, and the truth returns the same shapes."""
    machine = Machine.resolve("kid300")
    truth = blind_truth.TruthMachine("kid300")
    t = blind_truth.Truth("support_frame", {"m": 900.0, "k": 2.0e7, "horizontal": 0.4}, {})
    omega, shapes = blind_truth.true_modes(truth, machine, t)
    eigh = blind_truth.scipy.linalg.eigh

    def rotated(c, m):
        lam, vec = eigh(c, m)
        for j in range(len(lam) - 1):
            if abs(lam[j + 1] - lam[j]) <= 1e-9 * lam[j]:
                a = 0.7
                turn = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
                vec[:, j : j + 2] = vec[:, j : j + 2] @ turn
        return lam, vec

    monkeypatch.setattr(blind_truth.scipy.linalg, "eigh", rotated)
    omega2, shapes2 = blind_truth.true_modes(truth, machine, t)
    assert omega2 == pytest.approx(omega, rel=1e-12)
    signs = np.sign(np.sum(shapes * shapes2, axis=0))
    assert shapes2 * signs == pytest.approx(shapes, abs=1e-10)
    # the twins' shapes are the nominal ones projected: x moves along x (with theta), y along y (with psi)
    assert abs(shapes[1, 0]) < 1e-9 and abs(shapes[0, 1]) < 1e-9


@pytest.mark.parametrize(("machine", "seed"), [("kid300", 0), ("screen6", 4)])
def test_hardening_isolators_keep_each_modes_symmetry(monkeypatch, machine, seed):
    """The equivalent linearisation of hardening isolators is a fixed point per mode. Where a mode of the other
    mirror parity lies close once stiffened (kid300's psi and theta 0.1 rad/s apart, screen6 seed 4's), the
    iteration amplified rounding: psi drifted to a rotation about a diagonal, theta's shape, and which fixed point
    it reached depended on the order of a sum. Each mode keeps the parity its linear shape has in the machine's
    mirror planes, psi and theta stay M-orthogonal, and a rounding-level disturbance of every eigensolution
    leaves the result where it was."""
    model = Machine.resolve(machine)
    truth = blind_truth.TruthMachine(machine)
    _, t = blind.make_case(seed, "nonlinear_isolator", machine=machine)
    (m, _, _), _, linear = blind_truth.labelled_modes(truth, model, t)
    omega, shapes = blind_truth.true_modes(truth, model, t)
    for k in range(6):
        for mirror in MIRRORS:
            before = linear[:, k] @ m @ mirror @ linear[:, k] / (linear[:, k] @ m @ linear[:, k])
            after = shapes[:, k] @ m @ mirror @ shapes[:, k] / (shapes[:, k] @ m @ shapes[:, k])
            assert abs(abs(before) - 1) < 1e-9 and after == pytest.approx(before, abs=1e-9)
    psi, theta = (model.module.MODES.index(label) for label in ("psi", "theta"))
    assert abs(shapes[:, psi] @ m @ shapes[:, theta]) < 1e-9
    eigh = blind_truth.scipy.linalg.eigh
    rng = np.random.default_rng(1)

    def disturbed(c, mass):
        lam, vec = eigh(c, mass)
        return lam, vec + 1e-13 * rng.standard_normal(vec.shape) * np.abs(vec).max()

    monkeypatch.setattr(blind_truth.scipy.linalg, "eigh", disturbed)
    omega2, shapes2 = blind_truth.true_modes(truth, model, t)
    assert omega2 == pytest.approx(omega, rel=1e-9) and shapes2 == pytest.approx(shapes, abs=1e-8)


@pytest.mark.parametrize("name", blind.MACHINES)
def test_every_truth_draws_on_every_machine(name):
    """Every truth of the harness (the cycle's and those beside it) has a size and physics on every machine, and
    changes its modes."""
    machine = Machine.resolve(name)
    truth = blind_truth.TruthMachine(name)
    without = blind_truth.true_modes(truth, machine, blind_truth.Truth("none", {}, {}, name))
    for effect in blind.TRUTHS[1:]:
        size = blind_truth.sample(np.random.default_rng(5), effect, truth)
        modes = blind_truth.true_modes(truth, machine, blind_truth.Truth(effect, size, {}, name))
        assert all(np.all(np.isfinite(a)) for a in modes), effect
        changed = [not np.allclose(a, b, rtol=1e-9, atol=1e-12) for a, b in zip(modes, without, strict=True)]
        assert any(changed), f"the truth {effect} does not change the modes of {name}"


def test_a_tilted_isolator_turns_its_own_stiffness_and_damping_alone():
    """isolator_tilted: one isolator's stiffness and damping keep their principal values along axes turned by the
    tilt about a horizontal axis; every other isolator and the mass stay as described; no tilt is no effect. The
    isolator's tensor is read back from C (C = sum J^T K J with J = [I, -r x], so the translational block of a
    change of C is the change of K)."""
    truth = blind_truth.TruthMachine("rectangular")
    nominal = blind_truth.truth_matrices(truth, blind_truth.Truth("none", {}, {}, "rectangular"))
    size = {"isolator": 1, "tilt": 0.0, "about": 0.7}
    untilted = blind_truth.truth_matrices(truth, blind_truth.Truth("isolator_tilted", size, {}, "rectangular"))
    assert all(np.allclose(a, b, rtol=1e-14, atol=0) for a, b in zip(untilted, nominal, strict=True))
    tilted = blind_truth.truth_matrices(
        truth, blind_truth.Truth("isolator_tilted", {**size, "tilt": 0.2}, {}, "rectangular")
    )
    assert np.array_equal(tilted[0], nominal[0])
    iso = truth.isolators(truth.nominal)[1]
    across = np.array([math.cos(0.7), math.sin(0.7), 0.0])
    jac = np.hstack([np.eye(3), -np.cross(iso.point, np.eye(3)).T])  # u = t + w x r at the isolator's point
    for got, was, local in ((tilted[1], nominal[1], iso.stiffness), (tilted[2], nominal[2], iso.damping)):
        change = got - was
        np.testing.assert_allclose(change, jac.T @ change[:3, :3] @ jac, atol=1e-9 * np.abs(was).max())
        tensor = iso.tensor(local) + change[:3, :3]
        values, vectors = np.linalg.eigh(tensor)
        np.testing.assert_allclose(values, np.sort(local), rtol=1e-9)
        axial = vectors[:, np.argmin(np.abs(values - local[2]))]
        assert math.isclose(abs(axial @ iso.axis), math.cos(0.2), rel_tol=1e-9)
        assert abs(axial @ across) < 1e-9  # turned about the horizontal axis across it


def test_a_measured_mode_is_one_pole_however_heavy_damping_reorders_the_modes():
    """Blind case (seed 90, genset8, damping 3.4 times the described): z and psi (37.6 and 38.5 rad/s damped) have
    damping ratios 0.28 and 0.38, and the more damped one's damped frequency falls below the other's. Each
    mode's frequency and damping ratio are one pole of the truth (its frequency was once the pole of the next
    damped frequency, its damping ratio the pole of its shape)."""
    machine = Machine.resolve("genset8")
    truth = blind_truth.TruthMachine("genset8")
    _, t = blind.make_case(90, "damping", kind="damping", machine="genset8")
    omega, shapes = blind_truth.true_modes(truth, machine, t)
    zeta = blind_truth.true_damping_ratios(truth, machine, t)
    m, c, b = blind_truth.truth_matrices(truth, t)
    n = len(m)
    a = np.block([[np.zeros((n, n)), np.eye(n)], [-np.linalg.solve(m, c), -np.linalg.solve(m, b)]])
    poles = np.linalg.eigvals(a)
    measured = omega / np.sqrt(1 - zeta**2) * (-zeta + 1j * np.sqrt(1 - zeta**2))  # |p| from omega_d and zeta
    for p in measured:
        assert np.min(np.abs(poles - p)) < 1e-9 * abs(p)
    assert max(zeta) > 0.35  # heavy enough to reorder z and psi


def test_a_support_truths_damped_poles_are_told_apart_by_the_whole_shape():
    """Blind case (seed 106, rectangular, a support of its own mass under the feet, 12 coordinates): paired by
    the body's part of their shapes alone, z (49 rad/s) read the damping ratio of a support mode at 278 rad/s.
    Paired by the whole mass-weighted shape, every labelled mode's pole lies at its own frequency."""
    machine = Machine.resolve("rectangular")
    truth = blind_truth.TruthMachine("rectangular")
    _, t = blind.make_case(106, "foundation", kind="damping", machine="rectangular")
    (m, c, b), lam, modes = blind_truth.labelled_modes(truth, machine, t)
    assert len(m) == 12
    poles = blind_truth.true_poles(m, c, b, modes)
    assert np.abs(poles) == pytest.approx(np.sqrt(lam), rel=0.01)


def test_two_channels_misread_at_once_reduce_to_one_when_the_other_reads_true():
    """Two channels turned or misplaced, or one turned and misplaced. With the second turn (the offset) nil, each
    reads exactly as the catalogue's single-channel truth; with both, the readings differ from either alone."""
    truth = blind_truth.TruthMachine("kid300")
    machine = Machine.resolve("kid300")
    _, shapes = blind_truth.true_modes(truth, machine, blind_truth.Truth("none", {}, {}, "kid300"))
    turn = {"channel": 4, "angle": 0.2, "about": 1.0}

    def read(effect: str, size: dict[str, float]) -> np.ndarray:
        return blind_truth._misread(truth, shapes, blind_truth.Truth(effect, size, {}, "kid300"))

    one = read("sensor_turned", turn)
    two = {**turn, "channel_2": 9, "angle_2": 0.15, "about_2": 2.0}
    assert np.array_equal(read("sensor_turned+sensor_turned", {**two, "angle_2": 0.0}), one)
    both = read("sensor_turned+sensor_turned", two)
    assert not np.allclose(both, one, atol=1e-6)
    assert not np.allclose(both, read("sensor_turned", {"channel": 9, "angle": 0.15, "about": 2.0}), atol=1e-6)
    offset = {"x": 0.1, "y": -0.05, "z": 0.02}
    assert np.array_equal(read("sensor_turned+sensor_misplaced", {**turn, "x": 0.0, "y": 0.0, "z": 0.0}), one)
    misplaced = read("sensor_misplaced", {"channel": 4, **offset})
    assert np.array_equal(read("sensor_turned+sensor_misplaced", {**turn, **offset, "angle": 0.0}), misplaced)
    combined = read("sensor_turned+sensor_misplaced", {**turn, **offset})
    assert not np.allclose(combined, one, atol=1e-6) and not np.allclose(combined, misplaced, atol=1e-6)
    second = {"channel_2": 9, "x_2": -0.2, "y_2": 0.0, "z_2": 0.1}
    nil = {"x_2": 0.0, "y_2": 0.0, "z_2": 0.0}
    assert np.array_equal(
        read("sensor_misplaced+sensor_misplaced", {"channel": 4, **offset, **second, **nil}), misplaced
    )
    apart = read("sensor_misplaced+sensor_misplaced", {"channel": 4, **offset, **second})
    assert not np.allclose(apart, misplaced, atol=1e-6)
    assert not np.allclose(apart, read("sensor_misplaced", {"channel": 9, "x": -0.2, "y": 0.0, "z": 0.1}), atol=1e-6)


def test_a_reversed_channel_reads_as_one_turned_by_pi():
    """One channel of reversed polarity reads along -d, as a turn by pi about any axis across it would (to
    rounding); its shapes differ from the true ones, and every other channel reads true."""
    truth = blind_truth.TruthMachine("kid300")
    machine = Machine.resolve("kid300")
    _, shapes = blind_truth.true_modes(truth, machine, blind_truth.Truth("none", {}, {}, "kid300"))

    def read(effect: str, size: dict[str, float]) -> np.ndarray:
        return blind_truth._misread(truth, shapes, blind_truth.Truth(effect, size, {}, "kid300"))

    reversed_ = read("sensor_reversed", {"channel": 7})
    assert np.allclose(reversed_, read("sensor_turned", {"channel": 7, "angle": math.pi, "about": 0.4}), atol=1e-12)
    assert not np.allclose(reversed_, shapes, atol=1e-3)
    layout = blind_truth.sensor_layout(truth)
    rows = np.array([d @ blind_truth._jac(r) for _, r, d in layout])
    readings = rows @ shapes
    readings[7] *= -1
    assert np.allclose(reversed_, np.linalg.lstsq(rows, readings, rcond=None)[0], atol=1e-12)
