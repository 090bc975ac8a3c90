"""The dynamics of a generated module as the rest of the library uses it: calling a generated function by
parameter name, M, C, B, the first-order form, damped poles and sensor rows.

Units: M [kg, kg m, kg m^2], C [N/m, N, N m/rad], B [N s/m, N s, N m s/rad] (docs/architecture.md,
"Nomenclature"); poles and frequencies [rad/s].
"""

from __future__ import annotations

import struct
import threading
from collections.abc import Callable, Hashable, Mapping, Sequence
from typing import Any, TypeVar

import numpy as np
import scipy.linalg.lapack
import scipy.optimize
from numpy.typing import NDArray

from mountid.errors import InputError
from mountid.machine.modules import GeneratedModule
from mountid.runtime import SCALAR_TYPES, modal_diagonal


def call(module: GeneratedModule, function: str, values: Mapping[str, float]) -> Any:
    """The generated ``function`` of ``module`` evaluated with its arguments (``module.ARGUMENTS``, in the
    order of its signature) taken by name from ``values`` (which may hold more).

    With every argument a scalar, the result is kept (the last CALL_CACHE_SIZE calls, read-only arrays), by
    the values of the arguments it depends on (``module.DEPENDS``, where fewer than all): a candidate fit asks
    for matrices most of whose arguments it does not vary (the mass matrix, an isolator's stiffness) at every
    step, and for derivatives that do not depend on the unknowns it varies (a model linear in them)."""
    names = module.ARGUMENTS[function]
    args = [values[a] for a in names]
    if not SCALAR_TYPES.issuperset(map(type, args)):
        return getattr(module, function)(*args)
    depends = module.DEPENDS.get(function)  # a cached module is generated anew when the templates change
    keyed = args if depends is None else [values[a] for a in depends]
    key = (module, function, struct.pack(f"{len(keyed)}d", *keyed))  # bytes: -0.0 is not 0.0 here
    return recently_used(_kept_calls(), key, lambda: read_only(getattr(module, function)(*args)), CALL_CACHE_SIZE)


_T = TypeVar("_T")

_MISSING = object()


def recently_used(store: dict, key: Hashable, compute: Callable[[], _T], size: int) -> _T:
    """``compute()``, or what it gave for ``key`` while ``store`` keeps it: the ``size`` most recently used
    results (a dict in the order of use). Nothing is kept where ``compute`` raises."""
    out = store.pop(key, _MISSING)
    if out is _MISSING:
        out = compute()
        if len(store) >= size:
            del store[next(iter(store))]  # the least recently used
    store[key] = out  # last in the order of use
    return out


CALL_CACHE_SIZE = 64
"""Results of generated functions kept by :func:`call` in each thread (the most recently used, over every module and
function)."""

_THREAD = threading.local()
"""Each thread's own kept results (the blind harness on a dask cluster runs cases in threads)."""


def _kept_calls() -> dict:
    kept = getattr(_THREAD, "calls", None)
    if kept is None:
        kept = _THREAD.calls = {}
    return kept


def read_only(out: Any) -> Any:
    """``out`` (an array or a tuple of them) with every array made read-only (a kept result is shared); None and
    other values as they are."""
    if isinstance(out, np.ndarray):
        out.setflags(write=False)
    elif isinstance(out, tuple):
        for x in out:
            read_only(x)
    return out


def matrices(module: GeneratedModule, values: Mapping[str, float]) -> tuple[NDArray, NDArray, NDArray]:
    """M, C, B of a generated module at parameter ``values`` (every argument of the three functions)."""
    return tuple(np.asarray(call(module, f, values)) for f in ("mass_matrix", "stiffness_matrix", "damping_matrix"))


def state_matrix(mass: NDArray, stiffness: NDArray, damping: NDArray) -> NDArray[np.float64]:
    """First-order form x' = A x of M q'' + B q' + C q = 0 with x = [q; q']."""
    n = mass.shape[0]
    minv = np.linalg.inv(mass)
    out = np.zeros((2 * n, 2 * n))
    out[:n, n:] = np.eye(n)
    out[n:, :n] = -minv @ stiffness
    out[n:, n:] = -minv @ damping
    return out


