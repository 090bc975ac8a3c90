"""Measurement records: uniformly sampled channels with their metadata, and the CSV format.

A record is a time column [s] and one column per channel. Each channel says where it measures (body point
[m] from the coordinate origin), along which unit direction, what (quantity) and in which unit. The CSV
file carries this metadata in comment lines before the table, so a record read back is complete:

    # mountid record 1
    # channel {"name": "A_x", "point": [0.3, 0, 0], "direction": [1, 0, 0], "quantity": "acceleration", "unit": "m/s^2"}
    time,A_x,...
    0.0,0.0012,...

A file without the comment lines (a bench's export) reads with unknown points and directions (NaN), which
processing that needs them rejects by channel name (:func:`with_geometry` places them). Its header may carry
units, ``Time [ms];A_x [g];F (kN)``, or a row of units of its own below the names (``ms;g;kN``); its columns may
be separated by semicolons or tabs (then with decimal commas or points), its cells quoted, its lines ended by a
separator, and lines of text before the header (an acquisition's preamble: date, operator, rate) are read past.

Quantities and units as test benches write them (UNITS): acceleration in m/s^2, g, mm/s^2 or in/s^2; velocity in
m/s, mm/s or in/s (ips); displacement in m, mm, um (or µm), in or mil; force in N, kN or lbf (a hammer's force
channel: the excitation, never a response). A channel in V, mV or uV (VOLTAGE) is a sensor's raw output, read as
recorded and converted by its sensitivity (:func:`with_sensitivities`: the command line's --sensitivity, a campaign
record's "sensitivity"; 100mV/g, 2.25mV/N). Any other unit is rejected by channel name; :meth:`Record.in_si`
converts every channel to SI, and names a voltage left unconverted. A column mountid does not read (a tachometer,
a microphone in Pa, a status in text) is named with its unit or cell, and left out by name (``ignore``: the command
line's --ignore, a campaign record's "ignore").
"""

from __future__ import annotations

import csv
import io
import itertools
import json
import math
import re
import shlex
from collections.abc import Callable, Collection, Sequence
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, TypeVar

import numpy as np
from numpy.typing import NDArray

from mountid.effects import STANDARD_GRAVITY
from mountid.errors import InputError, existing_file
from mountid.measurement.settings import RECORDS, RecordSettings

if TYPE_CHECKING:
    from mountid.machine import Machine

Run = TypeVar("Run")
"""What a reader holds of one run of a file (each_run)."""

RecordOrTable = TypeVar("RecordOrTable", "Record", "ModeTable")
"""A record, or a table of modes where a file gives one (ModeTable)."""

FORMAT_LINE = "# mountid record 1"

INCH = 0.0254
"""[m] The international inch (1959), exact."""

POUND_FORCE = 0.45359237 * STANDARD_GRAVITY
"""[N] The pound-force: the international avoirdupois pound (1959, exact) under standard gravity."""

UNITS: dict[str, dict[str, float]] = {
    "acceleration": {
        "m/s^2": 1.0,
        "m/s2": 1.0,
        "m/s\u00b2": 1.0,
        "g": STANDARD_GRAVITY,
        "mm/s^2": 1e-3,
        "mm/s2": 1e-3,
        "mm/s\u00b2": 1e-3,
        "in/s^2": INCH,
        "in/s2": INCH,
        "in/s\u00b2": INCH,
    },
    "velocity": {"m/s": 1.0, "mm/s": 1e-3, "in/s": INCH, "ips": INCH},
    "displacement": {
        "m": 1.0,
        "mm": 1e-3,
        "um": 1e-6,
        "\u00b5m": 1e-6,  # the micro sign
        "\u03bcm": 1e-6,  # the Greek mu
        "in": INCH,
        "mil": 1e-3 * INCH,
    },
    "force": {"N": 1.0, "kN": 1e3, "lbf": POUND_FORCE},
}
"""Every quantity a channel may record, its units and each unit's factor to SI (the first unit listed): SI and the
US customary units of American benches (in/s, ips and mil of velocity and displacement, in/s^2, lbf)."""

VOLTAGE: dict[str, float] = {"V": 1.0, "mV": 1e-3, "uV": 1e-6, "\u00b5V": 1e-6, "\u03bcV": 1e-6}
"""Units of a voltage and their factors to V: a sensor's raw output as an acquisition without its sensitivities
records it (an accelerometer's or a force sensor's), held as recorded until with_sensitivities converts it."""

UNIT_NAMES: dict[str, str] = {
    "Volts": "V",
    "volts": "V",
    "Newtons": "N",
    "Pounds": "lbf",
    "g's": "g",
    "Meters": "m",
    "Inches": "in",
    "m/s**2": "m/s^2",
    "m s^-2": "m/s^2",
    "ms^-2": "m/s^2",
}
"""Other names of units of RECORDED as acquisition software writes them (NI's DAQmx and LabVIEW in a TDMS
unit_string or an LVM Y_Unit_Label: "Volts", "Newtons", "g's"; other exporters' spellings of m/s^2), each with the
unit it is (unit_named)."""


def unit_named(text: str) -> str:
    """The unit of RECORDED that ``text`` names (UNIT_NAMES), else ``text`` as it is."""
    return UNIT_NAMES.get(text.strip(), text.strip())


RECORDED: dict[str, dict[str, float]] = {**UNITS, "voltage": VOLTAGE}
"""Every quantity a file's channel may hold: those of UNITS, and a raw voltage (VOLTAGE), which the records chain
reads only after its sensor's sensitivity converts it (with_sensitivities; Record.in_si names it)."""

A_TABLE = "a table of modes (a bench's modal analysis results)"
"""What a ModeTable is called in errors."""

TABLE_HAS_NO = f"{A_TABLE} has no samples"
"""What an option of a record's samples is told of a table of modes (ModeTable)."""

RESPONSE_ORDER: dict[str, int] = {"displacement": 0, "velocity": 1, "acceleration": 2}
"""Time derivatives of the displacement a response quantity is: a free-decay amplitude of pole p in that
quantity times p^(2 - order) is the acceleration amplitude."""


@dataclass(frozen=True)
class Channel:
    """Metadata of one channel: name, body point [m], unit measuring direction, quantity and unit."""

    name: str
    point: tuple[float, float, float] = (math.nan, math.nan, math.nan)
    direction: tuple[float, float, float] = (math.nan, math.nan, math.nan)
    quantity: str = "acceleration"
    unit: str = "m/s^2"


@dataclass(frozen=True, eq=False)
class Lines:
    """Where impulse responses come from (Record.impulse): a bench's frequency response functions on lines
    ``spacing`` [Hz] apart from 0 to ``top`` [Hz], with an exponential window exp(-``window`` t) the bench put on
    the responses divided out again (``window`` [1/s]; 0: none divided out), and the ``coherence`` the file gives
    per channel name on the same lines (0 where it gives none)."""

    top: float
    spacing: float
    window: float = 0.0
    coherence: tuple[tuple[str, NDArray[np.float64]], ...] = ()
    origin: str = ""
    """Where the functions come from where mountid estimated them ("4 periods of a periodic excitation on F"); ""
    for a bench's."""
    per_volt: str = ""
    """The reference (input) the functions are per volt of, where a bench exported them over the hammer's raw
    voltage (its sensitivity left out): its name, which a sensitivity converts (with_sensitivities); "" per force."""
    together: str = ""
    """The measurement of several inputs at once these lines are one input's share of, where a file gives them so
    (a bench's multiple coherence beside them: the inputs' functions come from the same samples, and a mode's
    estimates from two of them are not independent); "" for one input's own."""

    def coherence_at(self, frequency: float, names: Sequence[str]) -> NDArray[np.float64]:
        """The coherence of the channels ``names`` that have one at the line nearest ``frequency`` [Hz]."""
        k = int(round(frequency / self.spacing))
        return np.array([c[min(k, len(c) - 1)] for name, c in self.coherence if name in names])


