"""The virtual test rig: the experiment of paper Sec. 4 on any generated machine, with a known truth.

M q'' + B q' + C q = Q(t) (Eq. 27) with M, B, C from the generated module. Excitations are forces at body
points (a hammer's finite pulse, optionally a double hit; a rotating unbalance, Eqs. 29-30 in general form)
acting on q through the generated point_jacobian (virtual work); sensors read the acceleration of a body
point along a direction, with noise, bias, an anti-alias filter and optional clipping.

Two independent solutions of the same equations, which tests hold against each other:

- :meth:`Rig.frf` / :meth:`Rig.steady_state`: the complex frequency response (C - w^2 M + i w B)^-1, for
  harmonic forcing in closed form;
- :meth:`Rig.simulate`: time integration in the complex modal coordinates of the first-order form, exact
  for forces that are linear between the internal samples (first-order hold), run by scipy.signal.lfilter.

A rig may carry hardening isolators (:class:`Hardening`): rubber whose restoring force grows with the cube of
its deformation, so that a mode's frequency depends on how hard the machine is hit. Its records are integrated
by scipy.integrate.solve_ivp (DOP853) on the same fine grid (:meth:`Rig.respond_hardening`); with the
hardening at zero that integration and the exact one agree, which the tests hold.
"""

from __future__ import annotations

import itertools
import math
import types
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy.integrate
import scipy.linalg
import scipy.signal
from numpy.typing import NDArray

from mountid.errors import InputError
from mountid.machine import Machine, matrices, sensor_row, state_matrix, unit_vector
from mountid.measurement.records import MIN_SAMPLES, UNITS, Channel, ModeTable, Record, along_axes
from mountid.runtime.eigen import with_real_positive_largest


@dataclass(frozen=True)
class Sensor:
    """A response channel: body point [m] (from the coordinate origin), measuring direction, what it
    measures (``quantity`` acceleration, velocity or displacement, recorded in ``unit``, one of
    records.UNITS), and its imperfections in that unit: white noise std relative to the channel's clean RMS,
    constant bias, clipping level (None: no clipping)."""

    name: str
    point: tuple[float, float, float]
    direction: tuple[float, float, float]
    noise: float = 0.0
    bias: float = 0.0
    clip: float | None = None
    quantity: str = "acceleration"
    unit: str = "m/s^2"


ANTI_ALIAS = 0.4
"""Corner of the simulated acquisition's anti-alias filter over the sampling rate (an 8th-order Butterworth): a
mode above it is not in the record's band."""

BLOCK = 1 << 17
"""Fine samples Rig.simulate integrates at a time (about 0.1 GB): a long record at a high rate is simulated in
blocks, each continuing from the state and the anti-alias filter's memory of the one before."""

SMALL_MOTION = 0.1
"""The largest rotation [rad], and translation as a fraction of the machine's length scale, that the linear model
describes well (sin 0.1 = 0.1 within 0.2 %): a steady state beyond it is named (Rig.beyond_small_motion)."""

RESOLVED = 16
"""Samples the simulation takes at least per hammer pulse and per period of the fastest mode or unbalance
(Rig.simulate raises its oversampling to reach them)."""


@dataclass(frozen=True)
class Hammer:
    """An impact: a half-sine force pulse of ``peak`` [N] lasting ``duration`` [s] from ``time`` [s], at a
    body point along a direction; ``second_hit`` = (delay [s], relative size) adds a double hit."""

    point: tuple[float, float, float]
    direction: tuple[float, float, float]
    peak: float = 2000.0
    duration: float = 0.004
    time: float = 0.05
    second_hit: tuple[float, float] | None = None

    def force(self, t: NDArray) -> NDArray[np.float64]:
        """Force magnitude [N] at times t [s]."""
        hits = [(self.time, 1.0)] + ([(self.time + self.second_hit[0], self.second_hit[1])] if self.second_hit else [])
        out = np.zeros_like(t, dtype=float)
        for start, size in hits:
            s = (t - start) / self.duration
            out += np.where((s >= 0) & (s <= 1), size * self.peak * np.sin(np.pi * np.clip(s, 0, 1)), 0.0)
        return out


