"""Blind validation of the gap diagnosis: synthetic campaigns from a higher-fidelity truth
(:mod:`mountid.validation.blind_truth`, in and outside the catalogue), and a scorer.

The diagnosis sees a campaign file's content only: frequencies with their uncertainty and mode shapes in
q with theirs. Which effect was injected, and its size, stay here.
"""

from __future__ import annotations

import itertools
import math
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from mountid.diagnosis import campaign as campaign_module
from mountid.diagnosis.candidates import (
    STATING_KINDS,
    EffectsReport,
    diagnose_effects,
    effect_dof,
    fits_within_uncertainty,
    ratio_counts,
)
from mountid.diagnosis.settings import DIAGNOSIS
from mountid.effects import CATALOGUE, EFFECTS
from mountid.errors import InputError
from mountid.identification.labelling import same_modes
from mountid.machine import Machine
from mountid.measurement.modes import scaled_unit
from mountid.validation.blind_truth import (
    DRAWN_AS,
    OUTSIDE_BESIDE,
    REPRESENTED_BESIDE,
    REPRESENTED_BY,
    REVERSED_BESIDE,
    Truth,
    TruthMachine,
    represented_by,
    sample,
    sensor_layout,
    true_damping_ratios,
    true_modes,
)

MACHINES: tuple[str, ...] = ("kid300", "kid300axes", "rectangular", "screen6", "genset8", "skid1plane")
"""The shipped descriptions the harness draws machines of (each truth is diagnosed with its own description)."""

EFFECT_NAMES: tuple[str, ...] = (
    "none",
    *(e.name for e in CATALOGUE if e.name not in DRAWN_AS and e.name not in REPRESENTED_BESIDE.values()),
    *REPRESENTED_BY,
)
"""The truths of the benchmark's cycle: none, one per catalogue effect (but those drawn as a truth of other physics,
blind_truth.DRAWN_AS, and those whose truth lies beside the cycle, blind_truth.REPRESENTED_BESIDE), and the truths of
other physics."""
TRUTHS: tuple[str, ...] = (*EFFECT_NAMES, *REVERSED_BESIDE, *OUTSIDE_BESIDE, *REPRESENTED_BESIDE)
"""Every truth make_case draws: the benchmark's cycle (EFFECT_NAMES), then the studies beside it of a reversed
channel beside a physical effect (blind_truth.REVERSED_BESIDE), of truths outside the catalogue
(blind_truth.OUTSIDE_BESIDE) and of truths represented by an effect added since the cycle was fixed
(blind_truth.REPRESENTED_BESIDE)."""
FREQUENCY_STD = 3e-4
"""Relative standard deviation of the synthetic frequencies (a 20 s record, see the records issue)."""
SHAPE_STD = 0.01
"""Standard deviation per component of the synthetic unit shapes."""


CAMPAIGN_KINDS: tuple[str, ...] = ("shapes", "frequencies", "damping")
"""What a blind campaign measures: six frequencies with mode shapes; six frequencies only; six frequencies
with their damping ratios (true modal damping of the truth's B, 2 % relative noise)."""
DAMPING_STD = 0.02
"""Relative standard deviation of the synthetic damping ratios."""

LEVEL_RUBBER = 0.1
"""A campaign's frequencies at another excitation level (make_case's ``level``) come, for every truth but
hardening isolators, from the truth with each unknown stiffness changed by a factor exp(u), u uniform within
+-LEVEL_RUBBER (drawn apart for each): filled rubber's dynamic stiffness moves by several percent between hits
of different force, alike in every mode, which the diagnosis must not mistake for an amplitude dependence no
linear model represents (mountid.diagnosis.levels)."""


def level_rng(seed: int) -> np.random.Generator:
    """The draws of the truth of ``seed`` at another excitation level (its rubber, then the level's noise)."""
    return np.random.default_rng(seed + 2_000_003)


def at_other_level(t: Truth, rng: np.random.Generator) -> Truth:
    """The linear truth ``t`` at another excitation level: each unknown stiffness changed by a factor exp(u), u
    uniform within +-LEVEL_RUBBER (rubber whose stiffness depends on the amplitude alike in every mode)."""
    return replace(
        t, unknowns={u: v * math.exp(rng.uniform(-LEVEL_RUBBER, LEVEL_RUBBER)) for u, v in t.unknowns.items()}
    )


NOMINAL_SOURCES: tuple[str, ...] = ("description", "identified")
"""Where a blind campaign's fits start (make_case): the description's nominal values of the unknowns, or the
identification on the measured frequencies (campaign "nominal": "identified")."""


