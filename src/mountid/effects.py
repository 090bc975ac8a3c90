"""The catalogue of candidate unmodelled effects: names, parameters, units and plausible ranges.

This module holds what an effect *is* (no sympy, no numerics). How each one changes the model:

- ``generated``: the effect adds or changes energy terms; :mod:`mountid.engine.symbolic.effects` derives the
  extended M, C, B from the energies and the engine emits them as ``effect_<name>()`` in every generated
  machine module.
- ``isolator``: one isolator's stiffness scaled by (1 + s); the per-isolator stiffness matrices are generated
  (``isolator_stiffness()``, Hessians of each isolator's potential energy).
- ``frequency``: rubber stiffness rising with frequency as a standard linear solid, c(omega) = c g(omega),
  g = 1 + beta x^2 / (1 + x^2), x = omega / omega_c (c is then the static stiffness): every isolator
  stiffness enters C linearly, so each mode solves omega^2 = g(omega) lambda_k(C, M).
- ``damping``: the measured frequencies are damped ones, |Im p| of M p^2 + eta B p + C = 0 (generated B).
- ``sensor``: the shapes were read through a sensor frame turned by a yaw angle and a reference point off in
  height; the generated ``point_jacobian`` maps the motion to that point.

Plausible ranges are multiples of machine scales (``effect_scales()`` of the generated module): ``length``
the RMS distance of the isolators from the centre of mass [m], ``mass`` the body mass [kg], ``stiffness`` the
mean isolator stiffness per direction [N/m], ``vertical`` and ``horizontal`` the total translational
stiffness C[z,z] and C[x,x] [N/m], ``rotational`` stiffness * length^2 [N m/rad], ``one`` 1.
The documentation of every effect (cause, signature on the modes, typical size) is docs/effects.md.
"""

from __future__ import annotations

from dataclasses import dataclass

STANDARD_GRAVITY = 9.80665
"""g [m/s^2] (the gravity_preload potential is derived with this value)."""


EFFECT_KINDS: tuple[str, ...] = ("generated", "isolator", "frequency", "damping", "sensor")
"""How an effect enters the model (module docstring); the diagnosis has one strategy per kind."""


@dataclass(frozen=True)
class EffectParameter:
    """One physical parameter of an effect, its unit and plausible range (``plausible`` times ``scale``)."""

    name: str
    unit: str
    scale: str
    plausible: tuple[float, float]
    start: float
    """Where the fit starts (a multiple of ``scale``): the effect is nil there, or small."""
    description: str
    floor: float | None = None
    """Hard lower bound of the search (a multiple of ``scale``) where the sign carries no meaning."""
    both_sides: bool = True
    """For a signed parameter: the fit also starts on either side of zero (it has a local minimum on the
    wrong side, as a height does). False where the machine's symmetry or the mode shapes decide the sign
    from any start (a horizontal position)."""


@dataclass(frozen=True)
class Effect:
    """A candidate effect: how it enters the model (see the module docstring) and its parameters."""

    name: str
    kind: str
    """How the effect enters the model: generated, isolator, frequency, damping or sensor (module docstring)."""
    title: str
    parameters: tuple[EffectParameter, ...]
    signature: str
    """One line: what the effect does to the six modes."""

    def __post_init__(self) -> None:
        if self.kind not in EFFECT_KINDS:
            raise ValueError(f"effect {self.name}: kind {self.kind!r} is not one of {EFFECT_KINDS}")


def _p(
    name: str, unit: str, scale: str, lo: float, hi: float, start: float, text: str, both_sides: bool = True
) -> EffectParameter:
    return EffectParameter(name, unit, scale, (lo, hi), start, text, both_sides=both_sides)


