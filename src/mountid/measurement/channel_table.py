"""A test's channel table: where each channel sits, along which direction, and its sensor's sensitivity, as a test
engineer documents a setup in a spreadsheet beside the records (the command line's --channels FILE, a campaign
record's "channel_table").

A CSV (comma, semicolon or tab separated; lines starting with # are comments) with a header naming its columns in
any case and order:

    name,x,y,z,direction,sensitivity
    A_x,0.45,0,0.1,+x,100mV/g
    B_y,0.45,0,0.312,0 1 0,98.7mV/g

``name`` (or ``channel``, ``channel name``, ``sensor``, ``label``) the channel's name in the records; ``x``,
``y``, ``z`` the point [m] (a header unit, "x [mm]", in mm or m); the direction either in one column
``direction`` (a signed axis, "+x", "-y", or three numbers separated by spaces) or three ``dx``, ``dy``, ``dz``;
``sensitivity`` optional (records.sensitivity: a channel the record holds in volts is converted by it; empty for a
channel recorded in its unit). A row whose point and direction are empty gives its channel's sensitivity only (a
hammer's force, at another point each hit). Every error names the file, the line and the column.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

from mountid.errors import InputError, existing_file
from mountid.measurement.records import (
    ModeTable,
    Placement,
    RecordOrTable,
    Sensitivity,
    sensitivity,
    with_geometry,
    with_sensitivities,
)
from mountid.nomenclature import axis_direction

NAME_COLUMNS = ("name", "channel", "channel name", "channel_name", "sensor", "label")
"""What the column of the channels' names may be called (in any case)."""

LENGTH_UNITS = {"": 1.0, "m": 1.0, "mm": 1e-3}
"""Units the point's columns may state in their header ("x [mm]"), and their factors to m."""


@dataclass(frozen=True)
class ChannelTable:
    """A channel table read (read_channel_table): each channel's point [m] and unit direction, and the
    sensitivities it gives."""

    placements: dict[str, Placement]
    sensitivities: dict[str, Sensitivity]


def read_channel_table(path: str | Path) -> ChannelTable:
    """The channel table at ``path`` (see the module docstring); an InputError naming the file, the line and the
    column for anything it cannot read."""
    path = existing_file(path, "channels")
    try:
        text = path.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError as err:
        raise InputError("channels", f"{path.name} is not UTF-8 text (byte {err.start})") from None
    numbered = enumerate(text.splitlines(), start=1)
    lines = [(k, line) for k, line in numbered if line.strip() and not line.startswith("#")]
    if not lines:
        raise InputError("channels", f"{path.name} holds no table")
    number, head = lines[0]
    separator = "," if "," in head else ";" if ";" in head else "\t"
    rows = list(csv.reader([line for _, line in lines], delimiter=separator))
    header = [cell.strip() for cell in rows[0]]
    columns = {_name(cell): k for k, cell in enumerate(header)}
    scales = {_name(cell): LENGTH_UNITS.get(_unit(cell), math.nan) for cell in header}
    where = f"{path.name}:{number}"
    name_column = next((columns[n] for n in NAME_COLUMNS if n in columns), None)
    missing = [c for c in ("x", "y", "z") if c not in columns]
    if name_column is None or missing:
        raise InputError(where, f"the header needs the columns name, x, y, z and a direction: it names {header}")
    for axis in ("x", "y", "z"):
        if math.isnan(scales[axis]):
            raise InputError(where, f"{header[columns[axis]]!r}: a point's unit is m or mm")
    if "direction" not in columns and not all(c in columns for c in ("dx", "dy", "dz")):
        raise InputError(where, "the header needs a column direction (+x, -y, or 'dx dy dz') or three: dx, dy, dz")
    placements: dict[str, Placement] = {}
    sensitivities: dict[str, Sensitivity] = {}
    for (number, _), cells in zip(lines[1:], rows[1:], strict=True):
        cells = [c.strip() for c in cells] + [""] * (len(header) - len(cells))
        where = f"{path.name}:{number}"
        name = cells[name_column]
        if not name:
            raise InputError(where, "a channel without a name")
        if name in placements or name in sensitivities:
            raise InputError(where, f"{name}: given twice")
        place = [cells[columns[c]] for c in ("x", "y", "z", "direction", "dx", "dy", "dz") if c in columns]
        if any(place):  # a row without a point and direction (a roving hammer's force): its sensitivity only
            point = tuple(_number(cells[columns[a]], f"{where} {a}") * scales[a] for a in ("x", "y", "z"))
            placements[name] = (point, _direction(cells, columns, where))  # type: ignore[assignment]
        given = cells[columns["sensitivity"]] if "sensitivity" in columns else ""
        if given:
            sensitivities[name] = sensitivity(given, f"{where} sensitivity")
    if not placements and not sensitivities:
        raise InputError("channels", f"{path.name} holds a header and no channel")
    return ChannelTable(placements, sensitivities)


