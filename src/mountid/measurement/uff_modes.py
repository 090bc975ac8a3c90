"""A bench's modal analysis results in the Universal File Format: mode shapes at nodes (dataset 55, or the analysis
data at nodes of dataset 2414 that later software writes them in), read by pyuff as a table of modes
(records.ModeTable) in the place of a record.

Modal test software (a hammer test's FRFs through its own curve fitter) exports the modes it found as one dataset
55 per mode: normal modes (analysis type 2: the frequency [Hz] and the modal viscous damping ratio, a real shape)
or complex modes (analysis types 3 and 7: the eigenvalue p [rad/s] and a complex shape). A mode's frequency is
taken as |p| and its damping ratio as -Re p / |p|, as the records chain's poles are (a normal mode's frequency
with its viscous damping ratio is the |p| of a proportionally damped mode); a mode given a hysteretic damping
ratio (loss factor) only takes half of it, the viscous ratio of the same bandwidth. The shapes are translations
along the global axes at each node (the format's "3 DOF global translation vector"; the rotations of a 6-DOF
vector are not read, and said so where they are not zero); a node's point comes from the file's geometry as for
time responses (uff_geometry). The format writes 0 for a direction not measured: a node and direction that is
zero in every mode is no channel (a uniaxial accelerometer's node gives one channel). Each channel is named
``node<N>:<axis>`` (axis 1, 2, 3 for x, y, z) and may be left unread by name (``ignore``). The datasets of
several load cases are the runs of the file, a table each. Complex shapes of six values per node are what pyuff
cannot read: an error naming the dataset. write_table writes a table the same way (the model's modes for a bench's
software: ``mountid modes --uff``, records.ModeTable.of_model).
"""

from __future__ import annotations

import math
from collections.abc import Collection, Sequence
from pathlib import Path

import numpy as np
import pyuff

from mountid.errors import InputError
from mountid.measurement.modal import pole_of
from mountid.measurement.records import ModeTable, check_ignored, chosen_run, each_run, node_channel
from mountid.measurement.uff_geometry import node_geometry, read_set
from mountid.nomenclature import counted

MODE_SHAPES = 55
"""The UFF dataset of data at nodes: a bench's mode shapes."""

ANALYSIS_DATA = 2414
"""The UFF dataset of analysis data, which later software (I-DEAS, Simcenter, Femap) writes its modes in: data at
nodes (dataset location 1) of a normal or complex mode, read as a dataset 55 is (_as_55)."""

PYUFF_READS = (
    "pyuff reads mode shapes of three translations per node, real or complex, and of six values per node real only: "
    "export complex shapes as translations"
)
"""What a dataset 55 pyuff cannot read is told (complex shapes of six values per node, its own limit)."""

_ANALYSIS_TYPES = {
    0: "unknown",
    1: "static",
    2: "normal mode",
    3: "complex eigenvalue",
    4: "transient",
    5: "frequency response",
    6: "buckling",
    7: "complex eigenvalue (second order)",
}

_NORMAL, _COMPLEX = (2,), (3, 7)

_VECTORS = (2, 3)
"""Data characteristics of a mode shape: a 3-DOF translation vector, or a 6-DOF translation and rotation one."""


def holds_mode_shapes(types: list) -> bool:
    """Whether a UFF file of the dataset ``types`` is a table of modes: datasets 55 or 2414 and no dataset 58 (a
    file of both is read for its functions, the measurement itself)."""
    kinds = {int(t) for t in types}
    return bool(kinds & {MODE_SHAPES, ANALYSIS_DATA}) and 58 not in kinds


def read_table(
    path: Path, uff: pyuff.UFF, types: list, ignore: Collection[str] = (), run: int | None = None
) -> ModeTable:
    """The table of modes of the load case ``run`` (1, 2, ... in the order the file gives them; None: the only
    one) of an opened UFF file (uff.read_uff), all but the channels ``ignore`` names."""
    runs = _load_cases(path, uff, types)
    held = f"{path.name} holds {counted(len(runs), 'run')} (tables of {', '.join(str(len(r)) for r in runs)} modes"
    return _table(chosen_run(runs, run, held, "a run per load case", "read_uff_runs"), uff, types, path, ignore)


