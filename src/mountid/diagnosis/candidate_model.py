"""A campaign's machine with one candidate effect as a function of a flat parameter vector: matrices,
modes labelled by shape and frequency, predicted frequencies and scaled shapes (mountid.diagnosis.candidates
fits them)."""

from __future__ import annotations

import itertools
import math
import weakref
from collections.abc import Callable
from dataclasses import dataclass
from typing import TypeVar

import numpy as np
import scipy.optimize
import scipy.stats

from mountid.diagnosis.campaign import DEFAULT_FREQUENCY_STD, Campaign
from mountid.diagnosis.strategies import strategy
from mountid.effects import Effect, Pair
from mountid.errors import InputError
from mountid.identification.labelling import LABELLING, LabellingSettings, assign
from mountid.machine import call, read_only, recently_used, undamped_modes
from mountid.measurement.modes import scaled_unit

DEGENERATE = 1e-6
"""Model modes closer than this in relative frequency are equal (twins): their combination is free. Modes
the measurement barely separates (a few standard deviations of the measured frequency) are compared with
the measured shape through their common span, blended smoothly into the single mode as they move apart."""


SPREAD_GRID = (0.125, 0.375, 0.625, 0.875)
"""Where CandidateModel.spread puts the starts along each plausible range of an effect of one or two
parameters (as shares of the range)."""
SPREAD_POINTS = 16
"""Starts CandidateModel.spread draws for an effect (or pair) of three or more parameters."""


@dataclass(frozen=True)
class Prediction:
    """Frequencies [rad/s], scaled unit shapes (6,) per mode label, and for each label an orthonormal basis
    (6, c) of the modes the measurement cannot separate from it with the weight of that basis (see
    :meth:`Data.residuals`)."""

    frequencies: np.ndarray
    shapes: np.ndarray
    """Row k: the scaled unit shape (6,) of labelled mode k."""
    clusters: list[tuple[np.ndarray, float] | None]
    damping: np.ndarray | None = None
    """Damping ratio of each mode (None when the campaign measures none)."""


@dataclass(frozen=True)
class CampaignFrame:
    """What every candidate model of one campaign shares, computed once per campaign (a blind case builds some
    40 models of each of its campaigns). Shared by them: the arrays are read-only, the dicts not to be changed."""

    damped: bool
    """Whether the campaign measures damping ratios."""
    damping_unknown: tuple[str, ...]
    """Damping parameters fitted with the stiffnesses (CandidateModel.damping_unknown)."""
    unknown: tuple[str, ...]
    """The machine's unknowns, then damping_unknown."""
    known: dict[str, float]
    """Every other parameter's value: the campaign's known ones, else the description's."""
    start_unknowns: dict[str, float]
    """The unknowns' nominal values (where fits start)."""
    scales: dict[str, float]
    """The generated effect_scales() at the nominal values."""
    omega_ref: float
    """Geometric mean of the measured frequencies [rad/s]."""
    reference: np.ndarray
    """Scaled unit shapes (6, n_modes) modes are labelled by: the measured ones where measured, else the
    generated (block-pure) modal matrix at the nominal values."""
    reference_lambda: np.ndarray
    """Squared frequencies [rad^2/s^2] of the reference modes: measured where measured, else nominal."""
    rows: tuple[int, ...]
    """Each measured label's mode index (the generated module's MODES)."""
    resolution: np.ndarray
    """Relative standard deviation of each mode's measured frequency (DEFAULT_FREQUENCY_STD where not measured)."""