CATALOGUE: tuple[Effect, ...] = (
    Effect(
        "com_offset",
        "generated",
        "horizontal centre-of-mass offset",
        (
            _p("dx_com", "m", "length", -0.15, 0.15, 0.0, "centre of mass ahead of the isolator pattern's centre (x)"),
            _p("dy_com", "m", "length", -0.15, 0.15, 0.0, "centre of mass beside the isolator pattern's centre (y)"),
        ),
        "couples z with rocking and the horizontal modes with yaw; frequencies move in second order, "
        "mode shapes in first order",
    ),
    Effect(
        "cog_height",
        "generated",
        "centre-of-mass height error",
        (_p("dz_com", "m", "length", -0.3, 0.3, 0.0, "centre of mass higher than described"),),
        "changes the coupling of translation and rocking: the lower (x, y) and upper (psi, theta) coupled "
        "modes move apart or together; z and phi stay",
    ),
    Effect(
        "isolator_scatter",
        "isolator",
        "one isolator stiffer or softer than the others",
        (_p("scatter", "1", "one", -0.5, 1.0, 0.0, "relative stiffness change of one isolator (all directions)"),),
        "splits the twin modes (x/y, psi/theta) and couples modes across the symmetry planes; which isolator "
        "shows only in the mode shapes",
    ),
    Effect(
        "rotational_stiffness",
        "generated",
        "isolator bending and torsion stiffness",
        (
            _p("k_bend", "N m/rad", "rotational", 0.0, 0.1, 0.0, "bending stiffness of one isolator"),
            _p("k_torsion", "N m/rad", "rotational", 0.0, 0.1, 0.0, "torsion stiffness of one isolator"),
        ),
        "raises the rocking modes (bending) and the yaw mode phi (torsion); z untouched",
    ),
    Effect(
        "frequency_dependent",
        "frequency",
        "viscoelastic rubber: stiffness rising with frequency",
        (
            _p("rubber_strength", "1", "one", 0.0, 1.0, 0.1, "stiffening from static to high frequency, beta"),
            EffectParameter(
                "rubber_corner",
                "1",
                "one",
                (0.1, 10.0),
                1.0,
                "corner frequency of the stiffening over the geometric mean of the measured frequencies",
            ),
        ),
        "every isolator stiffness times g(w) = 1 + beta x^2/(1 + x^2), x = w/w_c (a standard linear solid): "
        "the spectrum stretches, high modes rise more than low ones; shapes unchanged",
    ),
    Effect(
        "foundation",
        "generated",
        "compliant support below the isolators (pads under the feet or a frame on ground springs)",
        (
            _p(
                "m_found",
                "kg",
                "mass",
                0.05,
                10.0,
                0.5,
                "mass of the support (radius of gyration: the length scale)",
            ),
            _p(
                "k_found", "N/m", "vertical", 0.5, 100.0, 20.0, "vertical stiffness of the support (all ground springs)"
            ),
            _p("found_shear", "1", "one", 0.1, 2.0, 0.5, "horizontal over vertical stiffness of each ground spring"),
            _p(
                "found_spread",
                "1",
                "one",
                0.5,
                4.0,
                1.0,
                "horizontal distance of the ground springs from the axis over that of the isolator feet",
            ),
            _p(
                "found_depth",
                "m",
                "length",
                0.0,
                2.0,
                0.0,
                "depth of the support's centre of mass and its ground springs below the isolator feet",
            ),
        ),
        "a rigid support (six coordinates) between isolators and ground, on a ground spring below each isolator "
        "(vertical k_found/n, horizontal found_shear times that), found_spread times as far from the axis and "
        "found_depth below the feet: every mode drops, most those whose isolators are stiffest relative to the "
        "support (z, rocking); six support modes",
    ),
    Effect(
        "added_mass",
        "generated",
        "an unmodelled attached mass (drive, motor)",
        (
            _p("m_added", "kg", "mass", 0.0, 0.3, 0.0, "attached mass"),
            _p("x_added", "m", "length", -1.5, 1.5, 0.0, "its position ahead of the centre of mass (x)", False),
            _p("y_added", "m", "length", -1.5, 1.5, 0.0, "its position beside the centre of mass (y)", False),
            _p("h_added", "m", "length", -2.0, 2.0, 0.0, "its height above the centre of mass"),
            _p(
                "g_added",
                "m",
                "length",
                0.0,
                0.5,
                0.0,
                "its radius of gyration about its own centre (a body, not a point)",
            ),
        ),
        "lowers every translational mode by the mass ratio and the rocking modes by m h^2, yaw by m (x^2 + y^2); "
        "off the axis it couples z with rocking and x, y with yaw",
    ),
    Effect(
        "drive_belt",
        "generated",
        "a belt or coupling stiffness acting along x",
        (
            _p("k_belt", "N/m", "horizontal", 0.0, 0.5, 0.0, "stiffness of the belt along x"),
            _p("h_belt", "m", "length", -2.0, 2.0, 0.0, "height of the belt's line above the centre of mass"),
        ),
        "raises the x-theta modes only: the x/y and psi/theta twins split",
    ),
    Effect(
        "gravity_preload",
        "generated",
        "rocking geometric stiffness of the preloaded isolators",
        (_p("h_preload", "m", "length", 0.0, 3.0, 0.0, "depth below the centre of mass where the preload acts"),),
        "lowers the rocking stiffness by m g h: psi/theta (and x/y through coupling) drop; z and phi stay",
    ),
    Effect(
        "damping",
        "damping",
        "measured damped frequencies vs undamped model",
        (
            EffectParameter(
                "damping_scale", "1", "one", (0.0, 5.0), 1.0, "factor on the described damping matrix B", floor=0.0
            ),
        ),
        "each mode lower by about zeta^2/2 of its own damping ratio; shapes nearly unchanged",
    ),
    Effect(
        "sensor_error",
        "sensor",
        "sensor frame turned or placed off in height",
        (
            _p("sensor_yaw", "rad", "one", -0.1, 0.1, 0.0, "yaw of the sensor frame about z"),
            _p("sensor_dz", "m", "length", -0.5, 0.5, 0.0, "height error of the point the shapes refer to"),
        ),
        "mode shapes rotated in x-y and tilted by rocking; frequencies exactly unchanged",
    ),
)
"""Every candidate effect, in the order reports list them."""

EFFECTS: dict[str, Effect] = {e.name: e for e in CATALOGUE}
EFFECT_PARAMETERS: tuple[str, ...] = tuple(p.name for e in CATALOGUE for p in e.parameters)
"""Every effect parameter name (reserved: a description may not use them)."""
