"""Mode shapes from channel amplitudes (mountid.identification.shapes): one record's least squares and its
first-order uncertainty against a Monte-Carlo; a roving test's partial shapes fitted together against exact
round trips, an independent solve (scipy.optimize.least_squares) and a Monte-Carlo; where the runs do not determine
the shape, none; and end to end, a roving-accelerometer test through the records chain and the command line."""

from __future__ import annotations

import json

import numpy as np
import pytest
import scipy.linalg
import scipy.optimize
from conftest import budget
from hypothesis import given, settings
from hypothesis import strategies as st

from mountid.identification.shapes import (
    coordinate_shape,
    coordinate_shape_std,
    joint_motion,
    merged_shape,
    real_shape,
    unseen_motion,
)
from mountid.measurement.modes import ChannelShape, scaled_unit

LENGTH = 0.8


def _unit(shape) -> np.ndarray:
    s = np.array(shape, dtype=float)
    s[3:] *= LENGTH
    return s / np.linalg.norm(s)


def _triaxial(point) -> np.ndarray:
    """Channel rows of three sensors along x, y, z at ``point``: u = t + theta x r, q = (x, y, z, rx, ry, rz)."""
    x, y, z = point
    return np.array([[1, 0, 0, 0, z, -y], [0, 1, 0, -z, 0, x], [0, 0, 1, y, -x, 0]], dtype=float)


REFERENCE = _triaxial((0.7, 0.45, 0.2))[2:]  # a vertical sensor kept in place
CORNERS = ((0.7, 0.45, 0.2), (-0.7, 0.45, 0.2), (0.7, -0.45, 0.2))


def _roving_rows(corners=CORNERS) -> list[np.ndarray]:
    """A roving test's runs: the reference beside a triaxial sensor at each corner."""
    return [np.vstack([REFERENCE, _triaxial(c)]) for c in corners]


def _parts(motion, factors, rows, std=None, rng=None) -> list[ChannelShape]:
    parts = []
    for a, r in zip(factors, rows, strict=True):
        s = a * (r @ motion)
        sigma = None if std is None else np.full(len(s), std)
        if rng is not None:
            s = s + (rng.normal(size=len(s)) + 1j * rng.normal(size=len(s))) * std / np.sqrt(2)
        parts.append(ChannelShape(s, sigma, r, LENGTH))
    return parts


def test_coordinate_shape_std_matches_a_monte_carlo():
    """shapes.coordinate_shape_std (first order) against 3000 draws of complex channel noise through
    coordinate_shape: twelve channels of random geometry, a nearly real shape, channel noise of four sizes; the
    part of the unit shape (rotations times the length scale) normal to the noise-free one, per component over
    its five degrees of freedom, within 5 % (sampling error about 1 %)."""
    rng = np.random.default_rng(3)
    rows = rng.normal(size=(12, 6))
    amplitudes = rows @ (rng.normal(size=6) * (1 + 0.05j))
    std = np.repeat([0.01, 0.02, 0.04, 0.08], 3) * np.abs(amplitudes).mean()
    clean = _unit(coordinate_shape(rows, amplitudes))
    normal = []
    for _ in range(3000):
        noise = (rng.normal(size=12) + 1j * rng.normal(size=12)) * std / np.sqrt(2)
        u = _unit(coordinate_shape(rows, amplitudes + noise))
        normal.append(u - (u @ clean) * clean)
    scatter = np.sqrt(np.mean(np.sum(np.square(normal), axis=1)) / 5)
    assert scatter == pytest.approx(coordinate_shape_std(rows, amplitudes, std, LENGTH), rel=0.05)


@settings(max_examples=budget(40))
@given(
    motion=st.lists(st.floats(-1, 1), min_size=12, max_size=12),
    factors=st.lists(st.tuples(st.floats(0.2, 5.0), st.floats(-np.pi, np.pi)), min_size=3, max_size=3),
)
def test_noise_free_runs_give_back_the_motion(motion, factors):
    """Round trip: a motion seen by three runs, each scaled by a complex factor of its own hit, comes back from
    their partial shapes: the factors relative to the first run's and the shape of the motion, to rounding."""
    q = np.array(motion[:6]) + 1j * np.array(motion[6:])
    if np.linalg.norm(q) < 0.1:
        return
    a = np.array([m * np.exp(1j * p) for m, p in factors])
    found, cov = joint_motion(_parts(q, a, _roving_rows()))
    assert cov is None  # no channel noise stated
    np.testing.assert_allclose(found, q * a[0], atol=1e-9 * np.abs(q * a[0]).max())
    assert real_shape(found) == pytest.approx(real_shape(q), abs=1e-9)


