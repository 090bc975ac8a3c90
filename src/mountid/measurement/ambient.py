"""Output-only records: the responses to an excitation nobody measured (ambient ground vibration, a running
machine's process), read through their correlation functions (the natural excitation technique, NExT).

Under a random excitation whose correlation time is short against the modes' periods, the correlation of every
response y_j with one reference response y_r,

    R_jr(tau) = E[y_j(t + tau) y_r(t)],   tau > 0,

is a sum of the modes' free decays: the machine's poles, and per mode the shape over the channels j scaled by one
factor the reference sets (a hit at the reference point gives the same picture). The records chain fits it as a
free decay. A reference near a node of a mode does not see that mode: every response channel serves as a reference
in turn, and each mode is taken from the reference in which it shows most strongly
(identification.output_only).

The record is cut into SEGMENTS segments; each gives its correlation functions with the unbiased estimator
(divided by the products each lag has, no window: a window's taper would add to every mode's damping), and the
mean over the segments is fitted. Their scatter gives the uncertainty: the poles and amplitudes are fitted again
with each segment left out in turn (the jackknife), which holds what the least-squares bound of one fit does not
(the errors of correlation functions are correlated from lag to lag).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from mountid.errors import InputError
from mountid.measurement import modal
from mountid.measurement.records import Record

SEGMENTS = 8
"""Segments an output-only record is cut into: the correlation functions are their mean, and leaving each out in
turn gives the uncertainty (jackknife)."""

STATIONARY = 2.0
"""A record without a force channel is output-only (is_output_only) where the RMS of its SEGMENTS stretches stays
within this factor (the largest over the smallest, the median over the channels): a hit's free decay falls by
orders of magnitude, a hit in the middle of a quiet record rises as much."""

TONAL = 0.5
"""A steady record whose strongest spectral line (with TONE_LINES on either side) carries more than this share of
its variance (the median over the channels) is a tone, a machine running under its unbalance, not the broadband
response output-only data are: read as a free decay, whose check names the steady oscillation."""

TONE_LINES = 3
"""Lines of the record's spectrum on either side of its strongest that a tone's share takes in (TONAL)."""

LAG_SHARE = 0.25
"""The longest lag the correlation functions are fitted to, as a share of a segment: the lags are cut where their
envelope has fallen to the noise of the estimate (lag_length), at most here."""

FLOOR = 0.02
"""The correlation functions are fitted out to where their envelope (all channels with the reference) last
exceeds this share of its value at zero lag, or twice the envelope's level over the longest lags (the estimate's
noise), whichever is higher (lag_length)."""

FOUND_IN = 0.75
"""A pole is kept where the fits with one segment left out find it again (within MATCH) in at least this share
of them: one that comes and goes with a segment is the noise of the estimate, not a mode."""

MATCH = 0.03
"""A pole of a fit with one segment left out is the full fit's pole where |p - p0| / |p0| is below this, the
nearest."""

DAMPED = 2.0
"""A pole of an output-only record is a mode where its damping ratio exceeds this many of its standard deviations
(or it is a steady oscillation, modal.is_tone): the estimate's noise in the correlation functions gives poles of
damping ratios about zero (kid300, 1200 s, one in 20 records: 69.8 rad/s at 0.006 +- 0.010, labelled theta). A
running machine's tone comes out so too (0.0014 +- 0.015) and is named by its line (LINE)."""

START = 0.05
"""[s] The fit of the correlation functions starts at this lag: past lag zero, where the sensors' noise adds its
variance, and the anti-alias filter's correlation of it."""


LINE = 30.0
"""A pole of an output-only record left out for its damping ratio (within DAMPED of its scatter of zero) is a
steady oscillation (a running machine, mains hum) where the record's spectrum has a line within TONE_BAND of it that
stands this many times above the median of the LINE_BINS lines on either side (Spectrum.line): a mode's random
response spreads over its bandwidth, 2 zeta omega (kid300's modes in 1200 s records: their highest lines 4-14 times
the median around them), a tone's power sits in one line and grows with the record's length (an unbalance of 0.5 kg
x 0.02 m at 50 rad/s beside kid300's ambient forces: 90-98; of 0.2 kg: 14-17, not named). A pole kept is a mode
however sharp its line: a lightly damped mode's stands out as well."""

