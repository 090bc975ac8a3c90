"""The blind harness's truths: the KID-300 assembled in numpy, independently of the engine (rigid-body point
Jacobians typed from u = t + w x r), with effects built the way they are in a machine rather than the way the
candidate catalogue parameterises them.

In the catalogue (mountid.effects), each by its own physics here:

- ``foundation``: a 6-dof slab (2 m x 2 m x 0.3 m, its own mass and inertia) on pads under the isolator
  feet, the isolators between body and slab;
- ``frequency_dependent``: rubber as a fractional Kelvin-Voigt solid (storage stiffness
  k (1 + a (w tau)^r cos(r pi / 2))), each mode solved as a nonlinear eigenproblem;
- ``added_mass``: a motor as a rigid body with its own inertia, on the vertical axis;
- ``drive_belt``: a spring along x at the pulley;
- ``com_offset``: the centre of mass off in a random horizontal direction;
- ``sensor_error``: four triaxial sensors in a measurement frame turned in yaw against the machine's axes
  and placed off in height, the shapes recovered by least squares with the assumed geometry;
- ``damping``: damped frequencies |Im p| of non-proportionally damped isolators;
- ``cog_height``, ``isolator_scatter``, ``rotational_stiffness``, ``gravity_preload`` by the same physics;
- ``support_frame`` (the catalogue's ``foundation``): a steel frame (2.6 m x 2.6 m x 0.25 m, its own mass
  and inertia) below the isolators, standing on four ground springs on the x and y axes (not under the
  isolator feet, which sit on the diagonals), softer horizontally than vertically, the springs below the
  frame's centre of mass;
- ``offaxis_mass`` (the catalogue's ``added_mass``): a motor with its own inertia bolted on off the vertical
  axis (radius 0.2-0.6 m, any direction and height).

Outside the catalogue (REPRESENTED_BY None: no candidate represents them; an honest diagnosis ends "not
explained" or in a tie, never confident):

- ``isolator_scatter+cog_height``: two effects at once;
- ``nonlinear_isolator``: hardening rubber, stiffness k (1 + gamma (d / d_ref)^2) in each direction with the
  deformation amplitude d of that direction in the mode being measured (equivalent linearisation): each
  mode sees its own isolator stiffness, which no linear model reproduces.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg

from mountid.diagnosis.candidate_model import label_modes, scaled_unit
from mountid.effects import STANDARD_GRAVITY
from mountid.machine import Machine, call, damped_poles

REPRESENTED_BY: dict[str, str | None] = {
    "support_frame": "foundation",
    "offaxis_mass": "added_mass",
    "isolator_scatter+cog_height": None,
    "nonlinear_isolator": None,
}
"""The catalogue effect that represents each truth not named after one (None: no candidate does). A truth
named after a catalogue effect is represented by it, whatever the differences of its physics."""

OUT_OF_CATALOGUE: tuple[str, ...] = tuple(name for name, effect in REPRESENTED_BY.items() if effect is None)
"""Truths no candidate of the catalogue represents."""


def represented_by(truth: str) -> str | None:
    """The catalogue effect that represents the truth ``truth`` (None: none does; 'none' for no effect)."""
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


@dataclass(frozen=True)
class Truth:
    """One synthetic machine: kid300 values, the true unknowns, and the injected effect with its size."""

    effect: str
    size: dict[str, float]
    c_xy: float
    c_z: float


class Kid300:
    """The KID-300 assembled in numpy (known values of the description)."""

    def __init__(self, machine: Machine) -> None:
        v = machine.values({}, tuple(machine.parameters))
        self.v = v
        a = v["L_xy"] / math.sqrt(2)
        self.points = [np.array([sx * a, sy * a, -v["L_z"]]) for sx, sy in ((1, 1), (-1, 1), (1, -1), (-1, -1))]
        self.inertia = np.diag([v["J_xy"], v["J_xy"], v["J_z"]])
        scales = call(machine.module, "effect_scales", v)
        self.length = float(scales["length"])  # [m], the rotations' factor in scaled unit shapes

    def matrices(self, t: Truth):
        """M, C, B of the truth (12 x 12 with a support below the isolators)."""
        v = self.v
        parts = set(t.effect.split("+"))
        k_iso = [np.diag([t.c_xy, t.c_xy, t.c_z]) for _ in self.points]
        b_iso = [np.diag([v["b_xy"], v["b_xy"], v["b_z"]]) for _ in self.points]
        centre = np.zeros(3)
        s = t.size
        if "com_offset" in parts:
            centre = np.array([s["e"] * math.cos(s["angle"]), s["e"] * math.sin(s["angle"]), 0.0])
        if "cog_height" in parts:
            centre = np.array([0.0, 0.0, s["dz"]])
        if "isolator_scatter" in parts:
            k_iso[int(s["isolator"])] = k_iso[int(s["isolator"])] * (1 + s["s"])
        if "damping" in parts:
            b_iso = [b * s["eta"] for b in b_iso]
        m = _body_mass(v["m"], self.inertia, centre)
        c = sum(_jac(r).T @ k @ _jac(r) for r, k in zip(self.points, k_iso, strict=True))
        b = sum(_jac(r).T @ d @ _jac(r) for r, d in zip(self.points, b_iso, strict=True))
        if "rotational_stiffness" in parts:
            c[3:, 3:] += len(self.points) * np.diag([s["k_bend"], s["k_bend"], s["k_torsion"]])
        if "gravity_preload" in parts:
            c[3, 3] -= v["m"] * STANDARD_GRAVITY * s["h"]
            c[4, 4] -= v["m"] * STANDARD_GRAVITY * s["h"]
        if "added_mass" in parts:
            r_m, l_m = 0.12, 0.3  # motor as a solid cylinder with a horizontal axis along x
            ma = s["m"]
            own = ma * np.diag([r_m**2 / 2, (3 * r_m**2 + l_m**2) / 12, (3 * r_m**2 + l_m**2) / 12])
            m = m + _body_mass(ma, own, np.array([0.0, 0.0, s["h"]]))
        if "drive_belt" in parts:
            d = np.array([1.0, 0.0, 0.0])
            row = d @ _jac(np.array([0.0, 0.0, s["h"]]))
            c = c + s["k"] * np.outer(row, row)
        if "offaxis_mass" in parts:
            r_m, l_m = 0.12, 0.3
            ma = s["m"]
            own = ma * np.diag([r_m**2 / 2, (3 * r_m**2 + l_m**2) / 12, (3 * r_m**2 + l_m**2) / 12])
            where = np.array([s["r"] * math.cos(s["angle"]), s["r"] * math.sin(s["angle"]), s["h"]])
            m = m + _body_mass(ma, own, where)
        if "foundation" in parts:
            return self._on_slab(m, k_iso, b_iso, s)
        if "support_frame" in parts:
            return self._on_frame(m, k_iso, b_iso, s)
        return m, c, b

    def _on_slab(self, m_body, k_iso, b_iso, s):
        """Body and slab, 12 dof; the isolators act on the difference of the two bodies' point motions."""
        depth = self.v["L_z"]
        slab_origin = np.array([0.0, 0.0, -depth])
        n = 12
        m = np.zeros((n, n))
        c = np.zeros((n, n))
        b = np.zeros((n, n))
        m[:6, :6] = m_body
        half = 1.0  # slab 2 m x 2 m, 0.3 m thick
        mf = s["m"]
        m[6:, 6:] = _body_mass(mf, mf * np.diag([(4 * half**2 + 0.09) / 12] * 2 + [8 * half**2 / 12]), np.zeros(3))
        for r, k, d in zip(self.points, k_iso, b_iso, strict=True):
            rel = np.hstack([_jac(r), -_jac(r - slab_origin)])
            c += rel.T @ k @ rel
            b += rel.T @ d @ rel
        kz = s["k"] / 4  # a pad under each isolator foot
        ground = np.diag([0.5 * kz, 0.5 * kz, kz])
        for r in self.points:
            j = np.hstack([np.zeros((3, 6)), _jac(r - slab_origin)])
            c += j.T @ ground @ j
        return m, c, b

    def _on_frame(self, m_body, k_iso, b_iso, s):
        """Body and frame, 12 dof, both in coordinates about the body's origin: the isolators act on the
        difference of the two bodies' motions at the feet, the frame stands on four ground springs on the
        x and y axes at 1.3 m (the isolator feet are on the diagonals)."""
        depth = self.v["L_z"]
        m = np.zeros((12, 12))
        c = np.zeros((12, 12))
        b = np.zeros((12, 12))
        m[:6, :6] = m_body
        mf, half, thick = s["m"], 1.3, 0.25
        own = mf * np.diag([(4 * half**2 + thick**2) / 12] * 2 + [8 * half**2 / 12])
        m[6:, 6:] = _body_mass(mf, own, np.array([0.0, 0.0, -depth - thick / 2]))
        for r, k, d in zip(self.points, k_iso, b_iso, strict=True):
            rel = np.hstack([_jac(r), -_jac(r)])
            c += rel.T @ k @ rel
            b += rel.T @ d @ rel
        kv = s["k"] / 4
        ground = np.diag([s["horizontal"] * kv, s["horizontal"] * kv, kv])
        for x, y in ((half, 0.0), (-half, 0.0), (0.0, half), (0.0, -half)):
            j = np.hstack([np.zeros((3, 6)), _jac(np.array([x, y, -depth - thick]))])
            c += j.T @ ground @ j
        return m, c, b


