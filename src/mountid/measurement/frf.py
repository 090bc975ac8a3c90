"""Frequency response functions of a hammer test with a force channel: H1 = S_fy / S_ff averaged over the
separate hits of a record, the ordinary coherence, and the impulse responses the modal fit runs on.

A record with a force channel holds one or more hits (the hammer's force) and the responses to them. Each hit
opens a segment: the force inside a window of RecordSettings.hit_spacing after the hit's start (a double hit
within it belongs to the hit: the measured force is divided out, so it no longer spoils the fit), the
responses until the next hit, with an exponential window where they have not died out by the segment's end
(it keeps the transform from leaking; the impulse responses have it divided out again). Over the segments k,

    H1 = sum_k conj(F_k) Y_k / sum_k |F_k|^2,   coherence = |sum_k conj(F_k) Y_k|^2 / (sum_k |F_k|^2 sum_k |Y_k|^2),

the coherence 1 for a single hit (one average tells nothing) and below 1 where noise, a nonlinearity or an
unmeasured input enter. The impulse responses are the inverse transform of H1 where the hits carry force;
they are a free decay from the instant of the hit, whatever the pulse's shape or a second hit.

A shaker's force is continuous (is_continuous): where it repeats (periodic random, a multisine: a controller
repeats one block) or comes in bursts with quiet between (burst random), continuous_h1 averages its whole periods
after the transient, or its bursts, without a window, exact on the lines it excites, and gives the impulse
responses as a bench's frequency response functions are read (records.impulse_record). A random force that does
neither gives its impulse responses by least squares over the whole record (no window either: a Hann-windowed H1
biases the damping, which the modal fit would take for the machine's).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from mountid.errors import InputError
from mountid.measurement.records import Channel, Record, impulse_record
from mountid.measurement.settings import RECORDS, RecordSettings
from mountid.nomenclature import counted


@dataclass(frozen=True)
class FrfEstimate:
    """H1 estimates of every response channel from one force channel of a record."""

    omega: NDArray[np.float64]
    """Frequencies [rad/s] of the spectral lines, (n_f,)."""
    h1: NDArray[np.complex128]
    """H1 per response channel [response unit per N], (n_f, n_responses); 0 where the hits carry no force."""
    coherence: NDArray[np.float64]
    """Ordinary coherence per response channel, (n_f, n_responses), in [0, 1]."""
    responses: tuple[Channel, ...]
    force: str
    hits: tuple[float, ...]
    """Times [s] at which the averaged hits start."""
    length: float
    """Length of each segment [s]."""
    window_decay: float
    """Decay rate [1/s] of the exponential window on the responses (0 without one): H1 is the transform of the
    windowed impulse responses, which impulse_responses() divides out."""
    rate: float
    """Sampling rate [Hz] of the impulse responses: the record's (a periodic excitation's: twice the highest line)."""
    averages: int = 0
    """Blocks H1 averages where the force is a shaker's continuous excitation (continuous_h1); 0 for hits."""
    block: str = ""
    """What a block is: "period" (a periodic excitation's), "burst" (burst random's) or "block" (a random force's:
    its averages are the record's stretches of the impulse responses' length); "" for hits."""
    averaged: str = ""
    """What H1 averages where it is not hits: "3 periods of 16 s of a periodic excitation on F (...)"."""
    together: tuple[str, ...] = ()
    """The forces whose frequency responses were estimated with this one's from the same samples (several_inputs:
    all of them, this one's included); () where it is one force's own."""

    def at(self, omega: float) -> tuple[NDArray[np.complex128], NDArray[np.float64]]:
        """H1 and coherence of every response channel at the spectral line nearest ``omega`` [rad/s]."""
        k = int(np.argmin(np.abs(self.omega - omega)))
        return self.h1[k], self.coherence[k]

    def as_impulse_record(self) -> Record:
        """A shaker's H1 (continuous_h1: its lines from 0 to the highest excited) as the impulse
        responses a bench's frequency response functions are read as (Record.impulse, records.impulse_record), with
        their coherence where several blocks were averaged: what the records chain fits."""
        spacing = float(self.omega[1]) / (2 * np.pi)
        named = tuple((c.name, self.coherence[:, j]) for j, c in enumerate(self.responses))
        return impulse_record(self.h1, spacing, self.responses, named if self.averages > 1 else (), self.averaged)

    def impulse_responses(self) -> Record:
        """The impulse responses [response unit per N s] of the responses from the start of the segments
        (RecordSettings.pretrigger before the hits), as a record of the response channels: the inverse
        transform of H1 with the exponential window divided out again (for a hit much shorter than the window's
        time constant the window multiplies the impulse response; dividing it out leaves the measurement noise
        as level as it was recorded, so a fit weighs every sample alike)."""
        n = int(round(self.length * self.rate))
        t = np.arange(n) / self.rate
        h = np.fft.irfft(self.h1, n=n, axis=0) * self.rate * np.exp(self.window_decay * t)[:, None]
        return Record(t, h, self.responses)


def hit_times(record: Record, force: str, settings: RecordSettings = RECORDS) -> NDArray[np.float64]:
    """Times [s] at which the separate hits on the force channel ``force`` start: where the force first
    exceeds settings.double_hit_height of the largest peak, impacts within settings.hit_spacing of a hit
    belonging to it (a double hit)."""
    f = np.abs(record.channel(force))
    top = float(f.max()) if len(f) else 0.0
    if not top > 0:
        raise InputError(force, "the force channel is zero throughout: no impact recorded")
    above = np.flatnonzero(f > settings.double_hit_height * top)
    starts = [int(above[0])]
    for k in above[1:]:
        if record.time[k] - record.time[starts[-1]] > settings.hit_spacing:
            starts.append(int(k))
    return record.time[np.array(starts)]