@dataclass(frozen=True)
class Shaker:
    """A shaker driven with a multisine (a controller's periodic random): the force [N] sum_k a cos(2 pi k t / period
    + phase_k) over the lines k / ``period`` [s] from ``low`` to ``high`` [Hz], of equal amplitude a set for ``rms``
    [N], the phases uniformly random from ``seed``; at a body point along a direction. It repeats every period;
    with ``burst`` (a share of the period) it is burst random instead: on for that share of each period, then off,
    with new phases in every period (it never repeats); with ``random`` it is random: new phases in every period,
    back to back (it never repeats and never rests)."""

    point: tuple[float, float, float]
    direction: tuple[float, float, float]
    rms: float = 200.0
    low: float = 0.5
    high: float = 25.0
    period: float = 16.0
    seed: int = 0
    burst: float | None = None
    random: bool = False

    def __post_init__(self) -> None:
        if not (self.period > 0 and 0 <= self.low < self.high and self.rms > 0):
            raise InputError("shaker", "needs a period > 0, 0 <= low < high [Hz] and an rms force > 0")
        if self.burst is not None and not 0 < self.burst < 1:
            raise InputError("shaker", f"a burst is a share of the period between 0 and 1, got {self.burst}")
        if self.burst is not None and self.random:
            raise InputError("shaker", "is burst random or random, not both")
        if len(self.lines()) == 0:
            raise InputError("shaker", f"no line k / {self.period:g} s between {self.low:g} and {self.high:g} Hz")

    def lines(self) -> NDArray[np.float64]:
        """The frequencies [Hz] the shaker excites."""
        k = np.arange(math.ceil(self.low * self.period - 1e-9), math.floor(self.high * self.period + 1e-9) + 1)
        return k[k > 0] / self.period

    def force(self, t: NDArray) -> NDArray[np.float64]:
        """Force [N] at times t [s]."""
        t = np.asarray(t, dtype=float)
        lines = self.lines()
        amplitude = self.rms * math.sqrt(2.0 / len(lines))
        out = np.zeros_like(t)
        if self.burst is None and not self.random:
            return amplitude * self._multisine(t, lines, np.random.default_rng(self.seed))
        share = 1.0 if self.random else self.burst
        index = np.floor(t / self.period).astype(int)
        for k in np.unique(index):  # each period its own phases, on for the burst's share of it (random: all)
            at = (index == k) & (t - k * self.period < share * self.period)
            out[at] = amplitude * self._multisine(t[at], lines, np.random.default_rng([self.seed, int(k)]))
        return out

    @staticmethod
    def _multisine(t: NDArray, lines: NDArray, rng: np.random.Generator) -> NDArray[np.float64]:
        """sum_k cos(2 pi f_k t + phase_k) over ``lines`` [Hz], the phases uniformly random from ``rng``."""
        phases = rng.uniform(0.0, 2 * np.pi, len(lines))
        out = np.zeros_like(t)
        for start in range(0, len(lines), 64):  # 64 lines at a time: memory
            part = slice(start, start + 64)
            out += np.cos(2 * np.pi * np.outer(t, lines[part]) + phases[part]).sum(axis=1)
        return out


