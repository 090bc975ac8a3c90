"""Fit the candidate effects of :mod:`mountid.effects` to a campaign and rank them.

Every candidate (and the nominal model, ``"none"``) is fitted together with the machine's unknowns by
weighted least squares to every measured frequency and mode shape. The data vector, in units of each
measurement's standard deviation:

- frequencies: (measured - model) / sigma_omega;
- mode shapes: rotations scaled by the machine's length scale (so that components compare as motion
  of a point at the isolators), normalised to unit length; the residual is the part of the measured shape
  outside the model's mode (or the span of a model cluster of equal frequencies, where the model leaves
  the combination free), divided by the shape's standard deviation per component.

Ranking is by AICc (chi^2 + 2k + 2k(k+1)/(n-k-1)); fitted values outside the plausible range of the
effect rank after every plausible candidate. Candidates within ``settings.tie`` of the best AICc are a tie. The
held-out error of each candidate is its leave-one-mode-out prediction error (linearised for all
candidates; refitted for the nominal model and, when there is a gap to explain, the first three of the tie).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
import scipy.linalg
import scipy.optimize
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
    notes: list[str] = field(default_factory=list)

    @property
    def best(self) -> CandidateFit | None:
        """The first-ranked candidate, when the data rank candidates at all (a finite AICc)."""
        first = self.ranked[0] if self.ranked else None
        return first if first is not None and first.applicable and math.isfinite(first.aicc) else None


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
            if before is not None:
                fits.append(fit_candidate(campaign, effect, isolators.index(before.variant), before.theta))
                continue
            # the first isolator from the default starts; the others (often mirror images) start from it
            variants = [fit_candidate(campaign, effect, 0)]
            variants += [fit_candidate(campaign, effect, i, variants[0].theta) for i in range(1, len(isolators))]
            variants.sort(key=lambda f: f.chi2)
            best = variants[0]
            alike = [v.variant for v in variants[1:] if v.chi2 <= best.chi2 + settings.tie]
            if alike:
                note = f"as good: {', '.join(alike)} (which isolator needs mode shapes that tell them apart)"
                best = replace(best, note=note)
            fits.append(best)
        else:
            fits.append(fit_candidate(campaign, effect, start=before.theta if before else None))
    return nominal, fits


def _rank_key(f: CandidateFit) -> tuple:
    return (not f.applicable, not f.plausible, f.aicc if math.isfinite(f.aicc) else math.inf, f.chi2)


def rank(
    campaign: Campaign,
    nominal: CandidateFit,
    fits: list[CandidateFit],
    exact_held_out: bool = True,
    settings: DiagnosisSettings = DIAGNOSIS,
) -> EffectsReport:
    """Rank fitted candidates, judge the nominal gap, find the tie and what would separate it
    (``exact_held_out``: refit without each mode for the nominal model and, with a significant gap, the
    first three of the tie; else linearised only). The tie and what separates it are reported only when
    there is a significant gap to explain."""
    n, k = nominal.n_data, nominal.n_parameters
    p_value = float(scipy.stats.chi2.sf(nominal.chi2, n - k)) if n > k else math.nan
    significant = bool(p_value < settings.gap_p_value)
    ranked = sorted(fits, key=_rank_key)
    notes = []
    if n - k - 2 <= 0:
        notes.append(
            f"{n} data for {k} unknowns: too few to fit any candidate effect with a degree of freedom to spare; "
            "measure more modes (both members of each twin pair) or mode shapes"
        )
    best = (
        ranked[0] if ranked and ranked[0].applicable and ranked[0].plausible and math.isfinite(ranked[0].aicc) else None
    )
    tie = [f for f in ranked if best and f.applicable and f.plausible and f.aicc <= best.aicc + settings.tie]
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
        verdict = "cannot judge: no more data than unknowns"
    elif not significant:
        verdict = (
            f"no significant gap: the nominal model fits every measurement within its uncertainty "
            f"(chi^2 = {nominal.chi2:.3g} for {n - k} degrees of freedom, p = {p_value:.2g})"
        )
    elif best is None:
        verdict = "significant gap, but no candidate effect can be fitted with plausible values"
    elif best.aicc > nominal.aicc - settings.tie:
        verdict = "significant gap, but no candidate effect explains it better than the nominal model"
    else:
        p_after = float(scipy.stats.chi2.sf(best.chi2, best.n_data - best.n_parameters))
        names = ", ".join(f.effect for f in tie)
        if p_after < settings.gap_p_value:
            verdict = f"significant gap; {best.effect} explains part of it (the rest remains significant)"
        elif len(tie) > 1:
            verdict = f"significant gap; explained equally well by {names} (a tie)"
        else:
            verdict = f"significant gap, explained by {best.effect}" + (f" at {best.variant}" if best.variant else "")
            confident = True
    tie_names = [f.effect for f in tie] if significant else []
    return EffectsReport(nominal, ranked, p_value, significant, tie_names, separation, verdict, confident, notes)


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
