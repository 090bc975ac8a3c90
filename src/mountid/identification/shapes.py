"""Mode shapes in the coordinates q from complex channel amplitudes: one record's, by least squares through its
channel rows, and a roving test's, from runs whose channels alone do not span the six motions.

A roving-accelerometer test keeps a reference sensor in place and moves the others between hits: each run sees a
mode at a few channels, its amplitudes scaled by that run's own hit (force and phase). Run j measures
s_j = a_j R_j q + e_j: the rigid body's motion q (complex, 6) seen through the run's channel rows R_j, times the
run's complex factor a_j (a_1 = 1), with independent circular errors of standard deviation sqrt(E |e|^2). The
factors and the motion are fitted together (joint_motion): the reference channels tie the runs' scales together,
and the rigid body ties them further where the runs' channels overlap in what they see. Where the runs together do
not determine q and their factors (too few channels, or a motion none of them sees apart from the factors: two
triaxial sensors leave the rotation about the line through them open), there is no shape.

Shapes are real, rotated so that the largest entry is real and positive and scaled to 1 there (real_shape); their
standard deviation per component (MeasuredMode.shape_std) is of the shape scaled to unit length with its rotations
times the machine's length scale, to first order (unit_shape_std).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from mountid.identification.statistics import covariance
from mountid.machine import rigid_motion
from mountid.measurement.modes import ChannelShape

RANK_TOLERANCE = 1e-9
"""A joint fit's Jacobian (columns scaled to unit length) whose smallest singular value is below this fraction of
its largest leaves the motion or a run's factor undetermined: no shape."""

MAX_STEPS = 50
"""Gauss-Newton steps of the joint fit at most (from the homogeneous least-squares start it takes a few)."""


def real_shape(motion: NDArray[np.complex128]) -> tuple[float, ...]:
    """The real mode shape of a complex motion q: the common phase removed (rotated so that the largest entry is
    real and positive), scaled to 1 there."""
    k = int(np.argmax(np.abs(motion)))
    q = motion * np.exp(-1j * np.angle(motion[k])) / np.abs(motion[k])
    return tuple(float(v) for v in q.real)


def unit_shape_std(motion: NDArray[np.complex128], motion_covariance: NDArray[np.float64], length: float) -> float:
    """Standard deviation per component of real_shape(``motion``) scaled to unit length with its rotations times
    ``length`` [m], to first order, from the covariance of [Re q, Im q] (2n x 2n): the real part of the rotated motion
    has the covariance [cos, sin] C [cos, sin]^T; its normalisation keeps the part normal to the shape; that part's
    variance spread over the components less the free scale."""
    n = len(motion)
    k = int(np.argmax(np.abs(motion)))
    phase = np.exp(-1j * np.angle(motion[k]))
    rotate = np.hstack([phase.real * np.eye(n), -phase.imag * np.eye(n)])  # Re(phase q)
    real = (motion * phase).real
    scale = np.ones(n)
    scale[3:6] = length
    scaled = real * scale
    norm = float(np.linalg.norm(scaled))
    unit = scaled / norm
    normal = (np.eye(n) - np.outer(unit, unit)) * scale[None, :] / norm @ rotate
    cov = normal @ motion_covariance @ normal.T
    return float(np.sqrt(np.trace(cov) / max(n - 1, 1)))


def coordinate_shape(rows: NDArray[np.float64], channel_shape: NDArray[np.complex128]) -> tuple[float, ...]:
    """Real mode shape in q from one record's complex channel amplitudes: least squares through its channel rows
    (n_channels x 6, spanning the six motions), real_shape."""
    return real_shape(np.linalg.lstsq(rows, channel_shape, rcond=None)[0])


def coordinate_shape_std(
    rows: NDArray[np.float64], channel_shape: NDArray[np.complex128], channel_std: NDArray[np.float64], length: float
) -> float:
    """Standard deviation per component of the shape :func:`coordinate_shape` gives, scaled to unit length with
    its rotations times ``length`` [m] (MeasuredMode.shape_std), from the standard deviations sqrt(E |error|^2)
    of the complex channel amplitudes (modal.Pole.shape_std; independent, circular), to first order: the real and
    imaginary parts of the least-squares motion each have the covariance P diag(std^2 / 2) P^T (P the
    pseudo-inverse of the channel rows), independent (unit_shape_std)."""
    pinv = np.linalg.pinv(rows)
    half = (pinv * (np.asarray(channel_std, dtype=float) ** 2 / 2)[None, :]) @ pinv.T
    zero = np.zeros_like(half)
    return unit_shape_std(pinv @ channel_shape, np.block([[half, zero], [zero, half]]), length)


