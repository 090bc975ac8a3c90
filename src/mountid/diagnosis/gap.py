"""The gap diagnosis. Where the model misses the measurements: residuals against uncertainty, held-out
predictions, sensitivities, localisation at matrix level, broken symmetry, the modal force residual per
isolator. Which effect: :mod:`mountid.diagnosis.candidates`. :func:`diagnose` does both.

All numbers come from the generated module of the campaign's machine: the nominal identification is
mountid.identification.from_records.fit_stiffness, the frequencies and mode shapes the generated forward map.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterable
from dataclasses import asdict, dataclass, field

import numpy as np
import scipy.stats

from mountid.diagnosis.campaign import DEFAULT_FREQUENCY_STD, Campaign
from mountid.diagnosis.candidates import EffectsReport, diagnose_effects
from mountid.diagnosis.fitting import chi2_by_kind, damping_std
from mountid.diagnosis.settings import DIAGNOSIS, DiagnosisSettings
from mountid.identification.from_records import StiffnessFit, fit_stiffness
from mountid.identification.statistics import covariance, standard_deviations
from mountid.machine import GeneratedModule, call


@dataclass(frozen=True)
class Residual:
    """measured - predicted [rad/s] for one mode; z = residual / its standard deviation (None without the
    measurement's uncertainty): the measurement's ``uncertainty`` and, for a mode held out, the prediction's own
    ``prediction_std`` [rad/s] (the fit to the other modes propagated to this one at their stated uncertainties),
    in quadrature."""

    label: str
    measured: float
    predicted: float
    uncertainty: float | None
    held_out: bool
    threshold: float = DIAGNOSIS.significance
    """Significant beyond this many standard deviations (DiagnosisSettings.significance)."""
    prediction_std: float = 0.0

    @property
    def residual(self) -> float:
        return self.measured - self.predicted

    @property
    def sigma(self) -> float | None:
        """The standard deviation of the residual [rad/s]: measurement and prediction in quadrature."""
        return None if self.uncertainty is None else math.hypot(self.uncertainty, self.prediction_std)

    @property
    def z(self) -> float | None:
        return None if self.sigma is None else self.residual / self.sigma

    @property
    def significant(self) -> bool | None:
        return None if self.z is None else abs(self.z) > self.threshold

    def to_dict(self) -> dict:
        return {
            "mode": self.label,
            "measured": self.measured,
            "predicted": self.predicted,
            "residual": self.residual,
            "uncertainty": self.uncertainty,
            "prediction_std": self.prediction_std,
            "z": self.z,
            "significant": self.significant,
            "held_out": self.held_out,
        }


@dataclass(frozen=True)
class Localisation:
    """The change of one group of matrix entries (tied by symmetry) that best removes the residuals:
    ``change`` in the entries' unit, ``explained`` the share of the weighted squared residual it removes."""

    matrix: str
    entries: tuple[tuple[str, str], ...]
    change: float
    unit: str
    explained: float

    def describe(self) -> str:
        names = ", ".join(f"{self.matrix}[{i},{j}]" for i, j in self.entries)
        word = "short by" if self.change > 0 else "too large by"
        return f"{names} {word} about {abs(self.change):.3g} {self.unit} (explains {self.explained:.0%})"

    def to_dict(self) -> dict:
        return {
            "matrix": self.matrix,
            "entries": [list(e) for e in self.entries],
            "change": self.change,
            "unit": self.unit,
            "explained": self.explained,
            "text": self.describe(),
        }


@dataclass(frozen=True)
class GapReport:
    parameters: dict[str, float]
    parameter_std: dict[str, float]
    residuals: list[Residual]
    sensitivities: dict[str, dict[str, float]]
    """d ln(omega_mode) / d ln(parameter) for every measured mode and forward parameter."""
    localisation: list[Localisation]
    broken_symmetry: list[str]
    verdict: str
    notes: list[str] = field(default_factory=list)
    within_noise: bool = False
    """Whether the nominal model fits every measurement within its uncertainty (the diagnosis's "no significant
    gap"): the localisation then fits misses that may be noise, a lead only were they real."""


_UNITS = {"C": ("N/m", "N", "N m/rad"), "M": ("kg", "kg m", "kg m^2")}


def _unit(matrix: str, i: int, j: int) -> str:
    rot = (i >= 3) + (j >= 3)
    return _UNITS[matrix][rot]


def _fit_data(campaign: Campaign, labels: Iterable[str]) -> dict[str, tuple[float, float]]:
    """Distinct-frequency data for fit_stiffness: twins (x and y) averaged, weights from uncertainty."""
    rep = campaign.machine.module.REPRESENTATIVE
    groups: dict[str, list] = {}
    for label in labels:
        groups.setdefault(rep[label], []).append(campaign.modes[label])
    out = {}
    for r, items in groups.items():
        w = float(np.mean([m.frequency for m in items]))
        stds = [m.frequency_std for m in items]
        out[r] = (w, float(np.sqrt(np.sum(np.square(stds)))) / len(items))
    return out


def _predict(campaign: Campaign, params: dict[str, float]) -> dict[str, float]:
    return campaign.machine.frequencies({**campaign.known, **params})


def _prediction_std(campaign: Campaign, fit: StiffnessFit) -> dict[str, float]:
    """Standard deviation [rad/s] of each mode's frequency predicted by ``fit``, to first order from the
    covariance of its ln unknowns and d ln omega / d ln p (_log_sensitivities). Infinite where the fit leaves
    that frequency undetermined (a non-finite covariance)."""
    machine = campaign.machine
    mod = machine.module
    values = machine.values({**campaign.known, **fit.parameters}, mod.FORWARD_ARGUMENTS)
    lam, g = _log_sensitivities(mod, values)
    g = g[[mod.FORWARD_ARGUMENTS.index(u) for u in machine.unknown]]
    variance = np.einsum("im,ij,jm->m", g, fit.log_covariance, g)
    std = np.where(np.isfinite(variance), np.sqrt(np.abs(variance) * lam), np.inf)
    return {label: float(std[mod.MODES.index(label)]) for label in campaign.modes}


def sensitivities(campaign: Campaign, params: dict[str, float]) -> dict[str, dict[str, float]]:
    """d ln omega / d ln p of each measured mode in every argument p of the forward map (_log_sensitivities)."""
    mod = campaign.machine.module
    _, g = _log_sensitivities(mod, campaign.machine.values({**campaign.known, **params}, mod.FORWARD_ARGUMENTS))
    return {
        label: {name: float(g[i, mod.MODES.index(label)]) for i, name in enumerate(mod.FORWARD_ARGUMENTS)}
        for label in campaign.modes
    }


def _log_sensitivities(mod: GeneratedModule, values: dict[str, float]) -> tuple[np.ndarray, np.ndarray]:
    """The squared frequencies lambda [rad^2/s^2] of every mode and d ln omega / d ln p = p (d lambda / d p) /
    (2 lambda), shape (forward arguments, modes), from the generated d lambda / d p at ``values``."""
    lam = np.asarray(mod.squared_frequencies(**values), dtype=float)
    p = np.array([values[a] for a in mod.FORWARD_ARGUMENTS], dtype=float)
    g = np.asarray(mod.squared_frequency_derivatives(**values), dtype=float)
    return lam, g * p[:, None] / (2 * lam[None, :])


def localise(campaign: Campaign, params: dict[str, float], residuals: list[Residual]) -> list[Localisation]:
    """Rank single groups of M and C entries by how much of the residual one change of them removes.

    To first order d(lambda_k) = phi_k^T dC phi_k - lambda_k phi_k^T dM phi_k (mass-normalised phi). For a
    group of entries changed together (an entry and its mirror in the twin block, e.g. C[psi,psi] with
    C[theta,theta]) the change is fitted by weighted linear least squares to the residuals in lambda
    together with new steps of the unknowns (columns phi_k^T dC/dtheta phi_k): the nominal fit has already
    bent the unknowns towards the unmodelled effect, and a change judged alone would land where that fit
    pushed the residual, not where it comes from.
    """
    machine = campaign.machine
    mod = machine.module
    args = machine.values({**campaign.known, **params}, mod.FORWARD_ARGUMENTS)
    phi = mod.modal_matrix(**args)
    lam = mod.squared_frequencies(**args)
    rows = [mod.MODES.index(r.label) for r in residuals]
    d_lam = np.array([r.measured**2 - r.predicted**2 for r in residuals])
    sigma = np.array([2 * r.measured * (r.sigma or DEFAULT_FREQUENCY_STD * r.measured) for r in residuals])
    before = float(np.sum((d_lam / sigma) ** 2))
    if before < 1e-12 * len(residuals):  # nothing to localise (the fit reproduces every measurement)
        return []
    grads = call(mod, "stiffness_gradient", args)
    unknown_cols = np.array([[phi[:, k] @ grad @ phi[:, k] for grad in grads] for k in rows]).reshape(len(rows), -1)
    coords = mod.COORDINATES
    # the engine's twin map: coordinate -> (image, sign), both ways; an entry's image changes by s_i s_j
    twin_of: dict[int, tuple[int, int]] = {}
    for a, b, sign in mod.TWIN_COORDINATES:
        i, j = coords.index(a), coords.index(b)
        twin_of[i], twin_of[j] = (j, sign), (i, sign)
    out, seen = [], set()
    for block in mod.BLOCKS:
        for i, j in itertools.combinations_with_replacement(block, 2):
            group = {(i, j): 1.0}
            if i in twin_of and j in twin_of:
                (ti, si), (tj, sj) = twin_of[i], twin_of[j]
                group[tuple(sorted((ti, tj)))] = float(si * sj)
            key = frozenset(group)
            if key in seen:
                continue
            seen.add(key)
            for matrix in ("C", "M"):
                g = np.zeros(len(rows))
                for (a, b), sign in group.items():
                    factor = 1.0 if a == b else 2.0
                    g += sign * factor * phi[a, rows] * phi[b, rows] * (1.0 if matrix == "C" else -lam[rows])
                if not np.any(g):
                    continue
                design = np.column_stack([g, unknown_cols]) / sigma[:, None]
                coef = np.linalg.lstsq(design, d_lam / sigma, rcond=None)[0]
                delta = float(coef[0])
                after = float(np.sum((d_lam / sigma - design @ coef) ** 2))
                names = tuple((coords[a], coords[b]) for a, b in group)  # the entry first, then its image
                out.append(Localisation(matrix, names, delta, _unit(matrix, i, j), 1 - after / before))
    return _by_share(out)


SAME_SHARE = 1e-9
"""Single changes whose shares of the residual removed differ by this or less explain it equally (a mode alone
in its block: C[phi,phi] and M[phi,phi] scale one column of the same fit)."""


def _by_share(found: list[Localisation]) -> list[Localisation]:
    """``found`` by the share each explains, largest first; those that explain it equally (SAME_SHARE) in the
    order they were found (blocks in order, C before M), so the first one named does not rest on rounding (the
    fit of the frequencies 1e-11 apart put C[phi,phi] first or M[phi,phi], both at 87 %)."""
    order = sorted(range(len(found)), key=lambda i: -found[i].explained)
    out: list[Localisation] = []
    start = 0
    while start < len(order):
        end = start + 1
        while end < len(order) and found[order[start]].explained - found[order[end]].explained <= SAME_SHARE:
            end += 1
        out += [found[i] for i in sorted(order[start:end])]
        start = end
    return out


def _broken_symmetry(campaign: Campaign, labels: list[str], rep: dict[str, str], threshold: float) -> list[str]:
    """Pairs of modes equal by the model's symmetry whose measured frequencies differ significantly. Several
    pairs are tested at once, so the level of one test at ``threshold`` sigma (two-sided) holds for the family
    by Holm's step-down correction: the smallest p-value against level/m, the next against level/(m - 1), ..."""
    level = 2 * scipy.stats.norm.sf(threshold)
    tested, out = [], []
    for a, b in itertools.combinations(labels, 2):
        if rep[a] != rep[b]:
            continue
        ma, mb = campaign.modes[a], campaign.modes[b]
        diff = ma.frequency - mb.frequency
        if ma.stated_frequency_std and mb.stated_frequency_std:
            tested.append((a, b, diff, diff / math.hypot(ma.stated_frequency_std, mb.stated_frequency_std)))
        elif diff != 0:
            out.append(f"{a} and {b} differ by {diff:+.4g} rad/s (equal by symmetry; no uncertainty given)")
    tested.sort(key=lambda t: -abs(t[3]))
    for i, (a, b, diff, z) in enumerate(tested):
        if 2 * scipy.stats.norm.sf(abs(z)) > level / (len(tested) - i):
            break
        out.append(
            f"{a} and {b} are equal by the model's symmetry but differ by {diff:+.4g} rad/s ({z:+.1f} sigma, "
            f"significant among {len(tested)} pairs): broken symmetry"
        )
    return out


def diagnose_where(
    campaign: Campaign, settings: DiagnosisSettings = DIAGNOSIS, within_noise: bool = False
) -> GapReport:
    """Nominal identification and where the model misses the campaign's measurements. The fits start near the
    description (fit_stiffness with numeric_inverses False: the grid searches of numeric inverses only where no
    mount near it fits), as the candidate fits do. ``within_noise``: the diagnosis found no significant gap (the
    localisation's note then says its changes fit misses within their uncertainty)."""
    threshold = settings.significance
    machine = campaign.machine
    rep = machine.module.REPRESENTATIVE
    labels = list(campaign.modes)
    fitted = list(campaign.fit) if campaign.fit else labels
    held_out = [lab for lab in labels if lab not in fitted]
    notes: list[str] = []  # the nominal identification's own (a fit at a boundary), then the gap's
    nominal = fit_stiffness(
        machine,
        campaign.known,
        _fit_data(campaign, fitted),
        _fit_data(campaign, held_out) or None,
        notes=notes,
        boundary_ok=True,
        numeric_inverses=False,
    )
    params, stds = nominal.parameters, nominal.stds
    predicted = _predict(campaign, params)
    spread = _prediction_std(campaign, nominal)
    residuals = []
    for label in labels:
        m = campaign.modes[label]
        if campaign.fit is not None:
            held = label not in campaign.fit
            own = spread[label] if held else 0.0
            residuals.append(
                Residual(label, m.frequency, predicted[label], m.stated_frequency_std, held, threshold, own)
            )
    if campaign.fit is None:
        # leave-one-out: each distinct frequency predicted by the fit to all the others
        for label in labels:
            m = campaign.modes[label]
            others = [lab for lab in labels if rep[lab] != rep[label]]
            residuals.append(Residual(label, m.frequency, predicted[label], m.stated_frequency_std, False, threshold))
            distinct = {rep[lab] for lab in others}
            undetermined = machine.undetermined_by(distinct)
            if undetermined:
                notes.append(f"{label} is not predicted from the others: {undetermined.describe()}")
            elif len(distinct) >= len(machine.unknown):
                loo = fit_stiffness(
                    machine,
                    campaign.known,
                    _fit_data(campaign, others),
                    _fit_data(campaign, [label]),
                    boundary_ok=True,
                    numeric_inverses=False,
                )
                residuals.append(
                    Residual(
                        label,
                        m.frequency,
                        _predict(campaign, loo.parameters)[label],
                        m.stated_frequency_std,
                        True,
                        threshold,
                        _prediction_std(campaign, loo)[label],
                    )
                )
    broken = _broken_symmetry(campaign, labels, rep, threshold)
    # localised on the nominal fit's residuals: every measured mode (fitted and held out) when the campaign
    # names the fitted ones, the fit to all modes under leave-one-out
    loc = localise(campaign, params, [r for r in residuals if campaign.fit is not None or not r.held_out])
    judged = [r for r in residuals if r.significant is not None]
    if len(judged) < len(residuals):
        notes.append("some frequencies have no uncertainty: their gaps are listed, their significance not judged")
    tied = [x for x in loc if loc and x.explained >= loc[0].explained - 0.01]
    if len(tied) > 1:
        what = "would remove the misses (within their uncertainty)" if within_noise else "remove the gap"
        notes.append(
            f"{len(tied)} single changes of matrix entries {what} equally well "
            f"({'; '.join(x.describe() for x in tied[:4])}{'; ...' if len(tied) > 4 else ''}): "
            "these measurements cannot tell them apart"
        )
    significant = sorted({r.label for r in residuals if r.significant})
    if broken:
        verdict = "broken symmetry: " + "; ".join(broken)
    elif significant:
        where = loc[0].describe() if loc else "no single matrix entry explains it"
        verdict = f"significant gap in {', '.join(significant)}; at matrix level: {where}"
    elif judged and len(judged) == len(residuals):
        verdict = "no significant gap: the model reproduces every measurement within its uncertainty"
    else:
        verdict = "significance not judged (uncertainties missing); largest gaps listed"
    return GapReport(
        params, stds, residuals, sensitivities(campaign, params), loc, broken, verdict, notes, within_noise
    )


@dataclass(frozen=True)
class IsolatorForce:
    """The modal force residual (C - w^2 M) phi of the measured shapes, attributed to one isolator: the
    relative stiffness change of that isolator that best cancels it (all measured modes together)."""

    isolator: str
    change: float
    std: float

    def to_dict(self) -> dict:
        return {"isolator": self.isolator, "stiffness_change": self.change, "std": self.std}


def isolator_forces(campaign: Campaign, params: dict[str, float]) -> tuple[list[IsolatorForce], dict[str, float]]:
    """Per isolator, the stiffness change delta_i that makes sum_i delta_i C_i phi_k cancel the modal force
    residual r_k = (C - w_k^2 M) phi_k of every measured shape phi_k (mass-normalised, measured w_k), by
    linear least squares; and per mode |r_k| / |C phi_k|. Empty without measured shapes."""
    machine = campaign.machine
    mod = machine.module
    values = machine.values({**campaign.known, **params}, tuple(mod.PARAMETERS))
    m = np.asarray(call(mod, "mass_matrix", values))
    c = np.asarray(call(mod, "stiffness_matrix", values))
    per = np.asarray(call(mod, "isolator_stiffness", values))
    rows, rhs, relative = [], [], {}
    for label, data in campaign.modes.items():
        if data.shape is None:
            continue
        phi = np.array(data.shape, dtype=float)
        phi /= math.sqrt(phi @ m @ phi)
        r = (c - data.frequency**2 * m) @ phi
        relative[label] = float(np.linalg.norm(r) / np.linalg.norm(c @ phi))
        rows.append(np.stack([k @ phi for k in per], axis=1))
        rhs.append(-r)
    if not rows:
        return [], {}
    a, b = np.vstack(rows), np.concatenate(rhs)
    delta, *_ = np.linalg.lstsq(a, b, rcond=None)
    chi2 = float(np.sum((b - a @ delta) ** 2))
    spread = standard_deviations(covariance(a, chi2, len(b) - len(delta), stated_std=False))
    out = [
        IsolatorForce(name, float(d), float(spread[i]))
        for i, (name, d) in enumerate(zip(mod.ISOLATORS, delta, strict=True))
    ]
    return out, relative


@dataclass(frozen=True)
class Diagnosis:
    """The whole gap diagnosis of a campaign: where (nominal residuals), which effect, how far it shrinks."""

    campaign: Campaign
    where: GapReport
    effects: EffectsReport
    isolators: list[IsolatorForce]
    force_residual: dict[str, float]
    """|(C - w^2 M) phi| / |C phi| per measured shape, at the nominal fit."""

    @property
    def verdict(self) -> str:
        disagree = self.campaign.records_disagree
        caveat = (
            f" (but the records disagree on {', '.join(disagree)} beyond their uncertainty: not one state of the "
            "machine, see the notes)"
            if disagree
            else ""
        )
        return self._verdict + caveat

    @property
    def _verdict(self) -> str:
        if self.where.broken_symmetry and not self.effects.significant:
            return self.where.verdict
        if self.effects.kind == "not explained":
            damping = self.damping_lead
            if damping:
                return f"{self.effects.verdict}; lead: {damping}"
            if self.where.localisation:
                return f"{self.effects.verdict}; lead: {self.where.localisation[0].describe()}"
        return self.effects.verdict

    @property
    def damping_lead(self) -> str:
        """Where the damping ratios hold most of the nominal fit's chi^2: that the model's damping parameters do
        not reproduce them (the frequency localisation has nothing to say about it); '' otherwise."""
        nominal = self.effects.nominal
        if not nominal.applicable or not nominal.damping_gap:
            return ""
        parts = chi2_by_kind(nominal, self.campaign)
        if parts["damping ratios"] <= 0.5 * nominal.chi2:
            return ""
        names = self.campaign.machine.damping
        worst = max(
            nominal.damping_gap, key=lambda lab: abs(nominal.damping_gap[lab]) / damping_std(self.campaign.modes[lab])
        )
        return (
            f"the damping ratios (chi^2 {parts['damping ratios']:.4g} of {nominal.chi2:.4g}, most in {worst}): the "
            f"model's damping ({', '.join(names)}) does not reproduce them"
        )

    def to_dict(self) -> dict:
        """The diagnosis as plain data (the JSON of ``mountid diagnose --json`` without the figure; non-finite
        numbers stay, mountid.report.jsonable turns them to null)."""
        report, effects, campaign = self.where, self.effects, self.campaign
        return {
            "campaign": campaign.name,
            "machine": campaign.machine.name,
            "conventions": campaign.conventions(),
            "records": [str(r.path) for r in campaign.records],
            "level_records": {level: [str(r.path) for r in rs] for level, rs in campaign.level_records.items()},
            "record_notes": list(campaign.record_notes),
            "record_warnings": [asdict(w) for w in campaign.record_warnings],
            "campaign_notes": list(campaign.notes),
            "levels": [
                {**asdict(s), "z": s.z, "relative": s.relative}
                for s in (campaign.levels.shifts if campaign.levels else ())
            ],
            "level_damping": [
                {**asdict(s), "z": s.z, "relative": s.relative}
                for s in (campaign.levels.damping if campaign.levels else ())
            ],
            "parameters": report.parameters,
            "parameter_std": report.parameter_std,
            "residuals": [r.to_dict() for r in report.residuals],
            "sensitivities": report.sensitivities,
            "localisation": [loc.to_dict() for loc in report.localisation],
            "broken_symmetry": report.broken_symmetry,
            "isolator_force_residual": [f.to_dict() for f in self.isolators],
            "modal_force_residual": self.force_residual,
            "nominal": effects.nominal.to_dict(),
            "candidates": [f.to_dict() for f in effects.ranked],
            "screened_pairs": [
                {"effect": s.name, "promised_chi2": s.promised_chi2, "n_data": s.n_data, "n_parameters": s.n_parameters}
                for s in effects.screened
            ],
            "gap": self.gap_table(),
            "p_value": effects.p_value,
            "significant": effects.significant,
            "tie": effects.tie,
            "separation": effects.separation,
            "odds_against_first": [
                {"rival": o.rival, "log_odds": o.odds, "fit": o.fit, "priors": o.priors} for o in effects.odds_splits()
            ],
            "fit_alike": [o.rival for o in effects.alike()],
            "confident": effects.confident,
            "levels_move": effects.levels_move,
            "kind": effects.kind,
            "verdict": self.verdict,
            "where_verdict": report.verdict,
            "notes": [*report.notes, *effects.notes],
        }

    def gap_table(self) -> dict[str, dict]:
        """Per mode and in total: measured - model [rad/s] before (nominal) and after (best candidate), on
        the fit to all modes and held out (leave that mode out)."""
        nominal, best = self.effects.nominal, self.effects.best
        out: dict[str, dict] = {}
        for which, fit in (("before", nominal), ("after", best)):
            if fit is None:
                continue
            fitted, held = fit.frequency_gap, fit.held_out_gap
            out[which] = {
                "effect": fit.effect,
                "fitted": fitted,
                "held_out": held,
                "rms_fitted": _rms(fitted.values()),
                "rms_held_out": _rms(held.values()),
            }
        return out


def _rms(values: Iterable[float]) -> float | None:
    v = [x for x in values if math.isfinite(x)]
    return float(np.sqrt(np.mean(np.square(v)))) if v else None


def diagnose(campaign: Campaign, settings: DiagnosisSettings = DIAGNOSIS) -> Diagnosis:
    """Where the model misses the campaign, which candidate effect explains it, and how far the gap shrinks
    (``settings``: the decision thresholds)."""
    effects = diagnose_effects(campaign, settings=settings)
    where = diagnose_where(campaign, settings, effects.kind == "no significant gap")
    forces, relative = isolator_forces(campaign, where.parameters)
    return Diagnosis(campaign, where, effects, forces, relative)
