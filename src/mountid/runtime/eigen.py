"""Generalised symmetric eigen-solves of small blocks, mode shapes and eigenvalue derivatives (numpy).
All functions broadcast over leading batch dimensions."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mountid.runtime.evaluation import as_arrays


def stack_symmetric(
    shape: tuple[int, ...], dims: tuple[int, ...], entries: tuple[tuple[int, ...], ...], values: tuple[ArrayLike, ...]
) -> NDArray:
    """A (*shape, *dims) array of symmetric matrices (the last two of ``dims``; before them the index of a matrix in
    a stack, if any), zero but for their non-zero upper-triangle ``entries`` (indices into ``dims``), set to
    ``values`` and mirrored below the diagonal.

    With scalar inputs (``shape`` ()) the values are set in one step at flat positions computed once for each
    ``entries`` (a generated function passes the same constant tuple at every call): a stack of derivative
    matrices with 70 entries takes 2 us instead of 25 entry by entry."""
    out = np.zeros((*shape, *dims))
    if not shape:
        upper, lower = _flat_positions(dims, entries)
        flat = out.reshape(-1)
        flat[upper] = flat[lower] = np.fromiter(values, float, len(values))
        return out
    for index, value in zip(entries, values, strict=True):
        out[(..., *index)] = value
        out[(..., *index[:-2], index[-1], index[-2])] = value
    return out


_POSITIONS: dict[int, tuple[tuple, NDArray[np.intp], NDArray[np.intp]]] = {}
"""The flat positions of stack_symmetric's entries and of their mirror images, by the identity of the entries'
tuple (held here, so its identity is not reused)."""

_POSITIONS_KEPT = 4096
"""More distinct entry tuples than this (a generated function building its entries anew at every call) empty the
store rather than grow it."""


def _flat_positions(dims: tuple[int, ...], entries: tuple[tuple[int, ...], ...]) -> tuple[NDArray, NDArray]:
    kept = _POSITIONS.get(id(entries))
    if kept is not None and kept[0] is entries:
        return kept[1], kept[2]
    index = np.array(entries, dtype=np.intp).reshape(len(entries), len(dims)).T
    mirrored = index.copy()
    mirrored[[-2, -1]] = index[[-1, -2]]
    upper = np.ravel_multi_index(tuple(index), dims)
    lower = np.ravel_multi_index(tuple(mirrored), dims)
    if len(_POSITIONS) >= _POSITIONS_KEPT:
        _POSITIONS.clear()
    _POSITIONS[id(entries)] = (entries, upper, lower)
    return upper, lower


def block_eigen(
    mass: NDArray, stiffness: NDArray, index: tuple[int, ...]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Eigenvalues (ascending) and mass-normalised eigenvectors of one block of (C, M), numerically.

    Solves C_b u = lambda M_b u through the Cholesky factor of M_b and numpy's symmetric eigen-solver.
    Returns (lam (..., n), vectors (..., n, n)) with vectors as columns. A row of the batch without a solution
    (an entry NaN or infinite, M_b not positive definite) is NaN, as the closed-form blocks give it, and the
    other rows are solved (numpy raised LinAlgError for the whole batch).
    """
    idx = np.asarray(index)
    mb = mass[..., idx[:, None], idx[None, :]]
    cb = stiffness[..., idx[:, None], idx[None, :]]
    try:
        return _block_eigen(mb, cb)
    except np.linalg.LinAlgError:
        pass
    mb, cb = np.broadcast_arrays(mb, cb)
    shape = mb.shape
    mb, cb = mb.reshape(-1, *shape[-2:]), cb.reshape(-1, *shape[-2:])  # one batch axis (a scalar batch too)
    lam = np.full(mb.shape[:-1], np.nan)
    vec = np.full(mb.shape, np.nan)
    good = np.all(np.isfinite(mb) & np.isfinite(cb), axis=(-1, -2))
    good[good] = np.linalg.eigvalsh(mb[good])[..., 0] > 0
    with np.errstate(all="ignore"):  # entries so large that the reduced stiffness overflows
        inv = np.linalg.inv(np.linalg.cholesky(mb[good]))
        good[good] = np.all(np.isfinite(inv @ cb[good] @ np.swapaxes(inv, -1, -2)), axis=(-1, -2))
    if good.any():
        lam[good], vec[good] = _block_eigen(mb[good], cb[good])
    return lam.reshape(shape[:-1]), vec.reshape(shape)