def test_the_fit_is_the_least_squares_optimum():
    """With noise, the joint fit's motion is where an independent solver (scipy.optimize.least_squares on the real
    and imaginary parts of the motion and of the later runs' factors) ends from another start, and the first-order
    covariance is that solver's (J^T J)^-1 at its optimum: four runs, 0.5 % noise."""
    rng = np.random.default_rng(7)
    q = np.array([0.3, -0.1, 1.0, 0.2, -0.4, 0.05]) * (1 + 0.1j)
    a = np.array([1.0, 0.8 * np.exp(0.4j), 1.3 * np.exp(-1.1j), 0.6 * np.exp(2.0j)])
    rows = _roving_rows((*CORNERS, (-0.7, -0.45, 0.0)))
    parts = _parts(q, a, rows, std=0.005, rng=rng)
    found, cov = joint_motion(parts)

    def residuals(x):
        motion = x[:6] + 1j * x[6:12]
        factors = np.concatenate([[1.0], x[12:15] + 1j * x[15:18]])
        each = zip(factors, parts, strict=True)
        r = np.concatenate([(f * (p.rows @ motion) - p.amplitudes) / p.std for f, p in each])
        return np.sqrt(2.0) * np.concatenate([r.real, r.imag])

    start = np.concatenate([np.ones(6), np.zeros(6), np.ones(3), np.zeros(3)])
    solved = scipy.optimize.least_squares(residuals, start, xtol=1e-15, ftol=1e-15, gtol=1e-15)
    np.testing.assert_allclose(found, solved.x[:6] + 1j * solved.x[6:12], atol=1e-9)
    chi2 = float(np.sum(solved.fun**2))
    scale = max(1.0, chi2 / (len(solved.fun) - len(start)))
    reference = np.linalg.inv(solved.jac.T @ solved.jac) * scale
    np.testing.assert_allclose(cov, reference[:12, :12], rtol=1e-5, atol=1e-12)  # of [Re q, Im q]


def test_merged_shape_std_matches_a_monte_carlo():
    """merged_shape's standard deviation (first order, the factors' uncertainty included) against 2000 draws of
    channel noise through the joint fit: three runs of the roving layout, 1 % noise, within 6 %."""
    rng = np.random.default_rng(11)
    q = np.array([0.2, 0.1, 1.0, 0.3, -0.2, 0.1]) * (1 + 0.05j)
    a = np.array([1.0, 0.7 * np.exp(0.9j), 1.4 * np.exp(-0.5j)])
    rows = _roving_rows()
    clean, std = merged_shape(_parts(q, a, rows, std=0.01))
    clean = _unit(clean)
    normal = []
    for _ in range(2000):
        u = _unit(merged_shape(_parts(q, a, rows, std=0.01, rng=rng))[0])
        normal.append(u - (u @ clean) * clean)
    scatter = np.sqrt(np.mean(np.sum(np.square(normal), axis=1)) / 5)
    assert scatter == pytest.approx(std, rel=0.06)


def test_runs_that_do_not_determine_the_shape_give_none():
    """No shape where the runs leave something open: two triaxial corners and a reference at one of them leave
    the rotation about the line through the corners; too few channels for the motion and the factors; a run
    that does not see the mode (its factor has no start)."""
    q = np.array([0.2, 0.1, 1.0, 0.3, -0.2, 0.1])
    two = [np.vstack([REFERENCE, _triaxial(c)]) for c in CORNERS[:2]]
    assert merged_shape(_parts(q, [1.0, 0.5j], two)) is None
    few = [REFERENCE, _triaxial(CORNERS[1])[:2]]
    assert merged_shape(_parts(q, [1.0, 2.0], few)) is None
    blind = _parts(q, [1.0, 2.0, 0.0], _roving_rows())
    assert merged_shape(blind) is None
    assert merged_shape(_parts(q, [1.0, 2.0, 0.5], _roving_rows()))[0] == pytest.approx(real_shape(q + 0j), abs=1e-9)