TONE_BAND = 0.02
"""The share of a pole's frequency within which Spectrum.line looks for the record's line."""

LINE_BINS = 100
"""Lines of the record's spectrum on either side of a line that its level is compared with (LINE)."""


@dataclass(frozen=True)
class Spectrum:
    """The Hann-windowed power spectrum of a record's responses over the whole record, each channel's in units of
    its median and summed over the channels: where a tone's line stands out of the broadband response."""

    omega: NDArray[np.float64]
    """[rad/s] The lines."""
    level: NDArray[np.float64]

    @classmethod
    def of(cls, record: Record) -> Spectrum:
        data = record.data - record.data.mean(axis=0)
        power = np.abs(np.fft.rfft(data * np.hanning(len(data))[:, None], axis=0)) ** 2
        level = np.sum(power / np.maximum(np.median(power, axis=0), 1e-300), axis=1)
        return cls(2 * np.pi * np.fft.rfftfreq(len(data), float(record.time[1] - record.time[0])), level)

    def line(self, frequency: float) -> tuple[float, float]:
        """The strongest line within TONE_BAND of ``frequency`` [rad/s] and its level over the median of the
        LINE_BINS lines on either side: (line [rad/s], ratio); (frequency, 0) where no line lies there."""
        near = np.flatnonzero(np.abs(self.omega - frequency) <= TONE_BAND * frequency)
        if len(near) == 0:
            return frequency, 0.0
        k = int(near[np.argmax(self.level[near])])
        around = self.level[max(0, k - LINE_BINS) : k + LINE_BINS + 1]
        return float(self.omega[k]), float(self.level[k] / max(float(np.median(around)), 1e-300))


def tones(spectrum: Spectrum, poles: list[modal.Pole]) -> list[tuple[modal.Pole, float, float]]:
    """The ``poles`` that are steady oscillations (LINE), each with the record's line [rad/s] and its ratio."""
    out = []
    for pole in poles:
        line, ratio = spectrum.line(pole.frequency)
        if ratio > LINE:
            out.append((pole, line, ratio))
    return out


def shortest_lags(lowest: float, min_periods: float) -> float:
    """[s] The lags the correlation functions need at least: ``min_periods`` periods of the lowest mode (``lowest``
    [rad/s]) from START, as a free decay needs them (RecordSettings.min_periods)."""
    return min_periods * 2 * math.pi / lowest + START


def shortest_record(lowest: float, min_periods: float, segments: int = SEGMENTS, rate: float | None = None) -> float:
    """[s] The shortest output-only record the records chain reads: ``segments`` segments, each LAG_SHARE of it
    the shortest_lags; sampled at ``rate`` [Hz], to the sample (lags_reaching: up to two samples more per segment's
    share)."""
    if rate is None:
        return segments * shortest_lags(lowest, min_periods) / LAG_SHARE
    return _record_reaching(shortest_lags(lowest, min_periods), rate, segments)


def _record_reaching(lag: float, rate: float, segments: int) -> float:
    """[s] The shortest record at ``rate`` [Hz] whose ``segments`` segments give correlation functions to ``lag`` [s]
    (lags_reaching of them, LAG_SHARE of a segment)."""
    return segments * lags_reaching(lag, rate) / (rate * LAG_SHARE)


def lags_reaching(lag: float, rate: float) -> int:
    """How many lags (from 0, at ``rate`` [Hz]) reach ``lag`` [s]: to the first at it or beyond."""
    return math.ceil(lag * rate) + 1


@dataclass(frozen=True)
class Correlations:
    """The correlation functions of a record's responses with one of them (the reference): per segment, and their
    mean as a record (time: the lag [s]; channels: the responses, in [channel unit x reference unit])."""

    segments: NDArray[np.float64]
    """(SEGMENTS, lags, channels): each segment's unbiased correlation functions."""
    mean: Record
    segment_length: float
    """[s] The length of each segment."""

    def leaving_out(self, k: int) -> Record:
        """The mean correlation functions of every segment but the k-th."""
        keep = np.arange(len(self.segments)) != k
        return Record(self.mean.time, self.segments[keep].mean(axis=0), self.mean.channels)


