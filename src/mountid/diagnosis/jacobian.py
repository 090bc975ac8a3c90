"""The analytic Jacobian of a candidate fit's residuals (:class:`mountid.diagnosis.fitting.Data`) with respect
to its flat parameter vector, from the engine's generated matrix derivatives and first-order eigen-
perturbation, in place of finite differences.

Chain, for each fit parameter q (an unknown or an effect parameter):

1. d(M, C, B)/dq from the generated derivatives (the candidate's strategy, mountid.diagnosis.strategies);
2. d lambda_k = phi_k^T (C' - lambda_k M') phi_k and d phi_k by modal expansion (mountid.runtime);
3. the model frequencies and body shapes through the strategy (stiffening, damped poles, sensor frame), and
   the damping ratios from the damped-pole derivatives where the campaign measures them;
4. each shape residual: the part of the measured shape off the model shape, or off the span of the modes
   the measurement cannot separate from it, blended by their closeness weight (Data.residuals).

The labelling of modes is held fixed (it is piecewise constant). Where the model has exactly equal frequencies
(twins, within runtime.EQUAL_EIGENVALUES) and a parameter splits them, the frequencies are not differentiable in
that parameter: :func:`jacobian` returns its column as nan and the fit takes a finite difference for that column
alone (the parameters that move the twins together, often every unknown stiffness, keep their analytic columns).
Twins that a small asymmetry parts (within DEGENERATE, so that the residuals compare the measured shapes with
their span, but further apart than that) are distinct eigenvalues with their own derivatives; their labels may
swap under a step of 1e-9, and a finite difference across the swap reads their gap over the step.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from mountid.diagnosis.candidate_model import (
    DEGENERATE,
    PARTNER_WEIGHT,
    CandidateModel,
    Evaluation,
    exact_twins,
    off_span,
)
from mountid.runtime import EQUAL_EIGENVALUES, modal_projection

if TYPE_CHECKING:
    from mountid.diagnosis.fitting import Data

PARALLEL = 1e-12
"""Partners' shapes are parallel (their span drops a direction) where a diagonal entry of the R factor of their
unit columns is this small or smaller (the test of candidate_model._orthonormal)."""

# Twins (modes within DEGENERATE) whose eigenvalues differ by EQUAL_EIGENVALUES or less (relative) are equal: a
# parameter that splits them has no derivative there. Further apart (a small asymmetry parts them) each eigenvalue has
# its own, phi_k^T (C' - lambda_k M') phi_k, and their span moves with its coupling to the other modes alone (what the
# shape residuals of twins see), as eigen_derivatives gives it. LAPACK resolves eigenvectors parted by 1e-9 to about
# 1e-7 (eps over the gap). Forward differences there, as for equal twins, crossed swaps of the twins' labels: entries
# 40 times the largest derivative (kid300, an axial scatter of 1e-5 at one isolator).

_SPLIT_RTOL = 1e-8
"""A parameter keeps twins together when its perturbation of their common subspace is a multiple of the
identity within this (relative to its largest entry)."""


def jacobian(model: CandidateModel, data: Data, theta: np.ndarray) -> np.ndarray | None:
    """d(weighted residual rows)/d(theta), shape (n_rows, n_theta) in the row order of
    :meth:`Data.residuals`, with nan columns for the parameters in which the frequencies are not differentiable
    at this point (they split exactly equal twins); None where no column can be given (parallel partners, or
    modes the strategy cannot differentiate here: Strategy.mode_derivatives)."""
    e = model.evaluate(theta)
    names = model.parameter_names
    scale = model.jacobian_to_physical(theta, e.values)  # d(physical)/d(theta), diagonal
    d_mats, _ = model.strategy.derivatives(model, e.values, names, len(e.lam))  # a fresh array
    d_m, d_c, d_b = d_mats
    split = _splitting(e, d_m, d_c)
    if split.all():
        return None
    if split.any():  # the columns of the others are computed with the splitting ones' derivatives at zero
        d_m[split] = 0.0
        d_c[split] = 0.0
        d_b[split] = 0.0
    modes = model.strategy.mode_derivatives(model, e, d_mats, DEGENERATE)
    if modes is None:
        return None
    d_lam, d_vec = modes
    d_omega = model.strategy.frequency_derivatives(model, e, d_lam, d_mats)
    d_shapes = model.strategy.shape_derivatives(model, e, d_vec)

    rows = [-(d_omega[:, e.index] / data.sigma[None, :]).T]
    if data.shape_labels:
        shape_rows = _shape_rows(model, data, e, d_shapes, d_lam)
        if shape_rows is None:
            return None  # parallel partners: the span drops a direction (candidate_model._orthonormal)
        rows.append(shape_rows)
    if data.damping_labels:
        d_zeta = model.strategy.damping_ratio_derivatives(model, e, d_mats)
        rows.append(-(d_zeta[:, e.index[data.damping_index]] / data.zeta_sigma[None, :]).T)
    out = np.concatenate(rows) * scale[None, :]
    out[:, split] = np.nan
    return out


def _splitting(e: Evaluation, d_m: np.ndarray, d_c: np.ndarray) -> np.ndarray:
    """Per parameter, whether it splits a set of exactly equal eigenvalues of a measured mode (its perturbation
    of their subspace, phi^T (C' - lambda M') phi, is not a multiple of the identity). Twins among the modes no
    measurement is paired with or blended with (two support modes a support's aspect parts by 3e-8) leave the measured
    frequencies and shapes differentiable: their derivatives take the others' differences only."""
    split = np.zeros(len(d_m), dtype=bool)
    if not e.twins:
        return split
    used = {*e.index.tolist(), *np.flatnonzero(np.max(e.weight, axis=0) > PARTNER_WEIGHT).tolist()}
    sets = [
        (np.flatnonzero(group), members[0])
        for group, members in e.twins
        if not used.isdisjoint(members) and np.ptp(e.lam[group]) <= EQUAL_EIGENVALUES * abs(e.lam[members[0]])
    ]
    if not sets:
        return split
    n_p = len(d_m)
    projected = modal_projection(e.vec[:, np.concatenate([c for c, _ in sets])], np.concatenate((d_c, d_m)))
    at = 0
    for columns, j in sets:
        block = slice(at, at + len(columns))  # the set's rows and columns of the projection onto every set
        at += len(columns)
        g = projected[:n_p, block, block] - e.lam[j] * projected[n_p:, block, block]
        mean = np.trace(g, axis1=1, axis2=2) / len(columns)
        off = g - mean[:, None, None] * np.eye(len(columns))[None]
        size = np.max(np.abs(g), axis=(1, 2))
        split |= np.max(np.abs(off), axis=(1, 2)) > _SPLIT_RTOL * np.maximum(size, np.finfo(float).tiny)
    return split


def _shape_rows(
    model: CandidateModel, data: Data, e: Evaluation, d_shapes: np.ndarray, d_lam: np.ndarray
) -> np.ndarray | None:
    """The rows of the shape residuals (six per measured shape, in the order of Data.residuals) by fit parameter,
    unweighted by the scale to physical units: each the derivative of the part of the measured shape off the
    model shape, or for a mode with partners of its blend with the part off their span; None where partners'
    shapes are parallel."""
    body, d_body = _unit_shapes(e.shapes, d_shapes, model.length)
    k = data.shape_index
    j = e.index[k]
    s = data.shape_matrix
    own = _off_direction_derivatives(s, body[:, j], d_body[:, :, j])  # (n_q, 6, n_shapes)
    near_all = e.weight[k] > PARTNER_WEIGHT
    spans: dict[bytes, tuple[np.ndarray, np.ndarray] | None] = {}  # partner set -> (q, U^+) of their shapes
    for col in np.flatnonzero(near_all.sum(axis=1) > 1):
        near = near_all[col]
        partners = np.flatnonzero(near)
        key = near.tobytes()
        if key not in spans:
            spans[key] = _span_factors(body[:, partners])
        if spans[key] is None:
            return None
        q, pinv = spans[key]
        sc = s[:, col]
        rest = sc - q @ (q.T @ sc)  # off_span(sc, q): the part of the measured shape off the partners' span
        d_span = _off_span_derivative(sc, q, pinv, rest, d_body[:, :, partners])
        if exact_twins(e.lam, j[col], partners):
            own[:, :, col] = d_span
        else:
            w, d_w = _blend_weight(e, k[col], partners, d_lam)
            blended = w * d_span + (1 - w) * own[:, :, col] + np.outer(d_w, rest - off_span(sc, body[:, j[col]]))
            own[:, :, col] = blended
    own /= data.shape_sigma[None, None, :]
    return own.transpose(2, 1, 0).reshape(-1, own.shape[0])


def _unit_shapes(shapes: np.ndarray, d_shapes: np.ndarray, length: float) -> tuple[np.ndarray, np.ndarray]:
    """scaled_unit of the shapes (6, n) and its derivative (n_q, 6, n): rotations times the length scale,
    each column of unit length, du = (I - u u^T) dv / |v|."""
    v = np.array(shapes, dtype=float)
    v[3:6] *= length
    d_v = np.array(d_shapes, dtype=float)
    d_v[:, 3:6] *= length
    norm = np.sqrt(np.add.reduce(v * v, axis=0))  # np.linalg.norm(v, axis=0) without its checks
    norm = np.where(norm > 0, norm, 1.0)  # as scaled_unit: a mode may leave the body at rest
    u = v / norm
    d_u = d_v / norm[None, None, :]
    d_u -= u[None] * np.einsum("ak,qak->qk", u, d_u)[:, None, :]
    return u, d_u


def _off_direction_derivatives(s: np.ndarray, u: np.ndarray, d_u: np.ndarray) -> np.ndarray:
    """d/dq of s - u (u . s) for each column of s and u (6, n_shapes), shape (n_q, 6, n_shapes), from du/dq
    (n_q, 6, n_shapes)."""
    along = np.add.reduce(u * s, axis=0)  # u . s per column
    d_along = np.add.reduce(d_u * s[None], axis=1)  # du/dq . s, (n_q, n_shapes)
    return -(d_u * along[None, None, :] + d_along[:, None, :] * u[None])


def _span_factors(basis: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """Orthonormal columns q spanning the columns U of ``basis`` (6, c) and the pseudo-inverse U^+ = r^-1 q^T
    (c, 6), from U = q r by Gram-Schmidt, each column orthogonalised twice (twice is enough: q is orthonormal to
    rounding however close the columns lie); None where a column lies in the span of those before it (a diagonal
    entry of r at or below PARALLEL, the test of candidate_model._orthonormal). Two or three columns: numpy's
    QR and inverse cost several times these few products at this size."""
    n, c = basis.shape
    q = np.empty((n, c))
    r = np.zeros((c, c))
    for i in range(c):
        v = basis[:, i].copy()
        for _ in range(2):
            h = q[:, :i].T @ v
            v -= q[:, :i] @ h
            r[:i, i] += h
        r[i, i] = math.sqrt(v @ v)
        if r[i, i] <= PARALLEL:
            return None
        q[:, i] = v / r[i, i]
    pinv = np.empty((c, n))  # r pinv = q^T by back substitution
    for i in range(c - 1, -1, -1):
        pinv[i] = (q[:, i] - r[i, i + 1 :] @ pinv[i + 1 :]) / r[i, i]
    return q, pinv


def _off_span_derivative(
    s: np.ndarray, q: np.ndarray, pinv: np.ndarray, rest: np.ndarray, d_basis: np.ndarray
) -> np.ndarray:
    """d/dq of (I - P) s, P = q q^T the orthogonal projector onto the columns U of the partners' shapes (6, c),
    ``pinv`` = U^+ and ``rest`` = (I - P) s, from dU/dq (n_q, 6, c): dP = (I - P) dU U^+ + (U^+)^T dU^T (I - P),
    applied to s without forming dP."""
    along = d_basis @ (pinv @ s)  # dU U^+ s, (n_q, 6)
    along -= (along @ q) @ q.T  # (I - P) dU U^+ s
    across = np.einsum("qac,a->qc", d_basis, rest) @ pinv  # ((U^+)^T dU^T (I - P) s)^T, (n_q, 6)
    return -(along + across)


def _blend_weight(e: Evaluation, k: int, partners: np.ndarray, d_lam: np.ndarray) -> tuple[float, np.ndarray]:
    """The blend weight of labelled mode k (the smallest closeness weight exp(-gap^2) over its partners) and
    its derivative (n_q,) through gap = |lam_j - lam_l| / (2 |lam_j| resolution)."""
    j = e.index[k]
    ell = partners[np.argmin(e.weight[k, partners])]
    w, gap = float(e.weight[k, ell]), float(e.gap[k, ell])
    lam_j, lam_l = e.lam[j], e.lam[ell]
    d_diff = np.sign(lam_j - lam_l) * (d_lam[:, j] - d_lam[:, ell])
    d_gap = gap * (d_diff / abs(lam_j - lam_l) - np.sign(lam_j) * d_lam[:, j] / abs(lam_j))
    return w, -2 * gap * w * d_gap
