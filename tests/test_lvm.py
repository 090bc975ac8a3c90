"""LabVIEW Measurement files (mountid.measurement.lvm): files as LabVIEW's Write To Measurement File writes them
(written here to NI's specification of the format), read back as the records they hold; segments as runs; raw
voltages with their sensitivities; what mountid does not read named."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from mountid.errors import InputError
from mountid.measurement.records import Record, read_csv, read_record, read_runs, sensitivity, with_geometry
from mountid.measurement.rig import Rig
from mountid.validation.paper import paper_hit, paper_sensors

pytest.importorskip("lvm_read")

LABVIEW = {"m/s^2": "m/s^2", "g": "g", "N": "Newtons", "V": "Volts", "mV": "mV"}
"""The unit names LabVIEW writes for mountid's units."""


def _lvm(
    records: list[Record],
    x_columns: str = "One",
    decimal: str = ".",
    comment: bool = False,
    units: list[str] | None = None,
    dimension: str = "Time",
) -> str:
    """The text of an LVM file of one segment per record (LVM 2.0: tab separated, a file header, each segment's
    header with one value per channel, its table with an X column per ``x_columns``, empty for "No", and an optional
    Comment)."""
    head = [
        "LabVIEW Measurement\t",
        "Writer_Version\t2",
        "Reader_Version\t2",
        "Separator\tTab",
        f"Decimal_Separator\t{decimal}",
        "Multi_Headings\tNo",
        f"X_Columns\t{x_columns}",
        "Time_Pref\tRelative",
        "Operator\tbench",
        "Date\t2026/12/03",
        "Time\t10:00:00.000",
        "***End_of_Header***\t",
        "\t",
    ]

    def number(v: float) -> str:
        return repr(float(v)).replace(".", decimal)

    lines = list(head)
    for record in records:
        n, names = len(record.time), [c.name for c in record.channels]
        per = len(names)
        unit = units or [LABVIEW[c.unit] for c in record.channels]
        step = record.time[1] - record.time[0]
        lines += [
            f"Channels\t{per}\t",
            "Samples\t" + "\t".join([str(n)] * per) + "\t",
            "Date\t" + "\t".join(["2026/12/03"] * per) + "\t",
            "Time\t" + "\t".join(["10:00:00.000"] * per) + "\t",
            "Y_Unit_Label\t" + "\t".join(unit) + "\t",
            "X_Dimension\t" + "\t".join([dimension] * per) + "\t",
            "X0\t" + "\t".join([number(record.time[0])] * per) + "\t",
            "Delta_X\t" + "\t".join([number(step)] * per) + "\t",
            "***End_of_Header***\t",
            "\t".join(["X_Value", *names] + (["Comment"] if comment else [])),  # X_Value heads even an empty column
        ]
        for k in range(n):
            row = [number(record.time[k]) if x_columns == "One" else ""] + [number(v) for v in record.data[k]]
            lines.append("\t".join(row) + ("\tfirst hit" if comment and k == 3 else ""))
        lines.append("")
    return "\r\n".join(lines) + "\r\n"


@pytest.fixture(scope="module")
def hits() -> list[Record]:
    """Two simulated impact tests of kid300 with the paper's channels and the hammer's force, 4 s at 500 Hz."""
    rig = Rig.of("kid300")
    return [
        rig.simulate(paper_sensors(), 4.0, 500.0, hammers=[paper_hit()], seed=seed, force_channel="F")
        for seed in (1, 2)
    ]


def _placed(read: Record, simulated: Record) -> Record:
    """A record read from a file without geometry, its channels placed as the simulated ones are."""
    return with_geometry(read, {c.name: (c.point, c.direction) for c in simulated.channels if c.quantity != "force"})


def test_an_lvm_file_reads_as_the_record_it_holds(hits, tmp_path):
    """Time from X0 and Delta_X, each channel's unit from Y_Unit_Label (LabVIEW's "Newtons" a force in N), the values
    as written (decimal point or comma, a Comment column): the record, whose modes are those of its CSV."""
    record = hits[0]
    for decimal, comment in ((".", False), (",", True)):
        (tmp_path / "hit.lvm").write_text(_lvm([record], decimal=decimal, comment=comment), encoding="utf-8")
        back = read_record(tmp_path / "hit.lvm")
        assert back.names == record.names
        assert [(c.quantity, c.unit) for c in back.channels] == [(c.quantity, c.unit) for c in record.channels]
        np.testing.assert_array_equal(back.data, record.data)
        np.testing.assert_allclose(back.time, record.time, rtol=0, atol=1e-12)
    from mountid.identification.from_records import modal_data
    from mountid.measurement.records import write_csv

    write_csv(record, tmp_path / "hit.csv")
    machine = Rig.of("kid300").machine
    from_lvm = modal_data(machine, _placed(back, record), {})
    from_csv = modal_data(machine, read_csv(tmp_path / "hit.csv"), {})
    assert from_lvm.modes.keys() == from_csv.modes.keys() == {"x", "phi", "z", "psi"}
    for label, mode in from_lvm.modes.items():
        assert mode.frequency == pytest.approx(from_csv.modes[label].frequency, rel=1e-9), label


