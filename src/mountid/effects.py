"""The catalogue of candidate unmodelled effects: names, parameters, units and plausible ranges.

This module holds what an effect *is* (no sympy, no numerics). How each one changes the model:

- ``generated``: the effect adds or changes energy terms; :mod:`mountid.engine.symbolic.effects` derives the
  extended M, C, B from the energies and the engine emits them as ``effect_<name>()`` in every generated
  machine module.
- ``isolator``: one isolator's shear stiffness (its local x and y) scaled by (1 + s_shear) and its axial
  stiffness (local z) by (1 + s_axial); the per-isolator stiffness matrices and their axial parts are
  generated (``isolator_stiffness()``, ``isolator_axial_stiffness()``, Hessians of each isolator's energy).
- ``frequency``: rubber stiffness rising with frequency as a standard linear solid, c(omega) = c g(omega),
  g = 1 + beta x^2 / (1 + x^2), x = omega / omega_c (c is then the static stiffness): every isolator
  stiffness enters C linearly, so each mode solves omega^2 = g(omega) lambda_k(C, M).
- ``amplitude``: hardening rubber by equivalent linearisation: in each mode each isolator's stiffness along each
  of its local axes (its own axis from the generated ``isolator_axial_stiffness()``, its shear axes across it;
  a round mount's along the machine's x and y as far as its axis allows) times 1 + h (d / d_max)^2, d the
  deformation amplitude along that axis in the mode, d_max the largest over the isolators and axes: a test that
  excites each mode to the same largest isolator deformation. Each mode solves its own stiffened eigenproblem,
  iterated to its fixed point; no change of M and C common to the modes, so never part of a pair.
- ``damping``: the measured frequencies are damped ones, |Im p| of M p^2 + eta B p + C = 0 (generated B); in
  a campaign of poles' |p| (records), converted to undamped ones, eta acts on the damping ratios alone.
- ``sensor``: the shapes were read through a sensor frame turned by a yaw angle and a reference point off in
  height; the generated ``point_jacobian`` maps the motion to that point.
- ``channel``: one channel of the layout the shapes were estimated from (the campaign's ``sensors``) read along
  a turned axis; the shapes are the least-squares estimate from the layout's readings with that channel's row
  turned.
- ``placement``: one channel of that layout sits off its stated point across its direction; its row is that of
  the point where it sits (the generated ``point_jacobian`` is affine in the point, so the row changes linearly
  with the offset and only in the rotations).
- ``reversal``: one channel of that layout reads with its polarity reversed (along -d); its row is negated. No
  parameter: the fit is the unknowns' alone, at the channels whose reversal promises most from the unknowns the
  frequencies identify.
- ``channels``: two channels of that layout read along turned axes; the shapes are the least-squares estimate
  with both rows turned. Fitted at the pairs of channels whose turns promise most; two effects of one kind
  (``Effect.parts``): a pair's prior odds, and never part of a pair.
- ``turned_placement``: one channel of that layout read along a turned axis at a point off its stated one (a
  ``channel`` and a ``placement`` on one channel): its row is the turned axis times the point Jacobian where the
  sensor sits. Fitted at the channels whose turn and offset promise most; two slips of a test (``Effect.parts``).
- ``tilt``: one isolator mounted tilted: its stiffness tensor K turned by two small rotations about the axes across
  its own axis, C_i = J^T K J becoming J^T R K R^T J (K and J from the generated ``isolator_stiffness()``), and its
  damping tensor with it (B_i = J^T D J from the generated ``isolator_damping()``). Fitted
  at each isolator; never part of a pair (its pairs would be fitted at every isolator beside every other effect).

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


EFFECT_KINDS: tuple[str, ...] = (
    "generated",
    "isolator",
    "frequency",
    "amplitude",
    "damping",
    "sensor",
    "channel",
    "placement",
    "reversal",
    "channels",
    "turned_placement",
    "tilt",
)
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
    refines: bool = False
    """A refinement of the effect's shape (the support's aspect ratio, an attached body's anisotropy): a fit
    from the default starts holds it at its start, then releases it from the best fit, so the freedom it adds
    does not lead the search away from the basins the effect without it reaches."""

    @property
    def magnitude(self) -> bool:
        """A size of the effect that is positive throughout its plausible range (a stiffness, a mass): fitted
        in log, and its relative standard deviation says whether the data determine the effect's size."""
        return self.plausible[0] > 0

    @property
    def signed(self) -> bool:
        """Whether the plausible range runs across zero (a scatter, a height, a turn): the effect acts either way
        and a fit may stop on the wrong side."""
        return self.plausible[0] < 0 < self.plausible[1]

    @property
    def middle(self) -> float:
        """The middle of the plausible range (a multiple of ``scale``)."""
        return 0.5 * (self.plausible[0] + self.plausible[1])

    @property
    def lopsided(self) -> bool:
        """A signed parameter whose range is not centred on zero (a scatter of -0.5 to 1): its middle lies on
        one side, and a fit started there does not reach a minimum on the other."""
        return self.signed and self.middle != 0

    @property
    def unit_suffix(self) -> str:
        """The unit as it follows a number in text: ' N/m', nothing for a ratio (unit '1')."""
        return "" if self.unit == "1" else f" {self.unit}"