def make_case(
    seed: int,
    effect: str,
    noise: bool = True,
    kind: str = "shapes",
    machine: str = "kid300",
    nominal: str = "description",
    level: float | None = None,
) -> tuple[dict, Truth]:
    """A campaign (as its JSON data) of ``kind`` (CAMPAIGN_KINDS) on the shipped ``machine`` and the hidden
    truth for one seed and injected effect: the unknowns within 20 % of their nominal values, the known values
    as described. ``nominal``: where the diagnosis starts, the "description"'s nominal values of the unknowns or
    those "identified" from the measured frequencies (a description that gives none). ``level``: the six
    frequencies measured again with the machine hit at this many times the force (the campaign's ``levels``;
    their own noise, drawn apart so that the rest of the campaign is the same with and without them): hardening
    isolators (``nonlinear_isolator``) stiffen by their law at that level, every other truth's isolators by
    LEVEL_RUBBER at most in each unknown stiffness, alike in every mode."""
    if nominal not in NOMINAL_SOURCES:
        raise ValueError(f"nominal {nominal!r} is not one of {NOMINAL_SOURCES}")
    if kind not in CAMPAIGN_KINDS:
        raise ValueError(f"campaign kind {kind!r} is not one of {CAMPAIGN_KINDS}")
    rng = np.random.default_rng(seed)
    model = Machine.resolve(machine)
    undiagnosable = undiagnosable_because(model)
    if undiagnosable:
        raise InputError("machine", undiagnosable)
    tm = TruthMachine.of(machine)
    unmeasured = unmeasured_because(tm, kind)
    if unmeasured:
        raise InputError("kind", f"{tm.name}: {unmeasured}")
    size = sample(rng, effect, tm)
    t = Truth(effect, size, {u: tm.nominal[u] * rng.uniform(0.8, 1.2) for u in tm.unknown}, machine)
    omega, shapes = true_modes(tm, model, t)
    zeta = true_damping_ratios(tm, model, t)
    noise_rng = np.random.default_rng(seed + 1_000_003)
    modes = {}
    unit = scaled_unit(shapes, tm.length)
    for i, label in enumerate(model.modes):
        modes[label] = _measured_frequency(omega[i], noise_rng, noise)
        s = unit[:, i] + (SHAPE_STD * noise_rng.standard_normal(6) if noise else 0.0)
        s[3:] /= tm.length
        z = zeta[i] * (1 + (DAMPING_STD * noise_rng.standard_normal() if noise else 0.0))
        if kind == "shapes":
            modes[label] |= {"shape": [float(x) for x in s], "shape_uncertainty": SHAPE_STD}
        elif kind == "damping":
            modes[label] |= {"damping_ratio": float(z), "damping_uncertainty": float(DAMPING_STD * zeta[i])}
    # a test engineer knows the machine's build but not its isolators' damping: campaigns that measure damping
    # ratios leave the damping parameters to the fit
    damping = set(tm.damping_parameters) if kind == "damping" else set()
    known = {k: tm.nominal[k] for k in tm.known if k not in damping}
    data = {"name": f"blind case {seed}", "machine": machine, "known": known, "modes": modes}
    if level is not None:
        drawn = level_rng(seed)
        if "nonlinear_isolator" in t.effect.split("+"):
            at_level, level_shapes = true_modes(tm, model, t, level)
        else:
            at_level, level_shapes = true_modes(tm, model, at_other_level(t, drawn))
        at_level = at_level[same_modes(unit, scaled_unit(level_shapes, tm.length))]
        data["levels"] = [
            {
                "name": f"hit at {level:g} times the force",
                "modes": {
                    label: _measured_frequency(w, drawn, noise) for label, w in zip(model.modes, at_level, strict=True)
                },
            }
        ]
    if nominal == "identified":
        data["nominal"] = "identified"
    if kind == "shapes":  # the layout the shapes were estimated from
        data["sensors"] = [
            {"name": name, "point": [float(x) for x in r], "direction": [float(x) for x in d]}
            for name, r, d in sensor_layout(tm)
        ]
    return data, t


def _measured_frequency(omega: float, rng: np.random.Generator, noise: bool) -> dict[str, float]:
    """A campaign's entry for a true frequency ``omega`` [rad/s]: measured with FREQUENCY_STD relative noise (one
    draw of ``rng``; none without ``noise``) and that uncertainty."""
    w = omega * (1 + (FREQUENCY_STD * rng.standard_normal() if noise else 0.0))
    return {"frequency": float(w), "uncertainty": float(FREQUENCY_STD * omega)}


def example(seed: int, effect: str, machine: str = "kid300", kind: str = "shapes", level: float | None = None) -> dict:
    """A blind case as a campaign file's data (the worked examples in examples/): make_case's campaign with a
    name that says the truth is hidden."""
    data, _ = make_case(seed, effect, kind=kind, machine=machine, level=level)
    return {**data, "name": f"blind case {seed} on {machine}, {kind} (truth hidden)"}


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
    |held-out frequency error| / sigma; nan without a significant gap, or where the nominal model's held-out
    median is within DiagnosisSettings.significance: no held-out frequency gap to reduce)."""
    kind: str = ""
    """The verdict's kind (candidates.EffectsReport.kind)."""
    probability: float = math.nan
    """The posterior probability the diagnosis gave its first-ranked candidate."""
    campaign: str = "shapes"
    """What the campaign measured (CAMPAIGN_KINDS)."""
    machine: str = "kid300"
    """The shipped description the truth was built from and diagnosed with."""
    acceptable: tuple[str, ...] | None = None
    """The candidates counted right: the one that represents the truth, and for a truth of several parts each
    part's that alone explains the noise-free data within their uncertainty (None: the representing one)."""
    testable: bool = True
    """Whether the campaign can test the candidate that represents the truth at all: it has fewer parameters
    (with the unknowns) than the campaign has data, a pair DiagnosisSettings.pair_dof fewer (six frequencies
    cannot test a support of six parameters); measured damping ratios and the damping parameters left to the
    fit count apart from the rest (they determine each other, not an effect on M and C)."""
    seed: int = -1
    weights: tuple[tuple[str, float], ...] = ()
    """Log posterior weight of the nominal model ('none') and every ranked candidate (for studies of the
    probabilities' calibration)."""
    fit_terms: tuple[tuple[str, float], ...] = ()
    """-chi^2 / 2 of the nominal model ('none') and every ranked candidate, with the variances the probabilities
    were taken with (candidates.EffectsReport.misfit_scale): the part of each log weight the fit holds, the rest
    being its Occam factor and prior odds."""
    alike: tuple[str, ...] = ()
    """The candidates in the tie that the data fit as well as the first-ranked one (candidates.alike: the order
    between them rests on the priors); empty unless the verdict is confident or a tie."""
    verdict: str = ""
    """The verdict as the report states it (candidates.EffectsReport.verdict)."""

    @property
    def expected(self) -> str | None:
        """The catalogue effect (or pair) that represents the truth (None outside the catalogue)."""
        return represented_by(self.truth)

    @property
    def in_catalogue(self) -> bool:
        return self.expected is not None

    @property
    def right_answers(self) -> tuple[str, ...]:
        if self.acceptable is not None:
            return self.acceptable
        return (self.expected,) if self.expected is not None else ()

    @property
    def right(self) -> bool:
        """The first-ranked candidate is one counted right (right_answers)."""
        return bool(self.ranked) and self.ranked[0] in self.right_answers

    @property
    def confident_and_wrong(self) -> bool:
        return self.confident and not self.right


