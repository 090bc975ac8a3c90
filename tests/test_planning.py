"""Test planning (mountid plan): the paper's case before the test, against the records chain after it."""

from __future__ import annotations

import json

import numpy as np
import pytest

from mountid.cli import main
from mountid.identification.from_records import identify_from_record
from mountid.identification.planning import plan, plan_output_only
from mountid.machine import Machine
from mountid.measurement.rig import Rig, Sensor
from mountid.validation.paper import TABLE_1, paper_hit, paper_sensors


@pytest.fixture(scope="module")
def paper_plan():
    return plan(Machine.resolve("kid300"), paper_sensors()[:3], paper_hit(), 4.0, 2048.0, 0.01)


def test_the_papers_three_channels_cannot_see_z(paper_plan):
    assert paper_plan.unseen == ["z"] and paper_plan.not_excited == []
    measured = {m.label for m in paper_plan.modes if m.measured}
    assert measured == {"x", "y", "psi", "theta", "phi"}


def test_the_plan_predicts_what_the_records_chain_states_and_scatters(paper_plan):
    """Twelve simulated 4 s records of the paper's test: the plan's frequency standard deviations are those
    the chain states (within 15 %), its stiffness standard deviations match the chain's scatter (within a
    factor 1.6, the scatter of 12 draws being itself uncertain by about 20 %)."""
    rig = Rig.of("kid300")
    found, freq_std = [], []
    for seed in range(12):
        record = rig.simulate(paper_sensors()[:3], 4.0, 2048.0, hammers=[paper_hit()], seed=seed)
        result = identify_from_record(rig.machine, record, TABLE_1, 0.07)
        found.append([result.parameters["c_xy"], result.parameters["c_z"]])
        freq_std.append([result.modes[lab].frequency_std for lab in ("x", "psi", "phi")])
    planned = {m.label: m.frequency_std for m in paper_plan.modes}
    for k, lab in enumerate(("x", "psi", "phi")):
        assert planned[lab] == pytest.approx(np.mean(freq_std, axis=0)[k], rel=0.15), lab
    scatter = np.std(found, axis=0, ddof=1)
    for k, name in enumerate(("c_xy", "c_z")):
        assert 1 / 1.6 < paper_plan.parameter_std[name] / scatter[k] < 1.6, name


def test_effective_independence_proposes_channels_that_see_every_mode(paper_plan):
    rig = Rig.of("kid300")
    mod = rig.machine.module
    phi = mod.modal_matrix(**rig.machine.values(rig.values, mod.FORWARD_ARGUMENTS))
    best = []
    for name, _ in paper_plan.ranking[:6]:
        coords, axis = name.rsplit(" ", 1)
        point = tuple(float(v) for v in coords.strip("()").split(","))
        best.append(rig.sensor_row(point, np.eye(3)["xyz".index(axis)]) @ phi)
    assert np.linalg.matrix_rank(np.array(best)) == 6
    proposal = [Sensor(f"s{k}", *_parse(name)) for k, (name, _) in enumerate(paper_plan.ranking[:6])]
    assert plan(Machine.resolve("kid300"), proposal, paper_hit(), 4.0, 2048.0, 0.01).unseen == []


def _parse(name: str):
    coords, axis = name.rsplit(" ", 1)
    return tuple(float(v) for v in coords.strip("()").split(",")), tuple(np.eye(3)["xyz".index(axis)])