def impulse_record(
    lines: NDArray[np.complex128],
    spacing: float,
    channels: tuple[Channel, ...],
    coherence: tuple[tuple[str, NDArray[np.float64]], ...] = (),
    origin: str = "",
) -> Record:
    """Frequency response functions [unit per N] on ``lines`` (n_lines, n_channels) ``spacing`` [Hz] apart from 0 Hz
    as the impulse responses they transform back to (Record.impulse): h(t) = rate x the inverse real transform, at
    rate = twice the last line's frequency, over 1 / spacing seconds."""
    n = 2 * (len(lines) - 1)
    rate = n * spacing
    impulse = Lines(rate / 2, spacing, coherence=coherence, origin=origin)
    return Record(np.arange(n) / rate, np.fft.irfft(lines, n=n, axis=0) * rate, channels, impulse=impulse)


@dataclass(frozen=True)
class Record:
    """Uniformly sampled channels: time (n,) [s], data (n, n_channels) in each channel's unit."""

    time: NDArray[np.float64]
    data: NDArray[np.float64]
    channels: tuple[Channel, ...]
    impulse: Lines | None = None
    """Where the channels are impulse responses [unit per N s] from the instant of a hit, the frequency response
    functions they come from (uff.read_uff of a file of them: not a test's record); None for a record. The records
    chain fits them as it fits the H1 frequency responses of a record with a force channel, without a time
    record's checks."""

    def __post_init__(self) -> None:
        validate(self.time, self.data, tuple(c.name for c in self.channels))
        for c in self.channels:
            units = RECORDED.get(c.quantity)
            if units is None:
                raise InputError(c.name, f"quantity {c.quantity!r} is not one of {', '.join(RECORDED)}")
            if c.unit not in units:
                raise InputError(
                    c.name, f"unit {c.unit!r} is not a unit of {c.quantity} ({', '.join(units)}){unread(c.name)}"
                )
        largest = np.abs(self.data).max(axis=0, initial=0.0)
        for c, value in zip(self.channels, largest, strict=True):
            if value > SAMPLE_LIMIT:
                raise InputError(
                    c.name,
                    f"samples up to {value:g} {c.unit}, beyond {SAMPLE_LIMIT:g}: the records chain's squares of them "
                    "overflow (a corrupt file, or another unit)",
                )

    def in_si(self) -> Record:
        """The record with every channel in the SI unit of its quantity (m/s^2, m/s, m, N); an InputError naming a
        channel of a raw voltage, which only its sensor's sensitivity converts (with_sensitivities), or the reference
        of frequency response functions per volt."""
        if self.impulse is not None and self.impulse.per_volt:
            name = self.impulse.per_volt
            raise InputError(
                name,
                "frequency response functions per volt of this reference (the hammer's raw voltage): give its "
                f'sensitivity, as --sensitivity {shlex.quote(name)}=2.25mV/N, or a campaign record\'s "sensitivity"',
            )
        for c in self.channels:
            if c.quantity == "voltage":
                raw = RAW_VOLTAGE.format(name=shlex.quote(c.name))
                raise InputError(c.name, f"is a raw voltage in {c.unit}{raw}{unread(c.name)}")
        factors = np.array([UNITS[c.quantity][c.unit] for c in self.channels])
        if np.all(factors == 1.0):
            return self
        si = tuple(
            Channel(c.name, c.point, c.direction, c.quantity, next(iter(UNITS[c.quantity]))) for c in self.channels
        )
        return replace(self, data=self.data * factors, channels=si)

    @property
    def responses(self) -> tuple[str, ...]:
        """Names of the response channels (acceleration, velocity, displacement; not force, not a raw voltage)."""
        return tuple(c.name for c in self.channels if c.quantity in RESPONSE_ORDER)

    @property
    def forces(self) -> tuple[str, ...]:
        """Names of the force channels (the excitation)."""
        return tuple(c.name for c in self.channels if c.quantity == "force")

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

    def before(self, time: float) -> Record:
        """The samples before ``time`` [s] (every channel)."""
        keep = self.time < time
        return replace(self, time=self.time[keep], data=self.data[keep])

    def select(self, names: list[str] | tuple[str, ...]) -> Record:
        """A record of the named channels only, in that order."""
        cols = [self.names.index(n) if n in self.names else self.channel(n) for n in names]
        return replace(self, data=self.data[:, cols], channels=tuple(self.channels[c] for c in cols))


@dataclass(frozen=True, eq=False)
class ModeTable:
    """A bench's modal analysis results in the place of a record (uff_modes: a UFF file of mode shapes, datasets
    55): the ``poles`` p [rad/s] (Im p > 0) of its modes, their ``shapes`` (channels x modes, complex; real for
    normal modes) at the ``channels`` (a node and a measured direction each), and ``kind``, what the file calls
    them ("complex modes"). It has no samples: the records chain labels its modes against the model as it labels
    a record's poles (from_records.modal_data), without a pole fit or a record's checks, and without an uncertainty
    the bench did not state."""

    channels: tuple[Channel, ...]
    poles: NDArray[np.complex128]
    shapes: NDArray[np.complex128]
    kind: str
    notes: tuple[str, ...] = ()
    """What the reader made of the file beyond the table (a damping ratio from a hysteretic one, rotations not
    read)."""

    def __post_init__(self) -> None:
        if self.shapes.shape != (len(self.channels), len(self.poles)):
            raise InputError(
                "shapes", f"{self.shapes.shape} do not match {len(self.channels)} channels x {len(self.poles)} modes"
            )
        if len({c.name for c in self.channels}) != len(self.channels):
            raise InputError("channels", "channel names must be unique")

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(c.name for c in self.channels)

    @classmethod
    def of_model(cls, machine: Machine, values: dict[str, float], points: Sequence[Sequence[float]]) -> ModeTable:
        """The undamped normal modes of ``machine`` at the parameter ``values`` (its generated frequencies and
        mass-normalised modal matrix: what ``mountid modes`` prints), read as displacements along x, y and z at
        each of ``points`` [m], node k + 1 at the k-th (channels ``node<k>:<axis>``, as uff_modes names a file's),
        in the machine's mode order (its MODES): the table a bench's modal software compares its test with
        (uff_modes.write_table)."""
        from mountid.machine import sensor_row

        module = machine.module
        args = machine.values(values, module.FORWARD_ARGUMENTS)
        omega, phi = machine.evaluate("frequencies", args), machine.evaluate("modal_matrix", args)
        channels = along_axes(points)
        rows = [sensor_row(module, c.point, c.direction, c.name) for c in channels]
        return cls(
            channels,
            1j * np.asarray(omega, dtype=float),
            (np.array(rows) @ np.asarray(phi)).astype(complex),
            "normal modes",
            (f"the undamped normal modes of {machine.name}, mass-normalised",),
        )


def node_channel(node: int, axis: int, point: Sequence[float]) -> Channel:
    """A channel of a table of modes: node ``node``'s displacement along the global axis ``axis`` (1, 2, 3: x, y,
    z) at ``point`` [m], named ``node<node>:<axis>`` (uff_modes reads and writes them so)."""
    direction = (float(axis == 1), float(axis == 2), float(axis == 3))
    x, y, z = map(float, point)
    return Channel(f"node{node}:{axis}", (x, y, z), direction, "displacement", "m")


