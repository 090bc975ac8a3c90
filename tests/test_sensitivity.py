"""Raw voltages and sensor sensitivities (records.VOLTAGE, records.sensitivity, records.with_sensitivities): a bench's
acquisition that records volts and leaves the sensitivities to the analysis, in CSV, UFF (time records and frequency
response functions) and TDMS; converted on the command line (--sensitivity) and in a campaign ("sensitivity") to the
record the calibrated file holds; the records chain refuses a voltage left unconverted, naming it."""

from __future__ import annotations

import json
import re
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mountid.cli import main
from mountid.diagnosis import campaign
from mountid.effects import STANDARD_GRAVITY
from mountid.errors import InputError
from mountid.measurement.records import (
    UNITS,
    VOLTAGE,
    Record,
    Sensitivity,
    read_record,
    sensitivity,
    with_sensitivities,
    write_csv,
)
from mountid.measurement.rig import Rig
from mountid.validation.paper import paper_hit, paper_sensors

ACCELEROMETER = "100mV/g"
"""An accelerometer's sensitivity as its data sheet gives it: 0.1 V per g."""

FORCE = "2.25mV/N"
"""An impact hammer's: 2.25 mV per N."""

KNOWN = {"m": 838.6, "J_xy": 61.44, "J_z": 51.52, "L_xy": 0.486, "L_z": 0.3, "b_xy": 337.2, "b_z": 1039.0}
"""kid300's known values (as tests/test_campaign_records.py's)."""


@pytest.fixture(scope="module")
def hit() -> Record:
    """A simulated impact test of kid300 with the paper's channels and the hammer's force, 4 s at 500 Hz."""
    return Rig.of("kid300").simulate(paper_sensors(), 4.0, 500.0, hammers=[paper_hit()], seed=1, force_channel="F")


def _in_volts(record: Record) -> Record:
    """The record as an acquisition without sensitivities holds it: accelerations [m/s^2] times 100 mV/g written in
    mV, the force [N] times 2.25 mV/N written in V (the numbers of the data sheets, worked by hand)."""
    volts, channels = [], []
    for k, c in enumerate(record.channels):
        if c.quantity == "force":
            volts.append(record.data[:, k] * 2.25e-3)  # [V]
            channels.append(replace(c, quantity="voltage", unit="V"))
        else:
            volts.append(record.data[:, k] / STANDARD_GRAVITY * 100.0)  # [mV]
            channels.append(replace(c, quantity="voltage", unit="mV"))
    return replace(record, data=np.column_stack(volts), channels=tuple(channels))


def _given(record: Record) -> list[str]:
    """--sensitivity items for every channel of ``record``."""
    return [f"{c.name}={FORCE if c.quantity == 'force' else ACCELEROMETER}" for c in record.channels]


def test_a_sensitivity_is_read_as_a_data_sheet_writes_it():
    """Volts per unit from the text: the voltage's and the measured unit's factors, parentheses around a unit with a
    slash of its own; text that is none, an unknown unit, a value that is no positive number named."""
    assert sensitivity("100mV/g", "s") == Sensitivity(0.1, "acceleration", "g")
    assert sensitivity(" 10.2 mV / (m/s^2) ", "s") == Sensitivity(
        pytest.approx(0.0102, rel=1e-15), "acceleration", "m/s^2"
    )
    assert sensitivity("2.25mV/N", "s") == Sensitivity(pytest.approx(2.25e-3, rel=1e-15), "force", "N")
    assert sensitivity("2,25 mV/N", "s") == sensitivity("2.25mV/N", "s")  # a European sheet's decimal comma
    assert sensitivity("1V/(in/s)", "s") == Sensitivity(1.0, "velocity", "in/s")
    assert sensitivity("50uV/um", "s") == Sensitivity(pytest.approx(5e-5, rel=1e-15), "displacement", "um")
    for text, said in (
        ("100", "is no sensitivity: a number, a voltage unit and the unit measured"),
        ("100mA/g", "is no sensitivity"),
        ("mV/g", "no number before mV"),
        ("100mV/Pa", "'Pa' is not one of m/s^2"),
        ("-100mV/g", "must be a finite number > 0 (a sensor mounted the other way: reverse its direction)"),
        ("0mV/N", "must be a finite number > 0"),
        ("nanmV/g", "must be a finite number > 0"),
    ):
        with pytest.raises(InputError, match=f"^--sensitivity A_x: {re.escape(repr(text))}.*{re.escape(said)}"):
            sensitivity(text, "--sensitivity A_x")