def _campaign_frame(campaign: Campaign) -> CampaignFrame:
    machine = campaign.machine
    mod = machine.module
    labels = tuple(campaign.modes)
    damped = any(m.damping_ratio is not None for m in campaign.modes.values())
    damping_unknown = tuple(n for n in machine.damping if n not in campaign.known) if damped else ()
    unknown = machine.unknown + damping_unknown
    known = machine.values(campaign.known, tuple(n for n in mod.PARAMETERS if n not in unknown))
    start = machine.values({}, unknown)
    nominal = {**known, **start}
    scales = {k: float(v) for k, v in call(mod, "effect_scales", nominal).items()}
    length = scales["length"]
    measured = [campaign.modes[lab].frequency for lab in labels]
    # modes are paired with labels by shape and frequency: the measured ones where measured, else the
    # generated (block-pure) modal matrix and frequencies at the nominal values
    fwd = _pick(nominal, mod.FORWARD_ARGUMENTS)
    reference = scaled_unit(np.asarray(mod.modal_matrix(**fwd)), length)
    reference_lambda = np.asarray(mod.squared_frequencies(**fwd), dtype=float).copy()
    resolution = np.full(len(mod.MODES), DEFAULT_FREQUENCY_STD)
    for i, label in enumerate(mod.MODES):
        m = campaign.modes.get(label)
        if m is not None:
            resolution[i] = m.frequency_std / m.frequency
            reference_lambda[i] = m.frequency**2
            if m.shape is not None:
                reference[:, i] = scaled_unit(np.array(m.shape, dtype=float)[:, None], length)[:, 0]
    for a in (reference, reference_lambda, resolution):
        a.setflags(write=False)
    return CampaignFrame(
        damped,
        damping_unknown,
        unknown,
        known,
        start,
        scales,
        float(np.exp(np.mean(np.log(measured)))),
        reference,
        reference_lambda,
        tuple(mod.MODES.index(label) for label in labels),
        resolution,
    )


_FRAMES: dict[int, tuple[weakref.ref, CampaignFrame]] = {}
"""campaign_frame's results by the campaign's id, with a weak reference that tells a live campaign from a new one
at a reused id (and drops the entry with the campaign)."""


def campaign_frame(campaign: Campaign) -> CampaignFrame:
    """The frame of ``campaign``, computed once while the campaign lives (a campaign is frozen)."""
    key = id(campaign)
    kept = _FRAMES.get(key)
    if kept is not None and kept[0]() is campaign:
        return kept[1]
    frame = _campaign_frame(campaign)
    _FRAMES[key] = (weakref.ref(campaign, lambda _, key=key: _FRAMES.pop(key, None)), frame)
    return frame