@dataclass(frozen=True)
class Effect:
    """A candidate effect: how it enters the model (see the module docstring) and its parameters."""

    name: str
    kind: str
    """How the effect enters the model: one of EFFECT_KINDS (module docstring)."""
    title: str
    parameters: tuple[EffectParameter, ...]
    signature: str
    """One line: what the effect does to the six modes."""
    parts: int = 1
    """How many effects of one kind it stands for (two turned channels: 2): its prior odds against a single
    effect are a pair's (DiagnosisSettings.pair_prior) per part beyond the first, and it is never part of a pair."""
    extends: tuple[str, ...] = ()
    """The effects it holds as its special cases, its other parts nil (two turned channels hold one turned channel;
    a channel turned and off its point holds one turned and one misplaced): it fits those effects' data as well, so
    the data never rule it out beside them (candidates.rank)."""

    def __post_init__(self) -> None:
        if self.kind not in EFFECT_KINDS:
            raise ValueError(f"effect {self.name}: kind {self.kind!r} is not one of {EFFECT_KINDS}")


def _p(
    name: str,
    unit: str,
    scale: str,
    lo: float,
    hi: float,
    start: float,
    text: str,
    both_sides: bool = True,
    refines: bool = False,
    floor: float | None = None,
) -> EffectParameter:
    return EffectParameter(
        name, unit, scale, (lo, hi), start, text, floor=floor, both_sides=both_sides, refines=refines
    )


def _turn(name: str, text: str) -> EffectParameter:
    """A turn about one axis across a channel's direction or an isolator's axis [rad]: within 0.35 rad (20 degrees)
    either way, from 0."""
    return _p(name, "rad", "one", -0.35, 0.35, 0.0, text, False)