def read_tables(path: Path, uff: pyuff.UFF, types: list, ignore: Collection[str] = ()) -> list[ModeTable]:
    """Every load case's table of modes of an opened UFF file (uff.read_uff_runs)."""
    return each_run(_load_cases(path, uff, types), lambda sets: _table(sets, uff, types, path, ignore))


def write_table(table: ModeTable, path: str | Path, titles: Sequence[str] | None = None) -> None:
    """Write a table of modes to a new UFF file: the SI units (dataset 164), a node at each point of its channels
    (dataset 15, numbered from 1 in the order the channels give the points) and a dataset 55 per mode, ID line 1
    its ``titles`` entry (default "mode K"): normal modes (the frequency |p| / 2 pi [Hz], the viscous damping ratio
    -Re p / |p|, the real shapes) where every shape is real, else complex modes (the eigenvalue p, the complex
    shapes), each node's translations along x, y and z from its channels (0 along an axis none reads: not
    measured, as the format has it). A channel along no axis is an error naming it. Six significant digits: the
    format's (E13.5)."""
    path = Path(path)
    points = list(dict.fromkeys(c.point for c in table.channels))
    values = np.zeros((len(points), 3, len(table.poles)), dtype=complex)
    for c, shape in zip(table.channels, table.shapes, strict=True):
        axes = [k for k in range(3) if c.direction[k] != 0]
        if len(axes) != 1 or abs(c.direction[axes[0]]) != 1:
            raise InputError(c.name, "measures along no axis: a table of modes in UFF holds translations along x, y, z")
        node = points.index(c.point)
        if np.any(values[node, axes[0]]):
            raise InputError(c.name, f"a second channel at node {node + 1} along axis {axes[0] + 1}: one is written")
        values[node, axes[0]] = c.direction[axes[0]] * shape
    real = not np.any(values.imag)
    nodes = np.arange(1, len(points) + 1)
    sets = [
        pyuff.prepare_164(
            units_code=1, units_description="SI", temp_mode=1, length=1.0, force=1.0, temp=1.0, temp_offset=0.0
        ),
        pyuff.prepare_15(
            node_nums=list(nodes),
            def_cs=[0] * len(points),
            disp_cs=[0] * len(points),
            color=[1] * len(points),
            **{axis: [float(p[k]) for p in points] for k, axis in enumerate("xyz")},
        ),
    ]
    for k, p in enumerate(table.poles):
        common = {
            "id1": titles[k] if titles else f"mode {k + 1}",
            "id2": table.kind,
            "model_type": 1,
            "data_ch": 2,
            "spec_data_type": 8,
            "load_case": 1,
            "mode_n": k + 1,
            "node_nums": nodes,
        }
        shape = {f"r{a + 1}": values[:, a, k].real if real else values[:, a, k] for a in range(3)}
        if real:
            omega = abs(complex(p))
            ratio = -complex(p).real / omega
            sets.append(
                pyuff.prepare_55(
                    analysis_type=2,
                    freq=float(omega / (2 * math.pi)),
                    modal_m=0.0,  # not stated: a table's shapes carry no scale
                    modal_damp_vis=float(ratio),
                    modal_damp_his=0.0,
                    **common,
                    **shape,
                )
            )
        else:
            sets.append(pyuff.prepare_55(analysis_type=3, eig=complex(p), modal_a=0j, modal_b=0j, **common, **shape))
    if path.exists():
        path.unlink()  # pyuff appends to an existing file
    pyuff.UFF(str(path)).write_sets(sets, mode="add")