def along_axes(points: Sequence[Sequence[float]]) -> tuple[Channel, ...]:
    """The channels of a table of modes at ``points`` [m]: along x, y and z at each, node k + 1 at the k-th
    (node_channel; ModeTable.of_model, Rig.mode_table)."""
    return tuple(node_channel(k, axis, point) for k, point in enumerate(points, start=1) for axis in (1, 2, 3))


def _increasing(time: NDArray, dt: NDArray, step: float) -> None:
    """Reject a time column that does not increase: one written with a resolution coarser than its step (times
    repeated in a tenth of the steps or more, none back: clock times to 1 ms at 2 kHz), a median step that is not
    positive (a column written backwards), or one step back or of zero (rows swapped or written twice), which no
    uniform grid explains."""
    repeats = int(np.count_nonzero(dt == 0))
    if repeats >= 0.1 * len(dt) and np.all(dt >= 0) and time[-1] > time[0]:
        raise InputError(
            "time",
            f"repeats its times in {repeats} of {len(dt)} steps: written to {float(np.min(dt[dt > 0])):.3g} s, "
            f"coarser than its step of {(time[-1] - time[0]) / len(dt):.3g} s; give the sampling rate (--rate, or "
            "'rate' in a campaign's record) to use the nominal grid",
        )
    if not step > 0:
        raise InputError("time", "must increase")
    back = np.flatnonzero(dt <= 0)
    if len(back):
        i = int(back[0])
        raise InputError(
            "time",
            f"goes back or repeats at t = {time[i + 1]:.6g} s after {time[i]:.6g} s (samples out of order or "
            "written twice): re-export the record",
        )


TIME_COLUMN_INCREASING = 0.9
"""Share of the steps of a file's first column that must increase for it to be read as the time: a time column
increases at every step but where rows were swapped or written twice (named one by one); a channel's samples
rise in about half of them (a file without a time column had its first channel taken for the time, and with
--rate lost it without a word)."""

MIN_SAMPLES = 16
"""Fewest samples a record may hold."""

SAMPLE_LIMIT = 1e100
"""Largest |sample| a record may hold in its channel's unit (far beyond any acceleration, velocity, displacement
or force a test bench records; samples of 1e300 ended in "SVD did not converge" with a traceback)."""


def validate(time: NDArray, data: NDArray, names: tuple[str, ...], settings: RecordSettings = RECORDS) -> None:
    """Reject what would silently give a wrong frequency: NaN, too few samples, non-uniform sampling (beyond
    ``settings.sampling_rtol``). A Record validates itself with the default settings."""
    if data.ndim != 2 or data.shape != (len(time), len(names)):
        raise InputError("data", f"shape {data.shape} does not match {len(time)} samples x {len(names)} channels")
    if len(set(names)) != len(names):
        raise InputError("channels", "channel names must be unique")
    if len(time) < MIN_SAMPLES:
        raise InputError("time", f"a record needs at least {MIN_SAMPLES} samples, got {len(time)}")
    if not np.all(np.isfinite(time)):
        raise InputError("time", "contains NaN or infinite values")
    bad = ~np.all(np.isfinite(data), axis=0)
    if np.any(bad):
        first = int(np.flatnonzero(bad)[0])
        row = int(np.flatnonzero(~np.isfinite(data[:, first]))[0])
        raise InputError(names[first], f"NaN or infinite sample at t = {time[row]:g} s (row {row})")
    dt = np.diff(time)
    step = np.median(dt)
    _increasing(time, dt, step)
    off = np.abs(dt - step) > settings.sampling_rtol * step
    if np.any(off):
        k = int(np.flatnonzero(off)[0])
        kind = "a gap" if dt[k] > step else "non-uniform sampling"
        raise InputError("time", f"{kind} at t = {time[k]:g} s (step {dt[k]:g} s, typical {step:g} s)")


def uniform_time(time: NDArray, settings: RecordSettings = RECORDS) -> NDArray[np.float64]:
    """The time column as a uniform grid, or a named error that tells its fault apart.

    Sample times within settings.rounding of a step from the least-squares uniform grid t0 + k dt are the
    grid written with the instrument's resolution (a 2048 Hz record with 6 decimals is off by up to 0.1 %):
    the grid is returned. Otherwise a step back or of zero is rows out of order or repeated, a step of about
    two is a dropped sample, a longer one a gap, and times scattered about the grid with no such step are
    jitter; each is an error naming where (for jitter, the sampling-rate option ``rate`` takes the nominal grid
    instead of the column)."""
    time = np.asarray(time, dtype=float)
    if len(time) < 2 or not np.all(np.isfinite(time)):
        return time  # validate() names these
    dt = np.diff(time)
    step = float(np.median(dt))
    _increasing(time, dt, step)
    if np.all(np.abs(dt - step) <= settings.sampling_rtol * step):
        return time  # uniform as written: kept exactly (a record read back is the record written)
    k = np.arange(len(time))
    slope, intercept = np.polyfit(k, time, 1)
    grid = intercept + slope * k
    if np.max(np.abs(time - grid)) <= settings.rounding * slope:
        return grid
    ratio = dt / step
    long = np.flatnonzero(ratio > 1.5)
    if len(long):
        # a uniform grid would shift every later sample: the record itself must be mended or cut
        i = int(long[0])
        if ratio[i] < 2.5:
            raise InputError(
                "time",
                f"a dropped sample at t = {time[i]:.6g} s (step {dt[i]:.6g} s, typical {step:.6g} s): re-export the "
                "record or analyse the part before it",
            )
        raise InputError(
            "time",
            f"a gap of {dt[i] - step:.6g} s at t = {time[i]:.6g} s ({ratio[i]:.0f} steps of {step:.6g} s): analyse "
            "the parts on either side separately",
        )
    worst = float(np.max(np.abs(time - grid)) / slope)
    raise InputError(
        "time",
        f"jitter: sample times scatter by up to {worst:.1%} of a step about a uniform grid; give the sampling "
        "rate (--rate, or 'rate' in a campaign's record) to use the nominal grid",
    )


def without_window(record: Record | ModeTable, window: float) -> Record:
    """Impulse responses (Record.impulse) with the exponential window exp(-``window`` t) a bench put on the responses
    divided out (``window`` [1/s]: 1 / its time constant; -ln(end) / T for a window that ends at ``end`` of its
    start over a T-second block): the window adds its decay to every mode's, ``window`` / omega to its damping
    ratio. An InputError naming ``exponential_window`` for a record of a test (mountid puts and removes its own
    window) or a rate that is no finite number >= 0."""
    if not (math.isfinite(window) and window >= 0):
        raise InputError("exponential_window", f"must be a finite rate >= 0 [1/s], got {window}")
    if isinstance(record, ModeTable):
        raise InputError("exponential_window", f"applies to frequency response functions, not to {A_TABLE}")
    if record.impulse is None:
        raise InputError(
            "exponential_window",
            "applies to frequency response functions: a record's own window is mountid's, divided out already",
        )
    undone = np.exp(window * (record.time - record.time[0]))[:, None]
    return replace(record, data=record.data * undone, impulse=replace(record.impulse, window=window))


def with_rate(record: Record | ModeTable, rate: float) -> Record:
    """The record on a uniform grid at ``rate`` [Hz] from its first time (the sampling-rate option); an
    InputError for impulse responses (their frequency lines give their rate)."""
    if isinstance(record, ModeTable):
        raise InputError("rate", f"applies to a record's samples: {TABLE_HAS_NO}")
    if record.impulse is not None:
        raise InputError("rate", "frequency response functions: their lines give the impulse responses' rate")
    return Record(sampled_at(float(record.time[0]), len(record.time), rate), record.data, record.channels)