def joint_motion(parts: Sequence[ChannelShape]) -> tuple[NDArray[np.complex128], NDArray[np.float64] | None] | None:
    """The motion q of one mode from the partial channel shapes of several runs (the module's model), with the
    first run's factor 1, and the covariance of [Re q, Im q] (None where a run's channel standard deviations are
    not stated): the linearised fit's, widened by chi^2 per degree of freedom where the runs scatter beyond their
    stated noise (statistics.covariance). None where the runs do not determine the motion and their factors, or
    a run does not see the mode (a factor without a start).

    Started from the homogeneous least squares [R_j, -s_j] [q, b] = 0 (the smallest right singular vector, rows
    weighted by 1 / std), then Gauss-Newton on the complex residuals (a_j R_j q - s_j) / std, holomorphic in the
    unknowns."""
    stated = all(p.std is not None for p in parts)
    weights = [1.0 / np.asarray(p.std, dtype=float) if stated else np.ones(len(p.amplitudes)) for p in parts]
    n_q = parts[0].rows.shape[1]
    sizes = [len(p.amplitudes) for p in parts]
    unknowns = n_q + len(parts) - 1
    if sum(sizes) < unknowns:
        return None
    homogeneous = np.zeros((sum(sizes), n_q + len(parts)), dtype=complex)
    at = 0
    for j, (p, w) in enumerate(zip(parts, weights, strict=True)):
        homogeneous[at : at + sizes[j], :n_q] = w[:, None] * p.rows
        homogeneous[at : at + sizes[j], n_q + j] = -w * p.amplitudes
        at += sizes[j]
    v = np.linalg.svd(homogeneous)[2][-1].conj()
    b = v[n_q:]
    if np.min(np.abs(b)) <= RANK_TOLERANCE * np.max(np.abs(b)):
        return None
    motion, factors = v[:n_q] / b[0], b[0] / b[1:]

    def residuals_and_jacobian(q: NDArray, a: NDArray) -> tuple[NDArray, NDArray]:
        r, jac, at = np.zeros(sum(sizes), complex), np.zeros((sum(sizes), unknowns), complex), 0
        for j, (p, w) in enumerate(zip(parts, weights, strict=True)):
            factor = 1.0 if j == 0 else a[j - 1]
            seen = p.rows @ q
            r[at : at + sizes[j]] = w * (factor * seen - p.amplitudes)
            jac[at : at + sizes[j], :n_q] = factor * w[:, None] * p.rows
            if j > 0:
                jac[at : at + sizes[j], n_q + j - 1] = w * seen
            at += sizes[j]
        return r, jac

    for _ in range(MAX_STEPS):
        r, jac = residuals_and_jacobian(motion, factors)
        step = np.linalg.lstsq(jac, -r, rcond=None)[0]
        motion, factors = motion + step[:n_q], factors + step[n_q:]
        if np.linalg.norm(step) <= 1e-12 * np.linalg.norm(np.concatenate([motion, factors])):
            break
    r, jac = residuals_and_jacobian(motion, factors)
    columns = np.linalg.norm(jac, axis=0)
    singular = np.linalg.svd(jac / np.where(columns > 0, columns, 1.0), compute_uv=False)
    if not np.all(columns > 0) or singular[-1] <= RANK_TOLERANCE * singular[0]:
        return None
    if not stated:
        return motion, None
    # real form with unit-variance residuals: Re and Im of a circular error of E|e|^2 = std^2 each std^2 / 2
    real_jac = math.sqrt(2.0) * np.block([[jac.real, -jac.imag], [jac.imag, jac.real]])
    chi2 = 2.0 * float(np.sum(np.abs(r) ** 2))
    cov = covariance(real_jac, chi2, 2 * (sum(sizes) - unknowns))
    keep = np.r_[0:n_q, unknowns : unknowns + n_q]
    return motion, cov[np.ix_(keep, keep)]


def merged_shape(parts: Sequence[ChannelShape]) -> tuple[tuple[float, ...], float | None] | None:
    """One mode's shape (real_shape) and its standard deviation (unit_shape_std at the parts' length scale; None
    without stated channel noise) from several runs' partial channel shapes (joint_motion); None where they do
    not determine it."""
    joint = joint_motion(parts)
    if joint is None:
        return None
    motion, cov = joint
    return real_shape(motion), None if cov is None else unit_shape_std(motion, cov, parts[0].length)


MEND = "; a channel that moves in it would give them"
"""What unseen_motion says would mend one unseen motion."""


def unseen_motion(rows: NDArray[np.float64], length: float) -> str:
    """What the channel ``rows`` (d^T du/dq, n_channels x 6; q = (x, y, z, psi, theta, phi): translations of the
    description's origin [m] and small rotations about its axes [rad], a point p moving by t + omega x p) do not
    see, in words, with what would mend it; '' where they see all six motions. One motion unseen is named as the
    rigid-body motion it is (machine.rigid_motion); more are counted. ``length`` [m]: the
    machine's length scale, which makes the rotations' columns commensurate with the translations' (rank tolerance
    RANK_TOLERANCE)."""
    scale = np.array([1.0, 1.0, 1.0, 1.0 / length, 1.0 / length, 1.0 / length])
    _, s, vt = np.linalg.svd(rows * scale[None, :])
    seen = int(np.sum(s > RANK_TOLERANCE * s[0])) if s.size and s[0] > 0 else 0
    if seen == 6:
        return ""
    head = f"the channels see {seen} of the six rigid-body motions"
    if seen < 5:
        return f"{head}: channels along {6 - seen} more independent directions would give them"
    return f"{head}, not {rigid_motion(vt[-1] * scale, length)}{MEND}"  # the unseen motion in the coordinates


def no_shapes_note(rows: NDArray[np.float64], length: float) -> str:
    """The note where the channel ``rows`` give no mode shapes: what they do not see and what would mend it
    (unseen_motion); '' where they see all six motions."""
    unseen = unseen_motion(rows, length)
    return f"no mode shapes: {unseen}" if unseen else ""