@dataclass(frozen=True)
class RandomForce:
    """An unmeasured random force (ambient or operational excitation: ground vibration reaching the machine through
    an isolator, the process a running machine works on): white noise of ``rms`` [N] up to ``high`` [Hz] at a body
    point along a direction, from ``seed``. Its values at knots KNOTS x ``high`` apart [Hz] (independent standard
    normal, drawn in blocks of KNOT_BLOCK from (seed, block), so that any stretch of time gives the same force)
    joined by straight lines: a smooth spectrum (sinc(f / (KNOTS high)))^4, flat within 7 % to ``high`` and
    falling to zero at KNOTS x ``high``. No record holds it: a record of its responses is output-only (the records
    chain fits their correlation functions)."""

    point: tuple[float, float, float]
    direction: tuple[float, float, float]
    rms: float = 100.0
    high: float = 40.0
    seed: int = 0

    def __post_init__(self) -> None:
        if not (self.rms > 0 and self.high > 0):
            raise InputError(
                "random force", f"needs an rms force > 0 and a band high > 0 Hz, got {self.rms}, {self.high}"
            )

    def force(self, t: NDArray) -> NDArray[np.float64]:
        """Force [N] at times t [s] (t >= 0)."""
        t = np.asarray(t, dtype=float)
        if t.size == 0:
            return np.zeros(0)
        at = t * KNOTS * self.high
        k = np.floor(at).astype(np.int64)
        first, last = int(k.min()) // KNOT_BLOCK, (int(k.max()) + 1) // KNOT_BLOCK
        values = np.concatenate(
            [np.random.default_rng([self.seed, b]).standard_normal(KNOT_BLOCK) for b in range(first, last + 1)]
        )
        k0 = k - first * KNOT_BLOCK
        share = at - k
        # straight lines between unit-variance knots: the variance (1 - s)^2 + s^2, 2/3 on average over a knot
        return self.rms * math.sqrt(1.5) * ((1 - share) * values[k0] + share * values[k0 + 1])


KNOTS = 10.0
"""A random force's knots per period of its band's top (RandomForce): the straight lines between them are flat in
the spectrum within (sinc(1 / KNOTS))^4 = 0.935 at the top."""

KNOT_BLOCK = 4096
"""Knots a random force draws at a time (RandomForce.force): any stretch of time draws the blocks it needs."""


def ambient_forces(rig: Rig, rms: float, high: float, seed: int = 0) -> list[RandomForce]:
    """Ambient excitation of ``rig``: independent random forces (RandomForce, ``rms`` [N] each, to ``high`` [Hz])
    along x, y and z at every isolator's point on the body, the ground's vibration as it reaches the machine
    through each isolator; every mode is excited, none is recorded. Seeds (seed, isolator, axis)."""
    points = rig.machine.isolator_points(rig.parameters).T
    axes = np.eye(3)
    return [
        RandomForce(tuple(map(float, p)), tuple(map(float, axes[a])), rms, high, seed * 1000 + 3 * i + a)
        for i, p in enumerate(points)
        for a in range(3)
    ]


@dataclass(frozen=True)
class Unbalance:
    """A rotating unbalance: mass ``mass`` [kg] at eccentricity ``eccentricity`` [m] turning at ``speed``
    [rad/s] about an axis through ``point`` [m] along ``axis`` (default vertical). The force
    m_v e w^2 rotates in the plane normal to the axis; for the vertical axis it is Eqs. (29)-(30):
    F_x = m_v e w^2 sin(w t), F_y = m_v e w^2 cos(w t)."""

    mass: float
    eccentricity: float
    speed: float
    point: tuple[float, float, float] = (0.0, 0.0, 0.0)
    axis: tuple[float, float, float] = (0.0, 0.0, 1.0)

    def plane(self) -> tuple[NDArray, NDArray]:
        """Unit vectors (e_s, e_c) of the force plane: F = F0 (e_s sin wt + e_c cos wt)."""
        a = unit_vector(self.axis, "unbalance.axis")
        e_s = np.cross([0.0, 1.0, 0.0], a) if abs(a[1]) < 0.9 else np.cross(a, [0.0, 0.0, 1.0])
        e_s /= np.linalg.norm(e_s)
        return e_s, np.cross(a, e_s)

    @property
    def amplitude(self) -> float:
        """Force amplitude m_v e w^2 [N]."""
        return self.mass * self.eccentricity * self.speed**2


