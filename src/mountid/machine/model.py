"""A machine as the user sees it: a generated module plus input checking, by name or description path.

Importing this module does not import sympy; only resolving a description *file* that is not shipped
(which has to be generated first) does (:mod:`mountid.machine.modules`).
"""

from __future__ import annotations

import contextlib
import copy
import importlib
import itertools
import math
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from mountid.errors import InputError, real_number
from mountid.machine.dynamics import call, rigid_motion
from mountid.machine.modules import GeneratedModule, description_file, module_from_description, shipped_machines
from mountid.nomenclature import POSITIVE_KINDS, distinct_frequencies


class Undetermined(NamedTuple):
    """Distinct frequencies that leave unknowns undetermined (Machine.undetermined_by): the modes, the unknowns
    they leave undetermined, and the modes not among them any one of which would determine them."""

    modes: tuple[str, ...]
    unknowns: tuple[str, ...]
    completing: tuple[str, ...]
    by_all: bool
    """Whether every distinct frequency of the description together determines them."""

    def describe(self) -> str:
        """The sentence for an error: what is not determined, by which modes."""
        verb = "is" if len(self.unknowns) == 1 else "are"
        return f"{', '.join(self.unknowns)} {verb} not determined by {', '.join(self.modes)}"

    def advice(self) -> str:
        """What determines them: one more mode, more modes, or none of the description's."""
        them = "it" if len(self.unknowns) == 1 else "them"
        if self.completing:
            return f"{' or '.join(self.completing)} with them would determine {them}"
        if self.by_all:
            return f"more of the other modes would determine {them}"
        return f"no set of the description's frequencies determines {them}"


@dataclass(frozen=True)
class Solution:
    """One admissible root of an identification: unknowns [SI], every natural frequency [rad/s], the
    relative condition number (relative change of the unknowns per relative change of the given
    frequencies) and, when frequency standard deviations were given, each unknown's standard deviation [SI]."""

    parameters: dict[str, float]
    frequencies: dict[str, float]
    condition: float = float("nan")
    std: dict[str, float] | None = None


MECHANISM_RTOL = 1e-10
"""An eigenvalue of the Jacobi-scaled stiffness matrix (dimensionless, at most its size) at or below this is a
motion the mount leaves without stiffness (a singular matrix gives zero within rounding, of either sign)."""


