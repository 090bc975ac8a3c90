"""Parsing and checking command-line values, shared by the commands: every bad value is an InputError
naming the option (one line, exit code 2)."""

from __future__ import annotations

import argparse
import math
import re
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from mountid.errors import InputError
from mountid.machine import Machine
from mountid.nomenclature import SPEED_UNITS, axis_direction, in_rad_per_s
from mountid.report.jsonable import dumps

if TYPE_CHECKING:
    from mountid.measurement.records import ModeTable, Record, Sensitivity
    from mountid.measurement.rig import Unbalance


NEGATIVE_VALUES = re.compile(
    r"^-\d*\.?\d+(?:[eE][-+]?\d+)?(?:[,:][-+]?\d*\.?\d+(?:[eE][-+]?\d+)?)*(?:\s*[A-Za-z/]+)?$|^-[xyzXYZ]$"
)
"""What argparse takes for a value, not an option, where it begins with "-": a negative number, a point or
direction of them (``--hit-point -0.35,0.25,0.3``, ``--point -0.45,0,0.3``: argparse's own rule, negative numbers
alone, read those as unknown options and said "expected one argument"), a number with its unit (``--speed
-5rpm``: named then as no positive speed), and a negative axis (``--hit-direction -z``)."""


class Parser(argparse.ArgumentParser):
    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = NEGATIVE_VALUES  # argparse's own attribute, read by its parse of options

    def error(self, message: str) -> None:  # one line, exit 2 (argparse would print the usage too)
        raise InputError("arguments", message)


def file_to_write(text: str, option: str, suffixes: dict[str, str]) -> Path:
    """The path of a file ``option`` names to write: in a folder that exists, with one of ``suffixes`` (suffix:
    what such a file holds, for the error: "a file ending in .csv or .txt (text), .tdms (TDMS)"), else an
    InputError naming the option (a missing folder was a traceback from the writer's library)."""
    path = Path(text)
    if not path.parent.is_dir():
        raise InputError(option, f"the folder {str(path.parent)!r} does not exist")
    if path.suffix.lower() not in suffixes:
        kinds: dict[str, list[str]] = {}
        for suffix, what in suffixes.items():
            kinds.setdefault(what, []).append(suffix)
        named = ", ".join(f"{' or '.join(endings)} ({what})" for what, endings in kinds.items())
        raise InputError(option, f"{path.name}: name a file ending in {named}")
    return path


def speed(text: str) -> float:
    """A --speed value [rad/s]: a number, or one with a unit of nomenclature.SPEED_UNITS ("1500rpm", "25Hz")."""
    try:
        return in_rad_per_s(text, SPEED_UNITS)
    except ValueError as err:
        raise argparse.ArgumentTypeError(str(err)) from None


def pairs(items: Sequence[str] | None, option: str, units: dict[str, float] | None = None) -> dict[str, float]:
    """``name=value`` items of ``option`` as a dict of floats; an item without "=", a value that is not a number
    or NaN, or a name given twice is an InputError naming the option and the name ("--std x: is NaN"). With
    ``units`` (nomenclature.FREQUENCY_UNITS) a value may carry one of them ("x=2.82Hz"), converted to rad/s."""
    out: dict[str, float] = {}
    for item in items or ():
        name, sep, text = item.partition("=")
        name = name.strip()
        if not sep or not name:
            raise InputError(option, f"expected name=value, got {item!r}")
        try:
            value = float(text) if units is None else in_rad_per_s(text, units)
        except ValueError as err:
            reason = f"not a number: {text!r}" if units is None else str(err)
            raise InputError(f"{option} {name}", reason) from None
        if math.isnan(value):
            raise InputError(f"{option} {name}", "is NaN")
        if name in out:
            raise InputError(f"{option} {name}", "given twice")
        out[name] = value
    return out


def print_json(obj: object) -> None:
    print(dumps(obj))


def defaults_note(machine: Machine, defaults: dict[str, float]) -> None:
    """The text note naming the parameters that took the description's nominal value."""
    if defaults:
        values = ", ".join(f"{n} = {v:g} {machine.parameters[n]['unit']}" for n, v in defaults.items())
        print(f"note: not given, the description's nominal values are used: {values}")


def finite_number(value: float, option: str, minimum: float = 0.0, strict: bool = True, unit: str = "") -> float:
    """A command-line number that must be finite and above (``strict``) or at least ``minimum``; ``unit``: the
    unit the value is in when the option took another (a speed in rpm converted to rad/s), said in the error."""
    if not math.isfinite(value) or value < minimum or (strict and value == minimum):
        bound = "positive" if strict and minimum == 0 else f"{'>' if strict else '>='} {minimum:g}"
        raise InputError(option, f"must be {bound} and finite, got {value}" + (f" {unit}" if unit else ""))
    return value