def test_a_roving_accelerometer_test_gives_every_shape():
    """A roving-accelerometer test of the rectangular machine (no twins): a vertical reference kept in place, a
    triaxial sensor moved to three corners, one hit each of a different force. No run alone spans the six
    motions (no shape); together every mode's shape comes back, within its stated uncertainty of the rig's
    mode (the component normal to it, over five degrees of freedom: chi^2 of 30 below its 99.9 % point 59.7),
    and the notes say how."""
    from mountid.identification.combination import every_decay
    from mountid.identification.from_records import modal_data
    from mountid.measurement.rig import Hammer, Rig, Sensor

    rig = Rig.of("rectangular")
    machine = rig.machine
    runs = []
    for k, corner in enumerate(CORNERS):
        sensors = [Sensor("R_z", CORNERS[0], (0, 0, 1), noise=0.02)]
        sensors += [Sensor(f"P{k}_{d}", corner, v, noise=0.02) for d, v in zip("xyz", np.eye(3), strict=True)]
        hit = Hammer((0.6, 0.4, 0.3), (1.0, 0.8, -0.6), peak=3000.0 * (1 + 0.2 * k))
        runs.append((f"run {k + 1}", rig.simulate(sensors, 6.0, 1000.0, hammers=[hit], seed=k)))
    alone = modal_data(machine, runs[0][1], {})
    assert all(m.shape is None and m.channels is not None for m in alone.modes.values())
    found = every_decay(machine, runs, {})
    assert set(found.modes) == set(machine.module.MODES)
    length = machine.length_scale({})
    true = scaled_unit(scipy.linalg.eigh(rig.C, rig.M)[1], length)
    chi2 = 0.0
    for label, mode in found.modes.items():
        u = scaled_unit(np.array(mode.shape)[:, None], length)[:, 0]
        t = true[:, int(np.argmax(np.abs(true.T @ u)))]
        assert abs(u @ t) > 0.999, label
        chi2 += float(np.sum((u - (u @ t) * t) ** 2)) / mode.shape_std**2
        said = [n for n in found.notes if n.startswith(f"{label}: ")]
        assert "shape from the channels of all 3 together" in said[0]
    assert chi2 < 59.7


def test_twins_one_pole_stands_for_are_not_merged():
    """kid300's twins (x and y, psi and theta: equal by symmetry) give one pole each per run, in the mix its hit
    gave: no factor scales one run's mix onto another's, and those shapes stay out; z and phi have no twin and
    come together from the runs."""
    from mountid.identification.combination import every_decay
    from mountid.measurement.rig import Hammer, Rig, Sensor

    rig = Rig.of("kid300")
    runs = []
    for k, corner in enumerate(((0.4, 0.3, 0.3), (-0.4, 0.3, 0.3), (0.4, -0.3, 0.3))):
        sensors = [Sensor("R_z", (0.4, 0.3, 0.3), (0, 0, 1), noise=0.01)]
        sensors += [Sensor(f"P{k}_{d}", corner, v, noise=0.01) for d, v in zip("xyz", np.eye(3), strict=True)]
        hit = Hammer((0.35, 0.25, 0.3), (1.0, 0.8 - 0.5 * k, -0.6), peak=3000.0)
        runs.append((f"run {k + 1}", rig.simulate(sensors, 4.0, 2000.0, hammers=[hit], seed=k)))
    found = every_decay(rig.machine, runs, {})
    assert found.modes["z"].shape is not None and found.modes["phi"].shape is not None
    assert found.modes["x"].shape is None and found.modes["psi"].shape is None


def test_a_roving_export_gives_shapes_to_process_and_a_campaign(tmp_path, capsys):
    """A roving-accelerometer test exported to one UFF file (the reference's dataset first in each run, then the
    moved sensor's three): `process` reads its runs and gives every mode's shape from them together; a campaign of
    the file has every shape, their noise in its notes, and no sensor layout of the shapes (they come from three)."""
    import pyuff

    from mountid.cli import main
    from mountid.diagnosis import campaign
    from mountid.measurement.rig import Hammer, Rig, Sensor
    from mountid.measurement.uff import _axis, dataset_58, placement

    rig, sets = Rig.of("rectangular"), []
    for k, corner in enumerate(CORNERS):
        sensors = [Sensor("R_z", CORNERS[0], (0, 0, 1), noise=0.02)]
        sensors += [Sensor(f"P{k}_{d}", corner, v, noise=0.02) for d, v in zip("xyz", np.eye(3), strict=True)]
        hit = Hammer((0.6, 0.4, 0.3), (1.0, 0.8, -0.6), peak=3000.0 * (1 + 0.2 * k))
        record = rig.simulate(sensors, 6.0, 1000.0, hammers=[hit], seed=k)
        for j, c in enumerate(record.channels):  # the reference at node 1, the moved sensor at node 2, 3, 4
            node = 1 if j == 0 else 2 + k
            sets.append(dataset_58(c, record.time, record.data[:, j], node, _axis(c.direction), placement(c)))
    pyuff.UFF(str(tmp_path / "roving.uff")).write_sets(sets, mode="add")
    assert main(["process", "rectangular", str(tmp_path / "roving.uff"), "--json"]) == 0
    modes = json.loads(capsys.readouterr().out)["modes"]
    assert set(modes) == {"x", "y", "z", "phi", "theta", "psi"}
    assert all(m["shape"] is not None and m["shape_std"] > 0 for m in modes.values())
    c = campaign.parse({"machine": "rectangular", "records": ["roving.uff"]}, tmp_path)
    assert all(c.modes[label].shape is not None for label in modes)
    assert any(n.startswith("shape uncertainty per component: the record's noise (") for n in c.record_notes)
    assert not c.sensors


