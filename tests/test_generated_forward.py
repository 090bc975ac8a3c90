"""Generated forward maps against scipy.linalg.eigh and against the symbolic closed forms at 50 digits."""

from __future__ import annotations

import mpmath
import numpy as np
import pytest
import scipy.linalg
import sympy as sp
from conftest import CLOSED_FORM_MACHINES, MACHINES, budget, call, generated, parameters
from hypothesis import given, settings
from hypothesis import strategies as st

from mountid.engine.description import load, shipped_descriptions
from mountid.engine.symbolic.blocks import ModalStructure
from mountid.engine.symbolic.model import SymbolicModel
from mountid.validation.paper import TABLE_1


def matrices(mod, p):
    return call(mod, "mass_matrix", p), call(mod, "stiffness_matrix", p)


def block_reference(mod, p):
    """Per-mode eigenvalues from scipy.linalg.eigh on each block, and eigh's absolute accuracy per block."""
    M, C = matrices(mod, p)
    lam, scale = np.empty(len(mod.MODES)), np.empty(len(mod.MODES))
    for k in range(len(mod.MODES)):
        idx = list(mod.BLOCKS[mod.MODE_BLOCK[k]])
        w = scipy.linalg.eigh(C[np.ix_(idx, idx)], M[np.ix_(idx, idx)], eigvals_only=True)
        lam[k], scale[k] = w[mod.MODE_RANK[k] - 1], np.max(np.abs(w))
    return lam, scale, M, C


@pytest.mark.parametrize("name", MACHINES)
@settings(max_examples=budget(150), deadline=None)
@given(data=st.data())
def test_frequencies_match_eigh(name, data):
    mod = generated(name)
    p = data.draw(parameters(mod))
    lam = mod.squared_frequencies(**p)
    ref, scale, M, C = block_reference(mod, p)
    # eigh is backward stable: its eigenvalues carry an absolute error of a few eps times the largest one
    # of the block, so that is the accuracy the comparison can ask for (the 50-digit test below asks more)
    np.testing.assert_array_less(np.abs(lam - ref), 1e-10 * ref + 1e-13 * scale)
    # the full 6x6 problem: the same spectrum
    full = scipy.linalg.eigh(C, M, eigvals_only=True)
    np.testing.assert_array_less(np.abs(np.sort(lam) - full), 1e-10 * full + 1e-13 * full.max())


def check_modal_matrix(name: str, p: dict) -> None:
    """The generated modal matrix is the mass-normalised eigenvectors: phi^T M phi = I, and the residual of
    each eigenpair (C - lambda_k M) phi_k within 1e-9 of the size of its terms, (|C| + lambda_k |M|) |phi| (a
    backward-stable solver such as eigh leaves a residual of that form: a stiff mode's lambda_k |M| can exceed
    |C| by orders of magnitude)."""
    mod = generated(name)
    M, C = matrices(mod, p)
    phi, lam = mod.modal_matrix(**p), mod.squared_frequencies(**p)
    np.testing.assert_allclose(phi.T @ M @ phi, np.eye(6), atol=1e-9)
    residual = C @ phi - M @ phi * lam
    size = (np.abs(C).max() + np.abs(lam) * np.abs(M).max()) * np.abs(phi).max()
    assert np.all(np.abs(residual) <= 1e-9 * size[None, :])
    energy = mod.kinetic_energy_distribution(**p)
    np.testing.assert_allclose(energy.sum(axis=0), 1.0, rtol=1e-12)


@pytest.mark.parametrize("name", MACHINES)
@settings(max_examples=budget(60), deadline=None)
@given(data=st.data())
def test_modal_matrix_is_mass_normalised_eigenvectors(name, data):
    check_modal_matrix(name, data.draw(parameters(generated(name))))