def sample(rng: np.random.Generator, effect: str, v: dict[str, float]) -> dict[str, float]:
    """A random effect size, from barely visible to clearly visible against the synthetic noise."""

    def logu(lo: float, hi: float) -> float:
        return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))

    sign = 1.0 if rng.random() < 0.5 else -1.0
    c_rock = 4 * 472.3e3 * v["L_xy"] ** 2 / 2
    if effect == "com_offset":
        return {"e": logu(0.01, 0.06), "angle": rng.uniform(0, 2 * math.pi)}
    if effect == "cog_height":
        return {"dz": sign * logu(0.01, 0.1)}
    if effect == "isolator_scatter":
        return {"s": sign * logu(0.05, 0.4), "isolator": int(rng.integers(4))}
    if effect == "rotational_stiffness":
        return {"k_bend": logu(0.003, 0.03) * c_rock / 4, "k_torsion": logu(0.003, 0.03) * c_rock / 4}
    if effect == "frequency_dependent":
        return {"a": logu(0.03, 0.3), "r": rng.uniform(0.2, 0.6), "tau": 1 / 40.0}
    if effect == "foundation":
        return {"m": logu(0.5, 5) * v["m"], "k": logu(10, 100) * 4 * 472.3e3}
    if effect == "added_mass":
        return {"m": logu(0.02, 0.15) * v["m"], "h": rng.uniform(-0.5, 0.5)}
    if effect == "drive_belt":
        return {"k": logu(0.01, 0.2) * 4 * 74.4e3, "h": rng.uniform(-0.3, 0.5)}
    if effect == "gravity_preload":
        return {"h": v["L_z"] + rng.uniform(0.0, 0.2)}
    if effect == "damping":
        return {"eta": logu(1.5, 5.0)}
    if effect == "sensor_error":
        return {"yaw": sign * logu(0.01, 0.08), "dz": rng.uniform(-0.15, 0.15)}
    if effect == "support_frame":
        return {"m": logu(0.3, 2) * v["m"], "k": logu(3, 30) * 4 * 472.3e3, "horizontal": rng.uniform(0.2, 0.6)}
    if effect == "nonlinear_isolator":
        return {"gamma": logu(0.02, 0.2)}
    if effect == "offaxis_mass":
        return {
            "m": logu(0.03, 0.15) * v["m"],
            "r": logu(0.2, 0.6),
            "angle": rng.uniform(0, 2 * math.pi),
            "h": rng.uniform(-0.3, 0.5),
        }
    if "+" in effect:
        out: dict[str, float] = {}
        for part in effect.split("+"):
            out.update(sample(rng, part, v))
        return out
    if effect == "none":
        return {}
    raise ValueError(f"no blind truth for the effect {effect!r}: add its size here and its physics to Kid300")