def _name(cell: str) -> str:
    """A header cell's column name: lower case, without its unit ("X [mm]": "x")."""
    return cell.split("[")[0].split("(")[0].strip().lower()


def _unit(cell: str) -> str:
    """A header cell's unit in brackets or parentheses ("" where it states none)."""
    for left, right in ("[]", "()"):
        if left in cell and cell.rstrip().endswith(right):
            return cell.rsplit(left, 1)[1].rstrip()[:-1].strip()
    return ""


def _number(text: str, where: str) -> float:
    try:
        value = float(text.replace(",", "."))
    except ValueError:
        raise InputError(where, f"{text!r} is not a number") from None
    if not math.isfinite(value):
        raise InputError(where, f"{text!r} is not a finite number")
    return value


def _direction(cells: list[str], columns: dict[str, int], where: str) -> tuple[float, float, float]:
    """A row's direction: its column ``direction`` (a signed axis, or three numbers separated by spaces), else
    dx, dy, dz; not zero."""
    if "direction" in columns:
        text = cells[columns["direction"]]
        axis = axis_direction(text)
        if axis is not None:
            return axis
        parts = text.split()
        if len(parts) != 3:
            raise InputError(f"{where} direction", f"{text!r}: a signed axis (+x, -y, z) or three numbers 'dx dy dz'")
        values = tuple(_number(v, f"{where} direction") for v in parts)
    else:
        values = tuple(_number(cells[columns[c]], f"{where} {c}") for c in ("dx", "dy", "dz"))
    if not any(values):
        raise InputError(f"{where} direction", "is zero")
    return values  # type: ignore[return-value]


def applied(record: RecordOrTable, table: ChannelTable, source: str = "channels") -> RecordOrTable:
    """The record with the table's placements of its channels (records.with_geometry) and their sensitivities
    where the record holds them in volts (records.with_sensitivities; a channel the file gives in its unit is
    calibrated already); channels the table lists and the record lacks are the test's others (a roving test's). An
    InputError naming ``source`` where the table names none of the record's channels."""
    names = set(record.names)
    placed = {name: placement for name, placement in table.placements.items() if name in names}
    if not placed and not names & set(table.sensitivities):
        listed = ", ".join({**table.placements, **table.sensitivities})
        raise InputError(source, f"names none of the record's channels ({', '.join(record.names)}; it lists {listed})")
    record = with_geometry(record, placed, source) if placed else record
    if isinstance(record, ModeTable):
        return record
    volts = {c.name for c in record.channels if c.quantity == "voltage"}
    scales = {name: s for name, s in table.sensitivities.items() if name in volts}
    return with_sensitivities(record, scales, source) if scales else record


def set_up(
    record: RecordOrTable,
    sensitivities: dict[str, Sensitivity],
    table: ChannelTable | None,
    placements: dict[str, Placement],
    sources: tuple[str, str, str] = ("sensitivity", "channel_table", "channels"),
) -> RecordOrTable:
    """The record as the test's setup says, given one by one or in a table (the command line's --sensitivity,
    --channels, --channel; a campaign record's "sensitivity", "channel_table", "channels"; ``sources`` name them in
    errors, in that order): the sensitivities given one by one first (a channel they convert is no longer in volts
    for the table's), the table next (applied), the placements given one by one last (they replace its rows)."""
    if sensitivities:
        record = with_sensitivities(record, sensitivities, sources[0])
    if table is not None:
        record = applied(record, table, sources[1])
    return with_geometry(record, placements, sources[2]) if placements else record
