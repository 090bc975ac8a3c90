"""Measurement campaigns: a machine, known values, measured modal data, and what is fitted vs held out.

The format is JSON, described by ``mountid/schemas/campaign.schema.json`` (validated with jsonschema; every
violation is reported as one line naming the entry). Example (the paper's four frequencies)::

    {"name": "KID-300, reference paper",
     "machine": "kid300",
     "known": {"m": 838.6, "J_xy": 61.44, "J_z": 51.52, "L_xy": 0.486, "L_z": 0.3},
     "modes": {"x": {"frequency": 17.71}, "psi": {"frequency": 64.10},
               "z": {"frequency": 46.60}, "phi": {"frequency": 36.91}},
     "fit": ["x", "psi"]}
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

import jsonschema

from mountid.errors import InputError
from mountid.machine import Machine
from mountid.measurement.modes import MeasuredMode


def schema() -> dict:
    """The campaign JSON Schema."""
    return json.loads(resources.files("mountid.schemas").joinpath("campaign.schema.json").read_text("utf-8"))


DEFAULT_FREQUENCY_STD = 1e-3
"""Relative standard deviation taken for a frequency given without uncertainty."""
DEFAULT_SHAPE_STD = 0.02
"""Standard deviation per component of a unit-length scaled mode shape given without shape_uncertainty."""


@dataclass(frozen=True)
class Campaign:
    """A validated campaign (see the module docstring)."""

    machine: Machine
    known: dict[str, float]
    modes: dict[str, MeasuredMode]
    fit: tuple[str, ...] | None = None
    """Labels fitted; None: leave-one-out over all."""
    name: str = ""
    records: list[str] = field(default_factory=list)


def _path(error: jsonschema.ValidationError) -> str:
    return ".".join(str(p) for p in error.absolute_path) or "campaign"


def parse(data: dict, base: Path | None = None) -> Campaign:
    """A campaign from its JSON data (``base``: folder that relative description paths start from)."""
    validator = jsonschema.Draft202012Validator(schema())
    errors = sorted(validator.iter_errors(data), key=lambda e: list(e.absolute_path))
    if errors:
        raise InputError(_path(errors[0]), errors[0].message)
    target = data["machine"]
    if base is not None and target.endswith(".toml") and not Path(target).is_absolute():
        target = str(base / target)
    machine = Machine.resolve(target)
    for name in data.get("known", {}):
        if name not in machine.parameters:
            raise InputError(f"known.{name}", f"not a parameter of {machine.name}")
        if name in machine.unknown:
            raise InputError(f"known.{name}", "is an unknown to identify")
        if not math.isfinite(data["known"][name]):
            raise InputError(f"known.{name}", "must be finite")
    seen: dict[str, str] = {}
    modes = {}
    for label, entry in data["modes"].items():
        if label not in machine.modes:
            raise InputError(f"modes.{label}", f"not a mode of {machine.name} (modes: {', '.join(machine.modes)})")
        frequency, std = float(entry["frequency"]), entry.get("uncertainty")
        modes[label] = MeasuredMode(
            label,
            frequency,
            float(std) if std is not None else DEFAULT_FREQUENCY_STD * frequency,
            frequency_std_stated=std is not None,
            damping_ratio=entry.get("damping_ratio"),
            shape=tuple(map(float, entry["shape"])) if "shape" in entry else None,
            shape_std=float(entry.get("shape_uncertainty") or DEFAULT_SHAPE_STD),
        )
        if modes[label].shape is not None and not any(modes[label].shape):
            raise InputError(f"modes.{label}.shape", "is all zeros")
        seen[label] = machine.module.REPRESENTATIVE[label]
    fit = tuple(data["fit"]) if "fit" in data else None
    for label in fit or ():
        if label not in modes:
            raise InputError("fit", f"{label} is not among the measured modes ({', '.join(modes)})")
    distinct = {seen[label] for label in (fit or modes)}
    need = len(machine.unknown) + (0 if fit else 1)  # leave-one-out fits all but one
    if len(distinct) < need:
        raise InputError(
            "fit" if fit else "modes",
            f"{len(distinct)} distinct frequencies for {len(machine.unknown)} unknowns"
            + ("" if fit else " plus one held out"),
        )
    return Campaign(machine, dict(data.get("known", {})), modes, fit, data.get("name", ""), data.get("records", []))


def load(path: str | Path) -> Campaign:
    """Read and validate a campaign file."""
    path = Path(path)
    if not path.is_file():
        raise InputError("campaign", f"no such file: {path}")
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except UnicodeDecodeError as err:
        raise InputError(
            "campaign", f"{path.name} is not UTF-8 text (byte {err.start}): save it as UTF-8 JSON"
        ) from None
    except json.JSONDecodeError as err:
        raise InputError("campaign", f"{path.name} is not JSON: {err.msg} at line {err.lineno}") from None
    return parse(data, path.parent)