def can_test(candidate: str, n_data: int, n_unknowns: int, n_ratios: int = 0, n_free_damping: int = 0) -> bool:
    """Whether a campaign of ``n_data`` data for ``n_unknowns`` unknowns can test ``candidate`` (an effect or a
    pair 'a+b') at all: the data exceed the parameters by one, a pair's by DiagnosisSettings.pair_dof. Measured
    damping ratios (``n_ratios``) carry the damping parameters left to the fit (``n_free_damping``) and next to
    nothing of an effect on M and C, so both count apart: six frequencies and six ratios cannot test a
    six-parameter support of a machine with three unknown stiffnesses and three unknown damping coefficients,
    as six frequencies alone cannot."""
    names = candidate.split("+")
    k = n_unknowns + sum(len(EFFECTS[name].parameters) for name in names)
    spare = effect_dof(n_data, k, n_ratios, n_free_damping, "damping" in names)
    return spare >= (DIAGNOSIS.pair_dof if len(names) > 1 else 1)


def noise_free_diagnosis(
    seed: int,
    effect: str,
    kind: str,
    machine: str,
    nominal: str = "description",
    warm: EffectsReport | None = None,
    level: float | None = None,
) -> EffectsReport:
    """The candidates diagnosed on the truth of ``seed`` without noise (make_case with noise=False), the fits
    started from ``warm`` (a report on the same truth with noise) where given."""
    clean, _ = make_case(seed, effect, noise=False, kind=kind, machine=machine, nominal=nominal, level=level)
    return diagnose_effects(campaign_module.parse(clean), warm=warm, exact_held_out=False, other_roots=False)


def acceptable_parts(effect: str, ideal: EffectsReport) -> tuple[str, ...]:
    """The candidates counted right for a truth of several parts: the one that represents the whole truth and
    each part's that alone explains the noise-free data within their uncertainty (``ideal``:
    noise_free_diagnosis)."""
    fits = {f.effect: f for f in ideal.ranked}
    expected = represented_by(effect)
    alone = [represented_by(p) for p in effect.split("+")]
    return (
        *((expected,) if expected else ()),
        *(a for a in alone if a in fits and fits_within_uncertainty(fits[a])),
    )


def run_case(
    seed: int,
    effect: str,
    kind: str = "shapes",
    machine: str = "kid300",
    nominal: str = "description",
    level: float | None = None,
) -> CaseResult:
    """Diagnose one blind case. On the same truth without noise: identifiability (the gap is significant there
    and the effect that represents the truth has the posterior probability of a confident verdict), and for a
    truth of several parts which parts alone explain the data (fit them within their uncertainty). ``nominal``
    and ``level``: as make_case."""
    data, _ = make_case(seed, effect, kind=kind, machine=machine, nominal=nominal, level=level)
    campaign = campaign_module.parse(data)
    report = diagnose_effects(campaign)
    ranked = tuple(f.effect for f in report.ranked if f.applicable)
    identifiable = False
    expected = represented_by(effect)
    acceptable = None
    parts = effect.split("+")
    if effect != "none" and (expected is not None or len(parts) > 1):
        ideal = noise_free_diagnosis(seed, effect, kind, machine, nominal, warm=report, level=level)
        fits = {f.effect: f for f in ideal.ranked}
        truth = fits.get(expected) if expected is not None else None
        identifiable = bool(ideal.significant and truth is not None and truth.probability >= DIAGNOSIS.confidence)
        if len(parts) > 1:
            acceptable = acceptable_parts(effect, ideal)
    testable = True
    if expected not in (None, "none"):
        counts = ratio_counts(campaign, report.nominal.parameters)
        testable = can_test(expected, report.nominal.n_data, report.nominal.n_parameters, *counts)
    reduction = math.nan
    best = report.best
    if report.significant and best is not None:
        before, after = report.nominal.held_out_median, best.held_out_median
        # a gap to reduce: the nominal model misses the held-out frequencies beyond DiagnosisSettings.significance
        # (an effect on the shapes alone, a turned sensor, leaves them within their noise before and after)
        if math.isfinite(before) and math.isfinite(after) and before > DIAGNOSIS.significance:
            reduction = 1 - after / before
    return CaseResult(
        effect,
        ranked,
        tuple(report.tie),
        report.significant,
        report.confident,
        identifiable,
        reduction,
        report.kind,
        best.probability if best is not None else math.nan,
        kind,
        machine,
        acceptable,
        testable,
        seed,
        (("none", report.nominal.log_weight), *((f.effect, f.log_weight) for f in report.ranked)),
        tuple((f.effect or "none", -0.5 * f.chi2 / report.misfit_scale) for f in (report.nominal, *report.ranked)),
        tuple(s.rival for s in report.alike()),
        report.verdict,
    )


