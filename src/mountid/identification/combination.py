"""Modes of one machine measured more than once combined per mode: the free decays after each hit of a record
without a force channel, the runs of a file of several, and several records of one campaign.

Each decay (or record) gives its modes through the records chain (from_records.modal_data); per mode the estimates
are combined (weighted means of frequency and damping ratio, widened where they scatter beyond their uncertainty;
the shape of the sharpest that gives one, or where none does, the channels of all together: a roving test's runs,
identification.shapes), twins that some estimates part and others give one pole for are reconciled, and
estimates that disagree beyond RECORDS_DISAGREE are named. `process` and `identify-record` use it for a record
of several hits or runs (every_decay), the campaign (diagnosis.campaign) for its records as well.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from mountid.errors import InputError, NoModeFound
from mountid.identification.shapes import merged_shape, no_shapes_note
from mountid.machine import Machine
from mountid.measurement import ambient, modal
from mountid.measurement.modes import MeasuredMode
from mountid.measurement.records import ModeTable, Record
from mountid.measurement.settings import RECORDS, RecordSettings
from mountid.nomenclature import counted

if TYPE_CHECKING:
    from mountid.identification.from_records import ModalData

Estimates = dict[str, list[tuple[MeasuredMode, str]]]
"""Per mode label, its estimates with the name of the decay or record each comes from."""

RECORDS_DISAGREE = 5.0
"""Two records' (or decays') frequencies of one mode further apart than this many of their combined standard
deviations are named in the notes (the diagnosis takes their weighted mean, its uncertainty widened to their
scatter)."""


def every_hit(
    machine: Machine,
    record: Record,
    known: dict[str, float],
    first: ModalData,
    name: str,
    nominal: dict[str, float] | None = None,
    settings: RecordSettings = RECORDS,
) -> tuple[list[tuple[str, ModalData]], list[str]]:
    """A record of several hits without a force channel (ModalData.hits; ``first``: modal_data's without a start,
    the first hit's free decay): the free decay after each hit, from modal.AFTER_IMPACT after it to the next, as
    records of their own named "``name`` hit k" (the first keeps ``name``), combined per mode as records are: the
    superposed remainder of the decays before is a free decay of the same modes. A later decay the chain cannot use
    (too short for the lowest mode before the next hit, no mode found) is left out with a note. Returns the decays
    and the notes; the decays' own notes no longer say that the others are not used. ``nominal`` and ``settings``:
    modal_data's, as for the first decay."""
    from mountid.identification.from_records import modal_data

    def own(data: ModalData) -> ModalData:
        cut = modal.next_hit_note(data.end, len(data.hits)) if data.end is not None else None
        return replace(data, notes=tuple(n for n in data.notes if n != cut))

    segments, notes = [(name, own(first))], []
    for k, hit in enumerate(first.hits[1:], start=2):
        try:
            # a free decay, as the first: a force channel's H1 (modal_data's default) would give every hit's
            data = modal_data(machine, record, known, hit + modal.AFTER_IMPACT, nominal, settings, use_force=False)
            segments.append((f"{name} hit {k}", own(data)))
        except InputError as err:  # NoModeFound too
            notes.append(f"{name} hit {k}: left out: {err.reason}")
    starts = ", ".join(f"{data.start:.4g}" for _, data in segments)
    notes.insert(
        0,
        f"{name}: {counted(len(first.hits), 'hit')}, a free decay after each (from t = {starts} s; "
        f"{modal.AFTER_IMPACT:g} s after the later hits), combined per mode as records are",
    )
    return segments, notes


def lone_twins(machine: Machine, estimates: dict[str, list[tuple[MeasuredMode, str]]]) -> list[str]:
    """Where some records part two modes the model has equal by symmetry (twins: x and y, named in the order of
    frequency, from_records.label_poles) and another gives one pole of the two (under the first twin's label,
    whichever it is), that pole is left out (``estimates`` changed in place), with a note: it may be either twin,
    or lie between them, one pole in the place of two (kid300 with a drive belt, blind seed 7: psi and theta at
    61.357 and 61.857 rad/s, one record parts them, the other gives 61.80 +- 0.007); averaged under the first
    label, a pole of the upper twin or between them moved the lower one's frequency by many of its standard
    deviations."""
    rep = machine.module.REPRESENTATIVE
    notes = []
    for label in [lab for lab in estimates if rep[lab] == lab]:
        twins = [m for m in machine.module.MODES if rep[m] == label]
        parting = {name for t in twins[1:] for _, name in estimates.get(t, [])}
        if not parting:
            continue
        for mode, name in [e for e in estimates[label] if e[1] not in parting]:
            estimates[label].remove((mode, name))
            notes.append(
                f"{name}: one pole of {' and '.join(twins)} at {mode.frequency:.4f} rad/s left out: "
                f"{', '.join(sorted(parting))} part them, and one pole may be either, or lie between them"
            )
    return notes


def mixed_twins(
    machine: Machine, estimates: dict[str, list[tuple[MeasuredMode, str]]], mixed: list[tuple[str, str]]
) -> list[str]:
    """Where one record's lone pole on two twins is one that a fit of two lowers the misfit of beyond noise without
    parting them (``mixed``: label and record; from_records.modal_data widened its uncertainty to cover the fit of
    two and left its shape out: ModalData.mixed), the other records' lone poles of the same twins (no record parts
    them: lone_twins) are treated alike: their frequency and damping standard deviations widened by the widest of
    that record's, their shapes left out (``estimates`` changed in place), with a note. Their decays did not show
    the second pole, but the machine has it: a lone pole whose record shows one mode may still lie on either twin or
    between them (kid300axes, one isolator scattered and the centre of mass higher, blind seed 27: x and y at 16.405
    and 16.427 rad/s; one record's x 16.4149, flagged, the other's 16.4234 +- 0.0009)."""
    rep = machine.module.REPRESENTATIVE
    notes = []
    for label in sorted({lab for lab, _ in mixed}):
        flagged = {name for lab, name in mixed if lab == label}
        if any(rep[other] == label and other != label for other in estimates):
            continue  # a record parts them (lone_twins kept only the parted poles)
        widest = [m for m, name in estimates.get(label, []) if name in flagged]
        if not widest:
            continue
        cover = max(m.frequency_std for m in widest)
        cover_damping = max(m.damping_std or 0.0 for m in widest)
        for i, (mode, name) in enumerate(estimates[label]):
            if name in flagged:
                continue
            wide = replace(
                mode,
                frequency_std=math.hypot(mode.frequency_std, cover),
                damping_std=None if mode.damping_std is None else math.hypot(mode.damping_std, cover_damping),
                shape=None,
                shape_std=None,
            )
            estimates[label][i] = (wide, name)
            notes.append(
                f"{name}: the pole of {label} at {mode.frequency:.4f} rad/s may lie on either of two twins or "
                f"between them, as {', '.join(sorted(flagged))} shows: its uncertainty widened alike (+- "
                f"{wide.frequency_std:.2g} rad/s), its shape left out"
            )
    return notes


def kinds(mode: MeasuredMode) -> str:
    return "frequency, damping ratio, shape" if mode.shape is not None else "frequency, damping ratio"


def combined(found: list[tuple[MeasuredMode, str]], sharpest: MeasuredMode) -> tuple[MeasuredMode, str]:
    """One mode measured in several records: the frequency and the damping ratio as weighted means, each
    standard deviation the mean's, widened by the Birge ratio where the records scatter beyond their own
    uncertainty (their repeatability, not only their noise); the rest from ``sharpest`` (the record with the
    smallest frequency standard deviation; combine chooses the shape). Returns the mode and a note of any widening
    ('' without)."""
    frequency, frequency_std, widened = weighted([(m.frequency, m.frequency_std) for m, _ in found])
    mode = replace(sharpest, frequency=frequency, frequency_std=frequency_std)
    ratios = [(m.damping_ratio, m.damping_std) for m, _ in found if m.damping_ratio is not None and m.damping_std]
    note = (
        f"; the frequencies scatter {widened:.3g} times their stated uncertainty, the mean's widened as much"
        if _shown(widened)
        else ""
    )
    if len(ratios) > 1:
        zeta, zeta_std, zeta_widened = weighted(ratios)
        mode = replace(mode, damping_ratio=zeta, damping_std=zeta_std)
        if _shown(zeta_widened):
            note += f"; the damping ratios {zeta_widened:.3g} times theirs, widened as much"
    return mode, note


def sharpest_shape(found: list[tuple[MeasuredMode, str]]) -> tuple[MeasuredMode, str] | None:
    """The estimate with the smallest frequency standard deviation among those whose channels give a shape (span
    the six motions), None where none does."""
    shaped = [e for e in found if e[0].shape is not None]
    return min(shaped, key=lambda e: e[0].frequency_std) if shaped else None


def joint_shape(
    machine: Machine, label: str, found: list[tuple[MeasuredMode, str]], estimates: Estimates
) -> tuple[tuple[float, ...], float | None] | None:
    """The shape of a mode no record's channels give alone, from the channels of every record together
    (shapes.merged_shape: each record's amplitudes scaled by a factor fitted with the shape; a roving test's runs),
    and its standard deviation; None where they do not determine it. Twins a record gives one pole for are left
    alone: the pole lies in their span in the mix its hit gave, another in another mix, and no factor scales one
    onto the other; twins every record parts (both labelled in it) are modes of their own."""
    rep = machine.module.REPRESENTATIVE
    twins = [m for m in machine.module.MODES if rep[m] == rep[label] and m != label]
    parted = all(any(name in {n for _, n in estimates.get(t, [])} for t in twins) for _, name in found)
    if len(found) < 2 or any(m.channels is None for m, _ in found) or (twins and not parted):
        return None  # a pole without its channels: one a fit of two does not part from its twin (ModalData.mixed)
    return merged_shape([m.channels for m, _ in found if m.channels is not None])


def _shown(ratio: float) -> bool:
    """Whether a Birge ratio widens a mean by what the notes' three digits show: above 1, not printed as "1" (the
    widening is applied whatever its size; a note of "1 times" said nothing)."""
    return ratio > 1 and f"{ratio:.3g}" != "1"


def weighted(values: list[tuple[float, float]]) -> tuple[float, float, float]:
    """Inverse-variance weighted mean of (value, std) pairs, its standard deviation times the Birge ratio
    sqrt(chi^2 / (n - 1)) where that exceeds 1, and that ratio."""
    x = np.array([v for v, _ in values])
    w = 1.0 / np.array([s for _, s in values]) ** 2
    mean = float(np.sum(w * x) / np.sum(w))
    ratio = math.sqrt(float(np.sum(w * (x - mean) ** 2)) / (len(x) - 1))
    return mean, float(1.0 / math.sqrt(np.sum(w))) * max(1.0, ratio), ratio


def disagreement(label: str, found: list[tuple[MeasuredMode, str]]) -> list[str]:
    """A note when the records' frequencies of one mode differ by more than RECORDS_DISAGREE of their combined
    standard deviation: records of different states of the machine (another load, temperature, amplitude of the
    rubber's strain) or a mode labelled differently in one of them. Empty otherwise."""
    if len(found) < 2:
        return []
    pairs = [(a, b) for i, a in enumerate(found) for b in found[i + 1 :]]
    z = [abs(a.frequency - b.frequency) / math.hypot(a.frequency_std, b.frequency_std) for (a, _), (b, _) in pairs]
    if max(z) <= RECORDS_DISAGREE:
        return []
    each = ", ".join(f"{name} {m.frequency:.6g} +- {m.frequency_std:.2g}" for m, name in found)
    return [
        f"{label}: the records disagree beyond their uncertainty ({each} rad/s; up to {max(z):.3g} sigma apart): "
        "not one state of the machine, or a mode labelled differently in one of them"
    ]


@dataclass(frozen=True)
class Combination:
    """combine's result: per mode the combined estimate (in the order of the estimates), what was done, the modes
    whose estimates disagree beyond RECORDS_DISAGREE, and per mode the estimates its shape comes from (the sharpest
    that gives one, or all of a roving test's runs; none without a shape)."""

    modes: dict[str, MeasuredMode]
    notes: tuple[str, ...]
    disagree: tuple[str, ...]
    shape_from: dict[str, tuple[str, ...]]


def combine(
    machine: Machine, estimates: Estimates, mixed: list[tuple[str, str]], by_hand: frozenset[str] = frozenset()
) -> Combination:
    """The ``estimates`` of each mode combined (``estimates`` changed in place where twins are reconciled:
    lone_twins, mixed_twins with ``mixed``, the (label, source) pairs of lone poles on two twins): one estimate kept
    as it is, several combined (combined), disagreements named (disagreement). A label in ``by_hand`` (a campaign
    gives that mode by hand) keeps its sharpest estimate without a note of its own: the caller says what it did."""
    notes = lone_twins(machine, estimates)
    notes += mixed_twins(machine, estimates, mixed)
    best = {label: min(found, key=lambda e: e[0].frequency_std) for label, found in estimates.items()}
    modes, disagree, shape_from = {}, [], {}
    for label, (mode, name) in best.items():
        found = estimates[label]
        shape_from[label] = (name,) if mode.shape is not None else ()
        if label in by_hand:
            pass  # the caller says it, once its estimate is as the hand-given one
        elif len(found) == 1:
            notes.append(f"{label}: {kinds(mode)} from {name}")
        else:
            mode, note = combined(found, mode)
            names = ", ".join(n for _, n in found)
            shaped, shape = sharpest_shape(found), ""
            if shaped is not None:  # the sharpest estimate whose channels give one
                mode = replace(mode, shape=shaped[0].shape, shape_std=shaped[0].shape_std)
                shape_from[label], shape = (shaped[1],), f"; shape from {shaped[1]}"
            elif (joint := joint_shape(machine, label, found, estimates)) is not None:
                mode = replace(mode, shape=joint[0], shape_std=joint[1])
                shape_from[label] = tuple(n for _, n in found)
                shape = (
                    f"; shape from the channels of all {len(found)} together, each one's amplitudes scaled by a "
                    "factor fitted with it"
                )
            notes.append(f"{label}: frequency, damping ratio from {names} (weighted means{shape}){note}")
        said = disagreement(label, found) if label not in by_hand else []
        notes += said
        disagree += [label] if said else []
        modes[label] = mode
    notes += why_no_shapes(modes, [m for found in estimates.values() for m, _ in found])
    return Combination(modes, tuple(notes), tuple(disagree), shape_from)


def why_no_shapes(modes: dict[str, MeasuredMode], estimates: Sequence[MeasuredMode]) -> list[str]:
    """A note where none of the ``modes`` has a shape because the channels of every estimate of them, all together,
    do not see every rigid-body motion (shapes.unseen_motion: two triaxial sensors leave the rotation about the line
    through them unseen); empty where a mode has one or the channels see all six (a shape missing for another
    reason: its own notes)."""
    parts = [m.channels for m in estimates if m.channels is not None]
    if not parts or any(m.shape is not None for m in modes.values()):
        return []
    note = no_shapes_note(np.vstack([p.rows for p in parts]), parts[0].length)
    return [note] if note else []


def decays_of(
    machine: Machine,
    record: Record | ModeTable,
    known: dict[str, float],
    name: str,
    start: float | None = None,
    nominal: dict[str, float] | None = None,
    settings: RecordSettings = RECORDS,
    use_force: bool = True,
) -> tuple[list[tuple[str, ModalData]], list[str]]:
    """The decays of one record named ``name``, each with its name and modal data (from_records.modal_data,
    ``start``, ``nominal``, ``settings`` and ``use_force`` as there), and the notes on them: the free decay after
    each hit (every_hit) where ``start`` is None and the modes come from a free decay after several hits; an
    output-only record's (ambient.is_output_only, no ``start``) from its correlation functions with every response
    channel as the reference (output_only.every_reference); else the record's one (a ``start``, one hit, or the H1
    frequency responses of a force channel)."""
    from mountid.identification.from_records import modal_data
    from mountid.identification.output_only import every_reference

    if start is None and isinstance(record, Record) and ambient.is_output_only(record.in_si()):
        return every_reference(machine, record, known, name, nominal, settings)
    data = modal_data(machine, record, known, start, nominal, settings, use_force)
    if start is None and data.frf is None and len(data.hits) > 1:
        return every_hit(machine, record, known, data, name, nominal, settings)
    return [(name, data)], []


def at_once(
    machine: Machine,
    records: Sequence[tuple[str, Record | ModeTable]],
    segments: list[tuple[str, ModalData]],
    notes: list[str],
    known: dict[str, float],
    nominal: dict[str, float] | None = None,
) -> tuple[list[tuple[str, ModalData]], list[str]]:
    """The ``segments`` (named decays) with each group of a file's inputs measured at once (their Lines.together: a
    bench's multiple coherence) reduced to one estimate per mode: each mode kept in the input whose frequency
    responses show it most strongly (references.strongest, the forces' levels taken as equal: the functions are per
    N and the file gives no force), left out of the others. Their estimates share the samples, and the weighted mean
    of independent runs would claim a precision the measurement does not have. ``notes`` with one more per group;
    ``known`` and ``nominal`` the values the poles were labelled against (the model's frequencies at them decide
    which label one pole found twice keeps: references.one_pole_twice)."""
    from mountid.identification.references import strongest

    together = {
        name: record.impulse.together
        for name, record in records
        if isinstance(record, Record) and record.impulse is not None and record.impulse.together
    }
    groups: dict[str, list[tuple[str, ModalData]]] = {}
    for name, data in segments:
        if name in together:
            groups.setdefault(together[name], []).append((name, data))
    omega = machine.frequencies({**known, **(nominal or {})}) if groups else {}
    picks = {key: strongest(machine, group, dict.fromkeys(dict(group), 1.0), omega) for key, group in groups.items()}
    for key, group in groups.items():
        if len(group) > 1:
            notes = [
                *notes,
                f"{', '.join(dict(group))}: {key}: each mode from the input whose frequency responses show it most "
                "strongly (the others' estimates share its samples; the forces' levels taken as equal): "
                f"{picks[key].each}",
                *picks[key].notes,
            ]
    out = []
    for name, data in segments:
        picked = picks.get(together.get(name, ""))
        if picked is None or len(groups[together[name]]) < 2:
            out.append((name, data))
            continue
        own = {label: mode for label, mode in data.modes.items() if picked.source.get(label) == name}
        unlabelled = data.unlabelled if name in picked.taken else []
        out.append((name, replace(data, modes=own, unlabelled=unlabelled, mixed=frozenset(data.mixed & own.keys()))))
    return out, notes


def every_decay(
    machine: Machine,
    records: Sequence[tuple[str, Record | ModeTable]],
    known: dict[str, float],
    start: float | None = None,
    nominal: dict[str, float] | None = None,
    settings: RecordSettings = RECORDS,
    use_force: bool = True,
) -> ModalData:
    """The modal data of one test's records, each named (a record file, or the runs of a UFF or TDMS file), from
    every decay they hold (decays_of), combined per mode (combine). One record of several that gives no mode is left
    out with a note. Returns the modes, the poles left unlabelled in any decay (by frequency), every decay's
    warnings (named by the decay, ``record``, but for a lone record's first), the notes (every_hit's, each decay's
    own under its name, the combination's); its frf, start and end the first decay's (what a figure of one decay
    shows). A lone record with one decay (one hit, a ``start``, or the H1 frequency responses of a force channel)
    gives its modal_data, with why_no_shapes's note where its channels give no shapes."""
    segments: list[tuple[str, ModalData]] = []
    said: list[str] = []
    for name, record in records:
        try:
            decays, notes = decays_of(machine, record, known, name, start, nominal, settings, use_force)
        except NoModeFound as err:
            if len(records) == 1:
                raise
            said.append(f"{name}: left out: {err.reason}")
            continue
        except InputError as err:  # which of the records
            if len(records) == 1:
                raise
            raise type(err)(err.parameter, f"{name}: {err.reason}") from None
        segments, said = [*segments, *decays], [*said, *notes]
    segments, said = at_once(machine, records, segments, said, known, nominal)
    if not segments:
        raise NoModeFound("record", f"no mode in any of {counted(len(records), 'record')}: {'; '.join(said)}")
    if len(records) == 1 and len(segments) == 1:
        data = segments[0][1]
        return replace(data, notes=(*data.notes, *why_no_shapes(data.modes, list(data.modes.values()))))
    estimates: Estimates = {}
    mixed, warnings, notes, unlabelled = [], [], said, []
    for k, (segment, data) in enumerate(segments):
        own = k == 0 and len(records) == 1  # the record the caller names
        warnings += [w if own else replace(w, record=segment) for w in data.warnings]
        notes += [f"{segment}: {note}" for note in data.notes]
        unlabelled += data.unlabelled
        for label, mode in data.modes.items():
            estimates.setdefault(label, []).append((mode, segment))
        mixed += [(label, segment) for label in data.mixed]
    combination = combine(machine, estimates, mixed)
    return replace(
        segments[0][1],
        modes={label: combination.modes[label] for label in machine.module.MODES if label in combination.modes},
        unlabelled=sorted(unlabelled, key=lambda p: p.frequency),
        warnings=warnings,
        notes=(*notes, *combination.notes),
        mixed=frozenset(label for label, _ in mixed if label in combination.modes),
    )