def test_the_sharpest_record_with_a_shape_gives_it():
    """Two records of one mode: a partial layout (the reference beside one triaxial sensor) of little noise, whose
    frequencies are the sharper, and a full layout of more noise. The mode's shape is the full layout's (the
    sharpest record left the mode without one), named in the note."""
    from mountid.identification.combination import every_decay
    from mountid.measurement.rig import Hammer, Rig, Sensor

    rig = Rig.of("rectangular")
    hit = Hammer((0.6, 0.4, 0.3), (1.0, 0.8, -0.6), peak=3000.0)
    partial = [Sensor("R_z", CORNERS[0], (0, 0, 1), noise=0.002)]
    partial += [Sensor(f"P_{d}", CORNERS[1], v, noise=0.002) for d, v in zip("xyz", np.eye(3), strict=True)]
    full = [
        Sensor(f"F{k}_{d}", c, v, noise=0.05)
        for k, c in enumerate(CORNERS)
        for d, v in zip("xyz", np.eye(3), strict=True)
    ]
    runs = [
        ("partial", rig.simulate(partial, 6.0, 1000.0, hammers=[hit], seed=1)),
        ("full", rig.simulate(full, 6.0, 1000.0, hammers=[hit], seed=2)),
    ]
    found = every_decay(rig.machine, runs, {})
    for label, mode in found.modes.items():
        assert mode.shape is not None, label
        said = next(n for n in found.notes if n.startswith(f"{label}: frequency"))
        assert "shape from full" in said, said


def test_what_two_triaxial_sensors_do_not_see_is_the_rotation_about_the_line_through_them():
    """Two triaxial sensors see five of the six rigid-body motions: the rotation about the line through them moves
    neither. The note names that line (through the point nearest the origin, along its direction); rows built by
    hand from u = t + theta x r, apart from the engine's sensor rows."""
    rows = np.vstack([_triaxial((0.4, 0.3, 0.2)), _triaxial((-0.4, -0.3, 0.2))])
    assert unseen_motion(rows, LENGTH) == (
        "the channels see 5 of the six rigid-body motions, not a rotation about the axis through (0, 0, 0.2) m "
        "along (0.8, 0.6, 0); a channel that moves in it would give them"
    )
    a, b = np.array([1.0, 2.0, 3.0]), np.array([0.5, -1.0, 2.0])
    along = (a - b) / np.linalg.norm(a - b)
    nearest = a - (a @ along) * along
    said = unseen_motion(np.vstack([_triaxial(a), _triaxial(b)]), LENGTH)
    fmt = ", ".join
    assert said.endswith(
        f"through ({fmt(f'{v:.3g}' for v in nearest)}) m along ({fmt(f'{v:.3g}' for v in along)}); a channel that "
        "moves in it would give them"
    ), said


def test_what_channels_do_not_see_a_translation_a_screw_or_several_motions():
    """Channels along y and z only never see a translation along x; five rows orthogonal to a screw (a rotation
    about z through (0, 0.1, 0) with 0.05 m along z per radian) leave that screw; four rows leave two motions;
    channels that see all six give no note."""
    points = ((0.7, 0.45, 0.2), (-0.7, 0.45, 0.2), (0.7, -0.45, 0.2))
    yz = np.vstack([_triaxial(p)[1:] for p in points])
    assert unseen_motion(yz, LENGTH) == (
        "the channels see 5 of the six rigid-body motions, not a translation along (1, 0, 0); a channel that moves "
        "in it would give them"
    )
    screw = np.array([0.1, 0.0, 0.05, 0.0, 0.0, 1.0])  # t = (0.1, 0, 0.05), theta = (0, 0, 1)
    rows = scipy.linalg.null_space(screw[None, :]).T
    assert unseen_motion(rows, LENGTH) == (
        "the channels see 5 of the six rigid-body motions, not a rotation about the axis through (0, 0.1, 0) m "
        "along (0, 0, 1) with 0.05 m along it per radian; a channel that moves in it would give them"
    )
    assert unseen_motion(yz[:4], LENGTH) == (
        "the channels see 4 of the six rigid-body motions: channels along 2 more independent directions would give "
        "them"
    )
    assert unseen_motion(np.vstack([_triaxial(p) for p in points]), LENGTH) == ""
