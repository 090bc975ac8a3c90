"""Damped poles of the machine layer (mountid.machine.dynamics): which undamped mode each pole belongs to."""

from __future__ import annotations

import importlib
import inspect

import numpy as np
import pytest
import scipy.linalg
import scipy.optimize
import scipy.stats

import mountid.generated.screen6 as screen6
from mountid.machine import (
    call,
    damped_modes,
    damped_poles,
    dynamics,
    pair_with_undamped,
    rigid_motion,
    shipped_machines,
    state_matrix,
    undamped_modes,
)


def _uncoupled_in_a_turned_basis(c: list[float], b: list[float], seed: int = 0):
    """M = I, C = Q diag(c) Q^T, B = Q diag(b) Q^T: mode k is one degree of freedom of stiffness c[k] and
    damping b[k] in the basis Q, with the pole -b/2 + i sqrt(c - b^2/4) (0 when it does not oscillate)."""
    q = scipy.stats.special_ortho_group.rvs(len(c), random_state=seed)
    mass = np.eye(len(c))
    stiffness, damping = q @ np.diag(c) @ q.T, q @ np.diag(b) @ q.T
    exact = np.array(
        [complex(-bk / 2, np.sqrt(ck - bk**2 / 4)) if ck > bk**2 / 4 else 0j for ck, bk in zip(c, b, strict=True)]
    )
    return mass, stiffness, damping, exact


def test_heavy_damping_that_reorders_two_close_modes_does_not_swap_their_labels():
    """Two modes at 10 and 10.2 rad/s: damping the upper one at zeta 0.59 puts its damped frequency (8.3 rad/s)
    below the lower one's. Pairing by damped frequency would swap them; the poles stay with their shapes."""
    mass, stiffness, damping, exact = _uncoupled_in_a_turned_basis([100.0, 104.0, 400.0], [0.5, 12.0, 1.0])
    assert exact[1].imag < exact[0].imag  # the reordering this test is about
    lam = np.array([100.0, 104.0, 400.0])
    assert damped_poles(mass, stiffness, damping, lam) == pytest.approx(exact, rel=1e-12)
    # the modes in another order: the poles follow lam, not their position
    turned = lam[[2, 0, 1]]
    assert damped_poles(mass, stiffness, damping, turned) == pytest.approx(exact[[2, 0, 1]], rel=1e-12)


def test_a_lightly_damped_mount_is_paired_as_by_frequency():
    mass, stiffness, damping, exact = _uncoupled_in_a_turned_basis([50.0, 80.0, 120.0, 300.0], [0.2, 0.3, 0.1, 0.5], 3)
    assert damped_poles(mass, stiffness, damping, np.array([50.0, 80.0, 120.0, 300.0])) == pytest.approx(exact)


def test_twins_take_their_damped_modes_in_frequency_order_whatever_basis_eigh_returns():
    """Two undamped modes at exactly 100 rad^2/s^2 have no preferred basis: both damped modes belong to the
    pair, the lower damped frequency to the first slot."""
    mass, stiffness, damping, exact = _uncoupled_in_a_turned_basis([100.0, 100.0, 150.0], [1.0, 3.0, 1.0], 5)
    poles = damped_poles(mass, stiffness, damping, np.array([100.0, 100.0, 150.0]))
    assert poles[:2] == pytest.approx(sorted(exact[:2], key=lambda p: p.imag), rel=1e-9)
    assert poles[2] == pytest.approx(exact[2], rel=1e-9)


def test_a_mode_that_does_not_oscillate_has_no_pole_and_the_others_keep_their_labels():
    mass, stiffness, damping, exact = _uncoupled_in_a_turned_basis([100.0, 110.0, 200.0], [0.5, 30.0, 1.0], 2)
    assert exact[1] == 0
    assert damped_poles(mass, stiffness, damping, np.array([100.0, 110.0, 200.0])) == pytest.approx(exact)


def test_pair_with_undamped_is_one_to_one():
    rng = np.random.default_rng(4)
    a = rng.standard_normal((6, 6))
    mass = a @ a.T + 6 * np.eye(6)
    b = rng.standard_normal((6, 6))
    stiffness = 100 * (b @ b.T + np.eye(6))
    damping = 0.3 * np.abs(b @ b.T)
    poles, vectors = np.linalg.eig(state_matrix(mass, stiffness, damping))
    upper = poles.imag > 0
    ranks = pair_with_undamped(mass, stiffness, vectors[:6, upper], poles[upper].imag)
    assert sorted(ranks) == list(range(6))