def true_modes(kid: Kid300, machine: Machine, t: Truth) -> tuple[np.ndarray, np.ndarray]:
    """True frequencies [rad/s] and shapes (6, 6) in q, in the machine's mode order."""
    mod = machine.module
    m, c, b = kid.matrices(t)
    lam, vec = scipy.linalg.eigh(c, m)
    nominal = {**kid.v, "c_xy": t.c_xy, "c_z": t.c_z}
    fwd = {a: nominal[a] for a in mod.FORWARD_ARGUMENTS}
    ref = scaled_unit(mod.modal_matrix(**fwd), kid.length)
    body = scaled_unit(vec[:6], kid.length)
    share = np.einsum("ij,ik,kj->j", vec[:6], m[:6, :6], vec[:6])
    order = label_modes(lam, body, np.asarray(mod.squared_frequencies(**fwd)), ref, share)
    omega = np.sqrt(lam[order])
    shapes = vec[:6, order]
    parts = set(t.effect.split("+"))
    if "frequency_dependent" in parts:
        a, r, tau = t.size["a"], t.size["r"], t.size["tau"]
        for i in range(len(omega)):  # omega^2 = g(omega) lambda, g the fractional model's storage factor
            w = omega[i]
            for _ in range(200):
                g = 1 + a * (w * tau) ** r * math.cos(r * math.pi / 2)
                w_new = math.sqrt(g * lam[order][i])
                if abs(w_new - w) < 1e-13 * w:
                    break
                w = w_new
            omega[i] = w_new
    elif "damping" in parts:
        omega = damped_poles(m, c, b, lam)[order].imag
    elif "sensor_error" in parts:
        shapes = _through_sensors(kid, shapes, t.size["yaw"], t.size["dz"])
    elif "nonlinear_isolator" in parts:
        omega, shapes = _hardened(kid, t, m, shapes)
    return omega, shapes


