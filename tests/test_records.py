"""Records: CSV write and read back, and the input errors that keep a wrong frequency from being silent."""

from __future__ import annotations

import gc
import re
from pathlib import Path

import numpy as np
import pytest
from conftest import budget
from hypothesis import given, settings
from hypothesis import strategies as st

from mountid.errors import InputError
from mountid.measurement.records import Channel, Record, read_csv, write_csv


def _record(n: int = 100) -> Record:
    rng = np.random.default_rng(0)
    t = np.arange(n) / 500.0
    channels = (Channel("A_x", (0.3, 0.0, 0.1), (1.0, 0.0, 0.0)), Channel("B_y", (0.3, 0.0, 0.312), (0.0, 1.0, 0.0)))
    return Record(t, rng.standard_normal((n, 2)), channels)


def test_csv_round_trip_is_exact(tmp_path):
    rec = _record()
    write_csv(rec, tmp_path / "r.csv")
    back = read_csv(tmp_path / "r.csv")
    assert back.channels == rec.channels
    np.testing.assert_array_equal(back.time, rec.time)
    np.testing.assert_array_equal(back.data, rec.data)


def test_plain_csv_reads_without_metadata(tmp_path):
    (tmp_path / "p.csv").write_text("time,a\n" + "\n".join(f"{i / 100},{np.sin(i)}" for i in range(50)) + "\n")
    rec = read_csv(tmp_path / "p.csv")
    assert rec.names == ("a",) and np.isnan(rec.channels[0].point[0])


def test_a_csv_without_a_time_column_is_named_or_read_at_the_rate_given(tmp_path):
    """A bench export of channels only: its first channel was read as the time ("time: must increase", or with
    --rate its samples were dropped for a uniform grid and the channel was "no such channel"). Without a rate the
    first column is named as read for the time, and the error says how such a file reads; with one every column is
    a channel, sampled from t = 0 (also where the first states a channel's unit, "A_x [g]"). A first column named
    as a time whose steps do not rise stays an error with a rate too."""
    rec = _record()
    (tmp_path / "c.csv").write_text("A_x,B_y\n" + "\n".join(f"{a},{b}" for a, b in rec.data) + "\n")
    with pytest.raises(InputError, match=r"^c.csv: column 1: 'A_x' is read as the time, but \d+% of its steps") as e:
        read_csv(tmp_path / "c.csv")
    assert "a file of channels only reads with --rate or a campaign's 'rate'" in e.value.reason
    got = read_csv(tmp_path / "c.csv", 500.0)
    assert got.names == rec.names
    np.testing.assert_array_equal(got.data, rec.data)
    np.testing.assert_allclose(got.time, rec.time, rtol=0, atol=1e-15)
    (tmp_path / "g.csv").write_text("A_x [g];B_y [g]\n" + "\n".join(f"{a};{b}" for a, b in rec.data) + "\n")
    with pytest.raises(InputError, match=r"^g.csv: column 1: time in 'g': .* \(a file of channels only reads with"):
        read_csv(tmp_path / "g.csv")
    assert [(c.name, c.unit) for c in read_csv(tmp_path / "g.csv", 500.0).channels] == [("A_x", "g"), ("B_y", "g")]
    (tmp_path / "t.csv").write_text("Time [s],A_x\n" + "\n".join(f"{a},{b}" for a, b in rec.data) + "\n")
    with pytest.raises(InputError, match=r"^t.csv: column 1: 'Time \[s\]' is read as the time, but \d+% of its"):
        read_csv(tmp_path / "t.csv", 500.0)
    with pytest.raises(InputError, match="^rate: must be a positive number"):
        read_csv(tmp_path / "c.csv", 0.0)
    # a time column with two rows swapped is still named at the swap
    t = rec.time[np.r_[0:50, 51, 50, 52 : len(rec.time)]]
    rows = (f"{a},{b}" for a, b in zip(t, rec.data[:, 0], strict=True))
    (tmp_path / "s.csv").write_text("t,A_x\n" + "\n".join(rows) + "\n")
    with pytest.raises(InputError, match="^time: goes back or repeats at t = 0.1 s"):
        read_csv(tmp_path / "s.csv")


@pytest.mark.parametrize(
    "preamble", ["Sample rate;500;Hz", "Sampling Rate: 0.5 kHz", "Fs = 500", "Abtastrate [Hz];500,0"]
)
def test_a_csv_without_a_time_column_reads_at_the_rate_its_preamble_states(tmp_path, preamble):
    """A bench export of channels only (or of a sample count) whose preamble states the sampling rate reads at that
    rate, as with --rate (it needed --rate beside the file that states it); a file with a time column keeps its
    column's times."""
    rec = _record()
    separator = ";" if ";" in preamble else ","
    body = "\n".join(f"{a}{separator}{b}" for a, b in rec.data)
    (tmp_path / "c.csv").write_text(f"Exported by BenchSoft\n{preamble}\nA_x{separator}B_y\n{body}\n")
    got = read_csv(tmp_path / "c.csv")
    np.testing.assert_array_equal(got.data, rec.data)
    np.testing.assert_allclose(got.time, rec.time, rtol=0, atol=1e-15)
    counts = "\n".join(f"{k}{separator}{a}{separator}{b}" for k, (a, b) in enumerate(rec.data))
    (tmp_path / "n.csv").write_text(f"{preamble}\nSample{separator}A_x{separator}B_y\n{counts}\n")
    np.testing.assert_allclose(read_csv(tmp_path / "n.csv").time, rec.time, rtol=0, atol=1e-15)
    timed = "\n".join(f"{2 * t}{separator}{a}{separator}{b}" for t, (a, b) in zip(rec.time, rec.data, strict=True))
    (tmp_path / "t.csv").write_text(f"{preamble}\nTime{separator}A_x{separator}B_y\n{timed}\n")
    np.testing.assert_allclose(read_csv(tmp_path / "t.csv").time, 2 * rec.time, rtol=0, atol=1e-15)


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda t, d: (t, np.where(np.arange(len(t))[:, None] == 40, np.nan, d)), "^A_x: NaN or infinite sample"),
        (lambda t, d: (np.concatenate([t[:50], t[50:] + 0.1]), d), "^time: a gap at t = 0.098"),
        (
            lambda t, d: (np.where(np.arange(len(t)) == 50, t - 0.0006, t), d),
            "^time: non-uniform sampling at t = 0.098",
        ),
        (lambda t, d: (t[:10], d[:10]), "^time: a record needs at least 16 samples"),
        # two rows swapped: a step back, not a dropped sample one row later
        (lambda t, d: (t[np.r_[0:50, 51, 50, 52 : len(t)]], d), "^time: goes back or repeats at t = 0.1 s after"),
        (lambda t, d: (t[np.r_[0:50, 50, 50 : len(t) - 1]], d), "^time: goes back or repeats at t = 0.1 s after 0.1 s"),
        # samples whose squares overflow (they ended in "SVD did not converge" with a traceback)
        (lambda t, d: (t, d * [1.0, 1e300]), r"^B_y: samples up to .*e\+300 m/s\^2, beyond 1e\+100"),
    ],
)
def test_bad_records_are_rejected_by_name(edit, message):
    rec = _record()
    t, d = edit(rec.time, rec.data)
    with pytest.raises(InputError, match=message):
        Record(t, d, rec.channels)


@pytest.mark.parametrize(
    ("head", "units"),
    [
        ("Frequency [Hz],H1 Re,H1 Im", ""),
        ("Freq (Hz);A_x (g);B_y (g)", ""),
        ("Frequency,A_x,B_y", ""),
        ("f,A_x,B_y", "Hz,g,g"),
    ],
)
@pytest.mark.parametrize("rate", [None, 500.0])
def test_a_table_of_spectra_is_named_as_no_record(tmp_path, head, units, rate):
    """A bench's FRFs or spectra exported as a table: its first column, a frequency axis, was read as the time
    (a header "Freq (Hz)" without a unit it knew: seconds) and the spectra as accelerations; the chain then said
    "too short for 24 exponentials". The frequency axis is named (by its name or unit, with --rate too)."""
    separator = ";" if ";" in head else ","
    rows = [separator.join(str(v) for v in (0.125 * k, 0.1, 0.2)) for k in range(200)]
    (tmp_path / "frf.csv").write_text("\n".join([head, *([units] if units else []), *rows]) + "\n")
    with pytest.raises(InputError, match=r"^frf.csv: column 1: '.*' is a frequency axis: a table of spectra or freq"):
        read_csv(tmp_path / "frf.csv", rate)