def _load_cases(path: Path, uff: pyuff.UFF, types: list) -> list[list[dict]]:
    """The file's datasets 55 (and 2414, as their fields: _as_55), a list per load case in the order of their first
    dataset; one pyuff cannot read named with what it reads."""
    try:
        sets = [read_set(uff, i, types, path) for i, t in enumerate(types) if int(t) in (MODE_SHAPES, ANALYSIS_DATA)]
    except InputError as err:
        raise InputError(err.parameter, f"{err.reason}; {PYUFF_READS}") from None
    sets = [s if int(s["type"]) == MODE_SHAPES else _as_55(s, path) for s in sets]
    cases = list(dict.fromkeys(int(s.get("load_case", 0) or 0) for s in sets))
    return [[s for s in sets if int(s.get("load_case", 0) or 0) == case] for case in cases]


def _table(sets: list[dict], uff: pyuff.UFF, types: list, path: Path, ignore: Collection[str]) -> ModeTable:
    """One load case's datasets 55 as a table of modes (the module's conventions)."""
    poles, notes, kinds = [], [], set()
    for s in sets:
        pole, kind, note = _pole(s, path)
        poles.append(pole)
        kinds.add(kind)
        notes += [note] if note else []
    values: dict[tuple[int, int], np.ndarray] = {}
    turning = []
    for k, s in enumerate(sets):
        columns = (np.atleast_1d(s.get(key, ())) for key in ("node_nums", "r1", "r2", "r3"))
        for node, *motion in zip(*columns, strict=True):
            for axis, value in enumerate(motion, start=1):
                values.setdefault((int(node), axis), np.zeros(len(sets), dtype=complex))[k] = complex(value)
        if any(np.any(np.atleast_1d(s.get(key, 0.0)) != 0) for key in ("r4", "r5", "r6")):
            turning.append(_mode(s))
    if turning:
        notes.append(f"the rotations at the nodes of modes {', '.join(turning)} are not read (translations only)")
    measured = sorted(key for key, v in values.items() if np.any(v != 0))  # a direction not measured is 0 in all
    if not measured:
        raise InputError("record", f"{path.name}: every mode shape is zero at every node")
    geometry = node_geometry(uff, types, path)
    unplaced = (math.nan,) * 3
    every = [node_channel(node, axis, geometry[node][0] if node in geometry else unplaced) for node, axis in measured]
    check_ignored(ignore, [c.name for c in every], path.name)
    kept = [(key, c) for key, c in zip(measured, every, strict=True) if c.name not in ignore]
    if not kept:
        raise InputError("ignore", f"leaves no channel of {path.name}")
    channels = [c for _, c in kept]
    shapes = np.array([values[key] for key, _ in kept])
    if not np.all(np.isfinite(shapes)):
        raise InputError("record", f"{path.name}: a mode shape holds NaN or infinite values")
    kind = " and ".join(sorted(kinds))
    return ModeTable(tuple(channels), np.array(poles), shapes, kind, tuple(notes))