def paper_unbalance(args: argparse.Namespace) -> dict[str, str]:
    """The paper's eccentric weight (validation.paper.UNBALANCE) where simulate's or forced's --unbalance-mass or
    --eccentricity is not given; returns what was filled in by option ({"--unbalance-mass": "unbalance mass 43.1
    kg"}), for the note that says so on another machine than the paper's."""
    from mountid.validation.paper import UNBALANCE

    filled = {}
    if args.unbalance_mass is None:
        args.unbalance_mass = UNBALANCE["mass"]
        filled["--unbalance-mass"] = f"unbalance mass {args.unbalance_mass:g} kg"
    if args.eccentricity is None:
        args.eccentricity = UNBALANCE["eccentricity"]
        filled["--eccentricity"] = f"eccentricity {args.eccentricity:g} m"
    return filled


def check_unbalance(args: argparse.Namespace) -> None:
    """The rotating-unbalance options of simulate and forced: speeds positive, mass and eccentricity >= 0, the
    eccentricity within POINT_LIMIT (the mass against the machine's: unbalance_within)."""
    for w in args.speed or ():
        finite_number(w, "--speed", unit="rad/s")
    finite_number(args.unbalance_mass, "--unbalance-mass", strict=False)
    bounded(args.eccentricity, "--eccentricity", POINT_LIMIT, " m", strict=False)


def unbalances_of(args: argparse.Namespace) -> list[Unbalance]:
    """The rotating unbalance of simulate --speed and forced at each of its speeds: --unbalance-mass at
    --eccentricity about the axis through --unbalance-point along --unbalance-axis."""
    from mountid.measurement.rig import Unbalance

    point = point_on_machine(args.unbalance_point, "--unbalance-point")
    axis = direction(args.unbalance_axis, "--unbalance-axis")
    axis = tuple(v / math.hypot(*axis) + 0.0 for v in axis)
    return [Unbalance(args.unbalance_mass, args.eccentricity, w, point, axis) for w in args.speed or ()]


def unbalance_within(args: argparse.Namespace, mass: float) -> None:
    """--unbalance-mass at most the machine's vibrating ``mass`` [kg]: the unbalance is one of its parts."""
    if args.unbalance_mass > mass:
        raise InputError(
            "--unbalance-mass",
            f"{args.unbalance_mass:g} kg is more than the machine's vibrating mass {mass:g} kg, of which it is part",
        )


MAX_SAMPLES = 10_000_000
"""Most samples per channel a simulated or planned record may hold (80 MB per channel in memory)."""

POINT_LIMIT = 100.0
"""The largest coordinate [m] of a sensor or hit point: on a machine on isolators, within 100 m of its origin (a
point 1e300 m away overflowed)."""

NOISE_LIMIT = 100.0
"""The largest channel noise, relative to the channel's RMS: at 100 times its signal a channel measures nothing."""

HIT_PEAK_LIMIT = 1e7
"""The largest hit peak [N]: fifty times the largest modal impact hammers (a peak of 1e300 N overflowed)."""

HIT_TIME = 0.05
"""[s] When simulate's hit begins by default (--hit-time): a shaker drives from the start instead."""


def record_size(duration: float, rate: float) -> None:
    """--duration and --rate: positive, finite, and from MIN_SAMPLES to MAX_SAMPLES samples per channel together."""
    from mountid.measurement.records import MIN_SAMPLES

    finite_number(duration, "--duration")
    finite_number(rate, "--rate")
    if round(duration * rate) < MIN_SAMPLES:
        raise InputError(
            "--duration",
            f"{duration:g} s at {rate:g} Hz is {round(duration * rate)} samples per channel; a record needs at least "
            f"{MIN_SAMPLES}: a longer --duration or a higher --rate",
        )
    if duration * rate > MAX_SAMPLES:
        raise InputError(
            "--duration",
            f"{duration:g} s at {rate:g} Hz is {duration * rate:.3g} samples per channel; at most {MAX_SAMPLES:.0e}",
        )


def bounded(value: float, option: str, limit: float, unit: str, strict: bool = True) -> float:
    """A finite number above (``strict``) or at least 0 and at most ``limit``."""
    finite_number(value, option, strict=strict)
    if value > limit:
        raise InputError(option, f"{value:g}{unit} is beyond {limit:g}{unit}")
    return value


def writable(path: str, option: str) -> None:
    """Refuse a file path whose folder is a file (or under one): the write would fail after the work."""
    for parent in Path(path).parents:
        if parent.exists():
            if not parent.is_dir():
                raise InputError(option, f"{str(parent)!r} is a file, not a folder")
            return