def true_damping_ratios(kid: Kid300, t: Truth, shapes: np.ndarray) -> np.ndarray:
    """Damping ratio of each mode (in the machine's mode order, paired with ``shapes`` by MAC): -Re p / |p| of
    the truth's damped poles (M p^2 + B p + C = 0, its own non-proportional B)."""
    m, c, b = kid.matrices(t)
    n = m.shape[0]
    a = np.block([[np.zeros((n, n)), np.eye(n)], [-np.linalg.solve(m, c), -np.linalg.solve(m, b)]])
    poles, vectors = np.linalg.eig(a)
    upper = poles.imag > 0
    poles, vectors = poles[upper], vectors[:n, upper]
    out = np.empty(shapes.shape[1])
    for i in range(shapes.shape[1]):
        phi = shapes[:, i]
        fit = np.abs(np.conj(vectors[: len(phi)]).T @ phi) / np.linalg.norm(vectors[: len(phi)], axis=0)
        p = poles[int(np.argmax(fit))]
        out[i] = -p.real / abs(p)
    return out


def _hardened(kid: Kid300, t: Truth, m: np.ndarray, shapes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each mode of hardening isolators by equivalent linearisation: every isolator direction stiffer by
    1 + gamma (d / d_max)^2, d its deformation amplitude in the mode, d_max the largest over the isolators
    and directions (each mode excited to the same largest deformation); iterated to a fixed point."""
    gamma = t.size["gamma"]
    nominal = np.array([t.c_xy, t.c_xy, t.c_z])
    omega, out = np.empty(shapes.shape[1]), np.empty_like(shapes)
    for i in range(shapes.shape[1]):
        phi = shapes[:, i]
        for _ in range(50):
            d = np.array([_jac(r) @ phi for r in kid.points])
            factor = 1 + gamma * (np.abs(d) / np.abs(d).max()) ** 2
            c = sum(_jac(r).T @ np.diag(nominal * f) @ _jac(r) for r, f in zip(kid.points, factor, strict=True))
            lam, vec = scipy.linalg.eigh(c, m)
            j = int(np.argmax(np.abs(vec.T @ m @ phi)))
            step = vec[:, j] * np.sign(vec[:, j] @ m @ phi)
            done = np.allclose(step, phi / math.sqrt(phi @ m @ phi), rtol=0, atol=1e-12)
            phi = step
            if done:
                break
        omega[i], out[:, i] = math.sqrt(lam[j]), phi
    return omega, out


def _through_sensors(kid: Kid300, shapes: np.ndarray, yaw: float, dz: float) -> np.ndarray:
    """Shapes recovered by least squares from four triaxial sensors on the top corners. The measurement
    frame (sensor axes and the positions the processing assumes) is turned by ``yaw`` about the vertical
    against the machine's axes, and the sensors sit ``dz`` higher than assumed."""
    a = kid.v["L_xy"] / math.sqrt(2)
    assumed = [np.array([sx * a, sy * a, 0.25]) for sx, sy in ((1, 1), (-1, 1), (1, -1), (-1, -1))]
    cz, sz = math.cos(yaw), math.sin(yaw)
    turn = np.array([[cz, sz, 0.0], [-sz, cz, 0.0], [0.0, 0.0, 1.0]])  # machine axes -> measurement frame
    read = np.vstack([turn @ _jac(turn.T @ r + np.array([0.0, 0.0, dz])) for r in assumed])
    model = np.vstack([_jac(r) for r in assumed])
    return np.linalg.lstsq(model, read @ shapes, rcond=None)[0]
