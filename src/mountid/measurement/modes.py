"""One measured mode, whether it comes from a record (mountid.identification) or a campaign file
(mountid.diagnosis): the one measured-mode type of the package."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

DEFAULT_FREQUENCY_STD = 1e-3
"""Relative standard deviation taken for a frequency given without uncertainty (a campaign's mode, a bench's table
of modes)."""
DEFAULT_DAMPING_STD = 0.05
"""Relative standard deviation taken for a damping ratio given without damping_uncertainty."""

DAMPING_STD_FLOOR = 1e-3
"""Smallest standard deviation taken for a damping ratio given without one (a ratio of 0 has no relative
uncertainty)."""


def default_damping_std(ratio: float) -> float:
    """The standard deviation taken for a damping ratio ``ratio`` given without one: DEFAULT_DAMPING_STD of it, at
    least DAMPING_STD_FLOOR."""
    return max(DEFAULT_DAMPING_STD * ratio, DAMPING_STD_FLOOR)


@dataclass(frozen=True, eq=False)
class ChannelShape:
    """A mode as one record's channels saw it: the complex ``amplitudes`` at its response channels (accelerations
    [m/s^2] on the record's own scale: its hit's force and phase), their standard deviations sqrt(E |error|^2)
    ``std`` (None: not stated), the channel ``rows`` d^T du/dq (n_channels x 6) that see the coordinates q, and the
    machine's ``length`` scale [m] (MeasuredMode.shape_std multiplies rotations by it). The runs of a roving test
    each give a part of a shape (mountid.identification.shapes.merged_shape)."""

    amplitudes: NDArray[np.complex128]
    std: NDArray[np.float64] | None
    rows: NDArray[np.float64]
    length: float


@dataclass(frozen=True)
class MeasuredMode:
    """A labelled measured mode.

    ``frequency`` [rad/s] and its standard deviation ``frequency_std`` [rad/s]; ``frequency_std_stated``
    says whether the measurement gave it (False: a default the reader of a campaign filled in).
    ``damping_ratio`` [1] and ``damping_std``; ``shape`` in the coordinates q (rotations in rad) with
    ``shape_std`` the standard deviation per component of the shape scaled to unit length (rotations times
    the machine's length scale); ``mac`` the MAC of the channel shape against the model's mode it is
    labelled as, or for a pole that stands for twins its share in their span (records of two response channels
    or more: one channel's MAC is 1 whatever it measured); ``channels`` the channel amplitudes of a record.
    Quantities the measurement does not give are None."""

    label: str
    frequency: float
    frequency_std: float
    frequency_std_stated: bool = True
    damping_ratio: float | None = None
    damping_std: float | None = None
    shape: tuple[float, ...] | None = None
    shape_std: float | None = None
    mac: float | None = None
    channels: ChannelShape | None = field(default=None, compare=False, repr=False)
    """The channel amplitudes the shape comes from (records only; None elsewhere): where no record's channels span
    the six motions, several records' together may (a roving test's runs)."""

    @property
    def stated_frequency_std(self) -> float | None:
        """The frequency's standard deviation as the measurement stated it [rad/s], else None."""
        return self.frequency_std if self.frequency_std_stated else None


def scaled_unit(shapes: np.ndarray, length: float) -> np.ndarray:
    """Rotations times the length scale, each column normalised to unit length."""
    out = np.array(shapes, dtype=float)
    out[3:6] *= length
    norm = np.sqrt(np.add.reduce(out * out, axis=0))  # np.linalg.norm(out, axis=0) without its checks
    return out / np.where(norm > 0, norm, 1.0)  # a foundation mode may leave the body at rest
