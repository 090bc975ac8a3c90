"""One name per quantity, shared by every layer (no numerics, no sympy).

The paper's letters stay: M is the mass matrix [kg, kg m, kg m^2], C the stiffness matrix [N/m, N, N m/rad]
and B the damping matrix [N s/m, N s, N m s/rad] of M q'' + B q' + C q = Q. Angular frequencies omega are in
rad/s throughout (hertz only where a figure or a record says so, or a user gives them so: FREQUENCY_UNITS and
SPEED_UNITS, converted where they come in); a squared frequency is lambda = omega^2.
A standard deviation is always ``std`` (of a frequency [rad/s], of a parameter [its unit]); a relative
standard deviation is ``relative_std``. The full table is docs/architecture.md, "Nomenclature".
"""

from __future__ import annotations

import math

COORDINATES: tuple[str, ...] = ("x", "y", "z", "psi", "theta", "phi")
"""Generalised coordinates: translations of the body origin [m] and small rotations about x, y, z [rad]."""

KINDS: dict[str, str] = {
    "mass": "kg",
    "inertia": "kg m^2",
    "length": "m",
    "stiffness": "N/m",
    "rotational_stiffness": "N m/rad",
    "damping": "N s/m",
    "angle": "rad",
    "ratio": "1",
}
"""Parameter kinds and their SI units."""

POSITIVE_KINDS = frozenset({"mass", "inertia", "length", "stiffness", "rotational_stiffness", "damping"})
"""Kinds whose values must be strictly positive (a length may be 0 where the description allows it)."""


FREQUENCY_UNITS: dict[str, float] = {"rad/s": 1.0, "Hz": 2 * math.pi}
"""Units a natural frequency (or its standard deviation) may be given in, each one's factor to rad/s: the command
line's ``--measured x=2.82Hz``, a campaign's ``frequency_unit`` (a test engineer's software reports hertz)."""

SPEED_UNITS: dict[str, float] = {**FREQUENCY_UNITS, "rpm": 2 * math.pi / 60}
"""Units a speed of rotation may be given in (a rotating unbalance's: ``--speed 1500rpm``), each one's factor to
rad/s."""


AXES: dict[str, tuple[float, float, float]] = {"x": (1.0, 0.0, 0.0), "y": (0.0, 1.0, 0.0), "z": (0.0, 0.0, 1.0)}
"""The description's axes by name: a direction may be given as one, signed ("+x", "-y", "z", "Y-"), as a test
engineer labels an accelerometer's axes (axis_direction)."""


def axis_direction(text: str) -> tuple[float, float, float] | None:
    """The unit direction a signed axis name gives ("+x", "-y", "z", "Z+", "y-": AXES), None for other text."""
    value = text.strip().lower()
    sign = -1.0 if value.startswith("-") or value.endswith("-") else 1.0
    name = value.strip("+-").strip()
    if name not in AXES or value.count("-") + value.count("+") > 1:
        return None
    return tuple(sign * v + 0.0 for v in AXES[name])  # type: ignore[return-value]


def in_rad_per_s(text: str, units: dict[str, float]) -> float:
    """``text``, a number in rad/s or followed by one of ``units`` ("2.82Hz", "2.82 Hz", "1500 rpm"; the unit's case
    aside), in rad/s; a ValueError naming the units where it is neither."""
    value = text.strip()
    for unit, factor in units.items():
        if value.lower().endswith(unit.lower()):
            value, scale = value[: -len(unit)].strip(), factor
            break
    else:
        scale = 1.0
    try:
        return float(value) * scale
    except ValueError:
        raise ValueError(f"not a number in rad/s or with its unit ({', '.join(units)}): {text!r}") from None


def counted(n: int, noun: str, plural: str | None = None) -> str:
    """``n`` with ``noun`` in the number it takes: "1 channel", "12 channels", "0 degrees" (a regular plural, or
    ``plural``: "1 distinct frequency", "2 distinct frequencies")."""
    return f"{n} {noun if n == 1 else plural or noun + 's'}"


def distinct_frequencies(n: int) -> str:
    """ "1 distinct frequency", "3 distinct frequencies": how many distinct natural frequencies a measurement gives."""
    return counted(n, "distinct frequency", "distinct frequencies")


def root_rule_problem(rule: object, unknown: tuple[str, ...] | list[str]) -> str:
    """Why ``rule`` is no root rule on the ``unknown`` (root_rule), in words for an error; "" where it is one."""
    names = ", ".join(unknown)
    if isinstance(rule, str) and root_rule(rule, unknown) is not None:
        return ""
    if len(unknown) < 2:
        return (
            f"a rule picks between solutions of two unknowns, and there is {counted(len(unknown), 'unknown')} ({names})"
        )
    if not isinstance(rule, str) or not any(op in rule for op in "<>"):
        return f"must be a rule A>B or A<B on two unknowns ({names})"
    left, _, right = (part.strip() for part in rule.replace("<", ">").partition(">"))
    strange = [n for n in dict.fromkeys((left, right)) if n not in unknown]
    if strange:
        which = f"{strange[0]} is not an unknown" if len(strange) == 1 else f"{' and '.join(strange)} are not unknowns"
        return f"must be a rule A>B or A<B on two unknowns ({names}): {which}"
    return f"must be a rule A>B or A<B on two different unknowns ({names})"


def root_rule(rule: str, unknown: tuple[str, ...] | list[str]) -> tuple[str, str] | None:
    """The two unknowns (larger, smaller) of a root rule "A>B" or "A<B" (spaces allowed), or None when the
    rule is not one on two distinct unknowns. A description's ``root`` and the command line's --root pick with
    it between solutions that fit the measured frequencies equally."""
    for op in (">", "<"):
        left, sep, right = (part.strip() for part in rule.partition(op))
        if sep and left in unknown and right in unknown and left != right:
            return (left, right) if op == ">" else (right, left)
    return None