def test_modal_matrix_of_a_stiff_mode_on_an_ill_conditioned_mass_matrix():
    """Pinned find of `make fuzz`: skid1plane, 100 t with J = 1 kg m^2 and its centre of mass 4.87 m off (M's
    x-psi block of condition 1e8). The stiffest mode (lambda 9.9e5 rad^2/s^2) leaves a residual of 3.5e-4
    (eigh's own 1.7e-4), above the bound 1e-9 |C| |phi| = 2.1e-4 that left lambda |M| = 2.4e12 out; within
    1e-9 of (|C| + lambda |M|) |phi| by far."""
    p = dict(m=1e5, J_x=1.0, J_y=1.0, J_z=1.0, e=4.869675251658631, a=1.0, b=1.0, h=1.0, c_h=1e3, c_z=1e4)
    check_modal_matrix("skid1plane", p)


@pytest.mark.parametrize(("height", "above"), [(0.0, 0.0), (0.0, 1e-13), (1e-12, 0.0), (1e-12, 1e-13)])
def test_modal_matrix_at_a_double_root_of_an_uncoupled_block(height, above):
    """kid300 with its isolators in the plane of the centre of mass (L_z = 0: x and theta uncoupled), or a
    picometre off it, and c_xy where the x translation's frequency meets the rocking's (``above``: relative
    distance from it): the block's two modes, twins within EQUAL_EIGENVALUES, are an M-orthonormal pair. Each
    mode's own null vector of (C - lambda M) gave NaN at the double root (with a RuntimeWarning) and nearly the
    same vector twice beside it (phi^T M phi off the identity by 2e-5)."""
    p = dict(TABLE_1, L_z=0.0, c_z=472.3e3)
    p["c_xy"] = generated("kid300").squared_frequencies(**p, c_xy=74.4e3)[3] * p["m"] / 4 * (1 + above)
    check_modal_matrix("kid300", {**p, "L_z": height})


def test_vectorised_calls_broadcast_like_scalar_calls():
    mod = generated("kid300")
    rng = np.random.default_rng(1)
    c_xy = rng.uniform(1e4, 1e6, size=(3, 4))
    lam = mod.squared_frequencies(**TABLE_1, c_xy=c_xy, c_z=4.7e5)
    assert lam.shape == (3, 4, 6)
    for i in range(3):
        for j in range(4):
            np.testing.assert_array_equal(lam[i, j], mod.squared_frequencies(**TABLE_1, c_xy=c_xy[i, j], c_z=4.7e5))


@pytest.mark.parametrize("name", MACHINES)
def test_a_row_without_modes_is_nan_and_the_batch_beside_it_is_solved(name):
    """A batch row whose parameters give no modes (a NaN or infinite value, a negative mass) is NaN in every
    forward function, and the rows beside it equal their scalar calls: in numerically solved blocks
    (skid1plane's 3x3) numpy's eigh and Cholesky raised LinAlgError for the whole batch."""
    mod = generated(name)
    p = {a: mod.PARAMETERS[a]["value"] for a in mod.FORWARD_ARGUMENTS}
    mass = next(a for a in mod.FORWARD_ARGUMENTS if mod.PARAMETERS[a]["kind"] == "mass")
    unknown = mod.UNKNOWN[0]
    for varied, bad in ((unknown, np.nan), (unknown, np.inf), (mass, -p[mass]), (mass, np.nan)):
        values = {**p, varied: np.array([p[varied], bad, 0.5 * p[varied]])}
        for function in ("frequencies", "modal_matrix", "kinetic_energy_distribution"):
            with np.errstate(invalid="ignore"):
                rows = getattr(mod, function)(**values)
                assert np.isnan(rows[1]).any(), (function, varied, bad)
                assert not np.isnan(rows[0]).any() and not np.isnan(rows[2]).any()
                np.testing.assert_array_equal(rows[0], getattr(mod, function)(**p))
                np.testing.assert_array_equal(rows[2], getattr(mod, function)(**{**p, varied: 0.5 * p[varied]}))
        with np.errstate(invalid="ignore"):
            assert np.isnan(mod.frequencies(**{**p, varied: bad})).any()  # the modes it enters


