"""The generic numerics in mountid.runtime."""

from __future__ import annotations

import numpy as np
from conftest import budget
from hypothesis import given, settings
from hypothesis import strategies as st

from mountid import runtime
from mountid.generated import kid300
from mountid.validation.paper import TABLE_1


def test_quadratic_roots_are_stable_and_ascending():
    # roots 1e-9 and 1e9: the textbook formula loses the small root entirely
    r = runtime.quadratic_roots(1.0, -(1e9 + 1e-9), 1.0)
    np.testing.assert_allclose(r, [1e-9, 1e9], rtol=1e-15)
    np.testing.assert_array_equal(runtime.quadratic_roots(1.0, 0.0, 1.0), [np.nan, np.nan])  # complex
    np.testing.assert_array_equal(runtime.quadratic_roots(0.0, 2.0, -4.0)[0], 2.0)  # degenerates to linear


def test_newton_evaluates_only_rows_not_yet_converged():
    """The stopping rule must hold at rounding level: from the exact solution, one forward evaluation of
    the squared frequencies confirms every row and no modal matrix is formed; rows that need steps are the
    only ones evaluated again."""
    knowns = dict(TABLE_1)
    rng = np.random.default_rng(3)
    n = 1000
    c = np.column_stack([rng.uniform(3e4, 3e5, n), rng.uniform(1e5, 1e6, n)])
    known = tuple(np.full(n, knowns[a]) for a in ("m", "J_xy", "J_z", "L_xy", "L_z"))
    lam = kid300.squared_frequencies(*known, c[:, 0], c[:, 1])
    given = lam[:, [0, 3]]
    rows = []

    def model(known_, unknowns, modes):
        rows.append((len(unknowns), modes))
        return kid300._model(known_, unknowns, modes)

    x, lam_out = runtime.eigen_newton(model, known, c, (0, 3), given)
    assert rows == [(n, False)]
    np.testing.assert_array_equal(x, c)
    np.testing.assert_array_equal(lam_out, lam)
    # from 1 % off, quadratic convergence needs only a handful of steps, away from the double root of the
    # (x, psi) pair at c_xy / c_z of about 0.72 where the Jacobian is nearly singular and Newton is linear
    away = np.abs(c[:, 0] / c[:, 1] - 0.72) > 0.2
    start = c.copy()
    start[away] *= [1.01, 0.99]
    rows.clear()
    x, lam_out = runtime.eigen_newton(model, known, start, (0, 3), given)
    assert rows[0] == (n, False)
    assert all(r[0] <= away.sum() for r in rows[1:]) and len(rows) <= 6
    np.testing.assert_allclose(x[away], c[away], rtol=1e-12)
    np.testing.assert_allclose(lam_out[:, [0, 3]], given, rtol=1e-13)


def test_newton_gives_up_a_row_that_stalls():
    """A start in a minimum that is no root (kid300: c_xy / c_z where x cannot reach a given frequency
    far above it) is given up after STALL_STEPS steps without halving its residual, where it took all
    max_steps before; a row converging beside it is not held up and ends at the root."""
    knowns = dict(TABLE_1)
    known = tuple(np.full(2, knowns[a]) for a in ("m", "J_xy", "J_z", "L_xy", "L_z"))
    c = np.array([[1e5, 4e5], [1e5, 4e5]])
    lam = kid300.squared_frequencies(*known, c[:, 0], c[:, 1])
    given = lam[:, [0, 3]].copy()
    given[1, 0] = given[1, 1] * 4  # x four times psi's squared frequency: no mount gives that
    steps = []

    def model(known_, unknowns, modes):
        steps.append(len(unknowns))
        return kid300._model(known_, unknowns, modes)

    x, lam_out = runtime.eigen_newton(model, known, c * [1.1, 0.9], (0, 3), given, max_steps=40)
    np.testing.assert_allclose(lam_out[0, [0, 3]], given[0], rtol=1e-13)
    assert not np.allclose(lam_out[1, [0, 3]], given[1], rtol=1e-3)
    assert len(steps) <= runtime.inverse.STALL_STEPS + 4 < 40


def test_fused_expressions_agree_between_numexpr_and_numpy_paths():
    """Large batches go through numexpr, small ones through numpy: the same formula to rounding level."""
    rng = np.random.default_rng(7)
    n = runtime.FUSED_MIN_SIZE + 5
    p = {a: kid300.PARAMETERS[a]["value"] * rng.uniform(0.1, 10.0, n) for a in kid300.FORWARD_ARGUMENTS}
    batch = kid300.squared_frequencies(**p)  # numexpr
    pieces = np.concatenate(
        [kid300.squared_frequencies(**{a: v[i : i + 1000] for a, v in p.items()}) for i in range(0, n, 1000)]
    )  # numpy
    np.testing.assert_allclose(batch, pieces, rtol=4e-15, atol=0)
    scalar = kid300.squared_frequencies(**{a: float(v[0]) for a, v in p.items()})
    assert scalar.shape == (6,)
    np.testing.assert_allclose(scalar, batch[0], rtol=4e-15)


