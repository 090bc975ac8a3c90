"""Weighted least-squares fit of one candidate (with the machine's unknowns) to a campaign, its covariance
and its leave-one-mode-out held-out errors."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np
import scipy.linalg
import scipy.optimize
import scipy.special
import scipy.stats

from mountid.diagnosis.campaign import Campaign, damping_std
from mountid.diagnosis.candidate_model import CandidateModel, Prediction, off_span
from mountid.diagnosis.jacobian import jacobian
from mountid.effects import Effect, Pair
from mountid.identification.least_squares import VectorFunction, trust_region
from mountid.identification.statistics import covariance, standard_deviations
from mountid.machine import read_only
from mountid.measurement.modes import scaled_unit


@dataclass(frozen=True)
class FitState:
    """What a fit leaves behind for later refits (leave-one-out, separation, warm starts) and for its evidence
    at another noise level (the ranking's tempering): the candidate model, the fitted flat parameter vector,
    and the whitened data-row Jacobian, chi^2 and refining parameters' offsets from their starts
    (log_evidence) of each variant whose evidence the candidate's averages (one, or one per isolator). Not part
    of the result's value."""

    model: CandidateModel
    theta: np.ndarray
    evidence_terms: tuple[tuple[np.ndarray, float, np.ndarray], ...] = ()
    variants_by_fit: tuple[str, ...] = ()
    """For an effect fitted per isolator or channel: the variants from the best fitting to the worst."""
    variant_parameters: tuple[dict[str, float], ...] = ()
    """The fitted values at each of those variants, in the same order (a pair screened at an isolator starts
    from its member's fit at that isolator)."""


@dataclass(frozen=True)
class CandidateFit:
    """One fitted candidate: effect (``none`` for the nominal model), fitted values with standard deviations."""

    effect: str
    variant: str
    parameters: dict[str, float]
    std: dict[str, float]
    chi2: float
    n_data: int
    n_parameters: int
    aicc: float
    plausible: bool
    implausible_reason: str
    frequency_gap: dict[str, float]
    """measured - fitted model frequency [rad/s] per measured mode."""
    held_out_gap: dict[str, float] = field(default_factory=dict)
    """measured - prediction of the fit without that mode [rad/s] (leave one mode out)."""
    damping_gap: dict[str, float] = field(default_factory=dict)
    """measured - fitted model damping ratio per mode whose damping ratio the campaign measures."""
    held_out_exact: bool = False
    applicable: bool = True
    note: str = ""
    held_out_rms: float = math.nan
    """RMS of the held-out frequency errors in units of their standard deviation (set by the ranking)."""
    held_out_median: float = math.nan
    """Median of |held-out frequency error| / standard deviation over the modes: robust to the one mode
    whose omission leaves a parameter poorly determined (set by the ranking)."""
    held_out_variance: dict[str, float] = field(default_factory=dict)
    """Variance of each held-out frequency error in units of the frequency's variance, to first order: 1 plus
    the variance of the refit's prediction, [(I - H_gg)^-1]_00 of the weighted hat matrix H for the mode's rows
    g (nan where the mode alone determines a parameter). Large where the other modes barely determine the
    parameters that predict this one (a machine of four unknown stiffnesses measured at six frequencies)."""
    held_out_median_predictive: float = math.nan
    """Median of |held-out frequency error| / its predictive standard deviation (sigma times the square root of
    held_out_variance): whether the held-out modes are consistent with the fit, where held_out_median says
    whether it predicts them to within the measurement's uncertainty (set by the ranking)."""
    log_evidence: float = -math.inf
    """Laplace approximation of log p(data | candidate) (see :func:`log_evidence`; -inf when not applicable):
    for a candidate fitted per isolator or channel the mean over them (see ``evidence_offset``)."""
    evidence_offset: float = 0.0
    """Added to the log of the summed evidence of the variants: -log(number of variants) for a candidate whose
    isolator or channel is unknown (its evidence is the mean over them), else 0."""
    log_prior: float = 0.0
    """Log prior odds of the candidate against a single effect (0; a pair of effects, or an effect that stands for
    two of one kind, less: DiagnosisSettings.pair_prior, candidates.effect_prior)."""
    probability: float = math.nan
    """Posterior probability of the candidate among those ranked (set by the ranking)."""
    log_weight: float = -math.inf
    """Log of the candidate's unnormalised posterior weight (evidence, tempered, plus log prior; set by the
    ranking; -inf where its probability is 0 by rule)."""
    outside_range: tuple[str, ...] = ()
    """Effect parameters whose fitted value lies outside the plausible range beyond RANGE_TOLERANCE
    (``plausible`` allows more, PLAUSIBLE_MARGIN; a confident verdict allows none: candidates.explains)."""
    placed_outside: tuple[str, ...] = ()
    """Effect parameters the data place outside the plausible range: beyond it by more than their standard
    deviation (a rival is ruled out by them: candidates.rejected). A parameter the data leave undetermined
    (a stiff support's shear ratio at 5 +- 100 against a range of 0.1-2) is outside_range but not placed."""
    as_good: tuple[str, ...] = ()
    """The other isolators (channels) at which the candidate fits the data as well as at ``variant`` (chi^2
    within DiagnosisSettings.tie; candidates._over_variants, and for a pair named by the verdict
    candidates._at_other_isolators): which of them it acts at, the data do not say."""
    other_solutions: tuple[dict[str, float], ...] = ()
    """Other sets of values (unknowns and effect parameters, physical units) at which the candidate fits the data
    as well (see :func:`other_solutions`; searched for the verdict's best candidate): the standard deviations
    describe the neighbourhood of the reported values only."""
    state: FitState | None = field(default=None, repr=False, compare=False)
    """The fit's state (None when the candidate is not applicable)."""

    @property
    def theta(self) -> np.ndarray | None:
        """The fitted flat parameter vector (a warm start for nearby data)."""
        return None if self.state is None else self.state.theta

    def to_dict(self) -> dict:
        """The result as plain data (non-finite numbers stay; mountid.report.jsonable turns them to null)."""
        return {
            "effect": self.effect,
            "variant": self.variant,
            "parameters": self.parameters,
            "parameter_std": self.std,
            "chi2": self.chi2,
            "n_data": self.n_data,
            "n_parameters": self.n_parameters,
            "aicc": self.aicc,
            "plausible": self.plausible,
            "implausible_reason": self.implausible_reason,
            "gap_after": self.frequency_gap,
            "damping_gap_after": self.damping_gap,
            "held_out_gap": self.held_out_gap,
            "held_out_exact": self.held_out_exact,
            "applicable": self.applicable,
            "note": self.note,
            "as_good": list(self.as_good),
            "held_out_rms_sigma": self.held_out_rms,
            "held_out_median_sigma": self.held_out_median,
            "held_out_median_predictive_sigma": self.held_out_median_predictive,
            "log_evidence": self.log_evidence,
            "probability": self.probability,
            "other_solutions": list(self.other_solutions),
        }


def chi2_by_kind(fit: CandidateFit, campaign: Campaign) -> dict[str, float]:
    """The fit's chi^2 split by what was measured: frequencies, damping ratios and (the rest) mode shapes; the
    kinds the campaign does not measure are left out."""
    freq = sum((gap / campaign.modes[lab].frequency_std) ** 2 for lab, gap in fit.frequency_gap.items())
    damp = sum((gap / damping_std(campaign.modes[lab])) ** 2 for lab, gap in fit.damping_gap.items())
    out = {"frequencies": float(freq)}
    if any(m.shape is not None for m in campaign.modes.values()):
        out["shapes"] = max(0.0, float(fit.chi2 - freq - damp))
    if fit.damping_gap:
        out["damping ratios"] = float(damp)
    return out


class Data:
    """The campaign's measurements as weighted data rows (see the module docstring)."""

    def __init__(self, campaign: Campaign, length: float) -> None:
        self.labels = tuple(campaign.modes)
        modes = [campaign.modes[lab] for lab in self.labels]
        self.omega = np.array([m.frequency for m in modes])
        self.sigma = np.array([m.frequency_std for m in modes])
        self.shape_labels = tuple(lab for lab, m in zip(self.labels, modes, strict=True) if m.shape is not None)
        measured = [campaign.modes[lab].shape for lab in self.shape_labels]
        self.shape_matrix = scaled_unit(np.array(measured, dtype=float).reshape(-1, 6).T, length)
        """The measured shapes as columns (6, n_shapes) in the order of ``shape_labels``, scaled to unit length
        (measurement.modes.scaled_unit)."""
        self.shape_sigma = np.array([campaign.modes[lab].shape_std for lab in self.shape_labels], dtype=float)
        self.shape_index = np.array([self.labels.index(lab) for lab in self.shape_labels], dtype=int)
        """The index in ``labels`` of each measured shape's mode."""
        self.damping_labels = tuple(
            lab for lab, m in zip(self.labels, modes, strict=True) if m.damping_ratio is not None
        )
        self.damping_index = np.array([self.labels.index(lab) for lab in self.damping_labels], dtype=int)
        """The index in ``labels`` of each measured damping ratio's mode."""
        self.zeta = np.array([campaign.modes[lab].damping_ratio for lab in self.damping_labels], dtype=float)
        self.zeta_sigma = np.array(
            [damping_std(campaign.modes[lab]) for lab in self.damping_labels],
            dtype=float,
        )
        self.signature = (
            self.labels,
            self.shape_labels,
            self.damping_labels,
            b"".join(
                a.tobytes()
                for a in (self.omega, self.sigma, self.shape_matrix, self.shape_sigma, self.zeta, self.zeta_sigma)
            ),
        )
        """Everything the rows depend on: two Data alike give the same Jacobian (CandidateModel.kept)."""
        self.n = len(self.labels) + 5 * len(self.shape_labels) + len(self.damping_labels)
        """Data count: one per frequency, five per shape (six components less the free scale), one per damping
        ratio."""

    @property
    def n_rows(self) -> int:
        """Residual rows: one per frequency, six per shape, one per damping ratio (the prior rows follow)."""
        return len(self.labels) + 6 * len(self.shape_labels) + len(self.damping_labels)

    def residuals(self, pred: Prediction) -> np.ndarray:
        rows = [(self.omega - pred.frequencies) / self.sigma]
        if self.shape_labels:
            s = self.shape_matrix
            u = pred.shapes[self.shape_index].T  # (6, n_shapes)
            own = s - u * np.add.reduce(u * s, axis=0)  # off_span of each column, at once
            for col, i in enumerate(self.shape_index):
                cluster = pred.clusters[i]
                if cluster is not None:  # blended, so that the residual is continuous as modes split
                    basis, w = cluster
                    own[:, col] = w * off_span(s[:, col], basis) + (1 - w) * own[:, col]
            rows.append((own / self.shape_sigma[None, :]).T.ravel())
        if self.damping_labels:
            zeta = pred.damping[self.damping_index]
            rows.append((self.zeta - zeta) / self.zeta_sigma)
        return np.concatenate(rows)

    def rows_of(self, label: str) -> np.ndarray:
        """Row indices of one mode's data (its frequency and, if measured, its shape components)."""
        idx = [self.labels.index(label)]
        if label in self.shape_labels:
            k = self.shape_labels.index(label)
            first = len(self.labels) + 6 * k
            idx += list(range(first, first + 6))
        if label in self.damping_labels:
            idx.append(len(self.labels) + 6 * len(self.shape_labels) + self.damping_labels.index(label))
        return np.array(idx)


# -- fitting -----------------------------------------------------------------------------------------------
_FAILED = 1e6
"""Residual assigned to every row where the model cannot be evaluated (singular matrices)."""


PRIOR_WEIGHT = 0.1
"""Weight of the weak prior rows PRIOR_WEIGHT (theta - start) / (plausible width) of the effect parameters:
at most 0.01 in chi^2 inside the plausible range, but it holds a parameter the data do not determine (a
sensor yaw on a machine symmetric under rotation by 90 degrees) at its start instead of letting it drift,
and makes its standard deviation large instead of zero."""


UNKNOWN_PRIOR_WIDTH = math.log(100.0)
"""Width in log units of the (log-uniform) prior on each unknown stiffness: a factor 100. The same in every
candidate, so it cancels from their evidence ratios wherever the data determine the unknowns."""


def prior_widths(model: CandidateModel) -> np.ndarray:
    """Width of the uniform prior of every fitted parameter in the units of the flat vector: the unknowns
    UNKNOWN_PRIOR_WIDTH, the effect parameters their plausible range (log-uniform where it is positive)."""
    return np.array(
        [UNKNOWN_PRIOR_WIDTH] * len(model.unknown)
        + [
            math.log(p.plausible[1] / p.plausible[0]) if log else p.plausible[1] - p.plausible[0]
            for p, log in zip(model.effect_parameters, model.log_scaled, strict=True)
        ]
    )


def prior_box(model: CandidateModel, unknowns: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper ends, in the units of the flat vector, of the uniform prior whose widths prior_widths
    gives: each unknown over UNKNOWN_PRIOR_WIDTH centred on ``unknowns`` (log; where the box sits cancels from
    the candidates' evidence ratios as long as it holds their fits), the effect parameters over their plausible
    box. The region log_evidence approximates the integral over (its checks integrate over it)."""
    a, b = model.plausible_box()
    half = UNKNOWN_PRIOR_WIDTH / 2
    return np.concatenate([unknowns - half, a]), np.concatenate([unknowns + half, b])


REFINED_AT_START = 0.5
"""Prior probability that a refining parameter (EffectParameter.refines: the support's aspect, an attached
body's anisotropy) sits exactly at its start (a support as symmetric as the isolator layout, a body alike about
x and y); the rest is spread over its plausible range."""


def log_evidence(
    jac: np.ndarray, chi2: float, widths: np.ndarray, held: np.ndarray | None = None, offsets: np.ndarray | None = None
) -> float:
    """Laplace approximation of the log marginal likelihood of a fitted candidate, up to a constant common to
    all candidates of one campaign:

        log Z = -chi^2/2 - sum log W_i + (k/2) log 2 pi - (1/2) log det A,   A = J^T J + diag(12 / W_i^2),

    J the whitened residual Jacobian at the fit (data rows only), W_i the prior widths (prior_widths). The
    uniform prior enters A as the Gaussian of equal variance (W^2/12), so that a parameter the data do not
    determine costs little (its Occam factor tends to sqrt(2 pi / 12): 0.32 nats, where the exact integral of a
    flat likelihood over the prior costs none) and a determined one costs log(W / (sqrt(2 pi) sigma)): the
    penalty grows with the prior range the data rule out, not with a fixed count per parameter as AICc's (which
    outweighs small data sets: 30 per parameter at n = 6). The Gaussian of equal height (variance W^2 / (2 pi),
    exact in both limits) was tried on held-out seeds 264-461 (3564 cases): the calibration with frequencies
    only went from 0.017 to 0.035 pooled (genset8 0.19 to 0.36) and kid300's first places where a rival fits
    alike stayed as overconfident (0.82 stated, 0.71 right), log loss unchanged: not kept.

    ``held``: the columns of refining parameters, ``offsets`` their fitted values less their starts. Their
    prior puts REFINED_AT_START at the start and the rest uniformly over the range: the evidence is the mixture
    of the model with them free and with them held, the latter by the Savage-Dickey ratio (the free model's
    Gaussian posterior density at the starts over the prior density there). Where the data pin them at
    their starts (a square frame under a square machine) the held model carries the evidence, free of the
    Occam factor a parameter the data rule out most of the range of would cost; where they exclude the starts,
    the free one does."""
    a = jac.T @ jac + np.diag(12.0 / widths**2)
    sign, logdet = np.linalg.slogdet(a)
    if sign <= 0 or not math.isfinite(chi2):
        return -math.inf
    k = len(widths)
    free = float(-0.5 * chi2 - np.sum(np.log(widths)) + 0.5 * k * math.log(2 * math.pi) - 0.5 * logdet)
    if held is None or not len(held):
        return free
    cov = np.linalg.inv(a)[np.ix_(held, held)]
    d = np.asarray(offsets, dtype=float)
    sign_c, logdet_c = np.linalg.slogdet(cov)
    if sign_c <= 0:
        return free
    log_posterior = float(-0.5 * d @ np.linalg.solve(cov, d) - 0.5 * logdet_c - 0.5 * len(held) * math.log(2 * math.pi))
    at_start = free + log_posterior + float(np.sum(np.log(widths[held])))
    return float(
        scipy.special.logsumexp([math.log(1 - REFINED_AT_START) + free, math.log(REFINED_AT_START) + at_start])
    )


def tempered_log_evidence(fit: CandidateFit, scale: float = 1.0) -> float:
    """The candidate's log evidence with every measurement's variance multiplied by ``scale`` (>= 1): the
    Laplace approximation at the fit with chi^2 / scale and the Jacobian / sqrt(scale), summed over its variants
    and offset as :attr:`CandidateFit.log_evidence` (equal to it at scale 1). The ranking tempers with the best
    candidate's chi^2 per degree of freedom when even that one misses the data beyond their uncertainty: the
    misfit is then a model error no candidate holds, and evidence ratios taken at the stated noise would be
    overconfident."""
    if fit.state is None or not fit.state.evidence_terms or not math.isfinite(fit.log_evidence):
        return fit.log_evidence
    widths = prior_widths(fit.state.model)
    held = fit.state.model.held_first()
    root = math.sqrt(scale)
    terms = [
        log_evidence(jac / root, chi2 / scale, widths, held, offsets) for jac, chi2, offsets in fit.state.evidence_terms
    ]
    return float(scipy.special.logsumexp(terms) + fit.evidence_offset)


def predictive_std(fit: CandidateFit, quantity: Callable[[np.ndarray], np.ndarray]) -> np.ndarray:
    """Standard deviation of what the fitted candidate predicts, ``quantity`` (a function of the flat parameter
    vector, an array), to first order: sqrt(g^T A^-1 g) times sqrt(max(1, chi^2 / dof)) as the parameters'
    (identification.statistics.covariance), with g its forward-difference gradient at the fit and A the
    posterior precision of the Laplace evidence (log_evidence: the data's Jacobian and the uniform prior as the
    Gaussian of equal variance), so that a parameter the data leave free spreads the prediction over its prior
    range, not to infinity."""
    model, theta = fit.state.model, fit.state.theta
    jac = fit.state.evidence_terms[0][0]
    precision = jac.T @ jac + np.diag(12.0 / prior_widths(model) ** 2)
    scale = max(1.0, fit.chi2 / (fit.n_data - fit.n_parameters)) if fit.n_data > fit.n_parameters else 1.0
    grad = forward_differences(lambda x: np.atleast_1d(quantity(x)), theta, model.bounds()[1])
    variance = np.einsum("ik,ik->i", grad, np.linalg.solve(precision, grad.T).T)
    return np.sqrt(np.maximum(variance, 0.0) * scale)


def _residual_function(
    model: CandidateModel, data: Data, rows: np.ndarray | None
) -> tuple[VectorFunction, VectorFunction]:
    start = model.start()[0]
    n = len(model.unknown)
    width = prior_widths(model)[n:]

    n_rows = data.n_rows

    def fun(theta: np.ndarray) -> np.ndarray:
        try:
            r = data.residuals(model.predict(theta))
        except (np.linalg.LinAlgError, ValueError):
            r = np.full(n_rows, _FAILED)
        if not np.isfinite(r).all():
            r = np.full(n_rows, _FAILED)
        prior = PRIOR_WEIGHT * (theta[n:] - start[n:]) / width
        return np.concatenate([r if rows is None else r[rows], prior])

    prior_rows = np.zeros((len(width), len(start)))
    prior_rows[:, n:] = np.diag(PRIOR_WEIGHT / width)

    def jac(theta: np.ndarray) -> np.ndarray:
        """Analytic (mountid.diagnosis.jacobian); forward differences for the columns where it is undefined
        (parameters that split exactly equal twins)."""
        try:
            # every row of the data, whichever rows this fit uses (read-only: it is kept)
            j = model.kept(
                "jacobian", (theta.tobytes(), data.signature), lambda: read_only(jacobian(model, data, theta))
            )
        except (np.linalg.LinAlgError, ValueError):
            return np.zeros((len(fun(theta)), len(theta)))  # the residual is the constant _FAILED here
        if j is None:
            return forward_differences(fun, theta, model.bounds()[1])
        split = np.flatnonzero(np.isnan(j).all(axis=0))
        out = np.concatenate([j if rows is None else j[rows], prior_rows])
        if len(split):
            out[:, split] = forward_differences(fun, theta, model.bounds()[1], split, SPLIT_STEP)[:, split]
        if not np.isfinite(out).all():
            return np.zeros((len(fun(theta)), len(theta)))  # as where the model fails: a step there is refused
        return out

    return fun, jac


def promised_chi2(campaign: Campaign, model: CandidateModel, starts: list[np.ndarray]) -> float:
    """The smallest chi^2 one Gauss-Newton step from any of ``starts`` predicts (the residuals and Jacobian
    there, the step of the linear least squares with the prior rows): what a fit from there promises, at the
    cost of one Jacobian per start."""
    return min(promises(campaign, model, starts), default=math.inf)


def promises(campaign: Campaign, model: CandidateModel, starts: list[np.ndarray]) -> list[float]:
    """The chi^2 one Gauss-Newton step from each of ``starts`` predicts (see promised_chi2)."""
    data = Data(campaign, model.length)
    return _promises(*_residual_function(model, data, None), data.n_rows, starts)


def frequency_fit(campaign: Campaign, model: CandidateModel) -> np.ndarray:
    """The flat vector fitted to the measured frequencies alone, from the model's first default start: for an
    effect without parameters that leaves the frequencies exactly unchanged (a reversed channel), the unknowns the
    frequencies identify, near the truth's, where the fit to every measurement may stop in a basin the distorted
    shapes lead it to (genset8, blind seed 1014: the nominal fit 20 % off in c_v1)."""
    data = Data(campaign, model.length)
    return _least_squares(model, data, [model.start()[0]], rows=np.arange(len(data.omega))).x


def short_fit(
    campaign: Campaign, model: CandidateModel, start: np.ndarray, evaluations: int
) -> tuple[float, np.ndarray]:
    """The chi^2 (without the prior rows) a fit from ``start`` reaches within ``evaluations`` evaluations of the
    residuals, and where: a surer screen than one Gauss-Newton step where the starts lie far from the minimum
    (a pair whose members' single fits each absorbed part of the other's effect)."""
    data = Data(campaign, model.length)
    fun, jac = _residual_function(model, data, None)
    lo, hi = model.bounds()
    res = _solve(fun, jac, _inside(start, lo, hi), lo, hi, False, evaluations)
    return float(np.sum(res.fun[: data.n_rows] ** 2)), res.x


def _promises(fun: VectorFunction, jac: VectorFunction, n_rows: int, starts: list[np.ndarray]) -> list[float]:
    out = []
    for x in starts:
        r, j = fun(x), jac(x)
        step = np.linalg.lstsq(j, -r, rcond=None)[0]
        out.append(float(np.sum((r + j @ step)[:n_rows] ** 2)))
    return out


SPLIT_STEP = 1e-6
"""Relative forward-difference step for a parameter that splits exactly equal twins (fitting's Jacobian). At
scipy's sqrt(eps) the twins part by about 1e-10, LAPACK resolves their eigenvectors to eps over that, and the
damping ratios of the parted pair moved by rounding at 1e-4 of the derivative, differently under OpenBLAS's
SkylakeX and Haswell kernels, and with them where an attached mass's fit from the machine's axis went (chi^2 472
against 6.2, kid300 blind seed 1040 with damping ratios); at 1e-6 the kernels agree to 1e-9. The frequencies
are not differentiable there (they part as |step|): the step gives the one-sided slope whatever its size."""


def forward_differences(
    fun: VectorFunction,
    theta: np.ndarray,
    upper: np.ndarray,
    columns: np.ndarray | None = None,
    relative_step: float = 0.0,
) -> np.ndarray:
    """d fun / d theta by forward differences with scipy's 2-point step (sqrt(eps) max(1, |theta|), or
    ``relative_step`` max(1, |theta|) where given), stepping backwards where the forward step would pass the
    ``upper`` bounds (only the ``columns`` given, the others nan)."""
    f0 = fun(theta)
    out = np.full((len(f0), len(theta)), np.nan)
    for i, x in enumerate(theta):
        if columns is not None and i not in columns:
            continue
        h = (relative_step or math.sqrt(np.finfo(float).eps)) * max(1.0, abs(x))
        if x + h > upper[i]:
            h = -h
        step = theta.copy()
        step[i] = x + h
        out[:, i] = (fun(step) - f0) / (step[i] - x)
    return out


RANGE_TOLERANCE = 0.1
"""A fitted effect parameter is outside its plausible range (CandidateFit.outside_range) when it lies beyond
it by more than its standard deviation or this share of the range's width, whichever is smaller: a truth
at the edge of a range (a support right under the feet) stays inside, a support of a few kg under an
800 kg machine does not."""

PLAUSIBLE_MARGIN = 0.05
"""A fitted effect parameter makes its candidate implausible (probability 0) when it lies outside its plausible
range by more than its standard deviation or this share of the range's width (in the fit's own units: log for
positive ranges), whichever is larger. A truth at the edge of a range, fitted a little beyond it by a model
that only approximates its geometry, keeps its probability: a slab under the feet whose inertia differs from
the catalogue support's fits 8 cm above them at 8 standard deviations. A confident verdict allows less
(RANGE_TOLERANCE: the smaller of the two)."""

POLISH = 10.0
"""A fit whose best start ran out of evaluations is carried on when its chi^2 is within POLISH times the
noise level (noise_level: mean plus three standard deviations of chi^2 at its degrees of freedom)."""

SPREAD_PROMISE = 0.5
"""A fit whose starts all stopped above noise level goes on from the most promising of the spread starts
(CandidateModel.spread) when one Gauss-Newton step from there promises less than this share of its chi^2."""

LEAVE_ONE_OUT_STEPS = 12
"""Evaluations allowed to a leave-one-mode-out refit: it starts at the full fit, a few Gauss-Newton steps
away from its own minimum (its tolerance is looser than a fit's: a held-out error is judged in sigma)."""


HELD_WIDTH = 1e-9
"""Half-width of the search box around its start of a parameter held in a first fit (EffectParameter.refines)."""

NUDGE = 0.02
"""A refinement that a released fit (within POLISH times noise level) left at its start (within a tenth of this
share of its search range) is released again from this share off the start, on a side whose residuals there are
smaller (_least_squares)."""


def noise_level(n_data: int, n_parameters: int) -> float:
    """chi^2 at noise level for a fit of ``n_parameters`` to ``n_data`` data: the mean plus three standard
    deviations of chi^2 with their difference as degrees of freedom (one at least). Counting every residual
    row instead let a pair of seven parameters stop at chi^2 26 on five degrees of freedom (p = 1e-4) without
    trying its other starts, one of which reached the truth at chi^2 3 (kid300 seed 76 with damping ratios)."""
    dof = max(n_data - n_parameters, 1)
    return dof + 3 * math.sqrt(2 * dof)


def _least_squares(
    model: CandidateModel,
    data: Data,
    starts: list[np.ndarray],
    rows: np.ndarray | None = None,
    mandatory: int = 1,
    refit: bool = False,
    hold: bool = False,
) -> scipy.optimize.OptimizeResult:
    """The best fit from ``starts`` (the first ``mandatory`` always run, the others while the fit stays above
    noise level), on from a spread start where all stop above it. ``hold``: the refining parameters
    (CandidateModel.held_first) held at their start values until then, and released from the best fit."""
    full_lo, full_hi = lo, hi = model.bounds()
    fun, jac = _residual_function(model, data, rows)
    held = model.held_first() if hold else np.array([], dtype=int)
    if len(held):
        at = model.start()[0][held]
        lo, hi = lo.copy(), hi.copy()
        lo[held], hi[held] = at - HELD_WIDTH, at + HELD_WIDTH
    best = None
    noise = noise_level(data.n, len(starts[0]))
    for i, x0 in enumerate(starts):
        if i >= mandatory and 2 * best.cost <= noise:
            break  # fits to noise level: the remaining starts are not needed
        res = _solve(fun, jac, _inside(x0, lo, hi), lo, hi, refit, 100 if len(starts) == 1 else 15)
        if best is None or res.cost < best.cost:
            best = res
    if not refit and rows is None and model.strategy.spread_starts and 2 * best.cost > noise:
        # every start stopped above noise level: on from the spread start that promises most (CandidateModel.spread)
        # where it promises a fraction of the chi^2 reached (another basin, not the same one seen from elsewhere)
        spread = [_inside(x, lo, hi) for x in model.spread()]
        promised = _promises(fun, jac, data.n_rows, spread) if spread else [math.inf]
        if min(promised) < SPREAD_PROMISE * 2 * best.cost:
            x0 = spread[int(np.argmin(promised))]
            res = _solve(fun, jac, _inside(x0, lo, hi), lo, hi, refit, 15)
            if res.cost < best.cost:
                best = res
    if len(held):
        # released from the best held fit: the refinement can only lower its chi^2
        released = _solve(fun, jac, _inside(best.x, full_lo, full_hi), full_lo, full_hi, refit, 100)
        if released.cost <= best.cost:
            best = released
        lo, hi = full_lo, full_hi
        width = full_hi[held] - full_lo[held]
        stuck = np.all(np.abs(best.x[held] - at) < NUDGE * width / 10)
        if stuck and not refit and 2 * best.cost <= POLISH * noise:
            # at its start a refinement may sit on a kink: twins that the symmetric model leaves equal split by
            # |a| (an attached body alike about x and y on the KID-300's axis), and the gradient there points
            # back to the start from either side; released again from just off it on a side that fits better
            for sign in (-1.0, 1.0):
                x0 = best.x.copy()
                x0[held] = at + sign * NUDGE * width
                x0 = _inside(x0, lo, hi)
                if 0.5 * float(np.sum(fun(x0) ** 2)) < best.cost:
                    nudged = _solve(fun, jac, x0, lo, hi, refit, 100)
                    if nudged.cost < best.cost:
                        best = nudged
    if best.status == 0 and not refit and 2 * best.cost <= POLISH * noise:
        # the best start ran out of evaluations near noise level: carry it on (a candidate far from the data
        # keeps its rough minimum, its probability is nil either way)
        polished = _solve(fun, jac, best.x, lo, hi, refit, 100)
        if polished.cost <= best.cost:
            best = polished
    return best


def _inside(x: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """``x`` clipped to just inside the bounds (least squares starts strictly inside them)."""
    finite_lo, finite_hi = np.isfinite(lo), np.isfinite(hi)
    inner_lo = np.where(finite_lo, lo + 1e-9 * (1 + np.abs(np.where(finite_lo, lo, 0))), lo)
    inner_hi = np.where(finite_hi, hi - 1e-9 * (1 + np.abs(np.where(finite_hi, hi, 0))), hi)
    return np.clip(x, inner_lo, inner_hi)


CONVERGED_CHI2 = 1e-3
"""A fit has converged when its objective (chi^2 with the prior rows) fell by less than this over its last
CONVERGED_ITERATIONS iterations: what is left of the way to the minimum is worth hundredths of one unit of
chi^2 at most, while scipy's relative tolerances (1e-7 of chi^2) keep a fit creeping along a shallow valley
for tens of evaluations (a quarter of every fit's evaluations in the blind cases were made within 0.01 of
the fit's final chi^2)."""

CONVERGED_ITERATIONS = 3
"""The iterations (accepted steps) over which CONVERGED_CHI2 is judged."""


class _Converged:
    """least_squares callback that stops the fit (status -2) once it has converged (CONVERGED_CHI2)."""

    def __init__(self) -> None:
        self.costs: list[float] = []

    def __call__(self, intermediate_result: scipy.optimize.OptimizeResult) -> None:
        self.costs.append(2 * float(intermediate_result.cost))
        if len(self.costs) > CONVERGED_ITERATIONS and (
            self.costs[-1 - CONVERGED_ITERATIONS] - self.costs[-1] < CONVERGED_CHI2
        ):
            raise StopIteration


def _solve(
    fun: VectorFunction,
    jac: VectorFunction,
    x0: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
    refit: bool,
    max_nfev: int,
) -> scipy.optimize.OptimizeResult:
    """scipy.optimize.least_squares from ``x0`` within (``lo``, ``hi``): the trust-region reflective method with
    the Jacobian's column norms as scales, ``max_nfev`` evaluations (a refit: LEAVE_ONE_OUT_STEPS at looser
    tolerances), stopped once converged (_Converged); through identification.least_squares.trust_region, the
    same numbers with fewer calls."""
    tol = 1e-5 if refit else 1e-7
    evaluations = LEAVE_ONE_OUT_STEPS if refit else max_nfev
    callback = None if refit else _Converged()
    return trust_region(
        fun, jac, x0, lo, hi, ftol=tol, xtol=tol, max_nfev=evaluations, x_scale="jac", callback=callback
    )


def fit_candidate(
    campaign: Campaign,
    effect: Effect | Pair | None,
    variant: int | None = None,
    start: np.ndarray | None = None,
    starts: list[np.ndarray] | None = None,
    pick: bool = False,
    within_plausible: bool = False,
) -> CandidateFit:
    """Fit one candidate (None: the nominal model; a Pair: two effects at once) with the unknowns to every
    measured mode (``start``: a single starting vector, e.g. the fit of the same candidate to nearby data;
    ``starts``: several, the first always run, or with ``pick`` only the one whose Gauss-Newton step promises
    the smallest chi^2 (promised_chi2); instead of the default ones). ``within_plausible``: the effect
    parameters bounded by their plausible ranges (CandidateModel.within_plausible)."""
    model = CandidateModel(campaign, effect, variant, within_plausible)
    data = Data(campaign, model.length)
    name = effect.name if effect else "none"
    where = model.strategy.variants(campaign)[variant] if variant is not None else ""
    why = model.strategy.inapplicable(model, bool(data.shape_labels))
    k = len(model.start()[0])
    if why:
        return CandidateFit(
            name, where, {}, {}, math.nan, data.n, k, math.inf, False, "", {}, applicable=False, note=why
        )
    if starts is not None:
        if pick and len(starts) > 1:
            starts = [starts[int(np.argmin(promises(campaign, model, starts)))]]
        res = _least_squares(model, data, starts)
    elif start is None:
        res = _least_squares(model, data, model.start(), mandatory=model.mandatory_starts, hold=True)
    else:
        res = _least_squares(model, data, [start])
    theta = res.x
    n_rows = data.n_rows
    chi2 = float(np.sum(res.fun[:n_rows] ** 2))  # without the prior rows
    jac = res.jac
    dof = data.n - k
    spread = standard_deviations(covariance(jac, chi2, dof))
    d = model.jacobian_to_physical(theta)
    phys = model.physical(theta)
    std = {n: float(abs(d[i]) * spread[i]) for i, n in enumerate(phys)}
    reasons, outside, placed = [], [], []
    box = zip(*model.plausible_box(), strict=True)
    for j, (p, (a, b)) in enumerate(zip(model.effect_parameters, box, strict=True), len(model.unknown)):
        lo, hi = (v * model.scales[p.scale] for v in p.plausible)
        v = phys[p.name]
        # outside by more than its standard deviation or RANGE_TOLERANCE of the range (in the fit's own
        # units: log for positive ranges), whichever is smaller
        slack = min(spread[j], RANGE_TOLERANCE * (b - a))
        if not a - slack <= theta[j] <= b + slack:
            outside.append(p.name)
        if not a - spread[j] <= theta[j] <= b + spread[j]:
            placed.append(p.name)
        margin = max(spread[j], PLAUSIBLE_MARGIN * (b - a))
        if not a - margin <= theta[j] <= b + margin:
            reasons.append(f"{p.name} = {v:.3g}{p.unit_suffix} outside the plausible range [{lo:.3g}, {hi:.3g}]")
    aicc = chi2 + 2 * k + 2 * k * (k + 1) / (data.n - k - 1) if data.n - k - 1 > 0 else math.inf
    held = model.held_first()
    offsets = theta[held] - model.start()[0][held]
    evidence = log_evidence(jac[:n_rows], chi2, prior_widths(model), held, offsets)
    pred = model.predict(theta)
    gap = {lab: float(w - p) for lab, w, p in zip(data.labels, data.omega, pred.frequencies, strict=True)}
    damping_gap = {}
    if data.damping_labels:
        zeta = pred.damping[data.damping_index]
        damping_gap = {lab: float(z - m) for lab, z, m in zip(data.damping_labels, data.zeta, zeta, strict=True)}
    held_out, variance = _linear_leave_one_out(data, res.fun, jac)
    model.forget()
    return CandidateFit(
        name,
        where,
        phys,
        std,
        chi2,
        data.n,
        k,
        aicc,
        not reasons,
        "; ".join(reasons),
        gap,
        held_out_gap=held_out,
        damping_gap=damping_gap,
        held_out_variance=variance,
        log_evidence=evidence,
        outside_range=tuple(outside),
        placed_outside=tuple(placed),
        state=FitState(model, theta, ((jac[:n_rows], chi2, offsets),)),
    )


OTHER_SOLUTION_FITS = 3
"""Fits other_solutions runs: from the most promising of the spread starts and the fit's mirror image."""

OTHER_SOLUTION_SIGMA = 3.0
"""A solution is another one when an effect parameter differs from the fit's (and from every other solution's) by
more than this many of its standard deviations."""


def other_solutions(fit: CandidateFit, within: float) -> tuple[dict[str, float], ...]:
    """Other minima at which the candidate fits the data as well (chi^2 within ``within`` of the fit's) at plausible
    values (within PLAUSIBLE_MARGIN of each range) with an effect parameter OTHER_SOLUTION_SIGMA standard
    deviations or more away: fits from the OTHER_SOLUTION_FITS most promising (one Gauss-Newton step,
    fitting.promises) of the spread starts (CandidateModel.spread) and the fit's signed parameters through zero
    (CandidateModel.mirrored). Frequencies alone leave such roots: one kid300 isolator 39 % softer fits as well
    47 % stiffer in shear with a softer c_xy; a centre of mass off to one side as well off to the other. Physical
    values, unknowns included."""
    if fit.state is None or not fit.state.model.effect_parameters:
        return ()
    model, theta = fit.state.model, fit.state.theta
    data = Data(model.campaign, model.length)
    fun, jac = _residual_function(model, data, None)
    lo, hi = model.bounds()
    n = len(model.unknown)
    scale = model.jacobian_to_physical(theta)[n:]
    names = model.parameter_names[n:]
    sigma = np.array([fit.std.get(q, math.inf) / abs(d) if d else math.inf for q, d in zip(names, scale, strict=True)])
    sigma = np.maximum(sigma, 1e-12)  # in the flat vector's units
    starts = [*model.spread(), model.mirrored(theta)]
    promised = _promises(fun, jac, data.n_rows, starts)
    found = [theta]
    for i in np.argsort(promised)[:OTHER_SOLUTION_FITS]:
        res = _solve(fun, jac, _inside(starts[i], lo, hi), lo, hi, False, 30)
        if np.sum(res.fun[: data.n_rows] ** 2) > fit.chi2 + within or not _plausible(model, res.x):
            continue
        if all(np.any(np.abs(res.x[n:] - y[n:]) > OTHER_SOLUTION_SIGMA * sigma) for y in found):
            found.append(res.x)
    return tuple(model.physical(x) for x in found[1:])


def _plausible(model: CandidateModel, theta: np.ndarray) -> bool:
    """Whether every effect parameter of ``theta`` lies inside its plausible range widened by PLAUSIBLE_MARGIN of
    its width (in the fit's own units: log for positive ranges)."""
    a, b = model.plausible_box()
    margin = PLAUSIBLE_MARGIN * (b - a)
    values = theta[len(model.unknown) :]
    return bool(np.all((a - margin <= values) & (values <= b + margin)))


HELD_OUT_LEVERAGE = 1e-10
"""A mode is held out only where the smallest eigenvalue of I - H_gg (its rows' share of the fit left to the
others, in [0, 1]) exceeds this: below it the mode alone determines a parameter (a single frequency row with
leverage 1 - 1e-10 would be predicted within 1e5 of its own standard deviations)."""

HAT_RANK = 10**-7.5
"""Singular values of the weighted Jacobian below this fraction of the largest span no direction of the hat
matrix (pinv's cut of 1e-15 on J^T J, taken on J)."""


def _linear_leave_one_out(data: Data, r: np.ndarray, jac: np.ndarray) -> tuple[dict[str, float], dict[str, float]]:
    """measured - prediction without the mode [rad/s], to first order: (I - H_gg)^-1 r_g for the mode's rows g
    of the weighted hat matrix H = J (J^T J)^-1 J^T = U U^T (U: J's left singular vectors); and its variance in
    units of the frequency's, [(I - H_gg)^-1]_00 (r_g has covariance I - H_gg). Both nan where the mode alone
    determines a parameter (HELD_OUT_LEVERAGE). H is built from the SVD of J, not from J^T J: the normal matrix
    squares J's condition, and with as many parameters as rows (prior rows included) the leverages of 1 came out
    as 1 +- 1e-8, a negative variance or one of 1e9."""
    u, s, _ = np.linalg.svd(jac, full_matrices=False)
    u = u[:, s > HAT_RANK * s[0]] if s.size and s[0] > 0 else u[:, :0]
    out, variance = {}, {}
    for i, lab in enumerate(data.labels):
        g = data.rows_of(lab)
        a = np.eye(len(g)) - u[g] @ u[g].T
        if np.linalg.eigvalsh(a)[0] < HELD_OUT_LEVERAGE:
            out[lab] = variance[lab] = math.nan
            continue
        inverse = np.linalg.inv(a)
        out[lab] = float((inverse[0] @ r[g]) * data.sigma[i])
        variance[lab] = float(inverse[0, 0])
    return out, variance


def exact_leave_one_out(fit: CandidateFit) -> CandidateFit:
    """The fit with its held-out errors [rad/s] refitted without each mode in turn (frequency and shape); nan where
    the mode alone determines a parameter (its linearised held-out error is nan: the others leave a direction of
    the parameters flat, and a refit would return a prediction from wherever it stopped along it)."""
    model, theta = fit.state.model, fit.state.theta
    data = Data(model.campaign, model.length)
    out = {}
    for i, lab in enumerate(data.labels):
        keep = np.setdiff1d(np.arange(data.n_rows), data.rows_of(lab))
        few = len(keep) - 5 * len(data.shape_labels) + (5 if lab in data.shape_labels else 0) <= len(theta) - 1
        if few or not math.isfinite(fit.held_out_gap.get(lab, math.nan)):
            out[lab] = math.nan
            continue
        res = _least_squares(model, data, [theta], rows=keep, refit=True)
        out[lab] = float(data.omega[i] - model.predict(res.x).frequencies[i])
    return replace(fit, held_out_gap=out, held_out_exact=True)


def held_out_z(fit: CandidateFit, campaign: Campaign, predictive: bool = False) -> np.ndarray:
    """Held-out errors in units of each frequency's standard deviation, or with ``predictive`` of their own
    predictive standard deviation (fit.held_out_variance; modes without one skipped)."""
    z = []
    for lab, e in fit.held_out_gap.items():
        m = campaign.modes[lab]
        v = fit.held_out_variance.get(lab, 1.0) if predictive else 1.0
        if math.isfinite(e) and math.isfinite(v):
            z.append(e / (m.frequency_std * math.sqrt(max(v, 1.0))))
    return np.array(z)
