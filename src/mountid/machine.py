"""A machine as the user sees it: a generated module plus input checking, by name or description path.

Importing this module does not import sympy; only resolving a description *file* that is not shipped
(which has to be generated first) does.
"""

from __future__ import annotations

import importlib
import math
import types
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mountid.description import POSITIVE_KINDS
from mountid.errors import InputError


@dataclass(frozen=True)
class Solution:
    """One admissible root of an identification: unknowns [SI] and every natural frequency [rad/s]."""

    parameters: dict[str, float]
    frequencies: dict[str, float]


def shipped_machines() -> list[str]:
    """Names of the generated modules shipped with the package."""
    folder = Path(importlib.import_module("mountid.generated").__file__).parent
    return sorted(p.stem for p in folder.glob("*.py") if not p.stem.startswith("_"))


def _module_from_description(path: Path) -> types.ModuleType:
    from mountid.codegen.numpy_module import render  # sympy: only for descriptions not generated yet
    from mountid.description import load

    source = render(load(path))
    module = types.ModuleType(f"mountid_generated_{path.stem}")
    module.__file__ = str(path)
    exec(compile(source, f"<generated from {path}>", "exec"), module.__dict__)
    return module


class Machine:
    """Checked access to one generated module."""

    def __init__(self, module: types.ModuleType) -> None:
        self.module = module
        self.name: str = module.DESCRIPTION
        self.parameters: dict[str, dict] = module.PARAMETERS
        self.modes: tuple[str, ...] = module.MODES
        self.unique_modes: tuple[str, ...] = module.UNIQUE_MODES
        self.unknown: tuple[str, ...] = module.UNKNOWN

    @classmethod
    def resolve(cls, machine: str) -> Machine:
        """A shipped machine by name, or a description file by path (generated on the fly)."""
        if machine in shipped_machines():
            return cls(importlib.import_module(f"mountid.generated.{machine}"))
        path = Path(machine)
        if path.suffix == ".toml" and path.is_file():
            return cls(_module_from_description(path))
        raise InputError(
            "machine",
            f"unknown machine {machine!r}: not a shipped one ({', '.join(shipped_machines())}) "
            "nor a description file (.toml)",
        )

    # -- inputs -----------------------------------------------------------------------------------
    def values(self, given: dict[str, float], names: tuple[str, ...]) -> dict[str, float]:
        """Values of ``names``: given ones checked, missing ones from the description's nominal values."""
        for name in given:
            if name not in self.parameters:
                raise InputError(name, f"not a parameter of {self.name} (parameters: {', '.join(self.parameters)})")
        out = {}
        for name in names:
            spec = self.parameters[name]
            if name in given:
                value = float(given[name])
            elif spec["value"] is not None:
                value = float(spec["value"])
            else:
                raise InputError(name, "missing: no value given and the description has no nominal value")
            if not math.isfinite(value):
                raise InputError(name, f"must be a finite number, got {value}")
            if spec["kind"] in POSITIVE_KINDS and value <= 0:
                raise InputError(name, f"a {spec['kind']} must be positive, got {value:g} {spec['unit']}")
            out[name] = value
        return out

    def _forward(self, params: dict[str, float]) -> dict[str, float]:
        args = self.values(params, self.module.FORWARD_ARGUMENTS)
        omega = self.module.frequencies(**args)
        return {label: float(w) for label, w in zip(self.modes, omega, strict=True)}

    # -- the two directions -------------------------------------------------------------------------
    def frequencies(self, params: dict[str, float]) -> dict[str, float]:
        """Natural frequency of every mode [rad/s] for the given (or nominal) parameters."""
        return self._forward(params)

    def identify(self, known: dict[str, float], measured: dict[str, float]) -> list[Solution]:
        """Every admissible set of unknowns reproducing the measured frequencies [rad/s]."""
        rep = self.module.REPRESENTATIVE
        chosen: dict[str, tuple[str, float]] = {}
        for label, omega in measured.items():
            if label not in rep:
                raise InputError(label, f"not a mode label of {self.name} (modes: {', '.join(self.modes)})")
            if not math.isfinite(omega) or omega <= 0:
                raise InputError(label, f"a natural frequency must be positive and finite, got {omega}")
            r = rep[label]
            if r in chosen:
                raise InputError(
                    label, f"repeats the frequency of {chosen[r][0]} (equal by symmetry); give one of them"
                )
            chosen[r] = (label, omega)
        for unknown in self.unknown:
            if unknown in known:
                raise InputError(unknown, "is an unknown to identify; do not --set it")
        key = tuple(label for label in self.unique_modes if label in chosen)
        n = len(self.unknown)
        if len(key) != n:
            raise InputError(
                "measured",
                f"{len(key)} distinct frequencies given for {n} unknowns ({', '.join(self.unknown)}); "
                f"give {n} of {', '.join(self.unique_modes)}",
            )
        if key in self.module.UNIDENTIFIABLE:
            raise InputError(
                "measured",
                f"{', '.join(key)} cannot identify the unknowns: {self.module.UNIDENTIFIABLE[key]}",
            )
        if key not in self.module.INVERSES:
            raise InputError("measured", f"no inverse solution was generated for {', '.join(key)}")
        fn = self.module.INVERSES[key]
        knowns = self.values(known, tuple(a for a in self.module.FORWARD_ARGUMENTS if a not in self.unknown))
        omegas = {f"omega_{label}": chosen[label][1] for label in key}
        roots = fn(**knowns, **omegas)
        solutions = []
        for i in np.flatnonzero(roots.admissible):
            params = {u: float(roots.parameters[u][i]) for u in self.unknown}
            solutions.append(Solution(params, self._forward({**knowns, **params})))
        if not solutions:
            raise InputError("measured", self._explain_no_root(key, {k: v[1] for k, v in chosen.items()}))
        return solutions

    def _explain_no_root(self, key: tuple[str, ...], omegas: dict[str, float]) -> str:
        m = self.module

        def blocks(label: str) -> set[int]:
            return {m.MODE_BLOCK[i] for i, lab in enumerate(m.MODES) if m.REPRESENTATIVE[lab] == label}

        def rank(label: str) -> int:
            return m.MODE_RANK[m.MODES.index(label)]

        for a in key:
            for b in key:
                if blocks(a) & blocks(b) and rank(a) < rank(b) and omegas[a] >= omegas[b]:
                    return (
                        f"no physical mount produces these frequencies: {a} ({omegas[a]:g} rad/s) is the lower "
                        f"mode of its block and must lie below {b} ({omegas[b]:g} rad/s)"
                    )
        return (
            "no physical mount produces these frequencies with the given known parameters "
            "(no root with positive stiffnesses puts each frequency on its labelled mode)"
        )
