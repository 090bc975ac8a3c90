"""TDMS records (mountid.measurement.tdms): files as NI's acquisition software writes them, made with npTDMS's
writer, read back as the records they hold; mountid's own writer read back."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mountid.errors import InputError
from mountid.measurement.records import Record, read_csv, read_record, with_geometry, write_csv
from mountid.measurement.rig import Rig
from mountid.validation.paper import paper_hit, paper_sensors

nptdms = pytest.importorskip("nptdms")


def _write(path: Path, channels: list[tuple[str, str, np.ndarray, dict]]) -> Path:
    """A TDMS file of (group, channel, data, properties), in one segment."""
    with nptdms.TdmsWriter(str(path)) as writer:
        writer.write_segment([nptdms.ChannelObject(g, c, data, properties=p) for g, c, data, p in channels])
    return path


def _waveform(rate: float, unit: str, start: float = 0.0) -> dict:
    """The properties NI's DAQ software gives a waveform channel."""
    return {"wf_increment": 1.0 / rate, "wf_start_offset": start, "wf_samples": 1, "unit_string": unit}


@pytest.fixture(scope="module")
def hit() -> Record:
    """A simulated impact test of kid300 with the paper's channels, 4 s at 500 Hz."""
    return Rig.of("kid300").simulate(paper_sensors(), 4.0, 500.0, hammers=[paper_hit()], seed=1)


def test_a_record_written_as_tdms_reads_back_as_it_was(hit, tmp_path):
    """write_tdms keeps every channel's samples, unit, point and direction (an unplaced force channel: NaN) and the
    sampling: the record read back is the record written (the time to rounding of the step's sum)."""
    from dataclasses import replace

    from mountid.measurement.records import Channel
    from mountid.measurement.tdms import read_tdms, write_tdms

    force = Channel("F", quantity="force", unit="kN")
    rec = replace(hit, data=np.column_stack([hit.data, hit.data[:, 0]]), channels=(*hit.channels, force))
    rec = replace(rec, channels=(replace(rec.channels[0], unit="g"), *rec.channels[1:]))
    write_tdms(rec, tmp_path / "r.tdms")
    back = read_tdms(tmp_path / "r.tdms")
    assert back.names == rec.names and back.channels[:-1] == rec.channels[:-1]
    assert (back.channels[-1].quantity, back.channels[-1].unit) == ("force", "kN")
    assert np.isnan(back.channels[-1].point).all() and np.isnan(back.channels[-1].direction).all()
    np.testing.assert_array_equal(back.data, rec.data)
    np.testing.assert_allclose(back.time, rec.time, rtol=0, atol=1e-12)
    for point, said in (("nan,0,0.1", "point and direction must be finite"), ("0.45,0", "take three numbers each")):
        bad = {**_waveform(500.0, "g"), "mountid_point": point, "mountid_direction": "1,0,0"}
        _write(tmp_path / "bad.tdms", [("mountid", "A_x", hit.data[:, 0], bad)])
        with pytest.raises(InputError, match=f"^A_x: .*{said}"):
            read_tdms(tmp_path / "bad.tdms")


def test_a_flexlogger_file_reads_as_the_record_it_holds(hit, tmp_path):
    """Channels in two groups (accelerations in g and m/s^2, a hammer's force in N), timed by wf_increment and
    wf_start_offset: the record's samples, units and time; placed by with_geometry, the records chain gives the
    modes the CSV of the same record gives."""
    from mountid.identification.from_records import modal_data

    g = 9.80665
    channels = [
        ("Accelerations", c.name, hit.data[:, k] / (g if k % 2 else 1.0), _waveform(500.0, "g" if k % 2 else "m/s^2"))
        for k, c in enumerate(hit.channels)
    ]
    channels.append(("Hammer", "F", np.zeros(len(hit.time)), _waveform(500.0, "N")))
    record = read_record(_write(tmp_path / "flex.tdms", channels))
    assert record.names == (*hit.names, "F") and record.forces == ("F",)
    assert [c.unit for c in record.channels[:2]] == ["m/s^2", "g"]
    np.testing.assert_allclose(record.time, hit.time, rtol=0, atol=1e-12)
    np.testing.assert_allclose(record.in_si().data[:, :-1], hit.data, rtol=1e-15, atol=0)
    write_csv(hit, tmp_path / "hit.csv")
    placed = with_geometry(record.select(hit.names), {c.name: (c.point, c.direction) for c in hit.channels})
    machine = Rig.of("kid300").machine
    from_tdms, from_csv = modal_data(machine, placed, {}), modal_data(machine, read_csv(tmp_path / "hit.csv"), {})
    assert from_tdms.modes.keys() == from_csv.modes.keys()
    for label, mode in from_tdms.modes.items():
        assert mode.frequency == pytest.approx(from_csv.modes[label].frequency, rel=1e-9)


