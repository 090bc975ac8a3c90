"""The geometry of a UFF file, shared by its readers (time responses and frequency response functions: uff, mode
shapes at nodes: uff_modes): each node's point and axes (datasets 15 and 2411) in its coordinate systems
(datasets 2420 and 18), in the length unit of dataset 164; a dataset read with pyuff's reason named; a file cut
short named.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pyuff

from mountid.errors import InputError


def whole(path: Path, window: int = 256) -> None:
    """An InputError where ``path`` starts as a UFF file (a "-1" line) and does not end with one (or, after a
    binary dataset's data, with its "    -1" field): its last dataset is cut short (an interrupted copy). pyuff
    leaves an unterminated block out without a word, and with it the channels it held. Reads the first and last
    ``window`` bytes only."""
    with path.open("rb") as f:
        head = f.read(window)
        f.seek(max(0, path.stat().st_size - window))
        tail = f.read()
    first = head.strip().split(b"\n", 1)[0].strip()
    last = tail.rstrip().rsplit(b"\n", 1)[-1].strip()
    # a binary dataset (58b) ends with its data and the "    -1" field (I6) with no line break between them
    if first == b"-1" and last != b"-1" and not tail.rstrip().endswith(b"    -1"):
        raise InputError(
            "record", f"{path.name} ends inside a dataset (no closing -1 line): the file is cut short; copy it again"
        )


def read_set(uff: pyuff.UFF, index: int, types: list, path: Path) -> dict:
    """The file's dataset number ``index`` as pyuff reads it; one pyuff cannot read (a truncated or malformed
    block: pyuff raises a bare Exception) is an error naming the file, the dataset and pyuff's reason."""
    try:
        return uff.read_sets(index)
    except Exception as err:  # pyuff raises Exception itself; its reason goes into the message
        raise InputError(
            "record", f"{path.name}: dataset {index + 1} (type {int(types[index])}) is not readable ({err})"
        ) from None


def node_geometry(uff: pyuff.UFF, types: list, path: Path) -> dict[int, tuple[tuple[float, float, float], np.ndarray]]:
    """Each node's global coordinates [m] and the axes of its displacement coordinate system (rows: x, y, z in
    global coordinates) from the file's geometry (datasets 15 and 2411) and coordinate systems (2420 and 18),
    converted from the length unit of its first dataset 164 (SI = file value / its length factor; SI without
    one)."""
    units = [i for i, t in enumerate(types) if int(t) == 164]
    length = float(read_set(uff, units[0], types, path).get("length") or 1.0) if units else 1.0
    systems = _coordinate_systems(uff, types, length, path)
    out: dict[int, tuple[tuple[float, float, float], np.ndarray]] = {}
    for i in (i for i, t in enumerate(types) if int(t) in (15, 2411)):
        geometry = read_set(uff, i, types, path)
        xyz = np.column_stack([np.atleast_1d(geometry[a]) for a in "xyz"]).astype(float) / length
        labels = [np.atleast_1d(geometry.get(key, np.zeros(len(xyz)))).astype(int) for key in ("def_cs", "disp_cs")]
        for node, p, defined, displaced in zip(np.atleast_1d(geometry["node_nums"]), xyz, *labels, strict=True):
            axes, origin = _system(systems, int(defined), int(node), "definition")
            point = origin + p @ axes
            out[int(node)] = (
                (float(point[0]), float(point[1]), float(point[2])),
                _system(systems, int(displaced), int(node), "displacement")[0],
            )
    return out


_CS_TYPES = {0: "Cartesian", 1: "cylindrical", 2: "spherical"}

_SAME_SYSTEM = 1e-4
"""A coordinate system defined by both datasets 2420 and 18 must agree to this (axes; origin relative to its
size, 1 m at least): dataset 18 writes six significant digits."""


def _coordinate_systems(
    uff: pyuff.UFF, types: list, length: float, path: Path
) -> dict[int, tuple[np.ndarray, np.ndarray, int]]:
    """The coordinate systems of the file's datasets 2420 and 18: label -> (axes, rows the local x, y, z in global
    coordinates; origin [m]; type, 0 Cartesian). A transformation whose axes are not orthonormal is an error."""
    out = {}
    for i in (i for i, t in enumerate(types) if int(t) == 2420):
        found = read_set(uff, i, types, path)
        for label, kind, matrix in zip(found["CS_sys_labels"], found["CS_types"], found["CS_matrices"], strict=True):
            m = np.asarray(matrix, dtype=float)
            if m.shape != (4, 3) or not np.allclose(m[:3] @ m[:3].T, np.eye(3), rtol=0, atol=1e-6):
                raise InputError("record", f"coordinate system {label} (dataset 2420): its axes are not orthonormal")
            out[int(label)] = (m[:3], m[3] / length, int(kind))
    legacy = _legacy_systems(uff, types, length, path)
    for label, (axes, origin, kind) in _resolved(legacy, out).items():
        if label in out:
            a, o, k = out[label]
            size = max(1.0, float(np.max(np.abs(o))))
            if k != kind or not (
                np.allclose(a, axes, rtol=0, atol=_SAME_SYSTEM)
                and np.allclose(o, origin, rtol=0, atol=_SAME_SYSTEM * size)
            ):
                raise InputError("record", f"coordinate system {label}: datasets 2420 and 18 define it differently")
            continue
        out[label] = (axes, origin, kind)
    return out


