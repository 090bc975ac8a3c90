"""A test's channel table (mountid.measurement.channel_table): where each channel sits and its sensor's
sensitivity, as a spreadsheet beside the records; on the command line (--channels) and in a campaign
("channel_table") it gives what the channels' placements and sensitivities given one by one give."""

from __future__ import annotations

import json

import numpy as np
import pytest

from mountid.cli import main
from mountid.diagnosis import campaign
from mountid.effects import STANDARD_GRAVITY
from mountid.errors import InputError
from mountid.measurement.channel_table import read_channel_table
from mountid.measurement.records import Record, write_csv
from mountid.measurement.rig import Rig
from mountid.validation.paper import paper_hit, paper_sensors

KNOWN = {"m": 838.6, "J_xy": 61.44, "J_z": 51.52, "L_xy": 0.486, "L_z": 0.3, "b_xy": 337.2, "b_z": 1039.0}
"""kid300's known values (as tests/test_campaign_records.py's)."""


@pytest.fixture(scope="module")
def hit() -> Record:
    """A simulated impact test of kid300 with the paper's channels and the hammer's force, 4 s at 500 Hz."""
    return Rig.of("kid300").simulate(paper_sensors(), 4.0, 500.0, hammers=[paper_hit()], seed=1, force_channel="F")


def _bench_export(record: Record, path) -> None:
    """The record as a bench exports it: in volts (100 mV/g, 2.25 mV/N), no geometry (a plain CSV)."""
    forces = np.array([c.quantity == "force" for c in record.channels])
    volts = np.where(forces, record.data * 2.25e-3, record.data / STANDARD_GRAVITY * 0.1)
    head = ",".join(["Time [s]", *(f"{c.name} [V]" for c in record.channels)])
    rows = (",".join(map(repr, [float(t), *map(float, v)])) for t, v in zip(record.time, volts, strict=True))
    path.write_text("\n".join([head, *rows]) + "\n", encoding="utf-8")


def _table(record: Record, separator: str = ",", mm: bool = False) -> str:
    """The record's channel table: points (in mm where asked), directions as signed axes, sensitivities."""
    head = ["Channel", "X [mm]" if mm else "x", "Y [mm]" if mm else "y", "Z [mm]" if mm else "z", "Direction"]
    rows = [separator.join([*head, "Sensitivity"])]
    for c in record.channels:
        if c.quantity == "force":
            rows.append(separator.join([c.name, "", "", "", "", "2.25mV/N"]))  # a hammer's: its sensitivity only
            continue
        point = [repr(1e3 * v if mm else v) for v in c.point]
        k = int(np.argmax(np.abs(c.direction)))
        axis = ("-" if c.direction[k] < 0 else "+") + "xyz"[k]
        rows.append(separator.join([c.name, *point, axis, "100 mV/g"]))
    return "# the bench's setup sheet\n" + "\n".join(rows) + "\n"


