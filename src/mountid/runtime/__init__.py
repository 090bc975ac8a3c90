"""Numerics shared by the generated modules (numpy; numexpr, when installed, for large batches), no
machine-specific formulas.

Everything that depends on a machine (matrix entries, characteristic-polynomial coefficients, back-
substitutions) is generated from sympy; this module holds the generic numerical steps applied to them:
fused evaluation of generated expressions, stable polynomial roots, generalised symmetric eigen-solves of
small blocks, mode-shape normalisation, the Newton polish and the admissibility filter of inverse roots.
All functions broadcast over leading batch dimensions.
"""

from mountid.runtime.eigen import (
    EQUAL_EIGENVALUES,
    block_eigen,
    eigen_derivatives,
    eigen_jacobian,
    eigenvalue_derivatives,
    kinetic_energy_distribution,
    modal_diagonal,
    modal_matrix,
    modal_projection,
    stack_symmetric,
)
from mountid.runtime.evaluation import (
    FUSED_MIN_SIZE,
    SCALAR_TYPES,
    as_arrays,
    as_operands,
    batch_shape,
    fused,
    linear_root,
    polynomial_roots,
    quadratic_roots,
)
from mountid.runtime.inverse import (
    ADMISSIBILITY_RTOL,
    DUPLICATE_RTOL,
    MAX_RELATIVE_STEP,
    NEWTON_RESIDUAL_RTOL,
    RANK_RTOL,
    InverseRoots,
    admissible,
    eigen_newton,
    solve_inverse,
    start_grid,
)

__all__ = [
    "ADMISSIBILITY_RTOL",
    "DUPLICATE_RTOL",
    "EQUAL_EIGENVALUES",
    "FUSED_MIN_SIZE",
    "MAX_RELATIVE_STEP",
    "NEWTON_RESIDUAL_RTOL",
    "RANK_RTOL",
    "SCALAR_TYPES",
    "InverseRoots",
    "admissible",
    "as_arrays",
    "as_operands",
    "batch_shape",
    "block_eigen",
    "eigen_derivatives",
    "eigen_jacobian",
    "eigen_newton",
    "eigenvalue_derivatives",
    "fused",
    "kinetic_energy_distribution",
    "linear_root",
    "modal_diagonal",
    "modal_matrix",
    "modal_projection",
    "polynomial_roots",
    "quadratic_roots",
    "solve_inverse",
    "stack_symmetric",
    "start_grid",
]
