"""The covariance of least-squares parameters, one definition for identification and diagnosis."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray


def covariance(jacobian: NDArray, chi2: float, dof: int, *, stated_std: bool = True) -> NDArray[np.float64]:
    """Covariance of the parameters of a linear(ised) least-squares fit, pinv(J^T J) s, from the Jacobian of
    the residuals (n_residuals x n_parameters) at the solution, its chi^2 (sum of squared residuals) and its
    degrees of freedom (n_residuals - n_parameters).

    ``stated_std``: the residuals are in units of their stated standard deviations; s = max(1, chi^2/dof)
    inflates the covariance when the data scatter more than stated and never shrinks it (s = 1 without
    degrees of freedom). Otherwise the residuals carry no stated scale and s = chi^2 / max(dof, 1) estimates
    their variance. pinv: a parameter the data do not determine gets its minimum-norm variance, not inf."""
    jac = np.asarray(jacobian, dtype=float)
    if stated_std:
        scale = max(1.0, chi2 / dof) if dof > 0 else 1.0
    else:
        scale = chi2 / max(dof, 1)
    return np.linalg.pinv(jac.T @ jac) * scale


def standard_deviations(cov: NDArray) -> NDArray[np.float64]:
    """sqrt of the covariance's diagonal (rounding below zero taken as 0)."""
    return np.sqrt(np.maximum(np.diag(cov), 0.0))