class CandidateModel:
    """The campaign's machine, optionally with one candidate effect, as a function of a flat parameter
    vector: log of each unknown (the machine's unknown stiffnesses, then the damping parameters fitted where
    damping ratios are measured), then each effect parameter (log for strictly positive ranges, else in units of
    its scale)."""

    def __init__(
        self,
        campaign: Campaign,
        effect: Effect | Pair | None,
        variant: int | None = None,
        within_plausible: bool = False,
    ) -> None:
        self.campaign = campaign
        self.effect = effect
        self._kept: dict[str, dict] = {}
        self.strategy = strategy(effect)
        names = self.strategy.variants(campaign)
        if (variant is None) != (not names) or (variant is not None and not 0 <= variant < len(names)):
            where = f"one of 0..{len(names) - 1} ({', '.join(names)})" if names else "None (it acts once)"
            raise InputError(
                "variant", f"{effect.name if effect else 'the nominal model'} takes {where}, got {variant}"
            )
        self.variant = variant
        """Which isolator or channel a per-variant effect acts at (the strategy's variants)."""
        self.within_plausible = within_plausible
        """Whether the effect parameters are searched within their plausible ranges only (bounds), not the
        wider search box: the refit of a candidate whose free fit left them (candidates.fit_all)."""
        self.mod = campaign.machine.module
        self.labels = tuple(campaign.modes)
        frame = campaign_frame(campaign)
        self.damped = frame.damped
        """Whether the campaign measures damping ratios (the model's are then computed)."""
        self.damping_unknown = frame.damping_unknown
        """Damping parameters fitted with the stiffnesses: those the campaign does not know, where it measures
        damping ratios (else the known or nominal values)."""
        self.unknown = frame.unknown
        self.known = frame.known
        self.start_unknowns = frame.start_unknowns
        self.scales = frame.scales
        self.length = self.scales["length"]
        self.effect_parameters = effect.parameters if effect else ()
        self.log_scaled = tuple(p.magnitude for p in self.effect_parameters)
        self.parameter_names: tuple[str, ...] = tuple(self.unknown) + tuple(p.name for p in self.effect_parameters)
        """Names of the entries of the flat vector: the unknowns, then the effect parameters."""
        self.omega_ref = frame.omega_ref
        self.reference = frame.reference
        self.reference_lambda = frame.reference_lambda
        self._rows = frame.rows
        self.resolution = frame.resolution

    # -- parameter vector ---------------------------------------------------------------------------
    def start(self) -> list[np.ndarray]:
        """Starting vectors: the effect's start values; where an effect has positive parameters with wide
        ranges (a factor 100 or more: the support's mass and stiffness) a 2 x 2 grid over their decades, the
        others at their start; for an effect of two or more parameters with signed ones (a height, an offset)
        each signed parameter (EffectParameter.both_sides) at half its plausible bound on either side, the
        others at the middle of their range (at its start, often 0, the effect vanishes, the signed one has no
        gradient and slides to whichever side the unknowns prefer); last the middle of the plausible range, and
        where that puts a signed parameter off zero (a lopsided range) its mirror image through zero. Sets
        ``mandatory_starts``: the first starts, which always run (the others run only while the fit stays
        above noise level)."""
        base = [math.log(self.start_unknowns[u]) for u in self.unknown]
        params = self.effect_parameters

        def vector(values: list[float]) -> np.ndarray:
            out = list(base)
            for v, log in zip(values, self.log_scaled, strict=True):
                out.append(math.log(v) if log else v)
            return np.array(out)

        first = [p.start for p in params]
        starts = [vector(first)]
        self.mandatory_starts = 1
        wide = [
            i
            for i, (p, log) in enumerate(zip(params, self.log_scaled, strict=True))
            if log and p.plausible[1] >= 100 * p.plausible[0]
        ]
        if wide:
            grid = [
                [p.plausible[0] * (p.plausible[1] / p.plausible[0]) ** f for f in (0.3, 0.7)]
                if i in wide
                else [p.start]
                for i, p in enumerate(params)
            ]
            starts += [vector(point) for point in itertools.product(*grid)]
        elif len(params) >= 2:
            middle = [p.middle for p in params]
            for i, p in enumerate(params):
                if p.signed and p.both_sides:
                    for bound in p.plausible:
                        starts.append(vector([bound / 2 if j == i else v for j, v in enumerate(middle)]))
            self.mandatory_starts = len(starts)
        if params:
            middle = [p.middle for p in params]
            starts.append(vector(middle))
            # a signed parameter whose range is lopsided (a scatter of -0.5 to 1) has its middle on one side: its
            # mirror image through zero too (a softer isolator's minimum is not reached from a stiffer start)
            mirror = [-v if p.signed else v for p, v in zip(params, middle, strict=True)]
            if mirror != middle:
                starts.append(vector(mirror))
        return starts

    def held_first(self) -> np.ndarray:
        """Indices in the flat vector of the effect parameters a fit from the default starts holds at their start
        before releasing them (EffectParameter.refines)."""
        n = len(self.unknown)
        return np.array([n + i for i, p in enumerate(self.effect_parameters) if p.refines], dtype=int)

    def with_refinements_at_start(self, vectors: list[np.ndarray]) -> list[np.ndarray]:
        """Each flat vector with its refining parameters (held_first) set to their start values."""
        held, start = self.held_first(), self.start()[0]
        out = []
        for x in vectors:
            y = np.array(x, dtype=float)
            y[held] = start[held]
            out.append(y)
        return out

    def plausible_box(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper ends of each effect parameter's plausible range in the units of the flat vector (log
        for positive ranges): the spread starts' box and the plausibility checks' reference."""
        ends = [
            [math.log(v) for v in p.plausible] if log else list(p.plausible)
            for p, log in zip(self.effect_parameters, self.log_scaled, strict=True)
        ]
        box = np.array(ends, dtype=float).reshape(-1, 2)
        return box[:, 0], box[:, 1]

    def spread(self) -> list[np.ndarray]:
        """Starts spread over the effect parameters' plausible ranges (log for positive ones), the unknowns at
        their nominal values: for one or two parameters a grid at 1/8, 3/8, 5/8 and 7/8 of each range, for more
        SPREAD_POINTS points of a scrambled Sobol sequence (fixed seed). Where the default starts all stop
        above noise level a fit goes on from the one whose Gauss-Newton step promises most (a scatter of one
        isolator whose basin none of the default starts lies in)."""
        params = self.effect_parameters
        if not params:
            return []
        if len(params) <= 2:
            unit = np.array(list(itertools.product(SPREAD_GRID, repeat=len(params))))
        else:
            unit = scipy.stats.qmc.Sobol(len(params), scramble=True, seed=0).random(SPREAD_POINTS)
        base = self.start()[0]
        n = len(self.unknown)
        a, b = self.plausible_box()
        out = []
        for u in unit:
            x = base.copy()
            x[n:] = a + u * (b - a)
            out.append(x)
        return out

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Search box: unknowns within UNKNOWN_RANGE of their nominal values either way (log), effect
        parameters within their plausible range widened by its width on each side (log ranges by a factor 10);
        with ``within_plausible`` within their plausible range."""
        centre = [math.log(self.start_unknowns[u]) for u in self.unknown]
        lo = [c - math.log(UNKNOWN_RANGE) for c in centre]
        hi = [c + math.log(UNKNOWN_RANGE) for c in centre]
        if self.within_plausible:
            a, b = self.plausible_box()
            return np.array(lo + list(a)), np.array(hi + list(b))
        for p, log in zip(self.effect_parameters, self.log_scaled, strict=True):
            a, b = p.plausible
            if log:
                lo.append(math.log(a / 10))
                hi.append(math.log(b * 10))
            else:
                lo.append(a - (b - a) if p.floor is None else p.floor)
                hi.append(b + (b - a))
        return np.array(lo), np.array(hi)

    def physical(self, theta: np.ndarray) -> dict[str, float]:
        """Unknowns [SI] and effect parameters [their units] from the flat vector."""
        n = len(self.unknown)
        out = {u: float(np.exp(theta[i])) for i, u in enumerate(self.unknown)}
        for k, (p, log) in enumerate(zip(self.effect_parameters, self.log_scaled, strict=True)):
            v = theta[n + k]
            out[p.name] = float((np.exp(v) if log else v) * self.scales[p.scale])
        return out

    def mirrored(self, theta: np.ndarray) -> np.ndarray:
        """``theta`` with each signed effect parameter (a plausible range across zero: a scatter, a turn, an
        offset) through zero: a per-isolator fit's other-sign start (a softer isolator where the best one was
        stiffer)."""
        out = theta.copy()
        n = len(self.unknown)
        for k, p in enumerate(self.effect_parameters):
            if p.signed:  # never log-scaled (EffectParameter.magnitude)
                out[n + k] = -out[n + k]
        return out

    def vector(self, physical: dict[str, float]) -> np.ndarray:
        """The flat vector of physical values (inverse of :meth:`physical`)."""
        out = [math.log(physical[u]) for u in self.unknown]
        for p, log in zip(self.effect_parameters, self.log_scaled, strict=True):
            v = physical[p.name] / self.scales[p.scale]
            out.append(math.log(v) if log else v)
        return np.array(out)

    def jacobian_to_physical(self, theta: np.ndarray, physical: dict[str, float] | None = None) -> np.ndarray:
        """d(physical)/d(theta), diagonal (``physical``: :meth:`physical` of ``theta`` where the caller has it)."""
        phys = self.physical(theta) if physical is None else physical
        d = [phys[u] for u in self.unknown]
        for p, log in zip(self.effect_parameters, self.log_scaled, strict=True):
            d.append(phys[p.name] if log else self.scales[p.scale])
        return np.array(d)

    # -- the model -------------------------------------------------------------------------------------
    def evaluate(self, theta: np.ndarray, labels: tuple[str, ...] | None = None) -> Evaluation:
        """Every intermediate of :meth:`predict` (the analytic Jacobian of a fit differentiates them), kept
        (:meth:`kept`): a least-squares step asks for the residuals and then the Jacobian at one point."""
        key = (np.asarray(theta, dtype=float).tobytes(), labels)
        return self.kept("evaluation", key, lambda: self._evaluate(theta, labels))

    def kept(self, kind: str, key: object, compute: Callable[[], _T]) -> _T:
        """``compute()``, or what it gave for the same ``kind`` and ``key`` (the parameter vector's bytes: -0.0 is
        not 0.0; None for what a strategy computes once per model, a channel layout) among the last KEPT_POINTS
        of that kind. Nothing is kept where ``compute`` raises."""
        return recently_used(self._kept.setdefault(kind, {}), key, compute, KEPT_POINTS)

    def forget(self) -> None:
        """Drop what :meth:`kept` keeps but the last of each kind (a finished fit's model lives on in its report;
        the last is the fit's own point)."""
        for kind, store in self._kept.items():
            self._kept[kind] = dict([store.popitem()]) if store else store

    def _evaluate(self, theta: np.ndarray, labels: tuple[str, ...] | None) -> Evaluation:
        values = {**self.known, **self.physical(theta)}
        mats = self.strategy.matrices(self, values)
        m, c, _ = mats
        lam, vec = self.strategy.modes(self, values, mats, *undamped_modes(c, m))
        body = scaled_unit(vec[:6, :], self.length)
        share = np.einsum("ij,ik,kj->j", vec[:6], m[:6, :6], vec[:6]) if len(m) > 6 else None
        twins = twin_groups(lam)
        omega = self.strategy.frequencies(self, values, mats, lam)
        shapes = self.strategy.shapes(self, values, vec)  # the body motion as the sensors read it
        # the shapes as compared with the measured ones: the body motion itself (the strategy's view of the
        # vectors) unless the sensors turn it (a reading equal to it to the bit gives the same unit shapes)
        unit = body if shapes.base is vec else scaled_unit(shapes, self.length)
        # labelled by the motion of the body itself, or where the strategy says so by the shapes as read
        read = unit if self.strategy.labels_as_read else body
        order = label_modes(lam, read, self.reference_lambda, self.reference, share, twins=twins)
        rows = np.array(self._rows if labels is None else [self.mod.MODES.index(label) for label in labels])
        index = order[rows]
        # closeness of every model mode to each labelled one, in units of the measurement's resolution of
        # that frequency (relative); within a few units the measured shape may be any mix of them
        gap = np.abs(lam[index, None] - lam[None, :]) / (2 * np.abs(lam[index, None]) * self.resolution[rows, None])
        zeta = self.strategy.damping_ratios(self, values, mats, lam) if self.damped else None
        # an evaluation is kept (kept()) and shared: its arrays are read-only
        omega, shapes, index, gap, weight, unit, zeta = read_only(
            (omega, shapes, index, gap, np.exp(-(gap**2)), unit, zeta)
        )
        return Evaluation(values, mats, lam, vec, omega, shapes, index, gap, weight, twins, unit, zeta)

    def predict(self, theta: np.ndarray, labels: tuple[str, ...] | None = None) -> Prediction:
        """Frequencies and scaled shapes of the modes ``labels`` (default: the measured ones)."""
        e = self.evaluate(theta, labels)
        lam, index, weight = e.lam, e.index, e.weight
        body = e.unit
        partners = weight > PARTNER_WEIGHT
        shapes = body[:, index].T
        clusters: list[tuple[np.ndarray, float] | None] = [None] * len(index)
        spans: dict[bytes, np.ndarray] = {}
        for k in np.flatnonzero(partners.sum(axis=1) > 1):
            j = index[k]
            key = partners[k].tobytes()
            if key not in spans:
                spans[key] = _orthonormal(body[:, partners[k]])
            near = np.flatnonzero(partners[k])
            # the weakest partner sets how far the mix is allowed
            clusters[k] = (spans[key], 1.0 if exact_twins(lam, j, near) else float(np.min(weight[k, near])))
        return Prediction(e.omega[index], shapes, clusters, None if e.zeta is None else e.zeta[index])

    def support_motion(self, theta: np.ndarray, labels: tuple[str, ...]) -> np.ndarray | None:
        """Per mode of ``labels``: the largest motion of the support at an isolator's foot over the largest motion
        of the machine at an isolator (displacement magnitudes, the generated point_jacobian applied to the
        support's coordinates at the generated support_feet and to the body's at isolator_points); None for a
        model whose isolators stand on rigid ground. What an accelerometer on the support below an isolator,
        against one on the machine above it, would read."""
        e = self.evaluate(theta, labels)
        if e.vec.shape[0] <= 6:
            return None
        points = np.asarray(call(self.mod, "isolator_points", e.values))  # (3, isolators) [m]
        feet = np.asarray(call(self.mod, "support_feet", e.values))  # the same feet in the support's coordinates
        on_body = np.asarray(self.mod.point_jacobian(*points))  # (isolators, 3, 6)
        on_support = np.asarray(self.mod.point_jacobian(*feet))
        modes = e.vec[:, e.index]
        body = np.linalg.norm(on_body @ modes[:6], axis=1).max(axis=0)  # (modes,)
        support = np.linalg.norm(on_support @ modes[6:12], axis=1).max(axis=0)
        return support / np.where(body > 0, body, np.inf)


