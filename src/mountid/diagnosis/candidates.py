"""Fit the candidate effects of :mod:`mountid.effects` to a campaign and rank them.

Every candidate (and the nominal model, ``"none"``) is fitted together with the machine's unknowns by
weighted least squares to every measured frequency and mode shape. The data vector, in units of each
measurement's standard deviation:

- frequencies: (measured - model) / sigma_omega;
- mode shapes: rotations scaled by the machine's length scale (so that components compare as motion
  of a point at the isolators), normalised to unit length; the residual is the part of the measured shape
  outside the model's mode (or the span of a model cluster of equal frequencies, where the model leaves
  the combination free), divided by the shape's standard deviation per component;
- damping ratios, where measured: (measured - model) / sigma_zeta, the model's from the damped poles of the
  candidate's M, C, B (strategies.Strategy.damping_ratios).

Ranking is by posterior probability: each candidate's evidence by the Laplace approximation with a uniform
prior over the effect's plausible range (fitting.log_evidence), equal prior probabilities for the nominal model
and each effect. Fitted values outside the plausible range (outside the prior) get probability 0. The tie is
the credible set (the best candidates up to ``settings.credible`` of the probability). The
held-out error of each candidate is its leave-one-mode-out prediction error (linearised for all
candidates; refitted for the nominal model and, when there is a gap to explain, the first three of the tie).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
import scipy.linalg
import scipy.optimize
import scipy.special
import scipy.stats

from mountid.diagnosis.campaign import Campaign
from mountid.diagnosis.fitting import CandidateFit, exact_leave_one_out, fit_candidate, held_out_z
from mountid.diagnosis.settings import DIAGNOSIS, DiagnosisSettings
from mountid.diagnosis.strategies import strategy
from mountid.effects import CATALOGUE, Effect


@dataclass(frozen=True)
class EffectsReport:
    """Every candidate fitted and ranked, and what the data say about them."""

    nominal: CandidateFit
    ranked: list[CandidateFit]
    p_value: float
    """Probability of the nominal chi^2 or more if the nominal model were right."""
    significant: bool
    tie: list[str]
    separation: list[str]
    verdict: str
    confident: bool
    kind: str
    """The verdict's kind: "confident", "tie", "not explained", "no significant gap" or "cannot judge"."""
    notes: list[str] = field(default_factory=list)

    @property
    def best(self) -> CandidateFit | None:
        """The first-ranked candidate, when the data rank candidates at all (a positive probability)."""
        first = self.ranked[0] if self.ranked else None
        return first if first is not None and first.probability > 0 else None


def fit_all(
    campaign: Campaign,
    effects: tuple[Effect, ...] = CATALOGUE,
    warm: EffectsReport | None = None,
    settings: DiagnosisSettings = DIAGNOSIS,
) -> tuple[CandidateFit, list[CandidateFit]]:
    """The nominal fit and the best fit of each candidate effect (isolator_scatter: its best isolator; the
    others within settings.tie in chi^2 are named in its note, mirror images that frequencies alone cannot tell).
    ``warm``: a report on nearby data whose fits start these (one start each; scatter keeps its isolator)."""
    previous = {f.effect: f for f in (warm.ranked if warm else []) if f.state is not None}
    nominal = fit_candidate(campaign, None, start=warm.nominal.theta if warm else None)
    fits = []
    for effect in effects:
        before = previous.get(effect.name)
        if strategy(effect).per_isolator:
            isolators = campaign.machine.module.ISOLATORS
            if before is not None:  # the isolator of the nearby fit only: 1/N of the mean over isolators
                fit = fit_candidate(campaign, effect, isolators.index(before.variant), before.theta)
                fits.append(replace(fit, log_evidence=fit.log_evidence - math.log(len(isolators))))
                continue
            # the first isolator from the default starts; the others (often mirror images) start from it
            variants = [fit_candidate(campaign, effect, 0)]
            variants += [fit_candidate(campaign, effect, i, variants[0].theta) for i in range(1, len(isolators))]
            variants.sort(key=lambda f: f.chi2)
            # one candidate whose isolator is unknown: its evidence is the mean over the isolators
            evidence = float(scipy.special.logsumexp([v.log_evidence for v in variants]) - math.log(len(variants)))
            best = replace(variants[0], log_evidence=evidence)
            alike = [v.variant for v in variants[1:] if v.chi2 <= best.chi2 + settings.tie]
            if alike:
                note = f"as good: {', '.join(alike)} (which isolator needs mode shapes that tell them apart)"
                best = replace(best, note=note)
            fits.append(best)
        else:
            fits.append(fit_candidate(campaign, effect, start=before.theta if before else None))
    return nominal, fits


