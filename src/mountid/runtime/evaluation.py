"""Evaluation of generated expressions and stable polynomial roots (numpy; numexpr, when installed, for
large batches). All functions broadcast over leading batch dimensions."""

from __future__ import annotations

import functools
from types import CodeType

import numpy as np
from numpy.typing import ArrayLike, NDArray

try:  # the optional "fast" extra: one cache-blocked, threaded pass for large batches
    import numexpr
except ImportError:  # pragma: no cover - exercised by the core-install check (make core-check)
    numexpr = None

FUSED_MIN_SIZE = 4096
"""Batches from this size on are evaluated by numexpr (when installed); smaller ones by numpy, whose
per-call overhead is lower (numexpr parses and checks each call)."""

_NUMPY_FUNCTIONS = {"sqrt": np.sqrt, "sin": np.sin, "cos": np.cos, "tan": np.tan, "exp": np.exp, "log": np.log}


@functools.cache
def _compiled(expression: str) -> CodeType:
    return compile(expression, "<generated expression>", "eval")


def fused(expression: str, variables: dict, out: NDArray[np.float64]) -> NDArray[np.float64]:
    """Evaluate a generated elementwise expression into ``out``, the variables broadcast to out's shape.

    Large batches go through numexpr in one cache-blocked pass (a chain of numpy operations on them is bound
    by memory traffic and the first touch of every temporary); numexpr splits them over its threads
    (NUMEXPR_NUM_THREADS, numexpr.set_num_threads). Small ones use numpy (same formula, same operations)."""
    if numexpr is not None and out.size >= FUSED_MIN_SIZE:
        return numexpr.evaluate(expression, local_dict=variables, out=out, casting="unsafe")
    out[...] = eval(_compiled(expression), {"__builtins__": {}, **_NUMPY_FUNCTIONS}, variables)
    return out


def as_arrays(*args: ArrayLike) -> list[NDArray[np.float64]]:
    """Inputs as float arrays (no copies for float arrays)."""
    return [np.asarray(a, dtype=float) for a in args]


SCALAR_TYPES = frozenset((float, int, np.float64))
"""The types a generated function takes as a scalar (as_operands; machine.call keeps its results for them)."""


def as_operands(*args: ArrayLike) -> list[np.float64 | NDArray[np.float64]]:
    """The arguments of a generated function as its operands: a scalar (Python or numpy) as a numpy float64
    scalar, anything else as a float array (no copies for float arrays). A candidate fit calls generated
    functions with scalars 10^5 times per diagnosis: arithmetic on float64 scalars costs about half that on 0-d
    arrays, with the same IEEE results (the same ufuncs and C math)."""
    return [np.float64(a) if type(a) in SCALAR_TYPES else np.asarray(a, dtype=float) for a in args]


def batch_shape(*args: np.float64 | NDArray[np.float64]) -> tuple[int, ...]:
    """The shape the operands broadcast to (``numpy.broadcast_shapes`` of theirs): () at once when every one is
    a scalar. Read from their ``shape`` attributes (calling numpy.shape on 40 arguments costs ten times as
    much); numpy.shape only where an argument has none (a function generated without as_operands, given a
    Python float)."""
    try:
        shapes = [a.shape for a in args]
    except AttributeError:
        shapes = [np.shape(a) for a in args]
    if not any(shapes):
        return ()
    return np.broadcast_shapes(*shapes)


def linear_root(a1: ArrayLike, a0: ArrayLike) -> NDArray[np.float64]:
    """Root of a1 t + a0 = 0, shape (1, *batch)."""
    a1, a0 = np.broadcast_arrays(*as_arrays(a1, a0))
    with np.errstate(divide="ignore", invalid="ignore"):
        return (-a0 / a1)[np.newaxis]


def quadratic_roots(a: ArrayLike, b: ArrayLike, c: ArrayLike) -> NDArray[np.float64]:
    """Both real roots of a t^2 + b t + c = 0 without cancellation, ascending, shape (2, *batch).

    q = -(b + sign(b) sqrt(b^2 - 4ac)) / 2, roots q/a and c/q: no difference of nearly equal numbers.
    A discriminant that is negative only by rounding (|disc| < 1e-12 b^2) is taken as zero (double root);
    a clearly negative one gives NaN (no real root). a = 0 degrades to the linear root and a NaN.
    """
    a, b, c = np.broadcast_arrays(*as_arrays(a, b, c))
    disc = b * b - 4.0 * a * c
    disc = np.where((disc < 0) & (disc > -1e-12 * b * b), 0.0, disc)
    with np.errstate(divide="ignore", invalid="ignore"):
        q = -0.5 * (b + np.copysign(np.sqrt(disc), b))
        r1 = np.where(a != 0, q / a, np.nan)
        r2 = np.where(q != 0, c / q, np.where(a != 0, 0.0, np.nan))
        r2 = np.where(a == 0, -c / b, r2)
        one_missing = np.isnan(r1) | np.isnan(r2)
        lo = np.where(np.isnan(r1), r2, np.where(np.isnan(r2), r1, np.fmin(r1, r2)))
        hi = np.where(one_missing, np.nan, np.fmax(r1, r2))
    return np.stack([lo, hi])


def polynomial_roots(*coefficients: ArrayLike) -> NDArray[np.float64]:
    """Real roots of a polynomial (coefficients highest degree first), shape (degree, *batch).

    Degree 1 and 2 use :func:`linear_root` and :func:`quadratic_roots`; higher degrees the eigenvalues of the
    batched companion matrix. Complex roots (imaginary part above 1e-9 of the modulus) become NaN.
    """
    deg = len(coefficients) - 1
    if deg == 1:
        return linear_root(*coefficients)
    if deg == 2:
        return quadratic_roots(*coefficients)
    coeffs = np.broadcast_arrays(*as_arrays(*coefficients))
    batch = coeffs[0].shape
    lead = coeffs[0]
    comp = np.zeros((*batch, deg, deg))
    for j in range(deg):
        comp[..., 0, j] = -coeffs[j + 1] / lead
    comp[..., np.arange(1, deg), np.arange(deg - 1)] = 1.0
    roots = np.linalg.eigvals(comp)
    real = np.where(np.abs(roots.imag) <= 1e-9 * np.abs(roots), roots.real, np.nan)
    return np.moveaxis(np.sort(real, axis=-1), -1, 0)