def cases(
    n: int,
    first_seed: int = 0,
    kinds: tuple[str, ...] = ("shapes",),
    machines: tuple[str, ...] = ("kid300",),
    truths: tuple[str, ...] = EFFECT_NAMES,
) -> list[tuple[int, str, str, str]]:
    """n cases per campaign kind and machine cycling through ``truths`` (by default 'none', every effect of the
    catalogue and every truth of other physics; REVERSED_BESIDE for the study of a reversed channel beside a
    physical effect): (seed, truth, kind, machine); a seed gives the same truth in every kind. A machine without
    damping (a description of one's own) has no campaigns of damping ratios (measures_kind)."""
    unknown = [t for t in truths if t not in TRUTHS]
    if unknown or not truths:
        raise InputError("truths", f"no blind truth {', '.join(unknown)}" if unknown else "no truth given")
    return [
        (first_seed + i, truths[i % len(truths)], k, m)
        for m in machines
        for k in kinds
        if measures_kind(m, k)
        for i in range(n)
    ]


def measures_kind(machine: str, kind: str) -> bool:
    """Whether the blind harness draws campaigns of ``kind`` on ``machine`` (unmeasured_because says why not)."""
    return unmeasured_because(TruthMachine.of(machine), kind) is None


def undiagnosable_because(machine: Machine) -> str | None:
    """Why no blind campaign on ``machine`` can be diagnosed (None: they can): its distinct modes are fewer than a
    campaign that fits all but one of them in turn must measure (campaign.frequencies_needed), as on a machine
    with as many unknowns as modes. The harness does not draw campaigns that name the frequencies to fit."""
    need = campaign_module.frequencies_needed(machine)
    have = len(machine.unique_modes)
    if have >= need:
        return None
    return (
        f"{machine.name} has {have} distinct modes for {len(machine.unknown)} unknowns: the blind campaigns hold "
        f"one frequency out of the fit in turn ({need} needed); only a campaign that names the frequencies to fit "
        '("fit") can be diagnosed on it, from its mode shapes'
    )


def unmeasured_because(tm: TruthMachine, kind: str) -> str | None:
    """Why the blind harness draws no campaigns of ``kind`` on the machine ``tm`` (None: it draws them): damping
    ratios on a machine without damping would measure zeros (make_case refuses them)."""
    if kind == "damping" and not tm.damping_parameters:
        return "the machine has no damping: a campaign of damping ratios would measure zeros"
    return None


RELIABILITY_BINS = (0.0, 0.5, 0.8, 0.95, 0.99, 1.0 + 1e-12)
"""Bins of the stated probability of the first-ranked candidate for the reliability table."""