def _rank_key(f: CandidateFit) -> tuple:
    return (not f.applicable, not f.plausible, -f.log_evidence, f.chi2)  # log_evidence is finite or -inf


def _probabilities(nominal: CandidateFit, fits: list[CandidateFit]) -> dict[int, float]:
    """Posterior probability of every candidate (by id) with equal prior probabilities for the nominal model
    and each effect; 0 for candidates not applicable, implausible (outside their prior) or unfitted."""
    pool = [nominal, *(f for f in fits if f.applicable and f.plausible and math.isfinite(f.log_evidence))]
    logs = np.array([f.log_evidence for f in pool])
    weights = np.exp(logs - logs.max()) if np.isfinite(logs.max()) else np.ones(len(pool))
    out = {id(f): 0.0 for f in fits}
    out.update({id(f): float(w / weights.sum()) for f, w in zip(pool, weights, strict=True)})
    return out


def explains(f: CandidateFit, settings: DiagnosisSettings = DIAGNOSIS) -> bool:
    """Whether a candidate explains the gap: it fits every measurement within its uncertainty (chi^2 test at
    settings.fit_p_value) with every effect parameter inside its plausible range (a support of a few kg under
    an 800 kg machine mimics other effects; a flexible candidate fits much at values no machine has), and
    predicts the modes held out (leave one mode out) within settings.held_out_limit sigma in the median (the
    median forgives the one mode whose omission leaves a parameter undetermined)."""
    if not fits_within_uncertainty(f, settings) or f.outside_range:
        return False
    return math.isfinite(f.held_out_median) and f.held_out_median <= settings.held_out_limit


def fits_within_uncertainty(f: CandidateFit, settings: DiagnosisSettings = DIAGNOSIS) -> bool:
    """Whether the data do not reject a candidate: chi^2 below its 1 - settings.fit_p_value quantile."""
    if not (f.applicable and f.plausible) or f.n_data <= f.n_parameters:
        return False
    return bool(scipy.stats.chi2.sf(f.chi2, f.n_data - f.n_parameters) >= settings.fit_p_value)


def _closest(nominal: CandidateFit, fits: list[CandidateFit]) -> str:
    """How much of the gap each of the (up to three) best candidates explains."""
    parts = []
    for f in fits[:3]:
        share = 1 - f.chi2 / nominal.chi2 if nominal.chi2 > 0 else math.nan
        parts.append(
            f"{f.effect}{' at ' + f.variant if f.variant else ''} removes {share:.0%} of the chi^2, held-out "
            f"median {nominal.held_out_median:.1f} -> {f.held_out_median:.1f} sigma"
        )
    return "; ".join(parts)


