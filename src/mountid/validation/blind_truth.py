"""The blind harness's truths: any shipped machine assembled in numpy straight from its description file
(tomllib, expressions evaluated with :mod:`math`), independently of the engine (rigid-body point Jacobians
typed from u = t + w x r, isolators mirrored by hand), with effects built the way they are in a machine
rather than the way the candidate catalogue parameterises them.

In the catalogue (mountid.effects), each by its own physics here:

- ``foundation``: a 6-dof slab (square, 2.06 times the isolators' largest radius in half-width, 0.3 m thick, its
  own mass and inertia) on pads under the isolator feet, the isolators between body and slab;
- ``frequency_dependent``: rubber as a fractional Kelvin-Voigt solid (storage stiffness
  k (1 + a (w tau)^r cos(r pi / 2))), each mode solved as a nonlinear eigenproblem;
- ``added_mass``: a motor as a rigid body with its own inertia, on the vertical axis;
- ``drive_belt``: a spring along x at the pulley;
- ``com_offset``: the centre of mass off in a random horizontal direction;
- ``sensor_error``: four triaxial sensors in a measurement frame turned in yaw against the machine's axes
  and placed off in height, the shapes recovered by least squares with the assumed geometry;
- ``sensor_turned``: one of those twelve channels turned on its mount by 3-20 degrees about an axis across
  it (a rotation: the catalogue's turned_axis by its rotation vector), the shapes recovered with the assumed geometry;
- ``sensor_misplaced``: one of those twelve channels mounted 10-60 % of the isolators' largest radius off its
  stated point in a random direction (the component along its axis included, which changes nothing), the
  shapes recovered with the assumed geometry;
- ``sensor_reversed``: one of those twelve channels reads with its polarity reversed (a sensor mounted upside
  down or a cable wired the wrong way round: it reads along -d), the shapes recovered with the assumed geometry
  (added outside the catalogue, where it ended "not explained" in every case with shapes, before the catalogue
  had a reversed channel);
- ``damping``: damped frequencies |Im p| of non-proportionally damped isolators (a measured mode is one pole,
  its frequency and damping ratio, labelled by its shape: ``true_poles``);
- ``isolator_scatter``: one isolator of rubber from another batch: stiffer or softer in all directions, in
  shear only, or along its axis only;
- ``cog_height``, ``rotational_stiffness``, ``gravity_preload`` by the same physics;
- ``support_frame`` (the catalogue's ``foundation``): a steel frame (2.67 times the isolators' largest radius
  in half-width, 0.25 m thick, its own mass and inertia) below the isolators, standing on four ground springs
  on the x and y axes at its edges (not under the isolator feet), softer horizontally than vertically, the
  springs below the frame's centre of mass;
- ``offaxis_mass`` (the catalogue's ``added_mass``): a motor with its own inertia bolted on off the vertical
  axis (radius 0.4-1.2 times the isolators' largest radius, any direction and height).

- ``isolator_scatter+cog_height`` (the catalogue's pair ``cog_height+isolator_scatter``): two effects at once.
- ``support_frame+isolator_scatter`` (the catalogue's pair ``isolator_scatter+foundation``): one isolator off
  and the machine on a support frame (each as above); the scattered isolator stands on the frame.

Written outside the catalogue, represented since by an effect added to it (REPRESENTED_BY; drawn under their own
names, DRAWN_AS):

- ``nonlinear_isolator`` (the catalogue's ``rubber_hardening``): hardening rubber, stiffness
  k (1 + gamma (d / d_ref)^2) in each direction with the deformation amplitude d of that direction in the mode
  being measured (equivalent linearisation): each mode sees its own isolator stiffness;
- ``sensor_turned+sensor_turned`` (the catalogue's ``two_sensors_turned``): two channels of the layout turned on
  their mounts (each as ``sensor_turned``);
- ``sensor_turned+sensor_misplaced`` (the catalogue's ``sensor_turned_misplaced``): one channel turned on its mount
  and mounted off its stated point (offset in any direction, along its own as well: what an offset along the
  stated direction adds to the turned reading, of the order of the turn times the offset, the candidate's offsets
  across it take up but for a term of the turn's square).

Outside the catalogue (REPRESENTED_BY None: no candidate represents them; an honest diagnosis ends "not
explained" or in a tie, never confident):

- ``resilient_attachment``: a component (a cabinet, a motor on its own mounts) of 3-15 % of the mass on
  springs at a point off the axis, its own frequency 0.5-0.9 times the machine's highest, inside the band of
  the machine's modes: its apparent mass changes sign across its resonance (a vibration absorber), which
  neither a rigid added mass nor stiffening rubber reproduces (9 coordinates).

Beside the cycle (REVERSED_BESIDE): a reversed channel together with a higher centre of mass, an attached body, a
drive belt, or a scattered isolator (each represented by the pair of its parts). Beside it and represented by an
effect added for it (REPRESENTED_BESIDE): ``isolator_tilted``, one isolator mounted tilted, its stiffness and
damping axes turned by 3-14 degrees about a horizontal axis in any direction (a mount on a sloping floor or a bent
bracket), which couples its axial and shear stiffness in the machine's axes (the catalogue's ``isolator_tilted``
turns both, from the engine's per-isolator matrices). Beside it and outside the catalogue (OUTSIDE_BESIDE): two
channels of the layout each mounted off its stated point (``sensor_misplaced+sensor_misplaced``), one isolator off
with one channel turned on its mount (``isolator_scatter+sensor_turned``), and one isolator tilted with the centre
of mass higher than described (``isolator_tilted+cog_height``), each part as its truth alone.

A truth of several parts counts a candidate naming one part as right when that part alone explains the
noise-free data within their uncertainty (the other part is below what the data can see):
mountid.validation.blind.run_case.

Sizes are drawn relative to the machine (its mass, the isolators' stiffness and radius); physical parts keep
their size (a rubber block's height, a motor's proportions).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from functools import cached_property
from importlib import resources
from pathlib import Path

import numpy as np
import scipy.linalg
import scipy.optimize
import scipy.spatial.transform
import tomllib

from mountid.diagnosis.candidate_model import label_modes
from mountid.effects import STANDARD_GRAVITY
from mountid.machine import Machine, description_file
from mountid.machine.symmetry import mirror_planes, parities, with_parities
from mountid.measurement.modes import scaled_unit
from mountid.measurement.rig import Hardening
from mountid.runtime.eigen import EQUAL_EIGENVALUES

REPRESENTED_BY: dict[str, str | None] = {
    "support_frame": "foundation",
    "offaxis_mass": "added_mass",
    "isolator_scatter+cog_height": "cog_height+isolator_scatter",
    "nonlinear_isolator": "rubber_hardening",
    "resilient_attachment": None,
    "support_frame+isolator_scatter": "isolator_scatter+foundation",
    "sensor_turned+sensor_turned": "two_sensors_turned",
    "sensor_turned+sensor_misplaced": "sensor_turned_misplaced",
}
"""The catalogue effect that represents each truth not named after one (None: no candidate does). A truth
named after a catalogue effect is represented by it, whatever the differences of its physics."""

DRAWN_AS: dict[str, str] = {
    "rubber_hardening": "nonlinear_isolator",
    "two_sensors_turned": "sensor_turned+sensor_turned",
    "sensor_turned_misplaced": "sensor_turned+sensor_misplaced",
}
"""Catalogue effects whose truth is one of other physics (REPRESENTED_BY), drawn under its own name: the harness's
hardening isolators (written before the catalogue had hardening rubber; the candidate assumes every mode excited to
the same largest isolator deformation, as the truth does) stay the one truth of hardening rubber, and two turned
channels and one channel turned and off its point (truths of two parts, written before the catalogue had those) the
one truths of theirs, so that the benchmark's cycle (blind.EFFECT_NAMES) and every seed's truth are as they were."""

OUT_OF_CATALOGUE: tuple[str, ...] = tuple(name for name, effect in REPRESENTED_BY.items() if effect is None)
"""Truths of the benchmark's cycle no candidate of the catalogue represents (beside the cycle: OUTSIDE_BESIDE)."""

