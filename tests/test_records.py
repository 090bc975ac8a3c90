"""Records: CSV write and read back, and the input errors that keep a wrong frequency from being silent."""

from __future__ import annotations

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
    ],
)
def test_bad_records_are_rejected_by_name(edit, message):
    rec = _record()
    t, d = edit(rec.time, rec.data)
    with pytest.raises(InputError, match=message):
        Record(t, d, rec.channels)


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