def rank(
    campaign: Campaign,
    nominal: CandidateFit,
    fits: list[CandidateFit],
    exact_held_out: bool = True,
    settings: DiagnosisSettings = DIAGNOSIS,
) -> EffectsReport:
    """Rank fitted candidates by posterior probability (Laplace evidence, fitting.log_evidence), judge the
    nominal gap, find the tie (the credible set) and what would separate it (``exact_held_out``: refit
    without each mode for the nominal model and, with a significant gap, the first three of the tie; else
    linearised only). The verdict is confident only when the best candidate explains the gap (fits, and
    predicts the held-out modes: :func:`explains`), has probability settings.confidence or more, and the data
    reject every other candidate (:func:`fits_within_uncertainty`); when no candidate explains it, the verdict
    says so and names the closest."""
    n, k = nominal.n_data, nominal.n_parameters
    p_value = float(scipy.stats.chi2.sf(nominal.chi2, n - k)) if n > k else math.nan
    significant = bool(p_value < settings.gap_p_value)
    probability = _probabilities(nominal, fits)
    nominal = replace(nominal, probability=probability[id(nominal)])
    fits = [replace(f, probability=probability[id(f)]) for f in fits]
    ranked = sorted(fits, key=_rank_key)
    notes = []
    if n - k - 2 <= 0:
        notes.append(
            f"{n} data for {k} unknowns: too few to fit any candidate effect with a degree of freedom to spare; "
            "measure more modes (both members of each twin pair) or mode shapes"
        )
    candidates = [f for f in ranked if f.probability > 0]
    best = candidates[0] if candidates else None
    tie, total = [], nominal.probability
    for f in candidates:
        if total >= settings.credible and tie:
            break
        tie.append(f)
        total += f.probability
    # refitted held-out errors for the nominal model and, when there is a gap to explain, the first three of
    # the tie (the others keep their linearised ones)
    refit = {id(f) for f in [nominal, *(tie[:3] if significant else [])]} if exact_held_out else set()

    def finished(f: CandidateFit) -> CandidateFit:
        if id(f) in refit:
            f = exact_leave_one_out(f)
        z = held_out_z(f, campaign)
        if len(z):
            f = replace(f, held_out_rms=float(np.sqrt(np.mean(z**2))), held_out_median=float(np.median(np.abs(z))))
        return f

    done = {id(f): finished(f) for f in [nominal, *fits]}
    nominal, ranked, tie = done[id(nominal)], [done[id(f)] for f in ranked], [done[id(f)] for f in tie]
    best = done[id(best)] if best is not None else None
    separation = [separate(campaign, best, other) for other in tie[1:]] if best and significant else []
    confident = False
    if math.isnan(p_value):
        kind, verdict = "cannot judge", "cannot judge: no more data than unknowns"
    elif not significant:
        kind = "no significant gap"
        verdict = (
            f"no significant gap: the nominal model fits every measurement within its uncertainty "
            f"(chi^2 = {nominal.chi2:.3g} for {n - k} degrees of freedom, p = {p_value:.2g})"
        )
    elif (
        best is not None
        and explains(best, settings)
        and best.probability >= settings.confidence
        and not any(fits_within_uncertainty(f, settings) for f in candidates[1:])
    ):
        kind = "confident"
        verdict = (
            f"significant gap, explained by {best.effect}"
            + (f" at {best.variant}" if best.variant else "")
            + f" (probability {best.probability:.2f})"
        )
        confident = True
    elif any(explains(f, settings) for f in tie):
        kind = "tie"
        names = ", ".join(f"{f.effect} ({f.probability:.2f})" for f in tie)
        verdict = f"significant gap; explained equally well by {names} (a tie)"
    else:
        kind = "not explained"
        closest = _closest(nominal, [done[id(f)] for f in candidates]) if candidates else "none can be fitted"
        verdict = f"significant gap, not explained by any effect in the catalogue; closest: {closest}"
    tie_names = [f.effect for f in tie] if significant else []
    return EffectsReport(nominal, ranked, p_value, significant, tie_names, separation, verdict, confident, kind, notes)


def diagnose_effects(
    campaign: Campaign,
    effects: tuple[Effect, ...] = CATALOGUE,
    warm: EffectsReport | None = None,
    exact_held_out: bool = True,
    settings: DiagnosisSettings = DIAGNOSIS,
) -> EffectsReport:
    """Fit every candidate effect to the campaign and rank them (the 'which effect' half of the diagnosis;
    ``warm`` as in :func:`fit_all`, ``exact_held_out`` as in :func:`rank`)."""
    nominal, fits = fit_all(campaign, effects, warm, settings)
    return rank(campaign, nominal, fits, exact_held_out, settings)


def separate(campaign: Campaign, a: CandidateFit, b: CandidateFit) -> str:
    """The single modal measurement (a frequency or a mode shape of any mode) on which the fitted
    candidates a and b differ most, in units of the campaign's typical uncertainty."""
    mod = campaign.machine.module
    labels = tuple(mod.MODES)
    pa = a.state.model.predict(a.state.theta, labels)
    pb = b.state.model.predict(b.state.theta, labels)
    measured = list(campaign.modes.values())
    rel = float(np.median([m.frequency_std / m.frequency for m in measured]))
    shape_sigma = float(np.median([m.shape_std for m in measured]))
    best = (0.0, "")
    for i, lab in enumerate(labels):
        z = abs(pa.frequencies[i] - pb.frequencies[i]) / (rel * pa.frequencies[i])
        if z > best[0]:
            best = (z, f"the frequency of {lab}")
        twins = [c is not None and c[1] == 1.0 for c in (pa.clusters[i], pb.clusters[i])]
        if not any(twins):  # the shape of one of two equal modes is any mix of them: nothing to compare
            sa, sb = pa.shapes[i], pb.shapes[i]
            z = math.sqrt(max(0.0, 1 - float(sa @ sb) ** 2)) / shape_sigma
            if z > best[0]:
                best = (z, f"the mode shape of {lab}")
    if best[0] < 1:
        return f"{a.effect} vs {b.effect}: no single modal measurement separates them by 1 sigma"
    return f"{a.effect} vs {b.effect}: measure {best[1]} (they differ there by {best[0]:.1f} sigma)"