def _offset(name: str, text: str) -> EffectParameter:
    """A channel's offset from its stated point along one axis across its direction [m]: within one machine
    length either way, from 0."""
    return _p(name, "m", "length", -1.0, 1.0, 0.0, text, False)


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
        "one isolator stiffer or softer than the others (in shear, along its axis, or both)",
        (
            _p("scatter_shear", "1", "one", -0.5, 1.0, 0.0, "relative change of one isolator's shear stiffness", False),
            _p("scatter_axial", "1", "one", -0.5, 1.0, 0.0, "relative change of one isolator's axial stiffness", False),
        ),
        "splits the twin modes (x/y, psi/theta) and couples modes across the symmetry planes; which isolator "
        "shows only in the mode shapes",
    ),
    Effect(
        "rotational_stiffness",
        "generated",
        "isolator bending and torsion stiffness",
        (
            _p("k_bend", "N m/rad", "rotational", 0.002, 0.1, 0.005, "bending stiffness of one isolator"),
            _p("k_torsion", "N m/rad", "rotational", 0.002, 0.1, 0.005, "torsion stiffness of one isolator"),
        ),
        "raises the rocking modes (bending) and the yaw mode phi (torsion); z untouched",
    ),
    Effect(
        "frequency_dependent",
        "frequency",
        "viscoelastic rubber: stiffness rising with frequency",
        (
            _p("rubber_strength", "1", "one", 0.005, 1.0, 0.1, "stiffening from static to high frequency, beta"),
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
        "rubber_hardening",
        "amplitude",
        "hardening rubber: isolators stiffer the further a mode deforms them",
        (_p("hardening", "1", "one", 0.01, 1.0, 0.05, "relative stiffening of an isolator at the largest amplitude"),),
        "each mode sees its own isolator stiffness, 1 + h (d/d_max)^2 at each isolator (d its amplitude there in "
        "that mode, every mode excited to the same largest d_max): modes that move all isolators alike (z) rise "
        "most, those that leave some at rest (rocking, yaw about an isolator) less; shapes lean towards the "
        "isolators that move least",
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
                "distance of the ground springs from the yz plane (along x) over that of the isolator feet",
            ),
            _p(
                "found_aspect",
                "1",
                "one",
                0.25,
                4.0,
                1.0,
                "the ground springs' spread along y over their spread along x (1: under the feet, scaled alike)",
                refines=True,
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
        "(vertical k_found/n, horizontal found_shear times that), found_spread times as far from the yz plane "
        "and found_spread found_aspect times as far from the xz plane as the foot, found_depth below it: every "
        "mode drops, most those whose isolators are stiffest relative to the support (z, rocking); six support "
        "modes",
    ),
    Effect(
        "added_mass",
        "generated",
        "an unmodelled attached mass (drive, motor)",
        (
            _p("m_added", "kg", "mass", 0.005, 0.3, 0.01, "attached mass"),
            _p("x_added", "m", "length", -1.5, 1.5, 0.0, "its position ahead of the centre of mass (x)", False),
            _p("y_added", "m", "length", -1.5, 1.5, 0.0, "its position beside the centre of mass (y)", False),
            _p("h_added", "m", "length", -2.0, 2.0, 0.0, "its height above the centre of mass"),
            _p(
                "g_added",
                "m",
                "length",
                0.0,
                0.5,
                0.1,
                "its radius of gyration about its own vertical axis (a body, not a point)",
                floor=0.0,  # its inertia is m g^2: -g is the same body, outside the plausible range
            ),
            _p(
                "a_added",
                "1",
                "one",
                -0.5,
                0.5,
                0.0,
                "its own inertia about x and y, (1 + a) and (1 - a) times that about z (0: alike about every axis; "
                "below 0 for a motor with its shaft along x)",
                both_sides=False,
                refines=True,
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
            _p("k_belt", "N/m", "horizontal", 0.006, 0.5, 0.01, "stiffness of the belt along x"),
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
    Effect(
        "sensor_turned",
        "channel",
        "one channel's sensor turned (misaligned) on its mount",
        (
            _turn("turn_1", "turn of the sensor's axis toward the first axis across it"),
            _turn("turn_2", "turn of the sensor's axis toward the second axis across it"),
        ),
        "one channel reads along a turned axis: the shapes estimated from the layout are distorted in the motions "
        "that channel carries; frequencies exactly unchanged",
    ),
    Effect(
        "sensor_misplaced",
        "placement",
        "one channel's sensor mounted off its stated point",
        (
            _offset("offset_1", "offset of the sensor's point along the first axis across its direction"),
            _offset("offset_2", "offset of the sensor's point along the second axis across its direction"),
        ),
        "one channel reads the motion of another point: the shapes estimated from the layout are distorted in the "
        "rotations that channel carries (translations read true); frequencies exactly unchanged",
    ),
    Effect(
        "sensor_reversed",
        "reversal",
        "one channel's sensor reads with reversed polarity (mounted upside down, or its cable wired the wrong way)",
        (),
        "one channel reads the opposite of the motion along its axis: the shapes estimated from the layout are "
        "distorted along that channel's column of the layout's pseudo-inverse; frequencies exactly unchanged",
    ),
    Effect(
        "two_sensors_turned",
        "channels",
        "two channels' sensors turned (misaligned) on their mounts",
        (
            _turn("turn_1", "turn of the first channel toward the first axis across it"),
            _turn("turn_2", "turn of the first channel toward the second axis across it"),
            _turn("turn_3", "turn of the second channel toward the first axis across it"),
            _turn("turn_4", "turn of the second channel toward the second axis across it"),
        ),
        "two channels read along turned axes: the shapes estimated from the layout are distorted in the motions "
        "those channels carry, in ways one channel's turn or offset does not reach; frequencies exactly unchanged",
        parts=2,
        extends=("sensor_turned",),
    ),
    Effect(
        "sensor_turned_misplaced",
        "turned_placement",
        "one channel's sensor turned (misaligned) on its mount and mounted off its stated point",
        (
            _turn("turn_1", "turn of the sensor's axis toward the first axis across it"),
            _turn("turn_2", "turn of the sensor's axis toward the second axis across it"),
            _offset("offset_1", "offset of the sensor's point along the first axis across its stated direction"),
            _offset("offset_2", "offset of the sensor's point along the second axis across its stated direction"),
        ),
        "one channel reads the motion of another point along a turned axis: the shapes estimated from the layout "
        "are distorted in the motions that channel carries, in ways its turn or its offset alone does not reach; "
        "frequencies exactly unchanged",
        parts=2,
        extends=("sensor_turned", "sensor_misplaced"),
    ),
    Effect(
        "isolator_tilted",
        "tilt",
        "one isolator mounted tilted (its stiffness axes turned)",
        (
            _turn("tilt_1", "turn of the isolator's axes about the first axis across its own axis"),
            _turn("tilt_2", "turn of the isolator's axes about the second axis across its own axis"),
        ),
        "the isolator's axial and shear stiffness couple in the machine's axes: modes couple across the symmetry "
        "planes at that isolator and the frequencies move in first order of the tilt times the difference of its "
        "axial and shear stiffness; which isolator shows only in the mode shapes",
    ),
)
"""Every candidate effect, in the order reports list them (the tilted isolator, added last, after the channels so
that every other candidate's fits are as they were)."""

EFFECTS: dict[str, Effect] = {e.name: e for e in CATALOGUE}
EFFECT_PARAMETERS: tuple[str, ...] = tuple(p.name for e in CATALOGUE for p in e.parameters)
"""Every effect parameter name (reserved: a description may not use them)."""


PAIR_EXCLUSIONS: dict[frozenset[str], str] = {
    frozenset({"com_offset", "cog_height"}): "both move the body's centre of mass: one com_offset in 3D, not a pair",
    frozenset({"frequency_dependent", "damping"}): "both change how frequencies follow from M and C",
    frozenset({"foundation", "rotational_stiffness"}): "the isolators stand on the support, not on the ground",
    frozenset({"foundation", "gravity_preload"}): "the isolators stand on the support, not on the ground",
    frozenset({"foundation", "frequency_dependent"}): "the support's springs would stiffen with the rubber",
    frozenset({"sensor_error", "sensor_turned"}): "both change how the shapes are read",
    frozenset({"isolator_scatter", "sensor_turned"}): "at every isolator by every channel: 48 to 96 fits",
    frozenset({"sensor_error", "sensor_misplaced"}): "both change how the shapes are read",
    frozenset({"sensor_turned", "sensor_misplaced"}): "both change how the shapes are read",
    frozenset({"isolator_scatter", "sensor_misplaced"}): "at every isolator by every channel: 48 to 96 fits",
    frozenset({"sensor_error", "sensor_reversed"}): "both change how the shapes are read",
    frozenset({"sensor_turned", "sensor_reversed"}): "both change how the shapes are read",
    frozenset({"sensor_misplaced", "sensor_reversed"}): "both change how the shapes are read",
}
"""Pairs of effects that do not compose by adding their changes of M, C and B (the changes act on the same
energy term, or one effect's energy is written for isolators on the ground, or the pair would be fitted at
every isolator with every channel), with the reason. A scattered isolator beside a reversed channel is a pair:
the reversal is fitted at few channels (its screen), and the pair at each of those with each isolator. The
damping effect (the measured frequencies are damped ones) is a reading of the data, not a second physical
effect: it is never paired."""


@dataclass(frozen=True)
class Pair:
    """Two effects at once: the changes of M, C (and B) of each added to the nominal model, the first's
    frequency map or sensor frame where it has one (mountid.diagnosis.strategies.Composite)."""

    first: Effect
    second: Effect
    kind: str = "pair"

    @property
    def name(self) -> str:
        return f"{self.first.name}+{self.second.name}"

    @property
    def title(self) -> str:
        return f"{self.first.title} and {self.second.title}"

    @property
    def parameters(self) -> tuple[EffectParameter, ...]:
        return self.first.parameters + self.second.parameters

    @property
    def members(self) -> tuple[Effect, Effect]:
        return (self.first, self.second)

    @property
    def signature(self) -> str:
        return f"{self.first.signature}; and {self.second.signature}"


def pair(a: Effect, b: Effect) -> Pair | None:
    """The pair of two different catalogue effects in catalogue order (None when they do not compose:
    PAIR_EXCLUSIONS, either is the damping effect, either stiffens each mode on its own (kind ``amplitude``:
    no change of M and C to add), either is a tilted isolator (kind ``tilt``: fitted at each isolator, its pairs
    would be fitted at every isolator beside every other effect), or either is two effects of one kind already
    (Effect.parts))."""
    if (
        a.name == b.name
        or "damping" in (a.name, b.name)
        or "amplitude" in (a.kind, b.kind)
        or "tilt" in (a.kind, b.kind)
        or max(a.parts, b.parts) > 1
        or frozenset({a.name, b.name}) in PAIR_EXCLUSIONS
    ):
        return None
    order = [e.name for e in CATALOGUE]
    first, second = sorted((a, b), key=lambda e: order.index(e.name))
    return Pair(first, second)


def pair_name(names: list[str] | tuple[str, ...]) -> str:
    """The candidate name of effects acting at once, in catalogue order ('cog_height+isolator_scatter')."""
    order = [e.name for e in CATALOGUE]
    return "+".join(sorted(names, key=order.index))