def test_a_record_in_volts_converted_by_its_sensitivities_is_the_calibrated_record(hit, tmp_path):
    """CSV, UFF and TDMS files of the record in volts read as voltages (what they hold) and, their sensitivities
    applied, are the calibrated record to rounding; the writers keep a voltage channel (read back as written)."""
    raw = _in_volts(hit)
    scales = {c.name: sensitivity(FORCE if c.quantity == "force" else ACCELEROMETER, "s") for c in hit.channels}
    writers = {"csv": write_csv}
    from mountid.measurement.uff import write_uff

    writers["uff"] = write_uff
    try:
        from mountid.measurement.tdms import write_tdms

        writers["tdms"] = write_tdms
    except ImportError:  # npTDMS is an extra
        pass
    for kind, write in writers.items():
        write(raw, tmp_path / f"raw.{kind}")
        back = read_record(tmp_path / f"raw.{kind}")
        assert [(c.name, c.quantity, c.unit) for c in back.channels] == [
            (c.name, c.quantity, c.unit) for c in raw.channels
        ], kind
        for field in ("point", "direction"):  # the force channel unplaced: NaN
            np.testing.assert_array_equal(
                [getattr(c, field) for c in back.channels], [getattr(c, field) for c in raw.channels]
            )
        digits = 1e-11 if kind == "uff" else 1e-15  # pyuff's ASCII dataset 58 keeps 12 significant digits
        np.testing.assert_allclose(back.data, raw.data, rtol=digits, atol=0, err_msg=kind)
        calibrated = with_sensitivities(back, scales)
        assert [(c.quantity, c.unit) for c in calibrated.channels] == [("acceleration", "g")] * 5 + [("force", "N")]
        scale = np.abs(hit.data).max()
        np.testing.assert_allclose(calibrated.in_si().data, hit.data, rtol=10 * digits, atol=10 * digits * scale)


def test_the_records_chain_refuses_a_voltage_and_sensitivities_are_checked(hit):
    """A channel left in volts is named where the records chain starts (Record.in_si), with how to convert it and
    how to leave it out; a sensitivity for a channel the record lacks, or one not in volts, names the option."""
    raw = _in_volts(hit)
    with pytest.raises(InputError, match=r"^A_x: is a raw voltage in mV: give its sensor's sensitivity, as --sensi"):
        raw.in_si()
    with pytest.raises(InputError, match=r"^--sensitivity: Q: no such channel in the record \(channels: A_x, "):
        with_sensitivities(raw, {"Q": sensitivity("1mV/g", "s")}, "--sensitivity")
    with pytest.raises(InputError, match=r"^sensitivity: A_x: is recorded in m/s\^2 already, not in volts"):
        with_sensitivities(hit, {"A_x": sensitivity("1mV/g", "s")})


def test_process_and_identify_record_take_sensitivities(hit, tmp_path, capsys):
    """The command line's --sensitivity gives from a file in volts the stiffnesses the calibrated file gives (to
    1e-9); without it the records chain names the channel and the option (one line, exit code 2); a name given
    twice or an item without '=' named."""
    write_csv(hit, tmp_path / "calibrated.csv")
    write_csv(_in_volts(hit), tmp_path / "raw.csv")
    assert main(["identify-record", "kid300", str(tmp_path / "calibrated.csv"), "--json"]) == 0
    expected = json.loads(capsys.readouterr().out)
    code = main(["identify-record", "kid300", str(tmp_path / "raw.csv"), "--json", "--sensitivity", *_given(hit)])
    assert code == 0
    got = json.loads(capsys.readouterr().out)
    for name, value in expected["parameters"].items():
        assert got["parameters"][name] == pytest.approx(value, rel=1e-9), name
    assert main(["process", "kid300", str(tmp_path / "raw.csv")]) == 2
    err = capsys.readouterr().err
    assert err.startswith(
        "mountid: error: A_x: is a raw voltage in mV: give its sensor's sensitivity, as --sensitivity A_x="
    )
    assert len(err.strip().splitlines()) == 1
    for items, said in (
        (["A_x=100mV/g", "A_x=99mV/g"], "--sensitivity A_x: given twice"),
        (["A_x"], "--sensitivity: expected NAME=SENSITIVITY (as A_x=100mV/g), got 'A_x'"),
        (["A_x=100mV/Pa"], "--sensitivity A_x: '100mV/Pa': 'Pa' is not one of"),
        (["Q=100mV/g"], "--sensitivity: Q: no such channel in the record"),
    ):
        assert main(["process", "kid300", str(tmp_path / "raw.csv"), "--sensitivity", *items]) == 2
        err = capsys.readouterr().err
        assert said in err and len(err.strip().splitlines()) == 1, err