@dataclass(frozen=True)
class Score:
    n: int
    top1_identifiable: float
    top2_identifiable: float
    n_identifiable: int
    truth_in_tie: float
    n_detected: int
    median_reduction: float
    rms_reduction: float
    confident_on_none: int
    n_none: int
    confident_and_wrong: int
    confident_outside: int
    honest_outside: float
    """Share of the out-of-catalogue cases with a detected gap that end "not explained" or in a tie."""
    n_outside_detected: int
    reliability: tuple[tuple[float, float, int, float, float], ...]
    """Per bin of stated probability (lower, upper, count, mean stated, observed share right), over the truths
    the catalogue represents (the probabilities are conditional on the catalogue; truths outside it are scored by
    the honesty of their verdicts)."""
    calibration_error: float
    """Mean over the non-empty bins of |mean stated probability - observed share right| (the reliability table's
    truths)."""
    confusion: dict[str, Counter]
    campaign: str = "shapes"
    """What the scored campaigns measured (CAMPAIGN_KINDS)."""
    calibration_error_all: float = math.nan
    """The same over every truth, those outside the catalogue included (always counted wrong there unless a part
    of the truth alone explains the data)."""
    weighted_calibration_error: float = math.nan
    """Mean of |stated - observed| weighted by the bins' counts (the expected calibration error)."""
    mean_tie: float = math.nan
    """Mean number of candidates in the reported tie over the cases with a significant gap."""
    calibration_floor: float = math.nan
    """The calibration error a perfectly calibrated diagnosis would show on average with the same stated
    probabilities and counts (right with probability equal to the one stated; CALIBRATION_DRAWS draws): the
    sampling noise of calibration_error. With a few dozen verdicts it exceeds 0.05."""
    calibration_p: float = math.nan
    """Share of those draws whose calibration error is at least the observed one: small (< 0.05) when the
    observed error is more than sampling noise, i.e. evidence that the probabilities are miscalibrated. Pooled
    over machines, whose verdicts share seeds, the draws are widened by the design effect (design_effect)."""
    by_candidate: tuple[tuple[str, int, float, float, float], ...] = ()
    """The reliability table's verdicts per first-ranked candidate (candidate, verdicts, mean stated, observed
    share right, p: how often a perfectly calibrated diagnosis is as far off; _by_candidate): where the
    probabilities miss, which candidate's they are. With a dozen candidates tested, one p below 0.05 is
    expected by chance."""
    log_loss: float = math.nan
    """Mean of -ln(stated probability) over the reliability table's verdicts where the first-ranked candidate is
    right and -ln(1 - stated) where it is wrong (stated probabilities kept within LOG_LOSS_FLOOR of 0 and 1): a
    proper score, lowest only for probabilities that are both calibrated and sharp. The binned calibration
    error can fall while the probabilities say less (stated flatter over verdicts the ranking could tell
    apart); a change is better only where this does not rise."""
    brier: float = math.nan
    """Mean of (stated probability - 1 if right else 0)^2 over the same verdicts: the proper score that a single
    confident and wrong verdict moves least."""
    by_basis: tuple[tuple[str, int, float, float, float], ...] = ()
    """The reliability table's verdicts by what the first place rests on (_by_basis; rows as by_candidate): the
    priors where a rival in the tie fits the data as well as the first-ranked candidate, else the data."""
    design_effect: float = 1.0
    """How much verdicts that share a seed (one truth drawn for every machine) widen the calibration error's
    sampling noise (_design_effect): 1 for one machine, where every verdict has its own seed; calibration_floor
    and calibration_p widen each bin's drawn departure by its square root."""

    @property
    def wrong_limit(self) -> float:
        """Largest share of confident-and-wrong verdicts the targets allow: 2 % on frequency-only campaigns
        (fewer data, more alike candidates), 1 % otherwise."""
        return 0.02 if self.campaign == "frequencies" else 0.01

    def missed(self) -> list[str]:
        """The issue's targets this score misses (the in-catalogue ones where the data identify the effect); a
        calibration error above 0.05 is marked 'within noise' where a perfectly calibrated diagnosis shows as
        much in 5 % of its draws or more (calibration_p)."""
        checks = {
            "top-1": self.top1_identifiable >= 0.9,
            "in tie": self.truth_in_tie >= 0.98,
            "c&w": self.confident_and_wrong <= self.wrong_limit * self.n,
            "c none": self.confident_on_none == 0,
            "c out": self.confident_outside == 0,
            "honest": self.honest_outside >= 0.9,
            "calib.": self.calibration_error <= 0.05,
            "reduct.": self.median_reduction >= 0.8,
        }
        out = []
        for name, ok in checks.items():
            if ok:
                continue
            if _nan(name, self):  # a rate over no case: the target cannot be shown here
                out.append(f"{name} (no case)")
            elif name == "calib." and self.calibration_p >= 0.05:
                out.append(f"calib. (within noise, p {self.calibration_p:.2f})")
            else:
                out.append(name)
        return out

    @property
    def targets_met(self) -> bool:
        """Every target of the issue holds (missed() is empty)."""
        return not self.missed()

    def text(self) -> str:
        lines = [
            f"campaigns measuring {self.campaign}: {self.n} blind cases ({self.n_none} without an injected effect, "
            f"{sum(sum(row.values()) for t, row in self.confusion.items() if represented_by(t) is None)} outside "
            "the catalogue)",
            (
                f"top-1 on identifiable cases: {self.top1_identifiable:.1%} (target >= 90%), "
                f"top-2: {self.top2_identifiable:.1%}, identifiable: {self.n_identifiable}"
                if self.n_identifiable
                else "top-1 on identifiable cases: none is identifiable (the target cannot be shown)"
            ),
            f"truth inside the reported tie: {self.truth_in_tie:.1%} of {self.n_detected} in-catalogue cases with a "
            "detected gap that the campaign can test (target >= 98%)",
            f"held-out gap reduction: median {self.median_reduction:.1%} (target >= 80%), RMS {self.rms_reduction:.1%}",
            f"confident and wrong: {self.confident_and_wrong} of {self.n} (target <= {self.wrong_limit:.0%}); "
            "on cases without an effect: "
            f"{self.confident_on_none} of {self.n_none} (target 0); outside the catalogue: {self.confident_outside} "
            "(target 0)",
            f"outside the catalogue, 'not explained' or a tie: {self.honest_outside:.1%} of "
            f"{self.n_outside_detected} with a detected gap (target >= 90%)",
            f"mean size of the reported tie: {self.mean_tie:.2f} candidates",
            f"reliability of the stated probability of the first-ranked candidate, truths the catalogue represents "
            f"(calibration error {self.calibration_error:.3f}, target <= 0.05; weighted by the bins' counts "
            f"{self.weighted_calibration_error:.3f}; over every truth {self.calibration_error_all:.3f}; a perfectly "
            f"calibrated diagnosis would show {self.calibration_floor:.3f} on average at these counts"
            + (
                f" (widened by the seeds shared between machines, design effect {self.design_effect:.2f})"
                if self.design_effect != 1
                else ""
            )
            + ", and "
            f"{self.calibration_p:.0%} of its draws as much as observed; proper scores of the same verdicts: log "
            f"loss {self.log_loss:.3f}, Brier {self.brier:.3f}):",
            f"  {'stated':>13} {'cases':>6} {'mean stated':>12} {'observed':>9}",
        ]
        for lo, hi, count, stated, observed in self.reliability:
            lines.append(f"  [{lo:4.2f}, {min(hi, 1.0):4.2f}) {count:6d} {stated:12.3f} {observed:9.3f}")
        if self.by_basis:
            lines.append(
                "the same by what the first place rests on (the priors where the data fit a rival in the tie as "
                "well, DiagnosisSettings.fit_alike; p as below):"
            )
            lines.append(f"  {'first place rests on':>38} {'cases':>6} {'mean stated':>12} {'observed':>9} {'p':>6}")
            for name, count, stated, observed, p in self.by_basis:
                lines.append(f"  {name:>38} {count:6d} {stated:12.3f} {observed:9.3f} {p:6.3f}")
        shown = [row for row in self.by_candidate if row[1] >= BY_CANDIDATE_MINIMUM]
        if shown:
            lines.append(
                f"the same per first-ranked candidate, ranked first in {BY_CANDIDATE_MINIMUM} verdicts or more (p: "
                "share of a perfectly calibrated diagnosis's draws as far from the stated mean):"
            )
            lines.append(f"  {'first-ranked':>38} {'cases':>6} {'mean stated':>12} {'observed':>9} {'p':>6}")
            for name, count, stated, observed, p in shown:
                lines.append(f"  {name[:38]:>38} {count:6d} {stated:12.3f} {observed:9.3f} {p:6.3f}")
        # the benchmark's cycle in its order, then any other truth scored (REVERSED_BESIDE)
        lines += self.confusion_lines([*EFFECT_NAMES, *sorted(set(self.confusion) - set(EFFECT_NAMES))])
        return "\n".join(lines)

    def confusion_lines(self, truths: list[str]) -> list[str]:
        """The confusion matrix's head and its rows of ``truths`` (a truth not scored: a row of zeros)."""
        cols = ["-", "?", *(e.name for e in CATALOGUE), "pair"]
        lines = [
            "confusion (rows: injected; columns: ranked first, '-' no significant gap, '?' not explained, "
            "'pair' two effects):",
            " " * 28 + " ".join(f"{_short(c):>6}" for c in cols),
        ]
        for truth in truths:
            row = self.confusion.get(truth, Counter())
            lines.append(f"{truth[:27]:>27} " + " ".join(f"{row.get(c, 0):>6}" for c in cols))
        return lines