def sampled_at(start: float, n: int, rate: float) -> NDArray[np.float64]:
    """``n`` sample times [s] from ``start`` [s] at ``rate`` [Hz]; an InputError naming the rate where it is no
    positive number."""
    if not (math.isfinite(rate) and rate > 0):
        raise InputError("rate", f"must be a positive number of samples per second, got {rate}")
    return start + np.arange(n) / rate


def write_csv(record: Record, path: str | Path) -> None:
    """Write a record as CSV with its channel metadata in comment lines (see module docstring)."""
    lines = [FORMAT_LINE]
    lines += [f"# channel {json.dumps(asdict(c))}" for c in record.channels]
    lines.append(",".join(("time", *record.names)))
    table = np.column_stack([record.time, record.data])
    body = "\n".join(",".join(map(repr, row)) for row in table.tolist())  # Python floats: their shortest repr
    Path(path).write_text("\n".join(lines) + "\n" + body + "\n", encoding="utf-8")


def read_csv(
    path: str | Path, rate: float | None = None, ignore: Collection[str] = (), run: int | None = None
) -> Record:
    """Read a record written by :func:`write_csv`, or a plain CSV with a header row whose first column is
    the time [s] (channels then have unknown points and directions). ``rate`` [Hz]: the sampling rate, which
    replaces the time column's steps (see uniform_time for what is accepted without it); a file without a time
    column takes the rate its preamble states (_stated_rate) where none is given. ``ignore``: names of
    columns left unread (a bench's tachometer, microphone or spare channel: any unit, any text in its cells).
    A file whose header line recurs (an acquisition that appends each trigger's table with its header) holds a run
    per table, read one ``run`` at a time (1, 2, ...; read_csv_runs reads each)."""
    path, table = _csv_tables(path, ignore)
    if len(table.runs) == 1 and run not in (None, 1):
        raise InputError("run", f"{run}: {path.name} is a CSV of one table, which holds one run")
    held = f"{path.name} holds {len(table.runs)} runs (tables under a header line each"
    return _csv_run(path, table, chosen_run(table.runs, run, held, "one after another", "read_csv_runs"), rate, ignore)


def read_csv_runs(path: str | Path, rate: float | None = None, ignore: Collection[str] = ()) -> list[Record]:
    """Every run of a CSV (read_csv: a table under each recurrence of its header line), each a record."""
    path, table = _csv_tables(path, ignore)
    return each_run(table.runs, lambda chunk: _csv_run(path, table, chunk, rate, ignore))


@dataclass(frozen=True)
class _CsvTables:
    """A CSV's lines parted (_csv_tables): its channel metadata, its preamble (the lines before the header), the
    header line as written, and each run's header line number and lines (the header recurring parts runs)."""

    meta: dict[str, Channel]
    preamble: list[tuple[int, str]]
    head: str
    runs: list[tuple[int, list[tuple[int, str]]]]


def _csv_tables(path: str | Path, ignore: Collection[str]) -> tuple[Path, _CsvTables]:
    """The CSV at ``path`` read into its parts (_CsvTables)."""
    path = existing_file(path, "record")
    meta: dict[str, Channel] = {}
    try:
        text = path.read_text(encoding="utf-8-sig")  # a byte order mark (spreadsheet exports) is not text
    except UnicodeDecodeError as err:
        raise InputError("record", f"{path.name} is not UTF-8 text (byte {err.start}): not a CSV record") from None
    lines: list[tuple[int, str]] = []  # the table's lines with their numbers: neither blank nor comments
    for number, line in enumerate(text.splitlines(), start=1):
        if not line.strip():
            continue
        if line.startswith("# channel "):
            channel = _channel_metadata(line.removeprefix("# channel "), f"{path.name}:{number}")
            meta[channel.name] = channel
        elif not line.startswith("#"):
            lines.append((number, line))
    first = _header_index(lines, ignore)
    if not lines:
        raise InputError("record", f"{path.name} holds no table")
    head = lines[first][1]
    repeats = [k for k in range(first + 1, len(lines)) if lines[k][1].strip() == head.strip()]
    bounds = [first, *repeats, len(lines)]
    runs = [(lines[a][0], lines[a + 1 : b]) for a, b in itertools.pairwise(bounds)]
    return path, _CsvTables(meta, lines[:first], head, runs)


def _csv_run(
    path: Path,
    tables: _CsvTables,
    run: tuple[int, list[tuple[int, str]]],
    rate: float | None,
    ignore: Collection[str],
) -> Record:
    """One run of a CSV (_csv_tables) as a record: its header line number and lines under the file's header."""
    meta, head = tables.meta, tables.head
    header_line, body = run
    separator = _separator(head)
    header = [h.strip() for h in _cells(head, separator)]
    keep = _kept_columns(header, ignore, path.name)
    units = _cells(body[0][1], separator) if body and body[0][0] == header_line + 1 else []
    if _units_row(units, header, keep):
        header = [_with_unit(title, unit.strip()) for title, unit in zip(header, units, strict=True)]
        body = body[1:]
    columns = list(range(len(header))) if keep is None else keep  # the columns read, by their index in the file
    stamps = _timestamps(body, separator, path.name) if columns and columns[0] == 0 else None
    numeric = columns[1:] if stamps is not None else columns
    read = None if numeric == list(range(len(header))) else numeric
    table = _at_once(body, separator, len(header), read) if numeric else np.empty((len(body), 0))
    if table is None:
        table = _line_by_line(body, separator, header, header_line, path.name, read)
    if stamps is not None:
        table = np.column_stack([stamps, table])
    header = [header[k] for k in columns]
    meta = {name: c for name, c in meta.items() if name not in ignore}
    if not len(table):
        raise InputError("record", f"{path.name} holds no table")
    if not header[-1] and np.isnan(table[:, -1]).all():  # a separator at the end of every line (spreadsheets)
        header, table, columns = header[:-1], table[:, :-1], columns[:-1]
    for k, title in zip(columns, header, strict=True):
        if not title:
            raise InputError(f"{path.name}: column {k + 1}", f"has no name in the header (line {header_line})")
    time_unit = "s" if stamps is not None else _split_unit(header[0])[1] or "s"
    steps = np.diff(table[:, 0])
    rising = float(np.mean(steps[np.isfinite(steps)] > 0)) if np.isfinite(steps).any() else 1.0
    repeated = bool(np.all(steps[np.isfinite(steps)] >= 0))  # times that repeat, none back: written coarsely
    named = _split_unit(header[0])[0].lower() in TIME_NAMES
    first_column = table[:, 0]
    integers = bool(np.all(np.isfinite(first_column)) and np.all(first_column == np.round(first_column)))
    counted = header[0].lower() in INDEX_NAMES and integers and rising >= TIME_COLUMN_INCREASING
    timed = time_unit in TIME_UNITS and (rising >= TIME_COLUMN_INCREASING or named)
    where = f"{path.name}: column {columns[0] + 1}"
    axis, axis_unit = _split_unit(header[0])
    if stamps is None and (axis.lower() in FREQUENCY_AXIS[0] or axis_unit in FREQUENCY_AXIS[1]):
        raise InputError(
            where,
            f"{header[0]!r} is a frequency axis: a table of spectra or frequency response functions is no record of "
            "time responses (a bench's frequency response functions read as a UFF file of datasets 58, function "
            "type 4)",
        )
    stated = _stated_rate(tables.preamble) if rate is None and (counted or not timed) and stamps is None else None
    if stated is not None:  # a file without a time column whose preamble states its rate ("Sample rate;2048;Hz")
        rate = stated
    if counted and stamps is None:  # a sample index: the time at the rate given
        if rate is None:
            raise InputError(
                where,
                f"{header[0]!r} counts the samples, not the time: give the sampling rate (--rate, or 'rate' in a "
                "campaign's record)",
            )
        time, first = uniform_time(first_column / rate), 2  # a count skipped is a dropped sample, named
    elif rate is not None and not timed:  # channels only, sampled at the rate given from t = 0
        time, first = _time_column(np.zeros(len(table)), rate), 1
    elif time_unit not in TIME_UNITS:
        raise InputError(
            where,
            f"time in {time_unit!r}: the time column's unit must be s or ms (a file of channels only reads with "
            "--rate or a campaign's 'rate')",
        )
    elif rising < TIME_COLUMN_INCREASING and not (named and repeated):  # a channel in the time column's place
        raise InputError(
            where,
            f"{header[0]!r} is read as the time, but {rising:.0%} of its steps increase: a record's "
            "first column is its time (a file of channels only reads with --rate or a campaign's 'rate': every "
            "column a channel, sampled from t = 0)",
        )
    else:
        time, first = _time_column(table[:, 0] * TIME_UNITS[time_unit], rate), 2
    channels = tuple(
        _column(header[j], meta, f"{path.name}: column {columns[j] + 1}") for j in range(first - 1, len(header))
    )
    names = tuple(c.name for c in channels)
    missing = [n for n in meta if n not in names]
    if missing:
        raise InputError(missing[0], f"has metadata in {path.name} but no column")
    return Record(time, table[:, first - 1 :], channels)


