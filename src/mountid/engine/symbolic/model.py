"""From a description to energies and to the mass, stiffness and damping matrices.

The body is rigid; q = [x, y, z, psi, theta, phi] are the translations of the coordinate origin and small
rotations about x, y, z. An isolator at position r (from the origin) moves by u = t + w x r with
t = [x, y, z] and w = [psi, theta, phi]; with its stiffness tensor K and damping tensor B (global axes)

    T = 1/2 m |t' + w' x r_c|^2 + 1/2 w'^T J_c w'           (kinetic energy, r_c the centre of mass)
    P = 1/2 sum_i u_i^T K_i u_i                              (potential energy)
    D = 1/2 sum_i u_i'^T B_i u_i'                            (Rayleigh dissipation function)

and M, C, B are their Hessians (paper Eqs. 3-6): nothing here is typed in matrix form.
"""

from __future__ import annotations

import itertools
import random
from collections.abc import Iterable
from dataclasses import dataclass
from functools import cached_property

import sympy as sp
from sympy.parsing.sympy_parser import parse_expr, standard_transformations

from mountid.engine.description import MIRROR_PLANES, Description, IsolatorGroup
from mountid.engine.symbolic.syntax import FUNCTIONS, check_expression
from mountid.errors import DescriptionError
from mountid.nomenclature import COORDINATES, KINDS

_ALLOWED_FUNCTIONS = {name: getattr(sp, name) for name in FUNCTIONS}


@dataclass(frozen=True)
class Isolator:
    """One physical isolator after mirroring: position [m], stiffness and damping tensors in global axes."""

    group: str
    position: sp.Matrix
    stiffness: sp.Matrix
    damping: sp.Matrix
    axis: sp.Matrix
    """Unit vector of the isolator's own axis (local z) in global axes (sign irrelevant)."""
    mirror: tuple[int, int, int] = (1, 1, 1)
    """Signs of the reflection that made this isolator from its group's representative."""
    mirrored: tuple[str, ...] = ("x", "y")
    """The axes along which the group has mirror images (its representative lies off that mirror plane)."""

    @property
    def name(self) -> str:
        """Group name and the signs of the mirror image along the axes the group is mirrored along, e.g.
        ``corner[+x-y]``, ``middle[-y]`` (a group on the yz plane), ``centre`` (on the vertical axis)."""
        signs = "".join(
            ("+" if s > 0 else "-") + a for s, a in zip(self.mirror, "xy", strict=False) if a in self.mirrored
        )
        return f"{self.group}[{signs}]" if signs else self.group


def rational_point(symbols: Iterable[sp.Symbol], seed: int) -> dict[sp.Symbol, sp.Rational]:
    """A pseudo-random rational point (values in [50, 200]/97), reproducible from ``seed`` and the order of
    ``symbols``: where the engine decides a property exactly (rank, an identically vanishing expression, a
    symmetry map) at a generic point instead of symbolically."""
    rng = random.Random(seed)
    return {s: sp.Rational(rng.randint(50, 200), 97) for s in symbols}


def rigid_body_kinetic_energy(mass: sp.Expr, inertia: sp.Matrix, centre: sp.Matrix, qdot: sp.Matrix) -> sp.Expr:
    """T = 1/2 m |t' + w' x r_c|^2 + 1/2 w'^T J_c w' of a rigid body with centre of mass at ``centre`` [m] and
    inertia tensor ``inertia`` about it, moving with the body coordinates' velocities ``qdot``."""
    t_dot, w_dot = qdot[:3, 0], qdot[3:, 0]
    v_c = t_dot + w_dot.cross(centre)
    return sp.expand((mass * v_c.dot(v_c) + (w_dot.T * inertia * w_dot)[0]) / 2)


def _reflection(planes: tuple[str, ...]) -> sp.Matrix:
    diag = [1, 1, 1]
    for plane in planes:
        diag[MIRROR_PLANES[plane]] = -1
    return sp.diag(*diag)


def _rotation(angles: tuple[sp.Expr, sp.Expr, sp.Expr]) -> sp.Matrix:
    """Local isolator axes to global: R = Rz(az) Ry(ay) Rx(ax)."""
    ax, ay, az = angles
    rx = sp.Matrix([[1, 0, 0], [0, sp.cos(ax), -sp.sin(ax)], [0, sp.sin(ax), sp.cos(ax)]])
    ry = sp.Matrix([[sp.cos(ay), 0, sp.sin(ay)], [0, 1, 0], [-sp.sin(ay), 0, sp.cos(ay)]])
    rz = sp.Matrix([[sp.cos(az), -sp.sin(az), 0], [sp.sin(az), sp.cos(az), 0], [0, 0, 1]])
    return rz * ry * rx