def test_three_twins_take_their_damped_modes_in_frequency_order():
    mass, stiffness, damping, exact = _uncoupled_in_a_turned_basis(
        [100.0, 100.0, 100.0, 150.0], [1.0, 3.0, 2.0, 1.0], 7
    )
    poles = damped_poles(mass, stiffness, damping, np.array([100.0, 100.0, 100.0, 150.0]))
    assert poles[:3] == pytest.approx(sorted(exact[:3], key=lambda p: p.imag), rel=1e-9)
    assert poles[3] == pytest.approx(exact[3], rel=1e-9)


def test_damped_modes_keeps_its_last_result_and_hands_out_copies():
    mass, stiffness, damping, _ = _uncoupled_in_a_turned_basis([50.0, 80.0, 120.0], [0.2, 0.3, 0.1], 1)
    lam = np.array([50.0, 80.0, 120.0])
    poles, shapes = damped_modes(mass, stiffness, damping, lam)
    fresh = dynamics._damped_modes(mass, stiffness, damping, lam)
    poles[:], shapes[:] = 0, 0  # a caller's changes do not reach the kept result
    again = damped_modes(mass, stiffness, damping, lam)
    assert np.array_equal(again[0], fresh[0]) and np.array_equal(again[1], fresh[1])
    # other inputs are solved afresh
    assert not np.array_equal(damped_modes(mass, stiffness, 2 * damping, lam)[0], fresh[0])


def test_undamped_modes_are_scipy_eigh_to_the_bit_and_kept_read_only():
    """The direct LAPACK call gives scipy.linalg.eigh(C, M)'s numbers exactly (the benchmark's verdicts were
    validated with them); its kept result cannot be changed by a caller."""
    rng = np.random.default_rng(4)
    for n in (6, 12):
        a, b = rng.normal(size=(n, n)), rng.normal(size=(n, n))
        stiffness, mass = a @ a.T, b @ b.T + n * np.eye(n)
        lam, vec = undamped_modes(stiffness, mass)
        expected = scipy.linalg.eigh(stiffness, mass)
        assert np.array_equal(lam, expected[0]) and np.array_equal(vec, expected[1])
        assert undamped_modes(stiffness.copy(), mass.copy())[1] is vec  # the same pair again: the kept result
        with pytest.raises(ValueError):
            vec[0, 0] = 1.0


@pytest.mark.parametrize(
    ("mass", "why"),
    [(np.diag([1.0, -1.0]), "positive definite"), (np.diag([1.0, np.nan]), "NaN"), (np.eye(3), "size")],
)
def test_undamped_modes_refuses_what_eigh_refuses(mass, why):
    with pytest.raises((np.linalg.LinAlgError, ValueError), match=why):
        undamped_modes(np.eye(2), mass)


def test_call_keeps_scalar_results_read_only_and_tells_minus_zero_from_zero():
    values = {a: 0.3 + 0.01 * i for i, a in enumerate(screen6.ARGUMENTS["effect_foundation"])}
    first = call(screen6, "effect_foundation", values)
    fresh = screen6.effect_foundation(**{a: values[a] for a in screen6.ARGUMENTS["effect_foundation"]})
    assert all(np.array_equal(x, y) for x, y in zip(first, fresh, strict=True))
    assert call(screen6, "effect_foundation", dict(values))[0] is first[0]  # kept
    with pytest.raises(ValueError):
        first[1][0, 0] = 0.0
    turned = {**values, "alpha": 0.0}
    flipped = {**values, "alpha": -0.0}
    assert call(screen6, "effect_foundation", turned)[0] is not call(screen6, "effect_foundation", flipped)[0]
    # batches are evaluated afresh every time (and stay writable)
    batch = {**values, "alpha": np.array([0.1, 0.2])}
    out = call(screen6, "effect_foundation", batch)
    assert out[0].shape[0] == 2 and out[0].flags.writeable


def test_arguments_list_every_generated_function_in_the_order_of_its_signature():
    """call() passes the arguments by position."""
    for name in shipped_machines():
        mod = importlib.import_module(f"mountid.generated.{name}")
        for function, names in mod.ARGUMENTS.items():
            assert tuple(inspect.signature(getattr(mod, function)).parameters) == names, (name, function)