MOTOR = (0.12, 0.3)
"""Radius and length [m] of the motor of an 838.6 kg machine (the KID-300); a machine of mass m carries one
(m / 838.6)^(1/3) times as large."""
REFERENCE_MASS = 838.6
"""[kg] the mass whose motor has the MOTOR dimensions."""


REVERSED_BESIDE: dict[str, str | None] = {
    "cog_height+sensor_reversed": "cog_height+sensor_reversed",
    "added_mass+sensor_reversed": "added_mass+sensor_reversed",
    "drive_belt+sensor_reversed": "drive_belt+sensor_reversed",
    "isolator_scatter+sensor_reversed": "isolator_scatter+sensor_reversed",
}
"""Truths of one channel mounted reversed beside a physical effect (each part as its truth alone), with the
candidate that represents each: a study of their own (mountid.validation.blind.run with ``truths``), outside the
benchmark's cycle of EFFECT_NAMES so that its seeds keep their truths. A scattered isolator with a reversed channel
was outside the catalogue until the pair was fitted at each isolator with each channel (2026-12-01). From
frequencies alone a reversed channel changes nothing, and the physical part alone is counted right where it
explains the noise-free data."""


OUTSIDE_BESIDE: tuple[str, ...] = (
    "sensor_misplaced+sensor_misplaced",
    "isolator_scatter+sensor_turned",
    "isolator_tilted+cog_height",
)
"""Truths outside the catalogue beside the benchmark's cycle (a study of their own, as REVERSED_BESIDE's, so that the
cycle's seeds keep their truths), which no candidate represents: two channels each mounted off its stated point (each
as ``sensor_misplaced``; one misplaced channel, two turned ones and one turned and misplaced reach part of it), one
isolator off with one channel turned (each as its truth alone; the pair is not composed, it would be fitted at every
isolator with every channel: effects.PAIR_EXCLUSIONS), and one isolator tilted with the centre of mass higher than
described (each as its truth alone; a tilted isolator is never part of a pair: effects.pair). Written when the cycle's
truths outside the catalogue had come down to one (the component on its own springs), the others represented by the
effects added for them: an honest diagnosis ends "not explained" or in a tie, or names one part that alone explains
the noise-free data. Until the catalogue had a tilted isolator (2026-12-02) the third was ``isolator_tilted`` alone
(REPRESENTED_BESIDE since)."""

REPRESENTED_BESIDE: dict[str, str] = {"isolator_tilted": "isolator_tilted"}
"""Truths beside the benchmark's cycle that a candidate represents, written outside the catalogue and represented
since by the effect added for them (a study of their own, so that the cycle's seeds keep their truths): one isolator
mounted tilted (the catalogue's ``isolator_tilted``, its truth drawn by its own physics: the whole mount, stiffness
and damping axes, turned about a horizontal axis)."""


def represented_by(truth: str) -> str | None:
    """The catalogue effect that represents the truth ``truth`` (None: none does; 'none' for no effect)."""
    if truth in REVERSED_BESIDE:
        return REVERSED_BESIDE[truth]
    if truth in OUTSIDE_BESIDE:
        return None
    if truth in REPRESENTED_BESIDE:
        return REPRESENTED_BESIDE[truth]
    return REPRESENTED_BY.get(truth, truth)


def _skew(r: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]])


def _jac(r: np.ndarray) -> np.ndarray:
    """u = t + w x r = t - skew(r) w at the point r of a rigid body."""
    return np.hstack([np.eye(3), -_skew(np.asarray(r, dtype=float))])


def _body_mass(m: float, inertia: np.ndarray, centre: np.ndarray) -> np.ndarray:
    """6x6 mass matrix about the coordinate origin of a body with centre of mass ``centre``."""
    j = _jac(centre)
    out = m * j.T @ j
    out[3:, 3:] += inertia
    return out