@dataclass(frozen=True)
class Hardening:
    """Hardening isolators: along each of the isolators' local axes a restoring force
    k x (1 + (4/3) gamma (x / reference)^2) at the deformation x [m] of that direction, of which the linear part
    k x is in the rig's stiffness matrix. Harmonic balance at an amplitude A makes it a stiffness
    k (1 + gamma (A / reference)^2): ``gamma`` is the relative stiffening at the ``reference`` amplitude [m]
    (the blind harness's law of a hardening isolator, mountid.validation.blind_truth). ``deformation``: the rows
    d x / d q of every isolator direction (one row per isolator and local axis, [m per coordinate]);
    ``stiffness``: k of each row [N/m]."""

    deformation: NDArray
    stiffness: NDArray
    gamma: float
    reference: float

    def __post_init__(self) -> None:
        if not (math.isfinite(self.gamma) and self.gamma >= 0):
            raise InputError("gamma", f"must be a finite number >= 0, got {self.gamma}")
        if not (math.isfinite(self.reference) and self.reference > 0):
            raise InputError("reference", f"must be a positive deformation [m], got {self.reference}")
        if np.shape(self.stiffness) != np.shape(self.deformation)[:1]:
            raise InputError(
                "stiffness", f"needs one value per row of the deformation, {np.shape(self.deformation)[0]}"
            )

    def force(self, q: NDArray) -> NDArray[np.float64]:
        """The generalised restoring force beyond C q [N, N m] at the coordinates q (the last axis)."""
        x = q @ self.deformation.T
        return (self.stiffness * (4.0 / 3.0) * self.gamma * x**3 / self.reference**2) @ self.deformation