def test_segments_of_the_same_channels_are_runs(hits, tmp_path, capsys):
    """A logger's hits, a segment each: runs, read one at a time (an error naming them without one) or every one;
    a file without an X column takes its time from X0 and Delta_X; `process` combines the runs per mode."""
    path = tmp_path / "hits.lvm"
    path.write_text(_lvm(hits, x_columns="No"), encoding="utf-8")
    with pytest.raises(InputError, match=r"^run: hits.lvm holds 2 runs \(segments of the same channels, a hit each"):
        read_record(path)
    runs = read_runs(path)
    assert len(runs) == 2
    for got, expected in zip(runs, hits, strict=True):
        np.testing.assert_array_equal(got.data, expected.data)
        np.testing.assert_allclose(got.time, expected.time, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(read_record(path, run=2).data, hits[1].data)
    with pytest.raises(InputError, match=r"^run: 3: hits.lvm holds 2 runs"):
        read_record(path, run=3)
    from mountid.cli import main

    placed = [f"{c.name}={','.join(map(str, c.point))}:{','.join(map(str, c.direction))}" for c in paper_sensors()]
    assert main(["process", "kid300", str(path), "--channel", *placed]) == 0
    out = capsys.readouterr().out
    assert "hits.lvm run 1" in out and "hits.lvm run 2" in out


def test_raw_voltages_of_a_labview_daq_take_their_sensitivities(hits, tmp_path):
    """A DAQ that records volts (Y_Unit_Label "Volts"): read as voltages, converted by the sensors' sensitivities
    into the calibrated record (to rounding)."""
    from mountid.effects import STANDARD_GRAVITY
    from mountid.measurement.records import with_sensitivities

    record = hits[0]
    forces = np.array([c.quantity == "force" for c in record.channels])
    volts = np.where(forces, record.data * 2.25e-3, record.data / STANDARD_GRAVITY * 0.1)  # 2.25 mV/N, 100 mV/g
    raw = replace(record, data=volts)
    (tmp_path / "raw.lvm").write_text(_lvm([raw], units=["Volts"] * len(forces)), encoding="utf-8")
    back = read_record(tmp_path / "raw.lvm")
    assert {(c.quantity, c.unit) for c in back.channels} == {("voltage", "V")}
    scales = {c.name: sensitivity("2.25mV/N" if c.quantity == "force" else "100mV/g", "s") for c in record.channels}
    calibrated = with_sensitivities(back, scales).in_si()
    scale = np.abs(record.data).max(axis=0)
    np.testing.assert_allclose(calibrated.data, record.data, rtol=1e-13, atol=1e-13 * scale.max())


def test_what_mountid_does_not_read_of_an_lvm_file_is_named(hits, tmp_path):
    """A unit mountid does not read (with how to leave the channel out, and read without it when told), a cell that
    is not a number, an x axis that is not time, a time column per channel, segments of different channels and a
    file that is not LVM: errors naming the channel or the file."""
    record = hits[0].select(["A_x", "A_y"])

    def written(name: str, text: str) -> Path:
        (tmp_path / name).write_text(text, encoding="utf-8")
        return tmp_path / name

    mic = written("mic.lvm", _lvm([record], units=["m/s^2", "Pa"]))
    with pytest.raises(InputError, match=r"^A_y: mic.lvm: unit 'Pa' is not one of .*--ignore A_y"):
        read_record(mic)
    np.testing.assert_array_equal(read_record(mic, ignore=("A_y",)).data[:, 0], record.data[:, 0])
    with pytest.raises(InputError, match=r"^ignore: Q: no such channel in mic.lvm"):
        read_record(mic, ignore=("Q",))
    text = _lvm([record]).replace(repr(float(record.data[5, 1])), "overload", 1)
    with pytest.raises(InputError, match=r"^A_y: a value is not a number in row 6 of bad.lvm's table"):
        read_record(written("bad.lvm", text))
    with pytest.raises(InputError, match=r"^A_x: its x axis is Frequency: a record is time responses"):
        read_record(written("spectrum.lvm", _lvm([record], dimension="Frequency")))
    with pytest.raises(InputError, match=r"^record: multi.lvm has a time column per channel \(X_Columns Multi\)"):
        read_record(written("multi.lvm", _lvm([record], x_columns="Multi")))
    other = _lvm([record, hits[0].select(["A_x", "B_y"])])
    with pytest.raises(InputError, match=r"^record: mixed.lvm holds segments of different channels"):
        read_record(written("mixed.lvm", other))
    with pytest.raises(InputError, match=r"^record: plain.lvm is not an LVM file"):
        read_record(written("plain.lvm", "time,A_x\n0,1\n"))