KEPT_POINTS = 32
"""Evaluations (and Jacobians: fitting; a channel's layout transform: strategies) a candidate model keeps, the
most recently used of each kind. Besides the residuals and the Jacobian of one step, a fit asks again where
another ended or was screened: a carried-on or released fit starts at the best fit's end, a start picked by its
one-step promise (fitting.promises) is fitted from there, and a pair's screened starts may repeat (genset8: 87
evaluations and 65 Jacobians of about 1400 per diagnosis were repeats on their model; 10 and 9 are left with 32
kept). A finished fit keeps one of each (:meth:`forget`)."""

_T = TypeVar("_T")

UNKNOWN_RANGE = 1e4
"""How far the fit may take an unknown from its nominal value (a factor either way): far beyond any machine
built to its description, short of overflowing the matrices."""

PARTNER_WEIGHT = 1e-3
"""A model mode whose closeness weight to a labelled mode exceeds this is a partner: the measured shape is
compared with the span of the partners (see :meth:`CandidateModel.predict`)."""


def exact_twins(lam: np.ndarray, j: int, near: np.ndarray) -> bool:
    """Whether the modes ``near`` all have the eigenvalue of mode ``j`` (twins; relative :data:`DEGENERATE`)."""
    return bool((np.abs(lam[near] - lam[j]) <= DEGENERATE * abs(lam[j])).all())