def _block_eigen(mb: NDArray, cb: NDArray) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    chol = np.linalg.cholesky(mb)
    inv = np.linalg.inv(chol)
    sym = inv @ cb @ np.swapaxes(inv, -1, -2)
    lam, vec = np.linalg.eigh(sym)
    return lam, np.swapaxes(inv, -1, -2) @ vec


def modal_matrix(
    mass: NDArray,
    stiffness: NDArray,
    lam: NDArray,
    blocks: tuple[tuple[int, ...], ...],
    mode_block: tuple[int, ...],
    mode_rank: tuple[int, ...],
) -> NDArray[np.float64]:
    """Mass-normalised modal matrix (Phi^T M Phi = I), columns in mode order, shape (..., n, n_modes).

    For a block of size 1 the shape is 1/sqrt(M_ii). For size 2 the null vector of (C_b - lambda M_b) is
    taken from whichever row gives the larger vector (the other row may suffer cancellation when the
    coupling is weak); where the block's two eigenvalues are equal within EQUAL_EIGENVALUES (twins: every
    vector of the block is a mode, or nearly), its rank-2 mode is the M-orthogonal complement of its rank-1
    mode, which is the block's first coordinate where C_b - lambda M_b is exactly zero (each null vector alone
    gave the same vector twice near a double root of an uncoupled block, and NaN at it). Larger blocks use
    :func:`block_eigen`. Sign convention: the entry with the largest mass-weighted magnitude is positive.
    """
    mass, stiffness, lam = np.broadcast_arrays(*as_arrays(mass, stiffness[..., :, :], lam[..., None, :]))
    lam = lam[..., 0, :]
    n = mass.shape[-1]
    phi = np.zeros((*mass.shape[:-2], n, len(mode_block)))
    numeric: dict[int, NDArray] = {}
    for k, (b, rank) in enumerate(zip(mode_block, mode_rank, strict=True)):
        idx = blocks[b]
        if len(idx) == 1:
            i = idx[0]
            phi[..., i, k] = 1.0 / np.sqrt(mass[..., i, i])
            continue
        if len(idx) == 2:
            mb = mass[..., np.array(idx)[:, None], np.array(idx)[None, :]]
            cb = stiffness[..., np.array(idx)[:, None], np.array(idx)[None, :]]
            u = _null_vector(mb, cb, lam[..., k])
            other = [j for j, c in enumerate(mode_block) if c == b and mode_rank[j] != rank]
            if other:
                twin = np.abs(lam[..., other[0]] - lam[..., k]) <= EQUAL_EIGENVALUES * np.abs(lam[..., k])
                if np.any(twin):
                    first = u if rank == 1 else _null_vector(mb, cb, lam[..., other[0]])
                    first = np.where((_m_norm(first, mb) == 0)[..., None], np.array([1.0, 0.0]), first)
                    if rank == 1:
                        u = np.where(twin[..., None], first, u)
                    else:  # the M-orthogonal complement of the rank-1 mode
                        m_first = np.einsum("...ij,...j->...i", mb, first)
                        u = np.where(twin[..., None], np.stack([-m_first[..., 1], m_first[..., 0]], axis=-1), u)
            u = u / _m_norm(u, mb)[..., None]
            phi[..., idx[0], k], phi[..., idx[1], k] = u[..., 0], u[..., 1]
            continue
        if b not in numeric:
            numeric[b] = block_eigen(mass, stiffness, idx)[1]
        phi[..., np.array(idx), k] = numeric[b][..., :, rank - 1]
    return with_positive_largest(phi, mass)