def _rotation(ax: float, ay: float, az: float) -> np.ndarray:
    """Local isolator axes to global, R = Rz(az) Ry(ay) Rx(ax) (docs/descriptions.md)."""
    cx, sx, cy, sy, cz, sz = math.cos(ax), math.sin(ax), math.cos(ay), math.sin(ay), math.cos(az), math.sin(az)
    rx = np.array([[1.0, 0.0, 0.0], [0.0, cx, -sx], [0.0, sx, cx]])
    ry = np.array([[cy, 0.0, sy], [0.0, 1.0, 0.0], [-sy, 0.0, cy]])
    rz = np.array([[cz, -sz, 0.0], [sz, cz, 0.0], [0.0, 0.0, 1.0]])
    return rz @ ry @ rx


_FUNCTIONS = {"sqrt": math.sqrt, "sin": math.sin, "cos": math.cos, "tan": math.tan, "pi": math.pi}


@dataclass(frozen=True)
class TrueIsolator:
    """One isolator after mirroring: point [m], local axes in global ones (columns of ``axes``), stiffness and
    damping along the local axes [N/m, N s/m]."""

    point: np.ndarray
    axes: np.ndarray
    stiffness: np.ndarray
    damping: np.ndarray

    def tensor(self, local: np.ndarray) -> np.ndarray:
        """A tensor diagonal in the isolator's axes, in global axes."""
        return self.axes @ np.diag(local) @ self.axes.T

    @property
    def axis(self) -> np.ndarray:
        """The isolator's own (local z) axis in global axes."""
        return self.axes[:, 2]


class TruthMachine:
    """A shipped machine (``derivations/<name>.toml``) or a description file assembled in numpy: the body
    (mass, inertia with products, centre of mass) and every isolator mirrored across the declared planes."""

    @classmethod
    def of(cls, machine: str) -> TruthMachine:
        """The truth machine of a shipped machine's name or of a description file (a path ending in .toml, as
        Machine.resolve takes it): the blind harness on a machine of one's own."""
        return cls(machine, description_file(machine))

    def __init__(self, name: str, path: Path | None = None) -> None:
        if path is None:
            text = resources.files("mountid.derivations").joinpath(f"{name}.toml").read_text(encoding="utf-8")
        else:
            text = path.read_text(encoding="utf-8")
        self.name = name
        self.data = tomllib.loads(text)
        params = self.data["parameters"]
        self.nominal: dict[str, float] = {n: float(p["value"]) for n, p in params.items()}
        self.unknown: tuple[str, ...] = tuple(n for n, p in params.items() if p.get("role", "known") == "unknown")
        self.known: tuple[str, ...] = tuple(n for n in params if n not in self.unknown)

    def _eval(self, expr: object, values: dict[str, float]) -> float:
        if isinstance(expr, int | float):
            return float(expr)
        return float(eval(str(expr), {"__builtins__": {}}, {**_FUNCTIONS, **values}))

    def _triple(self, exprs: list, values: dict[str, float]) -> np.ndarray:
        return np.array([self._eval(e, values) for e in exprs])

    # -- the body ------------------------------------------------------------------------------------
    def mass(self, values: dict[str, float]) -> float:
        return self._eval(self.data["body"]["mass"], values)

    def inertia(self, values: dict[str, float]) -> np.ndarray:
        """Inertia tensor about the centre of mass [kg m^2]: principal moments and products [J_xy, J_xz, J_yz]
        entering as -J_ij."""
        body = self.data["body"]
        jx, jy, jz = self._triple(body["inertia"], values)
        jxy, jxz, jyz = self._triple(body.get("products_of_inertia", [0, 0, 0]), values)
        return np.array([[jx, -jxy, -jxz], [-jxy, jy, -jyz], [-jxz, -jyz, jz]])

    def centre(self, values: dict[str, float]) -> np.ndarray:
        return self._triple(self.data["body"].get("centre_of_mass", [0, 0, 0]), values)

    # -- the isolators ---------------------------------------------------------------------------------
    def isolators(self, values: dict[str, float]) -> list[TrueIsolator]:
        """Every isolator: each group's representative and its mirror images (a point on a mirror plane is
        its own image there); an image's axes are the representative's reflected."""
        planes = {"yz": 0, "xz": 1}
        symmetry = [planes[p] for p in self.data["symmetry"]]
        out = []
        for group in self.data["isolators"]:
            point = self._triple(group["point"], values)
            axes = _rotation(*self._triple(group.get("inclination", [0, 0, 0]), values))
            k = self._triple(group["stiffness"], values)
            b = self._triple(group.get("damping", [0, 0, 0]), values)
            seen: list[np.ndarray] = []
            for n in range(len(symmetry) + 1):
                for subset in itertools.combinations(symmetry, n):
                    s = np.ones(3)
                    s[list(subset)] = -1.0
                    image = s * point
                    if any(np.allclose(image, p, rtol=0, atol=1e-12) for p in seen):
                        continue
                    seen.append(image)
                    out.append(TrueIsolator(image, s[:, None] * axes, k, b))
        return out

    # -- machine scales (nominal values) ----------------------------------------------------------------
    @cached_property
    def _nominal_isolators(self) -> list[TrueIsolator]:
        return self.isolators(self.nominal)

    @cached_property
    def length(self) -> float:
        """RMS distance of the isolators from the centre of mass [m] (the rotations' factor in shapes)."""
        c = self.centre(self.nominal)
        return math.sqrt(np.mean([np.sum((i.point - c) ** 2) for i in self._nominal_isolators]))

    @cached_property
    def radius(self) -> float:
        """Largest horizontal distance of an isolator from the vertical axis through the centre of mass [m]."""
        c = self.centre(self.nominal)
        return max(math.hypot(*(i.point - c)[:2]) for i in self._nominal_isolators)

    @cached_property
    def damping_parameters(self) -> tuple[str, ...]:
        """The description's damping parameters (kind "damping")."""
        return tuple(n for n, p in self.data["parameters"].items() if p["kind"] == "damping")

    @cached_property
    def depth(self) -> float:
        """Mean depth of the isolator points below the centre of mass [m]."""
        c = self.centre(self.nominal)
        return float(np.mean([c[2] - i.point[2] for i in self._nominal_isolators]))

    @cached_property
    def vertical(self) -> float:
        """Total vertical stiffness of the isolators at the nominal values [N/m]."""
        return float(sum(i.tensor(i.stiffness)[2, 2] for i in self._nominal_isolators))

    @cached_property
    def horizontal(self) -> float:
        """Total stiffness of the isolators along x at the nominal values [N/m]."""
        return float(sum(i.tensor(i.stiffness)[0, 0] for i in self._nominal_isolators))

    @cached_property
    def rocking(self) -> float:
        """Rocking stiffness of the vertical springs, sum k_z r^2 / 2 over the isolators [N m/rad]."""
        c = self.centre(self.nominal)
        return float(
            sum(i.tensor(i.stiffness)[2, 2] * np.sum((i.point - c)[:2] ** 2) / 2 for i in self._nominal_isolators)
        )

    @cached_property
    def _nominal_frequencies(self) -> np.ndarray:
        m, c, _ = truth_matrices(self, Truth("none", {}, {}, self.name))
        return np.sqrt(scipy.linalg.eigh(c, m, eigvals_only=True))

    @cached_property
    def mean_frequency(self) -> float:
        """Geometric mean of the natural frequencies at the nominal values [rad/s]."""
        return float(np.exp(np.mean(np.log(self._nominal_frequencies))))

    @cached_property
    def highest_frequency(self) -> float:
        """The highest natural frequency at the nominal values [rad/s]."""
        return float(np.max(self._nominal_frequencies))


