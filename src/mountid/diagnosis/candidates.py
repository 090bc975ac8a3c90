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
effect rank after every plausible candidate. Candidates within ``TIE`` of the best AICc are a tie. The
held-out error of each candidate is its leave-one-mode-out prediction error (linearised for all
candidates; refitted for the nominal model and, when there is a gap to explain, the first three of the tie).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg
import scipy.optimize
import scipy.stats

from mountid.diagnosis.campaign import DEFAULT_FREQUENCY_STD, Campaign
from mountid.effects import CATALOGUE, Effect
from mountid.machine import call, damped_poles

GAP_P_VALUE = 1e-3
"""The nominal model has a significant gap when its chi^2 exceeds the 1 - GAP_P_VALUE quantile."""
TIE = 7.0
"""Candidates within this AICc of the best cannot be told apart by the data (Burnham and Anderson's rule
of thumb: up to 7 above the best a model keeps some support)."""
_DEGENERATE = 1e-6
"""Model modes closer than this in relative frequency are equal (twins): their combination is free. Modes
the measurement barely separates (a few standard deviations of the measured frequency) are compared with
the measured shape through their common span, blended smoothly into the single mode as they move apart."""


@dataclass(frozen=True)
class Prediction:
    """Frequencies [rad/s], scaled unit shapes (6,) per mode label, and for each label an orthonormal basis
    (6, c) of the modes the measurement cannot separate from it with the weight of that basis (see
    :meth:`Data.residuals`)."""

    frequencies: np.ndarray
    shapes: list[np.ndarray]
    clusters: list[tuple[np.ndarray, float] | None]


@dataclass
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
    held_out_exact: bool = False
    applicable: bool = True
    note: str = ""
    held_out_rms: float = math.nan
    """RMS of the held-out frequency errors in units of their standard deviation (set by the ranking)."""
    held_out_median: float = math.nan
    """Median of |held-out frequency error| / standard deviation over the modes: robust to the one mode
    whose omission leaves a parameter poorly determined (set by the ranking)."""
    model: CandidateModel | None = field(default=None, repr=False, compare=False)
    theta: np.ndarray | None = field(default=None, repr=False, compare=False)
    """The fitted model and its flat parameter vector (for leave-one-out refits and separation)."""

    def to_json(self) -> dict:
        return {
            "effect": self.effect,
            "variant": self.variant,
            "parameters": self.parameters,
            "parameter_std": self.std,
            "chi2": self.chi2,
            "n_data": self.n_data,
            "n_parameters": self.n_parameters,
            "aicc": self.aicc if math.isfinite(self.aicc) else None,
            "plausible": self.plausible,
            "implausible_reason": self.implausible_reason,
            "gap_after": self.frequency_gap,
            "held_out_gap": self.held_out_gap,
            "held_out_exact": self.held_out_exact,
            "applicable": self.applicable,
            "note": self.note,
            "held_out_rms_sigma": self.held_out_rms if math.isfinite(self.held_out_rms) else None,
            "held_out_median_sigma": self.held_out_median if math.isfinite(self.held_out_median) else None,
        }


