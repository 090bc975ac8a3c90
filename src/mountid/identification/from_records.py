"""From an impact record to labelled modal data, isolator stiffnesses and damping (paper Sec. 4, any machine).

1. Poles of the free decay (mountid.measurement.modal.free_decay_poles).
2. Labels: each pole's channel shape against the channel shapes the model predicts for its modes at the
   nominal parameters (MAC); modes equal by symmetry share their distinct-frequency label.
3. Stiffnesses: every generated inverse over the measured distinct frequencies gives starting points; a
   weighted least-squares fit over all measured frequencies (weights from their spread) gives the unknowns
   and their standard deviations from the Jacobian of the generated forward map.
4. Damping: modal damping of a lightly damped mode is 2 zeta_k omega_k = phi_k^T B phi_k (first order), and
   B is linear in the isolator damping parameters: a linear least-squares fit over the measured ratios.
"""

from __future__ import annotations

import functools
import itertools
import math
import struct
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass, field, replace
from typing import NamedTuple

import numpy as np
import scipy.optimize

from mountid.errors import InputError, NoModeFound
from mountid.identification.combination import every_decay
from mountid.identification.labelling import LABELLING, LabellingSettings, assign
from mountid.identification.least_squares import trust_region
from mountid.identification.references import SAME_SHAPE
from mountid.identification.shapes import coordinate_shape, coordinate_shape_std
from mountid.identification.statistics import covariance, standard_deviations
from mountid.machine import (
    GeneratedModule,
    Machine,
    call,
    damped_pole_derivatives,
    damped_poles,
    matrices,
    pole_damping_ratios,
    ratio_derivatives,
    recently_used,
    sensor_row,
)
from mountid.measurement import ambient, frf, modal
from mountid.measurement.frf import FrfEstimate
from mountid.measurement.modes import (
    DEFAULT_DAMPING_STD,
    DEFAULT_FREQUENCY_STD,
    ChannelShape,
    MeasuredMode,
    default_damping_std,
)
from mountid.measurement.records import RESPONSE_ORDER, TABLE_HAS_NO, Lines, ModeTable, Record
from mountid.measurement.settings import RECORDS, RecordSettings
from mountid.nomenclature import counted, distinct_frequencies, root_rule, root_rule_problem


@dataclass(frozen=True)
class Identification:
    """Result of identify_from_record: modal data, unknowns with standard deviations, damping."""

    modes: dict[str, MeasuredMode]
    parameters: dict[str, float]
    parameter_std: dict[str, float]
    damping: dict[str, float] = field(default_factory=dict)
    damping_std: dict[str, float] = field(default_factory=dict)
    frequencies: dict[str, float] = field(default_factory=dict)
    """Every mode's natural frequency [rad/s] with the identified parameters."""
    unlabelled: list[modal.Pole] = field(default_factory=list)
    warnings: list[modal.QualityWarning] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    """How the identification decided what the data leave open (a root chosen by a rule), the hits, and where
    the modes came from."""
    frf: FrfEstimate | None = None
    """The H1 frequency responses the modes were fitted on (None: the free decay)."""
    start: float = modal.DEFAULT_START
    """[s] Where the free decay the modes were fitted on starts (ModalData.start)."""
    end: float | None = None
    """[s] Where it ends (ModalData.end)."""
    reference: str = ""
    """The response channel an output-only record's modes came from, most of them (ModalData.reference)."""
    inputs: tuple[FrfEstimate, ...] = ()
    """The frequency responses of every force of several shakers at once (ModalData.inputs)."""


def channel_rows(machine: Machine, record: Record | ModeTable) -> np.ndarray:
    """d^T du/dq of every channel, shape (n_channels, 6); channels must carry point and direction."""
    rows = []
    for c in record.channels:
        if not (np.all(np.isfinite(c.point)) and np.all(np.isfinite(c.direction))):
            raise InputError(
                c.name,
                "channel has no point and direction: needed to label modes (place it with --channel "
                f"{c.name}=x,y,z:dx,dy,dz, or a campaign record's 'channels')",
            )
        rows.append(sensor_row(machine.module, c.point, c.direction, c.name))
    return np.array(rows)


SENSOR_RATIO = 4.0
"""A channel is named as not moving with the rigid body when the other channels' rigid-body fit without it
leaves a residual variance per redundant equation at most 1/SENSOR_RATIO of the fit with it, and removing any
other single channel leaves at least SENSOR_RATIO times that (the culprit is the one whose removal makes the
rest consistent)."""


