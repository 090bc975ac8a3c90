"""Modal data from free-decay records: natural frequencies, damping ratios, mode shapes, and their spread.

Pure functions on arrays and records, no plotting. The main estimator is a multi-channel matrix pencil
(Hua & Sarkar) on the free decay after an impact: a parametric fit of damped exponentials, so a 4 s record
(raw FFT bin 1.57 rad/s) still gives frequencies far inside one bin. The paper's own damping method (an
exponential fitted to the decaying peaks of one band-passed mode, Eq. 25) is here too, as an independent
check of the damping.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from mountid.errors import InputError
from mountid.measurement.records import Record
from mountid.measurement.settings import RECORDS, RecordSettings
from mountid.nomenclature import counted


def pole_of(frequency: float, damping_ratio: float) -> complex:
    """The pole p (Im p > 0) [rad/s] of a mode of undamped frequency |p| ``frequency`` [rad/s] and ``damping_ratio``
    -Re p / |p| (Im p 0 from a ratio of 1 on)."""
    w, z = frequency, damping_ratio
    return complex(-z * w, w * math.sqrt(max(1.0 - z * z, 0.0)))


@dataclass(frozen=True)
class Pole:
    """One damped mode found in a record.

    frequency: undamped natural frequency |p| [rad/s]; damping_ratio: -Re(p)/|p| [-]; shape: complex
    amplitude per channel at the start of the analysed segment [channel unit]; *_std: standard deviation
    the measurement noise causes (Cramer-Rao bound of the least-squares fit, see refine_poles); shape_std: per
    channel, the standard deviation of the complex amplitude, sqrt(E |error|^2) [channel unit]
    (amplitude_standard_deviations, with what the other poles' error moves between them), None where not
    estimated.
    """

    frequency: float
    damping_ratio: float
    shape: NDArray[np.complex128]
    frequency_std: float = 0.0
    damping_std: float = 0.0
    shape_std: NDArray[np.float64] | None = None

    @property
    def p(self) -> complex:
        """The pole p (Im p > 0) [rad/s] of this frequency |p| and damping ratio."""
        return pole_of(self.frequency, self.damping_ratio)

    @property
    def damped_frequency(self) -> float:
        """Im(p) [rad/s]: what an FFT peak would show."""
        return self.frequency * np.sqrt(max(0.0, 1.0 - self.damping_ratio**2))


def decimated(
    record: Record, start: float, max_frequency: float, points_per_period: float = 8.0
) -> tuple[float, NDArray[np.float64]]:
    """Free-decay samples from ``start`` [s], low-pass filtered (zero phase) and decimated so that the
    highest frequency of interest ``max_frequency`` [rad/s] has about ``points_per_period`` samples.

    The record is cut at ``start`` before filtering (the impact stays out), and the samples within half
    the decimation filter's length (20 x factor taps) of either end are dropped: there the zero-padded
    filter rings. Returns (time step [s], samples (n, n_channels))."""
    rate = record.rate
    factor = max(1, int(rate / (points_per_period * max_frequency / (2 * np.pi))))
    data = record.data[record.time >= start]
    if factor > 1:
        data = decimate(data, factor)[10:-10]
    return factor / rate, data


def decimate(data: NDArray, factor: int) -> NDArray[np.float64]:
    """Every ``factor``-th sample of ``data`` (along axis 0) after a zero-phase low-pass at 1/factor of the
    Nyquist frequency: a Hamming-windowed sinc of 20 factor + 1 taps, applied centred (linear phase, no
    delay). It is scipy.signal.decimate(data, factor, ftype="fir", zero_phase=True) to rounding (a test
    compares them), written in numpy so that the records chain does not import scipy.signal: that import
    alone took half of the one second a 4 s file to stiffness may take."""
    taps = 20 * factor + 1
    n = np.arange(taps) - (taps - 1) / 2
    kernel = np.sinc(n / factor) / factor * np.hamming(taps)
    kernel /= kernel.sum()
    half = (taps - 1) // 2
    x = np.asarray(data, dtype=float)
    if len(x) == 0:
        return x[::factor]
    # only the samples kept are filtered (the symmetric kernel against each window of the zero-padded channel): a
    # factor of 313 (kid300 at 51.2 kHz) filtered every sample for 17 s of a 3 s record's processing
    padded = np.concatenate([np.zeros((half, x.shape[1])), x, np.zeros((half, x.shape[1]))])
    windows = np.lib.stride_tricks.sliding_window_view(padded, taps, axis=0)[::factor]  # (kept, channels, taps)
    return np.column_stack([windows[:, j, :] @ kernel for j in range(x.shape[1])])


PENCIL_SIZES: tuple[int, ...] = (160, 250)
"""Pencil sizes L (columns of each channel's Hankel matrix less one) free_decay_poles solves with, at most half
the samples; a pole is kept where it recurs at both. The span L dt must hold the close modes apart: genset8's y
and x (18.9 and 21.6 rad/s, zeta 0.05, 0.005 s steps) come out 1.7 % high at L = 100, beyond the recurrence
tolerance against L = 160, and x was lost; from L = 130 on both sit within 0.05 % of the truth."""


def matrix_pencil(samples: NDArray, dt: float, order: int, pencil: int | None = None) -> NDArray[np.complex128]:
    """Continuous-time poles p [1/s] of ``order`` damped exponentials fitted to all channels at once.

    samples (n, n_channels) at step dt [s]. Each channel's Hankel matrix (n - L) x (L + 1) is stacked; the
    ``order`` dominant right singular vectors span the signal (taken from the small (L+1) x (L+1) Gram
    matrix); the shift between their first and last L rows gives the discrete poles z = exp(p dt).
    """
    return _shift_poles(_signal_basis(samples, order, pencil), order, dt)


def _signal_basis(samples: NDArray, order: int, pencil: int | None) -> NDArray[np.float64]:
    """The right singular vectors of the stacked Hankel matrices (matrix_pencil), dominant first, shape
    (L + 1, L + 1): the orders of one pencil size share them."""
    n, n_ch = samples.shape
    L = pencil or n // 3
    if not order < L < n - 1:
        raise InputError("record", f"too short for {order} exponentials: {n} samples after decimation")
    gram = np.zeros((L + 1, L + 1))
    for j in range(n_ch):  # channel by channel: the stacked Hankel matrices never held at once
        hankel = np.lib.stride_tricks.sliding_window_view(np.ascontiguousarray(samples[:, j]), L + 1)[: n - L]
        gram += hankel.T @ hankel
    return np.linalg.eigh(gram)[1][:, ::-1]


def _shift_poles(vecs: NDArray, order: int, dt: float) -> NDArray[np.complex128]:
    """The poles [1/s] of the ``order`` dominant singular vectors of _signal_basis."""
    v = vecs[:, :order]
    z = np.linalg.eigvals(np.linalg.pinv(v[:-1]) @ v[1:])
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.log(z.astype(complex)) / dt


def amplitudes(samples: NDArray, dt: float, poles: NDArray) -> NDArray[np.complex128]:
    """Complex amplitude of every pole in every channel by linear least squares, shape (n_poles, n_channels).
    A constant per channel (sensor bias) is fitted alongside and left out of the result."""
    return _least_squares(samples, dt, poles)[1][:-1]


def amplitude_standard_deviations(samples: NDArray, dt: float, poles: NDArray) -> NDArray[np.float64]:
    """Standard deviation sqrt(E |error|^2) of every amplitude that :func:`amplitudes` gives, shape (n_poles,
    n_channels) [channel unit], for white noise of each channel's residual variance: the linear least squares'
    sigma_c^2 [(B^H B)^-1]_kk (B the basis of the poles and the constant). The poles are taken as exact: their
    own error moves the amplitudes of every channel of a mode alike (its scale and phase), which a mode shape
    normalises away; another pole's error moves amplitude between the two, which the poles a record gives add
    (Pole.shape_std: _pole_shape_variances)."""
    return _amplitude_stds(samples, *_least_squares(samples, dt, poles))


def _amplitude_stds(samples: NDArray, basis: NDArray, coef: NDArray) -> NDArray[np.float64]:
    """amplitude_standard_deviations from the least squares' ``basis`` and coefficients ``coef``."""
    resid = np.real(samples - basis @ coef)
    dof = max(len(samples) - basis.shape[1], 1)  # real parameters per channel: two per conjugate pair, the bias
    variance = np.sum(resid**2, axis=0) / dof
    gain = np.real(np.diagonal(np.linalg.pinv(basis.conj().T @ basis)))[:-1]
    return np.sqrt(np.maximum(gain, 0.0)[:, None] * variance[None, :])


def _least_squares(
    samples: NDArray, dt: float, poles: NDArray
) -> tuple[NDArray[np.complex128], NDArray[np.complex128]]:
    """The basis of ``poles`` [rad/s] and a constant (_basis) on ``samples`` (step ``dt`` [s]), and the
    least-squares coefficients of every channel in it, shape (n_poles + 1, n_channels)."""
    basis = _basis(len(samples), dt, poles)
    return basis, np.linalg.lstsq(basis, samples.astype(complex), rcond=None)[0]


def _basis(n: int, dt: float, poles: NDArray) -> NDArray[np.complex128]:
    """exp(p t) for every pole, and a constant column (sensor bias), shape (n, n_poles + 1)."""
    t = np.arange(n) * dt
    return np.column_stack([np.exp(np.outer(t, poles)), np.ones(n)])


def stable_tolerance(pole: complex) -> float:
    """Relative change of |p| within which a pole recurs across model orders and pencil sizes: 1 %, or a
    quarter of its damping ratio where that is more (a heavily damped pole is as wide as 2 zeta |p| in the
    spectrum, and its estimate moves with the order by a few percent: zeta 0.28 moved 2 %)."""
    return max(0.01, 0.25 * float(-pole.real / abs(pole)))


def stable_poles(runs: list[NDArray[np.complex128]]) -> list[tuple[float, float, float, float]]:
    """The poles that recur in every run (model orders, pencil sizes; or any estimator's orders): each pole of
    the first run that every other run has within stable_tolerance in |p| and with the same damping ratio,
    as (mean |p| [rad/s], mean zeta, std of |p| over the runs, std of zeta). The one selection rule of the
    records chain; the benchmark applies it to LSCF's poles too, so that both estimators are compared with
    the same choice of stable poles."""
    out = []
    for p0 in runs[0] if runs else []:
        matches = []
        for run in runs:
            if not len(run):
                break
            match = _match(p0, run)
            if match is None:
                break
            matches.append(match)
        if len(matches) != len(runs):
            continue
        m = np.array(matches)
        w = np.abs(m)
        zeta = -m.real / w
        out.append((float(np.mean(w)), float(np.mean(zeta)), float(np.std(w, ddof=1)), float(np.std(zeta, ddof=1))))
    return out


def stabilisation(
    record: Record,
    start: float,
    max_frequency: float,
    n_modes: int,
    extra: range = range(0, 25, 2),
    steady: float = RECORDS.steady_damping,
) -> list[tuple[int, NDArray[np.complex128], NDArray[np.bool_]]]:
    """The data of a stabilisation diagram: for each model order 2 n_modes + e (e in ``extra``) the pencil's
    physical poles (0 < zeta < 0.5, |p| <= max_frequency [rad/s]) of the free decay from ``start`` [s] and its
    steady oscillations (|zeta| < ``steady``, of either sign: free_decay_poles keeps them, and one whose damping
    came out below zero was missing from the diagram), and whether each is stable against the previous order
    (within stable_tolerance in |p|, the same damping)."""
    dt, samples = decimated(record, start, max_frequency)
    out, previous = [], np.array([], dtype=complex)
    for e in extra:
        order = 2 * n_modes + e
        p = matrix_pencil(samples, dt, order, min(len(samples) // 2, PENCIL_SIZES[0]))
        p = p[np.isfinite(p) & (p.imag > 0)]
        w, zeta = np.abs(p), -p.real / np.abs(p)
        p = p[(((zeta > 0) & (zeta < 0.5)) | is_tone(p, steady)) & (w <= max_frequency)]
        stable = np.array([_recurs(x, previous) for x in p], dtype=bool)
        out.append((order, p, stable))
        previous = p
    return out


def _recurs(pole: complex, previous: NDArray[np.complex128]) -> bool:
    """Whether ``pole`` is in ``previous`` (_match)."""
    return _match(pole, previous) is not None


def _match(pole: complex, run: NDArray[np.complex128]) -> complex | None:
    """The pole of ``run`` that is ``pole``: the nearest in |p|, where it lies within stable_tolerance of |pole|
    and has the same damping ratio; None where there is none."""
    if not len(run):
        return None
    q = run[np.argmin(np.abs(np.abs(run) - abs(pole)))]
    return q if abs(abs(q) - abs(pole)) <= stable_tolerance(pole) * abs(pole) and _same_damping(q, pole) else None


def _same_damping(p: complex, p0: complex) -> bool:
    """Whether two estimates of a pole agree in damping ratio (within 0.01, or 30 % of the reference's where
    that is more): a noise pole of zeta 0.39 near a mode of zeta 0.05 is not that mode."""
    z, z0 = -p.real / abs(p), -p0.real / abs(p0)
    return abs(z - z0) <= max(0.01, 0.3 * z0)


def free_decay_poles(
    record: Record,
    start: float,
    max_frequency: float,
    n_modes: int,
    min_frequency: float = 0.0,
    extra_orders: tuple[int, ...] = (4, 8, 12),
    steady: float = RECORDS.steady_damping,
) -> list[Pole]:
    """Physical poles (0 < damping ratio < 0.5, frequency in [min_frequency, max_frequency] rad/s) of the
    free decay from ``start`` [s], for a machine with up to ``n_modes`` modes, and the steady oscillations in it.

    The pencil is solved with 2 n_modes + extra poles (the extra ones take up noise) for each entry of
    ``extra_orders`` and for two pencil sizes; a pole is kept when it recurs in every run (stable_poles;
    poles that carry less than 1e-3 of the strongest pole's amplitude are dropped as noise). A steady oscillation
    (a machine running nearby, mains hum) comes out of the pencil at a damping ratio of about +-1e-7: one within
    ``steady`` of zero or below it, recurring in every run, is kept too (a negative one was dropped, and the
    oscillation left in the samples spoiled the modes' estimates: a tone at 18.2 rad/s beside kid300's x at 17.71
    gave x at 18.06, zeta 0.012); the caller tells it from a mode by its damping (modal.not_a_free_decay).
    The kept poles, averaged over the runs, start a joint least-squares refinement of all of them on all
    channels (refine_poles), which also gives their standard deviations.
    """
    if max_frequency <= 0:
        raise InputError("max_frequency", f"must be positive, got {max_frequency}")
    dt, samples = decimated(record, start, max_frequency)
    runs, tones = [], []
    orders = [2 * n_modes + extra for extra in extra_orders]
    for cap in PENCIL_SIZES:
        vecs = _signal_basis(samples, max(orders), min(len(samples) // 2, cap))
        for order in orders:
            p = _shift_poles(vecs, order, dt)
            p = p[np.isfinite(p) & (p.imag > 0)]
            w = np.abs(p)
            zeta = -p.real / w
            band = (w >= min_frequency) & (w <= max_frequency)
            tones.append(p[is_tone(p, steady) & band])
            p = p[(zeta > 0) & (zeta < 0.5) & band]
            amp = np.linalg.norm(amplitudes(samples, dt, np.concatenate([p, p.conj()]))[: len(p)], axis=1)
            runs.append(p[amp > 1e-3 * amp.max()] if len(p) else p)
    steady_poles = np.array([_pole(w, z) for w, z, _, _ in stable_poles(tones)], dtype=complex)
    # a steady oscillation whose damping came out positive in every run is among the damped ones too: kept once
    damped = [
        _pole(w, z) for w, z, _, _ in stable_poles(runs) if z >= steady or _match(_pole(w, z), steady_poles) is None
    ]
    poles = damped + list(steady_poles)
    if not poles:
        return []
    return _refined(samples, dt, np.array(poles, dtype=complex))


def is_tone(p: NDArray, steady: float = RECORDS.steady_damping) -> NDArray[np.bool_]:
    """Which of the pencil's poles ``p`` (Im p > 0) are steady oscillations: |zeta| < ``steady``, of either sign
    (the pencil gives a running machine's tone about +-1e-7, as the noise moves it). What free_decay_poles keeps
    as tones, modal.stabilisation shows and the stabilisation figure draws as crosses."""
    return np.abs(-p.real / np.abs(p)) < steady


def is_steady(pole: Pole, settings: RecordSettings = RECORDS) -> bool:
    """Whether ``pole`` is a steady oscillation (a running machine, mains hum), not a mode: its damping ratio lies
    within settings.steady_damping of zero, or below (free_decay_poles keeps such poles; the caller tells them from
    the modes by this)."""
    return pole.damping_ratio < settings.steady_damping


def _pole(w: float, zeta: float) -> complex:
    """The pole of natural frequency ``w`` [rad/s] and damping ratio ``zeta`` (Im > 0)."""
    return complex(-zeta * w, w * np.sqrt(1 - zeta * zeta))


def poles_from(record: Record, start: float, max_frequency: float, seeds: NDArray, clipped: bool = False) -> list[Pole]:
    """The poles of the free decay from ``start`` [s] refined jointly from the complex ``seeds`` [rad/s] (Im > 0)
    on the samples free_decay_poles fits (same ``max_frequency``): e.g. two poles where its pencil found one in
    the place of two close modes. Sorted by frequency. ``clipped``: refine_poles's."""
    dt, samples = decimated(record, start, max_frequency)
    return _refined(samples, dt, np.asarray(seeds, dtype=complex), clipped)


def decay_misfit(record: Record, start: float, max_frequency: float, poles: NDArray) -> tuple[NDArray[np.float64], int]:
    """Per channel, the sum of squared residuals of the free decay from ``start`` [s] (the samples
    free_decay_poles fits, same ``max_frequency``) after the least-squares amplitudes of the damped exponentials
    ``poles`` [rad/s] and a constant; and the number of samples."""
    dt, samples = decimated(record, start, max_frequency)
    return _misfit(samples, dt, poles), len(samples)


def _misfit(samples: NDArray, dt: float, poles: NDArray) -> NDArray[np.float64]:
    """Per channel, the sum of squared residuals of ``samples`` (step ``dt`` [s]) after the least-squares
    amplitudes of the damped exponentials ``poles`` [rad/s] and a constant."""
    p = np.asarray(poles, dtype=complex)
    basis, coef = _least_squares(samples, dt, np.concatenate([p, p.conj()]))
    return np.sum(np.abs(samples - (basis @ coef).real) ** 2, axis=0)


def not_a_free_decay(
    record: Record,
    start: float,
    max_frequency: float,
    poles: list[tuple[str, Pole]],
    settings: RecordSettings = RECORDS,
) -> list[QualityWarning]:
    """Checks that the free decay from ``start`` [s] (free_decay_poles's samples, same ``max_frequency``) is one, from
    the ``poles`` found there (each with its label, "" for one left unlabelled):

    - steady: a pole whose damping ratio lies within settings.steady_damping of zero, or below, is a steady
      oscillation (a running machine, mains hum), not a mode: named with its frequency (and the label it took),
      and with the share of the decay's variance the steady oscillations carry;
    - unexplained: the poles and a constant leave more than settings.unexplained of the decay's variance
      unexplained (the median over the channels): the record is not the free decay of a hit (a record of another
      test) or holds more noise than response."""
    dt, samples = decimated(record, start, max_frequency)

    def unexplained(kept: list[Pole]) -> float:  # the median share of the variance the poles ``kept`` leave
        return _unexplained(samples, dt, np.array([p.p for p in kept], dtype=complex))

    everything = [p for _, p in poles]
    left = unexplained(everything)
    tones = [(label, p) for label, p in poles if is_steady(p, settings)]
    out = []
    if tones:
        carried = max(0.0, unexplained([p for p in everything if not is_steady(p, settings)]) - left)
        for label, pole in tones:
            taken = f" (labelled {label})" if label else ""
            out.append(
                QualityWarning(
                    "steady",
                    "all",
                    f"a pole at {pole.frequency:.4f} rad/s ({pole.frequency / (2 * np.pi):.4g} Hz){taken} of damping "
                    f"ratio {pole.damping_ratio:.2g} is a steady oscillation (a running machine, mains hum), not a "
                    f"mode; the steady oscillations carry {carried:.0%} of the free decay's variance",
                )
            )
    if left > settings.unexplained:
        quarter = max(1, len(samples) // 4)
        level = np.sqrt(
            np.mean(samples[-quarter:] ** 2, axis=0) / np.maximum(np.mean(samples[:quarter] ** 2, axis=0), 1e-300)
        )
        steady = 1 / STEADY_LEVEL < float(np.median(level)) < STEADY_LEVEL
        why = (
            f"the responses do not decay (their last quarter at {float(np.median(level)):.0%} of their first's level): "
            "a steady motion, not a hit's free decay (ambient or operational excitation: without a start given, "
            "mountid reads a broadband one as output-only, by its correlation functions; or a shaker whose force is "
            "not recorded: mountid reads a shaker's record with its force channel)"
            if steady
            else "not the free decay of a hit (a record of another test) or more noise than response"
        )
        out.append(
            QualityWarning(
                "unexplained",
                "all",
                f"the poles found leave {left:.0%} of the free decay's variance unexplained (the median over the "
                f"channels): {why}",
            )
        )
    return out


def unexplained_share(record: Record, start: float, max_frequency: float, poles: NDArray) -> float:
    """The share of the variance of ``record``'s samples from ``start`` [s] (free_decay_poles's, same
    ``max_frequency``) that the damped exponentials ``poles`` [rad/s] and a constant leave unexplained, the median
    over the channels."""
    dt, samples = decimated(record, start, max_frequency)
    return _unexplained(samples, dt, np.asarray(poles, dtype=complex))


def _unexplained(samples: NDArray, dt: float, poles: NDArray) -> float:
    """unexplained_share on the decimated ``samples`` (step ``dt`` [s])."""
    variance = np.sum((samples - samples.mean(axis=0)) ** 2, axis=0)
    misfit = _misfit(samples, dt, poles)
    return float(np.median(misfit / np.where(variance > 0, variance, np.inf)))


STEADY_LEVEL = 2.0
"""A free decay whose poles leave it unexplained (not_a_free_decay) and whose last quarter's RMS is within this
factor of its first's (the median over the channels) is a steady motion: an output-only record of random or
operational excitation (a hit's free decay falls by orders of magnitude; a segment of quiet before a hit rises)."""


def _refined(samples: NDArray, dt: float, start: NDArray, clipped: bool = False) -> list[Pole]:
    """Poles refined from ``start`` (refine_poles, ``clipped``) with their shapes and standard deviations, by
    frequency."""
    refined, cov = refine_poles(samples, dt, start, clipped=clipped)
    basis, coef = _least_squares(samples, dt, np.concatenate([refined, refined.conj()]))
    shapes = coef[:-1]  # amplitudes(): the constant's row left out
    shape_stds = np.sqrt(
        _amplitude_stds(samples, basis, coef)[: len(refined)] ** 2 + _pole_shape_variances(dt, basis, coef, cov)
    )
    stds = pole_standard_deviations(refined, cov)
    out = [
        Pole(float(abs(p)), float(-p.real / abs(p)), shapes[i], *stds[i], shape_std=shape_stds[i])
        for i, p in enumerate(refined)
    ]
    return sorted(out, key=lambda p: p.frequency)


def _pole_shape_variances(dt: float, basis: NDArray, coef: NDArray, cov: NDArray) -> NDArray[np.float64]:
    """E |error|^2 of each pole's channel amplitudes (n_poles, n_channels) from the error of the poles
    (``cov`` of (sigma_1..k, omega_1..k), refine_poles), to first order: d coef = -B^+ (dB) coef for the least
    squares' ``basis`` B (the poles, their conjugates and a constant) and coefficients ``coef``, with the part
    along the pole's own amplitudes left out (a pole's own error scales and turns all of them alike, which a mode
    shape normalises away). What is left is a partner's error moving amplitude between two poles: small where
    the poles lie apart, the larger part of a shape's error for two poles within each other's bandwidth (twins
    of a machine whose symmetry is broken), which amplitude_standard_deviations, the poles taken as exact, leaves
    out."""
    k = (basis.shape[1] - 1) // 2
    t = np.arange(basis.shape[0]) * dt
    pinv = np.linalg.pinv(basis)
    moved = np.empty((k, coef.shape[1], 2 * k), dtype=complex)  # d amplitude / d (sigma_1..k, omega_1..k)
    for m in range(k):
        own, conj = t * basis[:, m], t * basis[:, k + m]  # d exp(p t) / d sigma, and of the conjugate
        for j, (a, b) in enumerate(((own, conj), (1j * own, -1j * conj))):
            moved[:, :, m + j * k] = -(pinv @ (np.outer(a, coef[m]) + np.outer(b, coef[k + m])))[:k]
    out = np.empty((k, coef.shape[1]))
    for i in range(k):
        a = coef[i]
        d = moved[i] - np.outer(a, a.conj() @ moved[i]) / max(np.vdot(a, a).real, np.finfo(float).tiny)
        out[i] = np.maximum(np.real(np.einsum("cj,jl,cl->c", d, cov, d.conj())), 0.0)
    return out


def pole_standard_deviations(poles: NDArray, cov: NDArray) -> list[tuple[float, float]]:
    """Standard deviations of |p| [rad/s] and zeta = -Re p / |p| of each pole, from the covariance of
    (sigma_1..k, omega_1..k) (refine_poles, fisher_pole_covariance), by first-order propagation."""
    out = []
    k = len(poles)
    for i, p in enumerate(poles):
        w, sig, om = abs(p), p.real, p.imag
        c2 = cov[np.ix_([i, k + i], [i, k + i])]
        g_w = np.array([sig, om]) / w
        g_z = np.array([-(om**2), sig * om]) / w**3  # zeta = -sigma / |p|
        out.append((float(np.sqrt(max(g_w @ c2 @ g_w, 0.0))), float(np.sqrt(max(g_z @ c2 @ g_z, 0.0)))))
    return out


def fisher_pole_covariance(samples: NDArray, dt: float, poles: NDArray, variance: NDArray) -> NDArray:
    """The Cramer-Rao covariance of (sigma_1..k, omega_1..k) for noise-free ``samples`` of the damped
    exponentials ``poles`` and white noise of ``variance`` per channel (per sample of ``samples``): what
    refine_poles will state on such a record, before it is made."""
    info, _ = _gauss_newton_terms(samples, dt, np.asarray(poles, dtype=complex), variance)
    return np.linalg.pinv(info)


def _gauss_newton_terms(
    samples: NDArray, dt: float, poles: NDArray, variance: NDArray | None = None
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Normal equations of the damped-exponential fit in the poles (sigma_k, omega_k), with the amplitudes
    and a constant per channel projected out (variable projection, Kaufman's Jacobian) and each channel
    weighted by its residual variance (or the noise ``variance`` per channel given, for a record without
    noise: the Fisher information of a planned test). Returns (J^T W J, J^T W r)."""
    t = np.arange(len(samples)) * dt
    basis, coef = _least_squares(samples, dt, np.concatenate([poles, poles.conj()]))
    resid = np.real(samples - basis @ coef)
    var = np.maximum(np.mean(resid**2, axis=0) if variance is None else np.asarray(variance, float), 1e-300)
    q, _ = np.linalg.qr(basis)
    k = len(poles)
    info, grad = np.zeros((2 * k, 2 * k)), np.zeros(2 * k)
    for c in range(samples.shape[1]):
        # d y_c / d(sigma_k, omega_k) for y_c = sum 2 Re(a_kc exp(p_k t)), p_k = sigma_k + i omega_k
        d = t[:, None] * np.exp(np.outer(t, poles)) * coef[:k, c][None, :]
        jac = np.concatenate([2 * d.real, -2 * d.imag], axis=1)
        jac = jac - np.real(q @ (q.conj().T @ jac))
        info += jac.T @ jac / var[c]
        grad += jac.T @ resid[:, c] / var[c]
    return info, grad


def refine_poles(
    samples: NDArray, dt: float, poles: NDArray, max_steps: int = 10, clipped: bool = False
) -> tuple[NDArray, NDArray]:
    """Least-squares (maximum-likelihood for white noise) poles from the pencil's estimates: Gauss-Newton
    on the variable-projection problem until the step is below 1e-9 of |p|. Returns (poles, covariance of
    (sigma_1..k, omega_1..k)): the inverse of J^T W J, the Cramer-Rao bound of the noise. A step that leaves a
    pole unstable or moves one by more than 5 % of |p| ends the refinement (the linearisation does not hold), unless
    ``clipped``: then each pole's step is cut to 5 % of its |p| and to half its way to the imaginary axis, and the
    others go on (a pole the data hardly determine, as the estimate's noise in correlation functions gives, would
    otherwise stop the refinement of every pole at its start)."""
    p = np.array(poles, dtype=complex)
    k = len(p)
    for _ in range(max_steps):
        info, grad = _gauss_newton_terms(samples, dt, p)
        step = np.linalg.lstsq(info, grad, rcond=None)[0]
        move = step[:k] + 1j * step[k:]
        if clipped and np.all(np.isfinite(move)):
            move = move * np.minimum(1.0, 0.05 * np.abs(p) / np.maximum(np.abs(move), 1e-300))
            move.real = np.where(p.real + move.real < 0, move.real, 0.5 * -p.real)  # half way to the axis at most
        candidate = p + move
        step = np.concatenate([move.real, move.imag])
        # a clipped step is short by construction: testing its length again would stop on the rounding of the clip
        too_long = not clipped and np.any(np.abs(candidate - p) > 0.05 * np.abs(p))
        if not np.all(np.isfinite(candidate)) or np.any(candidate.real >= 0) or too_long:
            break  # keep the last physical estimate: a long step means the linearisation does not hold
        p = candidate
        if np.all(np.abs(step[:k] + 1j * step[k:]) <= 1e-9 * np.abs(p)):
            break
    info, _ = _gauss_newton_terms(samples, dt, p)
    return p, np.linalg.pinv(info)


def mac(a: NDArray, b: NDArray) -> float:
    """Modal assurance criterion |a^H b|^2 / (|a|^2 |b|^2) of two (complex) shapes, in [0, 1] (0 where either
    is zero)."""
    return float(mac_matrix(np.asarray(a)[:, None], np.asarray(b)[:, None])[0, 0])


def mac_matrix(a: NDArray, b: NDArray) -> NDArray[np.float64]:
    """The modal assurance criterion of every column of ``a`` with every column of ``b`` (real or complex
    shapes in the same coordinates, one per column): entry (i, j) is mac(a[:, i], b[:, j])."""
    a, b = np.asarray(a), np.asarray(b)
    norm = np.outer(np.sum(np.abs(a) ** 2, axis=0), np.sum(np.abs(b) ** 2, axis=0))
    cross = np.abs(np.conj(a).T @ b) ** 2
    return np.divide(cross, norm, out=np.zeros(norm.shape), where=norm > 0)


def band_pass(signal: NDArray, dt: float, low: float, high: float, order: int = 2) -> NDArray[np.float64]:
    """Zero-phase Butterworth band-pass of ``signal`` (sampled at step dt [s]) between low and high [rad/s]."""
    import scipy.signal  # not at module level: the records chain does not need it (see decimate)

    band = [low / (2 * np.pi), high / (2 * np.pi)]
    sos = scipy.signal.butter(order, band, btype="band", fs=1.0 / dt, output="sos")
    return scipy.signal.sosfiltfilt(sos, signal, axis=0)


def decay_envelope(
    signal: NDArray, dt: float, frequency: float, bandwidth: float = RECORDS.decay_bandwidth
) -> tuple[float, float]:
    """The paper's damping method (Eq. 25): band-pass one mode (``frequency`` [rad/s], relative
    ``bandwidth``), take the positive peaks of the decay and fit A0 exp(-n t) to them by least squares
    on log(amplitude). Returns (A0 [signal unit], n [1/s]); the damping ratio is n / frequency."""
    import scipy.signal

    fs = 1.0 / dt
    f = frequency / (2 * np.pi)
    y = band_pass(signal, dt, frequency * (1 - bandwidth), frequency * (1 + bandwidth))
    peaks, _ = scipy.signal.find_peaks(y, distance=max(1, int(0.7 * fs / f)))
    # the zero-phase filter rings in and out at both ends for a few of its time constants 1/(bandwidth w)
    edge = int(3 * fs / (bandwidth * frequency)) + int(2 * fs / f)
    peaks = peaks[(peaks > edge) & (peaks < len(y) - edge) & (y[peaks] > 0)]
    if len(peaks) < 3:
        raise InputError("record", f"fewer than 3 decaying peaks near {frequency:g} rad/s")
    top = y[peaks]
    keep = top > 0.05 * top.max()  # the noise floor flattens the tail
    t = peaks[keep] * dt
    slope, intercept = np.polyfit(t, np.log(top[keep]), 1)
    return float(np.exp(intercept)), float(-slope)


def spectrum(signal: NDArray, dt: float, pad: int = 4) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Amplitude spectrum with a Hann window, zero-padded ``pad`` times: (omega [rad/s], |X|)."""
    n = len(signal)
    window = np.hanning(n)
    x = np.fft.rfft((signal - np.mean(signal)) * window, n=pad * n)
    return 2 * np.pi * np.fft.rfftfreq(pad * n, dt), np.abs(x) * 2 / np.sum(window)


def spectrum_peaks(omega: NDArray, amplitude: NDArray, count: int, min_omega: float = 0.0) -> NDArray[np.float64]:
    """The ``count`` highest spectral peaks above ``min_omega`` [rad/s], each refined below the bin by a
    parabola through the log amplitudes of the peak bin and its neighbours (exact for a Gaussian peak;
    good to a few hundredths of a bin for a Hann-windowed damped sine). Ascending frequency."""
    import scipy.signal

    log_a = np.log(np.maximum(amplitude, 1e-300))
    peaks, props = scipy.signal.find_peaks(amplitude, height=0)
    peaks = peaks[(omega[peaks] >= min_omega) & (peaks > 0) & (peaks < len(omega) - 1)]
    peaks = peaks[np.argsort(amplitude[peaks])[::-1][:count]]
    a, b, c = log_a[peaks - 1], log_a[peaks], log_a[peaks + 1]
    shift = 0.5 * (a - c) / (a - 2 * b + c)
    return np.sort(omega[peaks] + shift * (omega[1] - omega[0]))


@dataclass(frozen=True)
class QualityWarning:
    """A named problem of an impact record that can bias modal estimates: ``kind`` names it (e.g. "clipping",
    "double_hit", "low_coherence", "unresolved_modes", "twin_modes", "sensor"), ``channel`` the channel it is on
    as it is printed ("all" for the record)."""

    kind: str
    channel: str
    message: str
    suspects: tuple[str, ...] = ()
    """The channels a "sensor" warning names, one of which does not move with the rigid body the others agree on
    (several where the layout cannot tell which of them; none where it cannot narrow them at all)."""
    record: str = ""
    """The record file it is about, where a campaign read several ("" for one record read on its own)."""

    def describe(self) -> str:
        """One line: "record: kind (channel): message" (without "record: " where ``record`` is empty)."""
        return (f"{self.record}: " if self.record else "") + f"{self.kind} ({self.channel}): {self.message}"


def find_bursts(x: NDArray, height: float, distance: int, prominence: float) -> NDArray[np.intp]:
    """Indices of the peaks of ``x`` at least ``height`` high, ``distance`` samples apart (the higher kept),
    standing ``prominence`` above the higher of the lowest points between them and the nearest higher
    sample on either side: scipy.signal.find_peaks(x, height, distance, prominence) on the smooth burst
    levels of impact_bursts (a test compares them), in numpy for the reason given at decimate."""
    x = np.asarray(x, dtype=float)
    if len(x) < 3:
        return np.array([], dtype=np.intp)
    peaks = np.flatnonzero((x[1:-1] > x[:-2]) & (x[1:-1] >= x[2:])) + 1
    peaks = peaks[x[peaks] >= height]
    keep = np.ones(len(peaks), dtype=bool)
    for k in np.argsort(x[peaks], kind="stable")[::-1]:  # the highest first; nearer lower ones go
        if keep[k]:
            near = np.abs(peaks - peaks[k]) < distance
            near[k] = False
            keep &= ~near
    out = []
    for i in peaks[keep]:
        higher_left = np.flatnonzero(x[:i] > x[i])
        higher_right = np.flatnonzero(x[i + 1 :] > x[i])
        left = x[(higher_left[-1] if len(higher_left) else 0) : i + 1].min()
        right = x[i : (i + 1 + higher_right[0] if len(higher_right) else len(x))].min()
        if x[i] - max(left, right) >= prominence:
            out.append(i)
    return np.array(out, dtype=np.intp)


def clipped_level(y: NDArray, settings: RecordSettings = RECORDS, step: int = 1) -> float | None:
    """The level a channel was clipped at, or None, among every ``step``-th sample (clip_step): in a lobe of the
    signal around its extreme (the samples beyond half the largest value, on one side), settings.clip_samples or
    more samples held at that value, and more than twice as many as a smooth peak of the lobe's width holds there,
    plus one (_smooth_band). Held: within 4 noise standard deviations (the noise from the first difference late in
    the record: a flat top the noise added after the saturation roughens), or within the record's resolution (its
    smallest step between values: an exact flat top, however noisy the rest). A smooth peak sampled finely stays
    within the noise of its top on several samples too (a channel at 2 kHz that the lowest mode fills, 700 samples
    a period, was "clipped" at 1 % noise), and the noise splits a flat top's run of samples in pieces: the samples
    are counted over the lobe, not in one run."""
    y = np.asarray(y, dtype=float)[::step]
    a = np.abs(y)
    top = float(a.max())
    if not top > 0:
        return None
    tail = np.diff(y[-max(len(y) // 4, 8) :])
    noise = max(float(np.median(np.abs(tail - np.median(tail)))) * 1.4826 / math.sqrt(2), 1e-9 * top)
    steps = np.diff(np.unique(y))
    resolution = max(float(steps[steps > 0].min(initial=top)), 1e-9 * top)
    # the lobes: runs of samples beyond half the extreme, on one side
    key = np.where(a > 0.5 * top, np.sign(y), 0.0)
    bounds = np.concatenate([[0], np.flatnonzero(np.diff(key) != 0) + 1, [len(key)]])
    for start, end in itertools.pairwise(bounds):
        if key[start] == 0:
            continue
        side = np.sign(y[start:end]) == key[start]
        for band in (4 * noise, resolution):
            held = int(np.count_nonzero((a[start:end] >= top - band) & side))
            if held >= settings.clip_samples and held > 2 * _smooth_band(end - start, band / top) + 1:
                return top
    return None


def _smooth_band(lobe: int, band: float) -> float:
    """How many samples a smooth peak stays within ``band`` (relative to its value) of its top, for a lobe of
    ``lobe`` samples beyond half that value: a sinusoid's (its lobe a third of its period T; within the band for
    T / pi x sqrt(2 band))."""
    return 3 * lobe / np.pi * math.sqrt(2 * band)


def impact_bursts(record: Record, settings: RecordSettings = RECORDS) -> NDArray[np.intp]:
    """Sample indices where the impacts of a record without a force channel begin.

    The first difference of every channel, each in units of its own level late in the record (noise and
    the slowest modes), as a moving RMS over settings.double_hit_spacing (a pulse's rise and fall are one
    impact); an impact is a burst above settings.double_hit_height of the first one and 4 times the
    record's median level, standing out from its surroundings (prominence half its height). Second hits
    closer than about settings.double_hit_spacing merge with the first: a force channel resolves them."""
    diff = np.diff(record.data, axis=0)
    tail = diff[-max(len(diff) // 4, 8) :]
    level = np.median(np.abs(tail - np.median(tail, axis=0)), axis=0) * 1.4826
    level = np.where(level > 0, level, np.max(np.abs(diff), axis=0) + 1e-300)
    energy = np.sum((diff / level) ** 2, axis=1)
    width = max(1, int(round(settings.double_hit_spacing * record.rate)))
    rms = np.sqrt(np.convolve(energy, np.ones(width) / width, mode="same"))
    floor = 4 * float(np.median(rms))
    first = int(np.argmax(rms > max(0.5 * rms.max(), floor)))  # the first burst's rise
    top = float(rms[first : first + 2 * width].max())
    level = max(settings.double_hit_height * top, floor)
    peaks = find_bursts(rms, level, width, 0.5 * level)
    # each burst at its rise: the last sample before the peak below half the peak's level (a burst that rises
    # out of the previous one: its lowest point since that one's peak)
    onsets, before = [], 0
    for k in peaks:
        back = rms[k:before:-1] if before else rms[k::-1]
        low = np.flatnonzero(back < 0.5 * rms[k])
        onsets.append(k - int(low[0]) + 1 if len(low) else before + int(np.argmin(rms[before : k + 1])))
        before = k
    return np.array(onsets, dtype=np.intp)


DEFAULT_START = 0.07
"""[s] The free decay's start where none is given and the record shows its impact before it: 0.02 s after the
virtual rig's hit (measurement.rig.Hammer.time, 0.05 s), a hammer pulse of a few milliseconds past."""

AFTER_IMPACT = 0.03
"""[s] Where a record shows its impact too late for DEFAULT_START (a bench export with a pre-trigger, the time
counted from the acquisition's start), the free decay starts by default this long after the impact's onset
(impact_bursts, whose moving RMS over RecordSettings.double_hit_spacing finds it up to half of that early): past a
hammer pulse of a few milliseconds, a soft tip's 10 ms with a margin."""


def clip_step(record: Record, highest_frequency: float | None, settings: RecordSettings = RECORDS) -> int:
    """Every how many samples a response channel's clipping is judged (clipped_level): 1, or k where ``record``
    holds more than k times settings.clip_resolution samples per period of ``highest_frequency`` [rad/s] (None:
    1)."""
    if highest_frequency is None or not highest_frequency > 0:
        return 1
    return max(1, int(record.rate // (settings.clip_resolution * highest_frequency / (2 * np.pi))))


def _too_slow_for_bursts(record: Record, highest_frequency: float | None, settings: RecordSettings) -> bool:
    """Whether ``record`` is sampled below settings.low_rate_factor times ``highest_frequency`` [rad/s] / (2 pi)
    (None: never): the modes' own oscillation then fills the first difference, and no impact burst stands out."""
    return highest_frequency is not None and record.rate < settings.low_rate_factor * highest_frequency / (2 * np.pi)


def clipping(
    record: Record,
    clipped: dict[str, float] | None = None,
    highest_frequency: float | None = None,
    settings: RecordSettings = RECORDS,
) -> list[QualityWarning]:
    """A clipping warning for each channel of ``record`` held at its extreme (``clipped``: _clipped's, found here
    where not given; judged at clip_step's samples for ``highest_frequency`` [rad/s])."""
    clipped = _clipped(record, highest_frequency, settings) if clipped is None else clipped
    units = {c.name: c.unit for c in record.channels}
    return [
        QualityWarning("clipping", name, f"held at {level:.4g} {units[name]} on several samples: clipped")
        for name, level in clipped.items()
    ]


def _clipped(record: Record, highest_frequency: float | None, settings: RecordSettings) -> dict[str, float]:
    """The clipped channels of ``record`` and their levels (clipped_level, judged at clip_step's samples for
    ``highest_frequency`` [rad/s])."""
    step = clip_step(record, highest_frequency, settings)
    levels = {c.name: clipped_level(record.data[:, j], settings, step) for j, c in enumerate(record.channels)}
    return {name: level for name, level in levels.items() if level is not None}


def _impacts(record: Record, settings: RecordSettings, clipped: dict[str, float]) -> NDArray[np.intp]:
    """impact_bursts on the channels not ``clipped`` (_clipped: a clipped channel's flat tops are bursts of their
    own)."""
    unclipped = [n for n in record.names if n not in clipped]
    return impact_bursts(record.select(unclipped), settings) if unclipped else np.array([], dtype=np.intp)


def _in_segment(onset: float, start: float, settings: RecordSettings) -> bool:
    """Whether an impact beginning at ``onset`` [s] lies in a segment from ``start`` [s] (within the spread of its
    onset, settings.double_hit_spacing)."""
    return onset >= start - settings.double_hit_spacing


@dataclass(frozen=True)
class FreeDecay:
    """Where a record's free decay lies (free_decay): from ``start`` [s] to ``end`` [s] (None: the record's end),
    and the notes that say so where the record, not the caller or the default, decided."""

    start: float
    end: float | None = None
    notes: tuple[str, ...] = ()
    hits: tuple[float, ...] = ()
    """[s] The onsets of the record's hits where it shows several (each more than RecordSettings.hit_spacing after
    the one before; one hit: ()): a free decay after each (another start) measures the same modes."""


def free_decay(
    record: Record, highest_frequency: float, start: float | None = None, settings: RecordSettings = RECORDS
) -> FreeDecay:
    """The free decay of a record without a force channel, from the impacts its responses show (impact_bursts, on
    the channels not clipped). Its start: ``start`` where given; else DEFAULT_START, or AFTER_IMPACT after the
    first impact where that begins too late for DEFAULT_START (where hammer_test_quality would find it in the
    analysed segment: a pre-trigger). Its end: the next impact after the start that is a hit of its own (more
    than settings.hit_spacing after the one before it; closer, a double hit, which the check names), where the
    record holds one: the decay after it is the sum of two. No impact is sought where the record is sampled too
    slowly for the bursts to stand out (below settings.low_rate_factor times ``highest_frequency`` [rad/s] /
    (2 pi))."""
    if _too_slow_for_bursts(record, highest_frequency, settings):
        return FreeDecay(DEFAULT_START if start is None else start)
    onsets = [float(t) for t in record.time[_impacts(record, settings, _clipped(record, highest_frequency, settings))]]
    notes = []
    if start is None:
        start = DEFAULT_START
        if onsets and _in_segment(onsets[0], DEFAULT_START, settings):
            start = onsets[0] + AFTER_IMPACT
            first = float(record.time[0])
            into = f" ({onsets[0] - first:.3g} s into the record)" if first != 0 else ""
            notes.append(
                f"free decay from t = {start:.4g} s, {AFTER_IMPACT:g} s after the impact the record shows at t = "
                f"{onsets[0]:.4g} s{into}; a start given chooses another"
            )
    hits: list[float] = []
    for t in onsets:
        if not hits or t - hits[-1] > settings.hit_spacing:  # closer: a bounce of the hit before
            hits.append(t)
    several = tuple(hits) if len(hits) > 1 else ()
    later = [t for t in hits[1:] if t > start]  # the first hit ends no decay (a start before it: the check warns)
    if not later:
        return FreeDecay(start, None, tuple(notes), several)
    return FreeDecay(start, later[0], (*notes, next_hit_note(later[0], len(hits))), several)


def next_hit_note(end: float, hits: int) -> str:
    """free_decay's note on a decay that ends at ``end`` [s], where the record shows another of its ``hits``."""
    return (
        f"free decay until t = {end:.4g} s, where the record shows another hit ({counted(hits, 'hit')} in all, the "
        "others' decays not used: a force channel would average them; without a start, process, identify-record "
        "and a campaign use each)"
    )


def hit_summary(record: Record, name: str, settings: RecordSettings = RECORDS) -> str:
    """The hits on the force channel ``name`` [N] (frf.hit_times: a double hit belongs to its hit): when each
    begins, its peak, how long it stays above 5 % of the peak, and its impulse (the integral of the force over
    that time) [N s]; for several hits the range of each over them."""
    from mountid.measurement.frf import hit_times, is_continuous

    f = record.channel(name)
    if not float(np.max(np.abs(f))) > 0:
        return f"{name}: no hit recorded"
    if is_continuous(record, name, settings):
        rms, peak = float(np.sqrt(np.mean(f**2))), float(np.max(np.abs(f)))
        return f"continuous excitation on {name}: {rms:.4g} N RMS, peak {peak:.4g} N"
    dt = 1 / record.rate
    starts = np.searchsorted(record.time, hit_times(record, name, settings))
    bounds = [0, *(max(0, int(k) - round(settings.pretrigger * record.rate)) for k in starts[1:]), len(f)]
    at, peaks, lengths, impulses = [], [], [], []
    for lo, hi in itertools.pairwise(bounds):
        hit = f[lo:hi]
        top = float(np.max(np.abs(hit)))
        above = np.abs(hit) > 0.05 * top
        first = int(np.argmax(above))
        end = first + (int(np.argmin(above[first:])) if not np.all(above[first:]) else len(hit) - first)
        at.append(float(record.time[lo + first]))
        peaks.append(top)
        lengths.append((end - first) * dt * 1e3)
        impulses.append(float(np.sum(hit[first:end]) * dt))
    if len(at) == 1:
        return (
            f"hit on {name} at t = {at[0]:.4f} s: peak {peaks[0]:.4g} N, "
            f"{lengths[0]:.1f} ms above 5 % of it, impulse {impulses[0]:.4g} N s"
        )
    return (
        f"{len(at)} hits on {name} at t = {', '.join(f'{t:.4f}' for t in at)} s: peak {_span(peaks, '.4g')} N, "
        f"{_span(lengths, '.1f')} ms above 5 % of it, impulse {_span(impulses, '.4g')} N s"
    )


def _span(values: list[float], spec: str) -> str:
    """The range of ``values`` as the notes print it: one value where both ends print alike, else "a to b"."""
    low, high = format(min(values), spec), format(max(values), spec)
    return low if low == high else f"{low} to {high}"


def same_place(record: Record) -> list[QualityWarning]:
    """A warning (none or one) naming the channels of ``record`` placed two or more at one point [m] along one
    direction (within 1e-9): one acquisition measures that motion twice (a spare sensor), but two hits' records read
    as one (the runs of a file the reader did not part: uff._runs) give each channel a twin of another hit, and their
    mode shapes mix the hits."""
    placed: dict[tuple[float, ...], list[str]] = {}
    for c in record.channels:
        where = (*c.point, *c.direction)
        if np.all(np.isfinite(where)):
            placed.setdefault(tuple(round(v, 9) + 0.0 for v in where), []).append(c.name)
    twins = [names for names in placed.values() if len(names) > 1]
    if not twins:
        return []
    return [
        QualityWarning(
            "same_place",
            ", ".join(n for names in twins for n in names),
            "; ".join(" and ".join(names) for names in twins)
            + " measure at one point along one direction each: a spare sensor, or the records of different hits "
            "read as one (the runs of a file taken as one record: export each run to a file of its own), whose mode "
            "shapes mix the hits",
        )
    ]


def force_quality(
    record: Record, name: str, start: float | None, settings: RecordSettings = RECORDS
) -> list[QualityWarning]:
    """Checks of a hammer's force channel ``name`` (a shaker's: clipping only): clipping (a flat top), a second hit
    (a pulse after the first one has ended and within settings.hit_spacing of its start, above
    settings.double_hit_height of its peak, however small the response shows it; later pulses are separate hits,
    which a frequency response averages over), and a hit inside the analysed free decay (after ``start`` [s]; None:
    no free decay is analysed, the frequency responses start at the hit)."""
    from mountid.measurement.frf import is_continuous

    f = np.abs(record.channel(name))
    out = []
    top = float(f.max())
    if top <= 0:
        shakers = [other for other in record.forces if other != name and is_continuous(record, other, settings)]
        if shakers:  # beside a shaker: a second shaker's force not recorded, or a spare channel
            return [
                QualityWarning(
                    "no_hit",
                    name,
                    f"the force channel is zero throughout beside the continuous excitation on {shakers[0]}: where a "
                    f"second shaker ran, its force was not recorded (a transducer not connected?), and its response "
                    f"counts as noise in {shakers[0]}'s frequency responses; where none did, --ignore {name}",
                )
            ]
        return [QualityWarning("no_hit", name, "the force channel is zero throughout: no impact recorded")]
    if clipped_level(record.channel(name), settings) is not None:
        out.append(QualityWarning("clipping", name, f"force held at {top:g} N on several samples: clipped"))
    if is_continuous(record, name, settings):  # a shaker's: no hit to check
        return out
    above = f > 0.05 * top
    first = int(np.argmax(above))
    end = first + int(np.argmin(above[first:])) if not np.all(above[first:]) else len(f)
    window = first + int(round(settings.hit_spacing * record.rate))
    second = float(f[end:window].max()) if end < min(window, len(f)) else 0.0
    if second > settings.double_hit_height * top:
        # both hits timed where they pass half their own peak (the same phase of a pulse)
        onset = int(np.argmax(f > 0.5 * top))
        k = end + int(np.argmax(f[end:] > 0.5 * second))
        gap = float(record.time[k] - record.time[onset])
        size = second / top
        out.append(
            QualityWarning(
                "double_hit", name, f"a second hit {gap * 1e3:.1f} ms after the first ({size:.0%} of its peak)"
            )
        )
    if start is not None and record.time[end - 1] >= start:
        out.append(
            QualityWarning(
                "impact_in_segment",
                name,
                f"the hit lasts until t = {record.time[end - 1]:.3f} s, inside the analysed segment (from {start:g} s)",
            )
        )
    return out


def hammer_test_quality(
    record: Record,
    lowest_frequency: float,
    start: float = 0.0,
    highest_frequency: float | None = None,
    settings: RecordSettings = RECORDS,
    impacts: bool = True,
) -> list[QualityWarning]:
    """Checks of an impact record before it is trusted (thresholds: ``settings``).

    - clipping: a channel's extreme value held on ``clip_samples`` or more samples (a flat top: the sensor or the
      acquisition saturated);
    - double_hit: the high-frequency burst of an impact (energy of the first difference, which the slow
      modes barely carry) recurs after the first one, above ``double_hit_height`` of its peak, later than
      ``double_hit_spacing`` and within ``hit_spacing`` (later, a hit of its own: free_decay ends there);
    - impact_in_segment: the impact burst lies after ``start``: the analysed "free decay" still holds the
      forced response (pass a start after the hit);
    - too_short: fewer than ``min_periods`` periods of ``lowest_frequency`` [rad/s] after ``start`` [s] (the pencil
      needs a few periods of every mode; the paper's 4 s record holds 11 of its 17.71 rad/s);
    - low_rate: sampled below ``low_rate_factor`` x ``highest_frequency`` [rad/s] / (2 pi), when given (the
      burst-based checks above are then not made: the modes' own oscillation fills the first difference).

    ``impacts`` False leaves out the checks that seek impacts in the responses (double_hit, impact_in_segment):
    a force channel shows the hits themselves (force_quality)."""
    clipped = _clipped(record, highest_frequency, settings)
    out = clipping(record, clipped)
    if _too_slow_for_bursts(record, highest_frequency, settings):
        out.append(
            QualityWarning(
                "low_rate",
                "all",
                f"{record.rate:g} Hz is below {settings.low_rate_factor:g} x the highest mode of interest "
                f"({highest_frequency / (2 * np.pi):.3g} Hz)",
            )
        )
    elif impacts:
        # the impact bursts (the first difference, which the slow modes barely carry) stand out only where the
        # modes are well sampled
        peaks = _impacts(record, settings, clipped)
        if len(peaks) and _in_segment(float(record.time[peaks[0]]), start, settings):
            out.append(
                QualityWarning(
                    "impact_in_segment",
                    "all",
                    f"the impact at t = {record.time[peaks[0]]:.3f} s lies in the analysed segment (from "
                    + (f"{start:g} s)" if start > record.time[0] else "the record's start)"),
                )
            )
        # a second impact within settings.hit_spacing is part of the hit (a bounce); a later one is a hit of its own,
        # where the free decay ends (free_decay)
        bounces = [k for k in peaks[1:] if (k - peaks[0]) / record.rate <= settings.hit_spacing]
        if bounces:
            gap = (bounces[0] - peaks[0]) / record.rate
            out.append(QualityWarning("double_hit", "all", f"a second impact {gap * 1e3:.1f} ms after the first"))
    length = record.time[-1] - max(start, record.time[0])
    periods = length * lowest_frequency / (2 * np.pi)
    if periods < settings.min_periods:
        out.append(
            QualityWarning(
                "too_short",
                "all",
                f"{length:g} s holds {periods:.1f} periods of {lowest_frequency:g} rad/s (< {settings.min_periods:g})",
            )
        )
    return out
