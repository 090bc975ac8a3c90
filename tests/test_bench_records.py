"""Records as test benches write them (the records issue): units, velocity and force channels, double hits with
and without a force channel, time columns rounded, jittered, with a dropped sample or a gap, the sampling-rate
option, and records too short for the modes asked for. Each fault has its message."""

from __future__ import annotations

import numpy as np
import pytest

from mountid.cli import main
from mountid.effects import STANDARD_GRAVITY
from mountid.errors import InputError
from mountid.identification.from_records import identify_from_record, modal_data
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
    # the force never enters the modal fit: the modes are those of the response channels alone
    clean = _rig().simulate(SIX, 20.0, 1000.0, hammers=[HIT], force_channel="F")
    with_force, _, _ = modal_data(Machine.resolve("kid300"), clean, KNOWN, 0.07)
    without, _, _ = modal_data(Machine.resolve("kid300"), clean.select(clean.responses), KNOWN, 0.07)
    assert {k: m.frequency for k, m in with_force.items()} == {k: m.frequency for k, m in without.items()}
    assert {k: m.mac for k, m in with_force.items()} == {k: m.mac for k, m in without.items()}


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
    with pytest.raises(InputError, match="record: too short: .* periods of the lowest mode .* record 1.8 s or more"):
        identify_from_record(Machine.resolve("kid300"), record, KNOWN, 0.07)
    path = tmp_path / "short.csv"
    write_csv(record, path)
    assert main(["identify-record", "kid300", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "too short" in err


# -- clipping ---------------------------------------------------------------------------------------------
def test_clipping_under_noise_is_named():
    """A sensor saturated before the electronics add their noise: no exact flat top, still clipping."""
    record = _rig().simulate([Sensor("b", (0.4, 0.0, 0.1), (0, 0, 1), clip=0.5)], 4.0, 2048.0, hammers=[HIT])
    rng = np.random.default_rng(0)
    noisy = Record(record.time, record.data + 0.004 * rng.standard_normal(record.data.shape), record.channels)
    kinds = [(w.kind, w.channel) for w in modal.hammer_test_quality(noisy, 17.7, start=0.07)]
    assert kinds == [("clipping", "b")]


def test_clipping_is_reported_when_the_run_stops_for_another_reason(capsys, tmp_path):
    """The paper's three channels, clipped, on a record too noisy to give two distinct frequencies."""
    from mountid.validation.paper import paper_sensors

    sensors = [Sensor(s.name, s.point, s.direction, noise=0.5, clip=0.3) for s in paper_sensors()]
    record = _rig().simulate(sensors, 4.0, 2048.0, hammers=[HIT])
    path = tmp_path / "clipped.csv"
    write_csv(record, path)
    assert main(["identify-record", "kid300", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "the record also shows: clipping" in err
