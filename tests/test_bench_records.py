"""Records as test benches write them (the records issue): units, velocity and force channels, double hits with
and without a force channel, time columns rounded, jittered, with a dropped sample or a gap, the sampling-rate
option, and records too short for the modes asked for. Each fault has its message."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from mountid.cli import main
from mountid.effects import STANDARD_GRAVITY
from mountid.errors import InputError
from mountid.identification.from_records import identify_from_record, inconsistent_channel, modal_data
from mountid.machine import Machine
from mountid.measurement import modal
from mountid.measurement.records import Channel, Record, read_csv, uniform_time, write_csv
from mountid.measurement.rig import Hammer, Rig, Sensor

KNOWN = {"m": 838.6, "J_xy": 61.44, "J_z": 51.52, "L_xy": 0.486, "L_z": 0.3}
HIT = Hammer((0.4, 0.3, 0.3), (1, 0.7, -0.6))
SIX = [
    Sensor(f"{c}{k}", p, d, noise=0.01)
    for k, p in enumerate(((0.4, 0.3, 0.25), (-0.4, -0.3, 0.25)))
    for c, d in zip("xyz", np.eye(3), strict=True)
]


def _rig() -> Rig:
    return Rig.of("kid300")


# -- double hits ----------------------------------------------------------------------------------------------
@pytest.mark.parametrize("pulse", [0.002, 0.006, 0.0095])
@pytest.mark.parametrize("rate", [500.0, 2048.0])
@pytest.mark.parametrize("seed", [0, 1])
def test_no_false_double_hit_on_clean_impulse_responses(pulse, rate, seed):
    """A hammer pulse's rise and fall (up to 9.5 ms apart) are one impact, whatever the noise (1 %)."""
    hit = Hammer(HIT.point, HIT.direction, duration=pulse)
    record = _rig().simulate(SIX[:3], 4.0, rate, hammers=[hit], seed=seed)
    assert modal.hammer_test_quality(record, 17.7, start=0.07, highest_frequency=64.1) == []


@pytest.mark.parametrize(("delay", "size"), [(0.05, 0.2), (0.05, 1.0), (0.03, 0.5), (0.1, 0.1)])
def test_a_second_hit_is_named_at_its_delay_even_when_small(delay, size):
    hit = Hammer(HIT.point, HIT.direction, duration=0.006, second_hit=(delay, size))
    record = _rig().simulate(SIX[:3], 4.0, 2048.0, hammers=[hit])
    (warning,) = [w for w in modal.hammer_test_quality(record, 17.7, start=0.3) if w.kind == "double_hit"]
    found = float(warning.message.split("a second impact ")[1].split(" ms")[0])
    assert found == pytest.approx(delay * 1e3, abs=3.0)


def test_a_force_channel_is_the_excitation_and_names_a_small_second_hit():
    hit = Hammer(HIT.point, HIT.direction, duration=0.004, second_hit=(0.05, 0.15))
    record = _rig().simulate(SIX, 20.0, 1000.0, hammers=[hit], force_channel="F")
    assert record.channels[-1] == Channel("F", quantity="force", unit="N")
    (warning,) = modal.force_quality(record, "F", start=0.2)
    assert warning.kind == "double_hit" and "a second hit 50.0 ms after the first (15% of its peak)" in warning.message
    # the force is the excitation, never a response: with it the modes come from the H1 frequency responses,
    # without it from the free decay, and both agree within their stated spread
    clean = _rig().simulate(SIX, 20.0, 1000.0, hammers=[HIT], force_channel="F")
    with_force = modal_data(Machine.resolve("kid300"), clean, KNOWN, 0.07)
    without = modal_data(Machine.resolve("kid300"), clean.select(clean.responses), KNOWN, 0.07)
    assert with_force.frf is not None and without.frf is None and with_force.modes.keys() == without.modes.keys()
    for label, m in with_force.modes.items():
        other = without.modes[label]
        assert abs(m.frequency - other.frequency) < 4 * math.hypot(m.frequency_std, other.frequency_std), label
        assert m.mac == pytest.approx(other.mac, abs=0.02)


def test_a_clipped_force_is_named():
    record = _rig().simulate(SIX[:3], 4.0, 2048.0, hammers=[HIT], force_channel="F")
    top = 0.7 * record.channel("F").max()
    data = record.data.copy()
    data[:, -1] = np.minimum(data[:, -1], top)
    kinds = [w.kind for w in modal.force_quality(Record(record.time, data, record.channels), "F", start=0.07)]
    assert kinds == ["clipping"]


# -- units and quantities ------------------------------------------------------------------------------------
def test_channels_in_g_and_velocity_give_the_same_modes_as_in_si():
    rig, machine = _rig(), Machine.resolve("kid300")
    si = rig.simulate(SIX, 20.0, 500.0, hammers=[HIT])
    in_g = Record(si.time, si.data / STANDARD_GRAVITY, tuple(_unit(c, "g") for c in si.channels))
    mixed = [Sensor(s.name, s.point, s.direction, s.noise, quantity="velocity", unit="mm/s") for s in SIX[:3]]
    velocity = rig.simulate([*mixed, *SIX[3:]], 20.0, 500.0, hammers=[HIT])
    reference, _, _ = modal_data(machine, si, KNOWN, 0.07)
    for other in (in_g, velocity):
        modes, _, _ = modal_data(machine, other, KNOWN, 0.07)
        assert set(modes) == set(reference)
        for label, m in modes.items():
            assert m.frequency == pytest.approx(reference[label].frequency, rel=1e-3)
            # the channel shape against the model's mode: velocity amplitudes converted (times p) to acceleration
            assert m.mac == pytest.approx(reference[label].mac, abs=0.02), label


def _unit(c: Channel, unit: str) -> Channel:
    return Channel(c.name, c.point, c.direction, c.quantity, unit)


def test_an_unknown_unit_or_quantity_is_named():
    t = np.arange(64) / 100.0
    with pytest.raises(InputError, match="a0: unit 'furlong/s\\^2' is not a unit of acceleration"):
        Record(t, np.zeros((64, 1)), (Channel("a0", unit="furlong/s^2"),))
    with pytest.raises(InputError, match="a0: quantity 'jerk' is not one of"):
        Record(t, np.zeros((64, 1)), (Channel("a0", quantity="jerk"),))


