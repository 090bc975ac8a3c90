"""Candidate effects as extensions of a description's energies (the ``generated`` effects of
:mod:`mountid.effects`), the per-isolator stiffness matrices, and the machine scales.

Each extension writes kinetic energy T, potential energy P and dissipation D of the extended system with
sympy and takes M, C, B as their Hessians, exactly as :class:`~mountid.symbolic.model.SymbolicModel` does for
the nominal model; an extra coordinate (the foundation's vertical motion) extends q.
"""

from __future__ import annotations

from functools import cached_property

import sympy as sp

from mountid.description import COORDINATES
from mountid.effects import EFFECTS, STANDARD_GRAVITY, Effect
from mountid.errors import DescriptionError
from mountid.symbolic.model import SymbolicModel, rigid_body_kinetic_energy

GENERATED_EFFECTS: tuple[str, ...] = tuple(name for name, e in EFFECTS.items() if e.how == "generated")


def second_order_motion(w: sp.Matrix, position: sp.Matrix) -> sp.Matrix:
    """Second-order displacement 1/2 w x (w x r) of the body point r under the small rotation w: the term
    through which a preload does work in the geometric (gravity) stiffness."""
    return w.cross(w.cross(position)) / 2


class ExtendedModel:
    """The nominal model of a description with one candidate effect added to its energies."""

    def __init__(self, model: SymbolicModel, effect: Effect) -> None:
        if effect.how != "generated":
            raise ValueError(f"{effect.name} is not an energy extension (how = {effect.how})")
        clash = [p.name for p in effect.parameters if p.name in model.symbols]
        if clash:
            raise DescriptionError(f"parameters.{clash[0]}", f"is reserved for the candidate effect {effect.name}")
        self.model = model
        self.effect = effect
        self.symbols = {p.name: sp.Symbol(p.name, real=True) for p in effect.parameters}
        extra = ("z_found",) if effect.name == "foundation" else ()
        self.coordinates: tuple[str, ...] = COORDINATES + extra
        self.q = sp.Matrix([*model.q, *(sp.Symbol(c, real=True) for c in extra)])
        self.qdot = sp.Matrix([*model.qdot, *(sp.Symbol(c + "_dot", real=True) for c in extra)])

    # -- energies ----------------------------------------------------------------------------------
    def _isolators(self, vec: sp.Matrix, tensor: str) -> sp.Expr:
        """Isolator energy 1/2 sum d^T K d of the deformation d = u(r_i) - (support motion)."""
        support = sp.Matrix([0, 0, vec[6]]) if len(vec) > 6 else sp.zeros(3, 1)
        total = sp.Integer(0)
        for iso in self.model.isolators:
            d = SymbolicModel.point_motion(vec[:6, 0], iso.position) - support
            total += (d.T * getattr(iso, tensor) * d)[0] / 2
        return total

    @cached_property
    def kinetic_energy(self) -> sp.Expr:
        m, s = self.model, self.symbols
        centre = m.centre_of_mass
        name = self.effect.name
        body = self.qdot[:6, 0]
        if name == "com_offset":
            centre = centre + sp.Matrix([s["dx_com"], s["dy_com"], 0])
        elif name == "cog_height":
            centre = centre + sp.Matrix([0, 0, s["dz_com"]])
        t = rigid_body_kinetic_energy(m.mass, m.inertia, centre, body)
        if name == "added_mass":
            t += rigid_body_kinetic_energy(s["m_added"], sp.zeros(3), sp.Matrix([0, 0, s["h_added"]]), body)
        elif name == "foundation":
            t += s["m_found"] * self.qdot[6] ** 2 / 2
        return sp.expand(t)

    @cached_property
    def potential_energy(self) -> sp.Expr:
        m, s = self.model, self.symbols
        name = self.effect.name
        p = self._isolators(self.q, "stiffness")
        w = self.q[3:6, 0]
        if name == "rotational_stiffness":
            # per isolator: bending about the axes across it, torsion about its own axis a
            for iso in m.isolators:
                a = iso.axis
                tensor = s["k_bend"] * (sp.eye(3) - a * a.T) + s["k_torsion"] * a * a.T
                p += (w.T * tensor * w)[0] / 2
        elif name == "foundation":
            p += s["k_found"] * self.q[6] ** 2 / 2
        elif name == "drive_belt":
            stretch = SymbolicModel.point_motion(self.q[:6, 0], sp.Matrix([0, 0, s["h_belt"]]))[0]
            p += s["k_belt"] * stretch**2 / 2
        elif name == "gravity_preload":
            # the isolators carry the weight m g upwards at depth h_preload below the centre of mass; the
            # weight acts down at the centre of mass: -F . u2 for each force, second-order point motion u2
            g = sp.nsimplify(STANDARD_GRAVITY)
            preload_point = m.centre_of_mass - sp.Matrix([0, 0, s["h_preload"]])
            p -= m.mass * g * second_order_motion(w, preload_point)[2]
            p += m.mass * g * second_order_motion(w, m.centre_of_mass)[2]
        return sp.expand(p)

    @cached_property
    def dissipation_function(self) -> sp.Expr:
        return sp.expand(self._isolators(self.qdot, "damping"))

    # -- matrices ------------------------------------------------------------------------------------
    @cached_property
    def M(self) -> sp.Matrix:
        return sp.hessian(self.kinetic_energy, list(self.qdot)).applyfunc(sp.factor_terms)

    @cached_property
    def C(self) -> sp.Matrix:
        return sp.hessian(self.potential_energy, list(self.q)).applyfunc(sp.factor_terms)

    @cached_property
    def B(self) -> sp.Matrix:
        return sp.hessian(self.dissipation_function, list(self.qdot)).applyfunc(sp.factor_terms)

    def arguments(self) -> tuple[str, ...]:
        """Description parameters, then effect parameters, that M, C and B depend on."""
        free: set[sp.Symbol] = set()
        for mat in (self.M, self.C, self.B):
            free |= mat.free_symbols
        own = tuple(n for n, sym in self.model.symbols.items() if sym in free)
        return own + tuple(n for n, sym in self.symbols.items() if sym in free)


def isolator_stiffness(model: SymbolicModel) -> list[sp.Matrix]:
    """The stiffness matrix of each isolator alone (Hessian of its potential energy): C is their sum."""
    out = []
    for iso in model.isolators:
        u = SymbolicModel.point_motion(model.q, iso.position)
        energy = sp.expand((u.T * iso.stiffness * u)[0] / 2)
        out.append(sp.hessian(energy, list(model.q)).applyfunc(sp.factor_terms))
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