class CandidateModel:
    """The campaign's machine, optionally with one candidate effect, as a function of a flat parameter
    vector: log of each unknown, then each effect parameter (log for strictly positive ranges, else in
    units of its scale)."""

    def __init__(self, campaign: Campaign, effect: Effect | None, isolator: int | None = None) -> None:
        self.campaign = campaign
        self.effect = effect
        self.isolator = isolator
        machine = campaign.machine
        self.mod = mod = machine.module
        self.labels = tuple(campaign.modes)
        self.unknown = machine.unknown
        everything = machine.values(campaign.known, tuple(n for n in mod.PARAMETERS if n not in machine.unknown))
        self.known = everything
        start = machine.values({}, machine.unknown)
        self.start_unknowns = start
        nominal = {**everything, **start}
        self.scales = {k: float(v) for k, v in call(mod, "effect_scales", nominal).items()}
        self.length = self.scales["length"]
        self.effect_parameters = effect.parameters if effect else ()
        self.log_scaled = tuple(p.plausible[0] > 0 for p in self.effect_parameters)
        measured = [campaign.modes[lab].frequency for lab in self.labels]
        self.omega_ref = float(np.exp(np.mean(np.log(measured))))
        # modes are paired with labels by shape and frequency: the measured ones where measured, else the
        # generated (block-pure) modal matrix and frequencies at the nominal values
        fwd = _pick(nominal, mod.FORWARD_ARGUMENTS)
        self.reference = scaled_unit(np.asarray(mod.modal_matrix(**fwd)), self.length)
        self.reference_lambda = np.asarray(mod.squared_frequencies(**fwd), dtype=float).copy()
        self._rows = [mod.MODES.index(label) for label in self.labels]
        self.resolution = np.full(len(mod.MODES), DEFAULT_FREQUENCY_STD)
        for i, label in enumerate(mod.MODES):
            m = campaign.modes.get(label)
            if m is not None:
                self.resolution[i] = m.frequency_std / m.frequency
                self.reference_lambda[i] = m.frequency**2
                if m.shape is not None:
                    self.reference[:, i] = scaled_unit(np.array(m.shape, dtype=float)[:, None], self.length)[:, 0]

    # -- parameter vector ---------------------------------------------------------------------------
    def start(self) -> list[np.ndarray]:
        """Starting vectors: the effect's start values; for wide positive ranges (the foundation) a 2 x 2
        grid over their decades; for a two-parameter effect with a signed parameter (a height, an offset)
        that parameter at half its plausible bound on either side (the fit has a local minimum on the wrong
        side); last the middle of the plausible range. Sets ``mandatory_starts``: the first starts, which
        always run (the others run only while the fit stays above noise level)."""
        base = [math.log(self.start_unknowns[u]) for u in self.unknown]
        params = self.effect_parameters

        def vector(values) -> np.ndarray:
            out = list(base)
            for v, log in zip(values, self.log_scaled, strict=True):
                out.append(math.log(v) if log else v)
            return np.array(out)

        first = [p.start for p in params]
        starts = [vector(first)]
        self.mandatory_starts = 1
        if params and all(self.log_scaled):  # wide positive ranges (foundation): a grid over the decades
            grid = [[p.plausible[0] * (p.plausible[1] / p.plausible[0]) ** f for f in (0.3, 0.7)] for p in params]
            starts += [vector(point) for point in itertools.product(*grid)]
        elif len(params) == 2:
            # the other parameter at the middle of its range: at its start (often 0, no effect) the signed
            # one has no gradient and slides to whichever side the unknowns prefer
            middle = [0.5 * (p.plausible[0] + p.plausible[1]) for p in params]
            for i, p in enumerate(params):
                if p.plausible[0] < 0 < p.plausible[1]:
                    for bound in p.plausible:
                        starts.append(vector([bound / 2 if j == i else v for j, v in enumerate(middle)]))
            self.mandatory_starts = len(starts)
        if params:
            starts.append(vector([0.5 * (p.plausible[0] + p.plausible[1]) for p in params]))
        return starts

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Search box: unknowns free (log), effect parameters within their plausible range widened by its
        width on each side (log ranges by a factor 10)."""
        lo = [-np.inf] * len(self.unknown)
        hi = [np.inf] * len(self.unknown)
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

    def vector(self, physical: dict[str, float]) -> np.ndarray:
        """The flat vector of physical values (inverse of :meth:`physical`)."""
        out = [math.log(physical[u]) for u in self.unknown]
        for p, log in zip(self.effect_parameters, self.log_scaled, strict=True):
            v = physical[p.name] / self.scales[p.scale]
            out.append(math.log(v) if log else v)
        return np.array(out)

    def jacobian_to_physical(self, theta: np.ndarray) -> np.ndarray:
        """d(physical)/d(theta), diagonal."""
        phys = self.physical(theta)
        d = [phys[u] for u in self.unknown]
        for p, log in zip(self.effect_parameters, self.log_scaled, strict=True):
            d.append(phys[p.name] if log else self.scales[p.scale])
        return np.array(d)

    # -- the model -------------------------------------------------------------------------------------
    def _matrices(self, values: dict[str, float]) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        mod = self.mod
        e = self.effect
        if e is not None and e.how == "generated":
            m, c, b = call(mod, f"effect_{e.name}", values)
            return m, c, b
        m = call(mod, "mass_matrix", values)
        c = call(mod, "stiffness_matrix", values)
        if e is not None and e.how == "isolator":
            per = call(mod, "isolator_stiffness", values)
            c = c + values["scatter"] * per[self.isolator]
        b = call(mod, "damping_matrix", values) if e and e.how == "damping" else None
        return m, c, b

    def predict(self, theta: np.ndarray, labels: tuple[str, ...] | None = None) -> Prediction:
        """Frequencies and scaled shapes of the modes ``labels`` (default: the measured ones)."""
        values = {**self.known, **self.physical(theta)}
        m, c, b = self._matrices(values)
        lam, vec = scipy.linalg.eigh(c, m)
        body = scaled_unit(vec[:6, :], self.length)
        share = np.einsum("ij,ik,kj->j", vec[:6], m[:6, :6], vec[:6]) if len(m) > 6 else None
        order = label_modes(lam, body, self.reference_lambda, self.reference, share)
        omega = np.sqrt(np.abs(lam))
        e = self.effect
        if e is not None and e.how == "frequency":
            omega = _stiffening(np.abs(lam), values["rubber_strength"], values["rubber_corner"] * self.omega_ref)
        elif e is not None and e.how == "damping":
            omega = damped_poles(m, c, values["damping_scale"] * b, lam).imag
        elif e is not None and e.how == "sensor":
            body = scaled_unit(
                sensor_transform(self.mod, values["sensor_yaw"], values["sensor_dz"]) @ vec[:6, :], self.length
            )
        rows = self._rows if labels is None else [self.mod.MODES.index(label) for label in labels]
        index = order[rows]
        # closeness of every model mode to each labelled one, in units of the measurement's resolution of
        # that frequency (relative); within a few units the measured shape may be any mix of them
        gap = np.abs(lam[index, None] - lam[None, :]) / (2 * np.abs(lam[index, None]) * self.resolution[rows, None])
        weight = np.exp(-(gap**2))
        partners = weight > 1e-3
        shapes = list(body[:, index].T)
        clusters: list[tuple[np.ndarray, float] | None] = [None] * len(index)
        spans: dict[bytes, np.ndarray] = {}
        for k in np.flatnonzero(partners.sum(axis=1) > 1):
            j = index[k]
            key = partners[k].tobytes()
            if key not in spans:
                spans[key] = _orthonormal(body[:, partners[k]])
            near = np.flatnonzero(partners[k])
            exact = np.all(np.abs(lam[near] - lam[j]) <= _DEGENERATE * abs(lam[j]))
            # the weakest partner sets how far the mix is allowed
            clusters[k] = (spans[key], 1.0 if exact else float(np.min(weight[k, near])))
        return Prediction(omega[index], shapes, clusters)


def _pick(values: dict[str, float], names: tuple[str, ...]) -> dict[str, float]:
    return {n: values[n] for n in names}


def scaled_unit(shapes: np.ndarray, length: float) -> np.ndarray:
    """Rotations times the length scale, each column normalised to unit length."""
    out = np.array(shapes, dtype=float)
    out[3:6] *= length
    norm = np.linalg.norm(out, axis=0)
    return out / np.where(norm > 0, norm, 1.0)  # a foundation mode may leave the body at rest


def label_modes(
    lam: np.ndarray,
    body: np.ndarray,
    reference_lambda: np.ndarray,
    reference: np.ndarray,
    participation: np.ndarray | None = None,
) -> np.ndarray:
    """Index of the model mode for each reference mode: one-to-one, by MAC with the reference shapes
    (scaled unit columns) times the share of the mode's kinetic energy in the body (``participation``, for
    models with more coordinates than the body's: a foundation mode is not a machine mode however its small
    body motion looks) and, to break ties between modes of equal shape, closeness in frequency."""
    mac = (reference.T @ body) ** 2
    # modes of equal frequency (twins) may come in any combination: each is matched by the reference's
    # projection on their common span
    near = np.abs(lam[:, None] - lam[None, :]) <= _DEGENERATE * np.abs(lam[None, :])
    done: dict[bytes, np.ndarray] = {}
    for j in np.flatnonzero(near.sum(axis=0) > 1):
        key = near[:, j].tobytes()
        if key not in done:
            q = _orthonormal(body[:, near[:, j]])
            done[key] = np.sum((reference.T @ q) ** 2, axis=1)
        mac[:, j] = done[key]
    if participation is not None:
        mac = mac * participation[None, :]
    distance = np.abs(np.log(np.abs(lam)[None, :] / reference_lambda[:, None]))
    rows, cols = scipy.optimize.linear_sum_assignment(-mac + 0.05 * distance)
    out = np.empty(len(reference_lambda), dtype=int)
    out[rows] = cols
    return out


def _stiffening(lam: np.ndarray, beta: float, corner: float) -> np.ndarray:
    """omega solving omega^2 = g(omega) lam, g = 1 + beta y / (y + c), y = omega^2, c = corner^2, for each
    eigenvalue lam of the static stiffness. Multiplied out, y^2 + b y - lam c = 0 with b = c - lam (1 + beta):
    one positive root (the product of the roots is -lam c), taken in the form without cancellation."""
    c = corner**2
    b = c - lam * (1 + beta)
    root = np.sqrt(b * b + 4 * lam * c)
    y = np.where(b > 0, 2 * lam * c / (b + root), (root - b) / 2)
    return np.sqrt(y)


def sensor_transform(mod, yaw: float, dz: float) -> np.ndarray:
    """Shapes as read by a sensor frame turned by ``yaw`` [rad] about z whose reference point is ``dz`` [m]
    above the origin: translations of that point (the generated point_jacobian) and rotations, both in the
    turned frame (6 x 6)."""
    jac = np.asarray(mod.point_jacobian(0.0, 0.0, dz))
    cz, sz = math.cos(yaw), math.sin(yaw)
    rot = np.array([[cz, sz, 0.0], [-sz, cz, 0.0], [0.0, 0.0, 1.0]])  # global -> turned frame
    out = np.zeros((6, 6))
    out[:3] = rot @ jac
    out[3:, 3:] = rot
    return out


def _orthonormal(basis: np.ndarray) -> np.ndarray:
    """Orthonormal columns spanning the (unit) columns of ``basis``: Gram-Schmidt for the common pair of
    twins, QR otherwise."""
    if basis.shape[1] == 2:
        a, b = basis[:, 0], basis[:, 1]
        b = b - a * (a @ b)
        norm = np.linalg.norm(b)
        return np.column_stack([a, b / norm]) if norm > 1e-12 else a[:, None]  # parallel: one direction
    q, r = np.linalg.qr(basis)
    return q[:, np.abs(np.diag(r)) > 1e-12]


def _off_span(s: np.ndarray, basis: np.ndarray) -> np.ndarray:
    """The part of s outside the span of a unit vector (or of orthonormal columns)."""
    if basis.ndim == 1:
        return s - basis * (basis @ s)
    return s - basis @ (basis.T @ s)


class Data:
    """The campaign's measurements as weighted data rows (see the module docstring)."""

    def __init__(self, campaign: Campaign, length: float) -> None:
        self.labels = tuple(campaign.modes)
        modes = [campaign.modes[lab] for lab in self.labels]
        self.omega = np.array([m.frequency for m in modes])
        self.sigma = np.array([m.frequency_std for m in modes])
        self.shape_labels = tuple(lab for lab, m in zip(self.labels, modes, strict=True) if m.shape is not None)
        self.shapes = [
            scaled_unit(np.array(campaign.modes[lab].shape, dtype=float)[:, None], length)[:, 0]
            for lab in self.shape_labels
        ]
        self.shape_sigma = [campaign.modes[lab].shape_std for lab in self.shape_labels]
        self.n = len(self.labels) + 5 * len(self.shape_labels)
        """Data count: one per frequency, five per shape (six components less the free scale)."""

    def residuals(self, pred: Prediction) -> np.ndarray:
        rows = [(self.omega - pred.frequencies) / self.sigma]
        for lab, s, sig in zip(self.shape_labels, self.shapes, self.shape_sigma, strict=True):
            i = self.labels.index(lab)
            own = _off_span(s, pred.shapes[i])
            cluster = pred.clusters[i]
            if cluster is not None:  # blended, so that the residual is continuous as modes split
                basis, w = cluster
                own = w * _off_span(s, basis) + (1 - w) * own
            rows.append(own / sig)
        return np.concatenate(rows)

    def rows_of(self, label: str) -> np.ndarray:
        """Row indices of one mode's data (its frequency and, if measured, its shape components)."""
        idx = [self.labels.index(label)]
        if label in self.shape_labels:
            k = self.shape_labels.index(label)
            first = len(self.labels) + 6 * k
            idx += list(range(first, first + 6))
        return np.array(idx)