RATE_NAMES = (
    "sample rate",
    "sampling rate",
    "samplerate",
    "sample frequency",
    "sampling frequency",
    "scan rate",
    "fs",
    "abtastrate",
    "abtastfrequenz",
    "fréquence d'échantillonnage",
)
"""Names (in any case) a bench's preamble gives the sampling rate under ("Sample rate;2048;Hz", "Fs = 1000 Hz")."""

_STATED_RATE = re.compile(
    r'^\s*"?(?P<name>[^:=;,\t"\[(]+?)\s*(?:[\[(](?P<head>k?Hz)[\])])?"?\s*[:=;,\t]\s*"?(?P<value>\d+(?:[.,]\d+)?(?:[eE][-+]?\d+)?)"?'
    r'\s*(?:[;,\t]\s*)?"?(?P<unit>k?Hz|S/s)?"?[;,\t\s]*$',
    re.IGNORECASE,
)
"""A preamble line that states a sampling rate: a name of RATE_NAMES, a unit in brackets after it or after the
value (Hz where none), a number (a decimal comma too)."""


def _stated_rate(preamble: list[tuple[int, str]]) -> float | None:
    """The sampling rate [Hz] a CSV's preamble (the lines before its header) states (_STATED_RATE); None where no
    line states one. Read only for a file without a time column, which without it needs --rate."""
    for _, line in preamble:
        found = _STATED_RATE.match(line)
        if found is None or found["name"].strip().lower() not in RATE_NAMES:
            continue
        unit = (found["head"] or found["unit"] or "Hz").lower()
        value = float(found["value"].replace(",", ".")) * (1e3 if unit == "khz" else 1.0)
        if value > 0:
            return value
    return None


def _timestamps(body: list[tuple[int, str]], separator: str, name: str) -> NDArray[np.float64] | None:
    """A time column of dates and times (ISO 8601, "2026-12-03 10:00:00.000", or clock times "10:00:00,000") as
    seconds from its first row; None where the first row's first cell is a number or no such time. An InputError
    naming the line of a later cell that is no such time."""
    if not body:
        return None
    first = _cells(body[0][1], separator)[0]
    if _is_numbers([first], separator) or _stamp(first) is None:
        return None
    texts = [_stamp_text(_cells(line, separator)[0]) for _, line in body]
    try:
        stamps = np.array(texts, dtype="datetime64[ns]")
    except ValueError:
        number, line = next((n, ln) for n, ln in body if _stamp(_cells(ln, separator)[0]) is None)
        cell = _cells(line, separator)[0].strip()
        raise InputError(f"{name}:{number}", f"column 1 holds {cell!r}, not a time as {first.strip()!r}") from None
    return (stamps - stamps[0]).astype(np.int64) * 1e-9


def _stamp_text(cell: str) -> str:
    """A cell of a date and time as numpy reads it: a decimal comma as a point, no "Z" (UTC) at the end, a clock
    time on a day of its own."""
    text = cell.strip().replace(",", ".").removesuffix("Z")
    return f"1970-01-01T{text}" if TIME_OF_DAY.fullmatch(text) else text


def _stamp(cell: str) -> np.datetime64 | None:
    """The date and time a cell states (_stamp_text), or None."""
    text = _stamp_text(cell)
    if not any(c.isdigit() for c in text) or ":" not in text:
        return None
    try:
        return np.datetime64(text, "ns")
    except ValueError:
        return None


def _at_once(
    body: list[tuple[int, str]], separator: str, width: int, keep: list[int] | None = None
) -> NDArray[np.float64] | None:
    """A table's rows (``body``: its lines with their numbers) read by numpy at once, five times faster than
    line by line (a minute's record of a dozen channels at 5 kHz: 7 s); None where a line needs _line_by_line
    (quotes, an empty cell, a cell that is no number, a row of another width), which reads the same numbers or
    names the line. ``keep``: the columns read (None: all of the ``width``)."""
    text = "\n".join(line for _, line in body)
    if not body or '"' in text:
        return None
    if keep is not None and any(line.count(separator) != width - 1 for _, line in body):
        return None  # numpy checks the width of the columns it reads only
    if separator != ",":  # as _values: decimal commas
        text = text.replace(",", ".")
    try:
        table = np.loadtxt(io.StringIO(text), delimiter=separator, dtype=float, ndmin=2, comments=None, usecols=keep)
    except ValueError:
        return None
    return table if table.shape == (len(body), width if keep is None else len(keep)) else None


def _kept_columns(header: list[str], ignore: Collection[str], name: str) -> list[int] | None:
    """The columns of ``header`` read, all but those ``ignore`` names (by name, without the header's unit); None
    where none is ignored. An InputError naming an ignored name the header lacks."""
    if not ignore:
        return None
    names = [_split_unit(title)[0] for title in header]
    check_ignored(ignore, names, name, "column")
    return [k for k, n in enumerate(names) if n not in ignore]


def check_ignored(ignore: Collection[str], names: list[str], file: str, what: str = "channel") -> None:
    """An InputError naming the first of the names to ``ignore`` that the file ``file`` does not hold (its
    ``names``: of each ``what``, column or channel), with the names it holds."""
    for wanted in ignore:
        if wanted not in names:
            raise InputError("ignore", f"{wanted}: no such {what} in {file} ({what}s: {', '.join(names)})")


