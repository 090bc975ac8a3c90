"""Measurement records: uniformly sampled channels with their metadata, and the CSV format.

A record is a time column [s] and one column per channel. Each channel says where it measures (body point
[m] from the coordinate origin), along which unit direction, what (quantity) and in which unit. The CSV
file carries this metadata in comment lines before the table, so a record read back is complete:

    # mountid record 1
    # channel {"name": "A_x", "point": [0.3, 0, 0], "direction": [1, 0, 0], "quantity": "acceleration", "unit": "m/s^2"}
    time,A_x,...
    0.0,0.0012,...

A file without the comment lines reads with unknown points and directions (NaN), which processing that
needs them rejects by channel name.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from mountid.errors import InputError
from mountid.measurement.settings import RECORDS, RecordSettings

FORMAT_LINE = "# mountid record 1"


@dataclass(frozen=True)
class Channel:
    """Metadata of one channel: name, body point [m], unit measuring direction, quantity and unit."""

    name: str
    point: tuple[float, float, float] = (math.nan, math.nan, math.nan)
    direction: tuple[float, float, float] = (math.nan, math.nan, math.nan)
    quantity: str = "acceleration"
    unit: str = "m/s^2"


@dataclass(frozen=True)
class Record:
    """Uniformly sampled channels: time (n,) [s], data (n, n_channels) in each channel's unit."""

    time: NDArray[np.float64]
    data: NDArray[np.float64]
    channels: tuple[Channel, ...]

    def __post_init__(self) -> None:
        validate(self.time, self.data, tuple(c.name for c in self.channels))

    @property
    def rate(self) -> float:
        """Sampling rate [Hz]."""
        return 1.0 / float(self.time[1] - self.time[0])

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(c.name for c in self.channels)

    def channel(self, name: str) -> NDArray[np.float64]:
        """One channel's samples by name."""
        if name not in self.names:
            raise InputError(name, f"no such channel (channels: {', '.join(self.names)})")
        return self.data[:, self.names.index(name)]

    def select(self, names: list[str] | tuple[str, ...]) -> Record:
        """A record of the named channels only, in that order."""
        cols = [self.names.index(n) if n in self.names else self.channel(n) for n in names]
        return Record(self.time, self.data[:, cols], tuple(self.channels[c] for c in cols))


def validate(time: NDArray, data: NDArray, names: tuple[str, ...], settings: RecordSettings = RECORDS) -> None:
    """Reject what would silently give a wrong frequency: NaN, too few samples, non-uniform sampling (beyond
    ``settings.sampling_rtol``). A Record validates itself with the default settings."""
    if data.ndim != 2 or data.shape != (len(time), len(names)):
        raise InputError("data", f"shape {data.shape} does not match {len(time)} samples x {len(names)} channels")
    if len(set(names)) != len(names):
        raise InputError("channels", "channel names must be unique")
    if len(time) < 16:
        raise InputError("time", f"a record needs at least 16 samples, got {len(time)}")
    if not np.all(np.isfinite(time)):
        raise InputError("time", "contains NaN or infinite values")
    bad = ~np.all(np.isfinite(data), axis=0)
    if np.any(bad):
        first = int(np.flatnonzero(bad)[0])
        row = int(np.flatnonzero(~np.isfinite(data[:, first]))[0])
        raise InputError(names[first], f"NaN or infinite sample at t = {time[row]:g} s (row {row})")
    dt = np.diff(time)
    step = np.median(dt)
    if not step > 0:
        raise InputError("time", "must increase")
    off = np.abs(dt - step) > settings.sampling_rtol * step
    if np.any(off):
        k = int(np.flatnonzero(off)[0])
        kind = "a gap" if dt[k] > step else "non-uniform sampling"
        raise InputError("time", f"{kind} at t = {time[k]:g} s (step {dt[k]:g} s, typical {step:g} s)")


def write_csv(record: Record, path: str | Path) -> None:
    """Write a record as CSV with its channel metadata in comment lines (see module docstring)."""
    lines = [FORMAT_LINE]
    lines += [f"# channel {json.dumps(asdict(c))}" for c in record.channels]
    lines.append(",".join(("time", *record.names)))
    table = np.column_stack([record.time, record.data])
    body = "\n".join(",".join(repr(float(v)) for v in row) for row in table)
    Path(path).write_text("\n".join(lines) + "\n" + body + "\n", encoding="utf-8")


def read_csv(path: str | Path) -> Record:
    """Read a record written by :func:`write_csv`, or a plain CSV with a header row whose first column is
    the time [s] (channels then have unknown points and directions)."""
    path = Path(path)
    if not path.is_file():
        raise InputError("record", f"no such file: {path}")
    meta: dict[str, Channel] = {}
    header: list[str] | None = None
    rows: list[list[float]] = []
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError as err:
        raise InputError("record", f"{path.name} is not UTF-8 text (byte {err.start}): not a CSV record") from None
    for number, line in enumerate(text.splitlines(), start=1):
        if not line.strip():
            continue
        if line.startswith("#"):
            if line.startswith("# channel "):
                try:
                    c = json.loads(line.removeprefix("# channel "))
                    channel = Channel(
                        str(c["name"]),
                        tuple(map(float, c["point"])),
                        tuple(map(float, c["direction"])),
                        str(c.get("quantity", "acceleration")),
                        str(c.get("unit", "m/s^2")),
                    )
                except (ValueError, KeyError, TypeError) as err:
                    raise InputError(f"{path.name}:{number}", f"bad channel metadata ({err})") from None
                meta[channel.name] = channel
            continue
        if header is None:
            header = [h.strip() for h in line.split(",")]
            continue
        try:
            rows.append([float(v) if v.strip() else math.nan for v in line.split(",")])
        except ValueError:
            raise InputError(f"{path.name}:{number}", "a value is not a number") from None
        if len(rows[-1]) != len(header):
            raise InputError(f"{path.name}:{number}", f"{len(rows[-1])} values for {len(header)} columns")
    if header is None or not rows:
        raise InputError("record", f"{path.name} holds no table")
    table = np.array(rows)
    names = tuple(header[1:])
    missing = [n for n in meta if n not in names]
    if missing:
        raise InputError(missing[0], f"has metadata in {path.name} but no column")
    channels = tuple(meta.get(n, Channel(n)) for n in names)
    return Record(table[:, 0], table[:, 1:], channels)


def read_record(path: str | Path) -> Record:
    """Read a record file: UFF (.uff, .unv: types 58 and 2411, mountid.measurement.uff) or CSV (read_csv)."""
    if str(path).lower().endswith((".uff", ".unv")):
        from mountid.measurement.uff import read_uff  # pyuff is an extra: imported only for UFF files

        return read_uff(path)
    return read_csv(path)