def _as_55(s: dict, path: Path) -> dict:
    """A dataset 2414 (pyuff's fields) as the fields of a dataset 55 that _pole and _table read: the analysis type
    and data characteristic; the mode number (record 10, field 6) and the solution set (field 3) as its load case;
    a normal mode's frequency [Hz], viscous and hysteretic damping ratios (record 12, fields 2, 5, 6), a complex
    mode's eigenvalue (record 13, fields 1 and 2); each node's values (record 15: x, y, z, and three rotations
    for a 6-DOF vector; real, or real and imaginary parts in turn for complex data types 5 and 6). An InputError
    where the data are not at nodes or a node's values are not as many as its data characteristic and type say
    (pyuff reads a node's values from one line)."""
    label = int(s.get("analysis_dataset_label", 0) or 0)
    where = f"{path.name}: dataset 2414 (analysis dataset {label})"
    if int(s.get("dataset_location", 0) or 0) != 1:
        raise InputError(
            "record", f"{where} holds no data at nodes (dataset location {s.get('dataset_location')}): no mode shape"
        )
    characteristic = int(s.get("data_characteristic", 0) or 0)
    complex_ = int(s.get("data_type", 0) or 0) in (5, 6)
    count = {2: 3, 3: 6}.get(characteristic, 0) * (2 if complex_ else 1)
    rows = [np.asarray(v, dtype=float) for v in s.get("data_at_node", [])]
    if count and any(len(v) != count for v in rows):
        wrong = next(len(v) for v in rows if len(v) != count)
        raise InputError(
            "record",
            f"{where}: a node with {wrong} values where data characteristic {characteristic} of "
            f"{'complex' if complex_ else 'real'} data has {count} (pyuff reads a node's values from one line)",
        )
    values = np.array(rows).reshape(len(rows), -1)
    if complex_ and values.size:
        values = values[:, 0::2] + 1j * values[:, 1::2]
    out = {
        "analysis_type": int(s.get("analysis_type", 0) or 0),
        "data_ch": characteristic,
        "mode_n": int(s.get("record10_field6", 0) or 0),
        "load_case": int(s.get("record10_field3", 0) or 0),
        "node_nums": np.atleast_1d(s.get("node_nums", [])),
        "freq": float(s.get("record12_field2", math.nan)),
        "modal_damp_vis": float(s.get("record12_field5", 0.0) or 0.0),
        "modal_damp_his": float(s.get("record12_field6", 0.0) or 0.0),
        "eig": complex(float(s.get("record13_field1", math.nan)), float(s.get("record13_field2", math.nan))),
        "dataset": ANALYSIS_DATA,
    }
    return out | ({f"r{k + 1}": values[:, k] for k in range(values.shape[1])} if count else {})


def _mode(s: dict) -> str:
    return str(int(s.get("mode_n", 0) or 0))


def _pole(s: dict, path: Path) -> tuple[complex, str, str]:
    """A dataset 55's pole p [rad/s] (Im p > 0), what kind of mode it is, and a note where its damping ratio is
    half its hysteretic one; an InputError naming the mode where the dataset is no mode shape or its pole is
    none of a damped mode."""
    where = f"{path.name}: dataset {s.get('dataset', MODE_SHAPES)} of mode {_mode(s)}"
    analysis = int(s.get("analysis_type", 0) or 0)
    if analysis not in _NORMAL + _COMPLEX:
        what = _ANALYSIS_TYPES.get(analysis, f"analysis type {analysis}")
        raise InputError(
            "record",
            f"{where} holds {what} data at nodes: a table of modes is of normal modes (analysis type 2) or complex "
            "modes (3, 7)",
        )
    if int(s.get("data_ch", 0) or 0) not in _VECTORS:
        raise InputError("record", f"{where}: its data are no translation vector at nodes (data characteristic 2 or 3)")
    note = ""
    if analysis in _NORMAL:
        frequency = 2 * math.pi * float(s.get("freq", math.nan))
        ratio = float(s.get("modal_damp_vis", 0.0) or 0.0)
        loss = float(s.get("modal_damp_his", 0.0) or 0.0)
        if ratio == 0 and loss > 0:
            ratio = loss / 2
            note = f"mode {_mode(s)}: damping ratio half its hysteretic damping ratio {loss:.4g} (no viscous one given)"
        if not (math.isfinite(frequency) and frequency > 0):
            raise InputError("record", f"{where}: its frequency {frequency / (2 * math.pi):g} Hz is no positive number")
        if not (math.isfinite(ratio) and 0 <= ratio < 1):
            raise InputError("record", f"{where}: its damping ratio {ratio:g} is not in [0, 1)")
        return pole_of(frequency, ratio), "normal modes", note
    pole = complex(s.get("eig", math.nan))
    if not (math.isfinite(pole.real) and math.isfinite(pole.imag)) or pole.imag == 0:
        raise InputError("record", f"{where}: its eigenvalue {pole:g} rad/s is no pole of a vibrating mode")
    pole = pole.conjugate() if pole.imag < 0 else pole
    if pole.real > 0:
        raise InputError("record", f"{where}: its eigenvalue {pole:g} rad/s grows (positive real part): no damped mode")
    return pole, "complex modes", note
