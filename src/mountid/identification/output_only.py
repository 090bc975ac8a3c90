"""An output-only record's modes (measurement.ambient): the correlation functions with each response channel as
the reference in turn, fitted as free decays (from_records.modal_data), and each mode taken from the reference in
which it shows most strongly (its amplitudes over the reference's level: the precision follows).

A reference near a node of a mode does not see it (kid300's A_z sees the rocking psi, not the torsion phi; B_y the
torsion, not psi), so one reference seldom gives every mode. The estimates of one mode with several references come
from the same samples: they are not independent, and a weighted mean would claim a precision the record does not
have. Each mode's estimate is one reference's, with that reference's uncertainty (the segments' scatter); twins
(modes the model has equal by symmetry) come from one reference together.
"""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from mountid.errors import NoModeFound
from mountid.machine import Machine
from mountid.measurement import ambient, modal
from mountid.measurement.modes import MeasuredMode
from mountid.measurement.records import Record
from mountid.measurement.settings import RECORDS, RecordSettings
from mountid.nomenclature import counted

if TYPE_CHECKING:
    from mountid.identification.from_records import ModalData


def _strength(mode: MeasuredMode, reference_rms: float) -> float:
    """How strongly a mode shows in the correlation functions with a reference: its channel amplitudes' norm over the
    reference's RMS (the correlation estimate's noise grows with the reference's level), 0 without amplitudes. The
    reference a mode is taken from is the strongest: its precision follows, and the amplitudes are steadier than the
    jackknife's standard deviations (with seven degrees of freedom each), of which the smallest of eight references
    is too small by chance (kid300, eight channels: x's damping ratio 10 of its stated deviations off)."""
    if mode.channels is None or not reference_rms > 0:
        return 0.0
    return float(np.linalg.norm(mode.channels.amplitudes)) / reference_rms


def every_reference(
    machine: Machine,
    record: Record,
    known: dict[str, float],
    name: str,
    nominal: dict[str, float] | None = None,
    settings: RecordSettings = RECORDS,
) -> tuple[list[tuple[str, ModalData]], list[str]]:
    """The modal data of the output-only ``record`` (named ``name``): modal_data with every response channel as the
    reference; the references whose fit leaves more than settings.unexplained of their correlation functions
    unexplained set aside (a note names them; where every one does, a warning); each group of twins (or lone mode)
    from the reference that gives most of the group, then shows it most strongly (_strength); the other references'
    estimates left out. Returns one decay (decays_of's form, its notes say which reference gave which mode) and no
    notes besides."""
    from mountid.identification.from_records import modal_data

    found: list[tuple[str, ModalData]] = []
    notes: list[str] = []
    si = record.in_si()
    references = si.responses
    for reference in references:
        try:  # the record's clipping check once, with the first reference that gives modes
            data = modal_data(machine, record, known, None, nominal, settings, reference=reference, clipping=not found)
            found.append((reference, data))
        except NoModeFound as err:
            notes.append(f"with {reference} as the reference no mode: {err.reason}")
    if not found:
        raise NoModeFound(
            "record",
            "output-only (no force channel, a steady motion): no damped mode in the correlation functions with any "
            f"response channel as the reference ({'; '.join(notes)})",
        )
    warnings: list[modal.QualityWarning] = []
    for _, data in found:  # the record's checks (clipping, its tones): alike whichever the reference
        warnings += [w for w in data.warnings if w not in warnings]
    explained = [item for item in found if item[1].unexplained <= settings.unexplained]
    missing = [
        f"{reference} {data.unexplained:.0%}" for reference, data in found if data.unexplained > settings.unexplained
    ]
    if explained and missing:
        notes.append(
            f"not used: the references whose fit leaves more than {settings.unexplained:.0%} of their correlation "
            f"functions unexplained ({', '.join(missing)}; a mode they hold is missing from the fit, and the others' "
            "shapes take it up)"
        )
    elif missing:
        warnings.append(
            modal.QualityWarning(
                "unexplained",
                "all",
                f"the fit with every reference leaves more than {settings.unexplained:.0%} of its correlation "
                f"functions unexplained ({', '.join(missing)}): a mode they hold is missing from the fits, and the "
                "shapes found may take it up (more noise than response, or a mode the record does not resolve)",
            )
        )
    found = explained or found
    rep = machine.module.REPRESENTATIVE
    rms = {name: float(np.std(si.channel(name))) for name in references}
    picked: dict[str, str] = {}
    for group in dict.fromkeys(rep[label] for _, data in found for label in data.modes):

        def score(item: tuple[str, ModalData], group: str = group) -> tuple[int, float]:
            labels = [label for label in item[1].modes if rep[label] == group]
            return -len(labels), -sum(_strength(item[1].modes[label], rms[item[0]]) for label in labels)

        reference, data = min((item for item in found if group in {rep[lab] for lab in item[1].modes}), key=score)
        picked |= {label: reference for label in data.modes if rep[label] == group}
    by_reference = dict(found)
    modes = {label: by_reference[picked[label]].modes[label] for label in machine.module.MODES if label in picked}
    taken = dict.fromkeys(picked.values())
    unlabelled = sorted(
        (p for reference in taken for p in by_reference[reference].unlabelled), key=lambda p: p.frequency
    )
    first = by_reference[next(iter(taken))]
    each = "; ".join(
        f"{', '.join(label for label in modes if picked[label] == reference)} from {reference}" for reference in taken
    )
    # the first reference's account of the correlation functions (the others' alike), then what each left out
    own = [f"{found[0][1].notes[0]} (the other references' alike)"]
    noise = [
        f"with {reference} " + ", ".join(f"{w:.4g}" for w in data.left_out)
        for reference, data in found
        if data.left_out
    ]
    if noise:
        own.append(
            f"poles left out as the estimate's noise (found again with fewer than {ambient.FOUND_IN:.0%} of the "
            f"segments, or of a damping ratio within {ambient.DAMPED:g} standard deviations of zero): "
            + "; ".join(noise)
            + " rad/s"
        )
    summary = (
        f"output-only, {counted(len(references), 'response channel')} as the reference in turn, {len(found)} used; "
        "each mode from the reference in which it shows most strongly (the others' estimates share its samples): "
        f"{each}"
    )
    most = max(taken, key=lambda reference: sum(picked[label] == reference for label in modes))
    merged = replace(
        first,
        modes=modes,
        unlabelled=unlabelled,
        warnings=warnings,
        notes=(summary, *notes, *own),
        mixed=frozenset(),
        reference=most,
    )
    return [(name, merged)], []