# -- time bases ---------------------------------------------------------------------------------------------
def test_time_columns_rounded_to_the_instruments_resolution_are_the_grid():
    t = np.arange(8192) / 2048.0
    assert np.allclose(uniform_time(np.round(t, 6)), t, rtol=0, atol=1e-9)


@pytest.mark.parametrize(
    ("fault", "message"),
    [
        ("dropped", "a dropped sample at t = 1 s \\(step 0.000976562 s"),
        ("gap", "a gap of 0.05 s at t = 1 s \\(103 steps"),
        ("jitter", "jitter: sample times scatter by up to 10.3% of a step .*--rate"),
    ],
)
def test_dropped_samples_gaps_and_jitter_are_told_apart(fault, message):
    t = np.arange(4096) / 2048.0
    if fault == "dropped":
        t = np.delete(t, 2049)
    elif fault == "gap":
        t[2049:] += 0.05
    else:
        t = t + np.random.default_rng(0).uniform(-0.1, 0.1, len(t)) / 2048.0
    with pytest.raises(InputError, match=message):
        uniform_time(t)


def test_the_sampling_rate_option_replaces_a_broken_time_column(tmp_path, capsys):
    record = _rig().simulate(SIX, 20.0, 512.0, hammers=[HIT])
    path = tmp_path / "shaken.csv"
    shaken = record.time + np.random.default_rng(1).uniform(-0.2, 0.2, len(record.time)) / 512.0
    write_csv(record, path)
    text = path.read_text().splitlines()
    head = next(k for k, line in enumerate(text) if line.startswith("time"))
    rows = [f"{float(shaken[i])!r}," + line.split(",", 1)[1] for i, line in enumerate(text[head + 1 :])]
    path.write_text("\n".join([*text[: head + 1], *rows]) + "\n")
    assert main(["identify-record", "kid300", str(path), "--json"]) == 2
    assert "time: jitter: sample times scatter" in capsys.readouterr().err
    assert main(["identify-record", "kid300", str(path), "--rate", "512", "--json"]) == 0
    assert read_csv(path, rate=512.0).rate == pytest.approx(512.0, rel=1e-12)