@dataclass(frozen=True)
class Truth:
    """One synthetic machine: its description, the true unknowns, and the injected effect with its size."""

    effect: str
    size: dict[str, float]
    unknowns: dict[str, float]
    machine: str = "kid300"
    known: dict[str, float] = field(default_factory=dict)
    """Known values that differ from the description's nominal ones (none so far)."""


Arrays = list[np.ndarray]
"""One array per isolator: its point [m], or its stiffness [N/m] or damping [N s/m] tensor (3 x 3)."""
Size = dict[str, float]
"""An injected effect's size (sample)."""
Matrices = tuple[np.ndarray, np.ndarray, np.ndarray]
"""M, C, B of a truth [SI]."""


def truth_matrices(tm: TruthMachine, t: Truth) -> Matrices:
    """M, C, B of the truth (12 x 12 with a support below the isolators)."""
    v = {**tm.nominal, **t.known, **t.unknowns}
    parts = set(t.effect.split("+"))
    isolators = tm.isolators(v)
    k_iso = [i.tensor(i.stiffness) for i in isolators]
    b_iso = [i.tensor(i.damping) for i in isolators]
    centre = tm.centre(v)
    inertia = tm.inertia(v)
    mass = tm.mass(v)
    s = t.size
    if "com_offset" in parts:
        centre = centre + np.array([s["e"] * math.cos(s["angle"]), s["e"] * math.sin(s["angle"]), 0.0])
    if "cog_height" in parts:
        centre = centre + np.array([0.0, 0.0, s["dz"]])
    if "isolator_scatter" in parts:
        i = int(s["isolator"])
        iso = isolators[i]
        k_iso[i] = iso.tensor(iso.stiffness * (1 + np.array([s["s_h"], s["s_h"], s["s_v"]])))
    if "isolator_tilted" in parts:
        # the whole mount (its stiffness and damping axes) turned by ``tilt`` about a horizontal axis at ``about``
        i = int(s["isolator"])
        turn = scipy.spatial.transform.Rotation.from_rotvec(
            s["tilt"] * np.array([math.cos(s["about"]), math.sin(s["about"]), 0.0])
        ).as_matrix()
        k_iso[i] = turn @ k_iso[i] @ turn.T
        b_iso[i] = turn @ b_iso[i] @ turn.T
    if "damping" in parts:
        b_iso = [b * s["eta"] for b in b_iso]
    m = _body_mass(mass, inertia, centre)
    points = [i.point for i in isolators]
    c = sum(_jac(r).T @ k @ _jac(r) for r, k in zip(points, k_iso, strict=True))
    b = sum(_jac(r).T @ d @ _jac(r) for r, d in zip(points, b_iso, strict=True))
    if "rotational_stiffness" in parts:
        for iso in isolators:
            a = iso.axis
            c[3:, 3:] += s["k_bend"] * (np.eye(3) - np.outer(a, a)) + s["k_torsion"] * np.outer(a, a)
    if "gravity_preload" in parts:
        c[3, 3] -= mass * STANDARD_GRAVITY * s["h"]
        c[4, 4] -= mass * STANDARD_GRAVITY * s["h"]
    if "added_mass" in parts or "offaxis_mass" in parts:
        ma = s["m"]
        size = (mass / REFERENCE_MASS) ** (1 / 3)
        r_m, l_m = MOTOR[0] * size, MOTOR[1] * size  # a solid cylinder with a horizontal axis along x
        own = ma * np.diag([r_m**2 / 2, (3 * r_m**2 + l_m**2) / 12, (3 * r_m**2 + l_m**2) / 12])
        where = np.array([0.0, 0.0, s["h"]])
        if "offaxis_mass" in parts:
            where = np.array([s["r"] * math.cos(s["angle"]), s["r"] * math.sin(s["angle"]), s["h"]])
        m = m + _body_mass(ma, own, tm.centre(v) + where)
    if "drive_belt" in parts:
        row = np.array([1.0, 0.0, 0.0]) @ _jac(np.array([0.0, 0.0, s["h"]]))
        c = c + s["k"] * np.outer(row, row)
    if "resilient_attachment" in parts:
        return _with_attachment(tm, m, c, b, s)
    if "foundation" in parts:
        return _on_slab(tm, m, points, k_iso, b_iso, s)
    if "support_frame" in parts:
        return _on_frame(tm, m, points, k_iso, b_iso, s)
    return m, c, b


