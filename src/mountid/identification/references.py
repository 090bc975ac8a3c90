"""The modes of one record fitted several times, once per reference, each mode taken from the reference it shows in
most strongly: an output-only record's correlation functions with each response channel in turn
(output_only.every_reference), a test of several shakers at once with each force's frequency responses
(every_input).

The estimates of one mode with several references come from the same samples: they are not independent, and a
weighted mean would claim a precision the record does not have. Each mode's estimate is one reference's, with that
reference's uncertainty; twins (modes the model has equal by symmetry) come from one reference together.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from mountid.errors import NoModeFound
from mountid.machine import Machine
from mountid.measurement import modal
from mountid.measurement.modes import MeasuredMode
from mountid.measurement.records import Record
from mountid.measurement.settings import RECORDS, RecordSettings
from mountid.nomenclature import counted

if TYPE_CHECKING:
    from mountid.identification.from_records import ModalData


def strength(mode: MeasuredMode, level: float) -> float:
    """How strongly a mode shows with a reference: its channel amplitudes' norm times the reference's ``level`` (the
    precision of a fit with it follows), 0 without amplitudes. For correlation functions the level is 1 over the
    reference channel's RMS (the estimate's noise grows with the reference's level); for a force's frequency
    responses the force's RMS (their noise falls as the force grows). Steadier than the fits' standard deviations:
    the smallest of eight references' jackknife deviations (seven degrees of freedom each) is too small by chance
    (kid300, eight channels: x's damping ratio 10 of its stated deviations off)."""
    if mode.channels is None or not level > 0:
        return 0.0
    return float(np.linalg.norm(mode.channels.amplitudes)) * level


SAME_POLE = 2.0
"""Two modes of different labels (not twins) picked from different references whose frequencies and damping ratios
agree within this many combined standard deviations, with channel shapes of MAC SAME_SHAPE or more, are one pole
found twice (one_pole_twice)."""

SAME_SHAPE = 0.9
"""The MAC of two picked modes' channel amplitudes from which they may be one pole (SAME_POLE)."""


def one_pole_twice(
    machine: Machine, modes: dict[str, MeasuredMode], omega: dict[str, float]
) -> tuple[dict[str, MeasuredMode], list[str], list[str]]:
    """The ``modes`` picked from several references without those that are another picked mode's pole again: two
    modes of different labels (not twins) whose frequencies and damping ratios agree within SAME_POLE combined
    standard deviations and whose channel amplitudes have a MAC of SAME_SHAPE or more are one pole, labelled one
    way with one reference and the other way with another (kid300 with the paper's three channels, output-only,
    seed 30: phi at 36.77 rad/s with B_y and "psi" at 36.93 with A_y, psi's model frequency 64.1). The label whose
    model frequency (``omega`` [rad/s]) lies nearer it, in log frequency as the labelling weighs it, keeps it.
    Returns the modes kept, the labels left out and a note for each."""
    rep = machine.module.REPRESENTATIVE
    dropped: list[str] = []
    notes: list[str] = []
    labels = list(modes)
    for i, a in enumerate(labels):
        for b in labels[i + 1 :]:
            if rep[a] == rep[b] or a in dropped or b in dropped or not _one_pole(modes[a], modes[b]):
                continue
            keep, lose = sorted((a, b), key=lambda label: abs(math.log(modes[label].frequency / omega[label])))
            dropped.append(lose)
            notes.append(
                f"{lose} left out: its pole ({modes[lose].frequency:.4g} rad/s, zeta {modes[lose].damping_ratio:.3g}) "
                f"is {keep}'s ({modes[keep].frequency:.4g} rad/s) again, labelled {lose} in another fit "
                f"(frequency and damping ratio within {SAME_POLE:g} standard deviations, channel shapes alike); "
                f"{keep}'s model frequency {omega[keep]:.4g} rad/s lies nearer it than {lose}'s {omega[lose]:.4g}"
            )
    return {label: m for label, m in modes.items() if label not in dropped}, dropped, notes


def _one_pole(a: MeasuredMode, b: MeasuredMode) -> bool:
    """Whether two modes are one pole (one_pole_twice): frequency and damping ratio within SAME_POLE combined
    standard deviations, channel amplitudes alike; False where either lacks what that takes."""
    if a.channels is None or b.channels is None or a.damping_ratio is None or b.damping_ratio is None:
        return False
    if a.damping_std is None or b.damping_std is None or len(a.channels.amplitudes) != len(b.channels.amplitudes):
        return False
    apart = abs(a.frequency - b.frequency) / math.hypot(a.frequency_std, b.frequency_std)
    damped = abs(a.damping_ratio - b.damping_ratio) / math.hypot(a.damping_std, b.damping_std)
    alike = modal.mac(a.channels.amplitudes, b.channels.amplitudes) >= SAME_SHAPE
    return apart < SAME_POLE and damped < SAME_POLE and alike


class Picked(NamedTuple):
    """What strongest gives: the ``modes`` (in the model's order), the ``source`` of each (its reference), the
    references ``taken`` (in the order their first group was), the poles they left ``unlabelled``, which modes came
    from which reference (``each``: "x, y from A_x; z from B_z") and the reference ``most`` of them came from."""

    modes: dict[str, MeasuredMode]
    source: dict[str, str]
    taken: tuple[str, ...]
    unlabelled: list[modal.Pole]
    each: str
    most: str
    notes: tuple[str, ...] = ()
    """What one_pole_twice left out, and why."""


def strongest(
    machine: Machine, found: list[tuple[str, ModalData]], level: dict[str, float], omega: dict[str, float]
) -> Picked:
    """Each group of twins (or lone mode) of the fits ``found`` ((reference, modal data) in the order of the
    references) from the reference that gives most of the group, then shows it most strongly (strength, with the
    reference's ``level``); of two labels on one pole (one_pole_twice, with the model's frequencies ``omega``
    [rad/s]) the one whose model frequency lies nearer."""
    rep = machine.module.REPRESENTATIVE
    source: dict[str, str] = {}
    for group in dict.fromkeys(rep[label] for _, data in found for label in data.modes):

        def score(item: tuple[str, ModalData], group: str = group) -> tuple[int, float]:
            labels = [label for label in item[1].modes if rep[label] == group]
            return -len(labels), -sum(strength(item[1].modes[label], level[item[0]]) for label in labels)

        reference, data = min((item for item in found if group in {rep[lab] for lab in item[1].modes}), key=score)
        source |= {label: reference for label in data.modes if rep[label] == group}
    by_reference = dict(found)
    modes = {label: by_reference[source[label]].modes[label] for label in machine.module.MODES if label in source}
    modes, dropped, notes = one_pole_twice(machine, modes, omega)
    source = {label: reference for label, reference in source.items() if label not in dropped}
    taken = tuple(dict.fromkeys(source.values()))
    unlabelled = sorted(
        (p for reference in taken for p in by_reference[reference].unlabelled), key=lambda p: p.frequency
    )
    each = "; ".join(
        f"{', '.join(label for label in modes if source[label] == reference)} from {reference}" for reference in taken
    )
    most = max(taken, key=lambda reference: sum(source[label] == reference for label in modes))
    return Picked(modes, {label: source[label] for label in modes}, taken, unlabelled, each, most, tuple(notes))


def every_input(
    machine: Machine,
    record: Record,
    known: dict[str, float],
    start: float | None = None,
    nominal: dict[str, float] | None = None,
    settings: RecordSettings = RECORDS,
) -> ModalData:
    """The modal data of a ``record`` of several shakers' continuous forces at once (MIMO: frf.several_inputs): the
    modes fitted on each force's frequency responses (from_records.modal_data with that ``force``), each group of
    twins from the force that gives most of it, then drives it most strongly (strength: the amplitudes times the
    force's RMS). A shaker near a node of a mode hardly drives it; the other's frequency responses give it. The
    record's warnings of every force's fit, once each; ``frf`` the frequency responses of the force most modes came
    from, ``inputs`` every force's that gave modes. A NoModeFound where no force's gives a mode."""
    from mountid.identification.from_records import modal_data

    si = record.in_si()
    found: list[tuple[str, ModalData]] = []
    notes: list[str] = []
    for force in si.forces:
        try:
            found.append((force, modal_data(machine, record, known, start, nominal, settings, force=force)))
        except NoModeFound as err:
            notes.append(f"{force}'s frequency responses give no mode: {err.reason}")
    if not found:
        raise NoModeFound(
            "record", f"{counted(len(si.forces), 'shaker')} at once: no damped mode in any force's ({'; '.join(notes)})"
        )
    levels = {force: float(np.std(si.channel(force))) for force in si.forces}
    picked = strongest(machine, found, levels, machine.frequencies({**known, **(nominal or {})}))
    warnings = list(dict.fromkeys(w for _, data in found for w in data.warnings))
    by_force = dict(found)
    summary = (
        f"{counted(len(si.forces), 'shaker')} at once ({', '.join(si.forces)}): each mode from the force whose "
        f"frequency responses show it most strongly (the others' estimates share its samples): {picked.each}"
    )
    chosen = by_force[picked.most]
    return replace(
        chosen,
        modes=picked.modes,
        unlabelled=picked.unlabelled,
        warnings=warnings,
        notes=(summary, *picked.notes, *notes, *chosen.notes),
        mixed=frozenset(label for label in picked.modes if label in by_force[picked.source[label]].mixed),
        inputs=tuple(data.frf for _, data in found if data.frf is not None),
    )
