"""Factoring with a fixed random state.

sympy factors multivariate polynomials by Wang's algorithm, which draws random evaluation points from
sympy's module-level generator (seeded afresh in every process). The factors are unique, but the time is
not: the same generation took 48 s in one run and more than 10 minutes in the next. Seeding before every
call makes the time, like the output, a function of the expression alone.
"""

from __future__ import annotations

import sympy as sp
from sympy.core import random as _sympy_random

SEED = 0
"""The seed of sympy's generator before every factorisation."""


def factor(expr: sp.Expr) -> sp.Expr:
    """sympy.factor(expr) with sympy's random generator seeded by :data:`SEED`."""
    _sympy_random.seed(SEED)
    return sp.factor(expr)


def factor_list(expr: sp.Expr, *gens: sp.Symbol) -> tuple:
    """sympy.factor_list(expr, *gens) with sympy's random generator seeded by :data:`SEED`."""
    _sympy_random.seed(SEED)
    return sp.factor_list(expr, *gens)