def test_a_channel_of_another_sampling_or_unit_is_named_and_left_out_when_told(hit, tmp_path):
    """A temperature logged at 10 Hz, or a tachometer in V (a raw voltage, named by the records chain), beside the
    accelerations: named with how to leave it out, and read without it when told; a name the file lacks is named with
    the file's channels; two groups' channels of one name are told apart by their group."""
    accelerations = [("Acc", c.name, hit.data[:, k], _waveform(500.0, "m/s^2")) for k, c in enumerate(hit.channels)]
    _write(tmp_path / "temp.tdms", [*accelerations, ("Climate", "T", np.full(80, 21.5), _waveform(10.0, "degC"))])
    with pytest.raises(
        InputError, match=r"^T: 80 samples against 2000 of A_x \(one record needs one sampling\).*--ignore"
    ):
        read_record(tmp_path / "temp.tdms")
    np.testing.assert_array_equal(read_record(tmp_path / "temp.tdms", ignore=("T",)).data, hit.data)
    tacho = ("Acc", "Tacho", np.full(2000, 5.0), _waveform(500.0, "V"))
    _write(tmp_path / "tacho.tdms", [*accelerations, tacho])
    with pytest.raises(InputError, match=r"^Tacho: is a raw voltage in V: .*left out by its name: --ignore Tacho,"):
        read_record(tmp_path / "tacho.tdms").in_si()  # read as recorded, named where the records chain starts
    with pytest.raises(InputError, match=r"^ignore: Rpm: no such channel in tacho.tdms \(channels: A_x, A_y, B_y"):
        read_record(tmp_path / "tacho.tdms", ignore=("Rpm",))
    slow = ("Acc", "Slow", hit.data[:, 0], _waveform(250.0, "m/s^2"))
    _write(tmp_path / "slow.tdms", [*accelerations, slow])
    with pytest.raises(InputError, match=r"^Slow: sampled at 250 Hz against 500 Hz of A_x"):
        read_record(tmp_path / "slow.tdms")
    twice = [*accelerations, ("Spare", "A_x", hit.data[:, 0], _waveform(500.0, "m/s^2"))]
    assert read_record(_write(tmp_path / "twice.tdms", twice)).names == ("Acc/A_x", *hit.names[1:], "Spare/A_x")


def test_a_file_without_waveform_timing_reads_by_its_time_channel_or_the_rate_given(hit, tmp_path):
    """LabVIEW's own logging writes a time channel (seconds, or timestamps) beside plain arrays, or as a waveform
    beside waveforms; a file without any timing reads at the rate given and says so where none is; a file that is
    no TDMS file is named."""
    plain = [("Log", c.name, hit.data[:, k], {"unit_string": "m/s^2"}) for k, c in enumerate(hit.channels)]
    stamps = np.datetime64("2026-12-03T10:00:00", "ns") + (hit.time * 1e9).round().astype("timedelta64[ns]")
    for time in (hit.time + 12.5, stamps):
        record = read_record(_write(tmp_path / "log.tdms", [("Log", "Time", time, {}), *plain]))
        assert record.names == hit.names
        np.testing.assert_allclose(record.time - record.time[0], hit.time, rtol=0, atol=1e-9)
        np.testing.assert_array_equal(record.data, hit.data)
    # a time channel written as a waveform beside the others (in seconds) is the time, not a channel
    waveforms = [(g, c, data, {**p, **_waveform(500.0, p["unit_string"])}) for g, c, data, p in plain]
    for unit in ("s", "ms"):
        clock = [("Log", "Time", hit.time * (1e3 if unit == "ms" else 1.0), _waveform(500.0, unit))]
        record = read_record(_write(tmp_path / "wave.tdms", [*clock, *waveforms]))
        assert record.names == hit.names
        np.testing.assert_allclose(record.time, hit.time, rtol=0, atol=1e-9)
    _write(tmp_path / "bare.tdms", plain)
    with pytest.raises(InputError, match=r"^record: bare.tdms states no sampling .*give the sampling rate \(--rate"):
        read_record(tmp_path / "bare.tdms")
    np.testing.assert_allclose(read_record(tmp_path / "bare.tdms", 500.0).time, hit.time, rtol=0, atol=1e-15)
    (tmp_path / "text.tdms").write_text("not a TDMS file\n")
    with pytest.raises(
        InputError, match=r"^record: text.tdms is not a TDMS file \(it does not begin with a TDMS segment\)"
    ):
        read_record(tmp_path / "text.tdms")
    with pytest.raises(InputError, match=r"^run: 2: bare.tdms is a TDMS file of one run"):
        read_record(tmp_path / "bare.tdms", 500.0, run=2)