def is_output_only(record: Record, segments: int = SEGMENTS) -> bool:
    """Whether ``record`` (no force channel, not impulse responses) is a steady motion: the RMS of its ``segments``
    stretches within STATIONARY of each other (the median ratio over the response channels), not a tone (TONAL),
    and no impact in it (modal.impact_bursts: a roving hammer's hits, a few seconds apart all through the record,
    are as steady)."""
    if record.forces or record.impulse is not None or not record.responses:
        return False
    responses = record.select(record.responses)
    data = responses.data
    n = len(data) // segments
    if n < 2:
        return False
    rms = np.sqrt(np.mean((data[: n * segments].reshape(segments, n, -1)) ** 2, axis=1))  # (segments, channels)
    ratio = rms.max(axis=0) / np.maximum(rms.min(axis=0), 1e-300)
    if not np.median(ratio) < STATIONARY:
        return False
    spectra = np.abs(np.fft.rfft(data - data.mean(axis=0), axis=0)) ** 2
    peak = np.argmax(spectra, axis=0)
    near = np.abs(np.arange(len(spectra))[:, None] - peak) <= TONE_LINES
    share = np.sum(spectra * near, axis=0) / np.maximum(np.sum(spectra, axis=0), 1e-300)
    if np.median(share) > TONAL:
        return False  # a running machine's tone and little else: read as a free decay, which names it
    return len(modal.impact_bursts(responses)) == 0


def correlations(record: Record, reference: str, min_lag: float = 0.0, segments: int = SEGMENTS) -> Correlations:
    """The correlation functions of the responses of ``record`` with ``reference`` (one of them), per segment and
    their mean, out to lag_length or ``min_lag`` [s] where that is longer (a record whose segments are too short
    for it is an error that says how long to record)."""
    if reference not in record.names:
        raise InputError("reference", f"{reference!r} is not a channel of the record ({', '.join(record.names)})")
    data = record.data - record.data.mean(axis=0)
    n = len(data) // segments
    rate = 1.0 / float(record.time[1] - record.time[0])
    if n < 64:
        raise InputError("record", f"{len(data)} samples: too short for {segments} segments of output-only data")
    r = record.names.index(reference)
    size = 1 << int(math.ceil(math.log2(2 * n)))
    longest = max(8, int(LAG_SHARE * n))
    reaching = lags_reaching(min_lag, rate)
    if longest < reaching:
        needed = _record_reaching(min_lag, rate, segments)
        raise InputError(
            "record",
            f"too short for output-only data: {len(data) / rate:.4g} s in {segments} segments gives correlation "
            f"functions to {(longest - 1) / rate:.3g} s, and the lowest mode needs {min_lag:.3g} s of them: record "
            f"{needed:.4g} s or more",
        )
    products = (n - np.arange(longest))[:, None]
    each = np.empty((segments, longest, data.shape[1]))
    for k in range(segments):
        spectra = np.fft.rfft(data[k * n : (k + 1) * n], size, axis=0)
        each[k] = np.fft.irfft(spectra * np.conj(spectra[:, [r]]), size, axis=0)[:longest] / products
    lags = max(lag_length(each.mean(axis=0)), reaching)  # at most longest: reaching is, lag_length's too
    each = each[:, :lags]
    mean = Record(np.arange(lags) / rate, each.mean(axis=0), record.channels)
    return Correlations(each, mean, n / rate)