# -- record length ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("duration", [0.05, 0.2, 0.5])
def test_a_record_too_short_for_the_modes_is_a_named_error(duration, tmp_path, capsys):
    record = _rig().simulate(SIX, duration, 2048.0, hammers=[HIT])
    with pytest.raises(InputError, match="record: too short: .* periods of the lowest mode .* record 1.84 s or more"):
        identify_from_record(Machine.resolve("kid300"), record, KNOWN, 0.07)
    path = tmp_path / "short.csv"
    write_csv(record, path)
    assert main(["identify-record", "kid300", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "too short" in err


@pytest.mark.parametrize(
    ("start", "message"),
    [
        (math.nan, "start: must be a finite time \\[s\\], got nan"),
        (-math.inf, "start: must be a finite time \\[s\\], got -inf"),
        (2.5, "start: 2.5 s is at or after the record's end \\(1.99951 s\\): no free decay"),
        (1.9, "record: too short: 0.0995 s of free decay after the start \\(1.9 s\\) .* record 3.67 s or more"),
    ],
)
def test_a_start_that_is_no_time_of_the_record_is_a_named_error(start, message):
    """A NaN start passed every length check (NaN compares false) and failed in the pencil as a record of 0
    samples; -inf was taken as the record's beginning without a word; a start past the record's end is named as
    the start (it read "record: too short ... record 1e+02 s or more" for a 4 s record and --start 100)."""
    record = _rig().simulate(SIX, 2.0, 2048.0, hammers=[HIT])
    with pytest.raises(InputError, match=f"^{message}"):
        identify_from_record(Machine.resolve("kid300"), record, KNOWN, start)


def test_the_command_line_names_the_start_as_its_option(tmp_path, capsys):
    """An error about a command's option value names the option as typed (the Python API's parameter name,
    "start: ...", read as a record field), and a start past the record's end is named as such."""
    path = tmp_path / "hit.csv"
    write_csv(_rig().simulate(SIX, 2.0, 2048.0, hammers=[HIT]), path)
    says = {"nan": "must be a finite time [s], got nan", "100": "100 s is at or after the record's end"}
    for start, said in says.items():
        assert main(["process", "kid300", str(path), "--start", start]) == 2
        assert capsys.readouterr().err.startswith(f"mountid: error: --start: {said}")


def test_one_channel_reports_no_mac(tmp_path, capsys):
    """A single channel's shape is one number: its MAC against any mode is 1. It was reported as "MAC 1.00" in
    the text, the JSON and the mode figure's titles, as if the shape agreed; now it is not reported (None). The
    modes the channel does not see are named as not found."""
    record = _rig().simulate([Sensor("a", (0.0, 0.0, 0.0), (1, 0, 0))], 4.0, 2048.0, hammers=[HIT])
    found = modal_data(Machine.resolve("kid300"), record, {}, 0.07)
    assert found.modes and all(m.mac is None for m in found.modes.values())
    two = _rig().simulate([Sensor("a", (0.0, 0.0, 0.0), (1, 0, 0)), *SIX[:1]], 4.0, 2048.0, hammers=[HIT])
    assert all(m.mac is not None for m in modal_data(Machine.resolve("kid300"), two, {}, 0.07).modes.values())
    path = tmp_path / "one.csv"
    write_csv(record, path)
    assert main(["identify-record", "kid300", str(path)]) == 0
    out = capsys.readouterr().out
    assert "MAC" not in out
    # the modes a channel along x at the centre of mass does not see are named (the table alone left them out)
    assert "\n  not found in the record: z, phi\n" in out
    assert main(["process", "kid300", str(path)]) == 0
    assert capsys.readouterr().out.endswith("\n  not found in the record: z, phi\n")


def test_a_pole_on_twins_has_the_mac_of_their_span():
    """kid300's x and y (psi and theta) are twins: one pole stands for both, in whatever mix the oblique hit gave.
    Its MAC against x alone read 0.60 (psi 0.81) on a noise-free record of the paper's experiment, as if the
    model's shapes missed; the share of its shape in the twins' span is 1 to rounding."""
    sensors = [Sensor(s.name, s.point, s.direction) for s in SIX]
    record = _rig().simulate(sensors, 4.0, 2048.0, hammers=[HIT])
    modes = modal_data(Machine.resolve("kid300"), record, KNOWN, 0.07).modes
    assert set(modes) == {"x", "z", "psi", "phi"}
    assert all(m.mac > 0.9999 for m in modes.values()), {k: m.mac for k, m in modes.items()}


def test_the_mode_figure_draws_a_legend_only_for_lines_it_draws(monkeypatch, tmp_path):
    """The mode figure's legend named "red dashed: measured" where no mode had a shape in q (five channels that do
    not span the six motions): it says so instead."""
    from mountid.measurement.modes import MeasuredMode
    from mountid.report import figures

    titles = []

    def title_only(fig, path):
        titles.append(fig._suptitle.get_text())
        figures.plt.close(fig)

    monkeypatch.setattr(figures, "_save", title_only)
    machine = Machine.resolve("kid300")
    shape = tuple(machine.module.modal_matrix(**machine.values(KNOWN, machine.module.FORWARD_ARGUMENTS))[:, 0])
    for given in ({"x": MeasuredMode("x", 17.7, 0.1)}, {"x": MeasuredMode("x", 17.7, 0.1, shape=shape)}):
        figures.mode_shapes_figure(machine, KNOWN, (0.5, 0.5, 0.4), tmp_path / "modes.png", given)
    assert "no measured shape (the channels do not span the six motions)" in titles[0]
    assert "red dashed" not in titles[0] and "red dashed: measured" in titles[1]


def test_a_shape_on_twins_is_drawn_beside_the_twins_mix_nearest_it(monkeypatch, tmp_path):
    """kid300's psi and theta are equal: a measured shape there is any mix of them (a bench's table of modes gave
    45-degree mixes, MAC 1.00 in their span), and the model's psi drawn beside it looked like another mode. The
    model's line is the twins' mix nearest the measured shape (on it, for an exact mix); a mode without twins is
    the model's own."""
    from mountid.measurement.modes import MeasuredMode
    from mountid.report import figures

    drawn = []

    def lines(fig, path):
        for ax in fig.axes:
            model = [line.get_xydata() for line in ax.lines if line.get_color() == "C0"]
            measured = [line.get_xydata() for line in ax.lines if line.get_color() == "C3"]
            drawn.append((ax.get_title(), model, measured))
        figures.plt.close(fig)

    monkeypatch.setattr(figures, "_save", lines)
    machine = Machine.resolve("kid300")
    mod = machine.module
    phi = mod.modal_matrix(**machine.values(KNOWN, mod.FORWARD_ARGUMENTS))
    psi, theta, z = (mod.MODES.index(label) for label in ("psi", "theta", "z"))
    mix = tuple(0.6 * phi[:, psi] + 0.8 * phi[:, theta])
    given = {
        "psi": MeasuredMode("psi", 64.1, 0.1, shape=mix),
        "z": MeasuredMode("z", 47.5, 0.1, shape=tuple(phi[:, z])),
    }
    figures.mode_shapes_figure(machine, KNOWN, (0.5, 0.5, 0.4), tmp_path / "modes.png", given)
    titled = {title.split(":")[0]: (title, model, measured) for title, model, measured in drawn if title}
    title, model, measured = titled["psi"]
    assert "(its twins' mix)" in title
    np.testing.assert_allclose(np.array(model), np.array(measured), atol=1e-12)
    assert "twins" not in titled["z"][0]


def test_the_record_tables_name_missing_modes_and_unlabelled_poles():
    """Below a record's table of modes: the model's modes without a pole (a twin found counts for both) and the
    poles labelled as no mode, which only the JSON held."""
    from mountid.cli.record_commands import _not_found
    from mountid.measurement.modes import MeasuredMode

    machine = Machine.resolve("kid300")
    found = {label: MeasuredMode(label, 1.0, 0.1) for label in ("y", "psi")}
    stray = modal.Pole(25.31, 0.0123, np.ones(1, complex))
    assert _not_found(machine, found, [stray]) == [
        "not found in the record: z, phi",
        "poles labelled as no mode of the model: 25.31 rad/s (zeta 0.0123)",
    ]
    assert _not_found(machine, {k: MeasuredMode(k, 1.0, 0.1) for k in ("x", "z", "psi", "phi")}, []) == []


# -- clipping ---------------------------------------------------------------------------------------------
def test_clipping_under_noise_is_named():
    """A sensor saturated before the electronics add their noise: no exact flat top, still clipping."""
    record = _rig().simulate([Sensor("b", (0.4, 0.0, 0.1), (0, 0, 1), clip=0.5)], 4.0, 2048.0, hammers=[HIT])
    rng = np.random.default_rng(0)
    noisy = Record(record.time, record.data + 0.004 * rng.standard_normal(record.data.shape), record.channels)
    kinds = [(w.kind, w.channel) for w in modal.hammer_test_quality(noisy, 17.7, start=0.07)]
    assert kinds == [("clipping", "b")]


@pytest.mark.parametrize("seed", range(4))
def test_a_smooth_peak_of_a_slow_mode_is_not_clipping_and_a_flat_one_is(seed):
    """A channel at 2 kHz that kid300's lowest mode fills (700 samples a period) stays within 4 noise deviations of
    its top on several samples at 1 % noise: it was "clipped" in every seed (a hammer record with a force channel,
    hits at 0.05 s and 4.05 s). The samples held at the top are counted against what a smooth peak of the lobe's
    width holds (modal.clipped_level); the same channel saturated at 60 % of its peak is still named."""
    from mountid.validation.paper import paper_hit

    hit = paper_hit()
    hits = [Hammer(hit.point, hit.direction, hit.peak, hit.duration, t) for t in (0.05, 4.05)]
    slow = [Sensor("z", (-0.4, 0.4, 0.3), (0.0, 0.0, 1.0), noise=0.01), Sensor("x", (-0.4, -0.4, -0.2), (1, 0, 0))]
    record = _rig().simulate(slow, 8.0, 2000.0, hammers=hits, seed=seed)
    assert modal.hammer_test_quality(record, 17.7, 0.07, highest_frequency=64.1, impacts=False) == []
    peak = float(np.abs(record.channel("z")).max())
    saturated = [Sensor("z", (-0.4, 0.4, 0.3), (0.0, 0.0, 1.0), noise=0.01, clip=0.6 * peak), slow[1]]
    clipped = _rig().simulate(saturated, 8.0, 2000.0, hammers=hits, seed=seed)
    kinds = [(w.kind, w.channel) for w in modal.hammer_test_quality(clipped, 17.7, 0.07, 64.1, impacts=False)]
    assert kinds == [("clipping", "z")]


def test_clipping_is_reported_when_the_run_stops_for_another_reason(capsys, tmp_path):
    """The paper's three channels, clipped and noisy: the run stops (a mode asked for is not found) and the
    clipping is in its message."""
    from mountid.validation.paper import paper_sensors

    sensors = [Sensor(s.name, s.point, s.direction, noise=0.5, clip=0.3) for s in paper_sensors()]
    record = _rig().simulate(sensors, 4.0, 2048.0, hammers=[HIT])
    path = tmp_path / "clipped.csv"
    write_csv(record, path)
    assert main(["identify-record", "kid300", str(path), "--use", "x", "phi", "z", "psi"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "not found in the record" in err and "the record also shows: clipping" in err


# -- sensors that do not move with the rigid body -----------------------------------------------------------
_EIGHT = [
    Sensor(f"{c}{k}", p, tuple(d), noise=0.01)
    for k, (p, axes) in enumerate((((0.4, 0.3, 0.25), "xyz"), ((-0.4, -0.3, 0.25), "xyz"), ((0.4, -0.3, 0.25), "zy")))
    for c, d in zip("xyz", np.eye(3), strict=True)
    if c in axes
]


def _turned(name: str, degrees: float = 20.0) -> Record:
    """The eight-channel record with one sensor turned by ``degrees`` but labelled as in _EIGHT."""
    from dataclasses import replace

    sensors = []
    for s in _EIGHT:
        if s.name == name:
            d = np.array(s.direction)
            perp = np.cross(d, (1, 0, 0) if abs(d[0]) < 0.9 else (0, 1, 0))
            a = np.radians(degrees)
            s = replace(s, direction=tuple(np.cos(a) * d + np.sin(a) * perp / np.linalg.norm(perp)))
        sensors.append(s)
    record = _rig().simulate(sensors, 4.0, 1000.0, hammers=[HIT])
    labelled = tuple(replace_direction(c, s.direction) for c, s in zip(record.channels, _EIGHT, strict=True))
    return Record(record.time, record.data, labelled)


def replace_direction(c: Channel, direction) -> Channel:
    return Channel(c.name, c.point, tuple(map(float, direction)), c.quantity, c.unit)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_no_sensor_is_blamed_on_a_clean_eight_channel_record(seed):
    record = _rig().simulate(_EIGHT, 4.0, 1000.0, hammers=[HIT], seed=seed)
    assert inconsistent_channel(Machine.resolve("kid300"), record, 0.07) is None


def test_a_sensor_turned_by_20_degrees_is_named(tmp_path, capsys):
    machine = Machine.resolve("kid300")
    warning = inconsistent_channel(machine, _turned("y0"), 0.07)
    assert warning.kind == "sensor" and warning.channel == "y0" and warning.suspects == ("y0",)
    # where the layout's redundant equations cannot separate channels, the suspects are named together
    warning = inconsistent_channel(machine, _turned("x1"), 0.07)
    assert warning.channel == "x0, x1 or y1" and "the layout cannot tell which" in warning.message
    assert warning.suspects == ("x0", "x1", "y1")
    # the command line runs the check on every record of 8 or more channels
    path = tmp_path / "turned.csv"
    write_csv(_turned("y2"), path)
    assert main(["process", "kid300", str(path)]) == 0
    assert "warning (sensor, y2): does not move with the rigid body" in capsys.readouterr().out
    # and --json gives the warning as data, its suspects a list a program reads without parsing the message
    assert main(["process", "kid300", str(path), "--json"]) == 0
    (sensor,) = [w for w in json.loads(capsys.readouterr().out)["warnings"] if w["kind"] == "sensor"]
    assert sensor["channel"] == "y2" and sensor["suspects"] == ["y2"] and sensor["record"] == ""


# -- heavily damped modes -----------------------------------------------------------------------------------
@pytest.mark.parametrize("seed", [0, 1])
def test_heavily_damped_modes_are_kept(seed):
    """z at zeta 0.29 and psi/theta at 0.36 (the vertical damping 5.5 times the paper's): the poles move a few
    percent with the model order, and are kept (a 1 % recurrence test dropped them)."""
    rig = Rig.of("kid300", {"b_z": 1039.0 * 5.5})
    state = np.block([[np.zeros((6, 6)), np.eye(6)], [-np.linalg.solve(rig.M, rig.C), -np.linalg.solve(rig.M, rig.B)]])
    poles = np.linalg.eigvals(state)
    poles = poles[poles.imag > 0]
    record = rig.simulate(_EIGHT, 4.0, 1000.0, hammers=[HIT], seed=seed)
    modes, _, _ = modal_data(Machine.resolve("kid300"), record, KNOWN | {"b_z": 1039.0 * 5.5}, 0.07)
    for label, near in (("z", 47.46), ("psi", 64.03)):
        p = poles[np.argmin(np.abs(np.abs(poles) - near))]
        zeta = -p.real / abs(p)
        assert zeta > 0.28
        m = modes[label]
        assert abs(m.frequency - abs(p)) < 3 * m.frequency_std, label
        assert abs(m.damping_ratio - zeta) < 3 * m.damping_std + 0.01 * zeta, label


# -- equally good roots ---------------------------------------------------------------------------------------
def test_a_root_rule_picks_between_equally_good_solutions(tmp_path, capsys):
    """A hit along x at the centre of mass's height excites x and theta only: the paper's three channels see
    x and psi/theta, and two stiffness pairs fit them exactly. The description's rule picks one, --root
    overrides it, and the output says which and why."""
    from mountid.validation.paper import paper_sensors

    sensors = [Sensor(s.name, s.point, s.direction, noise=0.01) for s in paper_sensors()]
    path = tmp_path / "along_x.csv"
    write_csv(_rig().simulate(sensors, 4.0, 2048.0, hammers=[Hammer((0.0, 0.0, 0.3), (1, 0, 0))]), path)
    import json

    # kid300's description carries the physical rule (rubber stiffer in compression than in shear)
    assert main(["identify-record", "kid300", str(path), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["parameters"]["c_z"] > out["parameters"]["c_xy"]
    assert out["parameters"]["c_xy"] == pytest.approx(74.4e3, rel=0.01)
    (tie,) = [n for n in out["notes"] if "2 solutions fit the measured frequencies equally" in n]
    assert "chosen by the rule of the description kid300 (c_z>c_xy)" in tie
    main(["identify-record", "kid300", str(path)])
    assert "note: 2 solutions fit" in capsys.readouterr().out
    # an explicit rule overrides the description's
    assert main(["identify-record", "kid300", str(path), "--root", "c_z<c_xy", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["parameters"]["c_z"] < 2e5 and any("chosen by the rule c_z<c_xy" in n for n in out["notes"])
    assert main(["identify-record", "kid300", str(path), "--root", "m>c_z"]) == 2
    assert (
        "--root: 'm>c_z': must be a rule A>B or A<B on two unknowns (c_xy, c_z): m is not an unknown"
        in capsys.readouterr().err
    )


def test_the_hit_on_a_force_channel_is_reported():
    """Peak, duration and impulse of the first hit (a 4 ms half-sine of 2 kN: 2 P T / pi = 5.09 N s)."""
    record = _rig().simulate(_EIGHT, 20.0, 1000.0, hammers=[HIT], force_channel="F")
    result = identify_from_record(Machine.resolve("kid300"), record, KNOWN, 0.07)
    (note,) = [n for n in result.notes if n.startswith("hit on F")]
    impulse = float(note.split("impulse ")[1].split(" N s")[0])
    assert impulse == pytest.approx(2 * HIT.peak * HIT.duration / np.pi, rel=0.02)
    assert "peak 2" in note and "ms above 5 % of it" in note


def test_the_records_chain_does_not_import_scipy_signal(tmp_path):
    """Half a second of the one a file to stiffness may take went to importing scipy.signal: the chain
    decimates and finds bursts in numpy (modal.decimate, modal.find_bursts; compared with scipy in
    test_modal), and the command line must stay free of it."""
    import subprocess
    import sys

    path = tmp_path / "r.csv"
    write_csv(_rig().simulate(SIX[:3], 4.0, 2048.0, hammers=[HIT]), path)
    code = (
        "import sys; from mountid.cli import main; "
        f"main(['identify-record', 'kid300', {str(path)!r}, '--json']); "
        "print('scipy.signal' in sys.modules, file=sys.stderr)"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert done.stderr.strip().splitlines()[-1] == "False"


def test_seven_channels_see_a_turned_sensor_but_cannot_place_it():
    """One redundant equation: a 20-degree turn of a channel in it shows as a misfit far beyond the channels'
    own noise, named as such (not blamed on a channel); clean records raise nothing."""
    machine = Machine.resolve("kid300")
    seven = [s for s in _EIGHT if s.name != "y2"]
    for seed in (0, 1):
        record = _rig().simulate(seven, 4.0, 1000.0, hammers=[HIT], seed=seed)
        assert inconsistent_channel(machine, record, 0.07) is None
    turned = _turned("y0")
    record = turned.select([s.name for s in seven])
    warning = inconsistent_channel(machine, record, 0.07)
    assert warning.channel == "all" and "7 channels cannot tell which" in warning.message
    assert warning.suspects == ()


def test_an_aliased_record_states_a_wide_stiffness_instead_of_two_equal_solutions(capsys, tmp_path):
    """A 60 s record at 12 Hz: psi (10.2 Hz) aliases, the chain warns, and the stiffness fit's starts stop at
    different points of a valley the data hardly rise from (c_z 220961 and 224709 N/m): one solution within
    their standard deviations, stated with its width, not "c_z>c_xy holds for 2 of the 2 solutions". (With the
    pencil sizes of 100 and 160 the record gave a third pole, zeta 0.002 and MAC 0.08, labelled phi; from 160 and
    250 it gives two, and every parameter is stated as hardly determined.)"""
    path = tmp_path / "slow.csv"
    assert main(["simulate", "kid300", "--out", str(path), "--rate", "12", "--duration", "60"]) == 0
    capsys.readouterr()
    assert main(["identify-record", "kid300", str(path)]) == 0
    out = capsys.readouterr().out
    assert "warning (low_rate, all)" in out
    c_z, std = (float(v) for v in out.split("c_z = ")[1].split(" N/m")[0].split(" +- "))
    assert std > 0.3 * c_z  # the record hardly determines c_z, and says so
    note = next(line for line in out.splitlines() if line.startswith("  note: the standard deviation"))
    assert ("of c_z" in note or " c_z," in note) and "half" in note
    assert "holds for 2 of the 2" not in out


EIGHT = (
    "a1x=0.5,0.4,0.3:1,0,0 a1y=0.5,0.4,0.3:0,1,0 a1z=0.5,0.4,0.3:0,0,1 a2x=-0.5,-0.4,0.3:1,0,0 "
    "a2y=-0.5,-0.4,0.3:0,1,0 a2z=-0.5,-0.4,0.3:0,0,1 a3z=0.5,-0.4,0.3:0,0,1 a4y=-0.5,0.4,0.3:0,1,0"
).split()
"""Two triaxial accelerometers and two single axes on a body of about a metre: the six motions."""


DEFAULT_PENCILS = modal.PENCIL_SIZES
"""The pencil sizes the records chain uses (the tests below also run the smaller ones that merged screen6's x and y)."""


@pytest.fixture(scope="module")
def screen6_record(tmp_path_factory) -> Record:
    """A 20 s record of the nominal screen6 (2 % noise, eight channels, one hit): its x and y modes lie 0.12 rad/s
    apart at a damping ratio of 0.05, within their half-power bandwidth of 1.9 rad/s."""
    path = tmp_path_factory.mktemp("screen6") / "hit.uff"
    argv = ["simulate", "screen6", "--out", str(path), "--duration", "20", "--rate", "500", "--noise", "0.02"]
    argv += ["--seed", "3", "--sensor", *EIGHT, "--hit-point", "0.5,0.4,0.3", "--hit-direction", "1,0.7,-0.6"]
    assert main(argv) == 0
    from mountid.measurement.records import read_record

    return read_record(path, None)


@pytest.mark.parametrize("sizes", [DEFAULT_PENCILS, (100, 160)])
def test_two_close_modes_in_one_pole_are_split_at_the_models_modes(screen6_record, monkeypatch, sizes):
    """Pencils of 100 and 160 columns find one pole for screen6's x and y (between them, its shape half of each:
    a measurement of neither, and its misfit spoiled phi's shape, MAC 0.74). Seeded at the model's two modes the
    joint fit separates them: each within 3 of its standard deviations of the truth's |p|, every shape MAC > 0.95
    with its mode, and a close_modes warning says how. The default pencils (modal.PENCIL_SIZES) resolve them
    without help, to the same values."""
    monkeypatch.setattr(modal, "PENCIL_SIZES", sizes)
    machine = Machine.resolve("screen6")
    found = modal_data(machine, screen6_record, {}, 0.07)
    pole_of = dict(zip(machine.module.MODES, _truth_poles(machine), strict=True))
    for label in ("x", "y"):
        mode = found.modes[label]
        assert abs(mode.frequency - pole_of[label]) < 3 * mode.frequency_std, (label, mode.frequency, pole_of[label])
    assert min(m.mac for m in found.modes.values()) > 0.95
    if sizes == DEFAULT_PENCILS:
        assert set(found.modes) == set(machine.module.UNIQUE_MODES) and not found.warnings
        return
    assert set(found.modes) == set(machine.module.UNIQUE_MODES)
    (warning,) = [w for w in found.warnings if w.kind in ("close_modes", "unresolved_modes")]
    assert warning.kind == "close_modes" and warning.message.startswith("x and y: one pole at 17.79 rad/s")


def _truth_poles(machine: Machine) -> np.ndarray:
    """The truth's |p| of each mode in the module's mode order (the damped poles paired with the undamped modes)."""
    from mountid.machine import damped_poles, matrices

    values = machine.values({}, tuple(machine.module.PARAMETERS))
    lam = np.asarray(machine.module.frequencies(**machine.values({}, machine.module.FORWARD_ARGUMENTS))) ** 2
    return np.abs(damped_poles(*matrices(machine.module, values), lam))


def test_close_modes_the_record_cannot_separate_are_left_out(screen6_record, monkeypatch):
    """Where the seeded fit does not separate them either, the merged pole (pencils of 100 and 160 columns) is
    left out of the modes, named in an unresolved_modes warning, and kept among the unlabelled poles."""
    from mountid.identification import from_records

    monkeypatch.setattr(modal, "PENCIL_SIZES", (100, 160))
    monkeypatch.setattr(from_records, "_split_merged", lambda *args: None)
    found = modal_data(Machine.resolve("screen6"), screen6_record, {}, 0.07)
    assert "x" not in found.modes and "y" not in found.modes
    (warning,) = [w for w in found.warnings if w.kind == "unresolved_modes"]
    assert "x and y: one pole at 17.79 rad/s" in warning.message and warning.message.endswith("x left out")
    assert any(abs(p.frequency - 17.79) < 0.01 for p in found.unlabelled)


@pytest.mark.parametrize("sizes", [DEFAULT_PENCILS, (100, 160)])
def test_records_of_the_nominal_screen6_show_no_gap(screen6_record, tmp_path, monkeypatch, sizes):
    """From records to a verdict on a clean machine whose x and y lie within one pole's bandwidth: with the pole
    merged (labelled x, its shape half y; pencils of 100 and 160 columns) the diagnosis found a significant gap
    that no effect explained; split, or resolved by the default pencils, no gap."""
    monkeypatch.setattr(modal, "PENCIL_SIZES", sizes)
    import json

    from mountid.diagnosis import campaign
    from mountid.diagnosis.gap import diagnose
    from mountid.measurement.records import write_csv

    write_csv(screen6_record, tmp_path / "hit.csv")
    (tmp_path / "c.json").write_text(json.dumps({"machine": "screen6", "records": ["hit.csv"]}), encoding="utf-8")
    report = diagnose(campaign.load(tmp_path / "c.json"))
    split = any(n.startswith("hit.csv: close_modes (all): x and y") for n in report.campaign.record_notes)
    assert split == (sizes != DEFAULT_PENCILS) and {"x", "y"} <= set(report.campaign.modes)
    assert report.effects.kind == "no significant gap"


# -- a pre-trigger ----------------------------------------------------------------------------------------------
@pytest.mark.parametrize(("hit_time", "pulse"), [(0.55, 0.004), (1.2, 0.01)])
def test_a_record_with_a_pre_trigger_is_analysed_from_after_its_impact(hit_time, pulse):
    """Bench exports keep part of the record before the hit (a pre-trigger) and count time from the
    acquisition's start: the default start 0.07 s (0.02 s after the virtual rig's hit) then lay before the
    impact, which was warned about and analysed all the same (one mode of four found, x at zeta 0.016). Without a
    given start the free decay now begins AFTER_IMPACT after the impact the responses show, with a note, and
    gives the modes the same hit at 0.05 s gives; a start given is taken as it is, and a record whose hit comes
    early keeps the default (no note)."""
    kid300 = Machine.resolve("kid300")
    late = Hammer(HIT.point, HIT.direction, duration=pulse, time=hit_time)
    record = _rig().simulate(SIX, 5.0 + hit_time, 2048.0, hammers=[late], seed=3)
    decay = modal.free_decay(record, 64.1)
    start, (note,) = decay.start, decay.notes
    assert hit_time + pulse < start <= hit_time + modal.AFTER_IMPACT and decay.end is None
    assert note.startswith(f"free decay from t = {start:.4g} s, 0.03 s after the impact the record shows at t = ")
    found = modal_data(kid300, record, KNOWN)
    assert found.start == start and found.notes == (note,) and found.warnings == []
    early = _rig().simulate(SIX, 5.0, 2048.0, hammers=[Hammer(HIT.point, HIT.direction, duration=pulse)], seed=3)
    assert modal.free_decay(early, 64.1) == modal.FreeDecay(modal.DEFAULT_START)
    reference = modal_data(kid300, early, KNOWN)
    assert reference.start == modal.DEFAULT_START and reference.notes == ()
    assert found.modes.keys() == reference.modes.keys() == {"x", "z", "psi", "phi"}
    for label, m in found.modes.items():
        other = reference.modes[label]
        assert abs(m.frequency - other.frequency) < 4 * math.hypot(m.frequency_std, other.frequency_std), label
    given = modal_data(kid300, record, KNOWN, 0.07)  # taken as given: the impact inside it is named
    assert given.start == 0.07 and given.notes == ()
    # and the pre-trigger before it and the hit itself are no free decay of the modes found
    assert [w.kind for w in given.warnings] == ["impact_in_segment", "unexplained"]


def test_a_campaign_and_the_command_line_say_where_a_pre_triggered_free_decay_starts(capsys, tmp_path):
    """The note reaches the reader: process prints it (and gives it in its JSON), a campaign's record notes
    name the record it belongs to. simulate --hit-time writes such a record."""
    # the virtual rig's record of a pre-trigger, as simulate --hit-time writes it (the hit 0.55 s in)
    argv = ["simulate", "kid300", "--out", str(tmp_path / "hit.csv"), "--hit-time", "0.55", "--duration", "5.55"]
    assert main(argv) == 0 and capsys.readouterr().out.startswith("wrote")
    assert main(["process", "kid300", str(tmp_path / "hit.csv")]) == 0
    out = capsys.readouterr().out
    assert out.splitlines()[1].startswith("  note: free decay from t = 0.5")
    assert main(["process", "kid300", str(tmp_path / "hit.csv"), "--json"]) == 0
    note, unseen = json.loads(capsys.readouterr().out)["notes"]  # and the paper's channels give no shapes
    assert note.startswith("free decay from t = 0.5") and unseen.startswith("no mode shapes: the channels see 5")
    campaign = {"name": "pre-trigger", "machine": "kid300", "known": KNOWN, "records": ["hit.csv"]}
    (tmp_path / "c.json").write_text(json.dumps(campaign), encoding="utf-8")
    from mountid.diagnosis.campaign import load

    assert f"hit.csv: {note}" in load(tmp_path / "c.json").record_notes


def test_a_record_of_several_hits_is_analysed_until_the_second():
    """Two hits 3.95 s apart in one record without a force channel (an engineer hits again before saving): the
    free decay ran over the second hit, which was named a "double hit", and gave one mode of four (x at zeta
    0.008). It now ends where the second hit begins, said in a note, and gives the modes the first hit alone
    gives; a bounce 30 ms after a hit stays a double hit, and hits closer than the lowest modes need are an error
    that says how long a free decay they need."""
    kid300 = Machine.resolve("kid300")
    second = Hammer(HIT.point, HIT.direction, time=4.0)
    record = _rig().simulate(SIX, 8.0, 2048.0, hammers=[HIT, second], seed=2)
    decay = modal.free_decay(record, 64.1)
    assert decay.start == modal.DEFAULT_START and 3.99 <= decay.end <= 4.0
    assert decay.notes == (
        f"free decay until t = {decay.end:.4g} s, where the record shows another hit (2 hits in all, the others' "
        "decays not used: a force channel would average them; without a start, process, identify-record and a "
        "campaign use each)",
    )
    assert decay.hits == (pytest.approx(0.05, abs=0.0075), decay.end)  # an onset up to half the burst window early
    third = Hammer(HIT.point, HIT.direction, time=8.0)
    middle = modal.free_decay(_rig().simulate(SIX, 12.0, 2048.0, hammers=[HIT, second, third], seed=2), 64.1, 4.1)
    assert middle.start == 4.1 and 7.99 <= middle.end <= 8.0  # a start after the first hit: its decay not used
    assert middle.notes == (modal.next_hit_note(middle.end, 3),)
    assert "(3 hits in all, the others' decays not used" in middle.notes[0]
    found = modal_data(kid300, record, KNOWN)
    assert found.notes == decay.notes and found.warnings == [] and (found.start, found.end) == (0.07, decay.end)
    alone = modal_data(kid300, _rig().simulate(SIX, 3.95, 2048.0, hammers=[HIT], seed=2), KNOWN)
    assert found.modes.keys() == alone.modes.keys() == {"x", "z", "psi", "phi"}
    for label, m in found.modes.items():
        assert m.frequency == pytest.approx(alone.modes[label].frequency, abs=4 * m.frequency_std), label
    bounce = Hammer(HIT.point, HIT.direction, second_hit=(0.03, 0.5))
    bounced = _rig().simulate(SIX[:3], 4.0, 2048.0, hammers=[bounce], seed=2)
    assert modal.free_decay(bounced, 64.1) == modal.FreeDecay(modal.DEFAULT_START)
    assert [w.kind for w in modal.hammer_test_quality(bounced, 17.7, start=0.07, highest_frequency=64.1)] == [
        "double_hit"
    ]
    close = Hammer(HIT.point, HIT.direction, time=1.0)
    with pytest.raises(InputError) as err:
        modal_data(kid300, _rig().simulate(SIX, 4.0, 2048.0, hammers=[HIT, close], seed=2), KNOWN)
    assert err.value.parameter == "record"
    assert err.value.reason.startswith("too short: 0.9") and "to the next hit (0.99" in err.value.reason
    assert err.value.reason.endswith("1.77 s of free decay or more before the next hit (or record the force)")


def test_the_figures_of_a_record_of_several_hits_show_the_decay_the_modes_came_from(monkeypatch, tmp_path):
    """identify-record --figures on two hits: the spectra and the stabilisation diagram are of the free decay
    the poles were fitted on, which ends at the second hit (they took the record to its end, the second hit's
    forced response in it)."""
    from mountid.report import figures

    second = Hammer(HIT.point, HIT.direction, time=4.0)
    record = _rig().simulate(SIX, 8.0, 2048.0, hammers=[HIT, second], seed=2)
    result = identify_from_record(Machine.resolve("kid300"), record, KNOWN)
    assert 3.99 <= result.end <= 4.0 and result.start == modal.DEFAULT_START
    titles, segments = [], []
    real_stabilisation = modal.stabilisation

    def stabilisation(responses, start, *args):
        segments.append((start, float(responses.time[-1])))
        return real_stabilisation(responses, start, *args)

    def keep(fig, where):
        titles.append(fig.axes[0].get_title())
        figures.plt.close(fig)
        return where

    monkeypatch.setattr(figures, "_save", keep)
    monkeypatch.setattr(figures.modal, "stabilisation", stabilisation)
    figures.experiment_figures(Machine.resolve("kid300"), record, result, KNOWN, tmp_path)
    assert titles[0].startswith(f"spectra of the free decay from 0.07 s to {result.end:.4g} s (raw FFT bin")
    assert segments == [(0.07, float(record.time[record.time < result.end][-1]))]


def test_the_stabilisation_diagram_shows_a_steady_oscillation_as_one(monkeypatch, tmp_path):
    """The machine running at 100 rad/s (seed 3): the pencil gives the steady oscillation a damping ratio of about
    -6e-7 at every order, and the stabilisation diagram left it out (its poles had to lie above zero), while one
    at +8e-7 (seed 1) was drawn as a mode would be. Both are kept at every order and drawn as crosses, named
    as a steady oscillation, no mode."""
    from mountid.measurement.rig import Unbalance
    from mountid.report import figures

    drawn = []

    def keep(fig, where):
        drawn.append(fig)
        return where

    monkeypatch.setattr(figures, "_save", keep)
    for seed, sign in ((3, -1), (1, 1)):
        steady = _rig().simulate(SIX, 4.0, 2000.0, unbalances=[Unbalance(43.1, 0.03, 100.0)], seed=seed)
        runs = modal.stabilisation(steady, 0.07, 2 * 64.1, 6)
        for _, p, _ in runs:
            (tone,) = p[np.abs(np.abs(p) - 100.0) < 0.05]
            assert np.sign(-tone.real) == sign and abs(tone.real) < 1e-4 * abs(tone)
        figures.stabilisation_figure(runs, {}, tmp_path / "s.png")
        ax = drawn[-1].axes[0]
        crosses = [line for line in ax.lines if line.get_marker() == "x" and len(line.get_xdata())]
        assert sum(len(line.get_xdata()) for line in crosses) == len(runs)
        assert all(abs(w - 100.0) < 0.05 for line in crosses for w in line.get_xdata())
        assert "steady oscillation (|zeta| < 0.0001): no mode" in [t.get_text() for t in ax.get_legend().get_texts()]
        figures.plt.close(drawn[-1])


# -- not the free decay of a hit ----------------------------------------------------------------------------------
def test_a_record_that_is_no_free_decay_is_said_so(tmp_path, capsys):
    """A record of the machine started under its rotating unbalance, processed as an impact test, gave two 'modes'
    (psi +- 3.3 rad/s, MAC 0.30) without a word of what the record was: the pencil gives the running speed a damping
    ratio of about -1e-7, and a pole below zero was dropped, its oscillation left to spoil the others. Such a pole is
    kept as a steady oscillation, named in a steady warning with the share of the variance it carries, and takes no
    mode's label; the start-up's free decay gives x and psi cleanly. A machine running near a mode beside a hit (18.2
    and 17.5 rad/s against kid300's x at 17.71: x came out at 18.06, zeta 0.012) leaves the mode where it is. A hit's
    record, even at 20 % noise, gets no warning; a segment holding a hit and the quiet before it, one that says
    the poles leave most of it unexplained (the pre-trigger test)."""
    from mountid.measurement.rig import Unbalance

    rig = _rig()
    steady = rig.simulate(SIX, 4.0, 2000.0, unbalances=[Unbalance(43.1, 0.03, 100.0)], seed=1)
    found = modal_data(rig.machine, steady, KNOWN)
    (tone,) = [w.message for w in found.warnings if w.kind == "steady"]
    assert tone.startswith("a pole at 100.0000 rad/s (15.92 Hz) of damping ratio ") and "labelled" not in tone
    assert float(tone.split("carry ")[1].split("%")[0]) >= 95 and "unexplained" not in [w.kind for w in found.warnings]
    assert {"x", "psi"} <= set(found.modes) and all(m.mac > 0.99 for m in found.modes.values())
    assert [p.frequency for p in found.unlabelled] == [pytest.approx(100.0, abs=1e-3)]
    truth = dict(zip(rig.machine.modes, _truth_poles(rig.machine), strict=True))
    for speed in (18.2, 17.5):
        near = rig.simulate(SIX, 4.0, 2000.0, hammers=[HIT], unbalances=[Unbalance(0.5, 0.03, speed)], seed=1)
        beside = modal_data(rig.machine, near, KNOWN)
        (tone,) = [w.message for w in beside.warnings if w.kind == "steady"]
        assert float(tone.split()[3]) == pytest.approx(speed, abs=0.005) and "labelled" not in tone
        x = beside.modes["x"]
        assert abs(x.frequency - truth["x"]) < 4 * x.frequency_std and abs(x.damping_ratio - 0.0375) < 0.001, speed
    noisy = [Sensor(s.name, s.point, s.direction, noise=0.2) for s in SIX]
    hit = modal_data(rig.machine, rig.simulate(noisy, 4.0, 2000.0, hammers=[HIT], seed=1), KNOWN)
    assert [w.kind for w in hit.warnings] == []
    write_csv(steady, tmp_path / "steady.csv")
    assert main(["process", "kid300", str(tmp_path / "steady.csv"), "--json"]) == 0
    assert "steady" in [w["kind"] for w in json.loads(capsys.readouterr().out)["warnings"]]


# -- a fast acquisition ---------------------------------------------------------------------------------------------
def test_a_record_sampled_at_51_2_khz_is_clean_where_it_is_and_clipped_where_it_is():
    """Acquisition systems sample at 51.2 kHz: a clean hit's record then had every channel "clipped" (a smooth peak
    sampled that finely holds its top within the noise on several samples), which also hid the impact the free
    decay starts after, and took 18 s to decimate (every sample filtered where one in 313 is kept). Clipping is
    judged at 400 samples per period of the highest mode (RecordSettings.clip_resolution): the clean record has no
    warning, its pre-triggered hit is found, and a saturated sensor is still named."""
    late = Hammer(HIT.point, HIT.direction, time=0.55)
    record = _rig().simulate(SIX, 3.0, 51200.0, hammers=[late], seed=1)
    found = modal_data(Machine.resolve("kid300"), record, KNOWN)
    assert found.warnings == [] and set(found.modes) == {"x", "z", "psi", "phi"}
    assert 0.55 < found.start <= 0.58 and found.notes[0].startswith("free decay from t = ")
    assert modal.clip_step(record, 64.1) == 12 and modal.clip_step(record, None) == 1
    saturated = _rig().simulate([Sensor("b", (0.4, 0.0, 0.1), (0, 0, 1), clip=0.5)], 3.0, 51200.0, hammers=[HIT])
    rng = np.random.default_rng(0)
    noisy = Record(
        saturated.time, saturated.data + 0.004 * rng.standard_normal(saturated.data.shape), saturated.channels
    )
    kinds = [(w.kind, w.channel) for w in modal.hammer_test_quality(noisy, 17.7, 0.07, highest_frequency=64.1)]
    assert kinds == [("clipping", "b")]