def _two_bodies(
    m_body: np.ndarray, points: Arrays, k_iso: Arrays, b_iso: Arrays, m_support: np.ndarray, support_origin: np.ndarray
) -> Matrices:
    """Body and support, 12 dof (each in coordinates about its own origin): the isolators act on the
    difference of the two bodies' motions at the feet."""
    m = np.zeros((12, 12))
    c = np.zeros((12, 12))
    b = np.zeros((12, 12))
    m[:6, :6] = m_body
    m[6:, 6:] = m_support
    for r, k, d in zip(points, k_iso, b_iso, strict=True):
        rel = np.hstack([_jac(r), -_jac(r - support_origin)])
        c += rel.T @ k @ rel
        b += rel.T @ d @ rel
    return m, c, b


def _with_attachment(tm: TruthMachine, m_body: np.ndarray, c_body: np.ndarray, b_body: np.ndarray, s: Size) -> Matrices:
    """A point mass on isotropic springs (5 % damping) at a body point: 9 coordinates, the attachment's
    translations last."""
    where = tm.centre(tm.nominal) + np.array([s["r"] * math.cos(s["angle"]), s["r"] * math.sin(s["angle"]), s["h"]])
    k = s["m"] * s["omega"] ** 2
    rel = np.hstack([_jac(where), -np.eye(3)])
    m = np.zeros((9, 9))
    m[:6, :6] = m_body
    m[6:, 6:] = s["m"] * np.eye(3)
    c = np.zeros((9, 9))
    c[:6, :6] = c_body
    c += k * rel.T @ rel
    b = np.zeros((9, 9))
    b[:6, :6] = b_body
    b += 2 * 0.05 * math.sqrt(k * s["m"]) * rel.T @ rel
    return m, c, b


def _on_slab(tm: TruthMachine, m_body: np.ndarray, points: Arrays, k_iso: Arrays, b_iso: Arrays, s: Size) -> Matrices:
    """A square slab, 0.3 m thick, under the isolator feet on a pad under each foot."""
    depth = float(np.mean([p[2] for p in points]))
    origin = np.array([0.0, 0.0, depth])
    half = 1.0 * tm.radius / 0.486  # the KID-300's slab: 2 m x 2 m under isolators at 0.486 m
    mf = s["m"]
    own = mf * np.diag([(4 * half**2 + 0.09) / 12] * 2 + [8 * half**2 / 12])
    m, c, b = _two_bodies(m_body, points, k_iso, b_iso, _body_mass(mf, own, np.zeros(3)), origin)
    kz = s["k"] / len(points)
    ground = np.diag([0.5 * kz, 0.5 * kz, kz])
    for r in points:
        j = np.hstack([np.zeros((3, 6)), _jac(r - origin)])
        c += j.T @ ground @ j
    return m, c, b


def _on_frame(tm: TruthMachine, m_body: np.ndarray, points: Arrays, k_iso: Arrays, b_iso: Arrays, s: Size) -> Matrices:
    """A square steel frame, 0.25 m thick, below the isolators on four ground springs on the x and y axes at its
    edges (wherever the isolator feet are)."""
    depth = float(np.mean([p[2] for p in points]))
    mf, half, thick = s["m"], 1.3 * tm.radius / 0.486, 0.25
    own = mf * np.diag([(4 * half**2 + thick**2) / 12] * 2 + [8 * half**2 / 12])
    support = _body_mass(mf, own, np.array([0.0, 0.0, depth - thick / 2]))
    m, c, b = _two_bodies(m_body, points, k_iso, b_iso, support, np.zeros(3))
    kv = s["k"] / 4
    ground = np.diag([s["horizontal"] * kv, s["horizontal"] * kv, kv])
    for x, y in ((half, 0.0), (-half, 0.0), (0.0, half), (0.0, -half)):
        j = np.hstack([np.zeros((3, 6)), _jac(np.array([x, y, depth - thick]))])
        c += j.T @ ground @ j
    return m, c, b


