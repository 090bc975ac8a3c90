"""Blind validation of the gap diagnosis: synthetic campaigns from a higher-fidelity truth, and a scorer.

The truth is the KID-300 assembled here in numpy, independently of the engine (rigid-body point
Jacobians typed from u = t + w x r), with one injected effect built the way it is in the machine rather than
the way the candidate library parameterises it:

- ``foundation``: a 6-dof slab (2 m x 2 m x 0.3 m, its own mass and inertia) on pads under the isolator
  feet, the isolators between body and slab (the support geometry is the library's; the slab's inertia
  and the participating mass are not);
- ``frequency_dependent``: rubber as a fractional Kelvin-Voigt solid (storage stiffness
  k (1 + a (w tau)^r cos(r pi / 2))), each mode solved as a nonlinear eigenproblem;
- ``added_mass``: a motor as a rigid body with its own inertia;
- ``drive_belt``: a spring along x at the pulley;
- ``com_offset``: the centre of mass off in a random horizontal direction;
- ``sensor_error``: four triaxial sensors in a measurement frame turned in yaw against the machine's axes
  and placed off in height, the shapes recovered by least squares with the assumed geometry;
- ``damping``: damped frequencies |Im p| of non-proportionally damped isolators;
- the others (``cog_height``, ``isolator_scatter``, ``rotational_stiffness``, ``gravity_preload``) by the
  same physics in this independent assembly.

The diagnosis sees a campaign file's content only: frequencies with their uncertainty and mode shapes in
q with theirs. Which effect was injected, and its size, stay here.
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass

import numpy as np
import scipy.linalg

from mountid.diagnosis import campaign as campaign_module
from mountid.diagnosis.candidate_model import label_modes, scaled_unit
from mountid.diagnosis.candidates import diagnose_effects
from mountid.diagnosis.settings import DIAGNOSIS
from mountid.effects import CATALOGUE, STANDARD_GRAVITY
from mountid.machine import Machine, call, damped_poles

EFFECT_NAMES: tuple[str, ...] = ("none", *(e.name for e in CATALOGUE))
FREQUENCY_STD = 3e-4
"""Relative standard deviation of the synthetic frequencies (a 20 s record, see the records issue)."""
SHAPE_STD = 0.01
"""Standard deviation per component of the synthetic unit shapes."""


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


class _Kid300:
    """The KID-300 assembled in numpy (known values of the description)."""

    def __init__(self, machine: Machine) -> None:
        v = machine.values({}, tuple(machine.parameters))
        self.v = v
        a = v["L_xy"] / math.sqrt(2)
        self.points = [np.array([sx * a, sy * a, -v["L_z"]]) for sx, sy in ((1, 1), (-1, 1), (1, -1), (-1, -1))]
        self.inertia = np.diag([v["J_xy"], v["J_xy"], v["J_z"]])
        scales = call(machine.module, "effect_scales", v)
        self.length = float(scales["length"])  # [m], the rotations' factor in scaled unit shapes

    def matrices(self, t: Truth, rng_isolator: int = 0):
        v = self.v
        k_iso = [np.diag([t.c_xy, t.c_xy, t.c_z]) for _ in self.points]
        b_iso = [np.diag([v["b_xy"], v["b_xy"], v["b_z"]]) for _ in self.points]
        centre = np.zeros(3)
        s = t.size
        if t.effect == "com_offset":
            centre = np.array([s["e"] * math.cos(s["angle"]), s["e"] * math.sin(s["angle"]), 0.0])
        elif t.effect == "cog_height":
            centre = np.array([0.0, 0.0, s["dz"]])
        elif t.effect == "isolator_scatter":
            k_iso[int(s["isolator"])] = k_iso[int(s["isolator"])] * (1 + s["s"])
        elif t.effect == "damping":
            b_iso = [b * s["eta"] for b in b_iso]
        m = _body_mass(v["m"], self.inertia, centre)
        c = sum(_jac(r).T @ k @ _jac(r) for r, k in zip(self.points, k_iso, strict=True))
        b = sum(_jac(r).T @ d @ _jac(r) for r, d in zip(self.points, b_iso, strict=True))
        if t.effect == "rotational_stiffness":
            c[3:, 3:] += len(self.points) * np.diag([s["k_bend"], s["k_bend"], s["k_torsion"]])
        elif t.effect == "gravity_preload":
            c[3, 3] -= v["m"] * STANDARD_GRAVITY * s["h"]
            c[4, 4] -= v["m"] * STANDARD_GRAVITY * s["h"]
        elif t.effect == "added_mass":
            r_m, l_m = 0.12, 0.3  # motor as a solid cylinder with a horizontal axis along x
            ma = s["m"]
            own = ma * np.diag([r_m**2 / 2, (3 * r_m**2 + l_m**2) / 12, (3 * r_m**2 + l_m**2) / 12])
            m = m + _body_mass(ma, own, np.array([0.0, 0.0, s["h"]]))
        elif t.effect == "drive_belt":
            d = np.array([1.0, 0.0, 0.0])
            row = d @ _jac(np.array([0.0, 0.0, s["h"]]))
            c = c + s["k"] * np.outer(row, row)
        if t.effect == "foundation":
            return self._on_slab(m, k_iso, b_iso, s)
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


def _sample(rng: np.random.Generator, effect: str, v: dict[str, float]) -> dict[str, float]:
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
    if effect == "none":
        return {}
    raise ValueError(f"no blind truth for the effect {effect!r}: add its size here and its physics to _Kid300")


def _modes(kid: _Kid300, machine: Machine, t: Truth) -> tuple[np.ndarray, np.ndarray]:
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
    if t.effect == "frequency_dependent":
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
    elif t.effect == "damping":
        omega = damped_poles(m, c, b, lam)[order].imag
    elif t.effect == "sensor_error":
        shapes = _through_sensors(kid, shapes, t.size["yaw"], t.size["dz"])
    return omega, shapes


def _through_sensors(kid: _Kid300, shapes: np.ndarray, yaw: float, dz: float) -> np.ndarray:
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


def make_case(seed: int, effect: str, noise: bool = True) -> tuple[dict, Truth]:
    """A campaign (as its JSON data) and the hidden truth for one seed and injected effect."""
    rng = np.random.default_rng(seed)
    machine = Machine.resolve("kid300")
    kid = _Kid300(machine)
    t = Truth(effect, _sample(rng, effect, kid.v), 74.4e3 * rng.uniform(0.8, 1.2), 472.3e3 * rng.uniform(0.8, 1.2))
    omega, shapes = _modes(kid, machine, t)
    noise_rng = np.random.default_rng(seed + 1_000_003)
    modes = {}
    unit = scaled_unit(shapes, kid.length)
    for i, label in enumerate(machine.modes):
        w = omega[i] * (1 + (FREQUENCY_STD * noise_rng.standard_normal() if noise else 0.0))
        s = unit[:, i] + (SHAPE_STD * noise_rng.standard_normal(6) if noise else 0.0)
        s[3:] /= kid.length
        modes[label] = {
            "frequency": float(w),
            "uncertainty": float(FREQUENCY_STD * omega[i]),
            "shape": [float(x) for x in s],
            "shape_uncertainty": SHAPE_STD,
        }
    known = {k: kid.v[k] for k in ("m", "J_xy", "J_z", "L_xy", "L_z", "b_xy", "b_z")}
    return {"name": f"blind case {seed}", "machine": "kid300", "known": known, "modes": modes}, t


@dataclass(frozen=True)
class CaseResult:
    truth: str
    ranked: tuple[str, ...]
    tie: tuple[str, ...]
    significant: bool
    confident: bool
    identifiable: bool
    reduction: float
    """1 - held-out gap of the best candidate / that of the nominal model (median over the modes of
    |held-out error| / sigma; nan without a significant gap)."""


def run_case(seed: int, effect: str) -> CaseResult:
    """Diagnose one blind case; identifiability is judged on the same truth without noise: the gap is
    significant there and the true effect beats every other candidate by more than the tie margin."""
    data, _ = make_case(seed, effect)
    report = diagnose_effects(campaign_module.parse(data))
    ranked = tuple(f.effect for f in report.ranked if f.applicable)
    identifiable = False
    if effect != "none":
        clean, _ = make_case(seed, effect, noise=False)
        ideal = diagnose_effects(campaign_module.parse(clean), warm=report, exact_held_out=False)
        fits = {f.effect: f for f in ideal.ranked if f.applicable and f.plausible}
        truth = fits.get(effect)
        identifiable = bool(
            ideal.significant
            and truth is not None
            and all(f.aicc > truth.aicc + DIAGNOSIS.tie for name, f in fits.items() if name != effect)
        )
    reduction = math.nan
    if report.significant and report.best is not None:
        before, after = report.nominal.held_out_median, report.best.held_out_median
        if math.isfinite(before) and math.isfinite(after) and before > 0:
            reduction = 1 - after / before
    return CaseResult(effect, ranked, tuple(report.tie), report.significant, report.confident, identifiable, reduction)


def cases(n: int, first_seed: int = 0) -> list[tuple[int, str]]:
    """n cases cycling through every effect and 'none' (so about 1 in 12 has no injected effect)."""
    return [(first_seed + i, EFFECT_NAMES[i % len(EFFECT_NAMES)]) for i in range(n)]


@dataclass(frozen=True)
class Score:
    n: int
    top1_identifiable: float
    top2_identifiable: float
    n_identifiable: int
    truth_in_tie: float
    n_detected: int
    median_reduction: float
    confident_on_none: int
    n_none: int
    confusion: dict[str, Counter]

    @property
    def targets_met(self) -> bool:
        return (
            self.top1_identifiable >= 0.8
            and self.truth_in_tie >= 0.95
            and self.median_reduction >= 0.7
            and self.confident_on_none == 0
        )

    def text(self) -> str:
        lines = [
            f"blind cases: {self.n} ({self.n_none} without an injected effect)",
            f"top-1 on identifiable cases: {self.top1_identifiable:.1%} (target >= 80%), "
            f"top-2: {self.top2_identifiable:.1%}, identifiable: {self.n_identifiable}",
            f"truth inside the reported tie: {self.truth_in_tie:.1%} of {self.n_detected} cases with a detected gap "
            "(target >= 95%)",
            f"median held-out gap reduction: {self.median_reduction:.1%} (target >= 70%)",
            f"confident verdicts on cases without an effect: {self.confident_on_none} of {self.n_none} (target 0)",
            "confusion (rows: injected; columns: ranked first, '-' no significant gap):",
        ]
        cols = ["-", *EFFECT_NAMES[1:]]
        short = {c: c[:6] for c in cols}
        lines.append(" " * 21 + " ".join(f"{short[c]:>6}" for c in cols))
        for truth in EFFECT_NAMES:
            row = self.confusion.get(truth, Counter())
            lines.append(f"{truth:>20} " + " ".join(f"{row.get(c, 0):>6}" for c in cols))
        return "\n".join(lines)


def score(results: list[CaseResult]) -> Score:
    """Top-1/top-2 on identifiable cases, truth-in-tie and gap reduction on detected ones, none-case verdicts."""
    ident = [r for r in results if r.identifiable]
    detected = [r for r in results if r.truth != "none" and r.significant]
    none = [r for r in results if r.truth == "none"]
    confusion: dict[str, Counter] = {}
    for r in results:
        confusion.setdefault(r.truth, Counter())[r.ranked[0] if r.significant and r.ranked else "-"] += 1
    reductions = [r.reduction for r in detected if math.isfinite(r.reduction)]
    return Score(
        len(results),
        float(np.mean([r.ranked[:1] == (r.truth,) for r in ident])) if ident else math.nan,
        float(np.mean([r.truth in r.ranked[:2] for r in ident])) if ident else math.nan,
        len(ident),
        float(np.mean([r.truth in r.tie for r in detected])) if detected else math.nan,
        len(detected),
        float(np.median(reductions)) if reductions else math.nan,
        sum(r.confident for r in none),
        len(none),
        confusion,
    )


def _run(args: tuple[int, str]) -> CaseResult:
    return run_case(*args)


def run(n: int, workers: int = 2, first_seed: int = 0) -> list[CaseResult]:
    """Run n blind cases over ``workers`` processes."""
    from concurrent.futures import ProcessPoolExecutor

    todo = cases(n, first_seed)
    if workers <= 1:
        return [run_case(*c) for c in todo]
    with ProcessPoolExecutor(max_workers=workers) as pool:
        return list(pool.map(_run, todo, chunksize=2))