# -- fitting -----------------------------------------------------------------------------------------------
_FAILED = 1e6
"""Residual assigned to every row where the model cannot be evaluated (singular matrices)."""


PRIOR_WEIGHT = 0.1
"""Weight of the weak prior rows PRIOR_WEIGHT (theta - start) / (plausible width) of the effect parameters:
at most 0.01 in chi^2 inside the plausible range, but it holds a parameter the data do not determine (a
sensor yaw on a machine symmetric under rotation by 90 degrees) at its start instead of letting it drift,
and makes its standard deviation large instead of zero."""


def _residual_function(model: CandidateModel, data: Data, rows: np.ndarray | None):
    start = model.start()[0]
    n = len(model.unknown)
    width = np.array(
        [
            math.log(p.plausible[1] / p.plausible[0]) if log else p.plausible[1] - p.plausible[0]
            for p, log in zip(model.effect_parameters, model.log_scaled, strict=True)
        ]
    )

    def fun(theta: np.ndarray) -> np.ndarray:
        try:
            r = data.residuals(model.predict(theta))
        except (np.linalg.LinAlgError, ValueError):
            r = np.full(len(data.labels) + 6 * len(data.shape_labels), _FAILED)
        prior = PRIOR_WEIGHT * (theta[n:] - start[n:]) / width
        return np.concatenate([r if rows is None else r[rows], prior])

    return fun