def sample(rng: np.random.Generator, effect: str, tm: TruthMachine) -> dict[str, float]:
    """A random effect size, from barely visible to clearly visible against the synthetic noise."""

    def logu(lo: float, hi: float) -> float:
        return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))

    sign = 1.0 if rng.random() < 0.5 else -1.0
    mass = tm.mass(tm.nominal)
    if effect == "com_offset":
        return {"e": logu(0.01, 0.06), "angle": rng.uniform(0, 2 * math.pi)}
    if effect == "cog_height":
        return {"dz": sign * logu(0.01, 0.1)}
    if effect == "isolator_scatter":
        s = sign * logu(0.05, 0.4)
        which = int(rng.integers(len(tm.isolators(tm.nominal))))
        direction = ("all", "shear", "axial")[int(rng.integers(3))]
        return {
            "s_h": 0.0 if direction == "axial" else s,
            "s_v": 0.0 if direction == "shear" else s,
            "isolator": which,
        }
    if effect == "isolator_tilted":
        return {
            "isolator": int(rng.integers(len(tm.isolators(tm.nominal)))),
            "tilt": logu(0.05, 0.25),
            "about": rng.uniform(0, 2 * math.pi),
        }
    if effect == "rotational_stiffness":
        return {"k_bend": logu(0.003, 0.03) * tm.rocking / 4, "k_torsion": logu(0.003, 0.03) * tm.rocking / 4}
    if effect == "frequency_dependent":
        return {"a": logu(0.03, 0.3), "r": rng.uniform(0.2, 0.6), "tau": 1 / tm.mean_frequency}
    if effect == "foundation":
        return {"m": logu(0.5, 5) * mass, "k": logu(10, 100) * tm.vertical}
    if effect == "added_mass":
        return {"m": logu(0.02, 0.15) * mass, "h": rng.uniform(-0.5, 0.5)}
    if effect == "drive_belt":
        return {"k": logu(0.01, 0.2) * tm.horizontal, "h": rng.uniform(-0.3, 0.5)}
    if effect == "gravity_preload":
        return {"h": tm.depth + rng.uniform(0.0, 0.2)}
    if effect == "damping":
        return {"eta": logu(1.5, 5.0)}
    if effect == "sensor_error":
        return {"yaw": sign * logu(0.01, 0.08), "dz": rng.uniform(-0.15, 0.15)}
    if effect == "sensor_turned":
        return {
            "channel": int(rng.integers(len(sensor_layout(tm)))),
            "angle": logu(0.05, 0.35),
            "about": rng.uniform(0, 2 * math.pi),
        }
    if effect == "sensor_reversed":
        return {"channel": int(rng.integers(len(sensor_layout(tm))))}
    if effect == "sensor_misplaced":
        theta, azimuth = math.acos(rng.uniform(-1.0, 1.0)), rng.uniform(0, 2 * math.pi)
        distance = logu(0.1, 0.6) * tm.radius
        direction = (math.sin(theta) * math.cos(azimuth), math.sin(theta) * math.sin(azimuth), math.cos(theta))
        return {
            "channel": int(rng.integers(len(sensor_layout(tm)))),
            **{a: distance * x for a, x in zip("xyz", direction, strict=False)},
        }
    if effect == "support_frame":
        return {"m": logu(0.3, 2) * mass, "k": logu(3, 30) * tm.vertical, "horizontal": rng.uniform(0.2, 0.6)}
    if effect == "nonlinear_isolator":
        return {"gamma": logu(0.02, 0.2)}
    if effect == "resilient_attachment":
        return {
            "m": logu(0.03, 0.15) * mass,
            "r": logu(0.2, 0.6) * tm.radius / 0.486,
            "angle": rng.uniform(0, 2 * math.pi),
            "h": rng.uniform(-0.2, 0.5),
            "omega": logu(0.5, 0.9) * tm.highest_frequency,
        }
    if effect == "offaxis_mass":
        return {
            "m": logu(0.03, 0.15) * mass,
            "r": logu(0.2, 0.6) * tm.radius / 0.486,
            "angle": rng.uniform(0, 2 * math.pi),
            "h": rng.uniform(-0.3, 0.5),
        }
    if effect in ("sensor_turned+sensor_turned", "sensor_misplaced+sensor_misplaced"):  # two different channels
        part = effect.split("+")[0]
        first = sample(rng, part, tm)
        second = sample(rng, part, tm)
        while second["channel"] == first["channel"]:
            second = sample(rng, part, tm)
        return {**first, **{f"{k}_2": v for k, v in second.items()}}
    if effect == "sensor_turned+sensor_misplaced":  # one channel, turned and off its point
        turned = sample(rng, "sensor_turned", tm)
        return {**turned, **{k: v for k, v in sample(rng, "sensor_misplaced", tm).items() if k != "channel"}}
    if "+" in effect:
        out: dict[str, float] = {}
        for part in effect.split("+"):
            out.update(sample(rng, part, tm))
        return out
    if effect == "none":
        return {}
    raise ValueError(f"no blind truth for the effect {effect!r}: add its size here and its physics to truth_matrices")


def labelled_modes(tm: TruthMachine, machine: Machine, t: Truth) -> tuple[Matrices, np.ndarray, np.ndarray]:
    """The truth's M, C, B and its undamped modes in the machine's mode order: squared frequencies [rad^2/s^2]
    and eigenvectors (n, 6) over all its coordinates (12 with a support). Where the truth has exactly equal
    frequencies (twins), any combination of them is a mode: each label gets the projection of its nominal mode
    on their span, so that the shapes do not depend on the basis LAPACK returned. Each mode's sign is its
    nominal mode's (_signed_as_reference), not the one LAPACK returned (which differs between BLAS kernels)."""
    m, c, b = truth_matrices(tm, t)
    lam, vec = scipy.linalg.eigh(c, m)
    ref, ref_lambda = _reference(tm, machine, t)
    body = scaled_unit(vec[:6], tm.length)
    share = np.einsum("ij,ik,kj->j", vec[:6], m[:6, :6], vec[:6])
    order = label_modes(lam, body, ref_lambda, ref, share)
    vec = _canonical_twins(lam, vec, m, order, ref, tm.length)[:, order]
    return (m, c, b), lam[order], _signed_as_reference(vec, ref, tm.length)


def _signed_as_reference(modes: np.ndarray, ref: np.ndarray, length: float) -> np.ndarray:
    """``modes`` (columns over all the truth's coordinates, in label order) each with the sign that makes its
    body part's scaled unit shape point the way of its label's nominal shape ``ref`` (a non-negative dot
    product): LAPACK's sign of an eigenvector is arbitrary and, for a mode resolved loosely, differs between
    BLAS kernels, and the noise of a campaign's shapes is added to the signed shape. A mode whose body part is
    orthogonal to its nominal shape (a support's own mode, the body at rest) keeps LAPACK's sign, which no
    body shape sees."""
    dot = np.einsum("ij,ij->j", scaled_unit(modes[:6], length), ref)
    return modes * np.where(dot < 0, -1.0, 1.0)