def test_a_channel_in_hertz_is_a_unit_not_read(tmp_path):
    """A tachometer's speed in Hz beside the accelerations ("Speed (Hz)") was a channel named so, read as an
    acceleration in m/s^2: its unit is named now, to be left out."""
    rows = [f"{0.002 * k},{np.sin(k)},{25.0}" for k in range(500)]
    (tmp_path / "tacho.csv").write_text("\n".join(["Time [s],A_x [g],Speed (Hz)", *rows]) + "\n")
    with pytest.raises(
        InputError, match=r"^tacho.csv: column 3: 'Speed \(Hz\)': unit 'Hz' is not one of .* --ignore Speed,"
    ):
        read_csv(tmp_path / "tacho.csv")
    assert read_csv(tmp_path / "tacho.csv", ignore=("Speed",)).names == ("A_x",)


def test_a_csv_with_a_byte_order_mark_reads_as_without(tmp_path):
    """Spreadsheet exports start UTF-8 with a byte order mark: it hid the first line's "#" (the record's
    metadata) or the time column's name; the file reads as the same file without it."""
    write_csv(_record(), tmp_path / "r.csv")
    (tmp_path / "bom.csv").write_text("\ufeff" + (tmp_path / "r.csv").read_text(encoding="utf-8"), encoding="utf-8")
    plain, marked = read_csv(tmp_path / "r.csv"), read_csv(tmp_path / "bom.csv")
    assert marked.channels == plain.channels
    np.testing.assert_array_equal(marked.data, plain.data)


def test_spreadsheet_exports_read_as_the_plain_table(tmp_path):
    """A bench's table as spreadsheets export it reads as the same table: every cell quoted ("0,5";"1,2": the
    quotes were 'a value is not a number'), a separator at the end of every line (an unnamed column of NaN
    ended in ': NaN or infinite sample' naming no channel). A header cell left empty over values is an error
    that says so."""
    rec = _record()
    rows = [";".join(f"{v:.17g}".replace(".", ",") for v in (t, *d)) for t, d in zip(rec.time, rec.data, strict=True)]
    plain = "time;" + ";".join(rec.names) + "\n" + "\n".join(rows) + "\n"
    (tmp_path / "plain.csv").write_text(plain, encoding="utf-8")
    quoted = "\n".join(";".join(f'"{c}"' for c in line.split(";")) for line in plain.splitlines())
    (tmp_path / "quoted.csv").write_text(quoted + "\n", encoding="utf-8")
    trailing = "".join(line + ";\n" for line in plain.splitlines())
    (tmp_path / "trailing.csv").write_text(trailing, encoding="utf-8")
    expected = read_csv(tmp_path / "plain.csv")
    np.testing.assert_array_equal(expected.data, rec.data)
    for name in ("quoted.csv", "trailing.csv"):
        got = read_csv(tmp_path / name)
        assert got.names == rec.names
        np.testing.assert_array_equal(got.time, expected.time)
        np.testing.assert_array_equal(got.data, expected.data)
    unnamed = plain.replace("time;A_x;", "time;;", 1)
    _refused(tmp_path / "unnamed.csv", unnamed, r"^unnamed.csv: column 2: has no name in the header \(line 1\)")


def test_a_bench_exports_preamble_is_read_past(tmp_path):
    """Acquisition software writes lines of text before the table (date, operator, "Sample rate;2000;Hz"): they
    were "a value is not a number (line 1 was read as the header...)". The header is the first line of names
    that a row of numbers (or a row of units and then one) of its width follows; the table reads as without the
    preamble. Where no line is such a header (channels named by numbers), the first line is read as the header
    and the error says so, as before."""
    rec = _record()
    rows = [";".join(f"{v:.17g}".replace(".", ",") for v in (t, *d)) for t, d in zip(rec.time, rec.data, strict=True)]
    table = "time;" + ";".join(rec.names) + "\ns;g;g\n" + "\n".join(rows) + "\n"
    (tmp_path / "plain.csv").write_text(table, encoding="utf-8")
    preamble = "Exported 2026-11-30 10:41\nOperator;J. Doe\nSample rate;2000;Hz\nChannels;2\n\n"
    (tmp_path / "bench.csv").write_text(preamble + table, encoding="utf-8")
    expected, got = read_csv(tmp_path / "plain.csv"), read_csv(tmp_path / "bench.csv")
    assert got.channels == expected.channels and got.channels[0].unit == "g"
    np.testing.assert_array_equal(got.time, expected.time)
    np.testing.assert_array_equal(got.data, expected.data)
    commas = "Title,Hammer test\nDate,2026-11-30\nRate,2000\n" + table.replace(",", ".").replace(";", ",")
    (tmp_path / "commas.csv").write_text(commas, encoding="utf-8")
    np.testing.assert_array_equal(read_csv(tmp_path / "commas.csv").data, expected.data)
    numbered = preamble + table.replace("time;A_x;B_y", "time;1;2", 1)
    _refused(tmp_path / "numbered.csv", numbered, r"^numbered.csv:2: a value is not a number \(line 1 was read as")


def _refused(path: Path, text: str, message: str) -> None:
    """``text`` written to ``path`` is refused by read_csv with an InputError matching ``message``."""
    path.write_text(text, encoding="utf-8")
    with pytest.raises(InputError, match=message):
        read_csv(path)


def test_a_row_of_units_below_the_header_gives_the_units(tmp_path):
    """Acquisition software that writes the units in a row of their own below the names ("ms;g;m/s^2") reads as
    a header that states them ("time [ms];A_x [g];B_y [m/s^2]"); a unit it cannot read, a row of another width or
    a unit the header contradicts are named."""
    rec = _record()
    rows = "".join(
        f"{float(1e3 * t)!r},{float(d[0])!r},{float(d[1])!r}\n" for t, d in zip(rec.time, rec.data, strict=True)
    )
    (tmp_path / "stated.csv").write_text("time [ms],A_x [g],B_y [m/s^2]\n" + rows, encoding="utf-8")
    (tmp_path / "row.csv").write_text("time,A_x,B_y\nms,g,m/s^2\n" + rows, encoding="utf-8")
    stated, row = read_csv(tmp_path / "stated.csv"), read_csv(tmp_path / "row.csv")
    assert row.channels == stated.channels and row.channels[0].unit == "g"
    np.testing.assert_array_equal(row.time, stated.time)
    np.testing.assert_array_equal(row.data, stated.data)
    for units, said in (
        ("ms,furlong,g", "a row of units? 'furlong' is not one of"),
        ("ms,g", "a row of units? 2 for 3 columns"),
    ):
        _refused(
            tmp_path / "bad.csv",
            f"time,A_x,B_y\n{units}\n" + rows,
            f"^bad.csv:2: a value is not a number \\({re.escape(said)}",
        )
    both = "time,A_x [g],B_y\nms,mm/s^2,g\n" + rows
    _refused(tmp_path / "both.csv", both, r"^A_x \[g\]: the header says 'g', the units row 'mm/s\^2'")


def test_channel_metadata_with_a_point_that_is_not_finite_is_named(tmp_path):
    """NaN in some of a channel's point or direction (JSON as Python reads it) is an error naming the line, not a
    channel without geometry; NaN in all is one without geometry."""
    write_csv(_record(), tmp_path / "r.csv")
    text = (tmp_path / "r.csv").read_text(encoding="utf-8").replace("[0.3, 0.0, 0.1]", "[NaN, 0.0, 0.1]", 1)
    (tmp_path / "nan.csv").write_text(text, encoding="utf-8")
    with pytest.raises(InputError, match="^nan.csv:2: channel A_x: point and direction must be finite numbers"):
        read_csv(tmp_path / "nan.csv")
    # all NaN is a channel without a placement, as write_csv writes a force channel's
    text = text.replace("[NaN, 0.0, 0.1]", "[NaN, NaN, NaN]", 1).replace("[1.0, 0.0, 0.0]", "[NaN, NaN, NaN]", 1)
    (tmp_path / "unplaced.csv").write_text(text, encoding="utf-8")
    assert np.isnan(read_csv(tmp_path / "unplaced.csv").channels[0].point).all()


def test_missing_channel_is_named():
    with pytest.raises(InputError, match="^C_z: no such channel"):
        _record().channel("C_z")