def _least_squares(
    model: CandidateModel, data: Data, starts: list[np.ndarray], rows: np.ndarray | None = None, mandatory: int = 1
):
    lo, hi = model.bounds()
    fun = _residual_function(model, data, rows)
    best = None
    finite = np.isfinite(lo)
    inner_lo = np.where(finite, lo + 1e-9 * (1 + np.abs(np.where(finite, lo, 0))), lo)
    inner_hi = np.where(np.isfinite(hi), hi - 1e-9 * (1 + np.abs(np.where(np.isfinite(hi), hi, 0))), hi)
    for i, x0 in enumerate(starts):
        n = len(best.fun) if best is not None else 0
        if i >= mandatory and 2 * best.cost <= n + 3 * math.sqrt(2 * n):
            break  # fits to noise level: the remaining starts are not needed
        x0 = np.clip(x0, inner_lo, inner_hi)
        res = scipy.optimize.least_squares(
            fun, x0, bounds=(lo, hi), method="trf", x_scale="jac", ftol=1e-7, xtol=1e-7, max_nfev=100 if i == 0 else 30
        )
        if best is None or res.cost < best.cost:
            best = res
    return best


def _applicable(model: CandidateModel, data: Data) -> str:
    """Why a candidate cannot act on this campaign ('' when it can)."""
    e = model.effect
    if e is None:
        return ""
    if e.how == "sensor" and not data.shape_labels:
        return "no mode shapes measured: a sensor error leaves the frequencies exactly unchanged"
    if e.how == "damping":
        _, _, b = model._matrices({**model.known, **model.physical(model.start()[0]), "damping_scale": 1.0})
        if not np.any(b):
            return "the description has no damping: nothing to scale"
    return ""