@dataclass
class Rig:
    """A machine on its isolators with every parameter fixed: the truth a simulated experiment is made of."""

    machine: Machine
    parameters: dict[str, float] = field(default_factory=dict)
    given: tuple[NDArray, NDArray, NDArray] | None = field(default=None, compare=False, repr=False)
    """M, C, B of a truth the description does not hold (:meth:`from_matrices`); None: the description's."""
    hardening: Hardening | None = field(default=None, compare=False, repr=False)
    """Hardening isolators (their force beyond C q); None: a linear rig. Only :meth:`simulate` feels them: the
    frequency-domain solutions are the linear rig's (its small-amplitude limit)."""

    def __post_init__(self) -> None:
        mod: types.ModuleType = self.machine.module
        args = mod.ARGUMENTS
        names = sorted({a for f in ("mass_matrix", "stiffness_matrix", "damping_matrix") for a in args[f]})
        self.values = self.machine.values(self.parameters, tuple(names))
        if self.given is None:
            self.M, self.C, self.B = matrices(mod, self.values)
        else:
            self.M, self.C, self.B = (np.array(x, dtype=float) for x in self.given)
        if self.hardening is not None and np.shape(self.hardening.deformation)[1:] != self.M.shape[:1]:
            raise InputError(
                "hardening",
                f"its deformation rows need one column per coordinate ({self.M.shape[0]}), got "
                f"{np.shape(self.hardening.deformation)[1:]}",
            )
        self.A = state_matrix(self.M, self.C, self.B)
        self.poles, self.V = scipy.linalg.eig(self.A)
        self.V_inv = np.linalg.inv(self.V)
        self._minv = np.linalg.inv(self.M)

    @classmethod
    def of(cls, machine: str | Machine, parameters: dict[str, float] | None = None) -> Rig:
        return cls(machine if isinstance(machine, Machine) else Machine.resolve(machine), dict(parameters or {}))

    @classmethod
    def from_matrices(
        cls,
        machine: str | Machine,
        mass: NDArray,
        stiffness: NDArray,
        damping: NDArray,
        hardening: Hardening | None = None,
    ) -> Rig:
        """A rig of a truth given by its own M, C, B (and hardening isolators, if any): the body's six
        coordinates q of ``machine`` first (the sensors and hammers act on them), then any the truth adds (a
        support below the isolators, an attached body), which no sensor reads. The blind harness's truths as
        records (mountid.validation.blind_records)."""
        found = machine if isinstance(machine, Machine) else Machine.resolve(machine)
        return cls(found, {}, (mass, stiffness, damping), hardening)

    def slowest_decay(self) -> float:
        """[s] The time constant of the rig's slowest decaying pole, 1 / min(-Re p) over the damped ones (inf where
        none decays): what a shaker test must wait out (frf.shaker_lengths)."""
        decaying = -self.poles.real[self.poles.real < 0]
        return 1.0 / float(decaying.min()) if len(decaying) else math.inf

    def lowest_frequency(self) -> float:
        """[rad/s] |p| of the rig's lowest pole (0 where a motion is free): what an output-only record must hold five
        periods of in its correlation functions (ambient.shortest_record)."""
        return float(np.min(np.abs(self.poles)))

    def mode_table(self, points: Sequence[Sequence[float]]) -> ModeTable:
        """The rig's complex modes (its state-space poles with Im p > 0, by |p|; the modes a truth's own coordinates
        add included) read as displacements along x, y and z at each of ``points`` [m], node k + 1 at the k-th
        (channels ``node<k>:<axis>``): what a bench's modal software would export of a noise-free test of the rig
        (uff_modes.write_table); each mode's phase puts its largest mass-weighted coordinate real and positive
        (runtime.eigen.with_real_positive_largest), not where the host's eigensolver left it."""
        n = self.M.shape[0]
        upper = np.flatnonzero(self.poles.imag > 0)
        order = upper[np.argsort(np.abs(self.poles[upper]), kind="stable")]
        channels = along_axes(points)
        rows = [self.sensor_row(c.point, c.direction, c.name) for c in channels]
        return ModeTable(
            channels,
            self.poles[order],
            np.array(rows) @ with_real_positive_largest(self.V[:n, order], self.M),
            "complex modes",
            (f"the complex modes of a rig of {self.machine.name}",),
        )

    # -- kinematics ---------------------------------------------------------------------------------
    def sensor_row(self, point: Sequence[float], direction: Sequence[float], name: str = "sensor") -> NDArray:
        """d^T du/dq: what a sensor at ``point`` along ``direction`` reads per unit of each coordinate (zero on
        the coordinates a truth adds beyond the body's)."""
        row = sensor_row(self.machine.module, point, direction, name)
        extra = self.M.shape[0] - len(row)
        return np.concatenate([row, np.zeros(extra)]) if extra else row

    def force_column(self, point: Sequence[float], direction: Sequence[float], name: str = "force") -> NDArray:
        """(du/dq)^T d: the generalised force [N, N m] of a unit force at ``point`` along ``direction``."""
        return self.sensor_row(point, direction, name)

    # -- frequency domain ---------------------------------------------------------------------------
    def frf(self, omega: NDArray) -> NDArray[np.complex128]:
        """Receptance H(w) = (C - w^2 M + i w B)^-1, shape (len(omega), 6, 6) [m/N, rad/N m, ...]."""
        w = np.asarray(omega, dtype=float)[:, None, None]
        return np.linalg.inv(self.C - w**2 * self.M + 1j * w * self.B)

    def steady_state(self, unbalance: Unbalance, t: NDArray) -> tuple[NDArray, NDArray]:
        """Steady-state (q, q'') at times t under a rotating unbalance, in closed form from the FRF."""
        e_s, e_c = unbalance.plane()
        col_s = self.force_column(unbalance.point, e_s)
        col_c = self.force_column(unbalance.point, e_c)
        w = unbalance.speed
        h = self.frf(np.array([w]))[0]
        # F0 (e_s sin wt + e_c cos wt) = Re(F0 (e_c - i e_s) e^{iwt})
        amp = h @ (unbalance.amplitude * (col_c - 1j * col_s))
        phase = np.exp(1j * w * np.asarray(t, dtype=float))[:, None]
        q = np.real(amp[None, :] * phase)
        return q, -(w**2) * q

    def beyond_small_motion(self, amplitude: NDArray) -> list[str]:
        """The coordinates whose steady-state ``amplitude`` (one per coordinate q [m, rad]) leaves the small motions
        the linear model describes: a rotation beyond SMALL_MOTION rad, a translation beyond SMALL_MOTION of the
        machine's length scale; each as "psi 2.44 rad" ([] where every motion is small)."""
        limits = [SMALL_MOTION * self.machine.length_scale(self.parameters)] * 3 + [SMALL_MOTION] * 3
        units = ["m"] * 3 + ["rad"] * 3
        coordinates = self.machine.module.COORDINATES
        return [
            f"{c} {a:.3g} {u}"
            for c, a, limit, u in zip(coordinates, amplitude, limits, units, strict=True)
            if a > limit
        ]

    def unbalance_force(self, unbalance: Unbalance, t: NDArray) -> NDArray[np.float64]:
        """Generalised force of the unbalance at times t, shape (len(t), n) (:meth:`forcing`)."""
        return self.forcing((), [unbalance])(np.asarray(t, dtype=float))

    # -- time domain --------------------------------------------------------------------------------
    def respond(self, t: NDArray, force: NDArray, x0: NDArray | None = None) -> tuple[NDArray, NDArray, NDArray]:
        """(q, q', q'') at the uniformly spaced times t for the generalised force (len(t), 6), linear
        between samples, from the state x0 = [q; q'] at t[0] (rest by default).

        Each complex mode z' = p z + g(t) is advanced exactly for piecewise-linear g:
        z[k+1] = e^{ph} z[k] + a0 g[k] + a1 g[k+1], a1 = (e^{ph} - 1 - ph) / (p^2 h), a0 = (e^{ph} - 1)/p - a1.
        """
        t = np.asarray(t, dtype=float)
        h = t[1] - t[0]
        n = self.M.shape[0]
        u = np.zeros((len(t), 2 * n))
        u[:, n:] = force @ self._minv.T
        g = u @ self.V_inv.T  # (len(t), 2n)
        p = self.poles
        em1 = np.expm1(p * h)
        a1 = (em1 - p * h) / (p**2 * h)
        a0 = em1 / p - a1
        z0 = self.V_inv @ (np.zeros(2 * n) if x0 is None else np.asarray(x0, dtype=float))
        z = np.empty((len(t), 2 * n), dtype=complex)
        z[0] = z0
        for k in range(2 * n):
            b, a = [a1[k], a0[k]], [1.0, -(em1[k] + 1.0)]
            # lfilter's y[j] = a1 g[j] + a0 g[j-1] + e^{ph} y[j-1], started from y[-1] = z0, x[-1] = g[0]
            zi = scipy.signal.lfiltic(b, a, [z0[k]], [g[0, k]])
            z[1:, k] = scipy.signal.lfilter(b, a, g[1:, k], zi=zi)[0]
        x = np.real(z @ self.V.T)
        q, qd = x[:, :n], x[:, n:]
        qdd = (force - qd @ self.B.T - q @ self.C.T) @ self._minv.T
        return q, qd, qdd

    def forcing(
        self, hammers: Sequence[Hammer | Shaker | RandomForce] = (), unbalances: Sequence[Unbalance] = ()
    ) -> Callable[[NDArray], NDArray[np.float64]]:
        """The generalised force [N, N m] of the hammers (or shakers, random forces) and unbalances as a function of
        the times t [s], shape (len(t), n): each one's force column taken once."""
        hits = [(h, self.force_column(h.point, h.direction, "hammer")) for h in hammers]
        turning = [
            (u, *(u.amplitude * self.force_column(u.point, e, "unbalance") for e in u.plane())) for u in unbalances
        ]
        n = self.M.shape[0]

        def force(t: NDArray) -> NDArray[np.float64]:
            out = np.zeros((len(t), n))
            for hammer, column in hits:
                out += np.outer(hammer.force(t), column)
            for u, sine, cosine in turning:
                out += np.outer(np.sin(u.speed * t), sine) + np.outer(np.cos(u.speed * t), cosine)
            return out

        return force

    def respond_hardening(
        self,
        t: NDArray,
        hammers: Sequence[Hammer] = (),
        unbalances: Sequence[Unbalance] = (),
        x0: NDArray | None = None,
    ) -> tuple[NDArray, NDArray, NDArray]:
        """(q, q', q'') at the times t under the hammers' and unbalances' forces with the hardening isolators', from
        the state x0 = [q; q'] at t[0] (rest by default): M q'' + B q' + C q + f(q) = Q(t) integrated by DOP853 at a
        relative tolerance of 1e-10, in steps no longer than an eighth of a pulse while a hammer pulse lasts
        (the integration is split at each pulse's start and end)."""
        if self.hardening is None:
            raise ValueError("respond_hardening needs a rig with hardening isolators")
        t = np.asarray(t, dtype=float)
        n = self.M.shape[0]
        hardening, minv, b, c = self.hardening, self._minv, self.B, self.C
        forcing = self.forcing(hammers, unbalances)

        def rate(time: float, x: NDArray) -> NDArray:
            q, qd = x[:n], x[n:]
            force = forcing(np.array([time]))[0]
            return np.concatenate([qd, minv @ (force - b @ qd - c @ q - hardening.force(q))])

        pulses = [
            (start, start + h.duration)
            for h in hammers
            for start in (h.time, *((h.time + h.second_hit[0],) if h.second_hit else ()))
        ]
        cuts = sorted({t[0], t[-1], *(x for p in pulses for x in p if t[0] < x < t[-1])})
        scale = self.hardening.reference * np.concatenate([np.ones(n), np.full(n, np.max(np.abs(self.poles)))])
        x = np.zeros(2 * n) if x0 is None else np.asarray(x0, dtype=float)
        out = np.empty((len(t), 2 * n))
        out[0] = x
        for a, z in itertools.pairwise(cuts):
            step = min(h.duration for h in hammers) / 8 if any(s < z and e > a for s, e in pulses) else np.inf
            take = (t > a) & (t <= z)
            wanted = np.concatenate([t[take], [z]]) if not take.any() or t[take][-1] < z else t[take]
            solution = scipy.integrate.solve_ivp(
                rate, (a, z), x, method="DOP853", t_eval=wanted, rtol=1e-10, atol=1e-10 * scale, max_step=step
            )
            if not solution.success:
                raise RuntimeError(f"the hardening rig's integration failed near t = {solution.t[-1]:g} s")
            out[take] = solution.y.T[: int(take.sum())]
            x = solution.y[:, -1]
        q, qd = out[:, :n], out[:, n:]
        qdd = (forcing(t) - qd @ self.B.T - q @ self.C.T - hardening.force(q)) @ self._minv.T
        return q, qd, qdd

    def simulate(
        self,
        sensors: Sequence[Sensor],
        duration: float,
        rate: float,
        hammers: Sequence[Hammer] = (),
        unbalances: Sequence[Unbalance] = (),
        oversample: int = 8,
        anti_alias: bool = True,
        seed: int | None = 0,
        force_channel: str | Sequence[str] | None = None,
        shakers: Sequence[Shaker] = (),
        ambient: Sequence[RandomForce] = (),
    ) -> Record:
        """A record of the sensors (each in its quantity and unit) sampled at ``rate`` [Hz] for ``duration``
        [s]; with ``force_channel`` a last channel of that name records the hammers' and shakers' force [N] (the
        excitation, through the same anti-alias filter, without noise); several names, one per shaker (no hammers),
        record each shaker's force on its own (a MIMO test). The ``ambient`` random forces act as well and are never
        recorded (ambient_forces: an output-only test).

        The response is computed at ``oversample`` x the rate, or more where that leaves fewer than
        RESOLVED samples per hammer pulse or per period of the fastest mode or unbalance (the physics does not
        depend on how the record is sampled: at 30 Hz x 8 a 4 ms pulse fell between the samples and the record
        was silent), passed through an 8th-order Butterworth anti-alias filter at ANTI_ALIAS x rate (the analog
        filter of a real acquisition), and decimated; then noise, bias and clipping are applied per sensor. A rig
        with hardening isolators is integrated through their law (:meth:`respond_hardening`), else exactly
        (:meth:`respond`).
        """
        if not duration > 0:
            raise InputError("duration", f"must be positive, got {duration}")
        if not rate > 0:
            raise InputError("rate", f"must be positive, got {rate}")
        if shakers and self.hardening is not None:
            raise InputError("shakers", "a shaker on hardening isolators is not simulated (hammers and unbalances are)")
        if ambient and self.hardening is not None:
            raise InputError(
                "ambient", "random forces on hardening isolators are not simulated (hammers and unbalances are)"
            )
        names = [force_channel] if isinstance(force_channel, str) else list(force_channel or [])
        # what each force channel records: the hammers' and shakers' force together, or each shaker's on its own
        pushing: list[list[Hammer | Shaker]] = (
            [] if not names else [[*hammers, *shakers]] if len(names) == 1 else [[s] for s in shakers]
        )
        if len(names) > 1 and (hammers or len(names) != len(shakers) or len(set(names)) != len(names)):
            raise InputError(
                "force_channel",
                f"{len(names)} names: one per shaker ({len(shakers)}, no hammers), each its own, or one for them all",
            )
        fastest = [float(np.max(np.abs(self.poles))) / (2 * np.pi), *(u.speed / (2 * np.pi) for u in unbalances)]
        fastest += [shaker.high for shaker in shakers] + [f.high for f in ambient]
        needed = [RESOLVED / (h.duration * rate) for h in hammers] + [RESOLVED * f / rate for f in fastest]
        oversample = max(oversample, math.ceil(max(needed)))
        n_out = int(round(duration * rate))
        if n_out < MIN_SAMPLES:
            raise InputError(
                "duration", f"{duration:g} s at {rate:g} Hz is {n_out} samples; a record needs at least {MIN_SAMPLES}"
            )
        fine_rate = rate * oversample
        rows = np.array([self.sensor_row(s.point, s.direction, s.name) for s in sensors])
        per_unit = np.array([UNITS[s.quantity][s.unit] for s in sensors])
        filtering = anti_alias and oversample > 1
        sos = scipy.signal.butter(8, ANTI_ALIAS * rate, fs=fine_rate, output="sos") if filtering else None
        n_fine = n_out * oversample
        forcing = self.forcing([*hammers, *shakers, *ambient], unbalances)
        state, filtered, blocks = None, None, []
        # the fine grid in blocks of BLOCK samples (memory), each from the state at the last one before it
        for start in range(0, n_fine, BLOCK):
            first = max(start - 1, 0)
            t = np.arange(first, min(start + BLOCK, n_fine)) / fine_rate
            if self.hardening is None:
                q, qd, qdd = self.respond(t, forcing(t), state)
            else:
                q, qd, qdd = self.respond_hardening(t, hammers, unbalances, state)
            state = np.concatenate([q[-1], qd[-1]])
            new = slice(start - first, None)  # the first sample of a later block is the last of the one before
            motion = {"displacement": q[new], "velocity": qd[new], "acceleration": qdd[new]}
            block = np.column_stack([motion[s.quantity] @ row for s, row in zip(sensors, rows, strict=True)])
            block = block / per_unit
            for acting in pushing:
                block = np.column_stack([block, sum((h.force(t[new]) for h in acting), np.zeros_like(t[new]))])
            if sos is not None:
                if filtered is None:
                    filtered = np.zeros((sos.shape[0], 2, block.shape[1]))
                block, filtered = scipy.signal.sosfilt(sos, block, axis=0, zi=filtered)
            blocks.append(block[(-start) % oversample :: oversample])
        clean = np.concatenate(blocks)
        rng = np.random.default_rng(seed)
        data = np.empty_like(clean)
        channels = []
        for j, s in enumerate(sensors):
            rms = np.sqrt(np.mean(clean[:, j] ** 2))
            y = clean[:, j] + s.bias + s.noise * rms * rng.standard_normal(len(clean))
            if s.clip is not None:
                y = np.clip(y, -s.clip, s.clip)
            data[:, j] = y
            channels.append(
                Channel(
                    s.name,
                    tuple(map(float, s.point)),
                    tuple(map(float, unit_vector(s.direction, s.name))),
                    s.quantity,
                    s.unit,
                )
            )
        for j, name in enumerate(names, start=len(sensors)):
            data[:, j] = clean[:, j]
            channels.append(Channel(name, quantity="force", unit="N"))
        return Record(np.arange(n_out) / rate, data, tuple(channels))
