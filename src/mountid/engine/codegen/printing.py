"""Sympy expressions to numpy source lines: common-subexpression elimination and printing.

Temporaries are named ``_tmp0``, ``_tmp1``, ... in the order cse produces them; the printer writes
``numpy.<function>`` so the emitted code needs nothing but ``import numpy``.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import sympy as sp
from sympy.printing.lambdarepr import NumExprPrinter
from sympy.printing.numpy import NumPyPrinter

from mountid.engine.codegen.layouts import Filled, Function, Mapping, Matrices, Step


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


def _map_leaves(obj: object, leaf: Callable, step: Callable) -> object:
    """``obj`` with every sympy leaf replaced by ``leaf(expr)`` and every Step by ``step(s)``, walking
    dataclasses (field order) and tuples; anything else is kept."""
    if isinstance(obj, sp.Basic):
        return leaf(obj)
    if isinstance(obj, Step):
        return step(obj)
    if dataclasses.is_dataclass(obj):
        fields = {f.name: _map_leaves(getattr(obj, f.name), leaf, step) for f in dataclasses.fields(obj)}
        return dataclasses.replace(obj, **fields)
    if isinstance(obj, tuple):
        return tuple(_map_leaves(o, leaf, step) for o in obj)
    return obj


def print_function(fn: Function) -> Function:
    """``fn`` printed in one pass: its layout's sympy leaves as source text, by one cse over all of them
    (``fn.cse``, temporaries ``_tmp0..n`` into ``fn.temporaries``) or each alone, with the numpy or the numexpr
    printer (``fn.printer``); each Step after them with its own cse, numbered on."""
    leaves: list[sp.Expr] = []
    _map_leaves(fn.layout, leaves.append, lambda s: s)
    printer = {"numpy": code, "numexpr": fused}[fn.printer]
    if fn.cse:
        done = eliminate(leaves)
        temporaries, texts = done.lines, iter(done.outputs)
    else:
        temporaries, texts = (), iter([printer(e) for e in leaves])
    count = len(temporaries)

    def step(s: Step) -> Step:
        nonlocal count
        done = eliminate([s.value], start=count)
        count += len(done.lines)
        return Step(s.unknown, done.outputs[0], done.lines)

    layout = _map_leaves(fn.layout, lambda _: next(texts), step)
    return dataclasses.replace(fn, layout=layout, temporaries=temporaries, depends=_depends(fn, leaves))


def _depends(fn: Function, leaves: list[sp.Expr]) -> tuple[str, ...] | None:
    """The arguments of ``fn`` its result depends on (Function.depends), from its sympy ``leaves`` before printing
    and the calls its layout makes; None for a layout with more in its body than these (a solve, an inverse)."""
    if not isinstance(fn.layout, Matrices | Filled | Mapping):
        return None
    used = {s.name for e in leaves for s in e.free_symbols}
    if isinstance(fn.layout, Matrices):
        used |= {a for call in fn.layout.bases for a in call.args}
    return tuple(a for a in fn.args if a in used)