def fit_candidate(
    campaign: Campaign, effect: Effect | None, isolator: int | None = None, start: np.ndarray | None = None
) -> CandidateFit:
    """Fit one candidate (None: the nominal model) with the unknowns to every measured mode (``start``: a
    single starting vector, e.g. the fit of the same candidate to nearby data, instead of the default ones)."""
    model = CandidateModel(campaign, effect, isolator)
    data = Data(campaign, model.length)
    name = effect.name if effect else "none"
    variant = campaign.machine.module.ISOLATORS[isolator] if isolator is not None else ""
    why = _applicable(model, data)
    k = len(model.start()[0])
    if why:
        return CandidateFit(
            name, variant, {}, {}, math.nan, data.n, k, math.inf, False, "", {}, applicable=False, note=why
        )
    if start is None:
        res = _least_squares(model, data, model.start(), mandatory=model.mandatory_starts)
    else:
        res = _least_squares(model, data, [start])
    theta = res.x
    n_rows = len(data.labels) + 6 * len(data.shape_labels)
    chi2 = float(np.sum(res.fun[:n_rows] ** 2))  # without the prior rows
    jac = res.jac
    dof = data.n - k
    scale = max(1.0, chi2 / dof) if dof > 0 else 1.0
    cov = np.linalg.pinv(jac.T @ jac) * scale
    d = model.jacobian_to_physical(theta)
    phys = model.physical(theta)
    std = {n: float(abs(d[i]) * math.sqrt(max(cov[i, i], 0.0))) for i, n in enumerate(phys)}
    reasons = []
    for p in model.effect_parameters:
        lo, hi = (v * model.scales[p.scale] for v in p.plausible)
        v, s = phys[p.name], std[p.name]
        if not lo - s <= v <= hi + s:
            reasons.append(f"{p.name} = {v:.3g} {p.unit} outside the plausible range [{lo:.3g}, {hi:.3g}]")
    aicc = chi2 + 2 * k + 2 * k * (k + 1) / (data.n - k - 1) if data.n - k - 1 > 0 else math.inf
    pred = model.predict(theta)
    gap = {lab: float(w - p) for lab, w, p in zip(data.labels, data.omega, pred.frequencies, strict=True)}
    fit = CandidateFit(name, variant, phys, std, chi2, data.n, k, aicc, not reasons, "; ".join(reasons), gap)
    fit.held_out_gap = _linear_leave_one_out(data, res.fun, jac)
    fit.model, fit.theta = model, theta
    return fit