def _line_by_line(
    body: list[tuple[int, str]],
    separator: str,
    header: list[str],
    header_line: int,
    name: str,
    keep: list[int] | None = None,
) -> NDArray[np.float64]:
    """A table's rows read line by line: each cell as _values reads it; a line that is not a row of numbers of
    the header's width is an error naming it (and where it follows the header, what it may be). ``keep``: the
    columns read (None: all)."""
    rows: list[list[float]] = []
    width = len(header) if keep is None else len(keep)
    for number, line in body:
        cells = every = _cells(line, separator)
        if keep is not None and len(cells) == len(header):
            cells = [cells[k] for k in keep]
        try:
            rows.append(_values(cells, separator))
        except ValueError:
            hint = "" if rows else f" (line {header_line} was read as the header: a line before it must start with #)"
            text = [k for k, c in enumerate(every) if not _is_numbers([c], separator) and c.strip()]
            if len(every) == len(header) and text and (rows or text[0] > 0 or ":" in every[0]):  # a column of text
                k = text[0]
                title = _split_unit(header[k])[0]
                where = f"column {k + 1} ({title!r}) holds {every[k].strip()!r}"
                if k == 0:  # a time column of another format
                    raise InputError(
                        f"{name}:{number}",
                        f"{where}, a time mountid does not read (seconds; ISO 8601 dates and times, 2026-12-03 "
                        f"10:00:00.000; clock times, 10:00:00.000): give the sampling rate and leave the column out "
                        f"(--rate R --ignore {title}; a campaign record's 'rate' and 'ignore')",
                    ) from None
                raise InputError(
                    f"{name}:{number}", f"a value is not a number: {where}{unread(_split_unit(title)[0])}"
                ) from None
            if not rows and number == header_line + 1 and cells[0].strip() in TIME_UNITS:
                other = next((c.strip() for c in cells[1:] if c.strip() and not quantity_of(c.strip())), None)
                why = f"{len(cells)} for {len(header)} columns" if other is None else f"{other!r} is not one of {KNOWN}"
                hint = f" (a row of units? {why})"
            raise InputError(f"{name}:{number}", f"a value is not a number{hint}") from None
        if len(rows[-1]) != width:
            raise InputError(f"{name}:{number}", f"{len(rows[-1])} values for {len(header)} columns")
    return np.array(rows, dtype=float).reshape(len(rows), width)


def _channel_metadata(text: str, where: str) -> Channel:
    """A "# channel" comment's JSON as a channel; an error naming ``where`` (file:line) for one that is not."""
    try:
        c = json.loads(text)
        channel = Channel(
            str(c["name"]),
            tuple(map(float, c["point"])),
            tuple(map(float, c["direction"])),
            str(c.get("quantity", "acceleration")),
            str(c.get("unit", "m/s^2")),
        )
    except (ValueError, KeyError, TypeError) as err:
        raise InputError(where, f"bad channel metadata ({err})") from None
    if any(_partly_known(v) for v in (channel.point, channel.direction)):
        why = "point and direction must be finite numbers (all NaN: not placed)"
        raise InputError(where, f"channel {channel.name}: {why}")
    return channel


def _values(cells: list[str], separator: str) -> list[float]:
    """One table row's numbers (an empty cell: NaN; the decimal commas of an export separated by semicolons or
    tabs read); a ValueError for a cell that is no number."""
    if separator != ",":  # an export separated by semicolons or tabs may write decimal commas (German locales)
        cells = [v.replace(",", ".") for v in cells]
    return [float(v) if v.strip() else math.nan for v in cells]


def _header_index(lines: list[tuple[int, str]], ignore: Collection[str] = ()) -> int:
    """Which of a CSV's table lines (neither blank nor comments) is its header: the first, unless lines of text
    come before it, as a bench export's preamble ("Exported 2026-11-30", "Sample rate: 2000 Hz"). The header is
    then the first line of at least two cells, none a number and not all units, that a row of numbers of its
    width follows (_is_data; or a row of units and then one), and not below a line of its width that could be a
    header; it is sought only before the first row of numbers. Where no line is one, the first line (whose table
    then fails to read, naming the line read as the header). The columns ``ignore`` names may hold any text."""
    names: list[str] | None = None  # the line before, where it could be a header
    for k, (_, line) in enumerate(lines):
        separator = _separator(line)
        cells = _cells(line, separator)
        if _is_numbers(cells, separator):
            break  # the table has begun: a header, if any, came before
        after, names = names, None
        if len(cells) < 2 or any(_is_numbers([c], separator) for c in cells) or _units_row(cells, cells):
            continue  # a header names its columns: no number, and not a row of units (of channels numbered)
        names = cells
        if after is not None and len(after) == len(cells):
            continue  # below a line that could be the header: a row of unknown units, not a header after a preamble
        keep = [j for j, title in enumerate(cells) if _split_unit(title.strip())[0] not in ignore]
        below = [_cells(other, separator) for _, other in lines[k + 1 : k + 3]]
        if below and _units_row(below[0], cells, keep):
            below = below[1:]
        if below and len(below[0]) == len(cells) and _is_data(below[0], keep, separator):
            return k
    return 0


def _is_data(cells: list[str], keep: list[int], separator: str) -> bool:
    """Whether a row is one of a table's rows: the cells ``keep`` (the columns read) all numbers, or the first cell
    (a number or a date and time) and most cells numbers (a column of text: a status, a comment, which then fails to
    read, naming it)."""
    if _is_numbers([cells[j] for j in keep], separator):
        return True
    numbers = [_is_numbers([c], separator) for c in cells]
    numbers[0] = numbers[0] or _stamp(cells[0]) is not None
    return numbers[0] and 2 * sum(numbers) > len(cells)


def _is_numbers(cells: list[str], separator: str) -> bool:
    """Whether a row's cells are all numbers (or empty), at least one not empty."""
    try:
        _values(cells, separator)
    except ValueError:
        return False
    return any(c.strip() for c in cells)


def _partly_known(vector: tuple[float, ...]) -> bool:
    """A metadata vector neither all finite (a placement) nor all NaN (a channel without one: write_csv writes a
    force channel's point and direction so)."""
    return not (all(map(math.isfinite, vector)) or all(map(math.isnan, vector)))


KNOWN = ", ".join(u for units in RECORDED.values() for u in units)
"""Every unit a channel may be recorded in (RECORDED), as errors list them."""

RAW_VOLTAGE = (
    ": give its sensor's sensitivity, as --sensitivity {name}=100mV/g (an accelerometer's; 2.25mV/N a force "
    "sensor's), or a campaign record's \"sensitivity\""
)
"""What an error on a channel of a raw voltage (VOLTAGE) says, formatted with the channel's ``name``."""


def unread(name: str) -> str:
    """The advice an error on channel ``name``'s quantity or unit ends with: how to leave it out, by the name the
    readers know it by (a CSV header's without its unit)."""
    return (
        f"; a channel mountid does not read (a tachometer, a microphone) is left out by its name: --ignore "
        f'{shlex.quote(name)}, or a campaign record\'s "ignore"'
    )


TIME_UNITS = {"s": 1.0, "ms": 1e-3}
"""Units a plain CSV's time column may state in its header ("Time [ms]"), and their factors to s."""

INDEX_NAMES = ("sample", "samples", "sample number", "sample no.", "index", "n", "no.", "nr.", "#")
"""Names of a first column that counts the samples (in any case, without a unit; its values rising integers): the
time is the count over the sampling rate, which must then be given (it was read as seconds: a record at 1 Hz)."""

TIME_OF_DAY = re.compile(r"\d{1,2}:\d{2}:\d{2}([.,]\d+)?")
"""A time of day, HH:MM:SS with a decimal point or comma: a time column of clock times (of one day)."""

FREQUENCY_AXIS = (("frequency", "freq", "frequenz", "fréquence", "frecuencia", "frequenza"), ("Hz", "kHz", "rad/s"))
"""Names (in any case) and units of a first column that is a frequency axis: a table of spectra or frequency response
functions, not a record (its lines were read as times, its FRFs as accelerations, and the chain said "too short for
24 exponentials")."""

TIME_NAMES = ("time", "t", "zeit", "temps", "tiempo", "tempo")
"""Names of a time column (in any case): with a sampling rate given, a first column whose steps do not rise as a
time's is a channel (a file of channels only), unless it is so named (a broken time column: an error)."""