def _null_vector(mb: NDArray, cb: NDArray, lk: NDArray) -> NDArray[np.float64]:
    """A null vector of the 2 x 2 matrix C_b - lambda M_b (unnormalised, shape (..., 2)), from whichever row gives
    the larger vector (the other row may suffer cancellation when the coupling is weak)."""
    a11 = cb[..., 0, 0] - lk * mb[..., 0, 0]
    a12 = cb[..., 0, 1] - lk * mb[..., 0, 1]
    a22 = cb[..., 1, 1] - lk * mb[..., 1, 1]
    u_row1 = np.stack([-a12, a11], axis=-1)
    u_row2 = np.stack([a22, -a12], axis=-1)
    use1 = np.hypot(a12, a11) > np.hypot(a22, a12)
    return np.where(use1[..., None], u_row1, u_row2)


def _m_norm(u: NDArray, mb: NDArray) -> NDArray[np.float64]:
    """sqrt(u^T M_b u) of vectors u (..., 2)."""
    return np.sqrt(np.einsum("...i,...ij,...j->...", u, mb, u))


EQUAL_EIGENVALUES = 1e-9
"""Two eigenvalues (squared frequencies) this close, relative, are equal up to rounding: twins, whose span is the
mode and which no parameter splits by a derivative (the inverse's condition number of a root with twins among
the given modes is infinite; a diagnosis takes a finite difference for a parameter that splits them; the blind
truth gives each twin's label the projection of its nominal shape on their span)."""

SAME_MAGNITUDE = 1e-9
"""Relative difference of two mass-weighted entries of a mode below which they are equally large (a mode parted
along a diagonal moves x and y alike): the first of them sets the sign."""


def _largest_entries(phi: NDArray, mass: NDArray) -> NDArray[np.intp]:
    """Per column of ``phi`` (shape (..., n, n_modes)), the row of its entry of largest mass-weighted magnitude
    (sqrt(M_ii) |phi_i|, diagonal of ``mass``); of entries equal within SAME_MAGNITUDE the first."""
    weight = np.abs(phi) * np.sqrt(np.diagonal(mass, axis1=-2, axis2=-1))[..., :, None]
    largest = np.max(weight, axis=-2, keepdims=True)
    return np.argmax(weight >= largest * (1 - SAME_MAGNITUDE), axis=-2)


def with_positive_largest(phi: NDArray, mass: NDArray) -> NDArray[np.float64]:
    """``phi`` (columns are modes over the rows' coordinates, shape (..., n, n_modes)) with each column's sign
    chosen so that its entry of largest mass-weighted magnitude (sqrt(M_ii) phi_i, diagonal of ``mass``) is
    positive; of entries equal within SAME_MAGNITUDE the first, so that rounding does not choose the sign."""
    first = _largest_entries(phi, mass)
    pick = np.take_along_axis(phi, first[..., None, :], axis=-2)
    return phi * np.where(pick < 0, -1.0, 1.0)


def with_real_positive_largest(vectors: NDArray, mass: NDArray) -> NDArray[np.complex128]:
    """Complex mode shapes ``vectors`` (columns are modes over the coordinates of ``mass``, shape (n, n_modes))
    with each column's phase chosen so that its entry of largest mass-weighted magnitude is real and positive; of
    entries equal within SAME_MAGNITUDE the first (with_positive_largest's convention for complex modes). An
    eigensolver's phase is its own: LAPACK builds on two hosts gave the same rig's modes opposite signs."""
    v = np.asarray(vectors, dtype=complex)
    first = _largest_entries(v, mass)
    columns = np.arange(v.shape[1])
    pick = v[first, columns]
    out = v * np.where(pick != 0, np.conj(pick) / np.where(pick != 0, np.abs(pick), 1.0), 1.0)
    out[first, columns] = np.abs(pick)  # real to the last bit, not to the product's rounding
    return out


def kinetic_energy_distribution(mass: NDArray, phi: NDArray) -> NDArray[np.float64]:
    """Share of each mode's kinetic energy per coordinate, shape (..., n_coordinates, n_modes).

    share[i, k] = phi_ik (M phi_k)_i / (phi_k^T M phi_k); each column sums to 1. With a diagonal mass matrix
    every share lies in [0, 1]; an off-diagonal M (centre of mass away from the origin) can make a share
    negative, since the kinetic energy is then not a sum over coordinates.
    """
    m_phi = mass @ phi
    per = phi * m_phi
    return per / np.sum(per, axis=-2, keepdims=True)