class HighPrecision:
    """The symbolic closed-form eigenvalues of a description, evaluated with mpmath at 50 digits."""

    def __init__(self, name: str) -> None:
        structure = ModalStructure(SymbolicModel(load(shipped_descriptions()[name])))
        self.symbols = [structure.model.symbols[a] for a in generated(name).FORWARD_ARGUMENTS]
        self.exprs = [structure.blocks[m.block].eigenvalue_exprs()[m.rank - 1] for m in structure.modes]
        self.fn = sp.lambdify(self.symbols, self.exprs, modules="mpmath")
        self.naive = sp.lambdify(self.symbols, self.exprs, modules="numpy")

    def __call__(self, values):
        with mpmath.workdps(50):
            return [self.fn(*(mpmath.mpf(v) for v in values))[k] for k in range(len(self.exprs))]


@pytest.mark.parametrize("name", CLOSED_FORM_MACHINES)
@settings(max_examples=budget(40), deadline=None)
@given(data=st.data())
def test_frequencies_match_50_digit_symbolic_closed_form(name, data):
    mod = generated(name)
    hp = HighPrecision(name)
    p = data.draw(parameters(mod))
    exact = hp([p[a] for a in mod.FORWARD_ARGUMENTS])
    lam = mod.squared_frequencies(**p)
    for k in range(len(mod.MODES)):
        assert abs(lam[k] - float(exact[k])) <= 1e-12 * float(exact[k])


@pytest.mark.parametrize(
    "case",
    [
        {"c_xy": 1.0, "c_z": 1e10},  # coupled modes many decades apart
        {"c_xy": 1e2, "c_z": 1e9},
        {"c_xy": 1e3, "c_z": 1e8, "L_z": 3.0},
        {"L_z": 1e-9},  # coupling vanishing: L_z -> 0
        {"L_z": 0.0},  # exactly decoupled
    ],
)
def test_badly_conditioned_cases_keep_full_relative_accuracy(case):
    mod = generated("kid300")
    p = TABLE_1 | {"c_xy": 7.44e4, "c_z": 4.72e5} | case
    hp = HighPrecision("kid300")
    exact = [float(v) for v in hp([p[a] for a in mod.FORWARD_ARGUMENTS])]
    lam = mod.squared_frequencies(**p)
    np.testing.assert_allclose(lam, exact, rtol=1e-13)


SPECIAL_POINTS = [
    # a decoupled crossing: C[x, theta] = 0 and x, theta at one frequency (the coupling term squared as an
    # expanded polynomial of mixed signs went negative by rounding there: NaN with exit code 0)
    ("screen6", {"alpha": -0.3, "c_h": 207158.53934775013, "J_y": 7226.07401376743}),
    ("screen6", {"alpha": -0.3, "c_h": 207158.53934775013, "J_y": 7226.07401376743 * (1 + 1e-9)}),
    ("screen6", {"alpha": 0.0}),  # upright corner isolators
    ("screen6", {"h": 0.0}),  # isolators in the plane of the centre of mass
    ("screen6", {"h": 0.0, "alpha": 0.0}),
    ("rectangular", {"h": 0.0}),
    ("kid300", {"L_z": 0.0}),
    ("rectangular", {"J_x": 380.0, "c_x": 1.4e5}),  # J_x = J_y, c_x = c_y: x, y repeated across blocks
    ("rectangular", {"J_x": 380.0, "c_x": 1.4e5, "h": 0.0}),
    ("kid300", {"c_z": 74.4e3 * 0.486**2 * 838.6 / 51.52}),  # 4 c_z / m = 4 c_xy L_xy^2 / J_z: z and phi coincide
]


@pytest.mark.parametrize(("name", "case"), SPECIAL_POINTS, ids=[f"{n}:{c}" for n, c in SPECIAL_POINTS])
def test_special_points_match_a_50_digit_reference(name, case):
    mod = generated(name)
    p = {a: mod.PARAMETERS[a]["value"] for a in mod.FORWARD_ARGUMENTS} | case
    exact = [float(v) for v in HighPrecision(name)([p[a] for a in mod.FORWARD_ARGUMENTS])]
    lam = mod.squared_frequencies(**p)
    assert np.all(np.isfinite(lam))
    np.testing.assert_allclose(lam, exact, rtol=1e-13)


