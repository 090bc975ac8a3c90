"""What an expression of a machine description may hold, checked on its text before sympy reads it.

sympy's ``parse_expr`` evaluates the text with Python's ``eval``: a description whose point read
``m.__class__.__mro__[-1].__subclasses__()[k].__init__.__globals__['system']('...') * 0 + m`` ran a shell command
when the machine was derived, and ``10**10**10`` never returned. A description is data: its expressions are
arithmetic (+, -, *, /, **) on names and numbers, and calls of the allowed functions by name, nothing else.
"""

from __future__ import annotations

import ast
import math
import operator
from collections.abc import Callable

from mountid.errors import DescriptionError

FUNCTIONS: dict[str, float | Callable[[float], float]] = {
    "sqrt": math.sqrt,
    "sin": math.sin,
    "cos": math.cos,
    "tan": math.tan,
    "pi": math.pi,
}
"""The functions (and the constant pi) an expression may name, each with its floating-point value for the check
of constant exponents; sympy's of the same name is the one the engine derives with."""

MAX_CONSTANT_EXPONENT = 64
"""Largest |exponent| of a power whose exponent holds no name (10**10**10 would take sympy forever in exact
integers; a description's powers are squares, roots and the like)."""

_BINARY: dict[type, Callable[[float, float], float]] = {
    ast.Add: operator.add,
    ast.Sub: operator.sub,
    ast.Mult: operator.mul,
    ast.Div: operator.truediv,
    ast.Pow: operator.pow,
}
_UNARY: dict[type, Callable[[float], float]] = {ast.UAdd: operator.pos, ast.USub: operator.neg}


def check_expression(text: str, entry: str) -> None:
    """Raise DescriptionError naming ``entry`` unless ``text`` is arithmetic (+, -, *, /, ** and parentheses) on
    names, integer and decimal numbers and calls by name of FUNCTIONS (positional arguments only). Which names
    the description declares is checked after parsing; this only keeps anything else (attributes, subscripts,
    strings, comparisons, comprehensions, lambdas) from being evaluated, and bounds constant exponents by
    MAX_CONSTANT_EXPONENT."""
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except (SyntaxError, ValueError) as exc:  # ValueError: an integer literal beyond Python's digit limit
        raise DescriptionError(entry, f"cannot read expression {_quoted(text)} ({type(exc).__name__})") from None
    _check(tree.body, text, entry)


def _check(node: ast.expr, text: str, entry: str) -> None:
    if isinstance(node, ast.Constant) and type(node.value) in (int, float):
        return
    if isinstance(node, ast.Name):
        return
    if isinstance(node, ast.UnaryOp) and type(node.op) in _UNARY:
        _check(node.operand, text, entry)
        return
    if isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
        _check(node.left, text, entry)
        _check(node.right, text, entry)
        if isinstance(node.op, ast.Pow) and all(  # no parameter in the exponent: a number sympy computes
            n.id in FUNCTIONS for n in ast.walk(node.right) if isinstance(n, ast.Name)
        ):
            exponent = _constant(node.right)
            if not abs(exponent) <= MAX_CONSTANT_EXPONENT:
                raise DescriptionError(
                    entry,
                    f"{_quoted(text)} raises to the power {ast.unparse(node.right)}: a constant exponent beyond "
                    f"{MAX_CONSTANT_EXPONENT} in magnitude (or not a real number) is no description's",
                )
        return
    if (
        isinstance(node, ast.Call)
        and isinstance(node.func, ast.Name)
        and callable(FUNCTIONS.get(node.func.id))
        and not node.keywords
        and not any(isinstance(a, ast.Starred) for a in node.args)
    ):
        for argument in node.args:
            _check(argument, text, entry)
        return
    hint = "; a power is written **" if isinstance(node, ast.BinOp) and isinstance(node.op, ast.BitXor) else ""
    raise DescriptionError(
        entry,
        f"{_quoted(text)} is not arithmetic on the parameters: {_quoted(ast.unparse(node))} is not allowed (+, -, "
        f"*, /, **, parentheses, numbers, parameter names, {', '.join(FUNCTIONS)}){hint}",
    )


def _quoted(text: str, limit: int = 80) -> str:
    """``text`` quoted for a one-line message, cut to ``limit`` characters."""
    return repr(text if len(text) <= limit else text[: limit - 3] + "...")


def _constant(node: ast.expr) -> float:
    """The value of a checked subtree without parameters, in floating point (nan where it overflows, divides by
    zero or leaves the reals, which the caller rejects)."""
    try:
        return _value(node)
    except (OverflowError, ZeroDivisionError, ValueError, TypeError):
        return math.nan


def _value(node: ast.expr) -> float:
    if isinstance(node, ast.Constant):
        return float(node.value)
    if isinstance(node, ast.Name):
        return float(FUNCTIONS[node.id])  # pi (a function standing alone is a TypeError: nan)
    if isinstance(node, ast.Call):
        function = FUNCTIONS[node.func.id]
        return float(function(*map(_value, node.args)))
    if isinstance(node, ast.UnaryOp):
        return _UNARY[type(node.op)](_value(node.operand))
    if isinstance(node, ast.BinOp):  # an inner power's exponent was bounded before (_check visits it first)
        result = _BINARY[type(node.op)](_value(node.left), _value(node.right))
        return math.nan if isinstance(result, complex) else float(result)
    return math.nan