def test_plan_on_the_command_line(capsys):
    assert main(["plan", "kid300"]) == 0
    out = capsys.readouterr().out
    assert "z           47.4637  0.0522    not seen by these channels" in out
    assert "expected std of c_xy: 3.3 N/m" in out
    assert main(["plan", "kid300", "--sensor", "V=0.3,0.3,0.3:0,0,1", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["unseen"] == ["phi"]  # one vertical channel off the axes sees the rocking in x and y, not yaw
    assert main(["plan", "kid300", "--duration", "0.01"]) == 2
    assert "duration: 0.01 s leaves no free decay" in capsys.readouterr().err


def test_modes_above_the_records_band_are_named_and_the_rest_still_planned(capsys):
    """At 10 Hz the anti-alias filter's corner is 4 Hz: phi (5.9 Hz) and psi, theta (10.2 Hz) are above the band
    and not planned as measured; x (2.8 Hz) is, with a larger standard deviation than at 2048 Hz (the hit was
    silent at such rates and the plan stated 0 rad/s); one distinct frequency leaves the stiffness spread
    unstated, with the reason."""
    slow = plan(Machine.resolve("kid300"), paper_sensors()[:3], paper_hit(), 4.0, 10.0, 0.01)
    fast = plan(Machine.resolve("kid300"), paper_sensors()[:3], paper_hit(), 4.0, 2048.0, 0.01)
    assert slow.above_band == ["psi", "theta", "phi"] and fast.above_band == []
    assert [m.label for m in slow.modes if m.measured] == ["x", "y"]
    assert slow.modes[0].frequency_std > 2 * fast.modes[0].frequency_std > 0
    assert all(np.isnan(v) for v in slow.parameter_std.values()) and "1 distinct frequency found" in slow.notes[0]
    assert main(["plan", "kid300", "--rate", "10"]) == 0
    out = capsys.readouterr().out
    assert "phi         36.9373  0.0837    above the record's band (the anti-alias filter at 0.4 x 10 Hz)" in out
    assert "expected std of c_xy: none (see the note)" in out and "nan" not in out


def test_a_hit_at_the_centre_plans_the_stiffness_by_the_descriptions_rule(capsys):
    """A hit at the origin excites x, psi (and their twins) but not z or phi: the two distinct frequencies
    have two solutions, the description's rule (c_z > c_xy) picks one, and the plan states their spread (it
    was a TypeError: the rule's choice went on to compare solutions with other modes that were None); a hit
    direction of components near the ends of double precision is that direction."""
    assert main(["plan", "kid300", "--hit-point", "0,0,0", "--hit-direction", "1e300,1e300,0"]) == 0
    out = capsys.readouterr().out
    assert "along (1e+300, 1e+300, 0.0)" in out and "not excited by this hit" in out
    assert "expected std of c_xy: " in out and "none" not in out


def test_the_plan_says_what_a_shaker_test_needs(paper_plan):
    """From the slowest decay (kid300's x, time constant 1.5 s), what the records chain's rules need of a shaker test
    (frf.shaker_lengths): periodic random settles in 13.9 s (with a tenth of the damping, 139 s: test_frf's lightly
    damped machine leaves 8 periods of 16 s out), burst random 4.5 s of quiet after each burst (test_frf: 8 s read,
    1.6 s named), a random force 96.3 s of record (test_frf: 96 s read, 64 s named)."""
    [note] = [n for n in paper_plan.notes if n.startswith("a shaker test instead")]
    assert "(the slowest decay's time constant 1.5 s): periodic random settles in 13.9 s" in note
    assert "4.5 s of quiet after each burst" in note and "a record of 96.3 s or more" in note


def test_the_plan_says_how_long_an_output_only_test_records(paper_plan):
    """ambient.shortest_record from the lowest mode (kid300's x, 17.7 rad/s): 8 segments, each 4 x 5 of its periods
    and the fit's start, 58.36 s (test_ambient: 30 s named with that length, 600 s read)."""
    [note] = [n for n in paper_plan.notes if n.startswith("an output-only test instead")]
    assert "a record of 58.36 s or more (8 segments, each 4 times 5 periods of the lowest mode)" in note


@pytest.fixture(scope="module")
def ambient_plans():
    """Output-only plans of kid300 with the paper's five channels (100 N RMS at every isolator, 100 Hz, two
    simulated records each), of 300 s and of 1200 s."""
    machine = Machine.resolve("kid300")
    return {t: plan_output_only(machine, paper_sensors(0.01), t, 100.0, 100.0, draws=2) for t in (300.0, 1200.0)}


def test_an_output_only_plan_simulates_the_test_and_shrinks_with_its_length(ambient_plans):
    """Per mode how many simulated records found it and their stated deviations: x, psi and phi in both records of
    either length, each twin as one pole with its partner (y with x, theta with psi: one pole for twins); the
    frequency deviations of the record four times as long about half, as a geometric mean over x, psi and phi (the
    jackknife's deviation falls as the square root of the length, a little faster where the longer record's
    correlation functions are fitted to longer lags: 0.3-0.8 allowed, two records' medians of deviations of seven
    degrees of freedom each: per mode the ratio's log spread is about 0.38, over three modes 0.22); the stiffness
    deviations likewise (c_xy 0.48, c_z 0.35 seen); a mode found in fewer than half the records is not counted as
    measured."""
    short, long = ambient_plans[300.0], ambient_plans[1200.0]
    for result in (short, long):
        by = {m.label: m for m in result.modes}
        for label, partner in (("x", "x"), ("y", "x"), ("psi", "psi"), ("theta", "psi"), ("phi", "phi")):
            assert by[label].found == (2, 2) and by[label].pole_of == partner and by[label].measured, label
        assert by["y"].frequency_std == by["x"].frequency_std
        assert all(m.measured == (2 * m.found[0] >= m.found[1]) for m in result.modes)
        assert result.notes[0].startswith("simulated: 2 records of ")
    ratios = [
        next(m for m in long.modes if m.label == label).frequency_std
        / next(m for m in short.modes if m.label == label).frequency_std
        for label in ("x", "psi", "phi")
    ]
    assert 0.3 < np.prod(ratios) ** (1 / 3) < 0.8  # 0.39 seen (x 0.54, psi 0.41, phi 0.28)
    for name in ("c_xy", "c_z"):
        assert 0.3 < long.parameter_std[name] / short.parameter_std[name] < 0.8, name


def test_an_output_only_plan_on_the_command_line(capsys):
    """plan --ambient prints the simulated records' findings (--json alike); a hit's options, --draws out of range
    or without --ambient, and a record shorter than the records chain reads are errors naming the option."""
    base = ["plan", "kid300", "--ambient", "100", "--duration", "300", "--draws", "1"]
    assert main([*base, "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert {m["label"]: m["found"] for m in result["modes"]}["x"] == [1, 1]
    assert main(base) == 0
    out = capsys.readouterr().out
    assert "output-only (random forces of 100 N RMS at every isolator), 300 s at 100 Hz" in out
    assert "not seen by these channels" in out and "found in" in out
    refusals = [
        ([*base, "--hit-point", "0,0,0"], "--hit-point: an output-only plan has no hit"),
        (["plan", "kid300", "--ambient", "100", "--draws", "0"], "--draws: 0: simulate 1 to 100 records"),
        (["plan", "kid300", "--draws", "3"], "--draws: is for an output-only plan (--ambient)"),
        (
            ["plan", "kid300", "--ambient", "100", "--duration", "30"],
            "duration: 30 s: the records chain reads an output-only record of 58.88 s or more",
        ),
    ]
    for args, message in refusals:
        assert main(args) == 2
        assert message in capsys.readouterr().err


def test_the_plan_says_which_motion_its_channels_do_not_see(paper_plan, ambient_plans):
    """A layout that will give no mode shapes says so before the test, naming what it does not see
    (shapes.unseen_motion), as the records chain's note on its record does: the paper's three channels see three
    of the six rigid-body motions, its five miss the rotation about an axis along y, two triaxial sensors the
    rotation about the line through them; a third triaxial sensor off that line leaves no note."""
    assert [n for n in paper_plan.notes if n.startswith("no mode shapes")] == [
        "no mode shapes: the channels see 3 of the six rigid-body motions: channels along 3 more independent "
        "directions would give them"
    ]
    five = (
        "no mode shapes: the channels see 5 of the six rigid-body motions, not a rotation about the axis through "
        "(0.45, 0, 0.1) m along (0, 1, 0); a channel that moves in it would give them"
    )
    assert all(five in result.notes for result in ambient_plans.values())

    def triaxial(*points):
        return [Sensor(f"P{i}{a}", p, d) for i, p in enumerate(points) for a, d in zip("xyz", np.eye(3), strict=True)]

    kid300, ends = Machine.resolve("kid300"), ((0.4, 0.3, 0.2), (-0.4, -0.3, 0.2))
    two = plan(kid300, triaxial(*ends), paper_hit(), 4.0, 2048.0, 0.01)
    assert [n for n in two.notes if n.startswith("no mode shapes")] == [
        "no mode shapes: the channels see 5 of the six rigid-body motions, not a rotation about the axis through "
        "(0, 0, 0.2) m along (0.8, 0.6, 0); a channel that moves in it would give them"
    ]
    three = plan(kid300, triaxial(*ends, (0.4, -0.3, 0.2)), paper_hit(), 4.0, 2048.0, 0.01)
    assert not [n for n in three.notes if n.startswith("no mode shapes")]


def test_the_plan_names_the_modes_the_records_chain_will_take_for_steady_oscillations(paper_plan):
    """A pole of damping ratio below RECORDS.steady_damping is a steady oscillation to the records chain (a running
    machine), not a mode. The plan gave such a mode the Cramer-Rao deviation of a decaying one: for press (no
    damping described) 0.00013 rad/s for x, where identify-record on the simulated record finds no mode. Now
    the mode is not measured, says why, and the stiffness deviations come from the modes that decay; kid300 with
    its horizontal damping 1e-5 of the described leaves phi out, and its paper plan leaves none out."""
    from pathlib import Path

    press = Machine.resolve(str(Path(__file__).parent / "data" / "press.toml"))
    sensors = [Sensor(f"S{a}", (0.9, 0.7, 0.3), d) for a, d in zip("xyz", np.eye(3), strict=True)]
    sensors += [Sensor(f"T{a}", (-0.9, 0.3, 0.3), d) for a, d in zip("xyz", np.eye(3), strict=True)]
    result = plan(press, sensors, paper_hit(), 4.0, 2048.0, 0.01)
    assert all(m.steady and not m.measured and np.isnan(m.frequency_std) for m in result.modes)
    assert all(np.isnan(v) for v in result.parameter_std.values())
    assert result.notes[0] == (
        "press has no damping: its modes do not decay, and the records chain takes a pole of damping ratio below "
        "0.0001 for a steady oscillation (a running machine), not a mode: a record gives none of them; describe the "
        "isolators' damping"
    )
    kid300 = Machine.resolve("kid300")
    light = plan(kid300, paper_sensors()[:3], paper_hit(), 4.0, 2048.0, 0.01, values={"b_xy": 0.003})
    assert [m.label for m in light.modes if m.steady] == ["phi"]
    assert [m.label for m in light.modes if m.measured] == ["x", "y", "psi", "theta"]  # z: unseen, as in the paper's
    assert light.notes[0].startswith("kid300 damps phi hardly at all: the records chain takes a pole")
    assert all(np.isfinite(v) for v in light.parameter_std.values())  # x and psi determine both stiffnesses
    assert not any(m.steady for m in paper_plan.modes) and not any("hardly" in n for n in paper_plan.notes)
    # an output-only plan simulates no record where no mode would come of it (it ran 4 x 1300 s for nothing)
    ambient = plan_output_only(press, sensors, 1300.0, 100.0, 10.0)
    assert all(m.steady and m.found == (0, 0) and not m.measured for m in ambient.modes)
    assert (
        ambient.notes[0]
        == "no record simulated: every mode is a steady oscillation to the records chain (the note below)"
    )
    assert ambient.notes[1] == result.notes[0] and all(np.isnan(v) for v in ambient.parameter_std.values())