@dataclass(frozen=True)
class Evaluation:
    """The candidate model at one parameter vector: parameter ``values``, matrices ``mats`` (M, C, B), the
    eigenvalues ``lam`` and M-normalised eigenvectors ``vec`` of (C, M), the model frequencies ``omega``
    [rad/s] and body ``shapes`` (6, n) of every mode, the model mode ``index`` of each labelled mode, and the
    closeness ``gap`` (in units of the measured resolution) and ``weight`` of every model mode to each
    labelled one."""

    values: dict[str, float]
    mats: tuple
    lam: np.ndarray
    vec: np.ndarray
    omega: np.ndarray
    shapes: np.ndarray
    index: np.ndarray
    gap: np.ndarray
    weight: np.ndarray
    twins: list[tuple[np.ndarray, list[int]]]
    """The sets of modes with equal eigenvalues (:func:`twin_groups` of ``lam``)."""
    unit: np.ndarray
    """The ``shapes`` as compared with measured ones (:func:`scaled_unit`)."""
    zeta: np.ndarray | None = None
    """Damping ratio of every mode (None unless the campaign measures damping ratios)."""


def _pick(values: dict[str, float], names: tuple[str, ...]) -> dict[str, float]:
    return {n: values[n] for n in names}


def label_modes(
    lam: np.ndarray,
    body: np.ndarray,
    reference_lambda: np.ndarray,
    reference: np.ndarray,
    participation: np.ndarray | None = None,
    settings: LabellingSettings = LABELLING,
    twins: list[tuple[np.ndarray, list[int]]] | None = None,
) -> np.ndarray:
    """Index of the model mode for each reference mode: one-to-one, by MAC with the reference shapes
    (scaled unit columns) times the share of the mode's kinetic energy in the body (``participation``, for
    models with more coordinates than the body's: a foundation mode is not a machine mode however its small
    body motion looks) and, to break ties between modes of equal shape, closeness in frequency. ``twins``:
    :func:`twin_groups` of ``lam`` where the caller has them."""
    mac = (reference.T @ body) ** 2
    # modes of equal frequency (twins) may come in any combination: each is matched by the reference's
    # projection on their common span
    for group, members in twin_groups(lam) if twins is None else twins:
        mac[:, members] = np.add.reduce((reference.T @ _orthonormal(body[:, group])) ** 2, axis=1)[:, None]
    if participation is not None:
        mac = mac * participation[None, :]
    log_ratio = np.log(np.abs(lam)[None, :] / reference_lambda[:, None])  # ln(lambda / lambda_reference)
    rows, cols, cost = assign(-mac, log_ratio, settings.model_frequency_weight)
    out = np.empty(len(reference_lambda), dtype=int)
    out[rows] = _tied_in_frequency_order(cost, np.abs(lam), reference_lambda, rows, cols)
    return out