def h1(record: Record, force: str, settings: RecordSettings = RECORDS) -> FrfEstimate:
    """H1 and coherence of every response channel of ``record`` (SI units) from its force channel ``force``,
    averaged over the hits (hit_times); segments start settings.pretrigger [s] before each hit and last until
    the next (the shortest such spacing for all, the record's end after the last hit)."""
    record = record.in_si()
    times = hit_times(record, force, settings)
    rate = record.rate
    pre = int(round(settings.pretrigger * rate))
    first = [max(0, int(round((t - record.time[0]) * rate)) - pre) for t in times]
    ends = [*first[1:], len(record.time)]
    n = min(e - s for s, e in zip(first, ends, strict=True))
    if n < 16:
        raise InputError("record", f"too short after the hit at {times[-1]:.3g} s for a frequency response")
    window = min(n, int(round(settings.hit_spacing * rate)))
    responses = record.select(record.responses)
    if not responses.channels:
        raise InputError("channels", "no response channel (acceleration, velocity or displacement): only force")
    f_all = record.channel(force)
    segments = [(f_all[s : s + n].copy(), responses.data[s : s + n]) for s in first]
    decay = _window_decay([y for _, y in segments], n / rate)
    t = np.arange(n) / rate
    expo = np.exp(-decay * t)[:, None]
    s_ff = np.zeros(n // 2 + 1)
    s_fy = np.zeros((n // 2 + 1, len(responses.channels)), dtype=complex)
    s_yy = np.zeros((n // 2 + 1, len(responses.channels)))
    for f, y in segments:
        f[window:] = 0.0  # the force window: the hit (and its double) only, no noise after it
        spec_f = np.fft.rfft(f)
        spec_y = np.fft.rfft(y * expo, axis=0)
        s_ff += np.abs(spec_f) ** 2
        s_fy += np.conj(spec_f)[:, None] * spec_y
        s_yy += np.abs(spec_y) ** 2
    carried = s_ff > settings.force_floor * s_ff.max()  # lines where the hits carry force
    h = np.where(carried[:, None], s_fy / np.where(carried, s_ff, 1.0)[:, None], 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        coherence = np.where(carried[:, None], np.abs(s_fy) ** 2 / (s_ff[:, None] * s_yy), 0.0)
    coherence = np.clip(np.nan_to_num(coherence), 0.0, 1.0)
    omega = 2 * np.pi * np.fft.rfftfreq(n, 1 / rate)
    return FrfEstimate(omega, h, coherence, responses.channels, force, tuple(map(float, times)), n / rate, decay, rate)


def _window_decay(responses: list[NDArray], length: float) -> float:
    """Decay rate [1/s] of an exponential window that brings the responses' level (RMS) over the last tenth of
    the segment down to 1 % of their level over the whole segment (0 where it is below that already): the
    segment is then a free decay that has died out, and the transform does not leak."""
    ratio = max(float(np.max(_tail_level(y))) for y in responses)
    return math.log(ratio / 0.01) / length if ratio > 0.01 else 0.0


def _tail_level(y: NDArray) -> NDArray[np.float64]:
    """Per channel of ``y`` (samples, channels), the RMS over its last tenth over the RMS over all of it: near 0
    where a response has died out, near 1 where it goes on (_window_decay, a burst's block)."""
    tail = y[-max(1, len(y) // 10) :]
    return np.sqrt(np.mean(tail**2, axis=0)) / np.maximum(np.sqrt(np.mean(y**2, axis=0)), 1e-300)


def of_record(record: Record, settings: RecordSettings = RECORDS) -> FrfEstimate:
    """The H1 frequency responses of a record from its (first) force channel, as the records chain estimates them:
    a shaker's (is_continuous: continuous_h1) or a hammer's hits (h1). An InputError naming the record where it
    holds frequency response functions already or no force channel."""
    if record.impulse is not None:
        raise InputError("record", "holds frequency response functions already (a bench's): no force to estimate from")
    record = record.in_si()
    if not record.forces:
        raise InputError("record", "has no force channel: frequency responses need the measured force")
    force = record.forces[0]
    if is_continuous(record, force, settings):
        return continuous_h1(record, force, settings)
    return h1(record, force, settings)


def of_inputs(record: Record, settings: RecordSettings = RECORDS) -> tuple[FrfEstimate, ...]:
    """The frequency responses of every input of a record: of each force of several shakers at once (at_once:
    several_inputs), else of_record's of its first force."""
    forces = at_once(record, settings)
    return several_inputs(record, forces, settings) if forces else (of_record(record, settings),)


def at_once(record: Record, settings: RecordSettings = RECORDS) -> tuple[str, ...]:
    """The force channels of a test of several shakers at once (two forces or more, every one continuous:
    several_inputs reads them together); () for any other record (a roving hammer's hits on two channels: its
    runs)."""
    if record.impulse is not None or len(record.forces) < 2:
        return ()
    return record.forces if all(is_continuous(record, name, settings) for name in record.forces) else ()


def is_continuous(record: Record, force: str, settings: RecordSettings = RECORDS) -> bool:
    """Whether the force channel ``force`` carries a continuous excitation (a shaker's) rather than hits: above 5 %
    of its peak on more than settings.continuous_force of its samples, both from its median (a hammer channel's
    offset is no excitation)."""
    x = record.channel(force)
    f = np.abs(x - np.median(x)) if len(x) else x
    top = float(f.max()) if len(f) else 0.0
    return top > 0 and float(np.mean(f > 0.05 * top)) > settings.continuous_force


def continuous_h1(record: Record, force: str, settings: RecordSettings = RECORDS) -> FrfEstimate:
    """The frequency responses of a shaker's continuous excitation on ``force``, the record in SI units, on the lines
    from 0 to the highest the force excites (FrfEstimate.rate twice that line: the impulse responses' rate;
    as_impulse_record for the fit), averaged over blocks that need no window (_block_h1):

    - a periodic excitation (periodic random, a multisine: a controller repeats one block): the period is the first
      lag at which the force correlates with itself beyond settings.periodic_correlation (_period); the periods
      before the response repeats (the transient from rest: at least the first, _settled) are left out, every whole
      period after them averaged (a periodic signal over whole periods has no leakage);
    - burst random (the force on for part of each block, then quiet while the response dies out): each burst from
      its start to the next one's (_bursts), the response died out by then (below settings.burst_tail of its level).

    - random (neither): the impulse responses over 1/settings.random_blocks of the record by least squares over all
      of it (_random), the lines the force excites of their transform.

    An InputError naming the force channel where it holds too few blocks, or the response has not settled or died
    out."""
    record = record.in_si()
    f = record.channel(force)
    responses = record.select(record.responses)
    if not responses.channels:
        raise InputError("channels", "no response channel (acceleration, velocity or displacement): only force")
    period = _period(f, settings)
    if period is not None:
        return _periodic(f, responses, force, period, settings)
    starts = _bursts(f, record.rate, settings)
    if len(starts) >= 3:
        return _burst(f, responses, force, starts, settings)
    if len(starts) == 2:
        raise InputError(force, "burst random of 2 bursts: three or more are needed (the last may be cut short)")
    return _random(f, responses, force, settings)


def _periodic(f: NDArray, responses: Record, force: str, period: int, settings: RecordSettings) -> FrfEstimate:
    """H1 of a periodic excitation of ``period`` samples (continuous_h1)."""
    rate = responses.rate
    count = len(f) // period
    if count < 3:
        raise InputError(
            force,
            f"a periodic excitation of {period / rate:.4g} s holds {count} periods: the first (its transient) and at "
            "least two more are needed",
        )
    settled = _settled(responses.data, period, count)
    if settled is None:
        raise InputError(
            force,
            f"the response to a periodic excitation of {period / rate:.4g} s has not settled in {count} periods "
            "(each differs from the last beyond the noise): a lightly damped machine needs a longer record",
        )
    blocks = [slice(k * period, (k + 1) * period) for k in range(settled, count)]
    left = "the first" if settled == 1 else f"the first {settled}"
    averaged = (
        f"{len(blocks)} periods of {period / rate:.4g} s of a periodic excitation on {force} ({left}, its transient, "
        "left out)"
    )
    return _block_h1(f, responses, force, blocks, "period", averaged, settings)


def _burst(f: NDArray, responses: Record, force: str, starts: list[int], settings: RecordSettings) -> FrfEstimate:
    """H1 of burst random starting at the samples ``starts`` (continuous_h1): _burst_blocks."""
    blocks = _burst_blocks(responses, force, starts, len(f), settings)
    n = blocks[0].stop - blocks[0].start
    averaged = f"{len(blocks)} bursts of {n / responses.rate:.4g} s of burst random on {force}"
    return _block_h1(f, responses, force, blocks, "burst", averaged, settings)


def _burst_blocks(
    responses: Record, force: str, starts: list[int], length: int, settings: RecordSettings
) -> list[slice]:
    """The blocks of burst random starting at the samples ``starts`` of a record of ``length`` samples: from
    settings.pretrigger before each burst's start, as long as the shortest spacing, the last burst's where the record
    holds a block after it. An InputError naming ``force`` where a response has not died out by a block's end."""
    rate = responses.rate
    pre = int(round(settings.pretrigger * rate))  # a burst's first samples below the threshold go with it
    starts = [max(0, a - pre) for a in starts]
    n = min(b - a for a, b in itertools.pairwise(starts))
    blocks = [slice(a, a + n) for a in starts if a + n <= length]
    y = responses.data
    for k, block in enumerate(blocks):
        level = _tail_level(y[block])
        if float(np.max(level)) > settings.burst_tail:
            name = responses.channels[int(np.argmax(level))].name
            raise InputError(
                force,
                f"burst {k + 1} of {len(blocks)}: {name}'s response has not died out before the next burst (its last "
                f"tenth at {float(np.max(level)):.0%} of its level): leakage a window would hide; a longer quiet time "
                "after each burst",
            )
    return blocks


def _random(f: NDArray, responses: Record, force: str, settings: RecordSettings) -> FrfEstimate:
    """The frequency responses of a random excitation (continuous_h1: neither periodic nor in bursts) from its
    impulse responses h over the first settings.random_blocks' share of the record (L samples), exact for a
    measured force of any kind: with y[n] = sum_{m < L} h[m] f[n - m] (h died out by L), correlating y with the force
    but for its first and last L samples, f'[j] = f[j] for L <= j < N - L, gives

        sum_j f'[j] y[j + k] = sum_m h[m] c(k - m),   c(d) = sum_j f'[j] f[j + d],   k = 0 .. L - 1,

    whose every sample lies inside the record, and no response before L, where a record that starts while the
    shaker runs holds the decay of what the force did before (noise-free kid300: 5e-3 off, 2e-4 without it): a
    Toeplitz system (Levinson's recursion) without the bias of the correlations over the whole record, which take
    the response after the record's end for 0 and shrink h[k] by 1 - k / N (a damping too high by 1 / (omega N) as
    a ratio: 1 % of kid300's x over 128 s). No window, no repetition. The lines of h's transform that the force
    excites (its spectrum above settings.shaker_floor of its largest) are H; the coherence is 1 - S_ee / S_yy of the
    residual e (Welch, blocks of L). An InputError naming the force where h has not died out within L (a longer
    record, _died_out), or where its spectrum changes over the record (a sweep: _spectrum_change)."""
    import scipy.linalg  # here: a hammer test's records chain does not import scipy's signal processing (decimate)
    import scipy.signal

    rate, n = responses.rate, len(f)
    taps = _taps(n, force, settings)
    _not_swept(f, rate, force)
    f0 = f - f.mean()
    y0 = responses.data - responses.data.mean(axis=0)
    column, row, b = _normal_equations(f0[:, None], y0, taps)
    h = scipy.linalg.solve_toeplitz((column[:, 0, 0], row[:, 0, 0]), b[:, 0])
    _, s_ff = scipy.signal.welch(f0, rate, nperseg=taps)
    excited = s_ff > settings.shaker_floor * s_ff.max()
    lines = np.where(excited[:, None], np.fft.rfft(h, axis=0), 0.0)
    _died_out(lines, excited, responses, force, settings)
    coherence = _multiple_coherence(y0, scipy.signal.fftconvolve(f0[:, None], h, axes=0)[:n], excited, rate)
    top = len(coherence) - 1
    spacing = rate / taps
    averaged = (
        f"{n / rate:.4g} s of a random excitation on {force} (impulse responses of {taps / rate:.4g} s by least "
        "squares over the record)"
    )
    return FrfEstimate(
        2 * np.pi * spacing * np.arange(top + 1),
        lines[: top + 1],
        coherence,
        responses.channels,
        force,
        (),
        1 / spacing,
        0.0,
        2 * top * spacing,
        settings.random_blocks,
        "block",
        averaged,
    )


def _not_swept(f: NDArray, rate: float, force: str) -> None:
    """An InputError naming ``force`` where its spectrum changes over the record (_spectrum_change beyond SWEPT)."""
    changed = _spectrum_change(f, rate)
    if changed > SWEPT:
        raise InputError(
            force,
            f"a continuous excitation whose spectrum changes over the record (a sweep or a stepped sine: the spectra "
            f"of its quarters differ in {changed:.0%} of their power): mountid reads hits, a periodic excitation "
            "(periodic random, a multisine), burst random and random",
        )


def _random_inputs(
    f: NDArray, responses: Record, forces: tuple[str, ...], settings: RecordSettings
) -> tuple[FrfEstimate, ...]:
    """_random of several forces at once, ``f`` (samples, forces): with f'_a the force a but for its first and last
    L samples,

        sum_j f'_a[j] y[j + k] = sum_b sum_m h_b[m] c_ab(k - m),   c_ab(d) = sum_j f'_a[j] f_b[j + d],

    for every force a and k = 0 .. L - 1: a system of Toeplitz blocks (forces x forces, each L x L) whose solution
    h_b is each force's impulse responses, the others' share of the response taken out, by the block Levinson
    recursion (_block_levinson: L^2 forces^3 operations where a dense solve takes (L forces)^3 / 3, seconds for
    two forces' 16 s at 200 Hz). The coherence is the multiple coherence, 1 - S_ee / S_yy of the residual of all
    forces. InputErrors as _random's, naming the force, and where two forces are one signal (INPUTS_APART)."""
    import scipy.signal

    rate, n = responses.rate, len(f)
    for name, column in zip(forces, f.T, strict=True):
        _not_swept(column, rate, name)
    taps = _taps(n, forces[0], settings)
    f0 = f - f.mean(axis=0)
    y0 = responses.data - responses.data.mean(axis=0)
    _, cross = scipy.signal.csd(f0[:, :, None], f0[:, None, :], rate, nperseg=taps, axis=0)  # (lines, forces, forces)
    power = np.real(np.diagonal(cross, axis1=1, axis2=2))
    excited = np.all(power > settings.shaker_floor * power.max(axis=0), axis=1)
    _apart(cross[excited], forces, f"{n / rate:.4g} s")
    column, row, b = _normal_equations(f0, y0, taps)
    h = _block_levinson(column, row, b).transpose(1, 0, 2)  # (forces, L, responses)
    transformed = np.where(excited[None, :, None], np.fft.rfft(h, axis=1), 0.0)  # (forces, lines, responses)
    for name, lines_of in zip(forces, transformed, strict=True):
        _died_out(lines_of, excited, responses, name, settings)
    fitted = sum(scipy.signal.fftconvolve(f0[:, a, None], h[a], axes=0)[:n] for a in range(len(forces)))
    coherence = _multiple_coherence(y0, fitted, excited, rate)
    top = len(coherence) - 1
    spacing = rate / taps
    averaged = (
        f"{n / rate:.4g} s of random excitation on {', '.join(forces)} at once (the impulse responses of each, "
        f"{taps / rate:.4g} s, by least squares over the record)"
    )
    return tuple(
        FrfEstimate(
            2 * np.pi * spacing * np.arange(top + 1),
            transformed[a, : top + 1],
            coherence,
            responses.channels,
            name,
            (),
            1 / spacing,
            0.0,
            2 * top * spacing,
            settings.random_blocks,
            "block",
            f"{name}'s share of {averaged}",
            tuple(forces),
        )
        for a, name in enumerate(forces)
    )


def _block_levinson(column: NDArray, row: NDArray, rhs: NDArray) -> NDArray:
    """The solution x (L, m, r) of the block Toeplitz system sum_j R(k - j) x[j] = rhs[k], k = 0 .. L - 1, its
    blocks R(d) (m x m) given as ``column`` R(0 .. L - 1) and ``row`` R(0, -1 .. -(L - 1)), both (L, m, m); rhs (L, m,
    r). Levinson's recursion for blocks (Whittle; Wiggins and Robinson), unsymmetric: the forward and backward
    solutions F, B of the leading n x n blocks (T_n F = [E_f, 0 .. 0], T_n B = [0 .. 0, E_b], F's first and B's last
    block the identity) extended by one block at a time, and x with them. Every leading block matrix must be
    regular (the ridge of _random_inputs sees to it)."""
    size, m, _ = column.shape
    r = rhs.shape[2]
    # R(n + 1), .., R(1) for the nth step is a slice of R(L - 1), .., R(0), and R(-1), .., R(-n - 1) one of row: both
    # laid out (m, L, m) so that a slice reshaped to m x (n + 1) m meets the blocks stacked in one product
    falling = np.ascontiguousarray(column[::-1].transpose(1, 0, 2))
    rising = np.ascontiguousarray(row.transpose(1, 0, 2))
    forward = np.zeros((size, m, m))  # F_n in its first n + 1 blocks, 0 after: [F_n, 0] is a slice
    backward = np.zeros((size, m, m))  # B_n in its last n + 1 blocks, 0 before: [0, B_n] is a slice
    forward[0] = backward[-1] = np.eye(m)
    e_f, e_b = column[0], column[0]
    x = np.zeros((size, m, r))
    x[0] = np.linalg.solve(column[0], rhs[0])
    for n in range(size - 1):
        ahead = falling[:, size - 2 - n : size - 1].reshape(m, -1)  # R(n + 1), .., R(1)
        d_f = ahead @ forward[: n + 1].reshape(-1, m)  # row n + 1 of T_(n+1) [F, 0]
        d_b = rising[:, 1 : n + 2].reshape(m, -1) @ backward[size - 1 - n :].reshape(-1, m)  # row 0 of [0, B]
        k_f, k_b = np.linalg.solve(e_b, d_f), np.linalg.solve(e_f, d_b)
        padded_f, padded_b = forward[: n + 2], backward[size - 2 - n :]
        new_f = padded_f - (padded_b.reshape(-1, m) @ k_f).reshape(-1, m, m)
        backward[size - 2 - n :] = padded_b - (padded_f.reshape(-1, m) @ k_b).reshape(-1, m, m)
        forward[: n + 2] = new_f
        e_f, e_b = e_f - d_b @ k_f, e_b - d_f @ k_b
        delta = ahead @ x[: n + 1].reshape(-1, r)  # row n + 1 of T_(n+1) [x, 0]
        step = np.linalg.solve(e_b, rhs[n + 1] - delta)
        x[: n + 2] += (backward[size - 2 - n :].reshape(-1, m) @ step).reshape(-1, m, r)
    return x


def _taps(n: int, force: str, settings: RecordSettings) -> int:
    """The samples L of a random excitation's impulse responses over ``n`` samples: 1/settings.random_blocks of
    them, even (the lines' transform gives them back); an InputError naming ``force`` below RANDOM_TAPS."""
    taps = 2 * (n // (2 * settings.random_blocks))
    if taps < RANDOM_TAPS:
        raise InputError(
            force,
            f"random excitation over {n} samples: its impulse responses, 1/{settings.random_blocks} of the record, "
            f"need {RANDOM_TAPS} samples or more",
        )
    return taps


def _normal_equations(f0: NDArray, y0: NDArray, taps: int) -> tuple[NDArray, NDArray, NDArray]:
    """The normal equations of _random and _random_inputs for the forces ``f0`` (samples, forces) and responses
    ``y0`` (samples, responses), both less their means: the Toeplitz blocks' first column c_ab(0 .. L - 1) and first
    row c_ab(0, -1 .. -(L - 1)), each (L, forces, forces), with c_ab(d) = sum_j f'_a[j] f_b[j + d] (f' the force but
    for its first and last L samples), and the right-hand sides sum_j f'_a[j] y[j + k], (L, forces, responses).
    Each force's c_aa(0) carries RIDGE: the band the forces leave out makes the matrix singular but for noise."""
    n, m = f0.shape
    size = 1 << (2 * n - 1).bit_length()  # zero-padded: linear correlations
    inner = (np.arange(n) >= taps) & (np.arange(n) < n - taps)
    early = np.conj(np.fft.rfft(np.where(inner[:, None], f0, 0.0), size, axis=0))  # f'
    c = np.fft.irfft(np.einsum("la,lb->lab", early, np.fft.rfft(f0, size, axis=0)), size, axis=0)  # d < 0: size + d
    b = np.fft.irfft(np.einsum("la,ly->lay", early, np.fft.rfft(y0, size, axis=0)), size, axis=0)[:taps]
    column = c[:taps].copy()
    row = np.concatenate([c[:1], c[size - 1 : size - taps : -1]])
    own = np.arange(m)
    column[0, own, own] = row[0, own, own] = c[0, own, own] * (1 + RIDGE)
    return column, row, b


def _multiple_coherence(y0: NDArray, fitted: NDArray, excited: NDArray, rate: float) -> NDArray[np.float64]:
    """1 - S_ee / S_yy of the residual e = ``y0`` - ``fitted`` (Welch, blocks as long as the ``excited`` lines'
    transform), per line to the highest excited, 0 on those not excited; clipped to [0, 1]."""
    import scipy.signal

    segment = 2 * (len(excited) - 1)
    _, s_ee = scipy.signal.welch(y0 - fitted, rate, nperseg=segment, axis=0)
    _, s_yy = scipy.signal.welch(y0, rate, nperseg=segment, axis=0)
    top = int(np.flatnonzero(excited)[-1])
    with np.errstate(invalid="ignore", divide="ignore"):
        coherence = np.where(excited[:, None], 1.0 - s_ee / s_yy, 0.0)[: top + 1]
    return np.clip(np.nan_to_num(coherence), 0.0, 1.0)


def _died_out(lines: NDArray, excited: NDArray, responses: Record, force: str, settings: RecordSettings) -> None:
    """Check that a random excitation's impulse responses (the transform of ``lines``, the excited ones) have died
    out within their length L: into their noise (DIED_OUT) or below TRUNCATED of their start, seen through a Hann
    taper across the band (its edges would ring for seconds); else an InputError naming the force with the length
    to record (the decay seen gives a bound on its time constant: the noise slows it)."""
    taps, rate = 2 * (len(lines) - 1), responses.rate
    tenth, on = taps // 10, np.flatnonzero(excited)
    taper = np.zeros(len(excited))
    taper[on[0] : on[-1] + 1] = np.hanning(on[-1] - on[0] + 3)[1:-1]
    seen = np.fft.irfft(lines * taper[:, None], taps, axis=0)
    end = taps - tenth // 5  # the taper's short kernel round t = 0 wraps round to the last samples

    def level(a: int, b: int) -> NDArray:
        return np.sqrt(np.mean(seen[a:b] ** 2, axis=0))

    later = level(end - 2 * tenth, end)
    ratio = level(end - 4 * tenth, end - 2 * tenth) / np.maximum(later, 1e-300)
    leaking = np.where((later > TRUNCATED * level(0, tenth)) & (ratio > DIED_OUT), ratio, 0.0)
    if leaking.any():
        worst = float(np.max(leaking))
        span = 2 * tenth / rate
        constant = span / math.log(worst)  # [s] the decay's time constant, the noise taken for decay (a bound)
        raise InputError(
            force,
            f"random excitation: {responses.channels[int(np.argmax(leaking))].name}'s impulse response still decays "
            f"towards the end of the {taps / rate:.4g} s it is fitted over (1/{settings.random_blocks} of the record; "
            f"by {worst:.3g} over {span:.3g} s: a time constant of {constant:.3g} s or less), which leaks: record "
            f"{shaker_lengths(constant, settings)['random']:.3g} s or more (impulse responses that outlast it "
            f"{RANDOM_DECAYS:g} times)",
        )


SWEPT = 0.5
"""A continuous force whose quarters' spectra differ in more than this share of their power (_spectrum_change) is
swept, not random: the least squares of a random excitation need its spectrum the same throughout (the force before
the record's last eighth must excite every line; a sweep's does not reach the top of its band). Random: 0.07 on
kid300's shaker; a sweep: 1."""


def _spectrum_change(f: NDArray, rate: float) -> float:
    """The largest share of power in which the spectra of two quarters of the force ``f`` differ (the total
    variation distance of their normalised Welch spectra, blocks of an eighth of a quarter): 0 for the same, 1 for
    disjoint bands."""
    import scipy.signal

    quarter = len(f) // 4
    spectra = []
    for k in range(4):
        _, power = scipy.signal.welch(f[k * quarter : (k + 1) * quarter], rate, nperseg=max(quarter // 8, 1))
        spectra.append(power / max(float(power.sum()), 1e-300))
    return max(0.5 * float(np.abs(a - b).sum()) for a, b in itertools.combinations(spectra, 2))


RANDOM_TAPS = 64
"""Samples a random excitation's impulse responses need at least (1/RecordSettings.random_blocks of the record)."""

RANDOM_DECAYS = 8.0
"""Time constants of the slowest decay a random excitation's impulse responses (1/RecordSettings.random_blocks of
the record) outlast where it has died out into 1 % noise (DIED_OUT; kid300, x's 1.5 s: in 8 s, 5.3 of them, it
still decays; in 12 s, 8 of them, it has died out): what `simulate --shaker-random` advises."""


def shaker_lengths(slowest: float, settings: RecordSettings = RECORDS) -> dict[str, float]:
    """What a shaker test of a machine whose slowest decay has the time constant ``slowest`` [s] needs [s], by the
    records chain's rules: ``settle``, the response to a periodic excitation differing by SETTLED from one period to
    the next (ln(1 / SETTLED) time constants: the periods before are left out, two or more after it averaged);
    ``quiet``, the time after a burst for its response to fall to settings.burst_tail of its level (the block's
    last tenth is checked: ln(1 / burst_tail) time constants); ``random``, the record of a random force
    (settings.random_blocks x RANDOM_DECAYS time constants: its impulse responses outlast the decay)."""
    return {
        "settle": math.log(1 / SETTLED) * slowest,
        "quiet": math.log(1 / settings.burst_tail) * slowest,
        "random": settings.random_blocks * RANDOM_DECAYS * slowest,
    }


DIED_OUT = 1.5
"""A random excitation's impulse response has died out into its noise where its RMS over the two tenths of its
length before the last is more than 1 / DIED_OUT of its RMS over the two tenths before them (noise alone: a ratio of
1, 0.74-1.33 on kid300 at 1 % and 0.1 % noise; a decay still above the noise: exp(0.2 L / time constant), 1.5-1.9
on kid300's 8 s at 1 % noise)."""

TRUNCATED = 2e-4
"""...or where that RMS is below this share of its RMS over its first tenth: the rest leaks less than the fit of
band-limited responses errs on its own (1e-4 of a damping ratio; a noise-free record: 6e-5)."""

RIDGE = 1e-9
"""The share of the force's variance added to the diagonal of a random excitation's normal equations (_random): a
shaker's band leaves lines without force, where the matrix is singular but for the force's noise; this keeps the
solution finite there (those lines are not used) and moves the others by as much."""


def _block_h1(
    f: NDArray,
    responses: Record,
    force: str,
    blocks: list[slice],
    block: str,
    averaged: str,
    settings: RecordSettings,
) -> FrfEstimate:
    """H1 and coherence over ``blocks`` of the force ``f`` and the responses, each transformed without a window,

        H1 = sum_k conj(F_k) Y_k / sum_k |F_k|^2,   coherence = |sum_k conj(F_k) Y_k|^2 / (sum_k |F_k|^2 sum_k |Y_k|^2)

    on the lines the force excites (settings.shaker_floor; 0 on the others below the highest), up to the highest."""
    return _block_inputs(f[:, None], responses, (force,), blocks, block, averaged, settings)[0]


def _block_inputs(
    f: NDArray,
    responses: Record,
    forces: tuple[str, ...],
    blocks: list[slice],
    block: str,
    averaged: str,
    settings: RecordSettings,
) -> tuple[FrfEstimate, ...]:
    """_block_h1 of several forces at once, ``f`` (samples, forces): per line the cross spectra over the blocks,
    S_ff (forces x forces) and S_fy, give H = S_ff^-1 S_fy, each force's frequency responses with the others' part
    of the response taken out (H1 of one force takes it for noise, and where the forces correlate, as a machine's
    motion makes two shakers' forces do, for its own); the coherence is the multiple coherence
    1 - S_ee / S_yy of what no force explains. The lines are those every force excites."""
    spec_f = np.array([np.fft.rfft(f[b], axis=0) for b in blocks])  # (blocks, lines, forces)
    spec_y = np.array([np.fft.rfft(responses.data[b], axis=0) for b in blocks])
    s_yy = np.sum(np.abs(spec_y) ** 2, axis=0)
    if len(forces) == 1:
        s_ff = np.sum(np.abs(spec_f[:, :, 0]) ** 2, axis=0)
        s_fy = np.sum(np.conj(spec_f[:, :, 0])[:, :, None] * spec_y, axis=0)
        excited = s_ff > settings.shaker_floor * s_ff.max()
        top = int(np.flatnonzero(excited)[-1])
        h = np.where(excited[:, None], s_fy / np.where(excited, s_ff, 1.0)[:, None], 0.0)[: top + 1, :, None]
        with np.errstate(invalid="ignore", divide="ignore"):
            coherence = np.where(excited[:, None], np.abs(s_fy) ** 2 / (s_ff[:, None] * s_yy), 0.0)[: top + 1]
    else:
        s_ff = np.einsum("kla,klb->lab", np.conj(spec_f), spec_f)
        s_fy = np.einsum("kla,kly->lay", np.conj(spec_f), spec_y)
        power = np.real(np.diagonal(s_ff, axis1=1, axis2=2))  # (lines, forces)
        excited = np.all(power > settings.shaker_floor * power.max(axis=0), axis=1)
        if not excited.any():
            raise InputError(forces[1], f"excites no line that {forces[0]} excites: no frequency response of both")
        _apart(s_ff[excited], forces, f"{len(blocks)} {block}s")
        top = int(np.flatnonzero(excited)[-1])
        ridge = np.where(excited, 0.0, 1.0)[:, None, None] * np.eye(len(forces))  # lines left out: kept solvable
        solved = np.linalg.solve(s_ff + ridge, s_fy)
        h = np.where(excited[:, None, None], solved, 0.0).transpose(0, 2, 1)[: top + 1]  # (lines, responses, forces)
        explained = np.real(np.einsum("lay,lay->ly", np.conj(s_fy), solved))
        with np.errstate(invalid="ignore", divide="ignore"):
            coherence = np.where(excited[:, None], explained / s_yy, 0.0)[: top + 1]
    coherence = np.clip(np.nan_to_num(coherence), 0.0, 1.0)
    spacing = responses.rate / (blocks[0].stop - blocks[0].start)
    omega = 2 * np.pi * spacing * np.arange(top + 1)
    rate = 2 * top * spacing
    return tuple(
        FrfEstimate(
            omega,
            h[:, :, j],
            coherence,
            responses.channels,
            force,
            (),
            1 / spacing,
            0.0,
            rate,
            len(blocks),
            block,
            averaged if len(forces) == 1 else f"{force}'s share of {averaged}",
            tuple(forces) if len(forces) > 1 else (),
        )
        for j, force in enumerate(forces)
    )


INPUTS_APART = 0.9
"""Forces whose coherence with each other (|S_ab|^2 / (S_aa S_bb)) reaches this at the median line they excite are one
signal: their frequency responses cannot be told apart (several_inputs). Independent forces: 1 / (blocks averaged)
on average, 0.05-0.2."""


def _apart(s_ff: NDArray, forces: tuple[str, ...], over: str) -> None:
    """An InputError naming the second of two ``forces`` whose coherence at the median of the lines (``s_ff``: their
    cross spectra there, lines x forces x forces) reaches INPUTS_APART: one signal drives both."""
    power = np.real(np.diagonal(s_ff, axis1=1, axis2=2))
    for a, b in itertools.combinations(range(len(forces)), 2):
        coherence = float(np.median(np.abs(s_ff[:, a, b]) ** 2 / (power[:, a] * power[:, b])))
        if coherence >= INPUTS_APART:
            raise InputError(
                forces[b],
                f"correlates with {forces[a]} (coherence {coherence:.3f} at the median line over {over}): one signal "
                "drives both shakers, and their frequency responses cannot be told apart; drive each with its own "
                "random signal",
            )


def several_inputs(
    record: Record, forces: tuple[str, ...], settings: RecordSettings = RECORDS
) -> tuple[FrfEstimate, ...]:
    """The frequency responses of several shakers' continuous forces at once (MIMO), one FrfEstimate per force, in
    the order of ``forces``: each force's frequency responses with the others' share of the response taken out.

    - burst random (the bursts of every force together, _onsets of the largest of the forces relative to their
      peaks): over the bursts, H = S_ff^-1 S_fy per line (_block_inputs), more bursts than forces;
    - random: the impulse responses of every force at once by least squares over the whole record (_random_inputs).

    A periodic excitation repeats the same spectra every period: with several forces at once the frequency responses
    of each cannot be told apart within one record (a controller's MIMO periodic random runs several records with new
    phases): an InputError naming the force. Likewise forces one signal drives (INPUTS_APART)."""
    record = record.in_si()
    if len(forces) < 2:
        raise InputError("forces", f"several_inputs takes two forces or more, got {len(forces)}")
    responses = record.select(record.responses)
    if not responses.channels:
        raise InputError("channels", "no response channel (acceleration, velocity or displacement): only force")
    f = np.column_stack([record.channel(name) for name in forces])
    for name, column in zip(forces, f.T, strict=True):
        if _period(column, settings) is not None:
            raise InputError(
                name,
                f"a periodic excitation beside {counted(len(forces) - 1, 'other force')}: it repeats the same spectrum "
                "every period, and within one record the frequency responses of each force cannot be told apart "
                "(burst random or random can; a controller's periodic MIMO runs a record per phase set; --ignore "
                "leaves a force channel unread)",
            )
    magnitude = np.abs(f - np.median(f, axis=0))
    starts = _onsets(np.max(magnitude / np.maximum(magnitude.max(axis=0), 1e-300), axis=1), record.rate, settings)
    if len(starts) >= 3:
        blocks = _burst_blocks(responses, forces[0], starts, len(f), settings)
        if len(blocks) <= len(forces):
            raise InputError(
                forces[0],
                f"burst random of {len(blocks)} bursts for {len(forces)} forces: each line's cross spectra need more "
                "bursts than forces",
            )
        n = blocks[0].stop - blocks[0].start
        averaged = (
            f"{len(blocks)} bursts of {n / record.rate:.4g} s of burst random on {', '.join(forces)} at once (each "
            "force's frequency responses by least squares over their cross spectra)"
        )
        return _block_inputs(f, responses, forces, blocks, "burst", averaged, settings)
    if len(starts) == 2:
        raise InputError(forces[0], "burst random of 2 bursts: three or more are needed (the last may be cut short)")
    return _random_inputs(f, responses, forces, settings)


def _bursts(f: NDArray, rate: float, settings: RecordSettings) -> list[int]:
    """The samples at which bursts of a force start: where it rises above 5 % of its peak (from its median) after
    staying below for settings.burst_gap [s] or more (the first where it starts after such quiet or at the
    record's start)."""
    return _onsets(np.abs(f - np.median(f)), rate, settings)


def _onsets(x: NDArray, rate: float, settings: RecordSettings) -> list[int]:
    """_bursts of a force's magnitude ``x`` (>= 0, its quiet at 0)."""
    on = np.flatnonzero(x > 0.05 * float(x.max()))
    if not len(on):
        return []
    gap = max(1, int(round(settings.burst_gap * rate)))
    # the record's start counts as after quiet; later, the samples below between two above it
    return [int(on[0]), *map(int, on[1:][np.diff(on) - 1 >= gap])]


SETTLED = 1e-4
"""A period of the response to a periodic excitation whose difference from the next is below this share of the
last period is settled (1e-4 of the response: 1e-4 of H1)."""

DECAYING = 1.1
"""Successive periods of a settled response differ by its noise alone, as much from one to the next (within 1 % for
a record of thousands of samples); a transient makes each difference this many times the next one or more (a decay
of exp(-sigma T) per period T: sigma T > 0.1, any rubber's damping over a period of seconds)."""


def _settled(y: NDArray, period: int, count: int) -> int | None:
    """The first period (1, 2, ...) from which the response ``y`` (samples, channels) repeats: its difference from
    the next below SETTLED of the last period, or not DECAYING times the next difference (the transient from rest
    has died into the noise); None where fewer than two periods are left then."""
    segment = [y[k * period : (k + 1) * period] for k in range(count)]
    step = [float(np.linalg.norm(segment[k + 1] - segment[k])) for k in range(count - 1)]
    floor = SETTLED * float(np.linalg.norm(segment[-1]))
    for k in range(1, count - 1):
        if step[k] <= floor or (k + 1 < len(step) and step[k] <= DECAYING * step[k + 1]):
            return k
    return None


def _period(f: NDArray, settings: RecordSettings) -> int | None:
    """The period [samples] of a repeating signal: the first lag, after its correlation with itself has fallen
    below 0 once, at which the correlation coefficient of the signal and the signal shifted by it exceeds
    settings.periodic_correlation and is highest among its neighbours; None where no lag up to half the
    record does."""
    x = f - f.mean()
    n = len(x)
    size = 1 << (2 * n - 1).bit_length()
    spectrum = np.fft.rfft(x, size)
    raw = np.fft.irfft(np.abs(spectrum) ** 2, size)[:n]  # sum_j x[j] x[j + k]
    energy = np.cumsum(x**2)
    head = energy[::-1][:n]  # sum of x[j]^2 over j < n - k: the first n - k samples
    tail = energy[-1] - np.concatenate([[0.0], energy[:-1]])  # over j >= k: the last n - k samples
    with np.errstate(invalid="ignore", divide="ignore"):
        r = raw / np.sqrt(head * tail)
    crossed = np.flatnonzero(r[: n // 2 + 1] < 0)
    if not len(crossed):
        return None
    for k in range(int(crossed[0]), n // 2 + 1):
        if r[k] > settings.periodic_correlation and r[k] >= r[k - 1] and r[k] >= r[min(k + 1, n - 1)]:
            return k
    return None
