"""Records in the LabVIEW Measurement format (.lvm), the text files LabVIEW's Write To Measurement File writes, read
by lvm_read (ladisk, the makers of pyuff).

An LVM file holds a file header, then segments, each a call of the writer: a segment header (one value per channel
of each tag: ``Samples``, ``X0``, ``Delta_X``, ``Y_Unit_Label``, ``X_Dimension``) and a table whose first column is
the time (``X_Columns`` One; No: none, the time is X0 + k Delta_X) and whose last may be a ``Comment``. Segments of
the same channels are runs (a logger's hits, a segment each), read one at a time as a TDMS file's groups are; one
segment is a record. A channel's unit is its Y_Unit_Label (records.RECORDED; LabVIEW's own names, "Volts" and
"Newtons", taken as V and N: records.UNIT_NAMES; a raw voltage is converted by its sensor's sensitivity,
records.with_sensitivities); a channel that states none is an acceleration in m/s^2, as a CSV's bare column. A
unit mountid does not read, a value that is not a number, an x axis that is not time and a time column per channel
(X_Columns Multi) are named. An LVM file carries no geometry: its channels are placed with records.with_geometry
(--channel, a campaign record's ``channels``), as a plain CSV's.
"""

from __future__ import annotations

import math
from collections.abc import Collection
from pathlib import Path

import lvm_read
import numpy as np
from numpy.typing import NDArray

from mountid.errors import InputError, existing_file
from mountid.measurement.records import (
    Record,
    channel_in,
    check_ignored,
    chosen_run,
    each_run,
    sampled_at,
    uniform_time,
    unread,
)
from mountid.nomenclature import counted

SAMPLING_RTOL = 1e-9
"""Relative difference of two channels' Delta_X within which they share one sampling."""


def read_lvm(
    path: str | Path, ignore: Collection[str] = (), rate: float | None = None, run: int | None = None
) -> Record:
    """Read an LVM file's channels as one record, all but those ``ignore`` names; ``rate`` [Hz]: the sampling rate,
    which replaces the file's timing. A file of several runs (segments of the same channels) is read one ``run`` at
    a time (1, 2, ...; an error naming the runs where it is not given; read_lvm_runs reads each)."""
    path, segments = _opened(path)
    if len(segments) == 1 and run not in (None, 1):
        raise InputError("run", f"{run}: {path.name} is an LVM file of one segment")
    held = f"{path.name} holds {counted(len(segments), 'run')} (segments of the same channels"
    chosen = chosen_run(segments, run, held, "a hit each", "read_lvm_runs")
    return _record(chosen, path, ignore, rate)


def read_lvm_runs(path: str | Path, ignore: Collection[str] = (), rate: float | None = None) -> list[Record]:
    """Every segment of an LVM file, each a record as read_lvm reads it (one where the file holds one)."""
    path, segments = _opened(path)
    return each_run(segments, lambda segment: _record(segment, path, ignore, rate))


def _opened(path: str | Path) -> tuple[Path, list[dict]]:
    """The LVM file at ``path`` parsed: its path and its segments; an InputError where it is missing, is not an LVM
    file, holds no segment, or holds segments of different channels."""
    path = existing_file(path, "record")
    raw = path.read_bytes()
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError:  # LabVIEW on Windows writes the system's code page (a unit in µm, a comment)
        text = raw.decode("cp1252", errors="replace")
    if not text.startswith("LabVIEW Measurement"):
        raise InputError("record", f"{path.name} is not an LVM file (it does not begin with 'LabVIEW Measurement')")
    try:
        lvm = lvm_read.read_str(text)
    except (ValueError, SyntaxError, KeyError, IndexError) as err:
        raise InputError("record", f"{path.name} is not a readable LVM file ({type(err).__name__}: {err})") from None
    segments = [lvm[k] for k in range(lvm["Segments"]) if len(lvm[k].get("data", ()))]
    if not segments:
        raise InputError("record", f"{path.name} holds no segment with data")
    if lvm.get("X_Columns", "One") == "Multi":
        raise InputError(
            "record",
            f"{path.name} has a time column per channel (X_Columns Multi): mountid reads one time for all (write "
            "the file with X_Columns One)",
        )
    for segment in segments:
        segment["file"] = lvm
    names = {tuple(_names(s)) for s in segments}
    if len(names) > 1:
        raise InputError(
            "record",
            f"{path.name} holds segments of different channels: mountid reads segments of the same channels, each a "
            "run (a hit)",
        )
    return path, segments