def _linear_leave_one_out(data: Data, r: np.ndarray, jac: np.ndarray) -> dict[str, float]:
    """measured - prediction without the mode [rad/s], to first order: (I - H_gg)^-1 r_g for the mode's rows g
    of the weighted hat matrix H = J (J^T J)^-1 J^T (nan where the mode alone determines a parameter)."""
    inv = np.linalg.pinv(jac.T @ jac)
    out = {}
    for i, lab in enumerate(data.labels):
        g = data.rows_of(lab)
        h = jac[g] @ inv @ jac[g].T
        a = np.eye(len(g)) - h
        if np.linalg.cond(a) > 1e10:
            out[lab] = math.nan
            continue
        out[lab] = float(np.linalg.solve(a, r[g])[0] * data.sigma[i])
    return out


def exact_leave_one_out(fit: CandidateFit) -> None:
    """Refit without each mode in turn (frequency and shape) and store its held-out error [rad/s]."""
    model, theta = fit.model, fit.theta
    data = Data(model.campaign, model.length)
    out = {}
    for i, lab in enumerate(data.labels):
        keep = np.setdiff1d(np.arange(len(data.labels) + 6 * len(data.shape_labels)), data.rows_of(lab))
        if len(keep) - 5 * len(data.shape_labels) + (5 if lab in data.shape_labels else 0) <= len(theta) - 1:
            out[lab] = math.nan
            continue
        res = _least_squares(model, data, [theta], rows=keep)
        out[lab] = float(data.omega[i] - model.predict(res.x).frequencies[i])
    fit.held_out_gap = out
    fit.held_out_exact = True


def held_out_z(fit: CandidateFit, campaign: Campaign) -> np.ndarray:
    """Held-out errors in units of each frequency's standard deviation (modes without one skipped)."""
    z = []
    for lab, e in fit.held_out_gap.items():
        m = campaign.modes[lab]
        if math.isfinite(e):
            z.append(e / m.frequency_std)
    return np.array(z)