def triple(text: str, option: str) -> tuple[float, float, float]:
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        raise InputError(option, f"expected three numbers x,y,z, got {text!r}") from None
    if len(values) != 3 or not all(map(math.isfinite, values)):
        raise InputError(option, f"expected three finite numbers x,y,z, got {text!r}")
    return values  # type: ignore[return-value]


def direction(text: str, option: str) -> tuple[float, float, float]:
    """A direction dx,dy,dz: three finite numbers, not all zero (its length does not matter), or a signed axis
    ("+x", "-y", "z": nomenclature.axis_direction)."""
    axis = axis_direction(text)
    if axis is not None:
        return axis
    try:
        values = triple(text, option)
    except InputError as err:
        raise InputError(option, f"{err.reason}, or an axis (+x, -y, z)") from None
    if not any(values):
        raise InputError(option, f"{text!r}: a direction must not be zero")
    return values


def placements(items: Sequence[str] | None, option: str) -> dict[str, tuple[tuple[float, ...], tuple[float, ...]]]:
    """Channel placements from NAME=x,y,z:dx,dy,dz items: {name: (point [m], direction)}; a name given twice is
    an InputError (two channels of one name: the record could not tell them apart)."""
    out = {}
    for item in items or ():
        name, sep, rest = item.partition("=")
        point, sep2, towards = rest.partition(":")
        name = name.strip()
        if not sep or not sep2 or not name:
            raise InputError(option, f"expected NAME=x,y,z:dx,dy,dz, got {item!r}")
        if name in out:
            raise InputError(f"{option} {name}", "given twice")
        out[name] = (point_on_machine(point, option), direction(towards, f"{option} {name}"))
    return out


def point_on_machine(text: str, option: str) -> tuple[float, float, float]:
    """A point x,y,z [m] on the machine: three finite numbers, each within POINT_LIMIT."""
    values = triple(text, option)
    if max(map(abs, values)) > POINT_LIMIT:
        raise InputError(option, f"{text!r}: a point on the machine lies within {POINT_LIMIT:g} m of its origin")
    return values


def read_runs(args: argparse.Namespace) -> list[tuple[str, Record | ModeTable]]:
    """The records of the file args.record, each with its name in notes (records.named_runs; --rate, --ignore and
    --run as records.read_record takes them, --exponential-window as records.without_window): the run --run gives
    ("PATH run K"), else every run of a UFF or TDMS file of several ("PATH run 1", ...), else the file's one record
    (PATH); a table of modes where the file holds a bench's mode shapes. --channels applies a channel table
    (measurement.channel_table), --channel places channels, --sensitivity converts channels of a raw voltage."""
    from mountid.measurement.channel_table import read_channel_table, set_up
    from mountid.measurement.records import named_runs

    if args.rate is not None:
        finite_number(args.rate, "--rate")
    table = None if args.channels is None else read_channel_table(args.channels)
    geometry = placements(args.channel, "--channel")
    scales = sensitivities(args.sensitivity, "--sensitivity")
    try:
        records = named_runs(
            args.record, args.record, args.rate, tuple(args.ignore or ()), args.run, args.exponential_window
        )
    except InputError as err:
        if err.parameter not in ("ignore", "run"):
            raise
        raise InputError(f"--{err.parameter}", err.reason) from None
    sources = ("--sensitivity", "--channels", "--channel")
    return [(name, set_up(r, scales, table, geometry, sources)) for name, r in records]


def sensitivities(items: Sequence[str] | None, option: str) -> dict[str, Sensitivity]:
    """Sensors' sensitivities from NAME=SENSITIVITY items (records.sensitivity: 100mV/g, 2.25mV/N); a name given
    twice is an InputError."""
    from mountid.measurement.records import sensitivity

    out = {}
    for item in items or ():
        name, sep, text = item.partition("=")
        name = name.strip()
        if not sep or not name:
            raise InputError(option, f"expected NAME=SENSITIVITY (as A_x=100mV/g), got {item!r}")
        if name in out:
            raise InputError(f"{option} {name}", "given twice")
        out[name] = sensitivity(text, f"{option} {name}")
    return out


def beyond_first_order(values: dict[str, float], std: dict[str, float] | None, indent: str = "      ") -> None:
    """A note where a first-order standard deviation reaches half its value: the linearisation it comes from
    no longer describes the uncertainty (a stiffness cannot go below zero); the frequencies, at the stated
    uncertainty, hardly determine that unknown."""
    wide = [n for n, v in values.items() if std is not None and std[n] >= 0.5 * abs(v)]
    if not wide:
        return
    if len(wide) == 1:
        what, it = f"the standard deviation of {wide[0]} is half its value or more", "it"
    else:
        what, it = f"the standard deviations of {', '.join(wide)} are half their values or more", "them"
    tail = f"first order does not hold there; at this uncertainty the frequencies hardly determine {it}"
    print(f"{indent}note: {what}: {tail}")
