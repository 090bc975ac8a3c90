"""An output-only record's modes (measurement.ambient): the correlation functions with each response channel as
the reference in turn, fitted as free decays (from_records.modal_data), and each mode taken from the reference in
which it shows most strongly (its amplitudes over the reference's level: the precision follows).

A reference near a node of a mode does not see it (kid300's A_z sees the rocking psi, not the torsion phi; B_y the
torsion, not psi), so one reference seldom gives every mode; each mode's estimate is one reference's
(references.strongest), with that reference's uncertainty (the segments' scatter).
"""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from mountid.errors import NoModeFound
from mountid.identification.references import strongest
from mountid.machine import Machine
from mountid.measurement import ambient, modal
from mountid.measurement.records import Record
from mountid.measurement.settings import RECORDS, RecordSettings
from mountid.nomenclature import counted

if TYPE_CHECKING:
    from mountid.identification.from_records import ModalData


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
    from the reference that gives most of the group, then shows it most strongly (references.strongest); the other
    references' estimates left out. Returns one decay (decays_of's form, its notes say which reference gave which
    mode) and no notes besides."""
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
    levels = {name: 1.0 / float(np.std(si.channel(name))) for name in references}
    picked = strongest(machine, found, levels, machine.frequencies({**known, **(nominal or {})}))
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
        f"{picked.each}"
    )
    merged = replace(
        dict(found)[picked.taken[0]],
        modes=picked.modes,
        unlabelled=picked.unlabelled,
        warnings=warnings,
        notes=(summary, *picked.notes, *notes, *own),
        mixed=frozenset(),
        reference=picked.most,
    )
    return [(name, merged)], []
