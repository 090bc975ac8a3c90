"""Test planning before the test: what a proposed sensor layout, hit and record length will measure.

For a machine at its nominal (or given) values, a set of sensors (points, directions), one hammer hit and a
record length and rate:

1. which modes the layout cannot observe (every channel reads less than OBSERVABLE of the mode's largest
   motion at the sensors' points), which the hit does not excite (its generalised force on the mode is
   less than OBSERVABLE of the largest) and which lie above the record's band (the acquisition's anti-alias
   corner, rig.ANTI_ALIAS x the rate);
2. the standard deviation of each observable distinct frequency and damping ratio: the Cramer-Rao bound of
   the records chain's own pole fit (mountid.measurement.modal.fisher_pole_covariance) on the noise-free
   response the rig simulates, with the channels' white noise (``noise`` times each channel's RMS, the rig's
   convention) through the chain's decimation;
3. the standard deviation of each unknown stiffness: the records chain's stiffness fit
   (from_records.fit_stiffness) on those frequencies with those standard deviations;
4. a ranked proposal of sensor positions: effective independence (Kammer, 1991) over candidate channels
   (the given sensors' points and the isolator points, in x, y and z) for the six modes.

An output-only test (ambient or operational excitation, no force measured: plan_output_only) has no bound of the
kind of 2: the errors of correlation functions run from lag to lag, and which modes a record gives (a weak one is
found in some records, not in others) is itself uncertain. Its plan simulates records of the test (the rig under
the ground's random forces at the isolators) and runs the records chain on each: per mode how many records found
it and the median of their stated deviations (the jackknife's, calibrated against the truth in docs/validation.md).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from mountid.errors import InputError
from mountid.identification.from_records import fit_stiffness, frequency_std, pole_frequency_derivatives
from mountid.identification.shapes import no_shapes_note
from mountid.identification.statistics import covariance, standard_deviations
from mountid.machine import Machine, call, sensor_row
from mountid.measurement import ambient, frf, modal
from mountid.measurement.rig import ANTI_ALIAS, Hammer, Rig, Sensor
from mountid.measurement.settings import RECORDS
from mountid.nomenclature import counted

OBSERVABLE = 1e-3
"""A mode is unseen by a layout (not excited by a hit) below this share of its largest reading (force)."""


@dataclass(frozen=True)
class ModePlan:
    """One mode of the plan: its natural frequency [rad/s] and damping ratio, whether the layout sees it, the
    hit excites it and the record's band holds it, and the standard deviations the test will state (nan where
    it will not measure it)."""

    label: str
    frequency: float
    damping_ratio: float
    seen: bool
    excited: bool
    frequency_std: float = math.nan
    damping_std: float = math.nan
    pole_of: str = ""
    """The label whose pole this mode shares (its twin of equal frequency; itself otherwise): the record
    shows one pole for both."""
    in_band: bool = True
    """Whether the mode lies below the acquisition's anti-alias corner (rig.ANTI_ALIAS x the rate): above it
    the filter takes it out of the record, and beyond half the rate it would alias."""
    found: tuple[int, int] = ()
    """Of an output-only plan: how many of its simulated records found the mode, of how many (() for a hit's)."""
    steady: bool = False
    """Whether the mode's damping ratio lies within RECORDS.steady_damping of zero: the records chain takes its
    pole for a steady oscillation (a running machine), not a mode, and will not give it (steady_modes)."""

    @property
    def measured(self) -> bool:
        """Whether the test will measure the mode: seen, excited and in the band, damped beyond a steady
        oscillation, and in an output-only plan found by half its simulated records or more."""
        found = not self.found or 2 * self.found[0] >= self.found[1]
        return self.seen and self.excited and self.in_band and not self.steady and found


@dataclass(frozen=True)
class Plan:
    """What the planned test will measure (see the module docstring)."""

    machine: str
    modes: list[ModePlan]
    parameter_std: dict[str, float]
    ranking: list[tuple[str, float]]
    """Candidate channels, most informative first, with their effective-independence value (1: the channel
    alone fixes a mode direction; 0: it adds nothing the others do not)."""
    notes: list[str] = field(default_factory=list)

    @property
    def unseen(self) -> list[str]:
        return [m.label for m in self.modes if not m.seen]

    @property
    def not_excited(self) -> list[str]:
        return [m.label for m in self.modes if m.seen and not m.excited]

    @property
    def above_band(self) -> list[str]:
        return [m.label for m in self.modes if m.seen and m.excited and not m.in_band]

    def to_dict(self) -> dict:
        return {
            "machine": self.machine,
            "modes": [vars(m) | {"measured": m.measured} for m in self.modes],
            "unseen": self.unseen,
            "not_excited": self.not_excited,
            "above_band": self.above_band,
            "parameter_std": self.parameter_std,
            "ranking": [{"channel": c, "effective_independence": v} for c, v in self.ranking],
            "notes": self.notes,
        }


def plan(
    machine: Machine,
    sensors: list[Sensor],
    hammer: Hammer,
    duration: float,
    rate: float,
    noise: float,
    values: dict[str, float] | None = None,
    start: float | None = None,
) -> Plan:
    """The plan of one impact test (see the module docstring); ``values`` override the description's nominal
    ones, ``noise`` is each channel's white-noise std relative to its RMS, ``start`` the start of the free
    decay [s] (default: 20 ms after the hit ends)."""
    rig = Rig.of(machine, values)
    mod = machine.module
    phi, label_pole, seen, in_band = _layout(rig, sensors, rate)
    force = np.abs(phi.T @ rig.force_column(hammer.point, hammer.direction))
    excited = force >= OBSERVABLE * max(force.max(), 1e-300)

    # the record shows one pole per distinct frequency (twins are one exponential): the measured labels
    steady = steady_modes(rig)
    measured = [lab for i, lab in enumerate(mod.MODES) if seen[i] and excited[i] and in_band[i] and lab not in steady]
    distinct: dict[str, complex] = {}
    for lab in measured:
        rep = mod.REPRESENTATIVE[lab]
        distinct.setdefault(rep, label_pole[lab])

    clean = rig.simulate([Sensor(s.name, s.point, s.direction) for s in sensors], duration, rate, [hammer])
    begin = hammer.time + hammer.duration + 0.02 if start is None else start
    top = float(np.max(np.abs(rig.poles)))
    dt, samples = modal.decimated(clean, begin, 2.0 * top)
    if len(samples) < 8:
        raise InputError("duration", f"{duration:g} s leaves no free decay after {begin:g} s")
    rms = np.sqrt(np.mean(clean.data**2, axis=0))
    # white noise of std noise * rms per sample at ``rate``: through the decimating low-pass its variance
    # per retained sample falls by the decimation factor
    variance = (noise * rms) ** 2 / max(1.0, round(dt * rate))
    reps = list(distinct)
    chosen = np.array([distinct[r] for r in reps])
    cov = modal.fisher_pole_covariance(samples, dt, chosen, variance) if len(reps) else np.zeros((0, 0))
    stds = dict(zip(reps, modal.pole_standard_deviations(chosen, cov), strict=True))
    modes = []
    for i, lab in enumerate(mod.MODES):
        p = label_pole[lab]
        w_std, z_std = stds.get(mod.REPRESENTATIVE[lab], (math.nan, math.nan)) if lab in measured else (math.nan,) * 2
        modes.append(
            ModePlan(
                lab,
                float(abs(p)),
                float(-p.real / abs(p)),
                bool(seen[i]),
                bool(excited[i]),
                w_std,
                z_std,
                mod.REPRESENTATIVE[lab],
                bool(in_band[i]),
                steady=lab in steady,
            )
        )

    notes = [note] if (note := steady_note(rig, steady)) else []
    parameter_std = _stiffness_spread(rig, {r: (float(abs(distinct[r])), stds[r][0]) for r in reps}, notes)
    notes += _shapes(rig, sensors)
    slowest = rig.slowest_decay()
    if math.isfinite(slowest):
        need = frf.shaker_lengths(slowest)
        notes.append(
            f"a shaker test instead (the slowest decay's time constant {slowest:.3g} s): periodic random settles in "
            f"{need['settle']:.3g} s, averaged over two periods or more after it; burst random needs "
            f"{need['quiet']:.2g} s of quiet after each burst; a random force a record of {need['random']:.3g} s or "
            "more"
        )
    lowest = rig.lowest_frequency()
    if lowest > 0:
        notes.append(
            f"an output-only test instead (ambient or operational excitation, no force measured): a record of "
            f"{ambient.shortest_record(lowest, RECORDS.min_periods):.4g} s or more ({ambient.SEGMENTS} segments, "
            f"each {1 / ambient.LAG_SHARE:g} times {RECORDS.min_periods:g} periods of the lowest mode); its modes' "
            "uncertainty shrinks as the square root of the record's length"
        )
    return Plan(machine.name, modes, parameter_std, effective_independence(rig, sensors, phi), notes)


def plan_output_only(
    machine: Machine,
    sensors: list[Sensor],
    duration: float,
    rate: float,
    level: float,
    draws: int = 4,
    values: dict[str, float] | None = None,
) -> Plan:
    """The plan of an output-only test (see the module docstring): ``draws`` records of ``duration`` [s] at ``rate``
    [Hz] simulated with the ``sensors`` (their noise) under random forces of ``level`` [N] RMS along x, y and z at
    every isolator, white to rig.ANTI_ALIAS x the rate (rig.ambient_forces, seeds 0, 1, ...), each through the
    records chain (combination.decays_of: every response channel as the reference). Per mode the records that
    found it and the median of their stated standard deviations; the stiffnesses' from the modes found in half the
    records or more, at those deviations. ``values`` override the description's nominal ones."""
    from mountid.errors import NoModeFound
    from mountid.identification.combination import decays_of
    from mountid.measurement.rig import ambient_forces

    rig = Rig.of(machine, values)
    mod = machine.module
    lowest = rig.lowest_frequency()
    needed = ambient.shortest_record(lowest, RECORDS.min_periods, rate=rate) if lowest > 0 else 0.0
    if duration < needed:
        raise InputError(
            "duration", f"{duration:g} s: the records chain reads an output-only record of {needed:.4g} s or more"
        )
    known = {k: v for k, v in rig.values.items() if k not in machine.unknown}
    found: dict[str, list[tuple[float, float]]] = {}
    notes = []
    steady = steady_modes(rig)
    simulated = 0 if len(steady) == len(mod.MODES) else draws  # no record of such a rig would give a mode
    for seed in range(simulated):
        forces = ambient_forces(rig, level, ANTI_ALIAS * rate, seed)
        record = rig.simulate(sensors, duration, rate, ambient=forces, seed=seed + 100)
        try:
            data = decays_of(machine, record, known, f"record {seed + 1}")[0][0][1]
        except (NoModeFound, InputError) as err:
            notes.append(f"simulated record {seed + 1}: no mode ({err})")
            continue
        for label, mode in data.modes.items():
            found.setdefault(label, []).append((mode.frequency_std, mode.damping_std))
    phi, label_pole, seen, in_band = _layout(rig, sensors, rate)
    notes += [note] if (note := steady_note(rig, steady)) else []
    modes, frequencies = [], {}
    for i, label in enumerate(mod.MODES):
        p = label_pole[label]
        rep = mod.REPRESENTATIVE[label]
        if label not in found:  # twins: the record shows one pole for both, labelled as one of them
            found[label] = [v for other in mod.MODES if mod.REPRESENTATIVE[other] == rep for v in found.get(other, [])]
        stds = np.median(np.array(found[label]), axis=0) if found[label] else (math.nan, math.nan)
        modes.append(
            ModePlan(
                label,
                float(abs(p)),
                float(-p.real / abs(p)),
                bool(seen[i]),
                True,  # the random forces at every isolator along every axis drive every mode
                float(stds[0]),
                float(stds[1]),
                rep,
                bool(in_band[i]),
                found=(len(found[label]), simulated),
                steady=label in steady,
            )
        )
        if found[label] and 2 * len(found[label]) >= simulated and rep not in frequencies:
            frequencies[rep] = (float(abs(p)), float(stds[0]))
    parameter_std = _stiffness_spread(rig, frequencies, notes)
    notes += _shapes(rig, sensors)
    notes.insert(
        0,
        f"simulated: {counted(draws, 'record')} of {duration:g} s at {rate:g} Hz under random forces of {level:g} N "
        f"RMS along x, y and z at every isolator (white to {ANTI_ALIAS * rate:g} Hz), each through the records chain; "
        "per mode the median of the deviations the records that found it state (the jackknife's); the stiffnesses' "
        "from the modes found in half the records or more"
        if simulated
        else "no record simulated: every mode is a steady oscillation to the records chain (the note below)",
    )
    return Plan(machine.name, modes, parameter_std, effective_independence(rig, sensors, phi), notes)


def _shapes(rig: Rig, sensors: list[Sensor]) -> list[str]:
    """The plan's note where the ``sensors`` will give no mode shapes: the rigid-body motion they do not see
    (shapes.no_shapes_note, the records chain's note on such a record)."""
    rows = np.array([sensor_row(rig.machine.module, s.point, s.direction, s.name) for s in sensors])
    note = no_shapes_note(rows, rig.machine.length_scale(rig.values))
    return [note] if note else []


def _layout(
    rig: Rig, sensors: list[Sensor], rate: float
) -> tuple[np.ndarray, dict[str, complex], np.ndarray, np.ndarray]:
    """The rig's modal matrix (6, modes; in the order of MODES), each mode's pole (Im p > 0: the rig's nearest its
    undamped frequency), which modes the ``sensors`` see (each reads OBSERVABLE of a mode's largest motion or more)
    and which lie below the anti-alias corner of a record at ``rate`` [Hz]."""
    mod = rig.machine.module
    fwd = {a: rig.values[a] for a in mod.FORWARD_ARGUMENTS}
    phi = np.asarray(mod.modal_matrix(**fwd))
    rows = np.array([rig.sensor_row(s.point, s.direction, s.name) for s in sensors])
    reading = np.abs(rows @ phi) / np.maximum(np.abs(phi).max(axis=0), 1e-300)
    seen = reading.max(axis=0) >= OBSERVABLE * max(reading.max(), 1e-300)
    omega = _undamped_frequencies(rig)
    return phi, labelled_poles(rig, omega), seen, omega / (2 * np.pi) < ANTI_ALIAS * rate


def _undamped_frequencies(rig: Rig) -> np.ndarray:
    """[rad/s] The undamped natural frequencies at the rig's values, in the order of MODES."""
    mod = rig.machine.module
    return np.sqrt(np.abs(np.asarray(mod.squared_frequencies(**{a: rig.values[a] for a in mod.FORWARD_ARGUMENTS}))))


def labelled_poles(rig: Rig, omega: np.ndarray | None = None) -> dict[str, complex]:
    """Each mode's pole (Im p > 0) [rad/s]: the rig's nearest its undamped natural frequency (``omega``, the rig's
    _undamped_frequencies where the caller has them)."""
    mod = rig.machine.module
    omega = _undamped_frequencies(rig) if omega is None else omega
    poles = rig.poles[rig.poles.imag > 0]
    return {
        label: complex(poles[np.argmin(np.abs(np.abs(poles) - w))]) for label, w in zip(mod.MODES, omega, strict=True)
    }


def steady_modes(rig: Rig) -> list[str]:
    """The modes whose damping ratio at the rig's values lies within RECORDS.steady_damping of zero: the records
    chain takes such a pole for a steady oscillation (a running machine, mains hum), not a mode of a machine on
    rubber, and gives no mode for it (every mode of a description without damping)."""
    return [label for label, p in labelled_poles(rig).items() if -p.real < RECORDS.steady_damping * abs(p)]


def steady_note(rig: Rig, steady: Sequence[str]) -> str:
    """What a test of the rig will not give because of its ``steady`` modes (steady_modes; '' where every mode
    decays)."""
    if not steady:
        return ""
    chain = f"the records chain takes a pole of damping ratio below {RECORDS.steady_damping:g} for a steady oscillation"
    if not rig.B.any():
        return (
            f"{rig.machine.name} has no damping: its modes do not decay, and {chain} (a running machine), not a mode: "
            "a record gives none of them; describe the isolators' damping"
        )
    one = len(steady) == 1
    which = "every mode" if len(steady) == len(rig.machine.modes) else ", ".join(steady)
    return (
        f"{rig.machine.name} damps {which} hardly at all: {chain} (a running machine), not a mode, and a record "
        f"will not give {'it' if one else 'them'}"
    )


def _stiffness_spread(rig: Rig, frequencies: dict[str, tuple[float, float]], notes: list[str]) -> dict[str, float]:
    """Each unknown's standard deviation from the records chain's stiffness fit (from_records.fit_stiffness, the
    description's root rule, the rig's damping) to the pole ``frequencies`` {label: (|p|, std)} [rad/s]; NaN with a
    note appended to ``notes`` where the fit cannot give it. Where the frequencies leave unknowns undetermined
    (Machine.undetermined_by) those are NaN and the others' come from _spread_beside."""
    machine = rig.machine
    known = {k: v for k, v in rig.values.items() if k not in machine.unknown}
    damping = {n: rig.values[n] for n in machine.damping}
    undetermined = machine.undetermined_by(frequencies)
    if undetermined:
        notes.append(
            f"no stiffness standard deviation of {', '.join(undetermined.unknowns)}: {undetermined.describe()}: "
            f"{undetermined.advice()}"
            + (
                f"; the others' standard deviations with {'it' if len(undetermined.unknowns) == 1 else 'them'} free"
                if len(undetermined.unknowns) < len(machine.unknown)
                else ""
            )
        )
        return _spread_beside(rig, frequencies, undetermined.unknowns)
    try:
        rule = getattr(machine.module, "ROOT_RULE", "") or None
        return fit_stiffness(machine, known, frequencies, damping=damping, root=rule)[1]
    except InputError as err:  # the plan says why it cannot give the stiffness spread
        notes.append(f"no stiffness standard deviation: {err}")
        return {u: math.nan for u in machine.unknown}


def _spread_beside(
    rig: Rig, frequencies: dict[str, tuple[float, float]], undetermined: tuple[str, ...]
) -> dict[str, float]:
    """The standard deviation of each unknown the pole ``frequencies`` {label: (|p|, std)} [rad/s] determine, with
    the ``undetermined`` ones free (NaN for those): the fit's linearised covariance at the rig's values
    (statistics.covariance, the pseudo-inverse of J^T J, J = d|p| / d ln unknown over std). Their null space lies
    within the undetermined unknowns, so each other unknown is a combination the data determine, and its
    variance is the same whichever way the null space is resolved (holding any of them at a value)."""
    machine = rig.machine
    labels = [lab for lab in machine.unique_modes if lab in frequencies]
    rows = [machine.module.MODES.index(lab) for lab in labels]
    std = frequency_std(frequencies, labels)
    values = np.array([rig.values[u] for u in machine.unknown])
    d_omega = pole_frequency_derivatives(machine, rig.values, machine.unknown)[:, rows]  # (unknowns, labels)
    spread = standard_deviations(covariance(d_omega.T * values[None, :] / std[:, None], 0.0, 0))
    return {u: math.nan if u in undetermined else float(values[i] * spread[i]) for i, u in enumerate(machine.unknown)}


def effective_independence(rig: Rig, sensors: list[Sensor], phi: np.ndarray) -> list[tuple[str, float]]:
    """Candidate channels (each given sensor's point and each isolator's point, along x, y and z) ranked by
    effective independence for the six modes: the candidate with the smallest E_i = diag(A (A^T A)^-1 A^T)
    is dropped in turn while more than six remain; the order of dropping, reversed, is the ranking (the
    last six kept first, by E_i), so that the first n of the list are the best n channels found."""
    iso = np.asarray(call(rig.machine.module, "isolator_points", rig.values))
    points = [tuple(map(float, s.point)) for s in sensors] + [tuple(map(float, iso[:, k])) for k in range(iso.shape[1])]
    unique = list(dict.fromkeys(points))
    candidates = [
        (f"({', '.join(f'{v:.3g}' for v in point)}) {axis}", rig.sensor_row(point, direction) @ phi)
        for point in unique
        for axis, direction in zip("xyz", np.eye(3), strict=True)
    ]
    names = [c for c, _ in candidates]
    a = np.array([row for _, row in candidates])
    keep = list(range(len(names)))
    dropped: list[tuple[str, float]] = []
    while len(keep) > phi.shape[1]:
        sub = a[keep]
        e = np.einsum("ij,jk,ik->i", sub, np.linalg.pinv(sub.T @ sub), sub)
        worst = int(np.argmin(e))
        dropped.append((names[keep[worst]], float(e[worst])))
        del keep[worst]
    sub = a[keep]
    e = np.einsum("ij,jk,ik->i", sub, np.linalg.pinv(sub.T @ sub), sub)
    kept = sorted(((names[k], float(v)) for k, v in zip(keep, e, strict=True)), key=lambda x: -x[1])
    return kept + dropped[::-1]
