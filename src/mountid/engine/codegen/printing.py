"""Sympy expressions to numpy source lines: common-subexpression elimination and printing.

Temporaries are named ``_tmp0``, ``_tmp1``, ... in the order cse produces them; the printer writes
``numpy.<function>`` so the emitted code needs nothing but ``import numpy``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import sympy as sp
from sympy.printing.lambdarepr import NumExprPrinter
from sympy.printing.numpy import NumPyPrinter


class _Printer(NumPyPrinter):
    def __init__(self) -> None:
        super().__init__({"fully_qualified_modules": True, "inline": True, "allow_unknown_functions": False})

    def _print_Rational(self, expr: sp.Rational) -> str:
        # exact rationals as float literals: 1/2 -> 0.5, 1/3 -> 0.3333333333333333
        if expr.q == 1:
            return str(int(expr.p))
        return repr(float(expr))


_PRINTER = _Printer()


class _FusedPrinter(NumExprPrinter):
    """Plain numexpr expression strings: numbers as float literals (numexpr knows no math.pi)."""

    def _print_Rational(self, expr: sp.Rational) -> str:
        return str(int(expr.p)) if expr.q == 1 else repr(float(expr))

    def _print_Pi(self, expr: sp.Expr) -> str:
        return repr(float(expr))


_FUSED = _FusedPrinter()


def fused(expr: sp.Expr) -> str:
    """One expression as a numexpr string (evaluated in one cache-blocked pass by runtime.fused)."""
    return _FUSED._print(expr)


def code(expr: sp.Expr) -> str:
    """One expression as numpy source."""
    return _PRINTER.doprint(expr)


@dataclass(frozen=True)
class Assignments:
    """Lines ``name = expression`` (temporaries first), then the outputs as expressions of them."""

    lines: tuple[tuple[str, str], ...]
    outputs: tuple[str, ...]


def eliminate(exprs: Sequence[sp.Expr], prefix: str = "_tmp", start: int = 0) -> Assignments:
    """Common-subexpression elimination of ``exprs`` into numbered temporaries.

    ``start`` offsets the numbering so that several groups in one function do not collide.
    """
    symbols = sp.numbered_symbols(prefix, start=start)
    replacements, reduced = sp.cse(list(exprs), symbols=symbols, order="canonical")
    return Assignments(
        tuple((str(s), code(e)) for s, e in replacements),
        tuple(code(e) for e in reduced),
    )


def describe(expr: sp.Expr) -> str:
    """Compact one-line text of an expression for docstrings."""
    return sp.sstr(expr, order="none")