def _nan(target: str, s: Score) -> bool:
    """Whether the rate a target is judged on was taken over no case."""
    value = {
        "top-1": s.top1_identifiable,
        "in tie": s.truth_in_tie,
        "honest": s.honest_outside,
        "calib.": s.calibration_error,
        "reduct.": s.median_reduction,
    }.get(target, 0.0)
    return math.isnan(value)


def _short(name: str) -> str:
    """A column head of six characters: the first three letters of each of two words (sensor_error -> senerr), the
    first two of each of the first three of three words or more (sensor_turned_misplaced -> setumi, apart from
    sensor_turned's sentur)."""
    words = name.split("_")
    if len(words) == 1:
        return name[:6]
    return words[0][:3] + words[1][:3] if len(words) == 2 else "".join(w[:2] for w in words[:3])


CALIBRATION_DRAWS = 2000
"""Draws of a perfectly calibrated diagnosis for the calibration error's sampling noise (Score.calibration_floor)."""

BY_CANDIDATE_MINIMUM = 10
"""Score.text lists a candidate's reliability (Score.by_candidate) when it is ranked first in this many verdicts
or more."""


def _stating(results: list[CaseResult]) -> list[CaseResult]:
    """The verdicts that state a probability of their first-ranked candidate: confident or a tie (a "not
    explained" verdict says the catalogue's probabilities do not apply)."""
    return [
        r for r in results if r.significant and r.ranked and r.kind in STATING_KINDS and math.isfinite(r.probability)
    ]


def _stated(verdicts: list[CaseResult]) -> tuple[np.ndarray, np.ndarray]:
    """Stated probability of the first-ranked candidate and whether it is right (1.0 or 0.0), of each of
    ``verdicts`` (already those that state a probability: _stating)."""
    return np.array([r.probability for r in verdicts], dtype=float), np.array([r.right for r in verdicts], dtype=float)


LOG_LOSS_FLOOR = 1e-9
"""Stated probabilities enter the log loss within this of 0 and 1: a verdict stated at 1 to the last digit and
wrong costs 20.7 (ln 1e9), not infinity."""


def _proper_scores(results: list[CaseResult]) -> tuple[float, float]:
    """Log loss and Brier score of the stated probability of the first-ranked candidate over the verdicts that
    state one (_stating; nan without any)."""
    stated, right = _stated(_stating(results))
    if not len(stated):
        return math.nan, math.nan
    p = np.clip(stated, LOG_LOSS_FLOOR, 1 - LOG_LOSS_FLOOR)
    log_loss = float(np.mean(-np.log(np.where(right > 0, p, 1 - p))))
    return log_loss, float(np.mean((stated - right) ** 2))


def _by_candidate(results: list[CaseResult], draws: int = CALIBRATION_DRAWS) -> tuple[tuple, ...]:
    """Reliability per first-ranked candidate over the verdicts that state a probability (_stating): rows
    (candidate, verdicts, mean stated probability, observed share right, p), most verdicts first (_by_group)."""
    return _by_group(results, lambda r: r.ranked[0], draws)


BASIS_PRIORS = "the priors (a rival fits alike)"
BASIS_DATA = "the data (no rival fits alike)"
BASES = (BASIS_DATA, BASIS_PRIORS)
"""What a first place can rest on, in the order the reliability diagram draws them."""


def _basis(r: CaseResult) -> str:
    """What the first place rests on: BASIS_PRIORS where a rival in the tie fits the data as well
    (CaseResult.alike), else BASIS_DATA."""
    return BASIS_PRIORS if r.alike else BASIS_DATA


def _by_basis(results: list[CaseResult], draws: int = CALIBRATION_DRAWS) -> tuple[tuple, ...]:
    """Reliability by what the first place rests on (_basis, _by_group)."""
    return _by_group(results, _basis, draws)