class Machine:
    """Checked access to one generated module."""

    def __init__(self, module: GeneratedModule) -> None:
        self.module = module
        self.name: str = module.DESCRIPTION
        self.parameters: dict[str, dict] = module.PARAMETERS
        self.modes: tuple[str, ...] = module.MODES
        self.unique_modes: tuple[str, ...] = module.UNIQUE_MODES
        self.unknown: tuple[str, ...] = module.UNKNOWN
        self.damping: tuple[str, ...] = tuple(n for n, p in module.PARAMETERS.items() if p["kind"] == "damping")
        """The damping parameters (B is linear in them), in the description's order."""

    @classmethod
    def resolve(cls, machine: str) -> Machine:
        """A shipped machine by name, or a description file by path (generated on the fly)."""
        if machine in shipped_machines():
            return cls(importlib.import_module(f"mountid.generated.{machine}"))
        path = description_file(machine)
        if path is not None and path.is_file():
            return cls(module_from_description(path))
        raise InputError(
            "machine",
            f"unknown machine {machine!r}: not a shipped one ({', '.join(shipped_machines())}) "
            "nor a description file (.toml)",
        )

    def with_nominal(self, values: dict[str, float]) -> Machine:
        """This machine with ``values`` [SI] as the nominal values of those parameters (where a description
        leaves them without one, a campaign gives the diagnosis the values identified from its measurements);
        the module and the other parameters are shared."""
        for name in values:
            if name not in self.parameters:
                raise InputError(name, f"not a parameter of {self.name} (parameters: {', '.join(self.parameters)})")
        out = copy.copy(self)
        out.parameters = {
            n: {**spec, "value": float(values[n])} if n in values else spec for n, spec in self.parameters.items()
        }
        return out

    # -- inputs -----------------------------------------------------------------------------------
    def defaults(self, given: dict[str, float], names: tuple[str, ...]) -> dict[str, float]:
        """The ``names`` not in ``given`` that take the description's nominal value, with that value."""
        return {n: float(self.parameters[n]["value"]) for n in names if n not in given and n in self.parameters}

    def values(self, given: dict[str, float], names: tuple[str, ...]) -> dict[str, float]:
        """Values of ``names``: given ones checked, missing ones from the description's nominal values.

        A length may be 0 (isolators in the plane of the centre of mass are a legitimate design); the other
        physical kinds must be positive."""
        for name in given:
            if name not in self.parameters:
                raise InputError(name, f"not a parameter of {self.name} (parameters: {', '.join(self.parameters)})")
        out = {}
        for name in names:
            spec = self.parameters[name]
            if name in given:
                value = real_number(given[name], name)
            elif spec["value"] is not None:
                value = float(spec["value"])
            else:
                raise InputError(
                    name,
                    "missing: no value given and the description has no nominal value (on the command line: "
                    f"--set {name}=VALUE)",
                )
            if not math.isfinite(value):
                raise InputError(name, f"must be a finite number, got {value}")
            if spec["kind"] == "length" and value < 0:
                raise InputError(name, f"a length must not be negative, got {value:g} {spec['unit']}")
            if spec["kind"] in POSITIVE_KINDS and spec["kind"] != "length" and value <= 0:
                article = "an" if spec["kind"][0] in "aeiou" else "a"
                raise InputError(name, f"{article} {spec['kind']} must be positive, got {value:g} {spec['unit']}")
            out[name] = value
        return out

    @contextlib.contextmanager
    def _floating_point_errors(
        self, values: dict[str, float], measured: dict[str, float] | None = None
    ) -> Iterator[None]:
        """Floating-point overflow, division by zero and invalid operations inside as an InputError naming
        the parameter furthest from its nominal value, or the ``measured`` frequency [rad/s] furthest from the
        model's at ``values`` where that is further (underflow to zero is caught on the results)."""
        with np.errstate(over="raise", invalid="raise", divide="raise", under="ignore"):
            try:
                yield
            except (FloatingPointError, OverflowError, np.linalg.LinAlgError) as exc:
                raise self._range_error(values, str(exc), measured) from None

    def evaluate(self, function: str, values: dict[str, float]) -> np.ndarray:
        """A generated function of the forward arguments (frequencies, modal_matrix, ...) at checked values.

        Overflow, underflow to zero and invalid operations are input errors that name the parameter furthest
        (in decades) from its nominal value, never NaN, inf or a wrong 0 in the output.
        """
        with self._floating_point_errors(values):
            out = np.asarray(getattr(self.module, function)(**values), dtype=float)
        if not np.all(np.isfinite(out)) or (function == "frequencies" and np.any(out <= 0)):
            raise self._range_error(values, "the result is not finite and positive in double precision")
        return out

    def _range_error(self, values: dict[str, float], why: str, measured: dict[str, float] | None = None) -> InputError:
        """The error for values at which the model fails in double precision: a mount that leaves a motion
        without stiffness (a mechanism) where that is the cause, else the parameter furthest from its nominal
        value (in decades; a zero where the nominal value is not is furthest; from 1 SI unit where the description
        gives none), or the ``measured`` frequency furthest from the model's at the other ``values`` where that is
        further still."""

        def decades(name: str) -> float:
            nominal = self.parameters[name]["value"]
            v = abs(values[name])
            if nominal == 0:
                return 0.0
            return math.inf if v == 0 else abs(math.log10(v / abs(nominal if nominal is not None else 1.0)))

        def stated(name: str) -> str:
            nominal = self.parameters[name]["value"]
            return (
                f"the nominal value is {nominal:g}" if nominal is not None else "the description gives no nominal value"
            )

        worst = max(values, key=decades)
        off = self._furthest_measured(values, measured or {})
        if off is not None and off[1] > decades(worst):
            label, _, model = off
            return InputError(
                "measured",
                f"{label} = {measured[label]:g} rad/s puts the model out of the range of double precision ({why}); "
                f"at these parameters {self.name} has {label} at {model:.4g} rad/s",
            )
        nominal = stated(worst)
        if self._mass_indefinite(values):
            worst = max(self.module.ARGUMENTS["mass_matrix"], key=decades)
            what = (
                "the mass matrix is not positive definite: no rigid body has these mass properties (a product of "
                "inertia beyond sqrt(J_i J_j) of its moments?)"
            )
            if decades(worst) == 0:
                return InputError("machine", f"at {self.name}'s nominal values {what}")
            return InputError(worst, f"{values[worst]:g} {self.parameters[worst]['unit']}: {what}; {stated(worst)}")
        free, motion = self._modes_without_stiffness(values)
        if free:
            worst = max((v for v in values if self.parameters[v]["kind"] != "stiffness"), key=decades)
            nominal = stated(worst)
            what = (
                f"the isolators leave {', '.join(free)}{f' ({motion})' if motion else ''} without stiffness: a "
                "motion they do not hold (are they all on one line, or is a plane of symmetry missing from the "
                "description?)"
            )
            if decades(worst) == 0:
                return InputError("machine", f"at {self.name}'s nominal values {what}")
            return InputError(worst, f"{values[worst]:g} {self.parameters[worst]['unit']}: {what}; {nominal}")
        return InputError(
            worst,
            f"{values[worst]:g} {self.parameters[worst]['unit']} puts the model out of the range of double "
            f"precision ({why}); {nominal}",
        )

    def _furthest_measured(
        self, values: dict[str, float], measured: dict[str, float]
    ) -> tuple[str, float, float] | None:
        """The measured frequency furthest (in decades) from the model's at ``values`` (the unknowns at their
        nominal values): (label, decades, the model's frequency [rad/s]); None without measured frequencies or
        where the model itself leaves double precision at these values."""
        if not measured:
            return None
        try:
            model = self._forward(values)  # evaluate: its floating-point errors are InputErrors
        except InputError:
            return None
        label = max(measured, key=lambda lab: abs(math.log10(measured[lab] / model[lab])))
        return label, abs(math.log10(measured[label] / model[label])), model[label]

    def _mass_indefinite(self, values: dict[str, float]) -> bool:
        """Whether the mass matrix at ``values`` (which hold its arguments) is not positive definite: mass
        properties no rigid body has (a product of inertia beyond sqrt(J_i J_j)); False where they are missing."""
        names = self.module.ARGUMENTS["mass_matrix"]
        if not all(a in values for a in names):
            return False
        with np.errstate(all="ignore"):
            m = np.asarray(self.module.mass_matrix(*(values[a] for a in names)), dtype=float)
            if not np.isfinite(m).all():
                return False
            d = np.sqrt(np.abs(np.diag(m)))
            return bool(np.any(np.diag(m) <= 0) or np.linalg.eigvalsh(m / np.outer(d, d)).min() <= 0)

    def _modes_without_stiffness(self, values: dict[str, float]) -> tuple[tuple[str, ...], str]:
        """Modes the mount's geometry leaves without stiffness (a mechanism), where ``values`` hold every forward
        argument, and where it leaves one motion so the rigid-body motion that is (dynamics.rigid_motion: a
        rotation about the line the isolators sit on); else ((), ""). The test is on the stiffness matrix alone,
        with every stiffness at its nominal value (stiffnesses or masses given decades apart are a range problem,
        not a mechanism): Jacobi-scaled, D^-1/2 C D^-1/2 with D its diagonal, it has an eigenvalue within rounding
        of zero, or a coordinate has no stiffness at all. The modes named are as many as the null space has
        dimensions, those of smallest squared frequency."""
        names = self.module.FORWARD_ARGUMENTS
        if not all(a in values for a in names):
            return (), ""
        nominal = {a: self.parameters[a]["value"] for a in names if self.parameters[a]["kind"] == "stiffness"}
        if any(v is None for v in nominal.values()):
            return (), ""
        at = {**values, **nominal}
        with np.errstate(all="ignore"):
            c = np.asarray(self.module.stiffness_matrix(*(at[a] for a in self.module.ARGUMENTS["stiffness_matrix"])))
            if not np.isfinite(c).all():
                return (), ""
            d = np.diag(c)
            held = d > 0
            scaled = c[np.ix_(held, held)] / np.sqrt(np.outer(d[held], d[held]))
            lam_c, vec_c = np.linalg.eigh(scaled)
            zero = lam_c <= MECHANISM_RTOL
            free = int(np.count_nonzero(~held)) + int(np.count_nonzero(zero))
            if free == 0:
                return (), ""
            lam = np.asarray(self.module.squared_frequencies(**{a: at[a] for a in names}), dtype=float)
        order = np.argsort(np.where(np.isfinite(lam), lam, -np.inf))
        same = self.module.REPRESENTATIVE  # a mode's twin (equal by symmetry) is as free as it
        chosen = {same[self.modes[k]] for k in order[:free]}
        motion = ""
        if free == 1 and len(d) == 6:  # the one motion: a coordinate without stiffness, or C's null vector
            q = np.zeros(6)
            if zero.any():
                q[held] = vec_c[:, 0] / np.sqrt(d[held])
            else:
                q[~held] = 1.0
            with contextlib.suppress(InputError, ArithmeticError, ValueError):
                motion = rigid_motion(q, self.length_scale(values))
        return tuple(label for label in self.modes if same[label] in chosen), motion

    def _forward(self, params: dict[str, float]) -> dict[str, float]:
        args = self.values(params, self.module.FORWARD_ARGUMENTS)
        omega = self.evaluate("frequencies", args)
        return {label: float(w) for label, w in zip(self.modes, omega, strict=True)}

    # -- the two directions -------------------------------------------------------------------------
    def length_scale(self, given: dict[str, float]) -> float:
        """The machine's length scale [m] (the generated effect_scales' length) at the ``given`` values, the
        description's nominal values for the rest: what the rotations of a mode shape are multiplied by to compare
        them with its translations (scaled_unit)."""
        mod = self.module
        return float(call(mod, "effect_scales", self.values(given, mod.ARGUMENTS["effect_scales"]))["length"])

    def isolator_points(self, given: dict[str, float]) -> np.ndarray:
        """Where the isolators sit on the body [m], (3, isolators) in the order of the module's ISOLATORS, at the
        ``given`` values, the description's nominal values for the rest."""
        mod = self.module
        return np.asarray(call(mod, "isolator_points", self.values(given, mod.ARGUMENTS["isolator_points"])))

    def frequencies(self, params: dict[str, float]) -> dict[str, float]:
        """Natural frequency of every mode [rad/s] for the given (or nominal) parameters."""
        return self._forward(params)

    def distinct_measured(self, measured: dict[str, float]) -> dict[str, tuple[str, float]]:
        """The measured natural frequencies [rad/s] checked and keyed by the representative of their mode
        (modes equal by symmetry share one): {representative: (label as given, omega)}. A label that is not a
        mode, a frequency that is not positive and finite, and two twins given at once are input errors."""
        rep = self.module.REPRESENTATIVE
        chosen: dict[str, tuple[str, float]] = {}
        for label, omega in measured.items():
            if label not in rep:
                raise InputError(label, f"not a mode label of {self.name} (modes: {', '.join(self.modes)})")
            omega = real_number(omega, label)
            if not math.isfinite(omega) or omega <= 0:
                raise InputError(label, f"a natural frequency must be positive and finite, got {omega} rad/s")
            r = rep[label]
            if r in chosen:
                twin, first = chosen[r]
                if omega == first:
                    raise InputError(label, f"repeats the frequency of {twin} (equal by symmetry); give one of them")
                apart = abs(omega - first) / min(omega, first)
                raise InputError(
                    label,
                    f"{twin} and {label} are one frequency of {self.name}'s model (equal by symmetry), measured "
                    f"{first:g} and {omega:g} rad/s ({apart:.2%} apart): give one of them, or their mean; a split "
                    "beyond the measurement's uncertainty is the machine's own asymmetry, which mountid diagnose "
                    "locates",
                )
            chosen[r] = (label, omega)
        return chosen

    def measured_std(
        self, chosen: dict[str, tuple[str, float]], std: dict[str, float] | None
    ) -> dict[str, float] | None:
        """The standard deviation [rad/s] of each measured frequency of ``chosen`` (distinct_measured), keyed as
        ``chosen``, from ``std`` keyed by the labels as given (None: no standard deviations). A standard
        deviation of a frequency not measured, one not positive and finite, or one missing are input errors."""
        if std is None:
            return None
        given = {label for label, _ in chosen.values()}
        for label in std:
            if label not in given:
                raise InputError(label, "a standard deviation is given for a frequency that is not measured")
            value = real_number(std[label], label)
            if not (math.isfinite(value) and value > 0):
                raise InputError(label, f"a standard deviation must be positive and finite, got {std[label]}")
        order = [k for k in self.unique_modes if k in chosen]
        missing = [chosen[k][0] for k in order if chosen[k][0] not in std]
        if missing:
            raise InputError(missing[0], "no standard deviation given (give one for every measured frequency)")
        return {k: std[chosen[k][0]] for k in order}

    def undetermined_by(self, labels: Iterable[str]) -> Undetermined | None:
        """What the distinct frequencies of ``labels`` (UNIQUE_MODES) leave undetermined, as the engine derived it
        (UNDETERMINED); None where they determine the unknowns, or are fewer than the unknowns (counted apart).
        They leave undetermined what every set of as many of them as there are unknowns does: the null space of
        their Jacobian lies in each such set's, and equals that of a set holding a basis of its rows (the vertical
        stiffness of one isolator at the centre moves z alone: every other mode leaves it undetermined, alone or
        together; tests/data/central5.toml)."""
        given = [label for label in self.unique_modes if label in set(labels)]
        n = len(self.unknown)
        if len(given) < n:
            return None
        table = self.module.UNDETERMINED
        undetermined = [table.get(key) for key in itertools.combinations(given, n)]
        if not all(undetermined):
            return None
        names = tuple(u for u in self.unknown if all(u in free for free in undetermined))

        def completes(label: str) -> bool:
            keys = itertools.combinations([lab for lab in self.unique_modes if lab in given or lab == label], n)
            return any(label in key and key not in table for key in keys)

        completing = tuple(lab for lab in self.unique_modes if completes(lab))
        by_all = any(key not in table for key in itertools.combinations(self.unique_modes, n))
        return Undetermined(tuple(given), names, completing, by_all)

    def check_known(self, known: dict[str, float]) -> None:
        """An unknown given as known is an input error; so are known values at which the mount leaves a motion
        without stiffness whatever the unknown stiffnesses (a mechanism: no frequencies identify them)."""
        for unknown in self.unknown:
            if unknown in known:
                raise InputError(unknown, "is an unknown to identify; do not --set it")
        if any(self.parameters[u]["kind"] != "stiffness" for u in self.unknown):
            return
        names = self.module.FORWARD_ARGUMENTS
        values = {
            **self.values(known, tuple(a for a in names if a not in self.unknown)),
            **dict.fromkeys(self.unknown, 1.0),
        }
        if self._modes_without_stiffness(values)[0]:  # it puts every stiffness at its nominal value
            raise self._range_error(values, "")

    def identify(
        self, known: dict[str, float], measured: dict[str, float], std: dict[str, float] | None = None
    ) -> list[Solution]:
        """Every admissible set of unknowns reproducing the measured frequencies [rad/s], each with its
        relative condition number and, with ``std`` (standard deviation [rad/s] of every measured
        frequency), the standard deviation of each unknown. Frequencies that leave an unknown undetermined
        at this point (e.g. a coupling that vanishes) are an input error naming it."""
        chosen = self.distinct_measured(measured)
        self.check_known(known)
        key = tuple(label for label in self.unique_modes if label in chosen)
        n = len(self.unknown)
        if len(key) != n:
            raise InputError(
                "measured",
                f"{distinct_frequencies(len(key))} given for {n} unknowns ({', '.join(self.unknown)}); "
                f"give {n} of {', '.join(self.unique_modes)}",
            )
        if key in self.module.UNIDENTIFIABLE:
            raise InputError(
                "measured",
                f"{', '.join(key)} cannot identify the unknowns: {self.module.UNIDENTIFIABLE[key]}",
            )
        if key not in self.module.INVERSES:
            raise InputError("measured", f"no inverse solution was generated for {', '.join(key)}")
        sigma = self.measured_std(chosen, std)
        if sigma is not None:
            sigma = np.array([sigma[k] for k in key])
        fn = self.module.INVERSES[key]
        knowns = self.values(known, tuple(a for a in self.module.FORWARD_ARGUMENTS if a not in self.unknown))
        omegas = {f"omega_{label}": chosen[label][1] for label in key}
        with self._floating_point_errors(knowns, {label: chosen[label][1] for label in key}):
            roots = fn(**knowns, **omegas)
        stds = roots.std(sigma) if sigma is not None else None
        solutions = []
        for i in np.flatnonzero(roots.admissible):
            params = {u: float(roots.parameters[u][i]) for u in self.unknown}
            spread = {u: float(stds[u][i]) for u in self.unknown} if stds is not None else None
            solutions.append(Solution(params, self._forward({**knowns, **params}), float(roots.condition[i]), spread))
        if not solutions:
            free = roots.most_specific_undetermined()
            if free:
                where = [f"{p} = 0" for p in getattr(self.module, "SPECIAL_POINTS", ()) if knowns.get(p) == 0]
                raise InputError(
                    "measured",
                    f"{', '.join(free)} {'is' if len(free) == 1 else 'are'} not determined by {', '.join(key)}"
                    + (f" when {' and '.join(where)}" if where else " at these parameters")
                    + " (the frequencies are reproduced, but the Jacobian is rank-deficient): measure another mode",
                )
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
