"""The generic numerics in mountid.runtime."""

from __future__ import annotations

import numpy as np

from mountid import runtime
from mountid.generated import kid300
from mountid.paper import TABLE_1


def test_quadratic_roots_are_stable_and_ascending():
    # roots 1e-9 and 1e9: the textbook formula loses the small root entirely
    r = runtime.quadratic_roots(1.0, -(1e9 + 1e-9), 1.0)
    np.testing.assert_allclose(r, [1e-9, 1e9], rtol=1e-15)
    np.testing.assert_array_equal(runtime.quadratic_roots(1.0, 0.0, 1.0), [np.nan, np.nan])  # complex
    np.testing.assert_array_equal(runtime.quadratic_roots(0.0, 2.0, -4.0)[0], 2.0)  # degenerates to linear


def test_newton_stops_once_converged():
    """The stopping rule must hold at rounding level: from the exact solution, one step confirms it."""
    knowns = dict(TABLE_1)
    rng = np.random.default_rng(3)
    c_xy, c_z = rng.uniform(3e4, 3e5, 1000), rng.uniform(1e5, 1e6, 1000)
    lam = kid300.squared_frequencies(**knowns, c_xy=c_xy, c_z=c_z)
    M = kid300.mass_matrix(knowns["m"], knowns["J_xy"], knowns["J_z"])
    dC = kid300.stiffness_gradient(knowns["L_xy"], knowns["L_z"])
    calls = []

    def forward(cxy, cz):
        calls.append(1)
        lam_ = kid300.squared_frequencies(**knowns, c_xy=cxy, c_z=cz)
        C = kid300.stiffness_matrix(knowns["L_xy"], knowns["L_z"], cxy, cz)
        return lam_, runtime.modal_matrix(M, C, lam_, kid300.BLOCKS, kid300.MODE_BLOCK, kid300.MODE_RANK), dC

    out = runtime.eigen_newton((c_xy, c_z), forward, (0, 3), (lam[:, 0], lam[:, 3]))
    assert len(calls) <= 2
    np.testing.assert_allclose(out[0], c_xy, rtol=1e-13)
    # from 1 % off, quadratic convergence needs only a handful of steps, away from the double root of the
    # (x, psi) pair at c_xy / c_z of about 0.72 where the Jacobian is nearly singular and Newton is linear
    away = np.abs(c_xy / c_z - 0.72) > 0.2
    calls.clear()
    out = runtime.eigen_newton((c_xy[away] * 1.01, c_z[away] * 0.99), forward, (0, 3), (lam[away, 0], lam[away, 3]))
    assert len(calls) <= 6
    np.testing.assert_allclose(out[0], c_xy[away], rtol=1e-12)
    np.testing.assert_allclose(out[1], c_z[away], rtol=1e-12)