def _legacy_systems(uff: pyuff.UFF, types: list, length: float, path: Path) -> dict[int, tuple[int, int, np.ndarray]]:
    """The coordinate systems of the file's datasets 18 as given: label -> (type, reference system, rows: the
    origin, a point on the +x axis and a point in the +xz plane in the reference system [m]). A method of
    definition other than 1 (the only one the format defines) is an error."""
    out = {}
    for i in (i for i, t in enumerate(types) if int(t) == 18):
        found = read_set(uff, i, types, path)
        keys = ("cs_num", "cs_type", "ref_cs_num", "method", "ref_o", "x_point", "xz_point")
        for label, kind, reference, method, origin, x_point, xz_point in zip(*(found[k] for k in keys), strict=True):
            if int(method) != 1:
                raise InputError(
                    "record", f"coordinate system {int(label)} (dataset 18): method of definition {int(method)}, not 1"
                )
            points = np.array([origin, x_point, xz_point], dtype=float) / length
            out[int(label)] = (int(kind), int(reference), points)
    return out


def _resolved(legacy: dict, given: dict) -> dict[int, tuple[np.ndarray, np.ndarray, int]]:
    """Each dataset-18 system in global coordinates (axes rows, origin [m], type), its reference chain followed
    through other dataset-18 systems to a dataset-2420 one (``given``) or the global system (an undefined 0 or 1).
    A chain through a cylindrical or spherical system, a loop or an undefined reference is an error naming the
    system; so are points that define no axes (the +x point at the origin, the +xz point on the x axis)."""
    out: dict[int, tuple[np.ndarray, np.ndarray, int]] = {}

    def resolve(label: int, chain: tuple[int, ...]) -> tuple[np.ndarray, np.ndarray, int]:
        if label in out:
            return out[label]
        kind, reference, (origin, x_point, xz_point) = legacy[label]
        if reference in chain or reference == label:
            raise InputError("record", f"coordinate system {label} (dataset 18): its reference systems form a loop")
        if reference in given:
            ref_axes, ref_origin, ref_kind = given[reference]
        elif reference in legacy:
            ref_axes, ref_origin, ref_kind = resolve(reference, (*chain, label))
        elif reference in (0, 1):
            ref_axes, ref_origin, ref_kind = np.eye(3), np.zeros(3), 0
        else:
            raise InputError(
                "record", f"coordinate system {label} (dataset 18): its reference system {reference} is not defined"
            )
        if ref_kind != 0:
            raise InputError(
                "record",
                f"coordinate system {label} (dataset 18): its reference system {reference} is "
                f"{_CS_TYPES.get(ref_kind, f'of type {ref_kind}')}; only Cartesian ones are read",
            )
        x = x_point - origin
        xz = xz_point - origin
        scale = max(float(np.linalg.norm(x)), float(np.linalg.norm(xz)))
        z = xz - x * (x @ xz) / (x @ x) if x @ x > 0 else xz
        if not scale or np.linalg.norm(x) <= 1e-9 * scale or np.linalg.norm(z) <= 1e-6 * scale:
            raise InputError(
                "record",
                f"coordinate system {label} (dataset 18): its points define no axes (the +x point at the origin or "
                "the +xz point on the x axis)",
            )
        ex, ez = x / np.linalg.norm(x), z / np.linalg.norm(z)
        local = np.array([ex, np.cross(ez, ex), ez])  # rows: the local axes in the reference system
        out[label] = (local @ ref_axes, ref_origin + origin @ ref_axes, kind)
        return out[label]

    for label in legacy:
        resolve(label, ())
    return out


def _system(systems: dict, label: int, node: int, role: str) -> tuple[np.ndarray, np.ndarray]:
    """Axes and origin [m] of coordinate system ``label`` (the global one for an undefined 0 or 1)."""
    if label not in systems:
        if label in (0, 1):
            return np.eye(3), np.zeros(3)
        raise InputError(
            "record",
            f"node {node}: its {role} coordinate system {label} is not defined in the file (no dataset 2420 or 18 "
            "holds it)",
        )
    axes, origin, kind = systems[label]
    if kind != 0:
        raise InputError(
            "record",
            f"node {node}: its {role} coordinate system {label} is {_CS_TYPES.get(kind, f'of type {kind}')}; only "
            "Cartesian ones are read",
        )
    return axes, origin