def test_modal_projection_and_diagonal_match_the_index_sums():
    """phi^T A phi by matrix products against the three-operand einsum they replace: batched, fewer modes than
    coordinates, and complex modes unconjugated (the damped poles' derivatives)."""
    rng = np.random.default_rng(3)
    phi = rng.normal(size=(2, 12, 5))
    stack = rng.normal(size=(2, 4, 12, 12))
    expected = np.einsum("...ak,...pab,...bl->...pkl", phi, stack, phi)
    np.testing.assert_allclose(runtime.modal_projection(phi, stack), expected, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(
        runtime.modal_diagonal(phi, stack), np.diagonal(expected, axis1=-2, axis2=-1), rtol=1e-12, atol=1e-12
    )
    x = rng.normal(size=(6, 6)) + 1j * rng.normal(size=(6, 6))
    single = rng.normal(size=(3, 6, 6))
    np.testing.assert_allclose(
        runtime.modal_diagonal(x, single), np.einsum("ak,qab,bk->qk", x, single, x), rtol=1e-12, atol=1e-12
    )


def test_stack_symmetric_sets_each_entry_and_its_mirror_in_both_paths():
    """The flat-position path of scalar inputs and the entry-by-entry path of a batch give the same matrices: each
    upper-triangle entry and its mirror set, zeros elsewhere, for a stack and for one matrix; entries built anew
    at each call (not a constant) are computed again, not kept without bound."""
    entries = ((0, 0, 0), (0, 1, 2), (2, 0, 1), (2, 2, 2))
    values = (1, 2.5, np.float64(-3.0), 4.0)
    one = runtime.stack_symmetric((), (3, 3, 3), entries, values)
    expected = np.zeros((3, 3, 3))
    for (k, i, j), v in zip(entries, values, strict=True):
        expected[k, i, j] = expected[k, j, i] = v
    assert np.array_equal(one, expected)
    batch = runtime.stack_symmetric((2,), (3, 3, 3), entries, tuple(np.array([v, 2 * v]) for v in values))
    assert np.array_equal(batch[0], expected) and np.array_equal(batch[1], 2 * expected)
    matrix = runtime.stack_symmetric((), (2, 2), ((0, 1),), (7.0,))
    assert np.array_equal(matrix, [[0.0, 7.0], [7.0, 0.0]])
    assert np.array_equal(runtime.stack_symmetric((), (2, 2), (), ()), np.zeros((2, 2)))
    for _ in range(3 * runtime.eigen._POSITIONS_KEPT):
        fresh = tuple(tuple(e) for e in [[0, 1]])
        assert runtime.stack_symmetric((), (2, 2), fresh, (1.0,))[1, 0] == 1.0
    assert len(runtime.eigen._POSITIONS) <= runtime.eigen._POSITIONS_KEPT


def test_generated_functions_give_scalars_the_numbers_of_a_batch():
    """A generated function computes with float64 scalars where every argument is a scalar (as_operands,
    batch_shape): the same numbers, to the bit, as the one row of a batch, and a batch's shape otherwise."""
    rng = np.random.default_rng(5)
    for _ in range(20):
        args = {a: float(rng.uniform(0.1, 3.0)) for a in kid300.ARGUMENTS["matrix_derivatives"]}
        one = kid300.matrix_derivatives(**args)
        batch = kid300.matrix_derivatives(**{a: np.array([v, 2 * v]) for a, v in args.items()})
        assert one.shape == batch.shape[1:]
        assert np.array_equal(one, batch[0])
        fwd = {a: args.get(a, 1.0) for a in kid300.FORWARD_ARGUMENTS}
        assert np.array_equal(
            kid300.frequencies(**fwd), kid300.frequencies(**{a: np.array([v]) for a, v in fwd.items()})[0]
        )
    assert runtime.batch_shape(*runtime.as_operands(1.0, 2, np.float64(3.0))) == ()
    assert runtime.batch_shape(*runtime.as_operands(1.0, [1.0, 2.0], np.zeros((3, 1)))) == (3, 2)
    assert all(type(x) is np.float64 for x in runtime.as_operands(1.0, 2, np.float64(3.0)))


@settings(max_examples=budget(60), deadline=None)
@given(
    distinct=st.lists(st.floats(0.1, 10.0), min_size=1, max_size=4),
    picks=st.lists(st.tuples(st.integers(0, 3), st.floats(-2e-9, 2e-9), st.booleans()), min_size=1, max_size=40),
    columns=st.integers(1, 3),
)
def test_repeated_roots_are_dropped_as_by_comparing_each_with_every_earlier_one(distinct, picks, columns):
    """inverse._drop_repeats (rounds over the kept roots) against the definition: a root is dropped when it lies
    within DUPLICATE_RTOL of an earlier admissible root of its row, comparing each with every earlier one in turn.
    Roots drawn from a few distinct values with relative jitter around the tolerance, some not admissible."""
    from mountid.runtime import inverse

    rng = np.random.default_rng(len(picks) * 7 + columns)
    x = np.empty((len(picks), columns, 2))
    ok = np.empty((len(picks), columns), dtype=bool)
    for i, (k, jitter, admissible) in enumerate(picks):
        base = distinct[k % len(distinct)]
        x[i] = base * (1 + jitter * rng.uniform(0, 1, (columns, 2)))  # within or beyond the tolerance, 1e-9
        ok[i] = admissible ^ (rng.uniform(size=columns) < 0.2)
    expected = ok.copy()
    for i in range(1, len(picks)):
        same = np.all(np.abs(x[i] - x[:i]) <= inverse.DUPLICATE_RTOL * np.abs(x[:i]), axis=-1)
        expected[i] &= ~np.any(same & expected[:i], axis=0)
    got = ok.copy()
    inverse._drop_repeats(x, got)
    assert np.array_equal(got, expected)
