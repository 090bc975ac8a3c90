"""Records in National Instruments' TDMS format (LabVIEW, FlexLogger, DAQExpress), read by npTDMS.

A TDMS file holds groups of channels. Every channel that holds data, in any group, is a channel of the record, named
by its channel name ("group/channel" where two groups share one), but where every group holds channels of the same
names: then each group is a run of its own (a logger's hits, a group each), read one at a time. A channel's unit is
its ``unit_string`` property (records.UNITS: the unit gives the quantity; a channel that states none is an
acceleration in m/s^2, as a CSV's bare column). The time comes from the waveform properties NI's DAQ channels carry,
``wf_increment`` [s] and ``wf_start_offset`` [s]; where they are absent, from a channel named as a time
(records.TIME_NAMES: seconds, or LabVIEW timestamps as seconds from the first), else from the sampling rate given. A
channel of another sampling or length (a temperature logged at 10 Hz beside accelerations at 2 kHz), of text, or in
a unit mountid does not read is named with how to leave it out (``ignore``). A bench's TDMS file carries no
geometry: its channels are placed with records.with_geometry (--channel, a campaign record's ``channels``), as a
plain CSV's. mountid's own (write_tdms) gives each channel its point [m] and direction in the properties
``mountid_point`` and ``mountid_direction`` ("x,y,z"), read back with it."""

from __future__ import annotations

import logging
import math
from collections import Counter
from collections.abc import Collection
from dataclasses import replace
from pathlib import Path

import nptdms
import numpy as np
from nptdms.log import log_manager
from numpy.typing import NDArray