def test_frequency_response_functions_in_volts_per_newton_take_the_accelerometers_sensitivity(tmp_path):
    """A bench's FRFs of raw response voltages per newton (an analyser told the hammer's sensitivity, not the
    accelerometers'): read as voltages per N s (they were a KeyError), converted, the impulse responses of the
    calibrated file to rounding; FRFs per volt (or mV) of the hammer (its sensitivity left out) read as such, named
    until its sensitivity is given under the reference's name, then the calibrated file's to rounding too."""
    from test_uff_frf import _frf_file

    from mountid.measurement.uff import read_uff

    _frf_file(tmp_path / "calibrated.uff", unit="g")
    expected = read_uff(tmp_path / "calibrated.uff")
    sets = __import__("pyuff").UFF(str(tmp_path / "calibrated.uff")).read_sets()
    for k, s in enumerate(sets):  # typed as an acceleration (the analyser's channel setup) or as general data
        s["data"] = np.asarray(s["data"]) * 100.0  # g per N times 100 mV/g: mV per N
        s["ordinate_axis_units_lab"], s["ordinate_spec_data_type"] = "mV", (12, 1)[k % 2]
    __import__("pyuff").UFF(str(tmp_path / "raw.uff")).write_sets(sets, mode="add")
    raw = read_uff(tmp_path / "raw.uff")
    assert {(c.quantity, c.unit) for c in raw.channels} == {("voltage", "V")}
    with pytest.raises(InputError, match="^A_x: is a raw voltage in V: give its sensor's sensitivity"):
        raw.in_si()
    scales = {c.name: sensitivity(ACCELEROMETER, "s") for c in raw.channels}
    got = with_sensitivities(raw, scales).in_si()
    scale = np.abs(expected.data).max()
    np.testing.assert_allclose(got.data, expected.in_si().data, rtol=1e-12, atol=1e-12 * scale)
    for k, s in enumerate(sets):  # the accelerometers' sensitivities applied, the hammer's left out: g per V
        s["data"] = np.asarray(s["data"]) / 100.0 / 2.25e-3
        s["ordinate_axis_units_lab"], s["orddenom_axis_units_lab"] = "g", ("V", "mV")[k % 2]
        s["data"] = s["data"] / (1.0, 1e3)[k % 2]  # per mV: a thousandth of per V
        s["ref_ent_name"] = "hammer"
    __import__("pyuff").UFF(str(tmp_path / "per_volt.uff")).write_sets(sets, mode="add")
    per_volt = read_uff(tmp_path / "per_volt.uff")
    assert per_volt.impulse.per_volt == "hammer"
    with pytest.raises(InputError, match="^hammer: frequency response functions per volt of this reference .* hammer="):
        per_volt.in_si()
    got = with_sensitivities(per_volt, {"hammer": sensitivity(FORCE, "s")}).in_si()
    np.testing.assert_allclose(got.data, expected.in_si().data, rtol=1e-12, atol=1e-12 * scale)
    with pytest.raises(InputError, match="^s: hammer: the reference's sensitivity is per force, not per g"):
        with_sensitivities(per_volt, {"hammer": sensitivity(ACCELEROMETER, "s")}, "s")


def test_a_campaign_converts_its_records_by_sensitivity(hit, tmp_path):
    """A campaign record's "sensitivity" gives the modes of the calibrated file (same frequencies to 1e-9), said in
    the notes; left out, the error names the entry and the channel; a sensitivity that is none names the entry and
    the channel."""
    write_csv(hit, tmp_path / "calibrated.csv")
    write_csv(_in_volts(hit), tmp_path / "raw.csv")
    data = {"machine": "kid300", "known": KNOWN, "records": ["calibrated.csv"]}
    expected = campaign.parse(data, tmp_path)
    scales = {c.name: FORCE if c.quantity == "force" else ACCELEROMETER for c in hit.channels}
    data["records"] = [{"file": "raw.csv", "sensitivity": scales}]
    got = campaign.parse(data, tmp_path)
    assert got.modes.keys() == expected.modes.keys()
    for label, mode in expected.modes.items():
        assert got.modes[label].frequency == pytest.approx(mode.frequency, rel=1e-9), label
    assert any(
        n.startswith("raw.csv: converted from volts by the campaign's sensitivities: A_x 100mV/g, ")
        for n in got.record_notes
    )
    data["records"] = ["raw.csv"]
    with pytest.raises(InputError, match=r"^records\.0 \(raw\.csv\): A_x: is a raw voltage in mV"):
        campaign.parse(data, tmp_path)
    data["records"] = [{"file": "raw.csv", "sensitivity": {**scales, "A_x": "100mV"}}]
    with pytest.raises(InputError, match=r"^records\.0 \(raw\.csv\): sensitivity\.A_x: '100mV' is no sensitivity"):
        campaign.parse(data, tmp_path)


@settings(max_examples=60, deadline=None)
@given(
    value=st.floats(min_value=1e-3, max_value=1e4, allow_nan=False),
    volts=st.sampled_from(["V", "mV", "uV"]),
    unit=st.sampled_from([u for units in UNITS.values() for u in units]),
)
def test_a_sensitivity_written_reads_back(value, volts, unit):
    """Any sensitivity as a data sheet writes it reads as its value in V per unit, and written back (str) reads as
    the same to 12 digits; a unit with a slash of its own in parentheses."""
    text = f"{value!r} {volts}/{unit if '/' not in unit else f'({unit})'}"
    read = sensitivity(text, "s")
    assert read.volts == pytest.approx(value * VOLTAGE[volts], rel=1e-15) and read.unit == unit
    again = sensitivity(str(read), "s")
    assert again.volts == pytest.approx(read.volts, rel=1e-11) and (again.quantity, again.unit) == (read.quantity, unit)