DIMENSIONS: dict[str, tuple[int, int, int]] = {
    "mass": (1, 0, 0),
    "inertia": (1, 2, 0),
    "length": (0, 1, 0),
    "stiffness": (1, 0, -2),
    "rotational_stiffness": (1, 2, -2),
    "damping": (1, 0, -1),
    "angle": (0, 0, 0),
    "ratio": (0, 0, 0),
}
"""Exponents of mass, length and time of each parameter kind (nomenclature.KINDS' units)."""


def _unit(monomial: sp.Expr, base: tuple[sp.Symbol, ...]) -> str:
    """A monomial in the base dimensions as SI units (kg, m, s); 'units that do not scale as a power' else."""
    powers = monomial.as_powers_dict()
    if not set(powers) <= set(base) | {sp.Integer(1)}:
        return "no unit (it does not scale as a power of kg, m and s: a dimensional quantity inside a function?)"
    parts = [
        f"{u}^{powers[b]}" if powers[b] != 1 else u for b, u in zip(base, ("kg", "m", "s"), strict=True) if b in powers
    ]
    return " ".join(parts) or "1 (dimensionless)"


class SymbolicModel:
    """The symbolic meaning of a description: symbols, isolators, energies and matrices."""

    def __init__(self, description: Description) -> None:
        self.description = description
        self.symbols: dict[str, sp.Symbol] = {
            name: sp.Symbol(name, positive=True) if p.positive else sp.Symbol(name, real=True)
            for name, p in description.parameters.items()
        }
        self.q = sp.Matrix(sp.symbols(" ".join(COORDINATES), real=True))
        self.qdot = sp.Matrix(sp.symbols(" ".join(c + "_dot" for c in COORDINATES), real=True))
        self._check_dimensions()
        self._check_symmetry()

    # -- expressions -------------------------------------------------------------------------------
    def expr(self, text: str, entry: str) -> sp.Expr:
        """Parse one expression of the description; only declared parameters and sqrt/sin/cos/tan/pi, checked as
        text first (syntax.check_expression: sympy evaluates it with Python's eval)."""
        check_expression(text, entry)
        local = dict(self.symbols)
        try:
            value = parse_expr(
                text,
                local_dict=local,
                global_dict={
                    "Integer": sp.Integer,
                    "Float": sp.Float,
                    "Rational": sp.Rational,
                    "Symbol": sp.Symbol,
                    **_ALLOWED_FUNCTIONS,
                },
                transformations=standard_transformations,
            )
        except Exception as exc:  # sympy raises many types for a malformed string
            raise DescriptionError(entry, f"cannot read expression {text!r} ({type(exc).__name__})") from None
        if not isinstance(value, sp.Expr):
            raise DescriptionError(entry, f"{text!r} is not an expression")
        undeclared = sorted(str(s) for s in value.free_symbols if s not in self.symbols.values())
        if undeclared:
            raise DescriptionError(entry, f"uses undeclared name(s) {undeclared}")
        if value.has(sp.zoo, sp.oo, -sp.oo, sp.nan):
            raise DescriptionError(entry, f"{text!r} is not finite ({value}): a division by zero?")
        # decimal literals become exact rationals, so solving stays over the rationals
        return sp.nsimplify(value, rational=True)

    def _triple(self, texts: tuple[str, str, str], entry: str) -> sp.Matrix:
        return sp.Matrix([self.expr(t, f"{entry}[{i}]") for i, t in enumerate(texts)])

    @cached_property
    def mass(self) -> sp.Expr:
        return self.expr(self.description.mass, "body.mass")

    @cached_property
    def inertia(self) -> sp.Matrix:
        """Inertia tensor about the centre of mass [kg m^2]; products enter as -J_ij."""
        d = self.description
        jx, jy, jz = self._triple(d.inertia, "body.inertia")
        jxy, jxz, jyz = self._triple(d.products_of_inertia, "body.products_of_inertia")
        return sp.Matrix([[jx, -jxy, -jxz], [-jxy, jy, -jyz], [-jxz, -jyz, jz]])

    @cached_property
    def centre_of_mass(self) -> sp.Matrix:
        return self._triple(self.description.centre_of_mass, "body.centre_of_mass")

    def _group_tensors(self, group: IsolatorGroup) -> tuple[sp.Matrix, sp.Matrix, sp.Matrix]:
        point, k, b, _ = self._group_geometry(group)
        return point, k, b

    def _group_geometry(self, group: IsolatorGroup) -> tuple[sp.Matrix, sp.Matrix, sp.Matrix, sp.Matrix]:
        """Point, stiffness and damping tensors in global axes, and the isolator axis (local z)."""
        entry = f"isolators.{group.name}"
        point = self._triple(group.point, f"{entry}.point")
        k_local = sp.diag(*self._triple(group.stiffness, f"{entry}.stiffness"))
        b_local = sp.diag(*self._triple(group.damping, f"{entry}.damping")) if group.damping else sp.zeros(3)
        axis = sp.Matrix([0, 0, 1])
        if group.inclination:
            rot = _rotation(tuple(self._triple(group.inclination, f"{entry}.inclination")))
            k_local, b_local, axis = rot * k_local * rot.T, rot * b_local * rot.T, rot[:, 2]
        return point, k_local, b_local, axis

    @cached_property
    def isolators(self) -> tuple[Isolator, ...]:
        """Every isolator: each group's representative mirrored across the declared planes.

        A point on a mirror plane is its own image there, so a group has 4, 2 or 1 isolators.
        The stiffness tensor of an image is S K S for the reflection S.
        """
        out = []
        planes = self.description.symmetry
        for group in self.description.isolators:
            point, k, b, axis = self._group_geometry(group)
            mirrored = tuple("xy"[MIRROR_PLANES[p]] for p in planes if sp.simplify(point[MIRROR_PLANES[p]]) != 0)
            seen: list[sp.Matrix] = []
            for n in range(len(planes) + 1):
                for subset in itertools.combinations(planes, n):
                    s = _reflection(subset)
                    image = s * point
                    if any(sp.simplify(image - p) == sp.zeros(3, 1) for p in seen):
                        continue
                    seen.append(image)
                    signs = (int(s[0, 0]), int(s[1, 1]), 1)
                    out.append(Isolator(group.name, image, s * k * s, s * b * s, s * axis, signs, mirrored))
        return tuple(out)

    # -- dimension validation ------------------------------------------------------------------------
    def _check_dimensions(self) -> None:
        """Reject an entry whose terms with parameters do not have the entry's dimension (a mass given as an
        isolator's stiffness, a length inside a sine), naming the entry, and a parameter no entry uses. Each
        parameter carries its kind's dimension in mass, length and time (DIMENSIONS); a term's dimension is how
        it scales when they do. A bare number is taken in SI units (a point 0.1 m off, h + 0.1)."""
        base = sp.symbols("_M _L _T", positive=True)
        scaled = {
            self.symbols[n]: self.symbols[n] * sp.Mul(*(b**e for b, e in zip(base, DIMENSIONS[p.kind], strict=True)))
            for n, p in self.description.parameters.items()
        }
        d = self.description
        entries = [("body.mass", d.mass, "mass")]
        entries += [(f"body.inertia[{i}]", t, "inertia") for i, t in enumerate(d.inertia)]
        entries += [(f"body.products_of_inertia[{i}]", t, "inertia") for i, t in enumerate(d.products_of_inertia)]
        entries += [(f"body.centre_of_mass[{i}]", t, "length") for i, t in enumerate(d.centre_of_mass)]
        for g in d.isolators:
            for field, kind in (("point", "length"), ("stiffness", "stiffness"), ("damping", "damping")):
                texts = getattr(g, field) or ()
                entries += [(f"isolators.{g.name}.{field}[{i}]", t, kind) for i, t in enumerate(texts)]
            entries += [(f"isolators.{g.name}.inclination[{i}]", t, "angle") for i, t in enumerate(g.inclination or ())]
        used: set[sp.Symbol] = set()
        for entry, text, kind in entries:
            value = self.expr(text, entry)
            used |= value.free_symbols
            want = sp.Mul(*(b**e for b, e in zip(base, DIMENSIONS[kind], strict=True)))
            for term in sp.Add.make_args(sp.expand(value)):
                if not term.free_symbols:
                    continue  # a number, in SI units
                ratio = sp.simplify(term.subs(scaled, simultaneous=True) / term / want)
                if ratio != 1:
                    names = sorted(map(str, term.free_symbols))
                    raise DescriptionError(
                        entry,
                        f"{text!r} is not a {kind} ({KINDS[kind]}): its term {term} is in "
                        f"{_unit(sp.simplify(ratio * want), base)}; check the kinds of {names}",
                    )
        for name, symbol in self.symbols.items():
            if symbol not in used:
                raise DescriptionError(
                    f"parameters.{name}", "is declared but no entry of the body or the isolators uses it"
                )

    # -- symmetry validation -------------------------------------------------------------------------
    def _check_symmetry(self) -> None:
        """Reject entries that contradict the declared mirror planes, naming the entry."""
        d = self.description
        for plane in d.symmetry:
            axis = MIRROR_PLANES[plane]
            if self.centre_of_mass[axis] != 0:
                raise DescriptionError(
                    f"body.centre_of_mass[{axis}]",
                    f"is {self.centre_of_mass[axis]}, but mirror plane {plane} needs it to be 0",
                )
            s = _reflection((plane,))
            bad = (s * self.inertia * s - self.inertia).applyfunc(sp.simplify)
            if bad != sp.zeros(3):
                raise DescriptionError(
                    "body.products_of_inertia",
                    f"products of inertia coupling the {'xy'[axis]} axis contradict mirror plane {plane}",
                )
            for group in d.isolators:
                point, k, b = self._group_tensors(group)
                if point[axis] == 0:
                    for name, tensor in (("stiffness", k), ("damping", b)):
                        if (s * tensor * s - tensor).applyfunc(sp.simplify) != sp.zeros(3):
                            raise DescriptionError(
                                f"isolators.{group.name}.inclination",
                                f"tilts an isolator that sits on mirror plane {plane} so that its {name} "
                                "is not mirror-symmetric there",
                            )

    # -- energies and matrices -------------------------------------------------------------------------
    @cached_property
    def kinetic_energy(self) -> sp.Expr:
        return rigid_body_kinetic_energy(self.mass, self.inertia, self.centre_of_mass, self.qdot)

    @staticmethod
    def point_motion(vec: sp.Matrix, position: sp.Matrix) -> sp.Matrix:
        """Motion of the body point at ``position`` [m] for generalised coordinates (or velocities) ``vec``:
        u = t + w x r (small rotations)."""
        return vec[:3, 0] + vec[3:, 0].cross(position)

    def _isolator_form(self, velocities: bool, tensor: str) -> sp.Expr:
        vec = self.qdot if velocities else self.q
        total = sp.Integer(0)
        for iso in self.isolators:
            u = self.point_motion(vec, iso.position)
            total += (u.T * getattr(iso, tensor) * u)[0] / 2
        return sp.expand(total)

    POINT = sp.symbols("r_x r_y r_z", real=True)
    """Coordinates [m] of a general body point (arguments of the generated point_jacobian)."""

    @cached_property
    def point_jacobian(self) -> sp.Matrix:
        """du/dq (3 x 6) at the general point POINT: what a sensor there measures along a direction d is
        d^T du/dq q, and a force F there acts on the coordinates as (du/dq)^T F (virtual work)."""
        return self.point_motion(self.q, sp.Matrix(self.POINT)).jacobian(self.q)

    @cached_property
    def potential_energy(self) -> sp.Expr:
        return self._isolator_form(velocities=False, tensor="stiffness")

    @cached_property
    def dissipation_function(self) -> sp.Expr:
        return self._isolator_form(velocities=True, tensor="damping")

    @cached_property
    def M(self) -> sp.Matrix:
        """Mass matrix, m_ij = d^2 T / dq_i' dq_j' (Eq. 5)."""
        return sp.hessian(self.kinetic_energy, list(self.qdot)).applyfunc(sp.factor_terms)

    @cached_property
    def C(self) -> sp.Matrix:
        """Stiffness matrix, c_ij = d^2 P / dq_i dq_j (Eq. 6)."""
        return sp.hessian(self.potential_energy, list(self.q)).applyfunc(sp.factor_terms)

    @cached_property
    def B(self) -> sp.Matrix:
        """Damping matrix, b_ij = d^2 D / dq_i' dq_j' (Eq. 27's B)."""
        return sp.hessian(self.dissipation_function, list(self.qdot)).applyfunc(sp.factor_terms)

    def parameters_of(self, *exprs: sp.Expr | sp.Matrix) -> tuple[str, ...]:
        """Names of the parameters an expression depends on, in the description's order."""
        free: set[sp.Symbol] = set()
        for e in exprs:
            free |= e.free_symbols
        return tuple(n for n, s in self.symbols.items() if s in free)