@dataclass
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
    campaign: Campaign, effects: tuple[Effect, ...] = CATALOGUE, warm: EffectsReport | None = None
) -> tuple[CandidateFit, list[CandidateFit]]:
    """The nominal fit and the best fit of each candidate effect (isolator_scatter: its best isolator; the
    others within TIE in chi^2 are named in its note, mirror images that frequencies alone cannot tell).
    ``warm``: a report on nearby data whose fits start these (one start each; scatter keeps its isolator)."""
    previous = {f.effect: f for f in (warm.ranked if warm else []) if f.theta is not None}
    nominal = fit_candidate(campaign, None, start=warm.nominal.theta if warm else None)
    fits = []
    for effect in effects:
        before = previous.get(effect.name)
        if effect.how == "isolator":
            isolators = campaign.machine.module.ISOLATORS
            if before is not None:
                fits.append(fit_candidate(campaign, effect, isolators.index(before.variant), before.theta))
                continue
            # the first isolator from the default starts; the others (often mirror images) start from it
            variants = [fit_candidate(campaign, effect, 0)]
            variants += [fit_candidate(campaign, effect, i, variants[0].theta) for i in range(1, len(isolators))]
            variants.sort(key=lambda f: f.chi2)
            best = variants[0]
            alike = [v.variant for v in variants[1:] if v.chi2 <= best.chi2 + TIE]
            if alike:
                best.note = f"as good: {', '.join(alike)} (which isolator needs mode shapes that tell them apart)"
            fits.append(best)
        else:
            fits.append(fit_candidate(campaign, effect, start=before.theta if before else None))
    return nominal, fits


def _rank_key(f: CandidateFit) -> tuple:
    return (not f.applicable, not f.plausible, f.aicc if math.isfinite(f.aicc) else math.inf, f.chi2)


def rank(
    campaign: Campaign, nominal: CandidateFit, fits: list[CandidateFit], exact_held_out: bool = True
) -> EffectsReport:
    """Rank fitted candidates, judge the nominal gap, find the tie and what would separate it
    (``exact_held_out``: refit without each mode for the nominal model and, with a significant gap, the
    first three of the tie; else linearised only). The tie and what separates it are reported only when
    there is a significant gap to explain."""
    n, k = nominal.n_data, nominal.n_parameters
    p_value = float(scipy.stats.chi2.sf(nominal.chi2, n - k)) if n > k else math.nan
    significant = bool(p_value < GAP_P_VALUE)
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
    tie = [f for f in ranked if best and f.applicable and f.plausible and f.aicc <= best.aicc + TIE]
    # refitted held-out errors for the nominal model and, when there is a gap to explain, the first three of
    # the tie (the others keep their linearised ones)
    for f in [nominal, *(tie[:3] if significant else [])] if exact_held_out else []:
        exact_leave_one_out(f)
    for f in [nominal, *fits]:
        z = held_out_z(f, campaign)
        if len(z):
            f.held_out_rms = float(np.sqrt(np.mean(z**2)))
            f.held_out_median = float(np.median(np.abs(z)))
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
    elif best.aicc > nominal.aicc - TIE:
        verdict = "significant gap, but no candidate effect explains it better than the nominal model"
    else:
        p_after = float(scipy.stats.chi2.sf(best.chi2, best.n_data - best.n_parameters))
        names = ", ".join(f.effect for f in tie)
        if p_after < GAP_P_VALUE:
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
) -> EffectsReport:
    """Fit every candidate effect to the campaign and rank them (the 'which effect' half of the diagnosis;
    ``warm`` as in :func:`fit_all`, ``exact_held_out`` as in :func:`rank`)."""
    nominal, fits = fit_all(campaign, effects, warm)
    return rank(campaign, nominal, fits, exact_held_out)


def separate(campaign: Campaign, a: CandidateFit, b: CandidateFit) -> str:
    """The single modal measurement (a frequency or a mode shape of any mode) on which the fitted
    candidates a and b differ most, in units of the campaign's typical uncertainty."""
    mod = campaign.machine.module
    labels = tuple(mod.MODES)
    pa = a.model.predict(a.theta, labels)
    pb = b.model.predict(b.theta, labels)
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
