"""Blind truths as records: the harness's truths (:mod:`mountid.validation.blind_truth`) simulated as impact
records of the harness's sensor layout (a sensor truth's channels as its sensors are mounted, the records stating
the layout) and diagnosed from those records (the records chain inside the campaign,
as a test engineer runs it), beside the same truth's modal-data campaign (:func:`blind.make_case`). What the
records chain adds to or loses from the diagnosis on a known truth: close modes one pole merges, twins a record
cannot split, the damped poles' |p| against the undamped frequencies, shapes from channels.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from mountid.diagnosis import campaign as campaign_module
from mountid.diagnosis.gap import diagnose
from mountid.errors import InputError
from mountid.measurement.records import ModeTable, write_csv
from mountid.measurement.rig import Hammer, Rig, Sensor
from mountid.validation import blind
from mountid.validation.blind_truth import (
    REVERSED_BESIDE,
    SENSOR_TRUTHS,
    Truth,
    TruthMachine,
    hardening,
    mounted_layout,
    represented_by,
    sensor_layout,
    truth_matrices,
)

_APART = frozenset(("frequency_dependent", "nonlinear_isolator"))
"""Truths kept out of the first two groups: the frequency-dependent rubber (not recorded) and the hardening
isolators (recorded last, HARDENING_TRUTHS)."""


def _record_truths(sensors: bool) -> tuple[str, ...]:
    return tuple(
        name
        for name in blind.EFFECT_NAMES
        if not _APART & set(name.split("+")) and bool(SENSOR_TRUTHS & set(name.split("+"))) == sensors
    )


HARDENING_TRUTHS = ("nonlinear_isolator",)
"""The truths whose records are integrated through the rubber's hardening (the rig's Hardening, a time
integration beyond M, C, B): the frequencies of a decaying record move as its amplitude falls."""

RECORD_TRUTHS: tuple[str, ...] = (
    *_record_truths(sensors=False),
    *_record_truths(sensors=True),
    *REVERSED_BESIDE,
    *HARDENING_TRUTHS,
)
"""The truths a record carries: those of the machine as they are (M, C and B), then those of its sensors (each
channel simulated as its sensor is mounted, mounted_layout, and stated in the record as the layout says: a
reversed, turned or misplaced channel, a turned and lifted measurement frame), then a reversed channel beside a
physical effect (REVERSED_BESIDE), then hardening isolators (HARDENING_TRUTHS, since 2026-11-30). Left out: the
frequency-dependent rubber (its frequencies are the roots of a nonlinear eigenproblem, which a time record of
M, C, B does not carry). Each group comes after those before it, so that they keep the seeds they had before it
was added (make bench-records)."""

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
    the record notes that split or left out close modes; ``error`` where the records chain stopped (its message);
    the channels the truth mounts otherwise than the records state (``misread``: none but for a sensor truth) and
    the suspects of each sensor warning the records chain gave (``sensor_suspects``: a channel that does not move
    with the rigid body the others agree on; several where the layout cannot tell which, none where it cannot
    narrow them)."""

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
    misread: tuple[str, ...] = ()
    sensor_suspects: tuple[tuple[str, ...], ...] = ()
    verdict: str = ""
    """The verdict as the report states it."""
    levels_move: bool = False
    """Whether the verdict says the frequencies at the second level move beyond any change of stiffness
    (EffectsReport.levels_move)."""

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

    @property
    def misread_named(self) -> bool:
        """Whether a sensor warning names the truth's one misread channel alone."""
        return len(self.misread) == 1 and self.misread in self.sensor_suspects

    @property
    def misread_suspected(self) -> bool:
        """Whether a sensor warning names the truth's one misread channel among the suspects it cannot tell apart
        (a reversed z channel of four: the layout's one redundant z equation cannot say which), or alone."""
        return len(self.misread) == 1 and any(self.misread[0] in s for s in self.sensor_suspects)


def record_campaign(
    seed: int, truth: str, machine: str, folder: Path, noise: float = RECORD_NOISE, level: float | None = None
) -> Path:
    """The campaign file (in ``folder``, with its two CSV records) of the truth blind.make_case draws for ``seed``
    on ``machine``: one hit per record at a top corner of the sensor layout, DURATION s, sampled at 20 points per
    period of the truth's highest nominal mode (200 Hz at least), the free decay analysed from 0.1 s plus 20
    samples after the hit (the anti-alias filter's ringing), the known values of the shapes campaign. ``level``:
    two more records of the truth hit at that many times the force, its rubber's stiffness changed as make_case's
    level draws it (blind.at_other_level: alike in every mode), listed under the campaign's ``levels``."""
    return _written(seed, truth, machine, folder, noise, level)[0]