def test_the_textbook_form_would_fail_where_the_generated_form_holds():
    """The check above can fail: the paper's k1 - k2 form loses the lower root when the modes are far apart."""
    mod = generated("kid300")
    p = TABLE_1 | {"c_xy": 1.0, "c_z": 1e10}
    hp = HighPrecision("kid300")
    values = [p[a] for a in mod.FORWARD_ARGUMENTS]
    exact = float(hp(values)[0])
    naive = float(hp.naive(*values)[0])
    assert abs(naive - exact) > 1e-7 * exact  # about 1.5e-6 here
    assert abs(mod.squared_frequencies(**p)[0] - exact) <= 1e-14 * exact


@pytest.mark.parametrize("name", MACHINES)
def test_matrix_derivatives_match_sympy_at_30_digits(name):
    """matrix_derivatives() against sympy's own derivative of M, C, B evaluated with 30 digits; fitted_derivatives()
    its rows for the unknowns and damping parameters, which (the shipped machines being linear in them) depend on
    none of them."""
    mod = generated(name)
    model = SymbolicModel(load(shipped_descriptions()[name]))
    values = {a: mod.PARAMETERS[a]["value"] for a in mod.ARGUMENTS["matrix_derivatives"]}
    got = call(mod, "matrix_derivatives", values)
    subs = {model.symbols[a]: sp.Float(v, 30) for a, v in values.items()}
    for k, p in enumerate(mod.DERIVATIVE_PARAMETERS):
        for m, matrix in enumerate((model.M, model.C, model.B)):
            exact = np.array(matrix.diff(model.symbols[p]).subs(subs).evalf(30).tolist(), dtype=float)
            np.testing.assert_allclose(got[k, m], exact, rtol=1e-13, atol=1e-13 * max(1.0, np.abs(exact).max()))
    # the fitted parameters' rows alone (the diagnosis's nominal derivatives), kept by call while the geometry stays
    alone = call(mod, "fitted_derivatives", values)
    damping = tuple(n for n, p in mod.PARAMETERS.items() if p["kind"] == "damping")
    assert mod.FITTED_PARAMETERS == mod.UNKNOWN + damping
    for k, q in enumerate(mod.FITTED_PARAMETERS):
        row = got[mod.DERIVATIVE_PARAMETERS.index(q)] if q in mod.DERIVATIVE_PARAMETERS else np.zeros_like(alone[k])
        np.testing.assert_allclose(alone[k], row, rtol=1e-14, atol=1e-14)
    depends = mod.DEPENDS.get("fitted_derivatives", mod.ARGUMENTS["fitted_derivatives"])
    assert set(depends).isdisjoint(mod.FITTED_PARAMETERS)


def derivative_rounding_bound(mod, p):
    """Absolute rounding error that d lambda_k / d p_j may carry, shape (n_p, n_modes).

    lambda_k' = phi_k^T G phi_k with G = C' - lambda_k M' (mass-normalised phi). A backward-stable mode of a
    symmetric block carries an error of about eps ||A|| / gap_k in the mass-normalised metric
    (A = M^-1/2 C M^-1/2 on the block, gap_k the distance to the block's other eigenvalues), which reaches the
    derivative doubled and weighted by ||M^-1/2 G M^-1/2||. A mode alone in its block has an exact shape.
    The factor 16 is the usual small multiple of n in rounding bounds; it is not fitted to a find.
    """
    M, C = matrices(mod, p)
    damping = {a: 1.0 for a in mod.ARGUMENTS["matrix_derivatives"] if a not in p}  # B' is not used
    d = call(mod, "matrix_derivatives", {**damping, **p})
    n_p = len(mod.FORWARD_ARGUMENTS)
    lam = mod.squared_frequencies(**p)
    bound = np.zeros((n_p, len(mod.MODES)))
    for k in range(len(mod.MODES)):
        idx = list(mod.BLOCKS[mod.MODE_BLOCK[k]])
        others = [lam[i] for i in range(len(lam)) if i != k and mod.MODE_BLOCK[i] == mod.MODE_BLOCK[k]]
        if not others:
            continue
        low = scipy.linalg.cholesky(M[np.ix_(idx, idx)], lower=True)

        def mass_normalised(x, low=low):
            y = scipy.linalg.solve_triangular(low, x, lower=True)
            return scipy.linalg.solve_triangular(low, y.T, lower=True).T

        a_norm = np.linalg.norm(mass_normalised(C[np.ix_(idx, idx)]), 2)
        gap = min(abs(lam[k] - o) for o in others)
        for j, name in enumerate(mod.FORWARD_ARGUMENTS):
            dm, dc = d[mod.DERIVATIVE_PARAMETERS.index(name), :2]
            g = dc[np.ix_(idx, idx)] - lam[k] * dm[np.ix_(idx, idx)]
            g_norm = np.linalg.norm(mass_normalised(g), 2)
            bound[j, k] = 16 * np.finfo(float).eps * 2 * g_norm * a_norm / gap
    return bound