def true_modes(tm: TruthMachine, machine: Machine, t: Truth, level: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """True frequencies [rad/s] and shapes (6, 6) in q, in the machine's mode order (labelled_modes), each mode
    excited at ``level`` times the amplitude of a campaign's test (which only hardening isolators feel)."""
    (m, c, b), lam, modes = labelled_modes(tm, machine, t)
    omega = np.sqrt(lam)
    shapes = modes[:6]
    parts = set(t.effect.split("+"))
    if "frequency_dependent" in parts:
        a, r, tau = t.size["a"], t.size["r"], t.size["tau"]
        for i in range(len(omega)):  # omega^2 = g(omega) lambda, g the fractional model's storage factor
            w = omega[i]
            for _ in range(200):
                g = 1 + a * (w * tau) ** r * math.cos(r * math.pi / 2)
                w_new = math.sqrt(g * lam[i])
                if abs(w_new - w) < 1e-13 * w:
                    break
                w = w_new
            omega[i] = w_new
    elif "damping" in parts:
        omega = true_poles(m, c, b, modes).imag
    elif parts & SENSOR_TRUTHS:
        shapes = _misread(tm, shapes, t)
    elif "nonlinear_isolator" in parts:
        omega, shapes = _hardened(tm, t, m, shapes, level)
    return omega, shapes


def _reference(tm: TruthMachine, machine: Machine, t: Truth) -> tuple[np.ndarray, np.ndarray]:
    """The machine's nominal modes at the true values (scaled unit shapes, squared frequencies): what the
    truth's modes are labelled by."""
    mod = machine.module
    values = {**tm.nominal, **t.known, **t.unknowns}
    fwd = {a: values[a] for a in mod.FORWARD_ARGUMENTS}
    return scaled_unit(np.asarray(mod.modal_matrix(**fwd)), tm.length), np.asarray(mod.squared_frequencies(**fwd))


def _canonical_twins(
    lam: np.ndarray, vec: np.ndarray, m: np.ndarray, order: np.ndarray, ref: np.ndarray, length: float
) -> np.ndarray:
    """The eigenvectors with each set of twins replaced, for the labels ``order`` gave them, by the
    projections of those labels' nominal shapes ``ref`` on the twins' span, M-orthonormalised in label order
    (independent of the basis LAPACK returned)."""
    out = vec.copy()
    done: set[int] = set()
    for j in range(len(lam)):
        group = np.flatnonzero(np.abs(lam - lam[j]) <= EQUAL_EIGENVALUES * abs(lam[j]))
        if len(group) < 2 or j in done:
            continue
        done |= set(group.tolist())
        labels = [k for k in range(len(order)) if order[k] in group]  # in label order
        v = vec[:, group]
        body = v[:6].copy()
        body[3:] *= length
        coef, *_ = np.linalg.lstsq(body, ref[:, labels], rcond=None)
        basis = v @ coef
        for k in range(basis.shape[1]):  # Gram-Schmidt in the mass inner product
            x = basis[:, k]
            for prev in range(k):
                x = x - basis[:, prev] * (basis[:, prev] @ m @ x)
            basis[:, k] = x / math.sqrt(x @ m @ x)
        out[:, order[labels]] = basis
    return out


def true_damping_ratios(tm: TruthMachine, machine: Machine, t: Truth) -> np.ndarray:
    """Damping ratio of each mode (in the machine's mode order, its pole by :func:`true_poles`): -Re p / |p| of
    the truth's damped poles (M p^2 + B p + C = 0, its own non-proportional B)."""
    (m, c, b), _, modes = labelled_modes(tm, machine, t)
    p = true_poles(m, c, b, modes)
    size = np.abs(p)
    return np.where(size > 0, -p.real / np.where(size > 0, size, 1.0), 1.0)


def true_poles(m: np.ndarray, c: np.ndarray, b: np.ndarray, modes: np.ndarray) -> np.ndarray:
    """The damped pole (Im p > 0) [rad/s] of each undamped mode (``modes``: eigenvectors over all the truth's
    coordinates, columns): one pole per mode, the assignment that keeps the most of the modes' mass-weighted
    overlap |x^H M phi|^2 / (x^H M x phi^T M phi) with the poles' shapes x (scipy.optimize.linear_sum_assignment).
    A measured mode is one pole: its frequency and its damping ratio both come from it, however heavy damping
    reorders them; a support's modes (12 coordinates) are told from the body's by their whole shape, not by
    the body's part alone (a mode that does not oscillate gets p = 0)."""
    n = m.shape[0]
    a = np.block([[np.zeros((n, n)), np.eye(n)], [-np.linalg.solve(m, c), -np.linalg.solve(m, b)]])
    poles, vectors = np.linalg.eig(a)
    upper = poles.imag > 0
    poles, x = poles[upper], vectors[:n, upper]
    size = np.einsum("ak,ab,bk->k", np.conj(x), m, x).real
    norm = np.einsum("ak,ab,bk->k", modes, m, modes)
    fit = np.abs(np.conj(x).T @ m @ modes) ** 2 / np.outer(size, norm)
    rows, columns = scipy.optimize.linear_sum_assignment(fit, maximize=True)
    out = np.zeros(modes.shape[1], dtype=complex)  # 0: a mode that does not oscillate
    out[columns] = poles[rows]
    return out


def _hardened(
    tm: TruthMachine, t: Truth, m: np.ndarray, shapes: np.ndarray, level: float = 1.0
) -> tuple[np.ndarray, np.ndarray]:
    """Each mode of hardening isolators by equivalent linearisation: every isolator stiffer along each of its local
    axes by 1 + gamma (level d / d_max)^2, d its deformation amplitude there in the mode, d_max the largest over the
    isolators and axes (a campaign's test excites each mode to the same largest deformation, ``level``
    times that another); iterated to a fixed point in the mode's own symmetry (mountid.machine.symmetry: a mode
    symmetric or antisymmetric in a mirror plane of the machine stays so)."""
    gamma = t.size["gamma"]
    rows, stiffness = _deformation(tm.isolators({**tm.nominal, **t.known, **t.unknowns}))
    mirrors = mirror_planes(m, rows.T @ (rows * stiffness[:, None]))
    omega, out = np.empty(shapes.shape[1]), np.empty_like(shapes)
    for i in range(shapes.shape[1]):
        phi = shapes[:, i]
        kept = parities(mirrors, m, phi)
        for _ in range(50):
            d = np.abs(rows @ phi)  # along each isolator's local axes
            factor = 1 + gamma * (level * d / d.max()) ** 2
            c = rows.T @ (rows * (stiffness * factor)[:, None])
            lam, vec = scipy.linalg.eigh(c, m)
            j = int(np.argmax(np.abs(vec.T @ m @ phi)))
            step = vec[:, j] * np.sign(vec[:, j] @ m @ phi)
            # the stiffened rubber keeps the mirror symmetry of a mode of definite parity; rounding does not,
            # and where a mode of the other parity lies close (kid300's psi and theta, 0.1 rad/s apart once
            # stiffened) the iteration amplifies it: psi drifted to a rotation about a diagonal, theta's shape
            # with it
            step = with_parities(step, kept, m)
            done = np.allclose(step, phi / math.sqrt(phi @ m @ phi), rtol=0, atol=1e-12)
            phi = step
            if done:
                break
        omega[i], out[:, i] = math.sqrt(lam[j]), phi
    return omega, out


def hardening(tm: TruthMachine, t: Truth, reference: float) -> Hardening | None:
    """The hardening isolators of a ``nonlinear_isolator`` truth for a time simulation (the rig's
    :class:`~mountid.measurement.rig.Hardening`): every isolator along each of its local axes with the law of
    _hardened, its relative stiffening ``gamma`` reached at the deformation ``reference`` [m] (a records test sets
    it at the largest deformation the campaign's hit gives the linear rubber, as _hardened excites each mode to
    the same largest deformation). None for a truth without hardening."""
    if "nonlinear_isolator" not in t.effect.split("+"):
        return None
    rows, stiffness = _deformation(tm.isolators({**tm.nominal, **t.known, **t.unknowns}))
    return Hardening(rows, stiffness, t.size["gamma"], reference)


def _deformation(isolators: list[TrueIsolator]) -> tuple[np.ndarray, np.ndarray]:
    """What each isolator's local axes deform per unit of each body coordinate (rows (3 per isolator, 6) [m per m,
    m per rad]) and the stiffness along them (3 per isolator) [N/m]: C of the isolators is rows^T diag(k) rows."""
    rows = np.vstack([iso.axes.T @ _jac(iso.point) for iso in isolators])
    return rows, np.concatenate([iso.stiffness for iso in isolators])


def sensor_layout(tm: TruthMachine) -> list[tuple[str, np.ndarray, np.ndarray]]:
    """The harness's measurement layout: four triaxial sensors on the top corners of the isolators' bounding
    box, 0.25 m above the origin; 12 channels (name, point [m], unit direction)."""
    points = np.array([i.point for i in tm._nominal_isolators])
    ax, ay = np.max(np.abs(points[:, 0])), np.max(np.abs(points[:, 1]))
    corners = [np.array([sx * ax, sy * ay, 0.25]) for sx, sy in ((1, 1), (-1, 1), (1, -1), (-1, -1))]
    return [(f"S{k + 1}_{a}", r, np.eye(3)[i]) for k, r in enumerate(corners) for i, a in enumerate("xyz")]


def _turned(direction: np.ndarray, angle: float, about: float) -> np.ndarray:
    """A channel's direction turned on its mount by ``angle`` [rad] about an axis across it (at ``about`` [rad]
    around it): Rodrigues' rotation (the catalogue's strategies.turned_axis by its rotation vector since 2026-11-28;
    it was the axis plus the tangents across it, normalised)."""
    helper = np.array([0.0, 0.0, 1.0]) if abs(direction[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    e1 = np.cross(helper, direction) / np.linalg.norm(np.cross(helper, direction))
    axis = math.cos(about) * e1 + math.sin(about) * np.cross(direction, e1)
    return direction * math.cos(angle) + np.cross(axis, direction) * math.sin(angle)


def _misread(tm: TruthMachine, shapes: np.ndarray, t: Truth) -> np.ndarray:
    """Shapes recovered by least squares from the layout's readings with the assumed geometry (sensor_layout),
    where the truth's channels read as they are mounted (mounted_layout): each the motion u = t + w x r of the
    point where its sensor sits, along the direction it points."""
    model = np.array([direction @ _jac(r) for _, r, direction in sensor_layout(tm)])
    read = np.array([direction @ _jac(r) for _, r, direction in mounted_layout(tm, t)])
    return np.linalg.lstsq(model, read @ shapes, rcond=None)[0]


SENSOR_TRUTHS = frozenset(("sensor_error", "sensor_turned", "sensor_misplaced", "sensor_reversed"))
"""The parts of a truth that change how the layout's channels are mounted, not the machine."""


def mounted_layout(tm: TruthMachine, t: Truth) -> list[tuple[str, np.ndarray, np.ndarray]]:
    """The layout's channels as the truth ``t`` mounts them (name, point [m], unit direction), where
    sensor_layout gives them as stated: what each channel reads, in a record and in the misread modal data
    (_misread), is the motion u = t + w x r of the point where its sensor sits along the direction it points.
    ``sensor_error``: the four sensors in a measurement frame turned by ``yaw`` about the vertical against the
    machine's axes and sitting ``dz`` higher than stated. ``sensor_turned``: one channel turned on its mount (a
    second one with the sizes ending in '_2' for two channels turned); ``sensor_misplaced``: one channel's
    sensor sitting offset (x, y, z) [m] off its stated point (a second one as for two turned); both at once on one
    channel; ``sensor_reversed``: one channel reading along -d (reversed polarity). Without a sensor part, the
    stated layout."""
    layout = sensor_layout(tm)
    size, parts = t.size, t.effect.split("+")
    if "sensor_error" in parts:
        cz, sz = math.cos(size["yaw"]), math.sin(size["yaw"])
        turn = np.array([[cz, sz, 0.0], [-sz, cz, 0.0], [0.0, 0.0, 1.0]])  # machine axes -> measurement frame
        lift = np.array([0.0, 0.0, size["dz"]])
        return [(name, turn.T @ r + lift, turn.T @ d) for name, r, d in layout]
    turned: dict[int, np.ndarray] = {}
    for suffix in ("", "_2")[: parts.count("sensor_turned")]:
        channel = int(size["channel" + suffix])
        turned[channel] = _turned(layout[channel][2], size["angle" + suffix], size["about" + suffix])
    if "sensor_reversed" in parts:
        turned[int(size["channel"])] = -layout[int(size["channel"])][2]
    offset = {
        int(size["channel" + suffix]): np.array([size["x" + suffix], size["y" + suffix], size["z" + suffix]])
        for suffix in ("", "_2")[: parts.count("sensor_misplaced")]
    }
    return [
        (name, r + offset[k] if k in offset else r, turned.get(k, direction))
        for k, (name, r, direction) in enumerate(layout)
    ]