def test_a_tdms_file_cut_short_is_named(hit, tmp_path):
    """An interrupted copy: npTDMS reads what a cut file holds and only logs that it is cut (a record of fewer
    samples, or one channel short of the others); the file is named as cut."""
    channels = [("Acc", c.name, hit.data[:, k], _waveform(500.0, "m/s^2")) for k, c in enumerate(hit.channels)]
    whole = _write(tmp_path / "whole.tdms", channels).read_bytes()
    for end in (len(whole) - 100, 200, 60, 20):
        (tmp_path / "cut.tdms").write_bytes(whole[:end])
        with pytest.raises(InputError, match=r"^record: cut.tdms ends inside a segment \(an interrupted copy"):
            read_record(tmp_path / "cut.tdms")


def test_groups_of_the_same_channels_are_runs(hit, tmp_path, capsys):
    """A logger that writes each hit to a group of its own ("Hit 1", "Hit 2", the same channels): read as one record
    it was each channel twice ("Hit 1/A_x" beside "Hit 2/A_x", the data of different hits, as one record's
    channels). Each group is a run, read one at a time or every one (read_runs), combined per mode by process."""
    from mountid.cli import main
    from mountid.measurement.records import read_runs

    other = Rig.of("kid300").simulate(paper_sensors(), 4.0, 500.0, hammers=[paper_hit()], seed=2)
    placed = [
        {"mountid_point": ",".join(map(str, c.point)), "mountid_direction": ",".join(map(str, c.direction))}
        for c in hit.channels
    ]
    groups = [
        (f"Hit {k}", c.name, r.data[:, j], {**_waveform(500.0, "m/s^2"), **placed[j]})
        for k, r in ((1, hit), (2, other))
        for j, c in enumerate(r.channels)
    ]
    path = _write(tmp_path / "hits.tdms", groups)
    with pytest.raises(InputError, match=r"^run: hits.tdms holds 2 runs \(groups Hit 1, Hit 2, each of the same"):
        read_record(path)
    runs = read_runs(path)
    assert [r.names for r in runs] == [hit.names, hit.names] and read_record(path, run=2).names == hit.names
    for got, expected in zip(runs, (hit, other), strict=True):
        np.testing.assert_array_equal(got.data, expected.data)
    assert main(["process", "kid300", str(path)]) == 0
    out = capsys.readouterr().out
    assert out.startswith(f"kid300: 4 modes from {path} (2 runs)\n") and f"from {path} run 1, {path} run 2" in out


def test_units_as_ni_daqmx_names_them_are_read(hit, tmp_path):
    """NI's DAQmx writes a channel's unit_string as "Volts", "Newtons" or "g's": read as V (a raw voltage), N and g
    (records.UNIT_NAMES; "Volts" was a unit mountid did not read)."""
    channels = [
        ("Acc", "A_x", hit.data[:, 0], _waveform(500.0, "g's")),
        ("Acc", "raw", hit.data[:, 1], _waveform(500.0, "Volts")),
        ("Acc", "F", hit.data[:, 2], _waveform(500.0, "Newtons")),
    ]
    record = read_record(_write(tmp_path / "daqmx.tdms", channels))
    assert [(c.quantity, c.unit) for c in record.channels] == [("acceleration", "g"), ("voltage", "V"), ("force", "N")]