def _units_row(cells: list[str], header: list[str], keep: list[int] | None = None) -> bool:
    """Whether a row right below the ``header`` is a row of units, as some acquisition software writes them
    ("s;m/s^2;g"): as many cells as the header, the first a time unit (or empty; or a frequency's, which the
    caller names as no record: FREQUENCY_AXIS), every other one a unit of UNITS (or empty; any text in a column
    not in ``keep``, the columns read), at least one not empty."""
    units = [c.strip() for c in cells]
    if len(units) != len(header) or not any(units) or units[0] not in ("", *TIME_UNITS, *FREQUENCY_AXIS[1]):
        return False
    read = range(len(header)) if keep is None else keep
    return all(not units[k] or quantity_of(units[k]) for k in read if k > 0)


def _with_unit(title: str, unit: str) -> str:
    """A header cell with the unit of a units row: "A_x [g]"; a cell that states a unit keeps it where the two
    agree (else an InputError naming the column)."""
    if not unit:
        return title
    stated = _split_unit(title)[1]
    if stated is not None and stated != unit:
        raise InputError(title, f"the header says {stated!r}, the units row {unit!r}")
    return title if stated is not None else f"{title} [{unit}]"


def _cells(line: str, separator: str) -> list[str]:
    """One line's cells, quotes as the csv module reads them ("0,5";"1,2" from a spreadsheet's export; a line
    without quotes is split directly, as fast)."""
    return next(csv.reader([line], delimiter=separator)) if '"' in line else line.split(separator)


def _separator(header: str) -> str:
    """The column separator of a CSV from its header row: a comma, else a semicolon, else a tab (with either of
    these two, decimal commas are read)."""
    if "," in header:
        return ","
    return ";" if ";" in header else "\t"


def _split_unit(title: str) -> tuple[str, str | None]:
    """A header cell's name and unit, as bench exports write them: "A_x [g]" (square brackets: always a unit)
    or "A_x (mm/s)" (parentheses: a unit where it is one of RECORDED (or UNIT_NAMES) or TIME_UNITS, else part of
    the name, as in "Ch(1)"); (title, None) without a unit."""
    for left, right in ("[]", "()"):
        if title.endswith(right) and left in title:
            name, unit = (part.strip() for part in title[:-1].rsplit(left, 1))
            if left == "[" or unit in TIME_UNITS or unit in FREQUENCY_AXIS[1] or quantity_of(unit_named(unit)):
                return name, unit
    return title, None


def quantity_of(unit: str) -> str | None:
    """The quantity a unit of records.RECORDED measures ("voltage" for a raw voltage; None for a unit it does not
    list)."""
    return next((q for q, units in RECORDED.items() if unit in units), None)


def _column(title: str, meta: dict[str, Channel], where: str) -> Channel:
    """A header cell as a channel: a name with mountid's channel metadata keeps it; a unit in the header sets
    the quantity (records.UNITS); a bare name is an acceleration in m/s^2."""
    if title in meta:
        return meta[title]
    name, unit = _split_unit(title)
    return channel_in(name, unit, where, f"{title!r}: ")


def channel_in(name: str, unit: str | None, where: str, said: str = "") -> Channel:
    """A channel ``name`` measuring in ``unit``, whose quantity the unit gives (UNITS; none: an acceleration in
    m/s^2); an InputError naming ``where`` (its reason starting with ``said``) for a unit mountid does not read."""
    if not unit:
        return Channel(name)
    unit = unit_named(unit)
    quantity = quantity_of(unit)
    if quantity is None:
        raise InputError(where, f"{said}unit {unit!r} is not one of {KNOWN}{unread(name)}")
    return Channel(name, quantity=quantity, unit=unit)


def _time_column(time: NDArray, rate: float | None) -> NDArray[np.float64]:
    """A file's time column as a uniform grid: at ``rate`` [Hz] from its first time when given, else
    uniform_time() (rounding accepted, dropped samples, gaps and jitter named)."""
    return uniform_time(time) if rate is None else sampled_at(float(time[0]), len(time), rate)


Placement = tuple[tuple[float, float, float], tuple[float, float, float]]
"""A channel's body point [m] and measuring direction (any length; made unit)."""


def with_geometry(record: RecordOrTable, geometry: dict[str, Placement], source: str = "channel") -> RecordOrTable:
    """The record with the named channels placed at ``geometry``'s point [m] along its direction (made unit),
    given or replacing what the file states (a plain CSV states nothing): how a test engineer places the
    channels of a bench's export. ``source`` names the option or entry in errors."""
    names = [c.name for c in record.channels]
    for name, (point, direction) in geometry.items():
        if name not in names:
            raise InputError(source, f"{name}: no such channel in the record (channels: {', '.join(names)})")
        if not all(map(math.isfinite, (*point, *direction))):
            raise InputError(source, f"{name}: point and direction must be finite numbers")
        if math.hypot(*direction) == 0:
            raise InputError(source, f"{name}: the direction is zero")
    channels = []
    for c in record.channels:
        if c.name in geometry:
            point, direction = geometry[c.name]
            size = math.hypot(*direction)  # not zero: checked above
            c = replace(c, point=tuple(map(float, point)), direction=tuple(float(v) / size for v in direction))
        channels.append(c)
    return replace(record, channels=tuple(channels))


@dataclass(frozen=True)
class Sensitivity:
    """A sensor's sensitivity: ``volts`` [V] of output per one ``unit`` of its ``quantity`` (an accelerometer's
    100 mV/g: 0.1 V per g; a force sensor's 2.25 mV/N: 0.00225 V per N)."""

    volts: float
    quantity: str
    unit: str

    def __str__(self) -> str:
        """As a data sheet writes it, in mV per unit to 12 digits (records.sensitivity reads it back)."""
        return f"{self.volts * 1e3:.12g}mV/{self.unit if '/' not in self.unit else f'({self.unit})'}"


def sensitivity(text: str, where: str) -> Sensitivity:
    """A sensitivity as a data sheet writes it: a number (a decimal comma too), a voltage unit (VOLTAGE), a slash and
    the unit measured (UNITS; in parentheses where it holds a slash of its own): 100mV/g, 10.2 mV/(m/s^2), 2,25
    mV/N. An InputError naming ``where`` for text that is none, or a value that is no finite number > 0."""
    form = "a number, a voltage unit and the unit measured, as 100mV/g, 10.2mV/(m/s^2) or 2.25mV/N"
    left, slash, right = text.strip().partition("/")
    volts = next((v for v in sorted(VOLTAGE, key=len, reverse=True) if left.strip().endswith(v)), None)
    unit = right.strip().removeprefix("(").removesuffix(")").strip()
    if not slash or volts is None:
        raise InputError(where, f"{text!r} is no sensitivity: {form}")
    number = left.strip().removesuffix(volts).strip()
    if number.count(",") == 1 and "." not in number:  # a decimal comma, as a European setup sheet writes it
        number = number.replace(",", ".")
    try:
        value = float(number)
    except ValueError:
        raise InputError(where, f"{text!r}: no number before {volts} ({form})") from None
    quantity = quantity_of(unit)
    if quantity in (None, "voltage"):  # a sensitivity says what the volts measure: a unit of UNITS
        known = ", ".join(u for units in UNITS.values() for u in units)
        raise InputError(where, f"{text!r}: {unit!r} is not one of {known}")
    if not (math.isfinite(value) and value > 0):
        raise InputError(
            where, f"{text!r}: must be a finite number > 0 (a sensor mounted the other way: reverse its direction)"
        )
    return Sensitivity(value * VOLTAGE[volts], quantity, unit)