def damped_poles(mass: NDArray, stiffness: NDArray, damping: NDArray, lam: NDArray) -> NDArray[np.complex128]:
    """The pole p (Im p > 0) of each mode of M p^2 + B p + C = 0 [rad/s], in the order of the undamped
    eigenvalues ``lam`` [rad^2/s^2] (the k-th lowest lam is the k-th lowest eigenvalue of C, M): each
    pole goes to the undamped mode whose shape it holds most of (:func:`pair_with_undamped`), so that heavy
    damping that lowers one of two close modes below the other does not swap their labels. A mode that does
    not oscillate (overdamped) has p = 0.

    The damped frequency a spectrum shows is ``p.imag`` (omega_d); the natural frequency a pole fit of a
    free decay reports is ``abs(p)`` (omega_n, with zeta = -p.real / abs(p))."""
    return damped_modes(mass, stiffness, damping, lam)[0]


def undamped_modes(stiffness: NDArray, mass: NDArray) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Eigenvalues lambda [rad^2/s^2] (ascending) and M-normalised eigenvectors (columns) of C phi = lambda M phi
    for one real symmetric pair: LAPACK's dsygvd, the routine scipy.linalg.eigh(C, M) calls, with the same
    arguments and so the same numbers, without its per-call validation (a candidate fit solves 10^5 of them).
    The last result is kept, read-only: the evaluation of a candidate model and the pairing of its damped poles
    (:func:`pair_with_undamped`) ask for the same pair. Raises ValueError for non-finite entries and
    numpy.linalg.LinAlgError where M is not positive definite or the solver fails (as scipy.linalg.eigh)."""
    stiffness = np.asarray(stiffness, dtype=float)
    mass = np.asarray(mass, dtype=float)
    return _kept_last(_LAST_UNDAMPED, (stiffness, mass), lambda: _undamped_modes(stiffness, mass))


def _undamped_modes(stiffness: NDArray, mass: NDArray) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    if stiffness.ndim != 2 or stiffness.shape[0] != stiffness.shape[1] or mass.shape != stiffness.shape:
        raise ValueError(f"expected two square matrices of one size, got {stiffness.shape} and {mass.shape}")
    if not (np.isfinite(stiffness).all() and np.isfinite(mass).all()):
        raise ValueError("array must not contain infs or NaNs")
    lam, vec, info = scipy.linalg.lapack.dsygvd(
        stiffness, mass, itype=1, jobz="V", uplo="L", overwrite_a=False, overwrite_b=False
    )
    if info != 0:
        raise np.linalg.LinAlgError(f"dsygvd failed (info {info}): M not positive definite or no convergence")
    return read_only((lam, vec))


def _kept_last(slot: list, inputs: tuple[NDArray, ...], solve: Callable[[], Any]) -> Any:
    """``solve()``, or the result ``slot`` keeps when its last call had the same ``inputs`` (shapes, types and
    bytes). The slot is read in one step: another thread may replace it meanwhile."""
    key = tuple((a.shape, a.dtype.str, a.tobytes()) for a in inputs)
    last = slot[0]
    if last is not None and last[0] == key:
        return last[1]
    out = solve()
    slot[0] = (key, out)
    return out


_LAST_UNDAMPED: list = [None]
"""The last (inputs, result) of undamped_modes."""


_LAST_DAMPED: list = [None]
"""The last (inputs, result) of damped_modes (read-only)."""


def damped_modes(
    mass: NDArray, stiffness: NDArray, damping: NDArray, lam: NDArray
) -> tuple[NDArray[np.complex128], NDArray[np.complex128]]:
    """The poles of :func:`damped_poles` and their mode shapes x (columns, (n, n); zero for a mode that
    does not oscillate): (M p^2 + B p + C) x = 0. The last result is kept: a fit asks for the poles, then
    their derivatives, at one point (copies are returned)."""
    inputs = tuple(map(np.asarray, (mass, stiffness, damping, lam)))
    poles, shapes = _kept_last(_LAST_DAMPED, inputs, lambda: read_only(_damped_modes(mass, stiffness, damping, lam)))
    return poles.copy(), shapes.copy()


def _damped_modes(
    mass: NDArray, stiffness: NDArray, damping: NDArray, lam: NDArray
) -> tuple[NDArray[np.complex128], NDArray[np.complex128]]:
    n = len(mass)
    poles, vectors = np.linalg.eig(state_matrix(mass, stiffness, damping))
    upper = np.flatnonzero(poles.imag > 0)
    upper = upper[np.argsort(poles[upper].imag, kind="stable")][:n]
    found, found_shapes = poles[upper], vectors[:n, upper]
    out = np.zeros(n, dtype=complex)
    shapes = np.zeros((n, n), dtype=complex)
    slots = np.argsort(lam, kind="stable")[pair_with_undamped(mass, stiffness, found_shapes, found.imag)]
    out[slots] = found
    shapes[:, slots] = found_shapes
    return out, shapes


def pair_with_undamped(
    mass: NDArray, stiffness: NDArray, shapes: NDArray, frequencies: NDArray, rtol: float = 1e-9
) -> NDArray[np.intp]:
    """For each damped mode (complex ``shapes``, columns, with damped ``frequencies`` [rad/s]) the rank of the
    undamped mode it is (0 = the lowest eigenvalue of C, M), one each: the assignment that keeps the most of
    the damped shapes' mass-weighted content |phi^T M x|^2 / x^H M x (scipy.optimize.linear_sum_assignment).
    Undamped eigenvalues within ``rtol`` of each other (twins) have no preferred basis: a damped mode's content
    in them is its projection on their span, and among themselves they take the damped modes in the order of
    their damped frequencies."""
    lam, phi = undamped_modes(stiffness, mass)
    same = np.abs(np.diff(lam)) <= rtol * np.maximum(np.abs(lam[1:]), np.abs(lam[:-1]))
    twins = same.any()
    m_shapes = mass @ shapes
    weight = np.sum(np.conj(shapes) * m_shapes, axis=0).real
    content = np.abs(phi.T @ m_shapes) ** 2 / np.where(weight > 0, weight, 1.0)
    if twins:  # a damped mode's content in a group of twins, repeated for each of the group's slots
        group = np.concatenate([[0], np.cumsum(~same)])
        content = (group[:, None] == group[None, :]).astype(float) @ content
    column = np.argmax(content, axis=0)
    # each damped mode's best slot, where no two modes share one, attains the sum of the row maxima, which no
    # assignment exceeds, so it is the assignment; twins repeat their content over the group's slots (ties)
    if twins or len(np.unique(column)) < len(column):
        _, column = scipy.optimize.linear_sum_assignment(content.T, maximize=True)
    if not twins:  # a slot a group: the slots are the ranks
        return column
    # within each group the damped modes given to it take its slots in the order of their frequencies (the
    # groups ascend with the rank, so the sorted slots run group by group as the modes sorted by group do)
    ranks = np.empty(shapes.shape[1], dtype=np.intp)
    ranks[np.lexsort((frequencies, group[column]))] = np.sort(column)
    return ranks


def damped_pole_derivatives(
    mass: NDArray,
    stiffness: NDArray,
    damping: NDArray,
    lam: NDArray,
    d_mass: NDArray,
    d_stiffness: NDArray,
    d_damping: NDArray,
) -> tuple[NDArray[np.complex128], NDArray[np.complex128]]:
    """The poles of :func:`damped_poles` and their derivatives dp/dq [rad/s per unit of q] for parameters q
    with d(M, C, B)/dq given as (n_q, n, n) arrays. For symmetric M, B, C the left and right eigenvectors
    of the quadratic problem coincide (unconjugated), so

        dp = -x^T (p^2 M' + p B' + C') x / x^T (2 p M + B) x;

    shape (n_q, n); zero for a mode that does not oscillate."""
    poles, x = damped_modes(mass, stiffness, damping, lam)
    n_q = len(d_mass)
    # one stack, one matrix product: d_mass, d_damping, d_stiffness, then mass and damping
    on = modal_diagonal(x, np.concatenate((d_mass, d_damping, d_stiffness, mass[None], damping[None])))
    p = poles[None, :]
    top = p**2 * on[:n_q] + p * on[n_q : 2 * n_q] + on[2 * n_q : 3 * n_q]
    bottom = 2 * poles * on[3 * n_q] + on[3 * n_q + 1]
    oscillates = poles != 0
    return poles, np.where(oscillates[None, :], -top / np.where(oscillates, bottom, 1.0)[None, :], 0.0)


def pole_damping_ratios(p: NDArray) -> NDArray[np.float64]:
    """The damping ratios zeta = -Re p / |p| of the poles ``p``; 1 for a pole at zero (a mode that does not
    oscillate, damped_poles)."""
    size = np.abs(p)
    return np.where(size > 0, -p.real / np.where(size > 0, size, 1.0), 1.0)


def ratio_derivatives(p: NDArray, dp: NDArray) -> NDArray[np.float64]:
    """d zeta / dq, shape (n_q, n_modes), of the damping ratios zeta = -Re p / |p| of the poles ``p`` (n_modes,)
    from their derivatives ``dp`` (n_q, n_modes), d|p| = Re(conj(p) dp) / |p|; 0 for a pole at zero."""
    size = np.abs(p)
    safe = np.where(size > 0, size, 1.0)
    d_size = (np.conj(p)[None, :] * dp).real / safe
    return np.where(size > 0, -(dp.real * safe - p.real * d_size) / safe**2, 0.0)


def _vector(v: NDArray[np.float64], tiny: float) -> str:
    """A point [m] or direction as the notes print it: three significant digits, components below ``tiny`` (the
    rounding of the vector they come from) as 0, no negative zero."""
    return "(" + ", ".join(f"{x + 0.0:.3g}" for x in np.where(np.abs(v) < tiny, 0.0, v)) + ")"


def rigid_motion(q: NDArray[np.float64], length: float) -> str:
    """A small rigid-body motion in words, of any size and sign: q = (x, y, z, psi, theta, phi), translations of
    the description's origin [m] and rotations about its axes [rad] (a point p moving by t + omega x p), as "a
    translation along (d)" or "a rotation about the axis through (p) m along (d)", with its translation along the
    axis where it is a screw ("with 0.1 m along it per radian"); ``length`` [m]: the machine's length scale, below
    whose 1e-6 a rotation's share is taken for none."""
    q = np.asarray(q, dtype=float)
    t, omega = q[:3], q[3:]
    if np.linalg.norm(omega) * length <= 1e-6 * np.linalg.norm(t):
        along = t / np.linalg.norm(t)
        along = along * np.sign(along[np.argmax(np.abs(along))])
        return f"a translation along {_vector(along, 1e-9)}"
    w2 = float(omega @ omega)
    axis = omega / np.sqrt(w2)
    axis = axis * np.sign(axis[np.argmax(np.abs(axis))])
    through = np.cross(omega, t) / w2  # the axis's point nearest the origin
    pitch = float(omega @ t) / w2  # [m/rad] translation along the axis per radian
    screw = f" with {abs(pitch):.3g} m along it per radian" if abs(pitch) > 1e-6 * length else ""
    return f"a rotation about the axis through {_vector(through, 1e-9 * length)} m along {_vector(axis, 1e-9)}{screw}"


def unit_vector(direction: Sequence[float], name: str) -> NDArray[np.float64]:
    """``direction`` normalised; an InputError naming ``name`` when it is not a non-zero finite 3-vector."""
    d = np.asarray(direction, dtype=float)
    if d.shape != (3,) or not np.isfinite(d).all() or not d.any():
        raise InputError(name, f"must be a non-zero 3-vector, got {np.ravel(d).tolist()}")
    with np.errstate(over="ignore", under="ignore"):
        norm = np.linalg.norm(d)
    if not np.isfinite(norm) or norm < 1e-150:  # components near the ends of double precision: scaled first
        d = d / np.max(np.abs(d))
        norm = np.linalg.norm(d)
    return d / norm


def sensor_row(module: GeneratedModule, point: Sequence[float], direction: Sequence[float], name: str) -> NDArray:
    """d^T du/dq: what a sensor at ``point`` [m] along ``direction`` reads per unit of each coordinate."""
    return unit_vector(direction, f"{name}.direction") @ module.point_jacobian(*np.asarray(point, float))