def test_uff58_round_trip(tmp_path):
    """Double-precision ASCII dataset 58 keeps 12 significant digits (%20.11e) and every channel's metadata."""
    from mountid.measurement.uff import read_uff, write_uff

    rec = _record()
    rec = Record(rec.time, rec.data, (*rec.channels[:1], Channel("C", (0.1, -0.2, 0.3), (0.6, 0.8, 0.0))))
    write_uff(rec, tmp_path / "r.uff")
    back = read_uff(tmp_path / "r.uff")
    assert back.channels == rec.channels
    np.testing.assert_allclose(back.time, rec.time, rtol=1e-11, atol=1e-15)
    np.testing.assert_allclose(back.data, rec.data, rtol=1e-11, atol=0)


def test_a_uff58_time_axis_in_milliseconds_is_read_in_seconds(tmp_path):
    """A bench that writes its time axis in ms (abscissa label "ms"): the same record as in s (it was read as
    seconds, a record at 500 Hz one at 0.5 Hz, and the chain found no mode)."""
    import pyuff

    from mountid.measurement.uff import read_uff, write_uff

    rec = _record()
    write_uff(rec, tmp_path / "s.uff")
    sets = [
        {**s, "x": np.asarray(s["x"]) * 1e3, "abscissa_inc": s["abscissa_inc"] * 1e3, "abscissa_axis_units_lab": "ms"}
        for s in pyuff.UFF(str(tmp_path / "s.uff")).read_sets()
    ]
    pyuff.UFF(str(tmp_path / "ms.uff")).write_sets(sets, mode="add")
    back = read_uff(tmp_path / "ms.uff")
    assert back.channels == rec.channels and back.rate == pytest.approx(500.0, rel=1e-12)
    np.testing.assert_allclose(back.time, rec.time, rtol=1e-11, atol=1e-15)
    np.testing.assert_allclose(back.data, rec.data, rtol=1e-11, atol=0)


# pyuff's 58b writer leaves its file open (a ResourceWarning when the handle is collected, here: gc.collect)
@pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")
@pytest.mark.parametrize("ordinate", [4, 2])
def test_a_binary_uff58_file_reads_as_its_ascii_twin(tmp_path, ordinate):
    """Dataset 58b (binary data, as acquisition software exports long records), double (4) or single (2)
    precision: the same record as the ASCII file pyuff was given. Its data end with the "    -1" field on the
    same line, which the cut-file check read as a file cut short."""
    import pyuff

    from mountid.measurement.uff import read_uff, write_uff

    rec = _record()
    write_uff(rec, tmp_path / "ascii.uff")
    sets = [
        {**s, "binary": 1, "ordinate_spec_data_type": ordinate}
        for s in pyuff.UFF(str(tmp_path / "ascii.uff")).read_sets()
    ]
    pyuff.UFF(str(tmp_path / "binary.uff")).write_sets(sets, mode="add")
    gc.collect()
    assert b"58b" in (tmp_path / "binary.uff").read_bytes()[:100]
    back = read_uff(tmp_path / "binary.uff")
    assert back.channels == rec.channels
    np.testing.assert_allclose(back.time, rec.time, rtol=1e-11, atol=1e-15)
    np.testing.assert_allclose(back.data, rec.data, rtol=1e-11 if ordinate == 4 else 1e-7, atol=0)
    whole = (tmp_path / "binary.uff").read_bytes()
    (tmp_path / "short.uff").write_bytes(whole[: len(whole) - 40])  # cut inside the last channel's data
    with pytest.raises(InputError, match=r"^record: short.uff ends inside a dataset"):
        read_uff(tmp_path / "short.uff")