def inconsistent_channel(machine: Machine, record: Record, start: float = 0.0) -> modal.QualityWarning | None:
    """The one channel that does not move with the rigid body (turned, misplaced or mislabelled), or None.

    Needs 8 or more response channels whose rows span the six motions without any one of them: each channel
    is left out in turn and the others fitted as a rigid body over the free decay from ``start`` [s]; the
    residual variance per redundant equation tells which removal makes the rest consistent. A plain
    leave-one-out residual of each channel blames honest channels too (the turned one pulls the fit of the
    others); with 7 channels a misfit beyond SENSOR_RATIO times the channels' own noise is seen but cannot be
    placed, and is reported as such."""
    rows = channel_rows(machine, record)
    c = len(rows)
    if c < 7 or np.linalg.matrix_rank(rows) < 6:
        return None
    data = record.data[record.time >= start].T  # (channels, samples)

    def variance(keep: np.ndarray) -> float:
        fit = np.linalg.lstsq(rows[keep], data[keep], rcond=None)[0]
        dof = keep.sum() - 6
        return float(np.sum((data[keep] - rows[keep] @ fit) ** 2) / (dof * data.shape[1])) if dof > 0 else math.nan

    full = variance(np.ones(c, dtype=bool))
    if c == 7:
        # one redundant equation: every channel's standardised residual is the same, so the misfit is judged
        # against the channels' own noise (from the first difference late in the record) and not placed
        null = np.linalg.svd(rows.T)[2][-1]  # the combination of channels no rigid motion excites
        tail = np.diff(record.data[-max(len(record.data) // 4, 8) :], axis=0)
        noise = (np.median(np.abs(tail - np.median(tail, axis=0)), axis=0) * 1.4826 / math.sqrt(2)) ** 2
        misfit = float(np.mean((null @ data) ** 2))
        expected = float(np.sum(null**2 * noise))
        if expected > 0 and misfit > SENSOR_RATIO**2 * expected:
            return modal.QualityWarning(
                "sensor",
                "all",
                f"the 7 channels do not move as one rigid body (misfit {math.sqrt(misfit / expected):.0f}x their "
                "noise): one is turned, misplaced or mislabelled, and 7 channels cannot tell which (add an 8th)",
            )
        return None
    without = []
    for j in range(c):
        keep = np.arange(c) != j
        without.append(variance(keep) if np.linalg.matrix_rank(rows[keep]) == 6 else math.nan)
    v = np.array(without)
    if not np.any(np.isfinite(v)):
        return None
    best = float(np.nanmin(v))
    if not full >= SENSOR_RATIO * best:
        return None
    # every channel whose removal makes the rest about as consistent is a suspect: a layout whose redundant
    # equations do not separate them cannot tell which of them is wrong
    suspects = [record.channels[j].name for j in range(c) if np.isfinite(v[j]) and v[j] * SENSOR_RATIO < full]
    who = suspects[0] if len(suspects) == 1 else ", ".join(suspects[:-1]) + " or " + suspects[-1]
    what = "does" if len(suspects) == 1 else "one of these does"
    return modal.QualityWarning(
        "sensor",
        who,
        f"{what} not move with the rigid body the other channels agree on (their misfit falls "
        f"{math.sqrt(full / best):.1f}x without it): check its direction, position and label"
        + ("" if len(suspects) == 1 else "; the layout cannot tell which (add a channel that separates them)"),
        suspects=tuple(suspects),
    )


def generalised_accelerations(machine: Machine, record: Record) -> tuple[np.ndarray, dict[str, float]]:
    """Rigid-body accelerations q''(t) (n, 6) [m/s^2, rad/s^2] by least squares over all channels (>= 6 with
    independent rows), and each channel's leave-one-out residual: the RMS of the channel minus its prediction
    from the rigid-body fit to all other channels, relative to the channel's RMS. A channel that does not fit
    a rigid body (misplaced, misaligned or mislabelled sensor) stands out; the plain least-squares residual
    would spread its misfit over the other channels."""
    rows = channel_rows(machine, record)
    if len(rows) < 6 or np.linalg.matrix_rank(rows) < 6:
        raise InputError(
            "channels",
            f"{len(rows)} channels with rank {np.linalg.matrix_rank(rows)}: six independent directions needed "
            "(use paper_generalised() for the paper's three-channel layout)",
        )
    qdd = np.linalg.lstsq(rows, record.data.T, rcond=None)[0].T
    residual = {}
    for j, c in enumerate(record.channels):
        others = np.arange(len(rows)) != j
        if np.linalg.matrix_rank(rows[others]) < 6:
            residual[c.name] = float("nan")  # the channel is needed to fix a coordinate: no check possible
            continue
        fit = np.linalg.lstsq(rows[others], record.data[:, others].T, rcond=None)[0]
        miss = record.data[:, j] - rows[j] @ fit
        residual[c.name] = float(np.sqrt(np.mean(miss**2) / np.mean(record.data[:, j] ** 2)))
    return qdd, residual


def paper_generalised(record: Record, a_x: str, a_y: str, b_y: str, spacing: float) -> tuple[np.ndarray, np.ndarray]:
    """The paper's three-channel case (Eqs. 23-24): x'' = s_Ax and the rotation about x from two y-channels
    ``spacing`` [m] apart vertically (B above A). With right-handed rotations a point above the axis moves
    by -psi dz along y, so psi'' = (s_Ay - s_By) / L; Eq. (24) prints the opposite sign, which changes no
    frequency. Returns (x'', psi'')."""
    if not spacing > 0:
        raise InputError("spacing", f"must be positive, got {spacing}")
    return record.channel(a_x), (record.channel(a_y) - record.channel(b_y)) / spacing


def label_poles(
    machine: Machine,
    record: Record | ModeTable,
    poles: list[modal.Pole],
    nominal: dict[str, float],
    settings: LabellingSettings = LABELLING,
) -> tuple[dict[str, tuple[modal.Pole, float]], list[modal.Pole]]:
    """Distinct-frequency label of each pole: a one-to-one assignment of poles to the model's modes at the
    ``nominal`` parameters by :func:`mountid.identification.labelling.assign` (MAC of the channel shapes,
    ``settings.record_frequency_weight``). Modes the channels cannot see are left out. Of two poles on modes equal
    by symmetry (twins) the better one keeps the twins' label, unless they lie settings.twin_separation standard
    deviations apart or more: a machine whose symmetry is broken (kid300 with its centre of mass off the axis: x
    and y 0.12 rad/s apart) parts its twins, and the two take the twins' labels in the order of frequency (the
    lower x, the higher y: what a mode is called then says where it lies, not how it moves). A pole nearer another
    mode's nominal frequency than the twins' (_in_band) parts no twins: the other keeps their label. Returns
    ({label: (pole, MAC)}, poles left unlabelled): the MAC against the mode, or for a pole that keeps the twins'
    label, the share of its channel shape in their span (:func:`_span_mac`)."""
    if not poles:
        return {}, []
    mod = machine.module
    omega, predicted, seen = _channel_modes(machine, record, nominal)
    visible = np.flatnonzero(seen)
    macs = modal.mac_matrix(np.column_stack([p.shape for p in poles]), predicted[:, visible])
    ratio = np.log(np.array([p.frequency for p in poles])[:, None] / omega[visible][None, :])
    rows, cols, cost = assign(1.0 - macs, ratio, settings.record_frequency_weight)
    assigned = set(rows)
    rest = [p for i, p in enumerate(poles) if i not in assigned]
    on: dict[str, list[tuple[float, str, modal.Pole, float]]] = {}  # per twins' label: (cost, mode, pole, MAC)
    for i, j in zip(rows, cols, strict=True):
        mode = mod.MODES[visible[j]]
        on.setdefault(mod.REPRESENTATIVE[mode], []).append((float(cost[i, j]), mode, poles[i], float(macs[i, j])))
    out: dict[str, tuple[modal.Pole, float]] = {}
    for label, found in on.items():
        found.sort(key=lambda f: f[0])
        if len(found) == 2:
            twins = [m for m in mod.MODES if mod.REPRESENTATIVE[m] == label]
            own = [omega[k] for k in visible if mod.MODES[k] in twins]
            others = [omega[k] for k in visible if mod.MODES[k] not in twins]
            inside = [_in_band(f[2].frequency, own, others) for f in found]
            if all(inside) and _parted(found[0][2], found[1][2], settings):
                # named in the order of frequency, as every record of the machine names them (by shape, the
                # nominal model's twins would name a pair mixed at 45 degrees by the noise)
                parted = sorted(found, key=lambda f: f[2].frequency)
                out.update({mode: (pole, m) for mode, (_, _, pole, m) in zip(twins, parted, strict=False)})
                continue
            if inside[1] and not inside[0]:  # the pole nearer another mode is no twin, however well it costs
                found.reverse()
        # a pole that stands for twins lies in their span, in whatever mix the hit gave: its MAC is its share there
        # (against one twin alone the paper's x pole read 0.60 on a noise-free record)
        span = [k for k in visible if mod.REPRESENTATIVE[mod.MODES[k]] == label]
        mac = _span_mac(predicted[:, span], found[0][2].shape) if len(span) > 1 else found[0][3]
        out[label] = (found[0][2], mac)
        rest += [pole for _, _, pole, _ in found[1:]]
    for label in _strays(machine, omega, out):
        rest.append(out.pop(label)[0])
    return out, sorted(rest, key=lambda p: p.frequency)


def _strays(machine: Machine, omega: np.ndarray, labelled: dict[str, tuple[modal.Pole, float]]) -> list[str]:
    """The labels whose pole is a stray beside another labelled mode's pole: it lies nearer that mode's nominal
    frequency (``omega`` [rad/s], in the model's order) than its own label's, that mode's pole nearer still, within
    that pole's half-power half-width (zeta |p|), the two channel shapes alike (MAC references.SAME_SHAPE or more),
    and that pole fits its label's channel shape as well or better (the MAC of ``labelled``: of two alike poles of a
    heavily damped pair, screen6's theta at 47.28 rad/s, MAC 0.82, beside a pole labelled psi at 49.34, MAC 0.19,
    theta's is no stray). Where the channels hardly tell two modes apart the one-to-one assignment gives a pole of
    the estimate's noise beside a mode the label of a mode the record did not show (kid300's five channels,
    output-only, 1170 s, seed 26: a second pole beside psi's 65.44 rad/s, at 67.38, MAC 0.95 with it, was labelled
    z, whose nominal frequency is 47.5; a diagnosis of the nominal machine said "not explained")."""
    mod = machine.module
    rep = mod.REPRESENTATIVE

    def away(frequency: float, label: str) -> float:
        return abs(math.log(frequency / omega[mod.MODES.index(label)]))

    strays: list[str] = []
    for label, (pole, fits) in labelled.items():
        for other, (beside, fits_beside) in labelled.items():
            if rep[other] == rep[label] or other in strays:
                continue
            near = away(pole.frequency, other)
            if (
                fits_beside >= fits
                and near < away(pole.frequency, label)
                and away(beside.frequency, other) < near
                and abs(pole.frequency - beside.frequency) <= beside.damping_ratio * beside.frequency
                and modal.mac(pole.shape, beside.shape) >= SAME_SHAPE
            ):
                strays.append(label)
                break
    return strays


def _in_band(frequency: float, twins: list[float], others: list[float]) -> bool:
    """Whether ``frequency`` [rad/s] lies nearer the nominal frequency of the ``twins`` than that of any of the
    ``others`` (the nominal frequencies of the other modes the channels see), in log frequency as the labelling
    weighs it: a symmetry that an effect breaks parts the twins about their own frequency. A pole nearer another
    mode that the one-to-one assignment still put on the twins (kid300 blind seed 24, hardening isolators: a
    drifting decay's pole at 53.2 rad/s beside psi and theta at 64.6, nearer z and phi) is no twin. On a side
    with no other mode (above the highest twins, below the lowest) the band ends where it ends on the other side:
    the nearest other mode is mirrored about the twins (kid300axes blind seed 5 on a frame: a pole of the frame
    at 90.9 rad/s, 60 % above psi and theta, was named theta)."""
    if not others:
        return True
    f, own, near = math.log(frequency), [math.log(w) for w in twins], [math.log(w) for w in others]
    lo, hi = min(own), max(own)
    below, above = [w for w in near if w <= lo], [w for w in near if w >= hi]
    mirrored = list(near)
    if below and not above:
        mirrored.append(2 * hi - max(below))
    if above and not below:
        mirrored.append(2 * lo - min(above))
    return min(abs(f - w) for w in own) < min(abs(f - w) for w in mirrored)


def _parted(a: modal.Pole, b: modal.Pole, settings: LabellingSettings) -> bool:
    """Whether two poles' frequencies lie settings.twin_separation combined standard deviations apart or more."""
    return abs(a.frequency - b.frequency) >= settings.twin_separation * math.hypot(a.frequency_std, b.frequency_std)


def _channel_modes(
    machine: Machine, record: Record | ModeTable, nominal: dict[str, float]
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The model's modes at the ``nominal`` parameters as the record's channels see them: the frequencies
    [rad/s], what each channel reads in each mode (channels x modes), and whether the channels see each mode at
    all (its readings above 1e-6 of the most visible mode's)."""
    mod = machine.module
    args = machine.values(nominal, mod.FORWARD_ARGUMENTS)
    predicted = channel_rows(machine, record) @ mod.modal_matrix(**args)
    norms = np.linalg.norm(predicted, axis=0)
    return mod.frequencies(**args), predicted, norms > 1e-6 * norms.max()


@dataclass(frozen=True)
class MergedPole:
    """A record's pole in the place of two (or more) close modes of the model (:func:`unresolved`): the ``label``
    it was given, the ``partners`` without a pole of their own, the share of its channel shape the labelled mode
    explains (``alone``) and all of them together (``both``), their largest distance ``apart`` [rad/s] in the
    model and the pole's half-power bandwidth ``width`` [rad/s]."""

    label: str
    pole: modal.Pole
    partners: tuple[str, ...]
    alone: float
    both: float
    apart: float
    width: float

    def describe(self) -> str:
        names = " and ".join([self.label, *self.partners])
        return (
            f"{names}: one pole at {self.pole.frequency:.4g} rad/s (zeta {self.pole.damping_ratio:.3g}) in the span "
            f"of all (MAC {self.alone:.2f} with {self.label} alone, {self.both:.2f} with {names}); the model puts them "
            f"{self.apart:.3g} rad/s apart, within its half-power bandwidth of {self.width:.3g} rad/s"
        )


def unresolved(
    machine: Machine,
    record: Record | ModeTable,
    labelled: dict[str, tuple[modal.Pole, float]],
    nominal: dict[str, float],
    settings: LabellingSettings = LABELLING,
) -> tuple[dict[str, tuple[modal.Pole, float]], list[MergedPole]]:
    """The labelled poles (label_poles) without those that merge modes of the model: a model mode of another
    label that has no pole of its own, lies within the pole's half-power bandwidth 2 zeta |p| of the labelled one
    (at the ``nominal`` parameters) and adds settings.unresolved_share or more of the pole's channel shape to what
    the labelled mode (with its twins) explains. Such a pole's frequency lies between the modes and its shape is a
    mix of them (screen6's x and y, 0.12 rad/s apart at a damping ratio of 0.05, from pencils of 100 and 160
    columns: one pole, MAC 0.51 with x, 1.00 with x and y), a measurement of neither. Returns (the poles kept,
    the merged ones)."""
    mod = machine.module
    omega, predicted, seen = _channel_modes(machine, record, nominal)
    rep = [mod.REPRESENTATIVE[lab] for lab in mod.MODES]
    parted = {lab for lab in labelled if lab != mod.REPRESENTATIVE[lab]}  # a twin with a pole of its own
    parted |= {mod.REPRESENTATIVE[lab] for lab in parted}
    kept, merged = {}, []
    for label, (pole, mac) in labelled.items():
        own = [
            k for k in range(len(rep)) if seen[k] and (mod.MODES[k] == label if label in parted else rep[k] == label)
        ]
        at = float(np.mean(omega[own])) if own else math.nan
        width = 2 * pole.damping_ratio * pole.frequency
        partners = [
            k
            for k in range(len(rep))
            if rep[k] != label and rep[k] not in labelled and seen[k] and abs(omega[k] - at) < width
        ]
        alone = _span_mac(predicted[:, own], pole.shape)
        both = _span_mac(predicted[:, own + partners], pole.shape) if partners else alone
        if both - alone < settings.unresolved_share:  # no partner, or one that adds too little
            kept[label] = (pole, mac)
            continue
        names = tuple(sorted({rep[k] for k in partners}, key=lambda n: mod.UNIQUE_MODES.index(n)))
        merged.append(MergedPole(label, pole, names, alone, both, max(abs(omega[k] - at) for k in partners), width))
    return kept, merged


def _split_merged(
    machine: Machine,
    record: Record,
    source: tuple[Record, float, float],
    poles: list[modal.Pole],
    merged: list[MergedPole],
    nominal: dict[str, float],
) -> tuple[dict[str, tuple[modal.Pole, float]], list[modal.Pole]] | None:
    """The record's poles refined again (modal.poles_from on ``source``: the record, start and highest frequency
    they were fitted on) with each merged pole replaced by one seed per mode it merges, at the model's frequencies
    scaled to the pole's and at its damping ratio; labelled. None unless every merged mode then has a pole of its
    own that merges nothing (the record cannot separate them after all)."""
    mod = machine.module
    omega = dict(
        zip(mod.MODES, machine.evaluate("frequencies", machine.values(nominal, mod.FORWARD_ARGUMENTS)), strict=True)
    )
    gone = {id(m.pole) for m in merged}
    seeds = [p.p for p in poles if id(p) not in gone]
    for m in merged:
        names = [m.label, *m.partners]
        level = m.pole.frequency / float(np.mean([omega[n] for n in names]))
        seeds += [replace(m.pole, frequency=omega[n] * level).p for n in names]
    with np.errstate(all="ignore"):
        split = [_as_acceleration(p, record) for p in modal.poles_from(*source, np.array(seeds))]
    labelled, rest = label_poles(machine, record, split, nominal)
    labelled, again = unresolved(machine, record, labelled, nominal)
    wanted = {n for m in merged for n in (m.label, *m.partners)}
    if again or not wanted <= set(labelled):
        return None
    return labelled, rest


class Twins(NamedTuple):
    """What split_twins gives: the record's ``poles`` (refined again where a pole was split), the ``labelled``
    ones and the ``rest``, as label_poles gives them, and a warning per split."""

    poles: list[modal.Pole]
    labelled: dict[str, tuple[modal.Pole, float]]
    rest: list[modal.Pole]
    warnings: list[modal.QualityWarning]
    mixed: tuple[tuple[str, float, float], ...] = ()
    """(label, frequency span [rad/s], damping-ratio span) of each pole on two twins that a fit of two does not
    part (_spans): modal_data widens its uncertainty by them and gives it no shape (a mix of the twins' in the
    proportions the hit set), whatever later refits of the record's poles (a split of other twins, of close
    modes) make of the pole itself."""


def split_twins(
    machine: Machine,
    record: Record,
    source: tuple[Record, float, float],
    found: Twins,
    nominal: dict[str, float],
    settings: LabellingSettings = LABELLING,
) -> Twins:
    """The record's poles with each lone pole on modes the model has equal by symmetry (twins: a pole labelled x,
    none labelled y) split in two where the record resolves them. A machine whose symmetry is broken parts its
    twins by less than a pole's bandwidth (kid300 with its centre of mass off the axis: 18.775 and 18.895 rad/s
    at zeta 0.034), and a record may give one pole between them with the uncertainty of one (18.8282 +- 0.00045
    rad/s), which measures neither. The poles are refined again (modal.poles_from on ``source``: the record, start
    and highest frequency they were fitted on) with the lone pole replaced by two seeds settings.twin_seed_offset
    of its bandwidth 2 zeta |p| below and above it; the split is kept where the decay's misfit falls beyond noise
    (settings.twin_p_value: the fall over each channel's residual variance against chi^2 of two parameters of the
    pole and two of each channel's amplitude) and label_poles labels the two as the two twins (they part by
    settings.twin_separation). ``found``: the poles as label_poles labelled them (no warnings). A "twin_modes"
    warning says each pair parted (by label_poles or here) and that its names follow the order of frequency, and
    each lone pole whose fit of two lowers the misfit beyond noise without parting them (kept: it may be either
    twin, kid300 blind seed 0 with the centre of mass off the axis: 66.952 rad/s against theta's 66.955, or lie
    between them)."""
    import scipy.stats

    mod = machine.module
    visible = [m for m, seen in zip(mod.MODES, _channel_modes(machine, record, nominal)[2], strict=True) if seen]
    parted = [
        modal.QualityWarning(
            "twin_modes",
            "all",
            f"{mod.REPRESENTATIVE[label]} and {label}: two poles, "
            + " and ".join(
                f"{p.frequency:.4f} +- {p.frequency_std:.2g}"
                for p in (found.labelled[mod.REPRESENTATIVE[label]][0], found.labelled[label][0])
            )
            + " rad/s, apart beyond their uncertainty: named in the order of frequency",
        )
        for label in found.labelled
        if label != mod.REPRESENTATIVE[label]  # the upper of two twins label_poles parted
    ]
    found = found._replace(warnings=[*found.warnings, *parted])
    for label in list(found.labelled):
        twins = [m for m in visible if mod.REPRESENTATIVE[m] == label]
        if label not in found.labelled or len(twins) != 2 or twins[1] in found.labelled:
            continue
        pole = found.labelled[label][0]
        offset = settings.twin_seed_offset * 2 * pole.damping_ratio * pole.frequency
        seeds = [p.p for p in found.poles if p is not pole]
        seeds += [replace(pole, frequency=pole.frequency + d).p for d in (-offset, offset)]
        with np.errstate(all="ignore"):
            split = [_as_acceleration(p, record) for p in modal.poles_from(*source, np.array(seeds))]
        before, n = modal.decay_misfit(*source, np.array([p.p for p in found.poles]))
        after, _ = modal.decay_misfit(*source, np.array([p.p for p in split]))
        # each channel's fall over its residual variance; a channel the decay leaves at rest (a hit along x on a
        # y channel: rounding only) weighs as one at 1e-12 of the largest variance
        variance = np.maximum(after, 1e-12 * after.max()) / (n - 2 * len(split) - 1)
        fall = float(np.sum((before - after) / variance))
        extra = 2 + 2 * len(before)
        if not fall > scipy.stats.chi2.isf(settings.twin_p_value, extra):
            continue
        labelled, rest = label_poles(machine, record, split, nominal, settings)
        if not all(t in labelled for t in twins):
            # two modes under the pole that the record cannot part: the pole kept (it may be either twin or lie
            # between them), its uncertainty widened to cover the two poles of the fit of two
            spans = _spans(pole, _pair_of(split, [p for p in found.poles if p is not pole]))
            wide = _widened(pole, *spans)
            warning = modal.QualityWarning(
                "twin_modes",
                "all",
                f"{twins[0]} and {twins[1]}: one pole at {pole.frequency:.4f} +- {pole.frequency_std:.2g} rad/s; a fit "
                f"of two lowers the misfit by {fall:.0f} (noise {extra}) but does not part them: the pole may be "
                f"either twin or lie between them: its uncertainty widened to cover the fit of two "
                f"(+- {wide.frequency_std:.2g} rad/s, damping ratio +- {wide.damping_std:.2g}), its shape (a mix of "
                "the twins') left out",
            )
            found = found._replace(warnings=[*found.warnings, warning], mixed=(*found.mixed, (label, *spans)))
            continue
        a, b = (labelled[t][0] for t in twins)
        warning = modal.QualityWarning(
            "twin_modes",
            "all",
            f"{twins[0]} and {twins[1]}: one pole at {pole.frequency:.4f} +- {pole.frequency_std:.2g} rad/s split by a "
            f"fit of two (the misfit falls {fall:.0f}, noise {extra}): {twins[0]} {a.frequency:.4f} +- "
            f"{a.frequency_std:.2g}, {twins[1]} {b.frequency:.4f} +- {b.frequency_std:.2g} rad/s (named in the "
            "order of frequency)",
        )
        found = Twins(split, labelled, rest, [*found.warnings, warning], found.mixed)
    return found


def _pair_of(split: list[modal.Pole], others: list[modal.Pole]) -> list[modal.Pole]:
    """The poles of a fit of two in the place of one (``split``: the record's poles refined again) that are not
    the record's ``others`` refined again: each of those takes the split pole nearest it (in p)."""
    left = list(split)
    for other in others:
        left.remove(min(left, key=lambda q: abs(q.p - other.p)))
    return left


def _spans(pole: modal.Pole, pair: list[modal.Pole]) -> tuple[float, float]:
    """The span of ``pole``'s frequency [rad/s] and those of ``pair`` (the fit of two in its place), and the same
    of their damping ratios."""
    return (
        float(np.ptp([pole.frequency, *(q.frequency for q in pair)])),
        float(np.ptp([pole.damping_ratio, *(q.damping_ratio for q in pair)])),
    )


def _widened(pole: modal.Pole, frequency_span: float, damping_span: float) -> modal.Pole:
    """``pole`` with its frequency and damping standard deviations widened by the spans of a fit of two in its
    place (_spans): sqrt(std^2 + span^2). A pole that may be either of two twins, or lie between them, may lie as
    far as their separation from the twin whose name it carries."""
    return replace(
        pole,
        frequency_std=math.hypot(pole.frequency_std, frequency_span),
        damping_std=math.hypot(pole.damping_std, damping_span),
    )


def _span_mac(basis: np.ndarray, shape: np.ndarray) -> float:
    """The share of a (complex) channel shape in the span of the real columns ``basis``: |P s|^2 / |s|^2."""
    if basis.shape[1] == 0:
        return 0.0
    fitted = basis @ np.linalg.lstsq(basis, shape, rcond=None)[0]
    return float(np.vdot(fitted, fitted).real / max(np.vdot(shape, shape).real, np.finfo(float).tiny))


def pole_frequencies(machine: Machine, values: dict[str, float]) -> np.ndarray:
    """omega_n = |p| [rad/s] of each mode of M q'' + B q' + C q = 0 (what a pole fit of a free decay
    reports), in mode order (:func:`mountid.machine.damped_poles`); a mode that does not oscillate keeps its
    undamped frequency."""
    mod = machine.module
    undamped = np.asarray(mod.frequencies(**{a: values[a] for a in mod.FORWARD_ARGUMENTS}))
    poles = damped_poles(*matrices(mod, values), undamped**2)
    return np.where(poles != 0, np.abs(poles), undamped)


def root_predicate(rule: str, unknown: tuple[str, ...]) -> Callable[[dict[str, float]], bool]:
    """The predicate of a root rule "A>B" or "A<B" on two unknowns (nomenclature.root_rule; fit_stiffness)."""
    parts = root_rule(rule, unknown)
    if parts is None:
        raise InputError("root", f"{rule!r}: {root_rule_problem(rule, unknown)}")
    big, small = parts
    return lambda v: v[big] > v[small]


def pole_frequency_derivatives(machine: Machine, values: dict[str, float], names: tuple[str, ...]) -> np.ndarray:
    """d omega_n / dq [rad/s per unit of q] of :func:`pole_frequencies` for the parameters ``names``, shape
    (n_names, n_modes): d|p| = Re(conj(p) dp) / |p| with dp from the generated matrix derivatives
    (:func:`mountid.machine.damped_pole_derivatives`); a mode that does not oscillate keeps the undamped
    derivative d lambda / (2 omega)."""
    mod = machine.module
    fwd = {a: values[a] for a in mod.FORWARD_ARGUMENTS}
    lam = np.asarray(mod.squared_frequencies(**fwd))
    d = np.asarray(call(mod, "matrix_derivatives", values))
    rows = [mod.DERIVATIVE_PARAMETERS.index(n) for n in names]
    poles, d_p = damped_pole_derivatives(*matrices(mod, values), lam, d[rows, 0], d[rows, 1], d[rows, 2])
    fwd_rows = [mod.FORWARD_ARGUMENTS.index(n) for n in names]
    undamped = np.asarray(mod.squared_frequency_derivatives(**fwd))[fwd_rows] / (2 * np.sqrt(lam))
    magnitude = np.abs(poles)
    damped = (np.conj(poles) * d_p).real / np.where(magnitude > 0, magnitude, 1.0)
    return np.where(poles != 0, damped, undamped)


class StiffnessFit(NamedTuple):
    """fit_stiffness's result: the unknowns [SI] with their standard deviations [SI] (widened by
    the reduced chi^2 where that exceeds 1), and the covariance of their logarithms at the stated standard
    deviations of the frequencies (never widened: what the fit's predictions scatter by if the model holds), in
    the order of the machine's unknowns."""

    parameters: dict[str, float]
    stds: dict[str, float]
    log_covariance: np.ndarray


def frequency_std(measured: dict[str, tuple[float, float]], labels: list[str]) -> np.ndarray:
    """The standard deviation [rad/s] of each frequency of ``measured`` {label: (omega, std)} at ``labels``, no
    less than 1e-6 of the frequency (a stated zero would weight its frequency without bound)."""
    return np.array([max(measured[lab][1], 1e-6 * measured[lab][0]) for lab in labels])


def fit_stiffness(
    machine: Machine,
    known: dict[str, float],
    measured: dict[str, tuple[float, float]],
    others: dict[str, tuple[float, float]] | None = None,
    damping: dict[str, float] | None = None,
    root: str | None = None,
    notes: list[str] | None = None,
    rule_source: str = "",
    boundary_ok: bool = False,
    numeric_inverses: bool = True,
) -> StiffnessFit:
    """Unknowns fitted to every measured distinct frequency {label: (omega, std)} [rad/s].

    ``root``: the rule that picks one of several solutions that fit equally when no other measured mode
    decides, "A>B" or "A<B" for two unknowns A, B (e.g. "c_z>c_xy": rubber is stiffer in compression than in
    shear); why the solution was chosen is appended to ``notes`` (naming the rule as ``rule_source``).

    Starting points: every admissible root of every generated inverse over a subset of the measured
    labels. The fit minimises sum ((omega_model - omega)/std)^2 in log-parameters; the returned standard
    deviations come from (J^T W J)^-1, scaled up by the reduced chi^2 when that exceeds 1 (more frequencies
    than unknowns, scattering more than their stated std). When several distinct solutions fit equally well
    (an exactly determined set with two admissible roots, as the paper's (w1, w4)), the one that best
    predicts the ``others`` (measured modes left out of the fit) is taken; without others that is an error
    naming the choices. A fit that runs an unknown to zero or without bound (the frequencies stop depending on
    it) is no solution; where such a fit is the closest, no mount of the description fits the frequencies and
    that is an error naming the unknown and the largest miss, unless ``boundary_ok`` (the gap diagnosis, whose
    nominal model may miss that far: the closest fit is returned, fits at the same boundary counted as one, and
    the reason is appended to ``notes``; frequencies for which no generated inverse has a root start from the
    description's nominal values). ``numeric_inverses`` False (the gap diagnosis, which fits a machine near its
    description): the subsets whose inverse is numeric (NUMERIC_INVERSES: a grid search of up to hundreds of
    starts, a tenth of a second each) give one start instead, the description's nominal values, beside every
    root of the closed forms; they are searched after all where the fit from these starts ends at a boundary,
    or where the description gives no nominal values. With ``damping`` (values of the damping parameters) the
    model frequencies are the damped |p| (pole_frequencies), which a free decay measures; without, the undamped
    ones. Returns a StiffnessFit."""
    mod = machine.module
    unknown = machine.unknown
    machine.check_known(known)
    if root is not None:
        root_predicate(root, unknown)  # a rule that is not one is an error whether or not a tie needs it
    labels = [lab for lab in mod.UNIQUE_MODES if lab in measured]
    if len(labels) < len(unknown):
        raise InputError("measured", f"{distinct_frequencies(len(labels))} found for {len(unknown)} unknowns")
    undetermined = machine.undetermined_by(labels)
    if undetermined:  # no fit would move them: it would return their start with a standard deviation of 0
        raise InputError("measured", f"{undetermined.describe()}: {undetermined.advice()}")
    knowns = machine.values(known, tuple(a for a in mod.FORWARD_ARGUMENTS if a not in unknown))
    idx = [mod.MODES.index(lab) for lab in labels]
    omega = np.array([measured[lab][0] for lab in labels])
    std = frequency_std(measured, labels)

    def model(p: dict[str, float]) -> np.ndarray:
        if damping is None:
            return mod.frequencies(**knowns, **p)
        return pole_frequencies(machine, machine.values({**known, **damping, **p}, tuple(machine.parameters)))

    last: dict[bytes, np.ndarray] = {}

    def frequencies_at(logp: np.ndarray) -> np.ndarray:
        """The model's frequencies at the ln unknowns ``logp``, the last kept: the Jacobian is asked for where the
        residuals were just taken, and the undamped one divides by the same frequencies."""
        return recently_used(last, logp.tobytes(), lambda: model(dict(zip(unknown, np.exp(logp), strict=True))), 1)

    def residual(logp: np.ndarray) -> np.ndarray:
        return (frequencies_at(logp)[idx] - omega) / std

    columns = [mod.FORWARD_ARGUMENTS.index(u) for u in unknown]

    def jacobian(logp: np.ndarray) -> np.ndarray:
        """d residual / d log p from the generated analytic derivatives: d omega / d p = (d lambda / d p) /
        (2 omega) for the undamped model, d|p| through the damped poles (pole_frequency_derivatives)."""
        p = np.exp(logp)
        values = {**knowns, **dict(zip(unknown, p, strict=True))}
        if damping is None:
            d_lam = mod.squared_frequency_derivatives(**values)[columns][:, idx]  # (n_unknown, n_labels)
            d_omega = d_lam / (2 * frequencies_at(logp)[idx])
        else:
            full = machine.values({**known, **damping, **values}, tuple(machine.parameters))
            d_omega = pole_frequency_derivatives(machine, full, unknown)[:, idx]
        return d_omega.T * p[None, :] / std[:, None]

    nominal = [machine.parameters[u]["value"] for u in unknown]
    # the description's nominal values as a start (ln unknowns), where it gives them
    at_nominal = None if None in nominal else ((), np.log(np.array(nominal, dtype=float)))
    subsets = [key for key in itertools.combinations(labels, len(unknown)) if key in mod.INVERSES]
    searched = [key for key in subsets if key not in getattr(mod, "NUMERIC_INVERSES", {})]
    near_design = not numeric_inverses and at_nominal is not None and len(searched) < len(subsets)
    roots = [
        (key, start)
        for key in (searched if near_design else subsets)
        for start in _inverse_starts(
            mod, key, tuple(knowns), _packed(knowns.values()), _packed(measured[lab][0] for lab in key)
        )
    ]
    if near_design:  # one start for the numeric inverses left out: the description's
        roots.append(at_nominal)
    if not roots:
        if not boundary_ok or at_nominal is None:
            raise InputError("measured", "no generated inverse has an admissible root for these frequencies")
        # the gap diagnosis: a machine far from its description (a support below it) may leave a subset of its
        # modes without a root; the fit starts from the description's values and may end at a boundary
        roots = [at_nominal]
        if notes is not None:
            notes.append(
                "no generated inverse has an admissible root for these frequencies: the fit starts from the "
                "description's nominal values"
            )
    starts = _distinct_starts(roots, residual)

    def fit_from(start: np.ndarray) -> scipy.optimize.OptimizeResult | None:
        """The fit from one start; None where its path left double precision (a frequency of zero or an
        overflow: scipy stops on a non-finite residual or Jacobian)."""
        with np.errstate(all="ignore"):
            try:
                return trust_region(residual, jacobian, start, xtol=1e-14, ftol=1e-14)
            except ValueError:
                return None

    fits = sorted((f for f in map(fit_from, starts) if f is not None), key=lambda f: f.cost)
    if not fits:
        raise InputError("measured", "every fit from the generated inverses' roots left the range of double precision")
    inside = [f for f in fits if not _left_behind(f.jac).any()]
    if not inside or inside[0].cost > fits[0].cost + 1e-6 * (1 + fits[0].cost):
        if near_design:  # no mount near the description fits: the numeric inverses search further
            return fit_stiffness(
                machine, known, measured, others, damping, root, notes, rule_source, boundary_ok=boundary_ok
            )
        why = _no_mount(fits[0], unknown, labels, omega, std, np.array([start for _, start in roots]))
        if not boundary_ok:
            raise InputError("measured", why)
        if notes is not None:
            notes.append(why)
    else:
        fits = inside
    dof = len(labels) - len(unknown)
    tied = [fits[0]]
    for f in fits[1:]:
        if f.cost <= fits[0].cost + 1e-6 * (1 + fits[0].cost) and np.all([_distinct(f, t, dof) for t in tied]):
            tied.append(f)
    best = tied[0]
    if len(tied) > 1:
        choices = "; ".join(
            ", ".join(f"{u} = {v:.6g}" for u, v in zip(unknown, np.exp(f.x), strict=True)) for f in tied
        )
        if not others and root is None:
            raise InputError(
                "measured",
                f"{len(tied)} solutions fit equally ({choices}): measure another mode, or choose by a physical "
                f"rule (--root, e.g. {unknown[0]}>{unknown[1]})",
            )
        if not others:
            keep = root_predicate(root, unknown)
            chosen = [f for f in tied if keep(dict(zip(unknown, np.exp(f.x), strict=True)))]
            if len(chosen) != 1:
                raise InputError("root", f"{root} holds for {len(chosen)} of the {len(tied)} solutions ({choices})")
            if notes is not None:
                notes.append(
                    f"{len(tied)} solutions fit the measured frequencies equally ({choices}) and no other "
                    f"measured mode decides: chosen by {rule_source or 'the rule ' + root}"
                )
            best = chosen[0]
        else:
            o_idx = [mod.MODES.index(lab) for lab in others]
            o_w = np.array([w for w, _ in others.values()])

            def miss(f: scipy.optimize.OptimizeResult) -> float:
                return float(np.sum(np.log(model(dict(zip(unknown, np.exp(f.x), strict=True)))[o_idx] / o_w) ** 2))

            best = min(tied, key=miss)
    jac = best.jac  # d residual / d log p
    spread = standard_deviations(covariance(jac, 2 * best.cost, dof))  # least_squares' cost is chi^2 / 2
    values = np.exp(best.x)
    params = dict(zip(unknown, map(float, values), strict=True))
    stds = {u: float(values[i] * spread[i]) for i, u in enumerate(unknown)}
    return StiffnessFit(params, stds, covariance(jac, 0.0, dof))


START_SPACING = 0.1
"""Roots of the inverses over two different subsets of the measured modes closer than this in every log-unknown
(about 10 %) are one starting point: fit_stiffness fits from the one with the smaller residual. Wherever the
model fits the frequencies, those subsets give nearly the same root (they differ by the gap), and fits from
one neighbourhood end in one minimum; the roots of one inverse are distinct solutions and are all kept."""


def _distinct_starts(
    roots: list[tuple[tuple[str, ...], np.ndarray]], residual: Callable[[np.ndarray], np.ndarray]
) -> list[np.ndarray]:
    """The starting points (ln unknowns) of ``roots`` ((subset of labels, start) pairs), taken in order of their
    chi^2 (``residual``'s sum of squares), without those within START_SPACING of one kept from another subset."""
    with np.errstate(all="ignore"):
        chi2 = [float(np.sum(residual(start) ** 2)) for _, start in roots]
    order = sorted(range(len(roots)), key=lambda i: (not math.isfinite(chi2[i]), chi2[i], i))
    kept: list[tuple[tuple[str, ...], np.ndarray]] = []
    for i in order:
        key, start = roots[i]
        if all(k == key or np.max(np.abs(start - s)) >= START_SPACING for k, s in kept):
            kept.append(roots[i])
    return [start for _, start in kept]


def _packed(values: Iterable[float]) -> bytes:
    """Floats as their bytes: a cache key that tells -0.0 from 0.0."""
    values = [float(v) for v in values]
    return struct.pack(f"{len(values)}d", *values)


@functools.lru_cache(maxsize=256)
def _inverse_starts(
    mod: GeneratedModule, key: tuple[str, ...], names: tuple[str, ...], knowns: bytes, omegas: bytes
) -> tuple[np.ndarray, ...]:
    """The log-unknowns of every admissible root of the generated inverse over the labels ``key`` at the
    frequencies ``omegas`` [rad/s] and the known values of ``names`` (both _packed): fit_stiffness's starting
    points. Kept (read-only): a leave-one-out runs fit_stiffness on every subset of the measured modes, whose
    inverses over the same labels at the same frequencies give the same roots (numeric inverses cost a tenth of a
    second each; genset8's gap report solved each of its twenty sets four times)."""
    values = dict(zip(names, struct.unpack(f"{len(names)}d", knowns), strict=True))
    frequencies = struct.unpack(f"{len(key)}d", omegas)
    try:
        with np.errstate(all="ignore"):
            roots = mod.INVERSES[key](**values, **{f"omega_{lab}": w for lab, w in zip(key, frequencies, strict=True)})
    except (OverflowError, ZeroDivisionError):
        return ()  # a frequency whose powers leave double precision: no root from this set
    unknown = mod.UNKNOWN
    out = tuple(np.log([roots.parameters[u][i] for u in unknown]) for i in np.flatnonzero(roots.admissible))
    for start in out:
        start.setflags(write=False)
    return out


_LEFT_BEHIND_RTOL = 1e-8
"""An unknown whose column of d residual / d ln p is below this share of the largest column no longer moves
the frequencies: the fit has taken it to zero or without bound."""


def _left_behind(jac: np.ndarray) -> np.ndarray:
    """Per unknown of a fit (columns of d residual / d ln p): whether the frequencies have stopped depending on
    it (the fit ran to a stiffness of zero or of no bound, off every mount of the description)."""
    size = np.sqrt(np.add.reduce(jac * jac, axis=0))
    return size <= _LEFT_BEHIND_RTOL * size.max(initial=0.0)


def _distinct(a: scipy.optimize.OptimizeResult, b: scipy.optimize.OptimizeResult, dof: int) -> bool:
    """Whether two fits of equal cost (ln p) are different solutions: apart by more than 1e-6 and more than
    SAME_SOLUTION_SIGMA of their standard deviations in an unknown that is not left behind by both. Two fits that
    ran one stiffness to 1e-72 and 1e-86 N/m are one; so are two that stopped at different points of a valley
    the data hardly rise from (c_z 220961 and 224709 N/m from an aliased record)."""
    both = _left_behind(a.jac) & _left_behind(b.jac)
    sigma = np.maximum(
        standard_deviations(covariance(a.jac, 2 * a.cost, dof)), standard_deviations(covariance(b.jac, 2 * b.cost, dof))
    )
    apart = np.abs(a.x - b.x) > np.maximum(1e-6, SAME_SOLUTION_SIGMA * sigma)
    return bool(np.any(apart[~both]))


SAME_SOLUTION_SIGMA = 3.0
"""Two fits of equal cost closer than this many standard deviations in every unknown are one solution."""


def _no_mount(
    fit: scipy.optimize.OptimizeResult,
    unknown: tuple[str, ...],
    labels: list[str],
    omega: np.ndarray,
    std: np.ndarray,
    starts: np.ndarray,
) -> str:
    """Why the frequencies [rad/s] fit no mount: the closest ``fit`` (ln p from ``starts``, one row each) runs an
    unknown to zero or without bound."""
    gone = np.flatnonzero(_left_behind(fit.jac))
    ends = [f"{unknown[i]} to {'zero' if fit.x[i] < np.median(starts[:, i]) else 'no bound'}" for i in gone]
    miss = np.abs(fit.fun * std / omega)
    worst = int(np.argmax(miss))
    return (
        f"no mount of this description fits these frequencies: the closest fit takes {', '.join(ends)}, where "
        f"they no longer depend on it, and still misses {labels[worst]} by {miss[worst]:.1%}; check the mode "
        "labels and the known parameters"
    )


def fit_damping(
    machine: Machine, parameters: dict[str, float], modes: dict[str, MeasuredMode], names: tuple[str, ...]
) -> tuple[dict[str, float], dict[str, float]]:
    """Damping parameters ``names`` from measured damping ratios, the others (the description's other damping
    parameters, at their values in ``parameters`` or nominal) held. B is linear in the damping parameters, so
    to first order in damping 2 zeta_k omega_k = phi_k^T B phi_k (mass-normalised undamped shapes): a weighted
    linear least-squares fit (weights from the damping ratios' std) starts a Gauss-Newton refinement on the
    damping ratios -Re p / |p| of the poles of M p^2 + B p + C = 0 themselves (damped_pole_derivatives), what
    a pole fit of a free decay measures: the first-order fit is off by a share of order zeta^2 of the
    non-proportional coupling (7e-6 of genset8's b_h at zeta 0.1, which moved its records' pole
    frequencies, converted to undamped ones, by 1e-8). A first-order solution that is no damping (a value not
    above zero) or a mode that stops oscillating is returned as it is (the caller names it). Returns (values,
    std), the std from the weighted normal equations at the solution, scaled up by the reduced chi^2 where it
    exceeds 1."""
    mod = machine.module
    if len(modes) < len(names):
        raise InputError("damping", f"{len(modes)} damping ratios for {len(names)} damping parameters")
    needed = _matrix_arguments(machine)
    values = machine.values({n: 1.0 for n in names} | parameters, needed)  # ``names``' values are not read
    args = {a: values[a] for a in mod.FORWARD_ARGUMENTS}
    phi, lam = mod.modal_matrix(**args), np.asarray(mod.squared_frequencies(**args))
    held = {a: values[a] for a in mod.ARGUMENTS["damping_matrix"]} | {n: 0.0 for n in names}
    unheld = {n: 0.0 for n in machine.damping if n in held}  # every damping parameter at zero
    offset = np.asarray(call(mod, "damping_matrix", held))  # what the held damping parameters give
    units = np.array([call(mod, "damping_matrix", held | unheld | {name: 1.0}) for name in names])
    picked = [mod.MODES.index(label) for label in modes]
    measured = np.array([mode.damping_ratio for mode in modes.values()])
    sigma = np.array([max(mode.damping_std, 1e-6 * mode.damping_ratio) for mode in modes.values()])
    omega = np.sqrt(lam[picked])
    rows = np.einsum("ik,qij,jk->kq", phi[:, picked], units, phi[:, picked])
    offsets = np.einsum("ik,ij,jk->k", phi[:, picked], offset, phi[:, picked])
    weight = 1.0 / (2 * sigma * omega)
    design = rows * weight[:, None]
    sol = np.linalg.lstsq(design, (2 * measured * omega - offsets) * weight, rcond=None)[0]
    chi2 = float(np.sum((design @ sol - (2 * measured * omega - offsets) * weight) ** 2))
    exact = _exact_damping(machine, values, lam, offset, units, picked, measured, sigma, sol)
    if exact is not None:
        sol, design, chi2 = exact
    spread = standard_deviations(covariance(design, chi2, len(modes) - len(names)))
    return dict(zip(names, map(float, sol), strict=True)), {n: float(spread[i]) for i, n in enumerate(names)}


class DampedFit(NamedTuple):
    """fit_damped_model's result: the unknowns and the damping parameters fitted (``free``; not the held ones),
    with their standard deviations."""

    params: dict[str, float]
    stds: dict[str, float]
    damping: dict[str, float]
    damping_std: dict[str, float]


def fit_damped_model(
    machine: Machine,
    known: dict[str, float],
    measured: dict[str, tuple[float, float]],
    modes: dict[str, MeasuredMode],
    free: tuple[str, ...],
    others: dict[str, tuple[float, float]] | None = None,
    root: str | None = None,
    notes: list[str] | None = None,
    rule_source: str = "",
) -> DampedFit:
    """The unknowns fitted to pole frequencies |p| ``measured`` {label: (omega, std)} [rad/s] and the damping
    parameters ``free`` to the damping ratios of ``modes``, the description's other damping parameters held at
    their values in ``known`` (else nominal): the unknowns fitted as undamped first (fit_stiffness, with
    ``others``, ``root``, ``notes`` and ``rule_source`` as there), the damping at them (fit_damping), the unknowns
    refitted to the damped model's |p| and the damping again at those. The damping shifts |p| at second order and
    the unknowns shift the damping ratios at first: one such round leaves both where more rounds would."""
    params, _, _ = fit_stiffness(machine, known, measured, others, root=root, notes=notes, rule_source=rule_source)
    held = {n: known[n] for n in machine.damping if n not in free and n in known}

    def damping_at(params: dict[str, float]) -> tuple[dict[str, float], dict[str, float]]:
        return fit_damping(machine, {**known, **params}, modes, free) if free else ({}, {})

    first, first_std = damping_at(params)
    for name, value in first.items():
        if not value > 0:  # the model cannot be evaluated with it: say why, not that a damping must be positive
            unit = machine.parameters[name]["unit"]
            raise InputError(
                name,
                f"the damping ratios of {', '.join(modes)} give {value:.4g} +- {first_std[name]:.2g} {unit}, no "
                f"damping: they hardly determine it ({_damped_by(machine, known, params, name, modes)})",
            )
    damping = held | first
    params, stds, _ = fit_stiffness(machine, known, measured, others, damping, root=root)
    fitted, damping_std = damping_at(params)
    return DampedFit(params, stds, fitted, damping_std)


def _matrix_arguments(machine: Machine) -> tuple[str, ...]:
    """The arguments of the description's mass, stiffness and damping matrices, each once."""
    mod = machine.module
    return tuple(
        dict.fromkeys(a for f in ("mass_matrix", "stiffness_matrix", "damping_matrix") for a in mod.ARGUMENTS[f])
    )


def _damped_by(
    machine: Machine, known: dict[str, float], params: dict[str, float], name: str, measured: Iterable[str]
) -> str:
    """Which modes determine the damping parameter ``name``, said for an error: the modes whose modal damping
    phi^T B phi it gives half of or more at its nominal value (the others at theirs; ``known`` and the fitted
    unknowns ``params``), else the two it gives most of (screen6's b_m, two middle isolators beside four
    corners, gives 26 % of z's and 20 % of psi's at most), each with its share, and of them the ones not among the
    ``measured`` modes to measure."""
    mod = machine.module
    needed = _matrix_arguments(machine)
    values = machine.values({**known, **params}, needed)
    phi = mod.modal_matrix(**{a: values[a] for a in mod.FORWARD_ARGUMENTS})
    damping = {a: values[a] for a in mod.ARGUMENTS["damping_matrix"]}
    alone = {**damping, **{n: 0.0 for n in machine.damping if n in damping and n != name}}
    own = np.diag(phi.T @ call(mod, "damping_matrix", alone) @ phi)
    every = np.diag(phi.T @ call(mod, "damping_matrix", damping) @ phi)
    share = dict(zip(mod.MODES, np.divide(own, every, out=np.zeros_like(own), where=every > 0), strict=True))
    half = [label for label, s in share.items() if s >= 0.5]
    most = half or sorted(share, key=share.get, reverse=True)[:2]
    shares = ", ".join(f"{label} {share[label]:.0%}" for label in most)
    which = f"half or more of the damping of {shares}" if half else f"no mode half its damping, {shares} the most"
    missing = [label for label in most if label not in set(measured)]
    advice = f"measure {' or '.join(missing)}, or" if missing else "each of them measured;"
    return f"it gives {which}: {advice} give it as a known value to hold it there"


def _exact_damping(
    machine: Machine,
    values: dict[str, float],
    lam: np.ndarray,
    offset: np.ndarray,
    units: np.ndarray,
    picked: list[int],
    measured: np.ndarray,
    sigma: np.ndarray,
    start: np.ndarray,
    steps: int = 20,
) -> tuple[np.ndarray, np.ndarray, float] | None:
    """fit_damping's Gauss-Newton refinement from the first-order solution ``start``: the damping values with B =
    offset + sum_i b_i units_i whose poles' damping ratios (modes ``picked``) best fit ``measured`` in units of
    ``sigma``, the weighted Jacobian there and chi^2; None where the start or a step is no damping (a value not
    above zero) or a mode stops oscillating."""
    mass, stiffness, _ = matrices(machine.module, values)
    zeros = np.zeros_like(units)
    b = np.array(start, dtype=float)
    for _ in range(steps):
        if not np.all(np.isfinite(b) & (b > 0)):
            return None
        p, dp = damped_pole_derivatives(mass, stiffness, offset + np.tensordot(b, units, 1), lam, zeros, zeros, units)
        if np.any(p[picked] == 0):
            return None
        residual = (pole_damping_ratios(p)[picked] - measured) / sigma
        design = ratio_derivatives(p, dp)[:, picked].T / sigma[:, None]
        step = np.linalg.lstsq(design, -residual, rcond=None)[0]
        if np.all(np.abs(step) <= 1e-10 * np.abs(b)):  # the damping ratios' rounding moves b by 1e-14
            return b, design, float(residual @ residual)
        b = b + step
    return None


@dataclass(frozen=True)
class ModalData:
    """What a record gives (modal_data): labelled modes, the poles left unlabelled, the record's quality
    warnings, and with a force channel the frequency responses the modes came from and how. Unpacks as
    (modes, unlabelled, warnings)."""

    modes: dict[str, MeasuredMode]
    unlabelled: list[modal.Pole]
    warnings: list[modal.QualityWarning]
    frf: FrfEstimate | None = None
    """The H1 frequency responses the modes were fitted on (None: the free decay after ``start``)."""
    notes: tuple[str, ...] = ()
    mixed: frozenset[str] = frozenset()
    """The labels whose pole lies on two twins that a fit of two does not part (Twins.mixed): its uncertainty
    widened to cover the fit of two, no shape."""
    start: float = modal.DEFAULT_START
    """[s] Where the free decay the modes were fitted on starts (the caller's, else modal.free_decay's); with
    the H1 frequency responses, the caller's or modal.DEFAULT_START, the segment the record's checks look at."""
    end: float | None = None
    """[s] Where that free decay ends: a later hit (modal.free_decay); None: the record's end, or the H1."""
    hits: tuple[float, ...] = ()
    """[s] Without a force channel, the onsets of the record's hits where it shows several (modal.FreeDecay.hits):
    the starts of the other free decays it holds."""
    left_out: tuple[float, ...] = ()
    """[rad/s] An output-only record's poles left out as the estimate's noise (ambient.with_scatter; a note says so)."""
    reference: str = ""
    """The response channel an output-only record's modes came from (the one most of them did, for several:
    output_only.every_reference); "" for other records."""
    unexplained: float = 0.0
    """An output-only record's share of the correlation functions' variance that the poles found leave unexplained
    (modal.unexplained_share): a reference whose fit misses a mode its correlation functions hold (kid300, eight
    channels: 0.82 against 0.01-0.04) gives the others' shapes biased (output_only.every_reference)."""
    inputs: tuple[FrfEstimate, ...] = ()
    """Several shakers at once: the frequency responses of each force whose fit gave modes, in the order of the
    forces (references.every_input; ``frf`` is the one most modes came from); () for other records."""

    def __iter__(self) -> Iterator:
        return iter((self.modes, self.unlabelled, self.warnings))


IRF_START = 0.02
"""[s] The pole fit on impulse responses starts this long after their beginning (RecordSettings.pretrigger
before the hit): past the hit and the ringing of the band-limited division at its instant."""

EDGE_CYCLES = 4.0
"""Impulse responses transformed back from lines up to a top frequency (a bench's frequency response functions, a
shaker's H1) ring at that frequency from the instant of the hit, decaying as 1 / (pi top t) only: the band's edge cuts
off the mass line and the responses' jump there, which no pole represents. Their fit starts this many periods of the
top frequency after the hit, or at IRF_START where that is later (kid300's H1 of 0.5-40 Hz, noise-free: phi's
damping ratio 8e-4 of its value low from 0.02 s, 5e-5 from 0.1 s; through 0.5-25 Hz 4e-3 high from 0.02 s, 3e-4
from 0.16 s)."""


def impulse_start(lines: Lines) -> float:
    """[s] Where the pole fit on impulse responses transformed back from ``lines`` starts (EDGE_CYCLES)."""
    return max(IRF_START, EDGE_CYCLES / lines.top)


def modal_data(
    machine: Machine,
    record: Record | ModeTable,
    known: dict[str, float],
    start: float | None = None,
    nominal: dict[str, float] | None = None,
    settings: RecordSettings = RECORDS,
    use_force: bool = True,
    reference: str | None = None,
    clipping: bool = True,
    force: str | None = None,
) -> ModalData:
    """Record of an impact test -> labelled modes, the poles left unlabelled, and the record's quality warnings.
    With a force channel (and ``use_force``) the modes are fitted on the impulse responses of the H1 frequency
    responses averaged over the record's hits (measurement.frf): from the instant of each hit, the force divided
    out; otherwise on the free decay from ``start`` [s] (None: modal.free_decay's, after the impact the record
    shows, said in a note where that is not at modal.DEFAULT_START). ``nominal`` values of the unknowns (default:
    the description's) only serve to label the modes; ``settings``: the record checks' thresholds. A bench's table
    of modes (records.ModeTable) gives its modes labelled as a record's poles are (table_modal_data). With a
    ``reference`` (a response channel) the record is output-only: the modes are fitted on the correlation functions
    of the responses with it (measurement.ambient), their uncertainty from the segments' scatter; ``clipping``
    False leaves its clipping check to the caller (output_only.every_reference runs it once for every reference).
    A record of several shakers' continuous forces at once (MIMO) gives each force's frequency responses with the
    others' share taken out (frf.several_inputs): fitted for ``force``, or without one for every force, each mode
    from the force that drives it most strongly (references.every_input)."""
    mod = machine.module
    guess = {**known, **_labelling_values(machine, nominal or {})}
    nominal_omega = machine.evaluate("frequencies", machine.values(guess, mod.FORWARD_ARGUMENTS))  # range-checked
    if isinstance(record, ModeTable):
        if start is not None:
            raise InputError("start", f"applies to a record's samples: {TABLE_HAS_NO}")
        return table_modal_data(machine, record, guess)
    top = float(np.max(nominal_omega))
    full = record.in_si()
    if not full.responses:
        raise InputError("channels", "no response channel (acceleration, velocity or displacement): only force")
    record = full.select(full.responses)
    shaker = None  # a shaker's H1 (periods or bursts): fitted as a bench's FRFs are
    several = bool(use_force and frf.at_once(full, settings))
    if force is not None and (not several or force not in full.forces):
        raise InputError(
            "force",
            f"{force!r}: one of the forces of a record of several shakers at once ({', '.join(full.forces) or 'none'})",
        )
    if several and force is None:
        from mountid.identification.references import every_input

        return every_input(machine, full, known, start, nominal, settings)
    if several:
        shaker = frf.several_inputs(full, full.forces, settings)[full.forces.index(force)]
        record = shaker.as_impulse_record()
    elif record.impulse is None and full.forces and use_force and frf.is_continuous(full, full.forces[0], settings):
        shaker = frf.continuous_h1(full, full.forces[0], settings)
        record = shaker.as_impulse_record()
    estimate, notes, end, hits = None, [], None, ()
    tone_warnings: list[modal.QualityWarning] = []  # an output-only record's steady oscillations
    noise: list[modal.Pole] = []  # and its poles left out as the estimate's noise
    correlated = None  # an output-only record's correlation functions with the reference
    if reference is not None:
        if start is not None:
            raise InputError("start", "an output-only record's correlation functions start at lag zero")
        lags = ambient.shortest_lags(float(np.min(nominal_omega)), settings.min_periods)
        correlated = ambient.correlations(record, reference, lags)
    if len(full.forces) > 1 and use_force and not several and (shaker is not None or record.impulse is None):
        # one input: the others' hits (a roving hammer: its runs) or a second shaker's force are not divided out
        notes.append(
            f"{counted(len(full.forces) - 1, 'force channel')} not used ({', '.join(full.forces[1:])}): the H1 "
            f"frequency responses are of one input, {full.forces[0]}"
        )
    if correlated is not None:
        begin, fitted = ambient.START, correlated.mean
        _check_length(fitted, begin, float(np.min(nominal_omega)), settings)
        source = (fitted, begin, 2.0 * top)
        poles = modal.free_decay_poles(
            fitted, begin, max_frequency=2.0 * top, n_modes=len(mod.MODES), steady=settings.steady_damping
        )
        poles, noise = ambient.with_scatter(correlated, begin, 2.0 * top, len(mod.MODES), poles)
        # a pole left out is a running machine's tone where it makes a line in the record's spectrum; a pole kept
        # (its damping ratio beyond its scatter) is a mode, however sharp: a lightly damped mode's peak stands out too
        steady = ambient.tones(ambient.Spectrum.of(record), noise)
        noise = [p for p in noise if all(p is not t for t, _, _ in steady)]
        tone_warnings = [
            modal.QualityWarning(
                "steady",
                "all",
                f"a steady oscillation at {line:.4f} rad/s ({line / (2 * np.pi):.4g} Hz), not a mode: a line of the "
                f"record's spectrum {ratio:.0f} times the lines around it, where a mode's response spreads over its "
                "bandwidth (a running machine, mains hum)",
            )
            for _, line, ratio in steady
        ]
        segments = len(correlated.segments)
        notes.append(
            f"output-only: modes from the correlation functions of the responses with {reference} (lags to "
            f"{float(fitted.time[-1]):.3g} s, the mean of {segments} segments of {correlated.segment_length:.4g} s; "
            "uncertainty from their scatter, each left out in turn)"
        )
        if noise:
            notes.append(
                f"{counted(len(noise), 'pole')} at "
                + ", ".join(f"{p.frequency:.4g}" for p in noise)
                + f" rad/s left out: found again with fewer than {ambient.FOUND_IN:.0%} of the segments, or a "
                f"damping ratio within {ambient.DAMPED:g} standard deviations of zero (the estimate's noise)"
            )
    elif record.impulse is not None or (full.forces and use_force):
        if record.impulse is not None:  # frequency response functions transformed back: fitted as H1 is
            if start is not None:
                raise InputError("start", "impulse responses (frequency response functions) start at the hit")
            start, fitted, lines = impulse_start(record.impulse), record, record.impulse
            windowed = (
                f"H1 of {lines.origin}, without a window"
                if lines.origin
                else f"the bench's exponential window of {lines.window:.4g} 1/s divided out"
                if lines.window
                else "an exponential window the bench put on the responses adds its decay to every mode's damping: "
                "give it (--exponential-window, a campaign record's exponential_window) to divide it out"
            )
            notes.append(
                f"modes from the impulse responses of {counted(len(record.channels), 'frequency response function')}"
                f" (lines to {lines.top:.4g} Hz by {lines.spacing:.4g} Hz; {windowed})"
            )
        else:
            if start is not None:  # a time of the record: its checks look from there, the impulse responses have theirs
                _check_start(record, start, what="")
                notes.append(
                    f"the start given ({start:g} s) places the record's checks only: the modes come from the H1 "
                    f"frequency responses on {full.forces[0]} (without the force channel, --free-decay: the free "
                    "decay from there)"
                )
            estimate = frf.h1(full, full.forces[0], settings)
            fitted = estimate.impulse_responses()
            window = estimate.window_decay
            notes.append(
                f"modes from the H1 frequency responses of {counted(len(estimate.hits), 'hit')} on {estimate.force} "
                f"({estimate.length:.3g} s each"
                + (f", exponential window of {window:.3g} 1/s on the responses" if window else "")
                + ("; one hit: no coherence" if len(estimate.hits) == 1 else "")
                + ")"
            )
        begin = IRF_START if record.impulse is None else impulse_start(record.impulse)
        _check_length(fitted, begin, float(np.min(nominal_omega)), settings)
        source = (fitted, begin, 2.0 * top)
        poles = modal.free_decay_poles(
            fitted, begin, max_frequency=2.0 * top, n_modes=len(mod.MODES), steady=settings.steady_damping
        )
    else:
        decay = modal.free_decay(record, top, start, settings)
        start, end, hits, notes = decay.start, decay.end, decay.hits, [*notes, *decay.notes]
        analysed = record if end is None else record.before(end)
        _check_length(analysed, start, float(np.min(nominal_omega)), settings, end)
        source = (analysed, start, 2.0 * top)
        poles = modal.free_decay_poles(
            analysed, start, max_frequency=2.0 * top, n_modes=len(mod.MODES), steady=settings.steady_damping
        )
    poles = [_as_acceleration(p, record) for p in poles]
    start = modal.DEFAULT_START if start is None else start  # the checks' segment where the hits gave the modes
    lowest = min([p.frequency for p in poles] or [float(np.min(nominal_omega))])
    if shaker is not None or correlated is not None:  # a shaker's, an output-only record: clipping (no hit to check)
        clipped = modal.clipping(full.select(full.responses), None, top, settings) if clipping else []
        warnings = clipped + tone_warnings
    elif record.impulse is not None:  # no record of the test: its checks (clipping, noise, the hit) were the bench's
        warnings = []
    else:
        warnings = modal.hammer_test_quality(
            record, lowest, start, highest_frequency=top, settings=settings, impacts=estimate is None
        )
    segment = None if estimate is not None else start
    warnings += [w for name in full.forces for w in modal.force_quality(full, name, segment, settings)]
    warnings += modal.same_place(record)
    if len(record.channels) >= 7 and all(np.all(np.isfinite(c.point + c.direction)) for c in record.channels):
        # over the free decay from its start, or the impulse responses from the start the free decay has by default
        sensor = inconsistent_channel(
            machine,
            source[0],
            modal.DEFAULT_START
            if estimate is not None or record.impulse is not None or correlated is not None
            else start,
        )
        warnings += [sensor] if sensor is not None else []
    # a steady oscillation (a machine running nearby: modal.not_a_free_decay names it) takes no mode's label
    damped = [p for p in poles if not modal.is_steady(p, settings)]
    labelled, rest = label_poles(machine, record, damped, guess)
    rest = sorted([*rest, *(p for p in poles if modal.is_steady(p, settings))], key=lambda p: p.frequency)
    found = Twins(poles, labelled, rest, [])
    # a fit of two poles in the place of one is tested against white noise: correlation functions' errors are not
    twins = found if correlated is not None else split_twins(machine, record, source, found, guess)
    poles, labelled, rest = twins.poles, twins.labelled, twins.rest
    warnings += twins.warnings
    labelled, merged = unresolved(machine, record, labelled, guess)
    if merged:
        # correlation functions: no fit seeded at the model's modes either (its test assumes white noise)
        split = None if correlated is not None else _split_merged(machine, record, source, poles, merged, guess)
        if split is None:  # left out: a frequency between the modes and a mix of their shapes measure neither
            rest = sorted([*rest, *(m.pole for m in merged)], key=lambda p: p.frequency)
            warnings += [
                modal.QualityWarning("unresolved_modes", "all", f"{m.describe()}: not separated, {m.label} left out")
                for m in merged
            ]
        else:
            labelled, rest = split
            warnings += [
                modal.QualityWarning(
                    "close_modes",
                    "all",
                    f"{m.describe()}: split by a fit seeded at the model's modes, "
                    + ", ".join(
                        f"{n} {labelled[n][0].frequency:.4f} +- {labelled[n][0].frequency_std:.2g}"
                        for n in (m.label, *m.partners)
                    )
                    + " rad/s",
                )
                for m in merged
            ]
    everything = [(label, p) for label, (p, _) in labelled.items()] + [("", p) for p in rest]
    checked = modal.not_a_free_decay(*source, everything, settings)
    unexplained = 0.0
    if correlated is not None:
        unexplained = modal.unexplained_share(*source, np.array([p.p for _, p in everything], dtype=complex))
    # correlation functions hold the estimate's noise out to their last lag: their share unexplained says no more
    warnings += [w for w in checked if correlated is None or w.kind != "unexplained"]
    if not labelled:
        found_in = (
            "the correlation functions (a longer record, or channels that see the modes)"
            if correlated is not None
            else "the free decay (check start, channels and excitation)"
        )
        raise with_warnings(NoModeFound("record", f"no damped mode found in {found_in}"), warnings)
    if estimate is not None and len(estimate.hits) > 1:
        at = estimate.at
        warnings += _coherence_warnings(lambda w: at(w)[1], labelled, settings, f"{len(estimate.hits)} hits")
    if record.impulse is not None and record.impulse.coherence:
        lines, names = record.impulse, record.names
        averages = f"the {shaker.block}s" if shaker is not None else "the bench's averages"
        warnings += _coherence_warnings(
            lambda w: lines.coherence_at(w / (2 * np.pi), names), labelled, settings, averages
        )
    # a pole on two twins that a fit of two does not part: widened, without its shape (Twins.mixed)
    mixed = {label: spans for label, *spans in twins.mixed}
    labelled = {label: (_widened(p, *mixed[label]) if label in mixed else p, m) for label, (p, m) in labelled.items()}
    modes = _measured_modes(machine, record, labelled, frozenset(mixed), guess)
    mixed_labels = frozenset(mixed) & set(modes)
    left_out = tuple(p.frequency for p in noise)
    return ModalData(
        modes,
        rest,
        warnings,
        estimate or shaker,
        tuple(notes),
        mixed_labels,
        start,
        end,
        hits,
        left_out,
        reference or "",
        unexplained,
    )


def _measured_modes(
    machine: Machine,
    record: Record | ModeTable,
    labelled: dict[str, tuple[modal.Pole, float]],
    mixed: frozenset[str],
    guess: dict[str, float],
    stated: bool = True,
) -> dict[str, MeasuredMode]:
    """The labelled poles ({label: (pole, MAC)}) of a record or a table of modes as measured modes: the shape in the
    coordinates where the channels see all six motions (and the pole is not ``mixed``: on two twins a fit of two did
    not part), the MAC where two channels or more give one, the channel amplitudes for a roving test's merge;
    ``stated``: whether the frequencies' standard deviations were measured (MeasuredMode.frequency_std_stated)."""
    rows = channel_rows(machine, record)
    full = np.linalg.matrix_rank(rows) == rows.shape[1]
    length = machine.length_scale(guess)
    return {
        label: MeasuredMode(
            label,
            p.frequency,
            p.frequency_std,
            frequency_std_stated=stated,
            damping_ratio=p.damping_ratio,
            damping_std=p.damping_std,
            shape=coordinate_shape(rows, p.shape) if full and label not in mixed else None,
            shape_std=coordinate_shape_std(rows, p.shape, p.shape_std, length)
            if full and label not in mixed and p.shape_std is not None
            else None,
            mac=m if rows.shape[0] > 1 else None,  # one channel's "shape" is its sign: a MAC of 1 by definition
            channels=ChannelShape(p.shape, p.shape_std, rows, length) if label not in mixed else None,
        )
        for label, (p, m) in labelled.items()
    }


def _twins_in_span(
    machine: Machine, table: ModeTable, labelled: dict[str, tuple[modal.Pole, float]], guess: dict[str, float]
) -> dict[str, tuple[modal.Pole, float]]:
    """The labelled modes of a table with the MAC of two on twins that a record's poles would not part
    (LABELLING.twin_separation) taken in the twins' span (_span_mac), as a record's one pole on them has it: the
    bench's two modes there are any mix of the model's twins (kid300's x and y of a symmetric machine), and the
    MAC against one twin measures the mix."""
    mod = machine.module
    _, predicted, _ = _channel_modes(machine, table, guess)
    out = dict(labelled)
    for rep in set(mod.REPRESENTATIVE.values()):
        twins = [label for label in mod.MODES if mod.REPRESENTATIVE[label] == rep]
        if len(twins) == 2 and all(t in labelled for t in twins):
            (a, _), (b, _) = (labelled[t] for t in twins)
            if not _parted(a, b, LABELLING):
                span = predicted[:, [mod.MODES.index(t) for t in twins]]
                out.update({t: (labelled[t][0], _span_mac(span, labelled[t][0].shape)) for t in twins})
    return out


def table_modal_data(machine: Machine, table: ModeTable, guess: dict[str, float]) -> ModalData:
    """A bench's table of modes (modal_data's, at the parameter values ``guess``) as modal data: each mode a pole
    of its |p|, -Re p / |p| and channel shape, labelled against the model as a record's poles are (label_poles), but
    that two modes on twins are both twins (the bench parted them); a mode in the place of two of the model's
    (unresolved) is left out with an unresolved_modes warning, as there.
    The bench states no uncertainty: DEFAULT_FREQUENCY_STD of each frequency and default_damping_std of each
    damping ratio are taken (MeasuredMode.frequency_std_stated False), and the shapes have none of their own (a
    campaign takes its DEFAULT_SHAPE_STD). A record's checks and the parting of twins by a fit of two need its
    samples: the table's modes are the bench's."""
    poles = []
    for k, p in enumerate(table.poles):
        frequency, ratio = abs(p), -p.real / abs(p)
        pole = modal.Pole(
            frequency,
            ratio,
            table.shapes[:, k],
            DEFAULT_FREQUENCY_STD * frequency,
            default_damping_std(ratio),
        )
        poles.append(_as_acceleration(pole, table))
    # the table lists the modes the bench parted: two on twins are the twins, however close (a record's two poles
    # there must lie LABELLING.twin_separation standard deviations apart)
    labelled, rest = label_poles(machine, table, poles, guess, replace(LABELLING, twin_separation=0.0))
    labelled = _twins_in_span(machine, table, labelled, guess)
    labelled, merged = unresolved(machine, table, labelled, guess)
    warnings = [
        modal.QualityWarning("unresolved_modes", "all", f"{m.describe()}: one mode of the table, {m.label} left out")
        for m in merged
    ]
    rest = sorted([*rest, *(m.pole for m in merged)], key=lambda p: p.frequency)
    if not labelled:
        raise with_warnings(NoModeFound("record", "no mode of the table is one of the model's"), warnings)
    notes = (
        f"modes from a table of {counted(len(poles), 'mode')} ({table.kind}) at "
        f"{counted(len(table.channels), 'channel')}: the bench's modal analysis, its frequencies and damping ratios "
        f"as it gives them; it states no uncertainty: {DEFAULT_FREQUENCY_STD:.1%} of each frequency and "
        f"{DEFAULT_DAMPING_STD:.0%} of each damping ratio taken",
        *table.notes,
    )
    modes = _measured_modes(machine, table, labelled, frozenset(), guess, stated=False)
    return ModalData(modes, rest, warnings, None, notes)


def _labelling_values(machine: Machine, nominal: dict[str, float]) -> dict[str, float]:
    """The values of the unknowns the record's poles are labelled against: ``nominal``, else the description's; an
    error naming what is missing where it gives none, and naming a value that is not an unknown's."""
    for name in nominal:
        if name not in machine.unknown:
            raise InputError("nominal", f"{name} is not an unknown of {machine.name} ({', '.join(machine.unknown)})")
    missing = [u for u in machine.unknown if u not in nominal and machine.parameters[u]["value"] is None]
    if missing:
        raise InputError(
            "nominal",
            f"{machine.name} gives no nominal value for {', '.join(missing)}: the record's poles are labelled against "
            "the model at the unknowns' nominal values (give values to label with, --nominal on the command line)",
        )
    return nominal


def _coherence_warnings(
    coherence_at: Callable[[float], np.ndarray],
    labelled: dict[str, tuple[modal.Pole, float]],
    settings: RecordSettings,
    over: str,
) -> list[modal.QualityWarning]:
    """A low_coherence warning for each mode whose coherence at its frequency (``coherence_at`` of its damped
    frequency [rad/s]: the channels' coherence there) is below settings.low_coherence on every channel: noise, a
    nonlinearity or an input the force channel does not measure. ``over``: what the coherence was averaged over."""
    out = []
    for label, (pole, _) in labelled.items():
        coherence = coherence_at(pole.damped_frequency)
        if len(coherence) and float(np.max(coherence)) < settings.low_coherence:
            out.append(
                modal.QualityWarning(
                    "low_coherence",
                    "all",
                    f"mode {label} at {pole.frequency:.4g} rad/s: coherence {float(np.max(coherence)):.2f} at most "
                    f"over {over} (noise, a nonlinearity or an unmeasured input)",
                )
            )
    return out


def _check_length(
    record: Record, start: float, lowest: float, settings: RecordSettings, next_hit: float | None = None
) -> None:
    """A named error when the free decay after ``start`` [s] holds fewer than settings.min_periods periods of
    the lowest mode expected (``lowest`` [rad/s], the model's at the nominal values): the pencil cannot
    resolve it, and a shorter segment would only fail later with a less useful message. A start that is not
    finite (NaN passed every comparison and failed in the pencil), or at or after the last sample of a record long
    enough from its beginning (the start is past it, not the record too short), is an error naming the start.
    ``next_hit`` [s]: where the record, cut there (modal.free_decay), holds another hit: too short, the hits are
    too close, not the record."""
    length = float(record.time[-1]) - max(start, float(record.time[0]))
    periods = max(length, 0.0) * lowest / (2 * np.pi)
    whole = (float(record.time[-1]) - float(record.time[0])) * lowest / (2 * np.pi)
    _check_start(record, start, whole >= settings.min_periods)
    if periods < settings.min_periods:
        decay = settings.min_periods * 2 * np.pi / lowest
        if next_hit is None:
            span = f"after the start ({start:g} s)"
            advice = f"record {decay + max(start - float(record.time[0]), 0.0):.3g} s or more"
        else:
            span = f"from the start ({start:g} s) to the next hit ({next_hit:.4g} s)"
            advice = f"{decay:.3g} s of free decay or more before the next hit (or record the force)"
        raise InputError(
            "record",
            f"too short: {max(length, 0.0):.3g} s of free decay {span} holds {periods:.1f} periods of the lowest "
            f"mode ({lowest:.4g} rad/s); at least {settings.min_periods:g} are needed: {advice}",
        )


def _check_start(record: Record, start: float, past_end: bool = True, what: str = ": no free decay") -> None:
    """An InputError naming the start [s] where it is not finite (NaN passed every comparison and failed in the
    pencil), or (``past_end``) at or after the record's last sample (``what``: what that leaves none of)."""
    if not math.isfinite(start):
        raise InputError("start", f"must be a finite time [s], got {start}")
    if past_end and start >= float(record.time[-1]):
        raise InputError("start", f"{start:g} s is at or after the record's end ({float(record.time[-1]):g} s){what}")


def _as_acceleration(pole: modal.Pole, record: Record | ModeTable) -> modal.Pole:
    """The pole with its channel amplitudes as accelerations: a velocity amplitude times p, a displacement
    amplitude times p^2 (p the complex pole), so that channels of different quantities give one shape."""
    orders = np.array([RESPONSE_ORDER[c.quantity] for c in record.channels])
    if np.all(orders == 2):
        return pole
    gain = pole.p ** (2 - orders)
    std = None if pole.shape_std is None else pole.shape_std * np.abs(gain)
    return replace(pole, shape=pole.shape * gain, shape_std=std)


def identify_from_record(
    machine: Machine,
    record: Record | ModeTable,
    known: dict[str, float],
    start: float | None = None,
    nominal: dict[str, float] | None = None,
    use: tuple[str, ...] | None = None,
    settings: RecordSettings = RECORDS,
    root: str | None = None,
    use_force: bool = True,
    name: str = "the record",
) -> Identification:
    """Record of an impact test -> labelled modes (modal_data: from the H1 frequency responses where the record
    has a force channel and ``use_force``, else from the free decay after ``start`` [s], None: after each impact
    the record shows, combined per mode where it shows several: combination.every_decay, the record named
    ``name`` in its notes) -> unknown stiffnesses from all measured distinct frequencies, or only from the labels
    in ``use`` (e.g. the paper's ("x", "psi"): then exactly determined) -> damping parameters from the damping
    ratios.
    ``root``: the rule that picks between equally good solutions when no measured mode decides (fit_stiffness)."""
    return identify_from_records(machine, [(name, record)], known, start, nominal, use, settings, root, use_force)


def identify_from_records(
    machine: Machine,
    records: Sequence[tuple[str, Record | ModeTable]],
    known: dict[str, float],
    start: float | None = None,
    nominal: dict[str, float] | None = None,
    use: tuple[str, ...] | None = None,
    settings: RecordSettings = RECORDS,
    root: str | None = None,
    use_force: bool = True,
) -> Identification:
    """identify_from_record on several records of one test, each named (the runs of a UFF or TDMS file): their
    modes combined per mode (combination.every_decay), then identified as one record's; the frequency responses,
    start and end of the result the first decay's."""
    machine.check_known(known)  # before the labelling, which reads the model at the known values
    found = every_decay(machine, records, known, start, nominal, settings, use_force)
    hits = []
    for name, record in records:
        if isinstance(record, ModeTable):
            continue  # a table of modes has no hits
        si = record.in_si()
        hits += [(f"{name}: " if len(records) > 1 else "") + modal.hit_summary(si, force) for force in si.forces]
    try:
        result = _identify(
            machine, known, found.modes, found.unlabelled, found.warnings, use, root, [*hits, *found.notes]
        )
    except InputError as err:
        raise with_warnings(err, found.warnings) from None
    return replace(
        result, frf=found.frf, start=found.start, end=found.end, reference=found.reference, inputs=found.inputs
    )


def _check_enough(
    machine: Machine, fitted: dict[str, tuple[float, float]], found: dict[str, MeasuredMode], chosen: bool
) -> None:
    """An error naming what the record gave, what it did not and what to do, where the modes ``fitted`` (``found``
    in the record, ``chosen`` by --use or all) give fewer distinct frequencies than the machine has unknowns (it
    said "measured: 2 distinct frequencies found for 3 unknowns"), or leave one undetermined however many they are
    (Machine.undetermined_by: a fit would return its start)."""
    unique, unknown = machine.module.UNIQUE_MODES, machine.unknown
    distinct = [label for label in unique if label in fitted]
    undetermined = machine.undetermined_by(distinct)
    if undetermined:
        shown = [label for label in undetermined.completing if label in found]
        tail = (
            f"the record shows {' and '.join(shown)}: use {'it' if len(shown) == 1 else 'one of them'}"
            if chosen and shown
            else "not found in the record (a longer record, or channels and an excitation that show it)"
        )
        said = f"{undetermined.describe()}; {undetermined.advice()}" + (f"; {tail}" if undetermined.completing else "")
        raise InputError("use" if chosen else "record", said)
    if len(distinct) >= len(unknown):
        return
    missing = [label for label in unique if label not in found]
    given = f"{distinct_frequencies(len(distinct))} ({', '.join(distinct)})" if distinct else "no distinct frequency"
    tail = (
        f"the record's modes are {', '.join(found)}: use more of them"
        if chosen and len(found) > len(distinct)
        else f"not found in the record: {', '.join(missing)} (a longer record, or channels and an excitation that "
        "show them)"
    )
    raise InputError(
        "use" if chosen else "record", f"{given} for {len(unknown)} unknowns ({', '.join(unknown)}); {tail}"
    )


def with_warnings(
    error: InputError, warnings: list[modal.QualityWarning], shows: str = "the record also shows"
) -> InputError:
    """The error with the record's quality warnings appended (clipping and the like are reported even when
    the run stops for another reason: they may be the reason); ``shows`` introduces them."""
    if not warnings:
        return error
    found = "; ".join(w.describe() for w in warnings)
    return type(error)(error.parameter, f"{error.reason} [{shows}: {found}]")


def _identify(
    machine: Machine,
    known: dict[str, float],
    modes: dict[str, MeasuredMode],
    rest: list[modal.Pole],
    warnings: list[modal.QualityWarning],
    use: tuple[str, ...] | None,
    root: str | None,
    notes: list[str],
) -> Identification:
    chosen = modes
    if use is not None:
        # a twin the record gave one pole for is found under the twins' label (kid300's y with x)
        rep = machine.module.REPRESENTATIVE
        strange = ", ".join(lab for lab in use if lab not in rep)
        if strange:
            raise InputError("use", f"{strange}: not a mode label of {machine.name} ({', '.join(machine.modes)})")
        use = tuple(dict.fromkeys(lab if lab in modes or rep[lab] not in modes else rep[lab] for lab in use))
        missing = [lab for lab in use if lab not in modes]
        if missing:
            raise InputError("use", f"{', '.join(missing)} not found in the record (found: {', '.join(modes)})")
        chosen = {lab: modes[lab] for lab in use}
    pairs = {k: (m.frequency, m.frequency_std) for k, m in modes.items()}
    fitted, others = {k: pairs[k] for k in chosen}, {k: v for k, v in pairs.items() if k not in chosen}
    _check_enough(machine, fitted, modes, use is not None)
    # the record shows damped poles: undamped fit first, then damping, then the stiffness refitted to the
    # damped model's |p| (the shift is second order in damping: one more round changes nothing measurable)
    notes = list(notes)
    # a damping parameter given as a known value is held there (one the modes found hardly determine)
    damping_names = tuple(n for n in machine.damping if n not in known)
    held = [n for n in machine.damping if n in known]
    if held:
        notes.append(
            "damping held at the known values given, not fitted: "
            + ", ".join(f"{n} = {known[n]:.6g} {machine.parameters[n]['unit']}" for n in held)
        )
    if root is None and getattr(machine.module, "ROOT_RULE", ""):
        root = machine.module.ROOT_RULE  # the description's physical rule, unless the caller gave one
        source = f"the rule of the description {machine.name} ({root})"
    else:
        source = f"the rule {root}"
    if not any(m.damping_ratio for m in modes.values()):
        # a table of undamped modes (normal modes exported without damping: ratios of 0): no pole to fit damping to
        notes.append(
            "no mode has a damping ratio above 0 (a table of undamped modes): the stiffnesses are fitted to the "
            "frequencies as undamped ones and no damping parameter is fitted"
        )
        params, stds, _ = fit_stiffness(machine, known, fitted, others, root=root, notes=notes, rule_source=source)
        damping, damping_std = {}, {}
    else:
        params, stds, damping, damping_std = fit_damped_model(
            machine, known, fitted, modes, damping_names, others, root=root, notes=notes, rule_source=source
        )
    freqs = machine.frequencies({**known, **params})
    return Identification(modes, params, stds, damping, damping_std, freqs, rest, warnings, notes)
