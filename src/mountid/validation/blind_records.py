"""Blind truths as records: the harness's truths (:mod:`mountid.validation.blind_truth`) simulated as impact
records of the harness's sensor layout and diagnosed from those records (the records chain inside the campaign,
as a test engineer runs it), beside the same truth's modal-data campaign (:func:`blind.make_case`). What the
records chain adds to or loses from the diagnosis on a known truth: close modes one pole merges, twins a record
cannot split, the damped poles' |p| against the undamped frequencies, shapes from channels.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

from mountid.diagnosis import campaign as campaign_module
from mountid.diagnosis.gap import diagnose
from mountid.errors import InputError
from mountid.measurement.records import write_csv
from mountid.measurement.rig import Hammer, Rig, Sensor
from mountid.validation import blind
from mountid.validation.blind_truth import TruthMachine, represented_by, sensor_layout, truth_matrices

_NOT_IN_RECORDS = frozenset(
    (
        "sensor_error",
        "sensor_turned",
        "sensor_misplaced",
        "sensor_reversed",
        "frequency_dependent",
        "nonlinear_isolator",
    )
)

RECORD_TRUTHS: tuple[str, ...] = tuple(
    name for name in blind.EFFECT_NAMES if not _NOT_IN_RECORDS & set(name.split("+"))
)
"""The truths a record carries as they are: M, C and B. Left out: the sensor truths (the harness misreads its
modal data, not a record's channels), the frequency-dependent rubber and the hardening isolator (frequencies the
harness computes beyond M, C, B)."""

RECORD_NOISE = 0.02
"""White noise of each channel, relative to its RMS."""

DURATION = 20.0
"""Length of each record [s]."""

HITS = ((1.0, 0.7, -0.6), (0.3, -1.0, -0.5))
"""Directions of the two hits, one record each, at the first and second sensor corners."""


@dataclass(frozen=True)
class RecordCase:
    """One truth diagnosed from its records: the verdict's ``kind``, the ``first`` candidate and its
    ``probability``, whether it was ``confident``, the candidates in the ``tie``, the modes the records gave, and
    the record notes that split or left out close modes; ``error`` where the records chain stopped (its message)."""

    truth: str
    machine: str
    seed: int
    kind: str
    first: str | None
    probability: float
    confident: bool
    tie: tuple[str, ...]
    modes: tuple[str, ...]
    close_modes: tuple[str, ...]
    error: str = ""
    acceptable: tuple[str, ...] | None = None
    """For a truth of two parts, the candidates counted right (blind.acceptable_parts: the whole truth's and each
    part's that alone explains the truth's noise-free modal data); None for one part."""

    @property
    def right(self) -> tuple[str, ...]:
        """The candidates counted right: the one that represents the truth, or ``acceptable``."""
        if self.acceptable is not None:
            return self.acceptable
        name = represented_by(self.truth)
        return (name,) if name else ()

    @property
    def confident_and_wrong(self) -> bool:
        return self.confident and self.first not in self.right


def record_campaign(seed: int, truth: str, machine: str, folder: Path, noise: float = RECORD_NOISE) -> Path:
    """The campaign file (in ``folder``, with its two CSV records) of the truth blind.make_case draws for ``seed``
    on ``machine``: one hit per record at a top corner of the sensor layout, DURATION s, sampled at 20 points per
    period of the truth's highest nominal mode (200 Hz at least), the free decay analysed from 0.1 s plus 20
    samples after the hit (the anti-alias filter's ringing), the known values of the shapes campaign."""
    data, t = blind.make_case(seed, truth, machine=machine)
    tm = TruthMachine(machine)
    rig = Rig.from_matrices(machine, *truth_matrices(tm, t))
    sensors = [
        Sensor(name, tuple(map(float, r)), tuple(map(float, d)), noise=noise) for name, r, d in sensor_layout(tm)
    ]
    rate = max(200.0, 20.0 * tm.highest_frequency / (2 * math.pi))
    peak = 2000.0 * tm.mass(tm.nominal) / 838.6  # the rig's 2 kN hit on the KID-300, scaled by the mass
    records = []
    for k, direction in enumerate(HITS):
        hit = Hammer(sensors[3 * k].point, direction, peak=peak)
        name = f"{machine}-{truth}-{seed}-{k}.csv"
        write_csv(rig.simulate(sensors, DURATION, rate, hammers=[hit], seed=seed * 10 + k), folder / name)
        records.append({"file": name, "start": 0.1 + 20.0 / rate})
    path = folder / f"{machine}-{truth}-{seed}.json"
    path.write_text(json.dumps({"machine": machine, "known": data["known"], "records": records}), encoding="utf-8")
    return path


def run_record_case(seed: int, truth: str, machine: str, folder: Path, noise: float = RECORD_NOISE) -> RecordCase:
    """Diagnose one truth from its records (record_campaign)."""
    path = record_campaign(seed, truth, machine, folder, noise)
    try:
        found = campaign_module.load(path)
        report = diagnose(found).effects
    except InputError as err:
        return RecordCase(truth, machine, seed, "error", None, math.nan, False, (), (), (), str(err))
    best = report.best
    notes = tuple(n for n in found.record_notes if "close_modes" in n or "unresolved_modes" in n)
    acceptable = None
    if "+" in truth:
        acceptable = blind.acceptable_parts(truth, blind.noise_free_diagnosis(seed, truth, "shapes", machine))
    return RecordCase(
        truth,
        machine,
        seed,
        report.kind,
        best.effect if best is not None else None,
        best.probability if best is not None else math.nan,
        report.confident,
        tuple(report.tie),
        tuple(found.modes),
        notes,
        acceptable=acceptable,
    )