def lag_length(mean: NDArray) -> int:
    """Lags of the correlation functions ``mean`` (lags, channels) worth fitting: to the first lag from which their
    envelope (the root sum of squares over the channels), as an RMS over the next twentieth of the lags, stays below
    FLOOR of its value at zero lag or twice its RMS over the last quarter of the lags (the estimate's noise),
    whichever is higher; at least a tenth of them."""
    envelope = np.sqrt(np.sum(mean**2, axis=1))
    n = len(envelope)
    noise = float(np.sqrt(np.mean(envelope[-max(1, n // 4) :] ** 2)))
    level = max(FLOOR * float(envelope[0]), 2.0 * noise)
    width = max(1, n // 20)
    ahead = np.sqrt(np.convolve(envelope**2, np.ones(width) / width, mode="valid"))  # [k]: over k .. k + width - 1
    above = np.flatnonzero(ahead > level)
    cut = int(above[-1]) + width if len(above) else 0  # past the last window above the level
    return min(n, max(cut, n // 10, 8))


def with_scatter(
    correlations: Correlations, start: float, max_frequency: float, n_modes: int, poles: list[modal.Pole]
) -> tuple[list[modal.Pole], list[modal.Pole]]:
    """The ``poles`` fitted on the mean correlation functions with their standard deviations from the fits that
    leave one segment out in turn (the jackknife: sqrt((K - 1) / K sum (x_k - mean)^2) of the frequency, the
    damping ratio, each channel's amplitude, _jackknife_std), where at least FOUND_IN of those fits find the pole
    again and its damping ratio is DAMPED standard deviations above zero (or it is a steady oscillation); returns
    (kept, dropped). Each fit leaving a segment out refines the full fit's poles on its mean (modal.poles_from,
    clipped: a pole the data hardly determine moves 5 % at most per step and does not stop the others): the same
    estimator, started where the full one ended. Running the pencil again instead found a strong mode in six of
    eight (kid300 seed 0, x with A_x as the reference: the pencil's order and size choices come and go with a
    segment), split it in two or left it out, and the scatter of the pencil's choices inflated the deviations (error
    over them RMS 0.79 and 0.90) and dropped modes as noise (z or psi in 4 of 24 records); it took 5.1 s where this
    takes 2.1 (eight channels at 200 Hz, the whole identification)."""
    k = len(correlations.segments)
    seeds = np.array([p.p for p in poles], dtype=complex)
    again = []
    for i in range(k):
        with np.errstate(all="ignore"):
            refined = modal.poles_from(correlations.leaving_out(i), start, max_frequency, seeds, clipped=True)
        # a pole the refinement left where it started was not fitted again (it gave up at once)
        again.append([p for p in refined if np.min(np.abs(p.p - seeds)) > 1e-12 * abs(p.p)])
    kept, dropped = [], []
    for pole in poles:
        found = [_nearest(pole, run) for run in again]
        found = [p for p in found if p is not None]
        if len(found) < FOUND_IN * k:
            dropped.append(pole)
            continue
        scattered = modal.Pole(
            pole.frequency,
            pole.damping_ratio,
            pole.shape,
            float(_jackknife_std(np.array([p.frequency for p in found]), k)),
            float(_jackknife_std(np.array([p.damping_ratio for p in found]), k)),
            _jackknife_std(np.array([p.shape for p in found]), k),
        )
        tone = bool(modal.is_tone(np.array([pole.p]))[0])
        (kept if tone or pole.damping_ratio > DAMPED * scattered.damping_std else dropped).append(scattered)
    return kept, dropped


def _jackknife_std(values: NDArray, k: int) -> NDArray[np.float64]:
    """The jackknife's standard deviation sqrt((k - 1) / k sum (x_i - mean)^2) over the first axis of ``values``,
    the fits of k that leave one segment out (where some did not find the pole, their sum scaled up to k), widened
    by sqrt(nu / (nu - 2)) for its nu = k - 1 degrees of freedom: an error over it is Student's t with nu degrees of
    freedom, of variance nu / (nu - 2) (7 / 5 for eight segments), where the diagnosis, which takes a measurement's
    deviation for a Gaussian's, expects 1 (kid300, 24 records: error over the unwidened deviation RMS 1.07 in
    frequency, 1.18 in damping ratio, as t_7 has it; 0.90 and 1.00 widened)."""
    squares = np.sum(np.abs(values - values.mean(axis=0)) ** 2, axis=0)
    nu = k - 1
    return np.sqrt((k - 1) / k * squares * k / len(values) * nu / max(nu - 2, 1))


def _nearest(pole: modal.Pole, run: list[modal.Pole]) -> modal.Pole | None:
    """The pole of ``run`` nearest ``pole`` where within MATCH of it (relative), else None."""
    if not run:
        return None
    distance = [abs(p.p - pole.p) / abs(pole.p) for p in run]
    best = int(np.argmin(distance))
    return run[best] if distance[best] < MATCH else None