def check_squared_frequency_derivatives(name: str, p: dict) -> None:
    """d lambda / d p against mpmath's derivative of the symbolic closed form at 50 digits."""
    mod = generated(name)
    hp = HighPrecision(name)
    values = [p[a] for a in mod.FORWARD_ARGUMENTS]
    got = mod.squared_frequency_derivatives(**p)
    lam = mod.squared_frequencies(**p)
    rounding = derivative_rounding_bound(mod, p)
    for j in range(len(values)):
        for k in range(len(mod.MODES)):

            def f(t, j=j, k=k):
                return hp.fn(*[t if i == j else mpmath.mpf(v) for i, v in enumerate(values)])[k]

            with mpmath.workdps(50):
                exact = float(mpmath.diff(f, mpmath.mpf(values[j])))
            # relative to the size of lambda_k / p_j (a derivative can vanish by symmetry; an angle can be 0),
            # and never asked below the rounding its mode shape carries
            scale = abs(lam[k]) / max(abs(values[j]), 1e-3)
            tolerance = 1e-8 * scale + 1e-9 * abs(exact) + rounding[j, k]
            assert abs(got[j, k] - exact) <= tolerance, (j, k, got[j, k], exact)


@pytest.mark.parametrize("name", CLOSED_FORM_MACHINES)
@settings(max_examples=budget(3))
@given(data=st.data())
def test_squared_frequency_derivatives_match_a_50_digit_derivative(name, data):
    check_squared_frequency_derivatives(name, data.draw(parameters(generated(name))))


def test_squared_frequency_derivatives_where_a_mode_barely_depends_on_a_parameter():
    """Pinned find of `make fuzz`: the x-theta block with eigenvalues 0.022 and 4e8 rad^2/s^2. The soft mode's
    d lambda / d c_x is 1.2e-17 at 50 digits and 4.8e-17 in double precision: its mode shape carries a rounding
    error of eps relative, which reaches the derivative through the stiff mode's 40 rad^2/s^2 per N/m."""
    p = dict(m=10.0, J_x=1.0, J_y=1.0, J_z=1.0, a=0.023713737056616554, b=1.0, h=np.sqrt(10.0))
    p.update(c_x=1e7, c_y=1e3, c_z=1e3)
    mod = generated("rectangular")
    assert derivative_rounding_bound(mod, p)[mod.FORWARD_ARGUMENTS.index("c_x"), 0] < 1e-12
    check_squared_frequency_derivatives("rectangular", p)


def test_squared_frequency_derivatives_of_3x3_blocks_match_eigh_differences():
    mod = generated("skid1plane")
    p = {a: mod.PARAMETERS[a]["value"] for a in mod.FORWARD_ARGUMENTS}
    got = mod.squared_frequency_derivatives(**p)
    for j, a in enumerate(mod.FORWARD_ARGUMENTS):
        h = 1e-5 * p[a]
        hi, lo = dict(p, **{a: p[a] + h}), dict(p, **{a: p[a] - h})
        fd = (block_reference(mod, hi)[0] - block_reference(mod, lo)[0]) / (2 * h)  # per mode, in mode order
        np.testing.assert_allclose(got[j], fd, rtol=1e-6, atol=1e-9 * np.abs(fd).max())
