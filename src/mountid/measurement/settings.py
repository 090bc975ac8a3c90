"""The thresholds of the records chain as one settings object, passed explicitly (defaults as shipped)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class RecordSettings:
    """Thresholds of record validation, quality checks and the decay fit."""

    sampling_rtol: float = 1e-6
    """A time step differing from the median step by more than this (relative) is non-uniform sampling."""
    rounding: float = 0.01
    """Sample times within this share of a step of a uniform grid are that grid written with the
    instrument's resolution (read as the grid); beyond it, the time column has jitter, a dropped sample or
    a gap (records.uniform_time)."""
    decay_bandwidth: float = 0.2
    """Relative half-width of the band-pass around the mode in the decay-envelope fit."""
    low_rate_factor: float = 5.0
    """A record sampled below this many times the highest frequency of interest (in Hz) gets a low_rate
    warning: the anti-alias filter's edge and the few samples per period degrade the pencil (on a 50 Hz
    kid300 record the torsion pole came out labelled as the vertical mode)."""
    clip_samples: int = 3
    """A channel's extreme value held on this many samples or more is clipping (a flat top)."""
    clip_resolution: float = 400.0
    """A response channel's clipping is judged on every k-th sample of a record sampled faster than this many
    samples per period of the highest mode of interest: sampled finer, a smooth peak holds its top within the
    noise on several consecutive samples (kid300 at 51.2 kHz: every channel of a clean hit "clipped"; none at 5
    kHz, 490 samples per period of its highest mode), where a flat top stays flat in every k-th sample."""
    double_hit_height: float = 0.1
    """A second impact above this fraction of the first (in amplitude: the force's peak, or the burst's RMS
    level without a force channel) is a double hit."""
    double_hit_spacing: float = 0.015
    """Impact bursts closer than this [s] are one impact (a hammer pulse's rise and fall, 1-10 ms apart)."""
    min_periods: float = 5.0
    """A record holding fewer periods of the lowest mode after the start is too short for the pencil."""
    hit_spacing: float = 0.5
    """[s] Impacts on a force channel closer than this to a hit belong to it (a double hit); later ones are
    separate hits that a frequency response averages over (measurement.frf)."""
    pretrigger: float = 0.01
    """[s] A frequency response's segment starts this long before its hit."""
    continuous_force: float = 0.2
    """A force channel above 5 % of its peak on more than this share of its samples is a continuous excitation (a
    shaker's), not hits (a hammer's: milliseconds per hit)."""
    periodic_correlation: float = 0.95
    """A continuous force is periodic (a shaker's periodic random or multisine, as its controller repeats one block)
    where one period of it correlates with the next beyond this (the correlation coefficient)."""
    burst_gap: float = 0.2
    """[s] A shaker's force below 5 % of its peak for this long or longer ends a burst (burst random)."""
    burst_tail: float = 0.05
    """Burst random's response must die out before the next burst: its last tenth below this share of its level
    (RMS) on every channel, else the block leaks."""
    shaker_floor: float = 1e-2
    """Lines where a shaker's force spectrum (continuous_h1) is below this share of its largest are not excited:
    burst random's on and off leak force beyond its band at -30 dB and less, where H1 would divide noise by noise
    (a multisine's lines outside its band carry none at all)."""
    random_blocks: int = 8
    """A random excitation's impulse responses (frf.continuous_h1: least squares over the whole record) last 1/this
    of the record, 1/8: long enough for a rubber mount's decay in a record of minutes, short enough that the record
    holds that many independent stretches of them (the estimate's noise grows as their share does)."""
    force_floor: float = 1e-6
    """Spectral lines where the hits' force spectrum is below this share of its largest carry no H1 (0): above
    the pulse's bandwidth the division only amplifies noise."""
    low_coherence: float = 0.8
    """A mode whose coherence at its frequency is below this on every channel gets a low_coherence warning."""
    unexplained: float = 0.5
    """A free decay whose poles leave more than this share of its variance unexplained (the median over the
    channels) gets an unexplained warning: not the decay of a hit (a segment of quiet before a hit and the hit),
    where a hit's record at 20 % noise leaves 0.02."""
    steady_damping: float = 1e-4
    """A pole whose damping ratio lies within this of zero, or below, is a steady oscillation (a running machine,
    mains hum: the pencil gives it a damping ratio of about +-1e-7), not a mode of a machine on rubber (0.01-0.2):
    kept by modal.free_decay_poles where it recurs, given no mode's label, named in a steady warning."""


RECORDS = RecordSettings()
"""The default settings."""