def modal_projection(phi: NDArray, matrices: NDArray) -> NDArray:
    """phi^T A phi of each matrix A of a stack (..., n_p, n, n) for modes phi (..., n, m): shape (..., n_p, m, m)
    (matrix products: a three-operand einsum walks every index combination, ten to sixty times slower here)."""
    return np.swapaxes(phi, -1, -2)[..., None, :, :] @ matrices @ phi[..., None, :, :]


def modal_diagonal(phi: NDArray, matrices: NDArray) -> NDArray:
    """phi_k^T A phi_k of each matrix A of a stack (..., n_p, n, n) and each mode k of phi (..., n, m) (unconjugated
    where complex): shape (..., n_p, m), the diagonal of :func:`modal_projection`."""
    return np.add.reduce(phi[..., None, :, :] * (matrices @ phi[..., None, :, :]), axis=-2)


def eigenvalue_derivatives(
    d_mass: NDArray | None, d_stiffness: NDArray, phi: NDArray, lam: NDArray | None
) -> NDArray[np.float64]:
    """d lambda_k / d p = phi_k^T (dC/dp - lambda_k dM/dp) phi_k for mass-normalised modes (distinct within
    their block), from dM/dp, dC/dp (..., n_p, 6, 6), phi (..., 6, n_modes) and lam (..., n_modes); shape
    (..., n_p, n_modes). ``d_mass`` None: M does not depend on the parameters (``lam`` is then unused)."""
    dc = modal_diagonal(phi, d_stiffness)
    if d_mass is None:
        return dc
    return dc - lam[..., None, :] * modal_diagonal(phi, d_mass)


def eigen_jacobian(phi: NDArray, dc: NDArray, mode_index: list[int] | tuple[int, ...]) -> NDArray[np.float64]:
    """d lambda_k / d theta_j for the given modes and the unknown stiffnesses (M does not depend on them),
    shape (N, n_modes_given, n_unknowns) from phi (N, 6, n_modes), dc (N, n_unknowns, 6, 6)."""
    return np.swapaxes(eigenvalue_derivatives(None, dc, phi[:, :, list(mode_index)], None), -1, -2)


def eigen_derivatives(
    d_mass: NDArray, d_stiffness: NDArray, phi: NDArray, lam: NDArray, degenerate_rtol: float = 1e-6
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """d lambda_k / d p and d phi_k / d p of the mass-normalised modes of (C, M) from dC/dp and dM/dp
    (n_p, n, n) projected together on every mode phi (n, n), lam (n,). The eigenvalue derivatives, shape
    (n_p, n), are :func:`eigenvalue_derivatives`' to the bit (the diagonal of the forcing below, summed in its
    order); the mode derivatives, by modal expansion (Fox and Kapoor), have shape (n_p, n, n),
    [p, :, k] = d phi_k / d p:

        phi_k' = sum_{j != k} phi_j phi_j^T (C' - lambda_k M') phi_k / (lambda_k - lambda_j)
                 - phi_k (phi_k^T M' phi_k) / 2,

    exact when ``phi`` holds every mode. Modes within ``degenerate_rtol`` (relative) of mode k are left out
    of its sum: within a degenerate subspace the eigenvectors are not differentiable (any rotation of them is
    a basis), and only the motion of the subspace itself is defined."""
    n_p = len(d_stiffness)
    both = np.concatenate((d_stiffness, d_mass))  # one stack: one call of each product below
    projected = modal_projection(phi, both)
    diagonal = modal_diagonal(phi, both)  # the diagonal of ``projected``, summed as eigenvalue_derivatives sums it
    forcing = projected[:n_p] - lam[None, None, :] * projected[n_p:]
    d_lam = diagonal[:n_p] - lam[None, :] * diagonal[n_p:]
    modes = np.arange(len(lam))
    gap = lam[None, :] - lam[:, None]  # [j, k] = lambda_k - lambda_j
    near = np.abs(gap) <= degenerate_rtol * np.abs(lam)[None, :]
    coefficient = np.where(near[None], 0.0, forcing / np.where(near, 1.0, gap)[None])
    coefficient[:, modes, modes] = -0.5 * diagonal[n_p:]
    return d_lam, phi[None] @ coefficient