def _names(segment: dict) -> list[str]:
    """A segment's channel names, without its time column and its Comment column."""
    names = list(segment.get("Channel names", []))
    if segment["file"].get("X_Columns", "One") != "No":
        names = names[1:]
    return names[:-1] if names[-1:] == ["Comment"] else names


def _record(segment: dict, path: Path, ignore: Collection[str], rate: float | None) -> Record:
    """One segment's channels as a record, all but those ``ignore`` names."""
    lvm, names = segment["file"], _names(segment)
    timed = lvm.get("X_Columns", "One") != "No"
    data = np.asarray(segment["data"], dtype=float)
    data = data.reshape(len(data), -1)
    check_ignored(ignore, names, path.name)
    if len(set(names)) != len(names):
        twice = next(n for n in names if names.count(n) > 1)
        raise InputError(twice, f"two channels of {path.name} have this name: mountid tells channels by name")
    columns = {name: data[:, k + timed] for k, name in enumerate(names) if k + timed < data.shape[1]}
    kept = [(k, name) for k, name in enumerate(names) if name not in ignore]
    if not kept:
        raise InputError("ignore", f"leaves no channel of {path.name}")
    channels = []
    for k, name in kept:
        axis = _value(segment, "X_Dimension", k)
        if axis and axis != "Time":
            raise InputError(name, f"its x axis is {axis}: a record is time responses, over time")
        if name not in columns:
            raise InputError(name, f"no column in {path.name}'s table{unread(name)}")
        values = columns[name]
        if not np.all(np.isfinite(values)):
            row = int(np.flatnonzero(~np.isfinite(values))[0])
            raise InputError(name, f"a value is not a number in row {row + 1} of {path.name}'s table{unread(name)}")
        unit = _value(segment, "Y_Unit_Label", k)
        channels.append(channel_in(name, unit, name, f"{path.name}: "))
    time = _time(segment, data, kept, path.name, rate, timed)
    return Record(time, np.column_stack([columns[name] for _, name in kept]), tuple(channels))


def _value(segment: dict, key: str, k: int) -> str:
    """Channel ``k``'s value of the segment header's tag ``key`` ('' where the header gives none)."""
    values = segment.get(key, [])
    return str(values[k]).strip() if k < len(values) else ""


def _time(
    segment: dict, data: NDArray, kept: list[tuple[int, str]], file: str, rate: float | None, timed: bool
) -> NDArray[np.float64]:
    """The record's time [s]: at ``rate`` [Hz] where given, else X0 + k Delta_X of the segment header (the channels
    must agree; X0 from 0 where the file's times are absolute, LabVIEW's seconds since 1904), else the table's time
    column."""
    n = len(data)
    steps = [(name, float(segment["Delta_X"][k])) for k, name in kept if k < len(segment.get("Delta_X", []))]
    absolute = segment["file"].get("Time_Pref", "Relative") == "Absolute"
    start = 0.0
    if steps and not absolute:
        k0 = kept[0][0]
        start = float(segment["X0"][k0]) if k0 < len(segment.get("X0", [])) else 0.0
        start = start if math.isfinite(start) else 0.0
    if rate is not None:
        return sampled_at(start, n, rate)
    if steps:
        first, step = steps[0]
        for name, other in steps:
            if not abs(other - step) <= SAMPLING_RTOL * abs(step):
                raise InputError(
                    name, f"Delta_X {other:g} s against {step:g} s of {first} (one record needs one sampling)"
                )
        if not (math.isfinite(step) and step > 0):
            raise InputError(first, f"Delta_X {step} s is no sampling step: give the sampling rate (--rate)")
        return start + np.arange(n) * step
    if not timed:
        raise InputError(
            "record", f"{file} states no sampling (no Delta_X, no time column): give the sampling rate (--rate)"
        )
    return uniform_time(data[:, 0] - (data[0, 0] if absolute else 0.0))