from mountid.errors import InputError, existing_file
from mountid.measurement.records import (
    TIME_NAMES,
    Channel,
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

LEAD_IN = 28
"""Bytes of a TDMS segment's lead-in: the tag "TDSm", the table of contents, the version and two offsets."""

GROUP = "mountid"
"""The group write_tdms writes a record's channels in."""

SAMPLING_RTOL = 1e-9
"""Relative difference of two channels' wf_increment within which they share one sampling."""


def read_tdms(
    path: str | Path, ignore: Collection[str] = (), rate: float | None = None, run: int | None = None
) -> Record:
    """Read the channels of a TDMS file as one record (they must share their sampling), all but those ``ignore``
    names; ``rate`` [Hz]: the sampling rate, which replaces the file's timing (and gives one to a file without).
    A file of several runs (_runs: groups of the same channels, a hit each) is read one ``run`` at a time (1, 2,
    ...; an error naming the runs where it is not given; read_tdms_runs reads each)."""
    path, runs = _opened(path)
    if len(runs) == 1 and run not in (None, 1):
        raise InputError("run", f"{run}: {path.name} is a TDMS file of one run")
    held = f"{path.name} holds {counted(len(runs), 'run')} (groups {', '.join(name for name, _ in runs)}"
    _, chosen = chosen_run(runs, run, held, "each of the same channels", "read_tdms_runs")
    return _record(chosen, path, ignore, rate)


def read_tdms_runs(path: str | Path, ignore: Collection[str] = (), rate: float | None = None) -> list[Record]:
    """Every run of a TDMS file (_runs), each a record as read_tdms reads it (one where the file holds one)."""
    path, runs = _opened(path)
    return each_run(runs, lambda run: _record(run[1], path, ignore, rate))


def _runs(found: list[tuple[str, nptdms.TdmsChannel]]) -> list[tuple[str, list[tuple[str, nptdms.TdmsChannel]]]]:
    """The (group, channel) pairs with data grouped into runs, each with its name: where two groups or more hold
    channels of the same names, each group is a run (a logger's hits, a group each; read as one record, each
    channel's hits were channels of their own, "Hit 1/ai0" beside "Hit 2/ai0"); otherwise one run of them all."""
    groups: dict[str, list[tuple[str, nptdms.TdmsChannel]]] = {}
    for group, channel in found:
        groups.setdefault(group, []).append((group, channel))
    names = {frozenset(c.name for _, c in members) for members in groups.values()}
    if len(groups) > 1 and len(names) == 1:
        return list(groups.items())
    return [("", found)]


def _opened(path: str | Path) -> tuple[Path, list[tuple[str, list[tuple[str, nptdms.TdmsChannel]]]]]:
    """The TDMS file at ``path`` read: its path and its channels with data in runs (_runs); an InputError where it
    is missing, not a TDMS file, cut short, or holds no channel with data."""
    path = existing_file(path, "record")
    with path.open("rb") as f:
        lead = f.read(LEAD_IN)
    if lead[:4] != b"TDSm":  # every TDMS segment begins with it (npTDMS reads another file as one without channels)
        raise InputError("record", f"{path.name} is not a TDMS file (it does not begin with a TDMS segment)")
    if len(lead) < LEAD_IN:
        raise InputError("record", f"{path.name} ends inside a segment (an interrupted copy: {len(lead)} bytes)")
    said, console = _Said(), log_manager.console_handler  # npTDMS's warnings become the error below, not lines
    logger, level = logging.getLogger("nptdms"), console.level
    logger.addHandler(said)
    console.setLevel(logging.CRITICAL + 1)
    try:
        tdms = nptdms.TdmsFile.read(str(path))
    except Exception as err:  # npTDMS raises ValueError, KeyError and others on a file it cannot parse
        raise InputError("record", f"{path.name} is not a readable TDMS file ({type(err).__name__}: {err})") from None
    finally:
        logger.removeHandler(said)
        console.setLevel(level)
    if said.messages:  # npTDMS reads what a cut file holds and logs that it is cut
        raise InputError(
            "record", f"{path.name} ends inside a segment (an interrupted copy: {said.messages[0].rstrip('.')})"
        )
    found = [(group.name, channel) for group in tdms.groups() for channel in group.channels() if len(channel)]
    if not found:
        raise InputError("record", f"{path.name} holds no channel with data")
    return path, _runs(found)


def _record(
    found: list[tuple[str, nptdms.TdmsChannel]], path: Path, ignore: Collection[str], rate: float | None
) -> Record:
    """One run's channels (group, channel) as a record, all but those ``ignore`` names (read_tdms)."""
    counts = Counter(channel.name for _, channel in found)
    named = [(c.name if counts[c.name] == 1 else f"{group}/{c.name}", c) for group, c in found]
    names = [name for name, _ in named]
    check_ignored(ignore, names, path.name)
    named = [(name, c) for name, c in named if name not in ignore]
    clock = [(name, c) for name, c in named if _is_time(name, c)]
    data = [(name, c) for name, c in named if not _is_time(name, c)]
    if not data:
        raise InputError("record", f"{path.name} holds no channel but its time")
    first, reference = data[0]
    n = len(reference)
    for name, c in data:
        if len(c) != n:
            raise InputError(
                name, f"{len(c)} samples against {n} of {first} (one record needs one sampling){unread(name)}"
            )
        if not np.issubdtype(c.dtype, np.number):
            raise InputError(name, f"holds {c.dtype} values, not numbers{unread(name)}")
    time = _time(path.name, data, clock, n, rate)
    channels = tuple(
        _placed(channel_in(name, str(c.properties.get("unit_string", "")).strip(), name), c) for name, c in data
    )
    return Record(time, np.column_stack([np.asarray(c[:], dtype=float) for _, c in data]), channels)


class _Said(logging.Handler):
    """The warnings npTDMS logs while it reads a file (a segment cut short, incomplete metadata)."""

    def __init__(self) -> None:
        super().__init__(logging.WARNING)
        self.messages: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.messages.append(record.getMessage())


def write_tdms(record: Record, path: str | Path) -> None:
    """Write a record as a TDMS file: one group ("mountid"), a channel each with its unit (unit_string), its
    sampling (wf_increment, wf_start_offset) and its point and direction (mountid_point, mountid_direction)."""
    step = float(record.time[1] - record.time[0])
    channels = [
        nptdms.ChannelObject(
            GROUP,
            c.name,
            np.asarray(record.data[:, k], dtype=float),
            properties={
                "unit_string": c.unit,
                "wf_increment": step,
                "wf_start_offset": float(record.time[0]),
                "wf_samples": len(record.time),
                "mountid_point": ",".join(repr(float(v)) for v in c.point),
                "mountid_direction": ",".join(repr(float(v)) for v in c.direction),
            },
        )
        for k, c in enumerate(record.channels)
    ]
    with nptdms.TdmsWriter(str(path)) as writer:
        writer.write_segment([nptdms.GroupObject(GROUP), *channels])


def _placed(channel: Channel, source: nptdms.TdmsChannel) -> Channel:
    """``channel`` at the point and along the direction its TDMS ``source`` states (write_tdms's properties), else
    as it is (unplaced)."""
    point, direction = (source.properties.get(f"mountid_{key}") for key in ("point", "direction"))
    if point is None or direction is None:
        return channel
    try:
        placed = tuple(tuple(float(v) for v in str(text).split(",")) for text in (point, direction))
    except ValueError as err:
        raise InputError(channel.name, f"bad mountid_point or mountid_direction ({err})") from None
    if any(len(v) != 3 for v in placed):
        raise InputError(channel.name, "mountid_point and mountid_direction take three numbers each")
    if any(np.isnan(v).any() and not np.isnan(v).all() for v in placed):
        raise InputError(channel.name, "point and direction must be finite numbers (all NaN: not placed)")
    return replace(channel, point=placed[0], direction=placed[1])


def _is_time(name: str, channel: nptdms.TdmsChannel) -> bool:
    """Whether a channel is the file's time: of LabVIEW timestamps, or named as one (records.TIME_NAMES) and
    without waveform timing of its own or in seconds or milliseconds (a logger that writes its time channel as a
    waveform beside the others: it was read as a channel, 'unit 's' is not ...')."""
    named = name.rsplit("/", 1)[-1].strip().lower() in TIME_NAMES
    unit = str(channel.properties.get("unit_string", "")).strip()
    waveform = "wf_increment" in channel.properties
    return np.issubdtype(channel.dtype, np.datetime64) or (named and (not waveform or unit in ("s", "ms")))


def _time(
    file: str,
    data: list[tuple[str, nptdms.TdmsChannel]],
    clock: list[tuple[str, nptdms.TdmsChannel]],
    n: int,
    rate: float | None,
) -> NDArray[np.float64]:
    """The record's time [s]: at ``rate`` [Hz] where given (from the file's start offset), else from the
    channels' waveform timing (they must agree), else from the time channel ``clock``."""
    first, reference = data[0]
    if "wf_increment" in reference.properties:
        step = float(reference.properties["wf_increment"])
        for name, c in data:
            other = float(c.properties.get("wf_increment", math.nan))
            if not abs(other - step) <= SAMPLING_RTOL * step:
                said = f"sampled at {1 / other:.6g} Hz" if other > 0 else "without a sampling (wf_increment)"
                raise InputError(name, f"{said} against {1 / step:.6g} Hz of {first} (one record needs one sampling)")
        start = float(reference.properties.get("wf_start_offset", 0.0))
        if rate is not None:
            return sampled_at(start, n, rate)
        if not (math.isfinite(step) and step > 0):
            raise InputError(first, f"wf_increment {step} s is no sampling step: give the sampling rate (--rate)")
        return start + np.arange(n) * step
    if rate is not None:
        return sampled_at(0.0, n, rate)
    if not clock:
        raise InputError(
            "record",
            f"{file} states no sampling (no wf_increment, no time channel): give the sampling rate (--rate, or 'rate' "
            "in a campaign's record)",
        )
    name, c = clock[0]
    if len(c) != n:
        raise InputError(name, f"{len(c)} times against {n} samples of {first}")
    values = c[:]
    if np.issubdtype(values.dtype, np.datetime64):
        seconds = (values - values[0]) / np.timedelta64(1, "ns") * 1e-9
    else:
        seconds = np.asarray(values, dtype=float) * (1e-3 if c.properties.get("unit_string", "s") == "ms" else 1.0)
    return uniform_time(seconds)