def test_a_malformed_or_cut_uff_file_is_an_error_naming_the_dataset_or_the_channel(tmp_path):
    """pyuff raises a bare Exception on a block it cannot parse (it ended in a traceback); a channel cut short by
    a transfer names the first channel's length beside its own, a channel on other sample times the first sample
    apart."""
    import pyuff

    from mountid.measurement.uff import dataset_58, read_uff, write_uff

    (tmp_path / "bad.uff").write_text("    -1\n    58\nnot a dataset\n    -1\n")
    with pytest.raises(InputError, match=r"^record: bad.uff: dataset 1 \(type 58\) is not readable \("):
        read_uff(tmp_path / "bad.uff")
    write_uff(_record(), tmp_path / "r.uff")
    text = (tmp_path / "r.uff").read_text()
    first_end = text.index("    -1", text.index("    -1") + 10)
    (tmp_path / "cut.uff").write_text(text[: first_end - 200] + text[first_end:])
    with pytest.raises(InputError, match=r"^B_y: 100 samples against 9\d of the first channel, A_x \(one record"):
        read_uff(tmp_path / "cut.uff")
    rec = _record()
    sets = [
        dataset_58(channel, rec.time + (0.5 if k else 0.0), rec.data[:, k], k + 1, 0, "")
        for k, channel in enumerate(rec.channels)
    ]
    pyuff.UFF(str(tmp_path / "late.uff")).write_sets(sets, mode="add")
    with pytest.raises(InputError, match=r"^B_y: sample \d+ at 0.5\d* s against 0 s of the first channel, A_x"):
        read_uff(tmp_path / "late.uff")
    # a file cut inside its last dataset (an interrupted copy): pyuff left that dataset, a channel, out silently
    for end in (len(text) // 4, 3 * len(text) // 4, len(text) - 8):
        (tmp_path / "short.uff").write_text(text[:end])
        with pytest.raises(InputError, match=r"^record: short.uff ends inside a dataset \(no closing -1 line\)"):
            read_uff(tmp_path / "short.uff")
    (tmp_path / "crlf.uff").write_text(text.replace("\n", "\r\n") + "\r\n\r\n")
    assert read_uff(tmp_path / "crlf.uff").names == _record().names


def test_a_uff_file_of_frequency_functions_or_empty_labels(tmp_path):
    """A bench's UFF file of spectra (function type 9, complex, abscissa in Hz) is named as such: it passed as a
    record of the real parts over a frequency axis taken for time, stopped only by a unit 'NONE' (frequency
    response functions, type 4, are read as their impulse responses: test_uff_frf). That label is what pyuff and
    other writers put in an empty field: a time response whose unit label says NONE takes the quantity's SI unit
    (it was 'unit NONE is not a unit of acceleration')."""
    import pyuff

    from mountid.measurement.uff import dataset_58, read_uff

    rec = _record()
    sets = [dataset_58(c, rec.time, rec.data[:, k], k + 1, 0, "") for k, c in enumerate(rec.channels)]
    for dataset in sets:
        dataset["ordinate_axis_units_lab"], dataset["id5"] = "NONE", "NONE"
    pyuff.UFF(str(tmp_path / "none.uff")).write_sets(sets, mode="add")
    back = read_uff(tmp_path / "none.uff")
    assert [(c.quantity, c.unit) for c in back.channels] == [("acceleration", "m/s^2")] * 2
    np.testing.assert_allclose(back.data, rec.data, rtol=1e-11)
    frequency = np.linspace(0.0, 50.0, 101)
    frf = 1.0 / (400.0 - (2 * np.pi * frequency) ** 2 + 2j * frequency)
    for kind, changes, said in (
        (9, {"ord_data_type": 6}, "is a power spectral density (UFF 58 function type 9)"),
        (0, {"ord_data_type": 6, "abscissa_spec_data_type": 18}, "its abscissa is frequency"),
        (0, {"ord_data_type": 6}, "holds complex values"),
    ):
        dataset = {**dataset_58(rec.channels[0], frequency, frf.real, 1, 1, ""), "func_type": kind, "data": frf}
        dataset.update(changes)
        dataset["abscissa_inc"] = float(frequency[1])
        (tmp_path / "frf.uff").unlink(missing_ok=True)
        pyuff.UFF(str(tmp_path / "frf.uff")).write_sets([dataset], mode="add")
        with pytest.raises(InputError, match=f"^A_x: {re.escape(said)}"):
            read_uff(tmp_path / "frf.uff")
    dataset = {**dataset_58(rec.channels[0], frequency, frf.real, 1, 1, ""), "func_type": 4, "data": frf}
    dataset.update({"ord_data_type": 6, "abscissa_spec_data_type": 18, "abscissa_inc": float(frequency[1])})
    (tmp_path / "frf.uff").unlink()
    pyuff.UFF(str(tmp_path / "frf.uff")).write_sets([dataset], mode="add")
    assert read_uff(tmp_path / "frf.uff").impulse


def test_a_uff_channel_mountid_does_not_read_is_named_and_left_out_when_told(tmp_path):
    """A bench's UFF export with a pressure (ordinate type 15) or a tachometer's speed (19) beside the
    accelerations: it read as an acceleration ("unit 'Pa' is not a unit of acceleration"), a reaction force (9) at
    an isolator would have been a response; now the channel is named by what it is, with how to leave it out, and
    ``ignore`` leaves it out. A general channel (0, 1) takes the quantity of its unit (a hammer's force in N); an
    ID line 5 of another tool ("Pressure [Pa]") is not read as mountid's quantity label."""
    import pyuff

    from mountid.measurement.uff import dataset_58, read_uff, write_uff

    rec = _record()
    write_uff(rec, tmp_path / "plain.uff")
    for kind, unit, said in ((15, "Pa", "a pressure (UFF 58 ordinate type 15)"), (19, "rpm", "a rotational speed")):
        extra = dataset_58(Channel("Mic"), rec.time, rec.data[:, 0], 3, 0, "", id5=f"Pressure [{unit}]")
        extra.update(ordinate_spec_data_type=kind, ordinate_axis_units_lab=unit)
        (tmp_path / "bench.uff").unlink(missing_ok=True)
        sets = [dataset_58(c, rec.time, rec.data[:, k], k + 1, 0, "", id5="NONE") for k, c in enumerate(rec.channels)]
        pyuff.UFF(str(tmp_path / "bench.uff")).write_sets([*sets, extra], mode="add")
        with pytest.raises(InputError, match=f"^Mic: is {re.escape(said)}.*left out by its name: --ignore Mic,"):
            read_uff(tmp_path / "bench.uff")
        back = read_uff(tmp_path / "bench.uff", ignore=("Mic",))
        assert back.names == rec.names
        np.testing.assert_allclose(back.data, rec.data, rtol=1e-11)
    with pytest.raises(InputError, match=r"^ignore: Tacho: no such channel in bench.uff \(channels: A_x, B_y, Mic\)"):
        read_uff(tmp_path / "bench.uff", ignore=("Tacho",))
    with pytest.raises(InputError, match="^ignore: leaves no channel of plain.uff"):
        read_uff(tmp_path / "plain.uff", ignore=("A_x", "B_y"))
    general = dataset_58(Channel("F"), rec.time, rec.data[:, 0], 3, 0, "", id5="NONE")
    general.update(ordinate_spec_data_type=1, ordinate_axis_units_lab="kN")
    (tmp_path / "force.uff").unlink(missing_ok=True)
    pyuff.UFF(str(tmp_path / "force.uff")).write_sets([general], mode="add")
    assert [(c.quantity, c.unit) for c in read_uff(tmp_path / "force.uff").channels] == [("force", "kN")]


def test_a_uff_file_of_several_runs_is_read_one_run_at_a_time(tmp_path):
    """Two hits exported one after another, a dataset per channel each (the same response nodes and directions, a
    bench's one description in every ID line 1): read at once they were one record of four channels named
    node1:1#1 ... node2:2#2, a pair at each point with the data of different hits. Each run reads on its own, by
    its number, or all of them (read_runs); without one read_uff names the runs; a CSV holds one run."""
    import pyuff

    from mountid.measurement.records import read_record, read_runs
    from mountid.measurement.uff import dataset_58, read_uff

    rec = _record()
    second = Record(rec.time, rec.data[::-1].copy(), rec.channels)
    sets = [
        dataset_58(c, r.time, r.data[:, k], k + 1, k + 1, "", title="Time Response", id5="NONE")
        for r in (rec, second)
        for k, c in enumerate(rec.channels)
    ]
    pyuff.UFF(str(tmp_path / "runs.uff")).write_sets(sets, mode="add")
    with pytest.raises(
        InputError, match=r"^run: runs.uff holds 2 runs \(datasets 58 of 2, 2 channels, a run beginning where a"
    ):
        read_uff(tmp_path / "runs.uff")
    for run, expected in ((1, rec), (2, second)):
        got = read_uff(tmp_path / "runs.uff", run=run)
        assert got.names == ("node1:1", "node2:2")
        np.testing.assert_allclose(got.data, expected.data, rtol=1e-11)
    with pytest.raises(
        InputError, match=r"^run: 3: runs.uff holds 2 runs \(datasets 58 of 2, 2 channels\), runs 1 to 2"
    ):
        read_uff(tmp_path / "runs.uff", run=3)
    every = read_runs(tmp_path / "runs.uff", rate=None)
    assert len(every) == 2
    for got, expected in zip(every, (rec, second), strict=True):
        assert got.names == ("node1:1", "node2:2")
        np.testing.assert_allclose(got.data, expected.data, rtol=1e-11)
    # exported channel by channel (node 1's hits, then node 2's): the k-th dataset of each is run k
    pyuff.UFF(str(tmp_path / "by_channel.uff")).write_sets([sets[0], sets[2], sets[1], sets[3]], mode="add")
    for got, expected in zip(read_runs(tmp_path / "by_channel.uff"), (rec, second), strict=True):
        assert got.names == ("node1:1", "node2:2")
        np.testing.assert_allclose(got.data, expected.data, rtol=1e-11)
    with pytest.raises(InputError, match=r"^ignore: run 1: node9:1: no such channel in runs.uff"):
        read_runs(tmp_path / "runs.uff", ignore=("node9:1",))
    write_csv(rec, tmp_path / "r.csv")
    assert read_record(tmp_path / "r.csv", run=1).names == rec.names
    assert [r.names for r in read_runs(tmp_path / "r.csv")] == [rec.names]
    with pytest.raises(InputError, match=r"^run: 2: r.csv is a CSV of one table, which holds one run"):
        read_record(tmp_path / "r.csv", run=2)


def test_a_bench_csv_column_mountid_does_not_read_is_named_and_left_out_when_told(tmp_path, monkeypatch):
    """A bench's CSV export (preamble, semicolons, decimal commas) with a tachometer in V, a microphone in Pa and a
    status column of text beside the accelerations: the text was "a value is not a number (line 1 was read as the
    header ...)" since no row of numbers followed the header; now the column and its cell are named with how to
    leave it out, a unit mountid does not read likewise, and ``ignore`` reads the file as without those columns
    (both readers; a units row with their units too)."""
    from mountid.measurement import records

    rec = _record()

    def table(extra: bool, units: bool = False) -> str:
        head = ["Time [s]", "A_x [g]", "B_y [g]"] + (["Tacho [V]", "Mic [Pa]", "Status"] if extra else [])
        if units:
            head = [h.split(" [")[0] for h in head]
        rows = [
            ";".join([repr(float(t)), *map(repr, map(float, d))] + (["5.0", "-0.25", "OK"] if extra else []))
            for t, d in zip(rec.time, rec.data, strict=True)
        ]
        row = ["s", "g", "g", "V", "Pa", ""] if units else []
        lines = ["Exported by BenchSoft 4.2", "Sample rate;500;Hz", "", ";".join(head)]
        return "\n".join([*lines, *([";".join(row)] if units else []), *(r.replace(".", ",") for r in rows)]) + "\n"

    (tmp_path / "plain.csv").write_text(table(False), encoding="utf-8")
    expected = read_csv(tmp_path / "plain.csv")
    (tmp_path / "bench.csv").write_text(table(True), encoding="utf-8")
    advice = "left out by its name: --ignore "
    with pytest.raises(
        InputError, match=f"^bench.csv:5: a value is not a number: column 6 \\('Status'\\) holds 'OK'.*{advice}Status,"
    ):
        read_csv(tmp_path / "bench.csv")
    with pytest.raises(
        InputError, match=f"^bench.csv: column 5: 'Mic \\[Pa\\]': unit 'Pa' is not one of .*{advice}Mic,"
    ):
        read_csv(tmp_path / "bench.csv", ignore=("Status",))
    raw = read_csv(tmp_path / "bench.csv", ignore=("Status", "Mic"))  # a voltage is read as recorded
    with pytest.raises(
        InputError, match=f"^Tacho: is a raw voltage in V: give its sensor's sensitivity.*{advice}Tacho,"
    ):
        raw.in_si()  # where the records chain starts
    with pytest.raises(InputError, match=r"^ignore: Rpm: no such column in bench.csv \(columns: Time, A_x, B_y, Tacho"):
        read_csv(tmp_path / "bench.csv", ignore=("Rpm",))
    (tmp_path / "units.csv").write_text(table(True, units=True), encoding="utf-8")
    for name in ("bench.csv", "units.csv"):
        for fast in (True, False):
            if not fast:  # the line-by-line reader, as for a file numpy's reader declines
                monkeypatch.setattr(records, "_at_once", lambda *args: None)
            got = read_csv(tmp_path / name, ignore=("Tacho", "Mic", "Status"))
            monkeypatch.undo()
            assert got.channels == expected.channels
            np.testing.assert_array_equal(got.time, expected.time)
            np.testing.assert_array_equal(got.data, expected.data)


_CELL_TEXT = st.text(st.characters(codec="utf-8", exclude_characters=',;\t"\r\n\x0b\x0c\x1c\x1d\x1e\x85\u2028\u2029'))


@settings(max_examples=40, deadline=None)
@given(
    st.integers(1, 4),
    st.lists(st.tuples(st.integers(0, 5), st.sampled_from(["text", "number", "empty"])), max_size=4),
    st.sampled_from([",", ";", "\t"]),
    st.data(),
)
def test_csv_columns_left_unread_leave_the_record_of_the_others(tmp_path_factory, channels, extra, separator, data):
    """Columns of any content (text, numbers in any unit, empty cells) put anywhere after the time column and
    named in ``ignore`` leave the record the file without them holds, to the bit, on both readers."""
    folder = tmp_path_factory.mktemp("ignored")
    n = 20
    time = np.arange(n) / 100.0
    values = np.round(np.sin(np.arange(n * channels).reshape(n, channels) * 0.7), 6)
    names = [f"A{k}" for k in range(channels)]

    def cell(v: float) -> str:
        return repr(float(v)).replace(".", ",") if separator != "," else repr(float(v))

    plain = [["time", *names]] + [[cell(t), *map(cell, row)] for t, row in zip(time, values, strict=True)]
    table = [list(row) for row in plain]
    ignored = []
    for k, (where, kind) in enumerate(extra):
        column = 1 + min(where, len(table[0]) - 1)
        ignored.append(f"X{k}")
        cells = {
            "text": [data.draw(_CELL_TEXT) for _ in range(n)],
            "number": [cell(v) for v in np.arange(n) * 1.5],
            "empty": [""] * n,
        }[kind]
        for row, value in zip(table, [f"X{k} [V]", *cells], strict=True):
            row.insert(column, value)
    (folder / "plain.csv").write_text("\n".join(separator.join(r) for r in plain) + "\n", encoding="utf-8")
    (folder / "extra.csv").write_text("\n".join(separator.join(r) for r in table) + "\n", encoding="utf-8")
    expected = read_csv(folder / "plain.csv")
    got = read_csv(folder / "extra.csv", ignore=ignored)
    assert got.channels == expected.channels
    np.testing.assert_array_equal(got.time, expected.time)
    np.testing.assert_array_equal(got.data, expected.data)


def _bench_uff(
    path,
    record: Record,
    nodes: dict[int, tuple[float, float, float]],
    dofs: list[tuple[int, int]],
    title=None,
    systems: dict[int, tuple[int, np.ndarray]] | None = None,
    cs: dict[int, tuple[int, int]] | None = None,
    legacy: dict[int, tuple[int, int, np.ndarray]] | None = None,
) -> None:
    """A file as test-bench software writes it: units (dataset 164, mm), geometry (2411, in mm), and one
    dataset 58 per channel naming its response node and direction (+-1, 2, 3), without mountid's ID-line-4.
    ``systems``: coordinate systems (label: (type, 4 x 3 transformation, origin in mm)) written as a dataset
    2420; ``legacy``: coordinate systems (label: (type, reference system, rows: origin, a point on +x and one in
    the +xz plane in the reference system, mm)) written as a dataset 18; ``cs``: each node's (definition,
    displacement) system (default 1, 1)."""
    import pyuff

    from mountid.measurement.uff import dataset_58

    uff = pyuff.UFF(str(path))
    cs = cs or {}
    sets = [
        pyuff.prepare_164(
            units_code=5,
            units_description="mm (milli newton)",
            temp_mode=1,
            length=1000.0,
            force=1000.0,
            temp=1.0,
            temp_offset=273.15,
        ),
        pyuff.prepare_2411(
            node_nums=np.array(list(nodes)),
            def_cs=np.array([cs.get(n, (1, 1))[0] for n in nodes], dtype=int),
            disp_cs=np.array([cs.get(n, (1, 1))[1] for n in nodes], dtype=int),
            color=np.ones(len(nodes), dtype=int),
            x=np.array([1e3 * p[0] for p in nodes.values()]),
            y=np.array([1e3 * p[1] for p in nodes.values()]),
            z=np.array([1e3 * p[2] for p in nodes.values()]),
        ),
    ]
    if systems:
        sets.append(
            pyuff.prepare_2420(
                Part_UID=1,
                Part_Name="bench",
                CS_sys_labels=list(systems),
                CS_types=[kind for kind, _ in systems.values()],
                CS_colors=[8] * len(systems),
                CS_names=[f"CS{label}" for label in systems],
                CS_matrices=[matrix for _, matrix in systems.values()],
            )
        )
    if legacy:
        sets.append(
            pyuff.prepare_18(
                cs_num=list(legacy),
                cs_type=[kind for kind, _, _ in legacy.values()],
                ref_cs_num=[ref for _, ref, _ in legacy.values()],
                color=[8] * len(legacy),
                method=[1] * len(legacy),
                cs_name=[f"CS{label}" for label in legacy],
                ref_o=[points[0] for _, _, points in legacy.values()],
                x_point=[points[1] for _, _, points in legacy.values()],
                xz_point=[points[2] for _, _, points in legacy.values()],
            )
        )
    for k, (node, axis) in enumerate(dofs):
        name = title or f"Point{node}:{'+-'[axis < 0]}{'XYZ'[abs(axis) - 1]}"
        sets.append(dataset_58(record.channels[k], record.time, record.data[:, k], node, axis, "NONE", "NONE", name))
    uff.write_sets(sets, mode="add")


def test_a_bench_files_geometry_places_its_channels(tmp_path):
    """A UFF file with geometry (2411 in mm) and node/direction references instead of mountid's metadata: each
    channel sits at its node [m] along its axis, and the records chain gets mode shapes from it."""
    from mountid.identification.from_records import modal_data
    from mountid.measurement.rig import Hammer, Rig, Sensor
    from mountid.measurement.uff import read_uff

    nodes = {11: (0.4, 0.3, 0.25), 12: (-0.4, -0.3, 0.25), 13: (0.4, -0.3, 0.25)}
    dofs = [(11, 1), (11, 2), (11, 3), (12, 1), (12, -2), (12, 3), (13, 3)]
    axes = {1: (1.0, 0.0, 0.0), 2: (0.0, 1.0, 0.0), 3: (0.0, 0.0, 1.0)}
    sensors = [
        Sensor(f"s{k}", nodes[n], tuple(np.sign(a) * v for v in axes[abs(a)]), noise=0.01)
        for k, (n, a) in enumerate(dofs)
    ]
    rig = Rig.of("kid300")
    record = rig.simulate(sensors, 8.0, 500.0, hammers=[Hammer((0.4, 0.3, 0.3), (1, 0.7, -0.6))], seed=2)
    _bench_uff(tmp_path / "bench.uff", record, nodes, dofs)
    back = read_uff(tmp_path / "bench.uff")
    assert [c.name for c in back.channels][:2] == ["Point11:+X", "Point11:+Y"] and back.channels[4].name == "Point12:-Y"
    for got, sensor in zip(back.channels, sensors, strict=True):
        np.testing.assert_allclose(got.point, sensor.point, rtol=1e-12, atol=1e-15)
        assert got.direction == tuple(float(v) + 0.0 for v in sensor.direction)
    found = modal_data(rig.machine, back, {}, 0.07).modes
    assert {"x", "z", "psi", "phi"} <= set(found) and all(m.shape is not None for m in found.values())
    # one description in every dataset's ID line 1: named by node and direction instead
    _bench_uff(tmp_path / "same.uff", record, nodes, [*dofs[:-1], (12, 3)], title="Time Response")
    names = [c.name for c in read_uff(tmp_path / "same.uff").channels]
    assert (
        names[:2] == ["node11:1", "node11:2"] and names[4] == "node12:-2" and names[-2:] == ["node12:3#1", "node12:3#2"]
    )


def _sloping_bench():
    """A bench with local coordinate systems: system 5 turned by 90 degrees about z and shifted (origin in mm),
    system 6 tilted (rows: the local axes in global coordinates); nodes 11 and 12 defined in system 5, node 12
    measuring along system 6's axes, node 13 global. Returns (turned, tilted, origin [mm], the nodes' coordinates
    in their definition systems [m], each node's (definition, displacement) system, the channels' (node, axis),
    the sensors at their global points along their global directions)."""
    from scipy.spatial.transform import Rotation

    from mountid.measurement.rig import Sensor

    turned = Rotation.from_euler("z", 90, degrees=True).as_matrix().T  # rows: the local axes in global
    tilted = Rotation.from_euler("xz", [30, -20], degrees=True).as_matrix().T
    origin = np.array([100.0, -50.0, 20.0])  # mm
    world = {11: np.array([0.4, 0.3, 0.25]), 12: np.array([-0.4, -0.3, 0.25]), 13: np.array([0.4, -0.3, 0.25])}
    local = {n: (1e3 * p - origin) @ turned.T / 1e3 for n, p in world.items()}  # the coordinates in system 5
    cs = {11: (5, 1), 12: (5, 6), 13: (1, 1)}
    dofs = [(11, 1), (11, 2), (11, 3), (12, 1), (12, -2), (12, 3), (13, 3)]
    rows = {11: np.eye(3), 12: tilted, 13: np.eye(3)}
    sensors = [
        Sensor(f"s{k}", tuple(world[n]), tuple(np.sign(a) * rows[n][abs(a) - 1]), noise=0.01)
        for k, (n, a) in enumerate(dofs)
    ]
    nodes = {n: tuple(local[n]) if cs[n][0] == 5 else tuple(world[n]) for n in world}
    return turned, tilted, origin, nodes, cs, dofs, sensors


def test_a_bench_files_local_coordinate_systems_are_applied(tmp_path):
    """Nodes defined in a rotated, shifted coordinate system and a triaxial sensor measuring along tilted axes
    (dataset 2420, as bench software writes a sensor mounted on a sloping face): each channel sits at its global
    point along its global direction (they were read as if in the global system: silently wrong shapes). An
    undefined system and a cylindrical one are named."""
    from mountid.identification.from_records import modal_data
    from mountid.measurement.rig import Hammer, Rig
    from mountid.measurement.uff import read_uff

    turned, tilted, origin, nodes, cs, dofs, sensors = _sloping_bench()
    systems = {5: (0, np.vstack([turned, origin])), 6: (0, np.vstack([tilted, np.zeros(3)]))}
    rig = Rig.of("kid300")
    record = rig.simulate(sensors, 8.0, 500.0, hammers=[Hammer((0.4, 0.3, 0.3), (1, 0.7, -0.6))], seed=2)
    _bench_uff(tmp_path / "bench.uff", record, nodes, dofs, systems=systems, cs=cs)
    back = read_uff(tmp_path / "bench.uff")
    for got, sensor in zip(back.channels, sensors, strict=True):
        np.testing.assert_allclose(got.point, sensor.point, rtol=0, atol=1e-12)
        np.testing.assert_allclose(got.direction, sensor.direction, rtol=0, atol=1e-12)
    found = modal_data(rig.machine, back, {}, 0.07).modes
    truth = rig.machine.frequencies({"c_xy": 74.4e3, "c_z": 472.3e3})
    assert {"x", "z", "psi", "phi"} <= set(found) and all(m.shape is not None for m in found.values())
    assert all(abs(m.frequency - truth[label]) < 1e-2 * truth[label] for label, m in found.items())
    _bench_uff(tmp_path / "undefined.uff", record, nodes, dofs, systems=systems, cs={**cs, 13: (1, 7)})
    with pytest.raises(InputError, match=r"^record: node 13: its displacement coordinate system 7 is not defined"):
        read_uff(tmp_path / "undefined.uff")
    systems[5] = (1, systems[5][1])
    _bench_uff(tmp_path / "cylindrical.uff", record, nodes, dofs, systems=systems, cs=cs)
    with pytest.raises(InputError, match=r"^record: node 11: its definition coordinate system 5 is cylindrical"):
        read_uff(tmp_path / "cylindrical.uff")


def test_a_bench_files_legacy_coordinate_systems_are_applied(tmp_path):
    """The same bench as above with its systems in the older dataset 18 (origin, a point on +x and one in the +xz
    plane, in a reference system): the tilted system is given in the turned one, so the chain is followed. Dataset
    18 writes six significant digits: points and directions to 2e-5. A loop of references, an undefined one, points
    that define no axes and a system that datasets 2420 and 18 define differently are named."""
    from mountid.measurement.rig import Hammer, Rig
    from mountid.measurement.uff import read_uff

    turned, tilted, origin, nodes, cs, dofs, sensors = _sloping_bench()
    in_turned = tilted @ turned.T  # system 6's axes in system 5's coordinates
    zero_in_turned = (np.zeros(3) - origin) @ turned.T  # system 6's origin (the global one) in system 5's
    legacy = {
        5: (0, 0, np.array([origin, origin + 1e3 * turned[0], origin + 1e3 * turned[2]])),
        6: (0, 5, np.array([zero_in_turned, zero_in_turned + 1e3 * in_turned[0], zero_in_turned + 1e3 * in_turned[2]])),
    }
    record = Rig.of("kid300").simulate(sensors, 2.0, 200.0, hammers=[Hammer((0.4, 0.3, 0.3), (1, 0.7, -0.6))], seed=2)
    _bench_uff(tmp_path / "bench.uff", record, nodes, dofs, cs=cs, legacy=legacy)
    back = read_uff(tmp_path / "bench.uff")
    for got, sensor in zip(back.channels, sensors, strict=True):
        np.testing.assert_allclose(got.point, sensor.point, rtol=0, atol=2e-5)
        np.testing.assert_allclose(got.direction, sensor.direction, rtol=0, atol=2e-5)
    # the same system in both datasets: read where they agree, named where they do not
    both = {5: (0, np.vstack([turned, origin]))}
    _bench_uff(tmp_path / "both.uff", record, nodes, dofs, systems=both, cs=cs, legacy=legacy)
    for got, sensor in zip(read_uff(tmp_path / "both.uff").channels, sensors, strict=True):
        np.testing.assert_allclose(got.point, sensor.point, rtol=0, atol=2e-5)
    both = {5: (0, np.vstack([tilted, origin]))}
    _bench_uff(tmp_path / "differ.uff", record, nodes, dofs, systems=both, cs=cs, legacy=legacy)
    with pytest.raises(InputError, match=r"^record: coordinate system 5: datasets 2420 and 18 define it differently"):
        read_uff(tmp_path / "differ.uff")
    prefix = r"coordinate system (?:5|6) \(dataset 18\): its"
    cases = {
        "loop": ({**legacy, 5: (0, 6, legacy[5][2])}, "reference systems form a loop"),
        "undefined": ({**legacy, 6: (0, 9, legacy[6][2])}, "reference system 9 is not defined"),
        "flat": ({**legacy, 5: (0, 0, legacy[5][2][[0, 1, 1]])}, "points define no axes"),
    }
    for name, (systems, message) in cases.items():
        _bench_uff(tmp_path / f"{name}.uff", record, nodes, dofs, cs=cs, legacy=systems)
        with pytest.raises(InputError, match=f"^record: {prefix} {message}"):
            read_uff(tmp_path / f"{name}.uff")


@settings(max_examples=budget(30), deadline=None)
@given(
    n=st.integers(16, 200),
    rate=st.floats(10.0, 1e5),
    values=st.lists(st.floats(-1e6, 1e6, allow_nan=False, allow_subnormal=False), min_size=1, max_size=3),
    point=st.tuples(*[st.floats(-10, 10, allow_nan=False, allow_subnormal=False)] * 3),
)
def test_csv_round_trip_any_record(tmp_path_factory, n, rate, values, point):
    """Any record (sizes, rates, values, metadata) reads back exactly from CSV."""
    t = np.arange(n) / rate
    data = np.outer(np.sin(np.arange(n)), values) + np.array(values)
    channels = tuple(Channel(f"c{i}", point, (0.0, 0.0, 1.0)) for i in range(len(values)))
    rec = Record(t, data, channels)
    path = tmp_path_factory.mktemp("rt") / "r.csv"
    write_csv(rec, path)
    back = read_csv(path)
    assert back.channels == rec.channels
    np.testing.assert_array_equal(back.data, rec.data)
    np.testing.assert_array_equal(back.time, rec.time)


@pytest.mark.parametrize("separator", [",", ";", "\t"])
def test_a_bench_export_reads_with_its_units_and_separator(tmp_path, separator):
    """Units in the header set each channel's quantity; time in ms; semicolon-separated files with decimal
    commas; a unit mountid does not know is named with its column."""
    rec = _record()

    def cell(v: float) -> str:
        return repr(float(v)).replace(".", ",") if separator == ";" else repr(float(v))

    head = separator.join(["Time [ms]", "A_x [g]", "B_y (mm/s)"])
    lines = [separator.join(cell(v) for v in (1e3 * t, *row)) for t, row in zip(rec.time, rec.data, strict=True)]
    (tmp_path / "bench.csv").write_text("\n".join([head, *lines]) + "\n", encoding="utf-8")
    back = read_csv(tmp_path / "bench.csv")
    assert [(c.name, c.quantity, c.unit) for c in back.channels] == [
        ("A_x", "acceleration", "g"),
        ("B_y", "velocity", "mm/s"),
    ]
    np.testing.assert_allclose(back.time, rec.time, rtol=1e-12, atol=1e-15)
    np.testing.assert_array_equal(back.data, rec.data)
    (tmp_path / "odd.csv").write_text(head.replace("(mm/s)", "[ft/min]") + "\n" + lines[0] + "\n", encoding="utf-8")
    with pytest.raises(InputError, match=r"^odd.csv: column 3: 'B_y \[ft/min\]': unit 'ft/min' is not one of"):
        read_csv(tmp_path / "odd.csv")
    (tmp_path / "min.csv").write_text(head.replace("[ms]", "[min]") + "\n" + lines[0] + "\n", encoding="utf-8")
    with pytest.raises(InputError, match="time in 'min'"):
        read_csv(tmp_path / "min.csv")
    # parentheses that hold no unit are part of the name; m/s\u00b2 as written with a superscript
    names = head.replace("A_x [g]", "Ch(1)").replace("(mm/s)", "[m/s\u00b2]")
    (tmp_path / "names.csv").write_text("\n".join([names, *lines]) + "\n", encoding="utf-8")
    assert [(c.name, c.unit) for c in read_csv(tmp_path / "names.csv").channels] == [
        ("Ch(1)", "m/s^2"),
        ("B_y", "m/s\u00b2"),
    ]


def _stamped(rec: Record, cell, separator: str = ",", head: str = "Time") -> str:
    """``rec`` as a plain CSV whose time column holds ``cell(t)`` for each time t [s] of the record."""
    rows = [
        separator.join([cell(t), *(repr(float(v)) for v in row)]) for t, row in zip(rec.time, rec.data, strict=True)
    ]
    if separator != ",":
        rows = [
            separator.join([r.split(separator)[0], *(v.replace(".", ",") for v in r.split(separator)[1:])])
            for r in rows
        ]
    return separator.join([head, *rec.names]) + "\n" + "\n".join(rows) + "\n"


def test_a_time_column_of_dates_and_clock_times_reads_as_seconds_from_the_first(tmp_path):
    """A logger's export stamps each row with its date and time (ISO 8601, with a T or a space, a Z for UTC) or its
    clock time (a decimal comma in a German locale, behind a preamble): read as seconds from the first row (it was
    "a value is not a number (line 1 was read as the header ...)"). A later cell of another form is named by its
    line; a time of a form mountid does not read is named with how to read the file at its rate without it."""
    from datetime import datetime, timedelta

    rec = _record(400)
    start = datetime(2026, 12, 3, 23, 59, 59)

    def at(t: float, form: str) -> str:
        return (start + timedelta(seconds=float(t))).strftime(form)

    files = {
        "iso.csv": _stamped(rec, lambda t: at(t, "%Y-%m-%dT%H:%M:%S.%fZ")),
        "space.csv": _stamped(rec, lambda t: at(t, "%Y-%m-%d %H:%M:%S.%f")[:-3]),
        "clock.csv": "Logger 7;serial 0042\nRate;500;Hz\n\n"
        + _stamped(rec, lambda t: at(t - 1, "%H:%M:%S,%f")[:-2], ";", "Zeit"),
    }
    for name, text in files.items():
        (tmp_path / name).write_text(text, encoding="utf-8")
        got = read_csv(tmp_path / name)
        assert got.names == rec.names, name
        np.testing.assert_allclose(got.time, rec.time, rtol=0, atol=1e-12)
        np.testing.assert_array_equal(got.data, rec.data)
    lines = files["space.csv"].splitlines()
    lines[7] = "2026-12-03 late" + lines[7][lines[7].index(",") :]
    _refused(tmp_path / "late.csv", "\n".join(lines), r"^late.csv:8: column 1 holds '2026-12-03 late', not a time as")
    slashes = _stamped(rec, lambda t: at(t, "%Y/%m/%d %H:%M:%S.%f"))
    _refused(
        tmp_path / "slash.csv", slashes, r"^slash.csv:2: column 1 \('Time'\) holds '2026/12/03 23:59:59.000000', a time"
    )
    got = read_csv(tmp_path / "slash.csv", 500.0, ignore=("Time",))
    np.testing.assert_array_equal(got.data, rec.data)
    np.testing.assert_allclose(got.time, rec.time, rtol=0, atol=1e-15)


def test_times_written_coarser_than_their_step_or_counted_samples_are_named_and_read_at_the_rate(tmp_path):
    """Clock times to the millisecond at 2 kHz repeat every other time; a first column "Sample" counts samples.
    The first was "'Time' is read as the time, but 50% of its steps increase" (a channel in the time column's
    place), the second read as seconds (a record at 1 Hz, "no damped mode found"); each is named with the sampling
    rate as the way to read it, and reads with the rate (the count over the rate from the first count)."""
    rec = _record(400)
    rec = Record(np.arange(400) / 2000.0, rec.data, rec.channels)
    coarse = _stamped(rec, lambda t: f"10:00:{t:06.3f}")
    _refused(
        tmp_path / "coarse.csv",
        coarse,
        r"^time: repeats its times in \d+ of 399 steps: written to 0.001 s, coarser than its step of 0.0005\d* s; give",
    )
    got = read_csv(tmp_path / "coarse.csv", 2000.0)
    np.testing.assert_allclose(got.time, rec.time, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(got.data, rec.data)
    for first in (0, 1):
        counted = _stamped(rec, lambda t, first=first: str(round(t * 2000) + first), head="Sample")
        _refused(tmp_path / "n.csv", counted, r"^n.csv: column 1: 'Sample' counts the samples, not the time: give the")
        got = read_csv(tmp_path / "n.csv", 2000.0)
        assert got.names == rec.names
        np.testing.assert_allclose(got.time, rec.time + first / 2000.0, rtol=0, atol=1e-15)
        np.testing.assert_array_equal(got.data, rec.data)
    # a count skipped is a dropped sample; a first column so named that counts nothing is a channel
    lines = _stamped(rec, lambda t: str(round(t * 2000)), head="Sample").splitlines()
    (tmp_path / "skip.csv").write_text("\n".join(lines[:11] + lines[12:]) + "\n", encoding="utf-8")
    with pytest.raises(InputError, match=r"^time: a dropped sample at t = 0.0045 s"):
        read_csv(tmp_path / "skip.csv", 2000.0)
    force = "n," + ",".join(rec.names) + "\n" + "".join(f"{v!r},{v!r},{v!r}\n" for v in rec.data[:, 0].tolist())
    (tmp_path / "force.csv").write_text(force, encoding="utf-8")
    assert read_csv(tmp_path / "force.csv", 2000.0).names == ("n", *rec.names)


def test_the_units_of_an_american_bench_read_as_their_si_values(tmp_path):
    """in/s^2, in/s (ips), mil, in and lbf, as American benches and vibration monitors write them (they were
    unknown units): converted by the inch's and the pound-force's definitions (25.4 mm; 0.45359237 kg under
    9.80665 m/s^2, 4.4482216152605 N)."""
    rec = _record()
    titles = ["a [in/s^2]", "v [ips]", "w (in/s)", "d [mil]", "e [in]", "F [lbf]"]
    rows = "".join(
        f"{t!r}" + f",{d[0]!r}" * len(titles) + "\n" for t, d in zip(rec.time.tolist(), rec.data.tolist(), strict=True)
    )
    (tmp_path / "us.csv").write_text("time," + ",".join(titles) + "\n" + rows, encoding="utf-8")
    got = read_csv(tmp_path / "us.csv")
    assert [c.quantity for c in got.channels] == [
        "acceleration", "velocity", "velocity", "displacement", "displacement", "force"
    ]  # fmt: skip
    factors = [0.0254, 0.0254, 0.0254, 2.54e-5, 0.0254, 4.4482216152605]
    np.testing.assert_allclose(got.in_si().data, rec.data[:, :1] * np.array(factors), rtol=1e-15, atol=0)


def test_micrometres_read_with_the_micro_sign_as_with_u(tmp_path):
    """Bench exports write a displacement in micrometres with the micro sign or the Greek mu (it was "unit 'µm'
    is not one of ..."); both read as um, converted to m alike."""
    rec = _record()
    rows = "".join(
        f"{t!r},{d[0]!r},{d[0]!r},{d[0]!r}\n" for t, d in zip(rec.time.tolist(), rec.data.tolist(), strict=True)
    )
    (tmp_path / "d.csv").write_text("time,d [um],e [\u00b5m],f [\u03bcm]\n" + rows, encoding="utf-8")
    got = read_csv(tmp_path / "d.csv")
    assert [c.quantity for c in got.channels] == ["displacement"] * 3
    si = got.in_si().data
    np.testing.assert_array_equal(si[:, 1], si[:, 0])
    np.testing.assert_array_equal(si[:, 2], si[:, 0])
    np.testing.assert_allclose(si[:, 0], 1e-6 * rec.data[:, 0], rtol=1e-15)


def test_a_tab_separated_export_with_decimal_commas_reads(tmp_path):
    """A tab-separated export in a German locale writes decimal commas ("0,5\t1,25"): it was "a value is not a
    number"; it reads as the same table with decimal points."""
    rec = _record()
    for name, mark in (("points.txt", "."), ("commas.txt", ",")):
        rows = [
            "\t".join(f"{v!r}".replace(".", mark) for v in (t, *d))
            for t, d in zip(rec.time.tolist(), rec.data.tolist(), strict=True)
        ]
        (tmp_path / name).write_text("time\tA_x\tB_y\n" + "\n".join(rows) + "\n", encoding="utf-8")
    points, commas = read_csv(tmp_path / "points.txt"), read_csv(tmp_path / "commas.txt")
    np.testing.assert_array_equal(commas.data, points.data)
    np.testing.assert_array_equal(commas.time, points.time)
    np.testing.assert_array_equal(points.data, rec.data)


@settings(max_examples=50, deadline=None)
@given(
    st.lists(
        st.lists(
            st.one_of(
                st.floats(allow_nan=True, allow_infinity=True).map(repr),
                st.integers(-(10**20), 10**20).map(str),
                st.sampled_from(["+2", "-0", " 1.5", "1.5 ", "1e5", "1E-5", ".5", "5.", "nan", "-inf", "Infinity"]),
            ),
            min_size=3,
            max_size=3,
        ),
        min_size=1,
        max_size=20,
    ),
    st.sampled_from([",", ";", "\t"]),
)
def test_a_table_read_at_once_is_the_table_read_line_by_line(rows, separator):
    """numpy's reader (long records, five times faster) gives the numbers the line-by-line reader gives, to the bit,
    or leaves the table to it."""
    from mountid.measurement.records import _at_once, _line_by_line

    def cell(text: str) -> str:
        return text.replace(".", ",") if separator != "," else text

    body = [(k + 2, separator.join(cell(c) for c in row)) for k, row in enumerate(rows)]
    fast = _at_once(body, separator, 3)
    slow = _line_by_line(body, separator, ["t", "a", "b"], 1, "x.csv")
    if fast is not None:
        np.testing.assert_array_equal(fast, slow)
        assert np.array_equal(np.signbit(fast), np.signbit(slow))


@pytest.mark.parametrize("separator", [",", ";", "\t"])
def test_a_plain_table_is_read_at_once(separator):
    """The fast path is taken on a plain table (with nan, inf, a sign and decimal commas where the separator is not a
    comma), so the round trip above cannot pass by leaving every table to the line-by-line reader."""
    from mountid.measurement.records import _at_once, _line_by_line

    rows = [["0.0", "+2", "-0"], ["0.5", "nan", "-inf"], ["1.0", "1e5", "1.5"]]
    if separator != ",":
        rows = [[c.replace(".", ",") for c in row] for row in rows]
    body = [(k + 2, separator.join(row)) for k, row in enumerate(rows)]
    fast = _at_once(body, separator, 3)
    assert fast is not None
    np.testing.assert_array_equal(fast, _line_by_line(body, separator, ["t", "a", "b"], 1, "x.csv"))


def test_a_channel_in_volts_is_read_as_recorded_and_named_before_the_records_chain(tmp_path):
    """A raw sensor voltage (an accelerometer in mV without its sensitivity applied) is read as the voltage it is
    (a header's unit, a units row's); the records chain names it with the sensitivity that converts it, beside how
    to leave it out (tests/test_sensitivity.py converts it)."""
    rows = [f"{0.002 * k},{np.sin(k)}" for k in range(500)]
    (tmp_path / "raw.csv").write_text("\n".join(["Time [s],A_x [mV]", *rows]) + "\n")
    (tmp_path / "row.csv").write_text("\n".join(["Time,A_x", "s,mV", *rows]) + "\n")
    for name in ("raw.csv", "row.csv"):
        raw = read_csv(tmp_path / name)
        assert (raw.channels[0].quantity, raw.channels[0].unit) == ("voltage", "mV")
        with pytest.raises(
            InputError, match=r"^A_x: is a raw voltage in mV: give its sensor's sensitivity.*--ignore A_x"
        ):
            raw.in_si()


@pytest.mark.parametrize(
    ("name", "what"),
    [
        ("rec.mat", "a MATLAB file"),
        ("book.xlsx", "an Excel workbook"),
        ("run.dxd", "a Dewesoft data file"),
        ("campaign.json", "a JSON file (a campaign or a report, not a record)"),  # was "holds no table"
    ],
)
def test_a_file_of_a_format_mountid_does_not_read_is_named_with_those_it_reads(tmp_path, name, what):
    """A bench's MATLAB, Excel or Dewesoft file was read as a CSV ("not UTF-8 text", "holds no table"): it is named
    with the formats mountid reads, and so is a campaign given as a record; a missing one is named as missing."""
    from mountid.measurement.records import read_record, read_runs

    with pytest.raises(InputError, match="^record: .*(no such file|not found|does not exist)"):
        read_record(tmp_path / name)
    (tmp_path / name).write_bytes(b"PK\x03\x04\x00binary")
    pattern = f"^record: {re.escape(name)} is {re.escape(what)}: mountid reads CSV .*LVM"
    for read in (read_record, read_runs):
        with pytest.raises(InputError, match=pattern):
            read(tmp_path / name)


def test_a_header_unit_as_ni_names_it_is_a_unit_in_parentheses_too(tmp_path):
    """ "F (Newtons)" and "Tacho (Volts)" are a force in N and a raw voltage (records.UNIT_NAMES), in parentheses as
    in brackets; they were channels named so, read as accelerations in m/s^2."""
    rows = "\n".join(f"{0.002 * k},{np.sin(k)},{np.cos(k)}" for k in range(100))
    for left, right in ("()", "[]"):
        (tmp_path / "n.csv").write_text(f"Time,F {left}Newtons{right},Tacho {left}Volts{right}\n{rows}\n")
        got = read_csv(tmp_path / "n.csv")
        assert [(c.name, c.quantity, c.unit) for c in got.channels] == [("F", "force", "N"), ("Tacho", "voltage", "V")]


def test_a_csv_of_appended_tables_holds_a_run_per_table(tmp_path, capsys):
    """An acquisition that appends each trigger's table under its own header line: a run per table (the header's
    recurrence was "a time mountid does not read ... give the sampling rate and leave the column out"), read one
    at a time or every one, and combined per mode by process as a UFF file's runs are."""
    from mountid.cli import main
    from mountid.measurement.records import read_record, read_runs
    from mountid.measurement.rig import Rig
    from mountid.validation.paper import paper_hit, paper_sensors

    rig = Rig.of("kid300")
    hits = [rig.simulate(paper_sensors(), 4.0, 500.0, hammers=[paper_hit()], seed=seed) for seed in (1, 2)]
    for k, hit in enumerate(hits):
        write_csv(hit, tmp_path / f"hit{k}.csv")
    text = "".join((tmp_path / f"hit{k}.csv").read_text(encoding="utf-8") for k in range(2))
    (tmp_path / "appended.csv").write_text(text, encoding="utf-8")
    runs = read_runs(tmp_path / "appended.csv")
    assert len(runs) == 2
    for got, hit in zip(runs, hits, strict=True):
        assert got.channels == hit.channels
        np.testing.assert_array_equal(got.data, hit.data)
    with pytest.raises(InputError, match=r"^run: appended.csv holds 2 runs \(tables under a header line each"):
        read_record(tmp_path / "appended.csv")
    np.testing.assert_array_equal(read_record(tmp_path / "appended.csv", run=2).data, hits[1].data)
    assert main(["process", "kid300", str(tmp_path / "appended.csv")]) == 0
    out = capsys.readouterr().out
    assert "4 modes from " in out and "appended.csv (2 runs)" in out
