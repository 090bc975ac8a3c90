"""Machine descriptions: the TOML files in ``derivations/`` that a researcher writes.

This module reads and checks the structure of a description without sympy; the symbolic meaning
(expressions, energies, symmetry checks on the expressions) lives in :mod:`mountid.engine.symbolic.model`.
The format is documented in ``docs/descriptions.md``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

import tomllib

from mountid.effects import EFFECT_PARAMETERS
from mountid.errors import DescriptionError
from mountid.nomenclature import COORDINATES, KINDS, POSITIVE_KINDS, root_rule, root_rule_problem

MIRROR_PLANES: dict[str, int] = {"yz": 0, "xz": 1}
"""Vertical mirror planes and the axis each one reverses (``yz``: x -> -x, ``xz``: y -> -y)."""

ROLES = ("known", "unknown")


@dataclass(frozen=True)
class Parameter:
    """One symbol of a description: its kind (and so its SI unit), role and an optional nominal value."""

    name: str
    kind: str
    role: str
    value: float | None
    description: str

    @property
    def unit(self) -> str:
        return KINDS[self.kind]

    @property
    def positive(self) -> bool:
        return self.kind in POSITIVE_KINDS


@dataclass(frozen=True)
class IsolatorGroup:
    """One representative isolator; the engine mirrors it across the declared symmetry planes.

    Entries are expression strings in the description's parameters (SI units).
    """

    name: str
    point: tuple[str, str, str]
    stiffness: tuple[str, str, str]
    damping: tuple[str, str, str] | None
    inclination: tuple[str, str, str] | None


@dataclass(frozen=True)
class ModeSpec:
    """A labelled natural mode: the root of rank ``rank`` (1 = lowest) of the block of ``block``."""

    label: str
    block: tuple[str, ...]
    rank: int


@dataclass(frozen=True)
class Description:
    """A machine description as written in its TOML file (validated for structure)."""

    name: str
    title: str
    symmetry: tuple[str, ...]
    parameters: dict[str, Parameter]
    mass: str
    inertia: tuple[str, str, str]
    products_of_inertia: tuple[str, str, str]
    centre_of_mass: tuple[str, str, str]
    isolators: tuple[IsolatorGroup, ...]
    modes: tuple[ModeSpec, ...] | None
    source: str = field(default="", compare=False)
    root: str = ""
    """Physical rule that picks between solutions fitting the measured frequencies equally, "A>B" or "A<B"
    on two unknowns (e.g. "c_z>c_xy": rubber stiffer in compression than in shear); "" for none."""

    @property
    def known(self) -> tuple[str, ...]:
        return tuple(n for n, p in self.parameters.items() if p.role == "known")

    @property
    def unknown(self) -> tuple[str, ...]:
        return tuple(n for n, p in self.parameters.items() if p.role == "unknown")


def _fail(entry: str, reason: str) -> DescriptionError:
    return DescriptionError(entry, reason)


def _string(value: object, entry: str) -> str:
    if isinstance(value, bool) or not isinstance(value, (str, int, float)):
        raise _fail(entry, f"expected an expression (string or number), got {value!r}")
    if isinstance(value, float) and not math.isfinite(value):
        raise _fail(entry, "must be finite")
    return str(value)


def _triple(value: object, entry: str) -> tuple[str, str, str]:
    if not isinstance(value, list) or len(value) != 3:
        raise _fail(entry, f"expected a list of three expressions (x, y, z), got {value!r}")
    a, b, c = (_string(v, f"{entry}[{i}]") for i, v in enumerate(value))
    return (a, b, c)


def _parameter(name: str, spec: object) -> Parameter:
    entry = f"parameters.{name}"
    if not name.isidentifier() or name in COORDINATES:
        raise _fail(entry, "a parameter name must be an identifier and not a coordinate name")
    if name in EFFECT_PARAMETERS:
        raise _fail(entry, "is reserved for a parameter of a candidate effect (mountid.effects)")
    if not isinstance(spec, dict):
        raise _fail(entry, "expected a table {kind = ..., role = ..., value = ...}")
    extra = set(spec) - {"kind", "role", "value", "description"}
    if extra:
        raise _fail(entry, f"unknown field(s) {sorted(extra)}")
    kind = spec.get("kind")
    if kind not in KINDS:
        raise _fail(f"{entry}.kind", f"must be one of {sorted(KINDS)}, got {kind!r}")
    role = spec.get("role", "known")
    if role not in ROLES:
        raise _fail(f"{entry}.role", f"must be 'known' or 'unknown', got {role!r}")
    if role == "unknown" and kind not in ("stiffness", "rotational_stiffness"):
        raise _fail(f"{entry}.role", "only stiffnesses can be identified from natural frequencies")
    value = spec.get("value")
    if value is not None:
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise _fail(f"{entry}.value", f"must be a finite number, got {value!r}")
        if kind in POSITIVE_KINDS and value <= 0:
            raise _fail(f"{entry}.value", f"a {kind} must be positive, got {value!r}")
        value = float(value)
    return Parameter(name, kind, role, value, str(spec.get("description", "")))


def _modes(raw: object) -> tuple[ModeSpec, ...] | None:
    if raw is None:
        return None
    if not isinstance(raw, list) or not raw:
        raise _fail("modes", "expected a list of [[modes]] tables")
    modes = []
    for i, spec in enumerate(raw):
        entry = f"modes[{i}]"
        if not isinstance(spec, dict) or set(spec) != {"label", "block", "rank"}:
            raise _fail(entry, "expected exactly the fields label, block, rank")
        label, block, rank = spec["label"], spec["block"], spec["rank"]
        if not isinstance(label, str) or not label.isidentifier():
            raise _fail(f"{entry}.label", f"must be an identifier, got {label!r}")
        if not isinstance(block, list) or not block or any(c not in COORDINATES for c in block):
            raise _fail(f"{entry}.block", f"must be a list of coordinates from {COORDINATES}")
        if isinstance(rank, bool) or not isinstance(rank, int) or not 1 <= rank <= len(block):
            raise _fail(f"{entry}.rank", f"must be an integer from 1 to {len(block)}")
        modes.append(ModeSpec(label, tuple(sorted(block, key=COORDINATES.index)), rank))
    labels = [m.label for m in modes]
    for label in labels:
        if labels.count(label) > 1:
            raise _fail("modes", f"label {label!r} is used twice")
    return tuple(modes)


def parse(data: dict, source: str = "") -> Description:
    """Check the structure of a description read from TOML and return it."""
    if not isinstance(data, dict):
        raise _fail("description", "expected a TOML table")
    extra = set(data) - {"name", "title", "symmetry", "parameters", "body", "isolators", "modes", "root"}
    if extra:
        raise _fail("description", f"unknown top-level entries {sorted(extra)}")
    name = data.get("name")
    if not isinstance(name, str) or not name.isidentifier():
        raise _fail("name", f"must be an identifier (it names the generated module), got {name!r}")
    symmetry = data.get("symmetry")
    if not isinstance(symmetry, list) or any(p not in MIRROR_PLANES for p in symmetry):
        raise _fail("symmetry", f"must be a list of mirror planes from {sorted(MIRROR_PLANES)} ([] for none)")
    if len(set(symmetry)) != len(symmetry):
        raise _fail("symmetry", "a plane is listed twice")
    raw_params = data.get("parameters")
    if not isinstance(raw_params, dict) or not raw_params:
        raise _fail("parameters", "expected a table of parameters")
    parameters = {n: _parameter(n, s) for n, s in raw_params.items()}
    if not any(p.role == "unknown" for p in parameters.values()):
        raise _fail("parameters", "no parameter has role = 'unknown': nothing to identify")
    body = data.get("body")
    if not isinstance(body, dict) or "mass" not in body or "inertia" not in body:
        raise _fail("body", "expected a table with mass and inertia")
    extra = set(body) - {"mass", "inertia", "products_of_inertia", "centre_of_mass"}
    if extra:
        raise _fail("body", f"unknown field(s) {sorted(extra)}")
    raw_iso = data.get("isolators")
    if not isinstance(raw_iso, list) or not raw_iso:
        raise _fail("isolators", "expected at least one [[isolators]] group")
    groups = []
    for i, g in enumerate(raw_iso):
        entry = f"isolators[{i}]"
        if not isinstance(g, dict):
            raise _fail(entry, "expected a table")
        extra = set(g) - {"name", "point", "stiffness", "damping", "inclination"}
        if extra:
            raise _fail(entry, f"unknown field(s) {sorted(extra)}")
        gname = g.get("name", f"group{i}")
        entry = f"isolators.{gname}"
        if "point" not in g or "stiffness" not in g:
            raise _fail(entry, "needs point and stiffness")
        groups.append(
            IsolatorGroup(
                name=str(gname),
                point=_triple(g["point"], f"{entry}.point"),
                stiffness=_triple(g["stiffness"], f"{entry}.stiffness"),
                damping=_triple(g["damping"], f"{entry}.damping") if "damping" in g else None,
                inclination=_triple(g["inclination"], f"{entry}.inclination") if "inclination" in g else None,
            )
        )
    names = [g.name for g in groups]
    if len(set(names)) != len(names):
        raise _fail("isolators", "two groups share a name")
    return Description(
        name=name,
        title=str(data.get("title", name)),
        symmetry=tuple(symmetry),
        parameters=parameters,
        mass=_string(body["mass"], "body.mass"),
        inertia=_triple(body["inertia"], "body.inertia"),
        products_of_inertia=_triple(body.get("products_of_inertia", [0, 0, 0]), "body.products_of_inertia"),
        centre_of_mass=_triple(body.get("centre_of_mass", [0, 0, 0]), "body.centre_of_mass"),
        isolators=tuple(groups),
        modes=_modes(data.get("modes")),
        source=source,
        root=_root(data.get("root", ""), parameters),
    )


def _root(rule: object, parameters: dict[str, Parameter]) -> str:
    """A root rule "A>B" or "A<B" on two unknowns, checked (see Description.root)."""
    if rule == "":
        return ""
    unknown = [n for n, p in parameters.items() if p.role == "unknown"]
    parts = root_rule(rule, unknown) if isinstance(rule, str) else None
    if parts is not None:
        return f"{parts[0]}>{parts[1]}"
    raise _fail("root", f"{root_rule_problem(rule, unknown)}, got {rule!r}")


def load(path: str | Path) -> Description:
    """Read a description file."""
    path = Path(path)
    try:
        with path.open("rb") as f:
            data = tomllib.load(f)
    except FileNotFoundError:
        raise _fail("machine", f"no description file {str(path)!r}") from None
    except tomllib.TOMLDecodeError as exc:
        raise _fail(str(path), f"not valid TOML: {exc}") from None
    return parse(data, source=path.name)


def shipped_descriptions() -> dict[str, Path]:
    """The descriptions shipped in ``derivations/``, by name."""
    folder = resources.files("mountid.derivations")
    return {Path(str(f)).stem: Path(str(f)) for f in folder.iterdir() if str(f).endswith(".toml")}