def reliability_panels(
    results: list[CaseResult], prefix: str = ""
) -> dict[str, dict[str, tuple[np.ndarray, np.ndarray]]]:
    """The reliability table's verdicts (truths the catalogue represents, verdicts that state a probability) as
    stated probabilities and outcomes (1 right, 0 wrong) per campaign kind (``prefix`` before its name), split
    by what the first place rests on (_basis): the panels of mountid.report.figures.reliability_figure."""
    panels = {}
    for kind in CAMPAIGN_KINDS:
        mine = [r for r in results if r.campaign == kind and r.in_catalogue]
        if _stating(mine):
            panels[f"{prefix}{kind}"] = {
                basis: _stated(_stating([r for r in mine if _basis(r) == basis])) for basis in BASES
            }
    return panels


def _by_group(
    results: list[CaseResult], group: Callable[[CaseResult], str], draws: int = CALIBRATION_DRAWS
) -> tuple[tuple, ...]:
    """Reliability per ``group`` (of a case result) over the verdicts that state a probability (_stating): rows
    (group, verdicts, mean stated probability, observed share right, p), most verdicts first. ``p``: the share
    of ``draws`` of a perfectly calibrated diagnosis (each verdict right with its stated probability, a fixed
    seed) whose share right is at least as far from the mean stated as the observed one (two-sided), the drawn
    departures widened by the square root of the group's design effect (_design_effect: verdicts sharing a seed),
    never narrowed: a group's shares right lie on a lattice, and draws narrowed by an estimate below 1 miss the
    observed share where it is the lattice's edge. Every verdict of a group right leaves the estimate nothing
    but the spread of the stated probabilities: 72 verdicts naming a belt, all right at a mean stated 0.959
    (a perfectly calibrated diagnosis gets all right in 4 % of its draws, is as far off in 10 %), read
    p = 0.006 at an estimate of 0.47 (a run of seeds 4000-4299 with shapes)."""
    verdicts = _stating(results)
    rng = np.random.default_rng(0)
    rows = []
    for name in sorted({group(r) for r in verdicts}):
        mine = [r for r in verdicts if group(r) == name]
        stated, right = _stated(mine)
        observed = float(np.mean(right))
        drawn = (rng.random((draws, len(mine))) < stated).mean(axis=1)
        effect = _design_effect(stated, right, [r.seed for r in mine], np.zeros(len(mine), dtype=int))
        widening = np.sqrt(max(effect, 1.0))
        distance = abs(observed - stated.mean())
        p = float(np.mean(widening * np.abs(drawn - stated.mean()) >= distance - 1e-12))
        rows.append((name, len(mine), float(stated.mean()), observed, p))
    return tuple(sorted(rows, key=lambda row: (-row[1], row[0])))


def _reliability_rows(stated: np.ndarray, right: np.ndarray) -> list[tuple[float, float, int, float, float]]:
    """Per non-empty bin of RELIABILITY_BINS: (lower, upper, count, mean stated, observed share right)."""
    rows = []
    for lo, hi in itertools.pairwise(RELIABILITY_BINS):
        inside = (stated >= lo) & (stated < hi)
        if inside.any():
            rows.append((lo, hi, int(inside.sum()), float(stated[inside].mean()), float(right[inside].mean())))
    return rows


def _calibration_error(rows: list[tuple[float, float, int, float, float]]) -> float:
    return float(np.mean([abs(a - b) for _, _, _, a, b in rows])) if rows else math.nan


def _reliability(
    results: list[CaseResult], draws: int = CALIBRATION_DRAWS
) -> tuple[tuple, float, float, float, float, float]:
    """The reliability table, its mean error over the bins, the mean weighted by the bins' counts, the error's
    sampling noise and the seeds' design effect (_design_effect). The noise: the mean error of a perfectly
    calibrated diagnosis with the same stated probabilities (outcomes drawn right with the stated probability,
    ``draws`` times with a fixed seed; nan without draws), each bin's departure widened by the square root of
    the design effect, and the share of those draws with an error at least the observed one."""
    verdicts = _stating(results)
    stated, right = _stated(verdicts)
    rows = _reliability_rows(stated, right)
    if not rows:
        return (), math.nan, math.nan, math.nan, math.nan, math.nan
    error = _calibration_error(rows)
    weighted = sum(n * abs(a - b) for _, _, n, a, b in rows) / sum(n for _, _, n, _, _ in rows)
    widening = _design_effect(stated, right, [r.seed for r in verdicts])
    if not draws:
        return tuple(rows), error, float(weighted), math.nan, math.nan, widening
    rng = np.random.default_rng(0)
    drawn = np.sqrt(widening) * np.array(
        [
            _calibration_error(_reliability_rows(stated, (rng.random(len(stated)) < stated).astype(float)))
            for _ in range(draws)
        ]
    )
    return tuple(rows), error, float(weighted), float(drawn.mean()), float(np.mean(drawn >= error - 1e-12)), widening


