"""Records in the Universal File Format, dataset 58 (function at nodal DOF), read and written by pyuff.

One dataset 58 per channel: a time response (function type 1, or 0 over time), real, evenly spaced abscissa; a
spectrum or complex data is an error naming the channel, and a label that says NONE (what writers put in an empty
one) is empty. A file of frequency response functions (function type 4, a bench's hammer test exported as
such, with their coherences) is read as the impulse responses they transform back to, a run per input (reference
node and direction): Record.impulse; a multiple coherence beside them (function type 26: a bench's MIMO export,
several inputs at once) is every run's coherence and marks the runs as one measurement (Lines.together). A
channel of a quantity mountid does not read (ordinate type: a pressure, a reaction force, a speed) is an error naming
it, and left out by name (read_uff's ``ignore``). A file
of several runs (the hits of a test one after another, a dataset per channel each; a roving test's, where a node and
direction recurs) is read one run at a time. A file of mode shapes (datasets 55 or 2414, no 58) is a bench's table
of modes, read by uff_modes; the geometry of both is uff_geometry's.
The channel name is ID line 1; its point [m] and unit direction are ID line 4 (``mountid point=x,y,z dir=dx,dy,dz``),
its quantity and unit ID line 5. The response node is the channel number; the response direction the
axis (+-1, 2, 3) when the direction lies along one, 0 otherwise. Files from other software read too: a
channel without the ID-line-4 metadata sits at its response node's coordinates where the file holds its
geometry (datasets 15 or 2411, in the length unit of dataset 164, converted to m) and measures along its
response direction's axis (+-1, 2, 3 for x, y, z); else its point and direction are NaN (processing that needs
them says so). A node's coordinates are in its definition coordinate system and its directions along the axes
of its displacement coordinate system, as datasets 15 and 2411 name them: Cartesian systems the file defines in
a dataset 2420 (the transformation's rows 1-3 the local axes in global coordinates, row 4 the origin) or in the
older dataset 18 (an origin, a point on the +x axis and a point in the +xz plane, given in a reference system,
which may itself be one of the file's) are applied; labels 0 and 1 the file does not define are the global
system; any other, a cylindrical or spherical system, a reference chain that does not end in the global system,
or one label defined differently by both datasets, is an error naming it. The global coordinates are taken as
the description's (origin and axes): a test bench's geometry in another frame must be moved there first.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Sequence
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pyuff

from mountid.errors import InputError, existing_file
from mountid.measurement.records import (
    RECORDED,
    TIME_UNITS,
    UNITS,
    VOLTAGE,
    Channel,
    ModeTable,
    Record,
    check_ignored,
    chosen_run,
    each_run,
    impulse_record,
    quantity_of,
    unit_named,
    unread,
)
from mountid.measurement.uff_geometry import node_geometry, read_set, whole
from mountid.measurement.uff_modes import holds_mode_shapes, read_table, read_tables
from mountid.nomenclature import counted

if TYPE_CHECKING:
    from mountid.measurement.frf import FrfEstimate

_TAG = "mountid point="


_ORDINATE_TYPES = {8: "displacement", 11: "velocity", 12: "acceleration", 13: "force"}
"""UFF 58 ordinate specific data types mountid reads (the others are read as acceleration)."""

_ORDINATE_TYPE_OF = {quantity: kind for kind, quantity in _ORDINATE_TYPES.items()}
"""The UFF 58 ordinate data type the writers give a quantity (0, unknown, for one not in _ORDINATE_TYPES)."""

_WRITTEN_58 = {
    "binary": 0,
    "ver_num": 0,
    "load_case_id": 0,
    "abscissa_spacing": 1,
    "z_axis_value": 0.0,
    "z_axis_spec_data_type": 0,
    "z_axis_axis_units_lab": "",
    **{
        f"{part}_{what}_unit_exp": 0
        for part in ("abscissa", "ordinate", "orddenom", "z_axis")
        for what in ("len", "force", "temp")
    },
}
"""The fields of a dataset 58 both writers (dataset_58's time responses, write_frf's functions) give alike: double
precision ASCII, evenly spaced abscissa, no load case, no z axis, units in SI (no exponents)."""


def _axis(direction: tuple[float, float, float]) -> int:
    d = np.asarray(direction, dtype=float)
    if not np.all(np.isfinite(d)):
        return 0
    k = int(np.argmax(np.abs(d)))
    return int(np.sign(d[k])) * (k + 1) if np.isclose(abs(d[k]), 1.0) and np.sum(np.abs(d)) <= 1 + 1e-12 else 0


def write_uff(record: Record, path: str | Path) -> None:
    """Write every channel as a dataset 58 (double precision ASCII) to a new file."""
    path = Path(path)
    if path.exists():
        path.unlink()  # pyuff appends to an existing file
    sets = [
        dataset_58(c, record.time, record.data[:, k], node=k + 1, axis=_axis(c.direction), id4=placement(c))
        for k, c in enumerate(record.channels)
    ]
    pyuff.UFF(str(path)).write_sets(sets, mode="add")


def write_frf(estimates: Sequence[tuple[FrfEstimate, Channel]], path: str | Path) -> None:
    """Write the H1 frequency responses of ``estimates``, each with its force channel (one per input: a record's
    runs, a roving hammer's points), to a new file as a bench exports them: per response channel a dataset 58 of
    function type 4 (complex, on the lines from 0 Hz, a response per N in the SI unit of its quantity), with its
    coherence (function type 6) where several hits or blocks were averaged. Response nodes are the channels'
    numbers, ID line 4 their point and direction (placement: mountid reads them back exactly; other tools take the
    node and the axis, 0 where oblique); each input is reference node 1000 + its number along its force channel's
    axis. ID line 3 says what H1 averages and the exponential window on the responses (a hammer's where they had not
    died out before the next hit): read back, --exponential-window divides it out. The inputs of several shakers at
    once (FrfEstimate.together) are one measurement, written to a file of its own: their multiple coherence once
    per response (function type 26, reference node 0), which marks them so when read back (Lines.together)."""
    together = {e.together for e, _ in estimates}
    if len(together) > 1 and any(together):
        raise InputError(
            "--frf-out",
            "the frequency responses of several shakers at once are one measurement (their inputs share the "
            "samples): write them to a file of their own",
        )
    path = Path(path)
    if path.exists():
        path.unlink()  # pyuff appends to an existing file
    sets = []
    for run, (estimate, force) in enumerate(estimates, start=1):
        freq = estimate.omega / (2 * np.pi)
        averaged = estimate.averaged or counted(len(estimate.hits), "hit")
        window = f"; exponential window {estimate.window_decay:.9g} 1/s" if estimate.window_decay else ""
        several = estimate.averages > 1 or len(estimate.hits) > 1
        for k, channel in enumerate(estimate.responses, start=1):
            common = dict(
                id1=channel.name,
                id3=f"H1 of {averaged} on {estimate.force}{window}",
                id4=placement(channel),
                id5=f"{channel.quantity} [{channel.unit}]",
                rsp_node=k,
                rsp_dir=_axis(channel.direction),
                ref_node=1000 + run,
                ref_dir=_axis(force.direction),
                x=freq,
            )
            sets.append(_frf_set(common, FRF, estimate.h1[:, k - 1], channel))
            if estimate.together and run == 1:  # the inputs' multiple coherence: one per response
                common = {**common, "ref_node": 0, "ref_dir": 0, "id2": _MULTIPLE}
                sets.append(_frf_set(common, COHERENCE, estimate.coherence[:, k - 1], channel))
            elif several and not estimate.together:
                sets.append(_frf_set(common, COHERENCE, estimate.coherence[:, k - 1], channel))
    pyuff.UFF(str(path)).write_sets(sets, mode="add")
    if together != {()}:
        _typed_multiple(path)


def _frf_set(common: dict, function: int, values: np.ndarray, channel: Channel) -> dict:
    """One dataset 58 of write_frf: a frequency response function (complex, the response per N) or its coherence
    (real, dimensionless)."""
    frf = function == FRF
    freq = common["x"]
    return pyuff.prepare_58(
        **_WRITTEN_58,
        func_type=function,
        rsp_ent_name=channel.name[:10],
        ref_ent_name="force",
        ord_data_type=6 if frf else 4,
        num_pts=len(freq),
        abscissa_min=float(freq[0]),
        abscissa_inc=float(freq[1] - freq[0]),
        abscissa_spec_data_type=18,  # frequency
        ordinate_spec_data_type=_ORDINATE_TYPE_OF[channel.quantity] if frf else 0,
        orddenom_spec_data_type=13 if frf else 0,  # force
        abscissa_axis_units_lab="Hz",
        ordinate_axis_units_lab=channel.unit if frf else "",
        orddenom_axis_units_lab="N" if frf else "",
        data=np.asarray(values, dtype=complex if frf else float),
        **{"id2": "H1" if frf else "coherence", **common},
    )


_MULTIPLE = "multiple coherence"
"""ID line 2 of the multiple coherences write_frf writes: pyuff (2.5) writes function types 0-4, 6 and 9 only, so
they are written as coherences (6) and given their type (26) after (_typed_multiple)."""


def _typed_multiple(path: Path) -> None:
    """Give the datasets 58 of ``path`` whose ID line 2 is _MULTIPLE the function type of a multiple coherence
    (record 6, field 1: columns 1-5)."""
    lines = path.read_text().split("\n")
    for k, line in enumerate(lines[:-7]):
        if line.strip() == "58" and lines[k - 1].strip() == "-1" and lines[k + 2].strip() == _MULTIPLE:
            lines[k + 6] = f"{MULTIPLE_COHERENCE:5d}" + lines[k + 6][5:]
    path.write_text("\n".join(lines))


def placement(channel: Channel) -> str:
    """The ID line 4 write_uff gives a channel: its point and direction in full, read back exactly."""
    point = ",".join(repr(float(v)) for v in channel.point)
    return f"{_TAG}{point} dir={','.join(repr(float(v)) for v in channel.direction)}"


def dataset_58(
    channel: Channel,
    time: np.ndarray,
    values: np.ndarray,
    node: int,
    axis: int,
    id4: str,
    id5: str | None = None,
    title: str | None = None,
) -> dict:
    """One channel's time response as a pyuff dataset 58 (double precision ASCII): ID line 1 ``title`` (default
    the channel's name), ID line 4 ``id4``, ID line 5 ``id5`` (default "quantity [unit]"), response ``node`` and
    direction ``axis`` (+-1, 2, 3; 0 for none), the ordinate's data type and axis label from the channel."""
    return pyuff.prepare_58(
        **_WRITTEN_58,
        id1=channel.name if title is None else title,
        id2="time response",
        id3="",
        id4=id4,
        id5=f"{channel.quantity} [{channel.unit}]" if id5 is None else id5,
        func_type=1,
        rsp_node=node,
        rsp_dir=axis,
        ref_node=0,
        ref_dir=0,
        ord_data_type=4,
        num_pts=len(time),
        abscissa_min=float(time[0]),
        abscissa_inc=float(time[1] - time[0]),
        abscissa_spec_data_type=17,  # time
        ordinate_spec_data_type=_ORDINATE_TYPE_OF.get(channel.quantity, 0),
        rsp_ent_name=channel.name[:10],
        ref_ent_name="NONE",
        abscissa_axis_units_lab="s",
        ordinate_axis_units_lab=channel.unit,
        orddenom_spec_data_type=0,
        orddenom_axis_units_lab="",
        data=np.asarray(values, dtype=float),
        x=np.asarray(time, dtype=float),
    )


def _triple(text: str) -> tuple[float, float, float]:
    values = tuple(float(v) for v in text.split(","))
    if len(values) != 3:
        raise ValueError(f"expected 3 values, got {len(values)}")
    return values  # type: ignore[return-value]


def read_uff(path: str | Path, ignore: Collection[str] = (), run: int | None = None) -> Record | ModeTable:
    """Read the dataset-58 time responses of a UFF file as one record (they must share their sampling), all but
    the channels ``ignore`` names (a bench's tachometer or microphone: any quantity, function or sampling).

    A file of several runs (hits recorded one after another, each a dataset per channel: _runs) is read one
    ``run`` at a time (1, 2, ...; an error naming the runs where it is not given; read_uff_runs reads each):
    read at once, two runs were one record of twice the channels, each pair at one point along one direction
    with the data of different hits."""
    path, uff, types = _opened(path)
    if holds_mode_shapes(types):  # a bench's modal analysis results: its table of modes
        return read_table(path, uff, types, ignore, run)
    return _record(_run(_grouped(path, uff, types), run, path), uff, types, path, ignore)


def read_uff_runs(path: str | Path, ignore: Collection[str] = ()) -> list[Record] | list[ModeTable]:
    """Every run of a UFF file (_runs), each a record as read_uff reads it (one where the file holds one); a file of
    mode shapes, each load case's table of modes (uff_modes)."""
    path, uff, types = _opened(path)
    if holds_mode_shapes(types):
        return read_tables(path, uff, types, ignore)
    return each_run(_grouped(path, uff, types), lambda sets: _record(sets, uff, types, path, ignore))


def _opened(path: str | Path) -> tuple[Path, pyuff.UFF, list]:
    """The file at ``path`` opened: its path, pyuff's reader and its dataset types; an InputError where it is missing
    or cut short (uff_geometry.whole)."""
    path = existing_file(path, "record")
    whole(path)
    uff = pyuff.UFF(str(path))
    return path, uff, list(uff.get_set_types())


def _grouped(path: Path, uff: pyuff.UFF, types: list) -> list[list[dict]]:
    """The file's datasets 58 grouped into runs (_runs; frequency response functions a run per input); an
    InputError where it holds none."""
    found = [i for i, t in enumerate(types) if int(t) == 58]
    if not found:
        raise InputError("record", f"{path.name} holds no dataset 58 (nor a table of modes: datasets 55)")
    sets = [read_set(uff, i, types, path) for i in found]
    frfs = [s for s in sets if _function_type(s) == FRF]
    if frfs:  # a bench's frequency response functions: a run per input (reference node and direction)
        other = next((s for s in sets if _function_type(s) not in (FRF, *COHERENCES)), None)
        if other is not None:
            kind = _function_type(other)
            what = "a time response" if kind in (0, 1) else _FUNCTION_TYPES.get(kind, f"of UFF 58 function type {kind}")
            raise InputError(_names([other])[0], f"is {what} beside frequency response functions: {FRF_ONLY}")
        inputs = list(dict.fromkeys(_reference(s) for s in frfs))  # each run's coherences after its functions
        ordered = frfs + [s for s in sets if _function_type(s) == COHERENCE]
        multiple = [s for s in sets if _function_type(s) == MULTIPLE_COHERENCE]  # one per response: every input's
        return [[s for s in ordered if _reference(s) == key] + multiple for key in inputs]
    return _runs(sets)


FRF = 4
"""UFF 58 function type of a frequency response function."""

COHERENCE = 6
"""UFF 58 function type of a coherence: a file of frequency response functions may hold them beside, one per
response and input (Lines.coherence)."""


MULTIPLE_COHERENCE = 26
"""UFF 58 function type of a multiple coherence: a bench's frequency response functions of several inputs at once
(a MIMO test) come with one per response, the share of its power all the inputs together explain. It goes with the
response's channel in every input's run (it takes the place of an ordinary coherence there), and it marks the runs
as one measurement (Lines.together)."""

COHERENCES = (COHERENCE, MULTIPLE_COHERENCE)


def _function_type(s: dict) -> int:
    return int(s.get("func_type", 1) or 0)


def _reference(s: dict) -> tuple[int, int]:
    """A dataset's reference (input) node and direction."""
    return int(s.get("ref_node", 0) or 0), int(s.get("ref_dir", 0) or 0)


def _record(sets: list[dict], uff: pyuff.UFF, types: list, path: Path, ignore: Collection[str]) -> Record:
    """One run's datasets 58 as a record, all but the channels ``ignore`` names (read_uff); coherences beside
    frequency response functions go with the channel of their response."""
    coherences = [s for s in sets if _function_type(s) in COHERENCES]  # a multiple coherence last: it takes the place
    sets = [s for s in sets if _function_type(s) not in COHERENCES]
    names = _names(sets)
    check_ignored(ignore, names, path.name)
    sets, names = (
        [s for s, n in zip(sets, names, strict=True) if n not in ignore],
        [n for n in names if n not in ignore],
    )
    if not sets:
        raise InputError("ignore", f"leaves no channel of {path.name}")
    nodes = node_geometry(uff, types, path)
    if _function_type(sets[0]) == FRF:
        record = _impulse_responses(sets, names, nodes, coherences)
        if not any(_function_type(c) == MULTIPLE_COHERENCE for c in coherences):
            return record
        together = f"the inputs of {path.name} at once (its multiple coherence)"
        return replace(record, impulse=replace(record.impulse, together=together))
    time = _seconds(sets[0])
    columns, channels = [], []
    for n, s in enumerate(sets):
        name = names[n]
        _time_response(s, name)
        x = _seconds(s)
        if len(x) != len(time):
            raise InputError(
                name,
                f"{len(x)} samples against {len(time)} of the first channel, {names[0]} (one record needs one "
                "time base: a channel cut short or sampled at another rate)",
            )
        if not np.allclose(x, time, rtol=0, atol=1e-9 * max(1.0, abs(time[-1]))):
            k = int(np.argmax(np.abs(x - time)))
            raise InputError(
                name,
                f"sample {k} at {x[k]:.9g} s against {time[k]:.9g} s of the first channel, {names[0]} (one "
                "record needs one time base)",
            )
        columns.append(np.real(np.asarray(s["data"])).astype(float))
        channels.append(Channel(name, *_placement(s, name, nodes), *_quantity(s, name)))
    return Record(time, np.column_stack(columns), tuple(channels))


def _placement(
    s: dict, name: str, nodes: dict[int, tuple[tuple[float, float, float], np.ndarray]]
) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
    """A channel's point [m] and unit direction: mountid's ID line 4, else its response node's coordinates and the
    response direction's axis in the file's geometry (``nodes``), else NaN."""
    point = direction = (math.nan,) * 3
    meta = str(s.get("id4", "")).strip()
    if meta.startswith(_TAG):
        try:
            p_text, d_text = meta.removeprefix(_TAG).split(" dir=")
            point, direction = _triple(p_text), _triple(d_text)
        except ValueError as err:
            raise InputError(name, f"bad point/direction in ID line 4 ({err})") from None
    else:  # another tool's file: the response node's coordinates and the response direction's axis
        node, axis = _response(s)
        if node in nodes and 1 <= abs(axis) <= 3:
            point, axes = nodes[node]
            direction = tuple(float(v) + 0.0 for v in math.copysign(1.0, axis) * axes[abs(axis) - 1])
    return point, direction  # type: ignore[return-value]


def _quantity(s: dict, name: str) -> tuple[str, str]:
    """A channel's quantity and unit: mountid's ID line 5 ("acceleration [m/s^2]"), else the ordinate's data type
    and axis label (_quantity_and_unit)."""
    label = str(s.get("id5", "")).strip()
    quantity, unit = label[:-1].split(" [", 1) if label.endswith("]") and " [" in label else ("", "")
    if quantity not in RECORDED:  # another tool's file: the ordinate's data type (UFF 58 record 8) and axis label
        quantity, unit = _quantity_and_unit(s, name)
    return quantity, unit


def _impulse_responses(
    sets: list[dict],
    names: list[str],
    nodes: dict[int, tuple[tuple[float, float, float], np.ndarray]],
    coherences: Collection[dict] = (),
) -> Record:
    """One input's frequency response functions (datasets 58 of function type 4) as the impulse responses they
    transform back to (Record.impulse), in SI units per N: every function on the first one's frequency lines (in
    Hz, evenly spaced, the first a whole number of spacings from 0: the lines below it taken as 0), a response
    over a force (the denominator's unit: N where it names none); h(t) = rate x the inverse real transform of the
    lines from 0 to the last, at rate = twice the last line's frequency, over 1 / spacing seconds. An abscissa
    labelled rad/s is converted to Hz; a function of real values only (a magnitude: its phase lost) is an error.
    A coherence of the same response (node and direction) on the same lines goes with its channel
    (Lines.coherence)."""
    abscissa = np.asarray(sets[0]["x"], dtype=float)
    radians = _label(sets[0], "abscissa_axis_units_lab").replace(" ", "").lower() in ("rad/s", "rad/sec")
    freq = abscissa / (2 * np.pi) if radians else abscissa
    if len(freq) < 3:
        raise InputError(names[0], f"{len(freq)} frequency lines: a frequency response function needs more")
    spacing = float(freq[1] - freq[0])
    first = round(float(freq[0]) / spacing) if spacing > 0 else -1
    if not (spacing > 0 and np.allclose(np.diff(freq), spacing, rtol=1e-6, atol=0) and first >= 0) or not math.isclose(
        float(freq[0]), first * spacing, rel_tol=0, abs_tol=1e-6 * spacing
    ):
        raise InputError(
            names[0],
            f"frequency lines from {freq[0]:g} Hz by {spacing:g} Hz: mountid reads lines evenly spaced from 0 or "
            "a whole number of spacings above it",
        )
    columns, channels, coherence, pers = [], [], [], []
    of_response = {_response(c): c for c in coherences}
    for name, s in zip(names, sets, strict=True):
        x = np.asarray(s["x"], dtype=float)
        if _response(s) in of_response:
            given = of_response[_response(s)]
            if len(given["x"]) != len(x) or not np.allclose(given["x"], x, rtol=0, atol=1e-9 * abscissa[-1]):
                raise InputError(name, "its coherence is not on its frequency lines")
            values = np.real(np.asarray(given["data"])).astype(float)
            coherence.append((name, np.concatenate([np.zeros(first), values])))
        if not np.iscomplexobj(s["data"]) or not np.any(np.imag(np.asarray(s["data"])) != 0):
            raise InputError(
                name,
                "holds real values only: a frequency response function is complex (a magnitude has lost its phase)",
            )
        if len(x) != len(abscissa) or not np.allclose(x, abscissa, rtol=0, atol=1e-9 * abscissa[-1]):
            raise InputError(name, f"its frequency lines are not those of {names[0]} ({freq[0]:g} to {freq[-1]:g} Hz)")
        s, per = _per_force(s)
        quantity, unit = _quantity(s, name)
        if quantity == "force":
            raise InputError(name, "is a force over a force: a frequency response function is a response per force")
        denominator = int(s.get("orddenom_spec_data_type", 13) or 0)
        pers.append((per in VOLTAGE, _reference_name(s)))
        if per not in VOLTAGE and (per not in UNITS["force"] or denominator not in (0, 1, 9, 13)):
            raise InputError(
                name,
                f"is a response per {per!r} (UFF 58 denominator type {denominator}): mountid reads a response "
                f"per force ({', '.join(UNITS['force'])}) or per volt of the hammer",
            )
        lines = np.asarray(s["data"], dtype=complex) * RECORDED[quantity][unit] / {**UNITS["force"], **VOLTAGE}[per]
        columns.append(np.concatenate([np.zeros(first, dtype=complex), lines]))
        channels.append(Channel(name, *_placement(s, name, nodes), quantity, next(iter(RECORDED[quantity]))))
    record = impulse_record(np.column_stack(columns), spacing, tuple(channels), tuple(coherence))
    per_volt = {reference for volts, reference in pers if volts}  # the hammer's raw voltage: its sensitivity converts
    if not per_volt:
        return record
    if len(per_volt) > 1 or not all(volts for volts, _ in pers):
        raise InputError(names[0], "functions per volt beside functions per force, or of two references: one input")
    return replace(record, impulse=replace(record.impulse, per_volt=per_volt.pop()))


def _reference_name(s: dict) -> str:
    """A function's reference (input) as a sensitivity names it: the dataset's reference entity name (the hammer's
    channel, as an analyser writes it), "reference" where it gives none."""
    name = str(s.get("ref_ent_name") or "").strip()
    return name if name and name.upper() != "NONE" else "reference"


def _response(s: dict) -> tuple[int, int]:
    """A dataset's response node and direction."""
    return int(s.get("rsp_node", 0) or 0), int(s.get("rsp_dir", 0) or 0)


def _per_force(s: dict) -> tuple[dict, str]:
    """A frequency response function's dataset with its ordinate's own unit, and the force unit it is per: the
    denominator's label (N where it names none), or where the ordinate's label names both ("g/N", "(m/s^2)/lbf",
    as some writers put it), the part after its last slash."""
    label = _label(s, "ordinate_axis_units_lab")
    head, _, tail = label.rpartition("/")
    if head and unit_named(tail) in UNITS["force"]:
        return {**s, "ordinate_axis_units_lab": head.strip().removeprefix("(").removesuffix(")")}, unit_named(tail)
    return s, unit_named(_label(s, "orddenom_axis_units_lab")) or "N"


FRF_ONLY = "a file of frequency response functions holds them (and their coherences, ordinary or multiple) only"


_FUNCTION_TYPES = {
    2: "an auto spectrum",
    3: "a cross spectrum",
    4: "a frequency response function",
    5: "a transmissibility",
    6: "a coherence",
    9: "a power spectral density",
    12: "a spectrum",
    21: "a partial coherence",
    26: "a multiple coherence",
}
"""UFF 58 function types (record 6, field 1) a bench exports besides 0 (general) and 1 (time response); the
others are named by number."""


_OTHER_ORDINATES = {
    2: "a stress",
    3: "a strain",
    5: "a temperature",
    6: "a heat flux",
    9: "a reaction force",
    15: "a pressure",
    16: "a mass",
    17: "a time",
    18: "a frequency",
    19: "a rotational speed (rpm)",
    20: "an order",
}
"""UFF 58 ordinate data types (record 8, field 1) a bench exports besides those mountid reads (_ORDINATE_TYPES)
and 0 (unknown), 1 (general); the others are named by number."""


def _quantity_and_unit(s: dict, name: str) -> tuple[str, str]:
    """A channel's quantity and unit from its dataset 58's ordinate data type and axis label: a type mountid reads
    (_ORDINATE_TYPES) with its label (the quantity's SI unit where it is empty); types 0 (unknown) and 1 (general)
    by the label's unit (records.UNITS), an acceleration where it names none; a label in volts (of any type) a
    raw voltage (records.VOLTAGE: its sensor's sensitivity converts it, records.with_sensitivities); any other type
    (a reaction force, a pressure: a channel mountid does not read) an InputError naming the channel. Read as an
    acceleration, a pressure was 'unit Pa is not a unit of acceleration', and a reaction force at an isolator a
    response."""
    kind = int(s.get("ordinate_spec_data_type", 12) or 0)
    unit = unit_named(_label(s, "ordinate_axis_units_lab"))
    if unit in VOLTAGE:  # an acquisition that records volts (of any type): converted by sensitivity later
        return "voltage", unit
    if kind in _ORDINATE_TYPES:
        quantity = _ORDINATE_TYPES[kind]
    elif kind in (0, 1):
        quantity = quantity_of(unit) or "acceleration"
    else:
        what = _OTHER_ORDINATES.get(kind, "a quantity")
        reads = ", ".join(f"{q} {k}" for k, q in _ORDINATE_TYPES.items())
        raise InputError(name, f"is {what} (UFF 58 ordinate type {kind}): mountid reads {reads}{unread(name)}")
    return quantity, unit or next(iter(UNITS[quantity]))


def _label(s: dict, key: str) -> str:
    """A dataset's text field, "" where it is empty or "NONE" (what pyuff and other writers put in a label that
    holds nothing: it was read as a unit named 'NONE')."""
    text = str(s.get(key, "")).strip()
    return "" if text.upper() == "NONE" else text


def _seconds(s: dict) -> np.ndarray:
    """A time response's abscissa [s]: in the unit its axis label gives (records.TIME_UNITS: "ms" too, as some
    acquisitions label it; read as seconds, a record at 500 Hz was one at 0.5 Hz), seconds where it gives another."""
    return np.asarray(s["x"], dtype=float) * TIME_UNITS.get(_label(s, "abscissa_axis_units_lab"), 1.0)


def _time_response(s: dict, name: str) -> None:
    """An InputError naming the channel where dataset 58 ``s`` is not a real time response: a frequency response
    function or a spectrum (function type, abscissa in Hz) or complex data was read as its real part over a
    frequency axis taken for time."""
    kind = int(s.get("func_type", 1) or 0)
    if kind not in (0, 1):
        what = _FUNCTION_TYPES.get(kind, "not a time response")
        raise InputError(name, f"is {what} (UFF 58 function type {kind}): a record is time responses (type 1)")
    if int(s.get("abscissa_spec_data_type", 0) or 0) == 18:
        raise InputError(name, "its abscissa is frequency: a record is time responses, over time")
    if np.iscomplexobj(s["data"]) and np.any(np.imag(np.asarray(s["data"])) != 0):
        raise InputError(name, "holds complex values: a record is real time responses")


def _runs(sets: list[dict]) -> list[list[dict]]:
    """A file's datasets 58 grouped into runs: where the response nodes and directions of its datasets (node > 0)
    repeat one sequence of distinct ones, each repetition is a run, as a bench exports the hits of a test one after
    another; where each node and direction occurs as often as every other, in another order (a channel's hits one
    after another, then the next channel's), run k holds the k-th dataset of each; where a new run begins at each
    node and direction that recurs, and the runs so parted are of one size, each is a run too (a roving test: the
    hammer's force at another node in each run, or one accelerometer moved beside a fixed reference; read as one
    record, the responses of one run were taken as the other's, its force unused); otherwise the file is one run
    (a node and direction that recurs elsewhere is a channel of its own)."""
    keys = [_response(s) for s in sets]
    counts = {keys.count(key) for key in keys}
    if len(counts) == 1 and (times := counts.pop()) > 1 and all(node > 0 for node, _ in keys):
        # the k-th dataset of each node and direction (one after another: a repeated sequence, each run in turn)
        occurrence: list[int] = []
        before: dict[tuple[int, int], int] = {}
        for key in keys:
            occurrence.append(before.get(key, 0))
            before[key] = occurrence[-1] + 1
        return [[s for s, k in zip(sets, occurrence, strict=True) if k == run] for run in range(times)]
    runs: list[list[dict]] = [[]]
    seen: set[tuple[int, int]] = set()
    for s, key in zip(sets, keys, strict=True):
        if key[0] > 0 and key in seen:
            runs.append([])
            seen = set()
        runs[-1].append(s)
        seen.add(key)
    return runs if len(runs) > 1 and len({len(r) for r in runs}) == 1 else [sets]


def _run(runs: list[list[dict]], run: int | None, path: Path) -> list[dict]:
    """The datasets of ``run`` (1, 2, ...; None: the only one); an InputError naming the runs where the file
    holds several and none is given, or the run is not one of them."""
    sizes = ", ".join(str(sum(_function_type(s) != COHERENCE for s in r)) for r in runs)
    held = f"{path.name} holds {counted(len(runs), 'run')} (datasets 58 of {sizes} channels"
    frfs = _function_type(runs[0][0]) == FRF
    parted = "a run per input" if frfs else "a run beginning where a response node and direction recurs"
    return chosen_run(runs, run, held, parted, "read_uff_runs")


def _names(sets: list[dict]) -> list[str]:
    """Each channel's name: ID line 1, unless it is empty or another channel's too (bench software often writes
    one description, "Time Response", into every dataset), then its response node and direction (node11:-2), and
    a count where even those repeat."""
    titles = [str(s.get("id1", "")).strip() for s in sets]
    out = [
        t if t and titles.count(t) == 1 else f"node{s.get('rsp_node', n)}:{s.get('rsp_dir', 0)}"
        for n, (t, s) in enumerate(zip(titles, sets, strict=True))
    ]
    return [name if out.count(name) == 1 else f"{name}#{out[:k].count(name) + 1}" for k, name in enumerate(out)]
