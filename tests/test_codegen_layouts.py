"""Code generation as data: every layout has its template macro, printing leaves no sympy behind, and a
function laid out by its macro evaluates to its sympy expressions."""

from __future__ import annotations

import dataclasses
import types
import typing

import numpy as np
import sympy as sp

from mountid.engine.codegen import layouts
from mountid.engine.codegen.formatting import format_source
from mountid.engine.codegen.numpy_module import _environment
from mountid.engine.codegen.printing import print_function

a, b, c, x = sp.symbols("a b c x", positive=True)


def _leaves(obj):
    if isinstance(obj, sp.Basic):
        yield obj
    elif dataclasses.is_dataclass(obj):
        for f in dataclasses.fields(obj):
            yield from _leaves(getattr(obj, f.name))
    elif isinstance(obj, tuple):
        for o in obj:
            yield from _leaves(o)


def _build(fn: layouts.Function) -> types.FunctionType:
    """``fn`` laid out by its macro alone, formatted and executed; the generated function."""
    source = _environment().from_string(
        '{% import "numpy_layouts.jinja" as layouts %}import numpy\n\nfrom mountid import runtime as _runtime\n\n\n'
        "def {{ fn.name }}({{ fn.args|join(', ') }}):\n{{ layouts[fn.macro](fn) }}"
    )
    namespace: dict = {}
    exec(format_source(source.render(fn=fn)), namespace)  # the code under test
    return namespace[fn.name]


def test_every_layout_has_its_macro():
    macros = _environment().get_template("numpy_layouts.jinja").module
    for cls in typing.get_args(layouts.Layout):
        fn = layouts.Function("f", (), "", cls.__new__(cls))
        assert callable(getattr(macros, fn.macro, None)), f"no macro {fn.macro} for {cls.__name__}"


def test_printing_leaves_no_sympy_and_numbers_steps_on():
    roots = layouts.Roots(
        ((a * b + c, -(a * b + c) * c),),
        "x",
        (layouts.Step("y", (a * b + 1) * x + (a * b + 1) ** 2),),
        ("x", "y"),
    )
    printed = print_function(layouts.Function("_roots", ("a", "b", "c"), "", roots, convert=False))
    assert not list(_leaves(printed.layout))
    names = [n for n, _ in printed.temporaries] + [n for n, _ in printed.layout.steps[0].temporaries]
    assert names == [f"_tmp{k}" for k in range(len(names))] and len(printed.layout.steps[0].temporaries) == 1
    f = _build(printed)
    xs, ys = f(2.0, 3.0, 5.0)
    assert np.allclose(xs, [5.0]) and np.allclose(ys, [(6 + 1) * 5.0 + 49.0])


def test_matrices_laid_out_by_the_macro_match_sympy():
    m1 = sp.Matrix([[a + b, a * c, 0], [a * c, b, 0], [0, 0, c**2]])
    m2 = m1.diff(a)
    base = layouts.Call("base", ("a",))
    point = {a: 1.5, b: 2.0, c: 0.7}
    expected = [np.array(m.subs(point), dtype=float) for m in (m1, m2)]
    cases = {
        None: lambda out: out,
        (): lambda out: list(np.moveaxis(out, -3, 0)),
        (2, 3, 3): lambda out: list(out),
    }
    for stacked, unpack in cases.items():
        layout = layouts.Matrices(tuple(map(layouts.SymmetricMatrix.of, (m1, m2))), stacked=stacked)
        f = _build(print_function(layouts.Function("f", ("a", "b", "c"), "", layout)))
        got = unpack(f(1.5, 2.0, 0.7))
        assert all(np.allclose(g, e, rtol=1e-15) for g, e in zip(got, expected, strict=True))
    layout = layouts.Matrices((layouts.SymmetricMatrix.of(m1),), bases=(base, base))
    f = _build(print_function(layouts.Function("f", ("a", "b", "c"), "", layout)))
    f.__globals__["base"] = lambda a: np.full((3, 3), a)
    summed, extra = f(1.5, 2.0, 0.7)
    assert np.allclose(summed, expected[0] + 1.5) and np.allclose(extra, 1.5)


def test_closed_form_eigen_plain_and_fused_agree():
    # a 2x2 block with M = diag(1, 1), C = [[a, c], [c, b]] and a 1x1 block b/a
    block = layouts.PairBlock(("u", "v"), 1, 0, a, b, c**2, a * b - c**2)
    single = layouts.SingleBlock(("w",), 2, b / a)
    point = (1.5, 2.0, 0.7)
    expected = np.linalg.eigvalsh([[1.5, 0.7], [0.7, 2.0]])
    for fused in (False, True):
        layout = layouts.ClosedFormEigen(4, (block, single), ((3, 2),), fused)
        printer = "numexpr" if fused else "numpy"
        f = _build(print_function(layouts.Function("f", ("a", "b", "c"), "", layout, cse=False, printer=printer)))
        lam = f(*(np.asarray(p) for p in point))
        assert np.allclose(lam, [*expected, 2.0 / 1.5, 2.0 / 1.5], rtol=1e-14)


def test_printing_records_the_arguments_a_result_depends_on():
    """Function.depends: the free symbols of the leaves and the arguments of the calls a matrices layout adds
    to, in the order of the signature; None where the layout holds more than leaves and calls (an eigen-solve)."""
    matrix = layouts.SymmetricMatrix.of(sp.Matrix([[a * x, 0], [0, 2 * a]]))
    base = layouts.Call("stiffness_matrix", ("b",))
    fn = layouts.Function("f", ("a", "b", "c", "x"), "", layouts.Matrices((matrix,), (base,)))
    assert print_function(fn).depends == ("a", "b", "x")
    filled = layouts.Function("g", ("a", "c"), "", layouts.Filled((1, 1), ((0, 0, 3 * c),)), cse=False)
    assert print_function(filled).depends == ("c",)
    mass, stiffness = layouts.Call("mass_matrix", ("a",)), layouts.Call("stiffness_matrix", ("b",))
    eigen = layouts.Function("h", ("a", "b"), "", layouts.NumericEigen(mass, stiffness, ()))
    assert print_function(eigen).depends is None