def _design_effect(stated: np.ndarray, right: np.ndarray, seeds: list[int], bins: np.ndarray | None = None) -> float:
    """How much verdicts that share a seed widen the sampling noise of the mean departure (right - stated) of
    each of ``bins`` (one bin index per verdict; by default the reliability table's): a seed draws one truth for
    every machine, so pooled over machines its verdicts are not independent. The ratio of the variance of the
    bins' summed departures taken seed by seed to the same taken verdict by verdict (the cluster-robust variance
    over the independent one; the departures centred in each bin, so that a miscalibration is not counted as
    noise): 1 where no two verdicts share a seed (a seed below 0 is unknown: its own), above 1 where a seed's
    verdicts tend to err together. An estimate from the verdicts themselves."""
    clusters = [s if s >= 0 else -1 - i for i, s in enumerate(seeds)]
    if len(set(clusters)) == len(clusters):
        return 1.0
    if bins is None:
        bins = np.digitize(stated, RELIABILITY_BINS[1:-1])
    departure = right - stated
    _, index = np.unique(bins, return_inverse=True)
    centred = departure - (np.bincount(index, departure) / np.bincount(index))[index]
    per_seed: Counter = Counter()
    for b, seed, value in zip(bins.tolist(), clusters, centred.tolist(), strict=True):
        per_seed[b, seed] += value
    independent = float(np.sum(centred**2))
    return sum(v * v for v in per_seed.values()) / independent if independent > 0 else 1.0


def _in_tie(r: CaseResult) -> bool:
    """A candidate counted right is in the reported tie, alone or as a member of a pair there."""
    return any(a in r.tie or any(a in t.split("+") for t in r.tie) for a in r.right_answers)


def score(results: list[CaseResult]) -> Score:
    """Top-1/top-2 on identifiable cases, truth-in-tie and gap reduction on detected in-catalogue ones,
    confident-and-wrong verdicts, honesty outside the catalogue, and the reliability of the probabilities,
    over cases of one campaign kind."""
    kinds = {r.campaign for r in results}
    if len(kinds) > 1:
        raise ValueError(f"score one campaign kind at a time, got {sorted(kinds)}")
    ident = [r for r in results if r.identifiable]
    detected = [r for r in results if r.truth != "none" and r.in_catalogue and r.significant and r.testable]
    none = [r for r in results if r.truth == "none"]
    outside = [r for r in results if not r.in_catalogue and r.significant]
    confusion: dict[str, Counter] = {}
    for r in results:
        column = "-" if not r.significant else "?" if r.kind == "not explained" or not r.ranked else r.ranked[0]
        confusion.setdefault(r.truth, Counter())["pair" if "+" in column else column] += 1
    reductions = np.array([r.reduction for r in detected if math.isfinite(r.reduction)])
    represented = [r for r in results if r.in_catalogue]  # the verdicts the probabilities are judged on
    reliability, calibration, weighted, floor, p_calibration, widening = _reliability(represented)
    _, calibration_all, *_ = _reliability(results, draws=0)  # its sampling noise is not reported
    ties = [len(r.tie) for r in results if r.significant]
    return Score(
        len(results),
        float(np.mean([r.right for r in ident])) if ident else math.nan,
        float(np.mean([any(a in r.ranked[:2] for a in r.right_answers) for r in ident])) if ident else math.nan,
        len(ident),
        float(np.mean([_in_tie(r) for r in detected])) if detected else math.nan,
        len(detected),
        float(np.median(reductions)) if len(reductions) else math.nan,
        float(1 - np.sqrt(np.mean((1 - reductions) ** 2))) if len(reductions) else math.nan,
        sum(r.confident for r in none),
        len(none),
        sum(r.confident_and_wrong for r in results),
        sum(r.confident_and_wrong for r in results if not r.in_catalogue),
        float(np.mean([r.kind in ("not explained", "tie") or r.right for r in outside])) if outside else math.nan,
        len(outside),
        reliability,
        calibration,
        confusion,
        kinds.pop() if kinds else "shapes",
        calibration_all,
        weighted,
        float(np.mean(ties)) if ties else math.nan,
        floor,
        p_calibration,
        _by_candidate(represented),
        *_proper_scores(represented),
        _by_basis(represented),
        widening,
    )


def run(
    n: int,
    workers: int = 2,
    first_seed: int = 0,
    kinds: tuple[str, ...] = ("shapes",),
    scheduler: str | None = None,
    machines: tuple[str, ...] = ("kid300",),
    nominal: str = "description",
    truths: tuple[str, ...] = EFFECT_NAMES,
    level: float | None = None,
) -> list[CaseResult]:
    """Run n blind cases per campaign kind and machine through dask: the local process scheduler with
    ``workers`` processes by default (one process: in this one, no dask needed), or the dask cluster at
    ``scheduler`` (an address such as tcp://host:8786, for studies of 10^4 cases over many machines).
    ``nominal``: where the fits start, ``level``: the frequencies measured again at another level (make_case);
    ``truths``: the truths cycled through (cases)."""
    todo = [(*c, nominal, level) for c in cases(n, first_seed, kinds, machines, truths)]
    if workers <= 1 and scheduler is None:
        return [run_case(*c) for c in todo]
    try:
        import dask
    except ImportError:
        raise InputError(
            "workers", "running blind cases in parallel needs dask: pip install 'mountid[validation]'"
        ) from None
    tasks = [dask.delayed(run_case, pure=True)(*c) for c in todo]
    if scheduler is None:
        # one case a task (dask's local processes take six at a time by default): a case takes about a second, the
        # batching saves nothing and leaves a process idle for up to six cases at the end
        return list(dask.compute(*tasks, scheduler="processes", num_workers=workers, chunksize=1))
    try:
        from distributed import Client
    except ImportError:
        raise InputError(
            "scheduler", "a dask cluster needs dask.distributed: pip install 'mountid[validation]'"
        ) from None
    with Client(scheduler) as client:
        return list(client.compute(tasks, sync=True))