def bench_table(seed: int, effect: str, machine: str = "kid300") -> ModeTable:
    """A blind truth (blind.make_case's of ``seed`` and ``effect``) as a bench's modal software would tabulate a
    noise-free test of it: its rig's complex modes at the four corners of the harness's sensor layout
    (Rig.mode_table). The worked example examples/kid300-bench-modes.unv is uff_modes.write_table of seed 20's
    belt, the truth of examples/kid300-blind-belt.json."""
    _, t = blind.make_case(seed, effect, machine=machine)
    tm = TruthMachine.of(machine)
    corners = list(dict.fromkeys(tuple(map(float, r)) for _, r, _ in sensor_layout(tm)))
    return Rig.from_matrices(machine, *truth_matrices(tm, t)).mode_table(corners)


def _written(
    seed: int, truth: str, machine: str, folder: Path, noise: float, level: float | None = None
) -> tuple[Path, tuple[str, ...]]:
    """record_campaign's file and the channels its truth mounts otherwise than the records state."""
    data, t = blind.make_case(seed, truth, machine=machine)
    tm = TruthMachine.of(machine)
    stated, mounted = (
        {name: (tuple(map(float, r)), tuple(map(float, d))) for name, r, d in layout}
        for layout in (sensor_layout(tm), mounted_layout(tm, t))
    )
    # as they are mounted: a sensor truth reads otherwise than the record states
    sensors = [Sensor(name, r, d, noise=noise) for name, (r, d) in mounted.items()]
    rate = max(200.0, 20.0 * tm.highest_frequency / (2 * math.pi))
    peak = 2000.0 * tm.mass(tm.nominal) / 838.6  # the rig's 2 kN hit on the KID-300, scaled by the mass

    def hammer(k: int, force: float) -> Hammer:  # at the stated corner
        return Hammer(stated[sensors[3 * k].name][0], HITS[k], peak=force * peak)

    reference = _largest_deformation(machine, tm, t, hammer(0, 1.0))

    def hits(truth_at: Truth, force: float, tag: str, first: int) -> list[dict]:
        rig = Rig.from_matrices(machine, *truth_matrices(tm, truth_at), hardening(tm, truth_at, reference))
        records = []
        for k in range(len(HITS)):
            hit = hammer(k, force)
            name = f"{machine}-{truth}-{seed}-{tag}{k}.csv"
            record = rig.simulate(sensors, DURATION, rate, hammers=[hit], seed=seed * 10 + first + k)
            channels = tuple(replace(c, point=stated[c.name][0], direction=stated[c.name][1]) for c in record.channels)
            write_csv(replace(record, channels=channels), folder / name)
            records.append({"file": name, "start": 0.1 + 20.0 / rate})
        return records

    out = {"machine": machine, "known": data["known"], "records": hits(t, 1.0, "", 0)}
    if level is not None:  # hardening isolators stiffen by their law at the level's force (as in make_case)
        hardens = "nonlinear_isolator" in t.effect.split("+")
        at_level = t if hardens else blind.at_other_level(t, blind.level_rng(seed))
        out["levels"] = [{"name": f"hit at {level:g} times the force", "records": hits(at_level, level, "level", 5)}]
    path = folder / f"{machine}-{truth}-{seed}.json"
    path.write_text(json.dumps(out), encoding="utf-8")
    return path, tuple(name for name in mounted if mounted[name] != stated[name])


def _largest_deformation(machine: str, tm: TruthMachine, t: Truth, hit: Hammer) -> float:
    """The largest deformation [m] along any isolator's local axis in the response of the truth's linear rubber
    to the hit, over one and a half periods of its slowest mode after it (where the free decay peaks): the
    deformation at which a hardening isolator of the truth stiffens by its ``gamma`` (blind_truth.hardening).
    NaN for other truths."""
    found = hardening(tm, t, 1.0)
    if found is None:
        return math.nan
    rig = Rig.from_matrices(machine, *truth_matrices(tm, t))
    slowest = float(np.min(np.abs(rig.poles)))
    fastest = float(np.max(np.abs(rig.poles)))
    step = min(hit.duration / 64, 2 * math.pi / fastest / 64)
    time = np.arange(0.0, hit.time + hit.duration + 3 * math.pi / slowest, step)
    q, _, _ = rig.respond(time, rig.forcing([hit])(time))
    return float(np.max(np.abs(q @ found.deformation.T)))


def run_record_case(
    seed: int, truth: str, machine: str, folder: Path, noise: float = RECORD_NOISE, level: float | None = None
) -> RecordCase:
    """Diagnose one truth from its records (record_campaign, ``level`` as there)."""
    path, misread = _written(seed, truth, machine, folder, noise, level)
    try:
        found = campaign_module.load(path)
        report = diagnose(found).effects
    except InputError as err:
        return RecordCase(truth, machine, seed, "error", None, math.nan, False, (), (), (), str(err), misread=misread)
    best = report.best
    close = tuple(w.describe() for w in found.record_warnings if w.kind in ("close_modes", "unresolved_modes"))
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
        close,
        acceptable=acceptable,
        misread=misread,
        sensor_suspects=tuple(w.suspects for w in found.record_warnings if w.kind == "sensor"),
        verdict=report.verdict,
        levels_move=report.levels_move,
    )