TIED_COST = 1e-6
"""Two pairings of labels with modes whose total labelling costs differ by less than this are tied: rounding,
not the data, would tell them apart. The costs are MACs (and log frequency ratios), and the eigenvectors of two
modes close in frequency carry LAPACK's rounding magnified by one over their gap: a scattered isolator on a
frame under kid300 (blind seed 66) leaves two modes 5e-6 apart, each with MAC 0.4996 with both twins' labels,
whose pairings cost the same to 1e-9 and came out in the other order under another BLAS kernel. A measured
MAC is never known to 1e-6."""
SAME_FREQUENCY = 1e-12
"""Relative difference of two squared frequencies below which they are the same (twins up to rounding: LAPACK
gives equal eigenvalues to a few eps; a forward-difference step of 1.5e-8 parts twins by about 1e-10, and the
frequency order then labels the parted pair)."""


def _tied_in_frequency_order(
    cost: np.ndarray, lam: np.ndarray, reference_lambda: np.ndarray, rows: np.ndarray, cols: np.ndarray
) -> np.ndarray:
    """``cols`` (the model modes assign gave the reference ``rows``) with every two pairs whose exchange costs
    the same (within TIED_COST) paired in the order of frequency: the lower reference frequency, or of two equal
    ones the first label (twins: x before y), with the lower model frequency; as the records chain names parted
    twins (from_records.label_poles). Such ties are exact by symmetry: one isolator of kid300's diagonal layout
    stiffer parts the twins x and y along the diagonals, each with MAC 1/2 with either label's nominal shape, and
    with the twins' equal nominal frequencies (or with four frequencies on one side) both pairings cost the same;
    the solver's pick then followed the last bits of LAPACK's eigenvectors (docs/validation.md, "Ties, not
    kernels"). Model modes of the same frequency keep their pairing (their combination is free: twin_groups)."""
    paired = cost[np.ix_(rows, cols)]  # pair i's reference with pair j's mode
    own = np.diag(paired)
    exchange = paired + paired.T - own[:, None] - own[None, :]
    tied = np.argwhere(np.triu(np.abs(exchange) <= TIED_COST, 1))
    if not len(tied):
        return cols  # no tie (the common case)
    cols = cols.copy()

    def before(a: float, b: float) -> int:  # -1, 0 or 1: a below, at or above b (relative SAME_FREQUENCY)
        return 0 if abs(a - b) <= SAME_FREQUENCY * max(abs(a), abs(b)) else (-1 if a < b else 1)

    for i, j in tied:
        ri, rj = rows[i], rows[j]
        reference = before(reference_lambda[ri], reference_lambda[rj]) or (-1 if ri < rj else 1)
        model = before(lam[cols[i]], lam[cols[j]])
        if model and model != reference:
            cols[i], cols[j] = cols[j], cols[i]
    return cols