def test_depends_lists_every_argument_a_result_changes_with():
    """DEPENDS names, in the order of ARGUMENTS, the arguments each listed function's result depends on: changing
    every other argument leaves the result the same to the bit, and call() keeps it across such changes; changing
    one that it lists changes the result."""
    rng = np.random.default_rng(8)
    for name in shipped_machines():
        mod = importlib.import_module(f"mountid.generated.{name}")
        assert mod.DEPENDS, name  # the derivatives of a model linear in its unknowns do not depend on them
        for function, depends in mod.DEPENDS.items():
            names = mod.ARGUMENTS[function]
            assert depends == tuple(a for a in names if a in depends) and len(depends) < len(names), (name, function)
            values = {a: float(rng.uniform(0.2, 0.6)) for a in names}
            first = call(mod, function, values)
            others = {a: (v if a in depends else v + float(rng.uniform(0.1, 0.3))) for a, v in values.items()}
            fresh = getattr(mod, function)(*(others[a] for a in names))
            assert np.array_equal(np.asarray(first), np.asarray(fresh)), (name, function)
            assert call(mod, function, others) is first  # kept: the arguments it depends on are the same
            if depends:
                moved = {**values, depends[-1]: values[depends[-1]] + 0.25}
                assert not np.array_equal(np.asarray(call(mod, function, moved)), np.asarray(first)), (name, function)


def test_each_thread_keeps_its_own_generated_results():
    """A dask cluster's workers run blind cases in threads: the results call() keeps are each thread's own
    (one thread's eviction never races another's lookup)."""
    from concurrent.futures import ThreadPoolExecutor

    values = {a: 0.3 + 0.01 * i for i, a in enumerate(screen6.ARGUMENTS["effect_foundation"])}
    here = call(screen6, "effect_foundation", values)
    with ThreadPoolExecutor(1) as pool:
        there = pool.submit(call, screen6, "effect_foundation", values).result()
    assert there[1] is not here[1] and np.array_equal(there[1], here[1])
    assert call(screen6, "effect_foundation", values)[1] is here[1]


def test_pair_with_undamped_is_the_assignment_that_keeps_the_most_content():
    """Where each damped mode's best undamped slot is its own the slots are taken as they are (no assignment
    solved); heavy damping that gives two damped modes one best slot goes through the assignment. Either way
    the ranks are those of scipy's linear_sum_assignment on the content."""
    rng = np.random.default_rng(11)
    solved = 0
    for _ in range(40):
        a, b = rng.standard_normal((6, 6)), rng.standard_normal((6, 6))
        mass = a @ a.T + 6 * np.eye(6)
        stiffness = 100 * (b @ b.T + np.eye(6))
        damping = rng.uniform(0.1, 20) * np.abs(b @ b.T)
        poles, vectors = np.linalg.eig(state_matrix(mass, stiffness, damping))
        upper = np.flatnonzero(poles.imag > 0)
        if len(upper) != 6:
            continue
        shapes = vectors[:6, upper]
        lam, phi = undamped_modes(stiffness, mass)
        m_shapes = mass @ shapes
        content = np.abs(phi.T @ m_shapes) ** 2 / np.sum(np.conj(shapes) * m_shapes, axis=0).real
        _, column = scipy.optimize.linear_sum_assignment(content.T, maximize=True)
        solved += len(np.unique(np.argmax(content, axis=0))) < 6
        expected = np.empty(6, dtype=np.intp)
        expected[np.lexsort((poles[upper].imag, column))] = np.sort(column)
        assert np.array_equal(pair_with_undamped(mass, stiffness, shapes, poles[upper].imag), expected)
    assert solved  # some draws take the assignment's path


@pytest.mark.parametrize("scale", [1.0, -2.5e-3])
def test_a_rigid_motion_is_named_by_its_axis_point_and_pitch(scale):
    """rigid_motion reads q = (t, omega), a point p moving by t + omega x p: a motion built from a known axis
    (through c along w, pitch s: t = c x w + s w) reads back as that axis, of any size and sign; a translation
    as its direction."""
    c, w = np.array([0.0, 0.5, -0.35]), np.array([1.0, 0.0, 0.0])
    for pitch, tail in ((0.0, ""), (0.1, " with 0.1 m along it per radian")):
        q = scale * np.concatenate([np.cross(c, w) + pitch * w, w])
        assert rigid_motion(q, 1.0) == f"a rotation about the axis through (0, 0.5, -0.35) m along (1, 0, 0){tail}"
    assert rigid_motion(scale * np.array([0.0, 3.0, 4.0, 0, 0, 0]), 1.0) == "a translation along (0, 0.6, 0.8)"
