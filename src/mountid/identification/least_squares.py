"""Nonlinear least squares as scipy.optimize.least_squares solves it with the trust-region reflective method, called
past least_squares' wrapper where scipy's private layout allows: one home for the fits of the identification (the
stiffnesses from frequencies) and of the gap diagnosis (every candidate effect).

least_squares wraps the residuals and the Jacobian in a VectorFunction that copies the point and compares it with
the last one at every call: 6-9 % of a gap diagnosis over its hundred fits, and about a tenth of the gap report's
small fits of the stiffnesses to a few frequencies (genset8: 94 ms instead of 106 per report). Where scipy's
private modules have the layout this was written for (_TRF), :func:`trust_region` calls the iteration itself
with the arguments least_squares would give it, and so returns the same numbers (tests/test_least_squares.py);
otherwise it calls least_squares.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable

import numpy as np
import scipy.optimize

VectorFunction = Callable[[np.ndarray], np.ndarray]
"""A function of the parameter vector: the weighted residual rows, or their Jacobian."""

GTOL = 1e-8
"""least_squares' default gtol, passed to its trust-region iteration where trust_region calls it directly."""


def trust_region(
    fun: VectorFunction,
    jac: VectorFunction,
    x0: np.ndarray,
    lo: np.ndarray | float = -np.inf,
    hi: np.ndarray | float = np.inf,
    *,
    ftol: float,
    xtol: float,
    max_nfev: int | None = None,
    x_scale: str | float = 1.0,
    callback: Callable | None = None,
) -> scipy.optimize.OptimizeResult:
    """scipy.optimize.least_squares(fun, x0, jac=jac, bounds=(lo, hi), method="trf", ftol=ftol, xtol=xtol,
    max_nfev=max_nfev, x_scale=x_scale, callback=callback), the same numbers with fewer calls (module
    docstring). Raises ValueError as least_squares does where the residuals at the start are not finite (and,
    from scipy's iteration, where a Jacobian is not). The result has every field of least_squares' but message and
    success (status > 0 is success)."""
    if _TRF is None:
        return scipy.optimize.least_squares(
            fun,
            x0,
            jac=jac,
            bounds=(lo, hi),
            method="trf",
            ftol=ftol,
            xtol=xtol,
            max_nfev=max_nfev,
            x_scale=x_scale,
            callback=callback,
        )
    trf, strictly_feasible = _TRF
    x0 = np.atleast_1d(x0).astype(float)
    lo = np.resize(np.asarray(lo, dtype=float), x0.shape)
    hi = np.resize(np.asarray(hi, dtype=float), x0.shape)
    x0 = strictly_feasible(x0, lo, hi)
    scale = x_scale if isinstance(x_scale, str) else np.resize(np.asarray(x_scale, dtype=float), x0.shape)
    f0 = fun(x0)
    if not np.all(np.isfinite(f0)):
        raise ValueError("Residuals are not finite in the initial point.")
    return trf(fun, jac, x0, f0, jac(x0), lo, hi, ftol, xtol, GTOL, max_nfev, scale, None, "exact", {}, 0, callback)


def _scipy_trf() -> tuple[Callable, Callable] | None:
    """scipy's trust-region reflective iteration (scipy.optimize._lsq.trf.trf, private) and the step least_squares
    takes into the bounds' interior before it, where their signatures are those of scipy 1.16-1.17; None
    otherwise (trust_region then calls least_squares)."""
    try:
        from scipy.optimize._lsq.common import make_strictly_feasible
        from scipy.optimize._lsq.trf import trf
    except ImportError:  # another layout of scipy's private modules
        return None
    expected = (
        "fun jac x0 f0 J0 lb ub ftol xtol gtol max_nfev x_scale loss_function tr_solver tr_options verbose callback"
    )
    if " ".join(inspect.signature(trf).parameters) != expected:
        return None
    if list(inspect.signature(make_strictly_feasible).parameters) != ["x", "lb", "ub", "rstep"]:
        return None
    return trf, make_strictly_feasible


_TRF = _scipy_trf()
"""(trf, make_strictly_feasible) of scipy's private least-squares modules, or None (see trust_region)."""