def twin_groups(lam: np.ndarray) -> list[tuple[np.ndarray, list[int]]]:
    """The sets of modes with equal eigenvalues (within DEGENERATE of mode j's, relative): (boolean mask of
    the set, the modes j whose set it is), for every set of two or more."""
    size = np.abs(lam)
    ordered = np.sort(lam)  # the differences below are np.diff's without its call (a third of the time)
    if (ordered[1:] - ordered[:-1]).min(initial=math.inf) > DEGENERATE * size.max(initial=0.0):
        return []  # no two within DEGENERATE of the largest: none within it of either (the common case, cheaply)
    near = np.abs(lam[:, None] - lam[None, :]) <= DEGENERATE * size[None, :]
    groups: dict[bytes, tuple[np.ndarray, list[int]]] = {}
    for j in np.flatnonzero(near.sum(axis=0) > 1):
        groups.setdefault(near[:, j].tobytes(), (near[:, j], []))[1].append(int(j))
    return list(groups.values())


def _orthonormal(basis: np.ndarray) -> np.ndarray:
    """Orthonormal columns spanning the (unit) columns of ``basis``: Gram-Schmidt for the common pair of
    twins, QR otherwise."""
    if basis.shape[1] == 2:
        a, b = basis[:, 0], basis[:, 1]
        b = b - a * (a @ b)
        norm = np.sqrt(b.dot(b))  # np.linalg.norm(b)
        return np.column_stack([a, b / norm]) if norm > 1e-12 else a[:, None]  # parallel: one direction
    q, r = np.linalg.qr(basis)
    return q[:, np.abs(np.diag(r)) > 1e-12]


def off_span(s: np.ndarray, basis: np.ndarray) -> np.ndarray:
    """The part of s outside the span of a unit vector (or of orthonormal columns)."""
    if basis.ndim == 1:
        return s - basis * (basis @ s)
    return s - basis @ (basis.T @ s)
