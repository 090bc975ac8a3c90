"""Candidate effects as extensions of a description's energies (the ``generated`` effects of
:mod:`mountid.effects`), the per-isolator stiffness matrices, and the machine scales.

Each extension writes kinetic energy T, potential energy P and dissipation D of the extended system with
sympy and takes M, C, B as their Hessians, exactly as :class:`~mountid.engine.symbolic.model.SymbolicModel` does for
the nominal model; an extra coordinate (the foundation's vertical motion) extends q.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import cache, cached_property

import sympy as sp

from mountid.effects import EFFECTS, STANDARD_GRAVITY, Effect
from mountid.engine.symbolic.model import Isolator, SymbolicModel, rigid_body_kinetic_energy
from mountid.errors import DescriptionError
from mountid.nomenclature import COORDINATES

GENERATED_EFFECTS: tuple[str, ...] = tuple(name for name, e in EFFECTS.items() if e.kind == "generated")


@dataclass(frozen=True)
class EnergyExtension:
    """What one ``generated`` effect adds to the energies of a description: T and P terms as functions of
    the extended model (its ``model``, effect ``symbols``, ``q`` and ``qdot``), and whether it adds a slab
    with six coordinates of its own under the isolators."""

    kinetic: Callable[[ExtendedModel], sp.Expr] | None = None
    potential: Callable[[ExtendedModel], sp.Expr] | None = None
    slab: bool = False


def _shifted_centre(shift: Callable[[dict[str, sp.Symbol]], sp.Matrix]) -> Callable[[ExtendedModel], sp.Expr]:
    """T of the body with its centre of mass moved by ``shift``, minus the nominal T."""

    def kinetic(x: ExtendedModel) -> sp.Expr:
        m = x.model
        centre = m.centre_of_mass + shift(x.symbols)
        return rigid_body_kinetic_energy(m.mass, m.inertia, centre, x.qdot[:6, 0]) - m.kinetic_energy

    return kinetic


def _added_mass(x: ExtendedModel) -> sp.Expr:
    s = x.symbols
    where = sp.Matrix([s["x_added"], s["y_added"], s["h_added"]])
    # its own inertia about axes parallel to the machine's: (1 + a, 1 - a, 1) times m g^2 (a rigid body for
    # |a| <= 1/2, where each moment is at most the sum of the other two)
    a = s["a_added"]
    own = s["m_added"] * s["g_added"] ** 2 * sp.diag(1 + a, 1 - a, 1)
    return rigid_body_kinetic_energy(s["m_added"], own, x.model.centre_of_mass + where, x.qdot[:6, 0])


def _rotational_stiffness(x: ExtendedModel) -> sp.Expr:
    """Per isolator: bending about the axes across it, torsion about its own axis a."""
    s, w = x.symbols, x.q[3:6, 0]
    p = sp.Integer(0)
    for iso in x.model.isolators:
        a = iso.axis
        tensor = s["k_bend"] * (sp.eye(3) - a * a.T) + s["k_torsion"] * a * a.T
        p += (w.T * tensor * w)[0] / 2
    return p


def _slab_kinetic(x: ExtendedModel) -> sp.Expr:
    """A rigid support of mass m_found with radius of gyration equal to the machine's length scale, its
    centre of mass found_depth below the isolator feet (the support's coordinates refer to the feet's centre)."""
    s = x.symbols
    inertia = s["m_found"] * scales(x.model)["length"] ** 2 * sp.eye(3)
    centre = sp.Matrix([0, 0, -s["found_depth"]])
    return rigid_body_kinetic_energy(s["m_found"], inertia, centre, x.qdot[6:, 0])


def _slab_on_ground(x: ExtendedModel) -> sp.Expr:
    """The support on a ground spring below each isolator: vertical k_found/n, horizontal found_shear times
    that, found_spread times as far from the yz plane as the isolator's foot, found_spread found_aspect times
    as far from the xz plane, and found_depth below it (the two spreads set the support's rocking stiffness
    about y and about x apart: a frame whose ground springs are not under the feet)."""
    m, s = x.model, x.symbols
    spring = sp.diag(s["found_shear"], s["found_shear"], 1) * s["k_found"] / len(m.isolators)
    spread = (s["found_spread"], s["found_spread"] * s["found_aspect"])
    p = sp.Integer(0)
    for iso in m.isolators:
        foot = _foot(x.model, iso, True)
        ground = sp.Matrix([spread[0] * foot[0], spread[1] * foot[1], foot[2] - s["found_depth"]])
        u = SymbolicModel.point_motion(x.q[6:, 0], ground)
        p += (u.T * spring * u)[0] / 2
    return p


def _drive_belt(x: ExtendedModel) -> sp.Expr:
    s = x.symbols
    stretch = SymbolicModel.point_motion(x.q[:6, 0], sp.Matrix([0, 0, s["h_belt"]]))[0]
    return s["k_belt"] * stretch**2 / 2


def _gravity_preload(x: ExtendedModel) -> sp.Expr:
    """The isolators carry the weight m g upwards at depth h_preload below the centre of mass; the weight
    acts down at the centre of mass: -F . u2 for each force, u2 the second-order point motion."""
    m, w = x.model, x.q[3:6, 0]
    g = sp.nsimplify(STANDARD_GRAVITY)
    preload_point = m.centre_of_mass - sp.Matrix([0, 0, x.symbols["h_preload"]])
    return (
        -m.mass * g * second_order_motion(w, preload_point)[2]
        + m.mass * g * second_order_motion(w, m.centre_of_mass)[2]
    )


ENERGIES: dict[str, EnergyExtension] = {
    "com_offset": EnergyExtension(kinetic=_shifted_centre(lambda s: sp.Matrix([s["dx_com"], s["dy_com"], 0]))),
    "cog_height": EnergyExtension(kinetic=_shifted_centre(lambda s: sp.Matrix([0, 0, s["dz_com"]]))),
    "rotational_stiffness": EnergyExtension(potential=_rotational_stiffness),
    "foundation": EnergyExtension(kinetic=_slab_kinetic, potential=_slab_on_ground, slab=True),
    "added_mass": EnergyExtension(kinetic=_added_mass),
    "drive_belt": EnergyExtension(potential=_drive_belt),
    "gravity_preload": EnergyExtension(potential=_gravity_preload),
}
"""The energy extension of every ``generated`` effect of the registry (mountid.effects), by name."""

SUPPORT_EFFECTS: tuple[str, ...] = tuple(name for name in GENERATED_EFFECTS if ENERGIES[name].slab)
"""The generated effects that put a support with coordinates of its own between the isolators and the ground."""


def second_order_motion(w: sp.Matrix, position: sp.Matrix) -> sp.Matrix:
    """Second-order displacement 1/2 w x (w x r) of the body point r under the small rotation w: the term
    through which a preload does work in the geometric (gravity) stiffness."""
    return w.cross(w.cross(position)) / 2


class ExtendedModel:
    """The nominal model of a description with one candidate effect added to its energies."""

    def __init__(self, model: SymbolicModel, effect: Effect) -> None:
        if effect.kind != "generated":
            raise ValueError(f"{effect.name} is not an energy extension (kind = {effect.kind})")
        clash = [p.name for p in effect.parameters if p.name in model.symbols]
        if clash:
            raise DescriptionError(f"parameters.{clash[0]}", f"is reserved for the candidate effect {effect.name}")
        self.model = model
        self.effect = effect
        self.symbols = {p.name: sp.Symbol(p.name, real=True) for p in effect.parameters}
        extra = tuple(f"{c}_found" for c in COORDINATES) if ENERGIES[effect.name].slab else ()
        self.coordinates: tuple[str, ...] = COORDINATES + extra
        self.q = sp.Matrix([*model.q, *(sp.Symbol(c, real=True) for c in extra)])
        self.qdot = sp.Matrix([*model.qdot, *(sp.Symbol(c + "_dot", real=True) for c in extra)])

    # -- energies ----------------------------------------------------------------------------------
    @cached_property
    def added_kinetic_energy(self) -> sp.Expr:
        """T of the extended model minus the nominal T (the effect's registered kinetic energy)."""
        term = ENERGIES[self.effect.name].kinetic
        return sp.expand(term(self)) if term else sp.Integer(0)

    @cached_property
    def added_potential_energy(self) -> sp.Expr:
        """P of the extended model minus the nominal P (for the foundation: minus the isolators' P, which
        the foundation changes; see isolator_hessian)."""
        term = ENERGIES[self.effect.name].potential
        return sp.expand(term(self)) if term else sp.Integer(0)

    # -- matrices ------------------------------------------------------------------------------------
    # The Hessian is linear: the extended matrix is the nominal one (Hessian of the nominal energy) plus the
    # Hessian of the added energy. The foundation changes the isolators' energies themselves (they deform
    # between body and slab), so there the isolator energies are differentiated afresh in all 12 coordinates.
    def _matrix(self, added: sp.Expr, nominal: sp.Matrix, variables: sp.Matrix, tensor: str | None) -> sp.Matrix:
        if len(variables) > 6:
            full = sp.zeros(len(variables))
            if tensor is not None:
                for iso in self.model.isolators:
                    full += isolator_hessian(iso.position, getattr(iso, tensor), _foot(self.model, iso, True))
                full = full.applyfunc(sp.expand)
            elif nominal is not None:
                full[:6, :6] = nominal
            return (full + sp.hessian(added, list(variables))).applyfunc(sp.factor_terms)
        if added == 0:
            return nominal
        return (nominal + sp.hessian(added, list(variables))).applyfunc(sp.factor_terms)

    @cached_property
    def added_M(self) -> sp.Matrix:
        """Hessian of the added kinetic energy (extensions without extra coordinates)."""
        return sp.hessian(self.added_kinetic_energy, list(self.qdot)).applyfunc(sp.factor_terms)

    @cached_property
    def added_C(self) -> sp.Matrix:
        """Hessian of the added potential energy (extensions without extra coordinates)."""
        return sp.hessian(self.added_potential_energy, list(self.q)).applyfunc(sp.factor_terms)

    @cached_property
    def M(self) -> sp.Matrix:
        return self._matrix(self.added_kinetic_energy, self.model.M, self.qdot, None)

    @cached_property
    def C(self) -> sp.Matrix:
        return self._matrix(self.added_potential_energy, self.model.C, self.q, "stiffness")

    @cached_property
    def B(self) -> sp.Matrix:
        return self._matrix(sp.Integer(0), self.model.B, self.qdot, "damping")

    def arguments(self) -> tuple[str, ...]:
        """Description parameters, then effect parameters, that M, C and B depend on."""
        free: set[sp.Symbol] = set()
        for mat in (self.M, self.C, self.B):
            free |= mat.free_symbols
        own = tuple(n for n, sym in self.model.symbols.items() if sym in free)
        return own + tuple(n for n, sym in self.symbols.items() if sym in free)


_POINT = sp.Matrix(sp.symbols("_r_x _r_y _r_z", real=True))
_SLAB_POINT = sp.Matrix(sp.symbols("_s_x _s_y _s_z", real=True))
_TENSOR = sp.Matrix(3, 3, lambda i, j: sp.Symbol(f"_k{min(i, j)}{max(i, j)}", real=True))


@cache
def _generic_isolator_hessian(slab: bool) -> sp.Matrix:
    """Hessian of the energy 1/2 d^T K d of one isolator with symbolic point, tensor (and slab point):
    d = u_body(r) (- u_slab(s)). Differentiated once with symbols; each isolator then substitutes its own
    expressions, which is far cheaper than differentiating energies full of its trigonometric entries."""
    q = sp.Matrix(sp.symbols(" ".join(f"_q{i}" for i in range(12 if slab else 6)), real=True))
    d = SymbolicModel.point_motion(q[:6, 0], _POINT)
    if slab:
        d -= SymbolicModel.point_motion(q[6:, 0], _SLAB_POINT)
    energy = sp.expand((d.T * _TENSOR * d)[0] / 2)
    return sp.hessian(energy, list(q))


def isolator_hessian(position: sp.Matrix, tensor: sp.Matrix, slab_position: sp.Matrix | None = None) -> sp.Matrix:
    """The Hessian of one isolator's energy in the body coordinates (and the slab's, when on a slab)."""
    generic = _generic_isolator_hessian(slab_position is not None)
    subs = {_POINT[i]: position[i] for i in range(3)}
    subs |= {_TENSOR[i, j]: tensor[i, j] for i in range(3) for j in range(i, 3)}
    if slab_position is not None:
        subs |= {_SLAB_POINT[i]: slab_position[i] for i in range(3)}
    return generic.xreplace(subs)


def _tidy(e: sp.Expr) -> sp.Expr:
    return sp.factor_terms(sp.expand(e))


def slab_centre(model: SymbolicModel) -> sp.Matrix:
    """Where the coordinates of a support below the isolators (the foundation's slab) refer to: the mean of
    the isolator points [m]."""
    points = [iso.position for iso in model.isolators]
    return sum(points, sp.zeros(3, 1)) / len(points)


def _foot(model: SymbolicModel, iso: Isolator, on_support: bool) -> sp.Matrix | None:
    """The isolator's foot in the support's coordinates (None: the isolator stands on the ground)."""
    return iso.position - slab_centre(model) if on_support else None


def support_feet(model: SymbolicModel) -> list[sp.Matrix]:
    """Each isolator's foot in the support's coordinates [m] (its point from slab_centre), in the order of the
    isolators."""
    return [_foot(model, iso, True) for iso in model.isolators]


def isolator_stiffness(model: SymbolicModel, on_support: bool = False) -> list[sp.Matrix]:
    """The stiffness matrix of each isolator alone (Hessian of its potential energy): C is their sum. With
    ``on_support``, the isolator between the body and a support below it (the foundation's twelve coordinates,
    body then support): the foundation's C is their sum plus the support's ground springs."""
    return [
        isolator_hessian(iso.position, iso.stiffness, _foot(model, iso, on_support)).applyfunc(_tidy)
        for iso in model.isolators
    ]


def isolator_damping(model: SymbolicModel) -> list[sp.Matrix]:
    """The damping matrix of each isolator alone (Hessian of its Rayleigh dissipation 1/2 u'^T B_i u' in the
    velocities, the same form as its energy in the displacements): B is their sum. On the ground only (an isolator
    on a support below it carries its damping in the support effect's B)."""
    return [isolator_hessian(iso.position, iso.damping).applyfunc(_tidy) for iso in model.isolators]


def isolator_axial_stiffness(model: SymbolicModel, on_support: bool = False) -> list[sp.Matrix]:
    """The part of each isolator's stiffness matrix along its own axis a (local z): the Hessian of the energy
    1/2 k_a (a . u)^2 with k_a = a^T K a, the isolator's axial stiffness (compression of the rubber). The rest
    of isolator_stiffness() is its shear part (local x and y). ``on_support`` as for isolator_stiffness()."""
    out = []
    for iso in model.isolators:
        a = iso.axis
        axial = sp.simplify((a.T * iso.stiffness * a)[0])
        out.append(isolator_hessian(iso.position, axial * a * a.T, _foot(model, iso, on_support)).applyfunc(_tidy))
    return out


def scales(model: SymbolicModel) -> dict[str, sp.Expr]:
    """Machine scales the plausible ranges of :mod:`mountid.effects` are multiples of."""
    isolators = model.isolators
    n = len(isolators)
    offsets = [iso.position - model.centre_of_mass for iso in isolators]
    length = sp.sqrt(sum((r.T * r)[0] for r in offsets) / n)
    stiffness = sum(iso.stiffness.trace() for iso in isolators) / (3 * n)
    return {
        "length": length,
        "mass": model.mass,
        "stiffness": stiffness,
        "vertical": model.C[2, 2],
        "horizontal": model.C[0, 0],
        "rotational": stiffness * length**2,
        "one": sp.Integer(1),
    }