def test_a_channel_table_places_and_converts_a_bench_export(hit, tmp_path, capsys):
    """A plain CSV in volts with the table (commas, or semicolons with the points in mm): identify-record gives the
    stiffnesses of the calibrated file with its geometry (1e-9); --channel and --sensitivity beside the table
    replace its rows."""
    write_csv(hit, tmp_path / "calibrated.csv")
    _bench_export(hit, tmp_path / "raw.csv")
    assert main(["identify-record", "kid300", str(tmp_path / "calibrated.csv"), "--json"]) == 0
    expected = json.loads(capsys.readouterr().out)["parameters"]
    for separator, mm in ((",", False), (";", True)):
        (tmp_path / "channels.csv").write_text(_table(hit, separator, mm), encoding="utf-8")
        argv = ["identify-record", "kid300", str(tmp_path / "raw.csv"), "--json", "--channels"]
        assert main([*argv, str(tmp_path / "channels.csv")]) == 0
        got = json.loads(capsys.readouterr().out)["parameters"]
        for name, value in expected.items():
            assert got[name] == pytest.approx(value, rel=1e-9), (separator, name)
    a = hit.channels[0]
    moved = f"{a.name}={a.point[0]},{a.point[1]},{a.point[2] + 0.05}:{','.join(map(str, a.direction))}"
    argv = ["process", "kid300", str(tmp_path / "raw.csv"), "--channels", str(tmp_path / "channels.csv")]
    assert main([*argv, "--channel", moved, "--sensitivity", "A_x=50mV/g", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["modes"]  # both accepted over the table's rows


def test_a_channel_table_in_a_campaign_is_its_channels_and_sensitivities(hit, tmp_path):
    """A campaign record's "channel_table" gives the modes its "channels" and "sensitivity" give (1e-12), said in
    the notes."""
    _bench_export(hit, tmp_path / "raw.csv")
    (tmp_path / "channels.csv").write_text(_table(hit), encoding="utf-8")
    table = read_channel_table(tmp_path / "channels.csv")
    channels = {n: {"point": list(p), "direction": list(d)} for n, (p, d) in table.placements.items()}
    scales = {name: str(s) for name, s in table.sensitivities.items()}
    by_hand = {"machine": "kid300", "known": KNOWN, "records": [{"file": "raw.csv", "channels": channels}]}
    by_hand["records"][0]["sensitivity"] = scales
    with_table = {
        "machine": "kid300",
        "known": KNOWN,
        "records": [{"file": "raw.csv", "channel_table": "channels.csv"}],
    }
    expected, got = campaign.parse(by_hand, tmp_path), campaign.parse(with_table, tmp_path)
    assert got.modes.keys() == expected.modes.keys()
    for label, mode in expected.modes.items():
        assert got.modes[label].frequency == pytest.approx(mode.frequency, rel=1e-12), label
    assert any("channels placed, and converted from volts, by the table channels.csv" in n for n in got.record_notes)


@pytest.mark.parametrize(
    ("text", "said"),
    [
        ("name,x,y\nA_x,0,0\n", r"channels.csv:1: the header needs the columns name, x, y, z and a direction"),
        ("name,x,y,z\nA_x,0,0,0\n", r"channels.csv:1: the header needs a column direction"),
        ("name,x [in],y,z,direction\nA_x,0,0,0,+x\n", r"channels.csv:1: 'x \[in\]': a point's unit is m or mm"),
        ("name,x,y,z,direction\nA_x,0,zero,0,+x\n", r"channels.csv:2 y: 'zero' is not a number"),
        (
            "name,x,y,z,direction\nA_x,0,0,0,w\n",
            r"channels.csv:2 direction: 'w': a signed axis \(\+x, -y, z\) or three",
        ),
        ("name,x,y,z,dx,dy,dz\nA_x,0,0,0,0,0,0\n", r"channels.csv:2 direction: is zero"),
        ("name,x,y,z,direction\nA_x,0,0,0,+x\nA_x,0,0,0,+y\n", r"channels.csv:3: A_x: given twice"),
        ("name,x,y,z,direction,sensitivity\nA_x,0,0,0,+x,100mV\n", r"channels.csv:2 sensitivity: '100mV' is no sens"),
        ("name,x,y,z,direction\n", r"channels: channels.csv holds a header and no channel"),
    ],
)
def test_what_a_channel_table_cannot_say_is_named_by_line_and_column(tmp_path, text, said):
    (tmp_path / "channels.csv").write_text(text, encoding="utf-8")
    with pytest.raises(InputError, match=f"^{said}"):
        read_channel_table(tmp_path / "channels.csv")


def test_a_table_of_other_channels_is_named(hit, tmp_path, capsys):
    """A table that names none of the record's channels (another test's sheet): one line, exit 2; a table listing
    more channels than the record holds (a roving test's sheet) places those it holds."""
    _bench_export(hit, tmp_path / "raw.csv")
    (tmp_path / "other.csv").write_text("name,x,y,z,direction\nQ1,0,0,0,+x\n", encoding="utf-8")
    assert main(["process", "kid300", str(tmp_path / "raw.csv"), "--channels", str(tmp_path / "other.csv")]) == 2
    err = capsys.readouterr().err
    assert "--channels: names none of the record's channels (A_x, A_y" in err and len(err.strip().splitlines()) == 1
    (tmp_path / "more.csv").write_text(_table(hit) + "Q1,0,0,0,+x,100mV/g\n", encoding="utf-8")
    assert main(["process", "kid300", str(tmp_path / "raw.csv"), "--channels", str(tmp_path / "more.csv")]) == 0


def test_given_one_by_one_replaces_the_tables_rows(hit, tmp_path):
    """set_up: a sensitivity given one by one converts its channel before the table (whose row for it is then not
    applied), a placement given one by one replaces the table's row."""
    from mountid.measurement.channel_table import set_up
    from mountid.measurement.records import read_record, sensitivity

    _bench_export(hit, tmp_path / "raw.csv")
    (tmp_path / "channels.csv").write_text(_table(hit), encoding="utf-8")
    table = read_channel_table(tmp_path / "channels.csv")
    raw = read_record(tmp_path / "raw.csv")
    moved = {"A_x": ((0.1, 0.2, 0.3), (0.0, 0.0, 1.0))}
    got = set_up(raw, {"A_x": sensitivity("50mV/g", "s")}, table, moved)
    a_x = got.channels[got.names.index("A_x")]
    assert (a_x.point, a_x.direction, a_x.unit) == ((0.1, 0.2, 0.3), (0.0, 0.0, 1.0), "g")
    np.testing.assert_allclose(got.channel("A_x"), raw.channel("A_x") / 0.05)  # 50 mV/g, not the table's 100
    b_y = got.channels[got.names.index("B_y")]
    assert b_y.point == hit.channels[hit.names.index("B_y")].point and b_y.unit == "g"