def with_sensitivities(
    record: RecordOrTable, sensitivities: dict[str, Sensitivity], source: str = "sensitivity"
) -> RecordOrTable:
    """The record with the named channels of a raw voltage (VOLTAGE) converted by their sensors' sensitivities into
    the quantity and unit each measures (a bench's acquisition that records volts and leaves the sensitivities to the
    analysis). ``source`` names the option or entry in errors: a channel not in the record, or not in volts."""
    reference = record.impulse.per_volt if isinstance(record, Record) and record.impulse is not None else ""
    names = [c.name for c in record.channels] + ([reference] if reference else [])
    for name in sensitivities:
        if name not in names:
            raise InputError(source, f"{name}: no such channel in the record (channels: {', '.join(names)})")
    if isinstance(record, ModeTable):
        raise InputError(source, f"applies to a channel in volts, not to {A_TABLE}")
    if reference in sensitivities:  # functions per volt of the hammer: times its volts per N, per N
        given = sensitivities[reference]
        if given.quantity != "force":
            raise InputError(source, f"{reference}: the reference's sensitivity is per force, not per {given.unit}")
        volts_per_newton = given.volts / UNITS["force"][given.unit]
        record = replace(record, data=record.data * volts_per_newton, impulse=replace(record.impulse, per_volt=""))
    channels, factors = [], np.ones(len(record.channels))
    for k, c in enumerate(record.channels):
        if c.name in sensitivities:
            s = sensitivities[c.name]
            if c.quantity != "voltage":
                raise InputError(source, f"{c.name}: is recorded in {c.unit} already, not in volts")
            factors[k] = VOLTAGE[c.unit] / s.volts
            c = replace(c, quantity=s.quantity, unit=s.unit)
        channels.append(c)
    return replace(record, data=record.data * factors, channels=tuple(channels))


OTHER_FORMATS = {
    ".mat": "a MATLAB file",
    ".xlsx": "an Excel workbook",
    ".xls": "an Excel workbook",
    ".ods": "a spreadsheet",
    ".h5": "an HDF5 file",
    ".hdf5": "an HDF5 file",
    ".dxd": "a Dewesoft data file",
    ".d7d": "a Dewesoft data file",
    ".mf4": "an ASAM MDF file",
    ".mdf": "an ASAM MDF file",
    ".ldsf": "a Simcenter Testlab file",
    ".wav": "a sound file",
    ".json": "a JSON file (a campaign or a report, not a record)",
    ".toml": "a TOML file (a machine description, not a record)",
}
"""Files a bench writes that mountid does not read, by extension: named with the formats it reads (they were read
as CSV: "not UTF-8 text", "holds no table"); so are mountid's own campaigns and descriptions given as a record."""


def _not_another_format(path: str | Path) -> None:
    """An InputError naming a file of another format (OTHER_FORMATS) with the formats mountid reads."""
    what = OTHER_FORMATS.get(Path(path).suffix.lower())
    if what is not None:
        existing_file(path, "record")
        raise InputError(
            "record",
            f"{Path(path).name} is {what}: mountid reads CSV (a text table), UFF (.uff, .unv: datasets 58, 55), "
            "TDMS (.tdms) and LVM (.lvm); export the record as one of them",
        )


def read_record(
    path: str | Path, rate: float | None = None, ignore: Collection[str] = (), run: int | None = None
) -> Record | ModeTable:
    """Read a record file: UFF (.uff, .unv: types 58 and 2411, mountid.measurement.uff; a table of modes from one of
    mode shapes, datasets 55: mountid.measurement.uff_modes), TDMS (.tdms, mountid.measurement.tdms), LVM (.lvm,
    mountid.measurement.lvm) or CSV (read_csv); ``rate`` [Hz] and ``ignore`` (channels left unread) as in read_csv,
    ``run`` as in read_uff, read_tdms, read_lvm and read_csv (a CSV's tables under a recurring header)."""
    kind = str(path).lower()
    _not_another_format(path)
    if kind.endswith((".uff", ".unv")):
        from mountid.measurement.uff import read_uff  # pyuff is an extra: imported only for UFF files

        record = read_uff(path, ignore, run)
        return record if rate is None else with_rate(record, rate)
    if kind.endswith(".tdms"):
        from mountid.measurement.tdms import read_tdms  # npTDMS is an extra: imported only for TDMS files

        return read_tdms(path, ignore, rate, run)
    if kind.endswith(".lvm"):
        from mountid.measurement.lvm import read_lvm  # lvm_read is an extra: imported only for LVM files

        return read_lvm(path, ignore, rate, run)
    return read_csv(path, rate, ignore, run)


def chosen_run(runs: Sequence[Run], run: int | None, held: str, parted: str, reader: str) -> Run:
    """The run ``run`` (1, 2, ...; None: the only one) of a file's ``runs``; an InputError naming them where the file
    holds several and none is given, or the run is not one of them (uff.read_uff, tdms.read_tdms). ``held``: what
    the file holds, its parenthesis open ("hit.uff holds 2 runs (datasets 58 of 8, 8 channels"); ``parted``: how its
    runs are told apart; ``reader``: the function that reads each."""
    if run is None and len(runs) == 1:
        return runs[0]
    if run is None:
        raise InputError("run", f"{held}, {parted}): give the run to read ({reader} reads each)")
    if not 1 <= run <= len(runs):
        raise InputError("run", f"{run}: {held}), runs 1 to {len(runs)}")
    return runs[run - 1]


def each_run(runs: Sequence[Run], read: Callable[[Run], RecordOrTable]) -> list[RecordOrTable]:
    """Each of a file's ``runs`` read as a record (``read``); a reader's error names its run ("run 2: ...") where
    the file holds several (uff.read_uff_runs, tdms.read_tdms_runs)."""
    records = []
    for k, run in enumerate(runs, start=1):
        try:
            records.append(read(run))
        except InputError as err:
            raise err if len(runs) == 1 else type(err)(err.parameter, f"run {k}: {err.reason}") from None
    return records


def read_runs(
    path: str | Path, rate: float | None = None, ignore: Collection[str] = ()
) -> list[Record] | list[ModeTable]:
    """Every run a record file holds, each a record as read_record reads it: a UFF file's runs (the hits of a test
    exported one after another, a dataset per channel each: uff.read_uff_runs), a TDMS file's (groups of the same
    channels: tdms.read_tdms_runs), an LVM file's (segments of the same channels: lvm.read_lvm_runs), a CSV's (its
    tables under a recurring header line: read_csv_runs)."""
    kind = str(path).lower()
    if kind.endswith((".uff", ".unv")):
        from mountid.measurement.uff import read_uff_runs  # pyuff is an extra: imported only for UFF files

        return [r if rate is None else with_rate(r, rate) for r in read_uff_runs(path, ignore)]
    if kind.endswith(".tdms"):
        from mountid.measurement.tdms import read_tdms_runs

        return read_tdms_runs(path, ignore, rate)
    if kind.endswith(".lvm"):
        from mountid.measurement.lvm import read_lvm_runs

        return read_lvm_runs(path, ignore, rate)
    _not_another_format(path)
    return read_csv_runs(path, rate, ignore)


def named_runs(
    path: str | Path,
    name: str,
    rate: float | None = None,
    ignore: Collection[str] = (),
    run: int | None = None,
    window: float | None = None,
) -> list[tuple[str, Record | ModeTable]]:
    """The records of a record file, each with its name in notes: the run ``run`` gives ("``name`` run K",
    read_record), else every run (read_runs), "``name`` run 1", ... where the file holds several, ``name`` where
    it holds one; ``window`` [1/s]: a bench's exponential window divided out of frequency response functions
    (without_window)."""
    if run is not None:
        named = [(f"{name} run {run}", read_record(path, rate, ignore, run))]
    else:
        records = read_runs(path, rate, ignore)
        named = [(name if len(records) == 1 else f"{name} run {k}", r) for k, r in enumerate(records, start=1)]
    return named if window is None else [(n, without_window(r, window)) for n, r in named]
