"""Inverse solutions: hypothesis round trips through the forward map, and a scipy.optimize cross-check."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import scipy.optimize
from conftest import MACHINES, budget, generated, log_uniform, parameters
from hypothesis import assume, example, given, settings
from hypothesis import strategies as st

from mountid import runtime
from mountid.validation.paper import TABLE_1

CONDITION_LIMIT = 1e5
"""Round trips must hold to rtol 1e-9 where the inverse problem itself is not ill-conditioned: a relative
condition number kappa (relative change of the unknowns per relative change of the frequencies) above
1e5 turns rounding of the forward map alone (1e-16) into errors near 1e-11 * kappa; those cases are left
to test_near_degenerate_cases_degrade_with_the_condition_number."""


def relative_condition(mod, key, p):
    """1 / smallest singular value of d ln(omega_given) / d ln(unknowns), by central differences."""
    idx = [mod.MODES.index(k) for k in key]
    jac = np.empty((len(key), len(mod.UNKNOWN)))
    for j, u in enumerate(mod.UNKNOWN):
        hi, lo = dict(p), dict(p)
        hi[u], lo[u] = p[u] * (1 + 1e-6), p[u] * (1 - 1e-6)
        jac[:, j] = (np.log(mod.frequencies(**hi)[idx]) - np.log(mod.frequencies(**lo)[idx])) / 2e-6
    s = np.linalg.svd(jac, compute_uv=False)
    return np.inf if s[-1] == 0 else 1.0 / s[-1]


def round_trip_tolerance(mod, key, p, kappa: float) -> float:
    """1e-9, or where larger the rounding the forward map itself carries into the unknowns: its eigenvalues
    carry an absolute error of about eps * lambda_max, a relative one of eps * lambda_max / lambda_k on a
    given mode, which the inverse problem amplifies by kappa (factor 16, as the 50-digit derivative check's;
    not fitted). A machine whose given modes lie decades below its highest (screen6 at m = 1000 kg on J = 1
    kg m^2: 3.7e3 apart, kappa 5e4) cannot round-trip to 1e-9."""
    lam = np.asarray(mod.frequencies(**p)) ** 2
    idx = [mod.MODES.index(k) for k in key]
    return max(1e-9, 16 * kappa * np.finfo(float).eps * float(lam.max() / lam[idx].min()))


def invert(mod, key, p):
    omega = mod.frequencies(**p)
    knowns = {a: p[a] for a in mod.FORWARD_ARGUMENTS if a not in mod.UNKNOWN}
    given_ = {f"omega_{k}": omega[mod.MODES.index(k)] for k in key}
    return mod.INVERSES[key](**knowns, **given_)


def check_round_trip(name: str, key: tuple[str, ...], p: dict, pinned: bool = False) -> None:
    """The true unknowns are an admissible root, every admissible root reproduces the given frequencies
    (``pinned``: an explicit example outside hypothesis, which must be well conditioned)."""
    mod = generated(name)
    kappa = relative_condition(mod, key, p)
    if pinned:
        assert kappa < CONDITION_LIMIT
    else:
        assume(kappa < CONDITION_LIMIT)
    roots = invert(mod, key, p)
    truth = np.array([p[u] for u in mod.UNKNOWN])
    found = np.array([roots.parameters[u] for u in mod.UNKNOWN])  # (n_unknowns, n_roots)
    err = np.max(np.abs(found - truth[:, None]) / truth[:, None], axis=0)
    assert roots.admissible.any(), "the true parameters must be an admissible root"
    closest = np.nanmin(np.where(roots.admissible, err, np.inf))
    assert closest <= round_trip_tolerance(
        mod, key, p, kappa
    ), f"closest admissible root off by {closest:.2e} (kappa {kappa:.1e})"
    # every admissible root (the truth or another exact solution) reproduces the given frequencies far more
    # closely than the 1e-6 admissibility tolerance
    knowns = {a: p[a] for a in mod.FORWARD_ARGUMENTS if a not in mod.UNKNOWN}
    idx = [mod.MODES.index(k) for k in key]
    omega = mod.frequencies(**p)[idx]
    for i in np.flatnonzero(roots.admissible):
        again = mod.frequencies(**knowns, **{u: roots.parameters[u][i] for u in mod.UNKNOWN})[idx]
        np.testing.assert_allclose(again, omega, rtol=1e-10)


def _keys(name: str) -> list[tuple[str, ...]]:
    return list(generated(name).INVERSES)


@pytest.mark.parametrize("key", _keys("kid300"), ids="_".join)
@settings(max_examples=budget(40))
@given(p=parameters(generated("kid300")))
def test_round_trip_recovers_the_unknowns_kid300(key, p):
    check_round_trip("kid300", key, p)


@pytest.mark.parametrize("key", _keys("rectangular"), ids="_".join)
@settings(max_examples=budget(40))
@given(p=parameters(generated("rectangular")))
def test_round_trip_recovers_the_unknowns_rectangular(key, p):
    check_round_trip("rectangular", key, p)


def test_a_start_far_from_its_root_is_not_given_up_under_the_trust_region():
    """`make fuzz` (2026-11-28): rectangular with c_x 56 000 times c_y (m = 10 kg, J_y = 1e4 kg m^2). From y, theta
    and phi the closed form's candidates miss, and Newton from the description's nominal values climbs to the root
    under the trust region (MAX_RELATIVE_STEP), c_x 1.5 times larger a step, its residual 895 -> 845 in eight
    steps; the stall rule (STALL_STEPS) gave it up there and no root was admissible. Where no Levenberg-Marquardt
    phase came first, a step the trust region cut short counts as progress while it lowers the residual by more
    than the step before."""
    p = {"m": 10.0, "J_x": 1.0, "J_y": 10000.0, "J_z": 1.0, "a": 0.06978305848598663, "b": 0.027384196342643614}
    p |= {"h": 1.0, "c_x": 56234132.51903491, "c_y": 1000.0, "c_z": 1000.0}
    check_round_trip("rectangular", ("y", "theta", "phi"), p, pinned=True)


# Pinned finds. A square upright screen (alpha = 0): identify_x_y_phi gave only NaN roots (the closed form
# divides by sin(alpha)^2 and the nearby-point fallback landed outside Newton's basin); about 1 in 100
# square upright machines failed before the engine derived the alpha = 0 solution.
_SQUARE_UPRIGHT = dict(m=10.0, J_x=1.0, J_y=1.0, J_z=1.0, a=1.0, b=1.0, h=1.0, alpha=0.0, c_h=1e3, c_v=10**6.5, c_m=1e6)
# `make fuzz` (2026-11-27): a heavy body on tiny inertias, its given modes 3.7e3 below its highest: 3.3e-9 off,
# within what the forward map's rounding allows (round_trip_tolerance), beyond the flat 1e-9 of before.
_HEAVY_ON_TINY_INERTIA = dict(
    m=1000.0,
    J_x=1.0,
    J_y=1.0,
    J_z=1.0,
    a=0.7233941627366748,
    b=1.0,
    h=1.0,
    alpha=-0.609375,
    c_h=1000.0,
    c_v=10.0**6.5,
    c_m=1000.0,
)


@pytest.mark.parametrize("key", _keys("screen6"), ids="_".join)
@settings(max_examples=budget(40))
@given(p=parameters(generated("screen6")))
@example(p=_SQUARE_UPRIGHT)
@example(p=_HEAVY_ON_TINY_INERTIA)
def test_round_trip_recovers_the_unknowns_screen6(key, p):
    check_round_trip("screen6", key, p)


# Machines researchers add: eight mounts in two groups off the planes (4 closed-form sets, 11 numeric) and
# one plane of symmetry (3x3 blocks, every set numeric: Newton from the generated forward map). A numeric
# inverse starts from the nominal unknowns scaled to the data's level times 10^(-1, 0, 1) each: it promises
# every root whose unknowns stand in ratios within about a decade of the nominal ones, and is tested so.
@st.composite
def near_nominal_ratios(draw, module, known_spread: float | None = None):
    """Known parameters over their full ranges (or within 10^known_spread of their nominal values), the
    unknowns at any common level but in ratios within 10^0.8 of the nominal ones."""
    p = draw(parameters(module))
    if known_spread is not None:
        for a in module.KNOWN:
            if a in p and module.PARAMETERS[a]["kind"] != "angle":
                p[a] = module.PARAMETERS[a]["value"] * 10 ** draw(st.floats(-known_spread, known_spread))
    level = draw(log_uniform(1e-2, 1e3))
    for u in module.UNKNOWN:
        p[u] = module.PARAMETERS[u]["value"] * level * 10 ** draw(st.floats(-0.8, 0.8))
    return p


def _split(name: str) -> tuple[list, list]:
    mod = generated(name)
    keys = list(mod.INVERSES)
    return [k for k in keys if k not in mod.NUMERIC_INVERSES], [k for k in keys if k in mod.NUMERIC_INVERSES]


@pytest.mark.parametrize("key", _split("genset8")[0], ids="_".join)
@settings(max_examples=budget(20))
@given(p=parameters(generated("genset8")))
def test_round_trip_recovers_the_unknowns_genset8_closed_form(key, p):
    check_round_trip("genset8", key, p)


@pytest.mark.parametrize(
    ("name", "key"),
    [(n, k) for n in ("genset8", "skid1plane") for k in _split(n)[1]],
    ids=lambda v: v if isinstance(v, str) else "_".join(v),
)
@settings(max_examples=budget(8))
@given(data=st.data())
def test_round_trip_recovers_the_unknowns_numeric(name, key, data):
    # skid1plane (3x3 blocks) near its design only: see the pinned miss below
    spread = 0.5 if name == "skid1plane" else None
    check_round_trip(name, key, data.draw(near_nominal_ratios(generated(name), spread)))


def test_numeric_inverse_far_from_the_design():
    """Found by hypothesis: m = 1e4 kg with J = 1 kg m^2 and e = 1 m; the rank-labelled eigenvalues of the
    3x3 blocks cross and Newton from the start grid did not reach the true root (another root was found).
    Found with the Levenberg-Marquardt start of the polish (runtime.eigen_levenberg_marquardt), beside two
    other roots. (Pinned as a strict xfail until then, which an error of the test itself, hypothesis's
    ``assume`` outside a property, satisfied as well: now called as a pinned example.)"""
    p = {"m": 10000.0, "J_x": 1.0, "J_y": 1.0, "J_z": 1.0, "e": 1.0, "a": 10.0**0.5, "b": 1.0, "h": 1.0}
    check_round_trip("skid1plane", ("z", "theta"), p | {"c_h": 1800000.0, "c_z": 23717082.451262847}, pinned=True)


GENSET8_SMALL = {"m": 10.0, "J_x": 1.0, "J_y": 1.0, "J_z": 1.0, "b": 1.0, "h": 1.0, "gamma": 0.0, "c_v2": 600000.0}
"""The 10 kg body with unit inertias that `make fuzz` draws genset8's degenerate layouts on."""


@pytest.mark.parametrize(
    ("key", "p"),
    [
        (
            ("x", "y", "psi", "phi"),
            {"a1": 3.78551524925863, "a2": 3.651741272548377, "c_x": 391221.470208563, "c_y": 160000.0, "c_v1": 8e5},
        ),
        (
            ("x", "y", "psi", "phi"),
            {"a1": 1.0, "a2": 1.036632928437698, "c_x": 2.2e5, "c_y": 284524.7056062276, "c_v1": 8e5},
        ),
        (
            ("x", "z", "psi", "theta"),
            {"a1": 1.0, "a2": 0.9998594712341624, "c_x": 2.2e5, "c_y": 1.6e5, "c_v1": 2921393.0180387017},
        ),
        (
            ("x", "psi", "theta", "phi"),
            {
                "a1": 1.0,
                "a2": 1.0,
                "gamma": -0.0625,
                "c_x": 315262.7654521318,
                "c_y": 1.6e5,
                "c_v1": 142262.35280311384,
            },
        ),
    ],
    ids=["fuzz-2026-11-24", "fuzz-2026-11-27a", "fuzz-2026-11-27b", "fuzz-2026-11-27c"],
)
def test_numeric_inverse_near_a_degenerate_layout(key, p):
    """Found by `make fuzz` (2026-11-24): genset8 with its two isolator groups at almost the same distance
    (a1 = 3.79 m, a2 = 3.65 m) on a 10 kg body; x, y, psi and phi hold c_v1 + c_v2 far better than either
    (relative condition 2e4). Newton's undamped steps slid along the valley of that sum to c_v1 = 0, c_v2 =
    1.4e6 from every start, not to the truth (8e5, 6e5). Found again on 2026-11-27 with the groups at 1.00 and
    1.04 m, 1.00 and 0.9999 m, and at the same distance with the layout turned (gamma): no admissible root.
    Strict xfails until the polish of a numeric inverse started with Levenberg-Marquardt steps in the
    logarithms of the unknowns (runtime.eigen_levenberg_marquardt), which reach the truth in each."""
    check_round_trip("genset8", key, GENSET8_SMALL | p, pinned=True)


def test_damped_steps_reach_the_root_newton_alone_slides_past(monkeypatch):
    """The first degenerate layout above: with the Levenberg-Marquardt start of the polish left out (each start
    goes straight to Newton, as before), no start reaches the truth and none is admissible; with it, the truth
    is the admissible root."""
    import mountid.runtime.inverse as inverse

    mod = generated("genset8")
    key = ("x", "y", "psi", "phi")
    p = GENSET8_SMALL | {"a1": 3.78551524925863, "a2": 3.651741272548377, "c_x": 391221.470208563, "c_y": 1.6e5}
    p |= {"c_v1": 8e5}
    monkeypatch.setattr(inverse, "eigen_levenberg_marquardt", lambda model, known, x, *args: x)
    assert not invert(mod, key, p).admissible.any()
    monkeypatch.undo()
    check_round_trip("genset8", key, p, pinned=True)


def test_numeric_inverse_where_a_start_meets_a_singular_normal_matrix():
    """Found by `make fuzz` (2026-11-27) on the Levenberg-Marquardt start of the polish: genset8's groups at
    one distance with the layout turned (gamma = -0.25), J_x 562 kg m^2 on a 10 kg body (relative condition
    35). The damping of a start's steps shrank on every kept step until (J^T J + mu diag(J^T J)) was singular
    where J^T J is, and numpy's solve raised for the whole batch; the damping now has a floor, and a singular
    system takes the pseudo-inverse."""
    p = GENSET8_SMALL | {"J_x": 562.341325190349, "a1": 1.0, "a2": 1.0, "gamma": -0.25}
    check_round_trip(
        "genset8",
        ("x", "y", "psi", "theta"),
        p | {"c_x": 2.2e5, "c_y": 1.6e5, "c_v1": 8e5, "c_v2": 1897366.5961010277},
        pinned=True,
    )


def test_numeric_inverse_of_genset8_far_from_the_design():
    """Found by `make fuzz` (2026-11-27): genset8 with its inner isolator group at a tenth of the outer one's
    distance, J_y 316 and J_x 151 kg m^2 on a 10 kg body, c_v1 7.5 times c_v2 (relative condition 9e3): from
    y, psi, theta and phi the numeric inverse found a root 2 times off and not the truth (a strict xfail); with
    the Levenberg-Marquardt start of the polish it finds both."""
    p = GENSET8_SMALL | {"J_x": 151.24725453106234, "J_y": 10.0**2.5, "a1": 1.0, "a2": 0.1}
    check_round_trip(
        "genset8",
        ("y", "psi", "theta", "phi"),
        p | {"c_x": 2.2e5, "c_y": 1.6e5, "c_v1": 4498730.601522793},
        pinned=True,
    )


@pytest.mark.parametrize(
    ("key", "share"),
    [(("x", "psi", "theta", "phi"), 0.4), (("x", "y", "theta", "phi"), 0.6), (("y", "psi", "theta", "phi"), 0.9)],
)
def test_numeric_inverse_gives_up_starts_that_lead_nowhere(monkeypatch, key, share):
    """genset8 a few per cent off its design: many of the 625 grid starts lead to no root (over x, psi, theta
    and phi none does). With the stall rules (runtime.inverse.LM_STALL, STALL_STEPS) they are given up early:
    the same roots to rounding as with every start run to LM_STEPS and max_steps, for a ``share`` of the rows
    evaluated (0.31, 0.52 and 0.79 when written)."""
    mod = generated("genset8")
    p = {a: v["value"] for a, v in mod.PARAMETERS.items() if a in mod.FORWARD_ARGUMENTS}
    omega = mod.frequencies(**p) * (1 + 0.01 * np.arange(6))
    knowns = {a: p[a] for a in mod.FORWARD_ARGUMENTS if a not in mod.UNKNOWN}
    given_ = {f"omega_{k}": omega[mod.MODES.index(k)] for k in key}
    rows = []
    model = mod._model

    def counted(known, unknowns, modes):
        rows.append(len(unknowns))
        return model(known, unknowns, modes)

    monkeypatch.setattr(mod, "_model", counted)
    results = []
    for stall in (True, False):
        if not stall:
            monkeypatch.setattr(runtime.inverse, "LM_STALL", runtime.inverse.LM_STEPS + 1)
            monkeypatch.setattr(runtime.inverse, "STALL_STEPS", 10**6)
        rows.clear()
        roots = mod.INVERSES[key](**knowns, **given_)
        found = np.array([roots.parameters[u][roots.admissible] for u in mod.UNKNOWN]).T
        results.append((found[np.lexsort(found.T)], sum(rows)))
    (quick, quick_rows), (full, full_rows) = results
    assert quick.shape == full.shape
    np.testing.assert_allclose(quick, full, rtol=1e-9)
    assert quick_rows <= share * full_rows


def test_an_ill_conditioned_solution_is_listed_once():
    """skid1plane far off its design (c_h 1.6e4, c_z 7.8e7 N/m from x and psi with 0.1 % noise; relative condition
    1e5, where the frequencies hardly depend on c_z): the grid's starts end on one solution whose copies scatter by
    1e-8, the rounding of so ill-conditioned a root. It was listed 75 times (DUPLICATE_RTOL alone); roots within
    their condition number times the admissibility tolerance of an earlier one are one solution."""
    mod = generated("skid1plane")
    known = {"m": 1506.760270865734, "J_x": 284.56558259315284, "J_y": 689.584161290722, "J_z": 873.0055989971304}
    known |= {"e": 0.15616113846063714, "a": 0.6989307054356815, "b": 0.5392966167838718, "h": 0.3281491486095065}
    roots = mod.INVERSES[("x", "psi")](**known, omega_x=6.589145239598699, omega_psi=8.004444697904681)
    assert roots.admissible.sum() == 1
    assert 1e4 < roots.condition[roots.admissible][0] < 1e6
    found = {u: roots.parameters[u][roots.admissible][0] for u in mod.UNKNOWN}
    omega = mod.frequencies(**known, **found)
    np.testing.assert_allclose(
        omega[[mod.MODES.index("x"), mod.MODES.index("psi")]], [6.589145239598699, 8.004444697904681], rtol=1e-11
    )


def test_numeric_inverse_finds_a_root_between_two_others():
    """Found by `make fuzz` (2026-11-27), skid1plane near its design (relative condition 8.9): psi and theta
    have three roots along a curve, (c_h, c_z) = (1.45e5, 6.77e5), the truth (1.8e5, 5.62e5) and (2.03e5,
    3.86e5); every one of the 81 grid starts went to one of the outer two. Newton started midway between
    two roots found (runtime.solve_inverse's ``numeric``) reaches the one between them."""
    p = {"m": 974.072447364317, "J_x": 260.0, "J_y": 610.0, "J_z": 1478.5380190491453, "e": 0.05692099788303083}
    p |= {"a": 0.5061071926713142, "b": 0.55, "h": 1.0953678537057445, "c_h": 180000.0, "c_z": 562420.6569993419}
    check_round_trip("skid1plane", ("psi", "theta"), p, pinned=True)
    assert invert(generated("skid1plane"), ("psi", "theta"), p).admissible.sum() == 3


def test_near_degenerate_cases_degrade_with_the_condition_number():
    """Near a double root of (x, psi) the inverse loses digits in proportion to the problem's condition number,
    not more: error <= 1e-15 kappa with kappa ~ 3e4 one part in 1e4 away from the double root."""
    mod = generated("kid300")
    base = TABLE_1 | {"c_z": 4.72e5}

    def truth_index(ratio):  # which of the two ascending roots is the truth
        p = dict(base, c_xy=ratio * base["c_z"])
        return int(np.argmin(np.abs(invert(mod, ("x", "psi"), p).parameters["c_xy"] - p["c_xy"])))

    lo, hi = 0.01, 100.0  # bisect on the ratio c_xy / c_z where the two roots swap: the double root
    assert truth_index(lo) != truth_index(hi)
    for _ in range(60):
        mid = np.sqrt(lo * hi)
        lo, hi = (mid, hi) if truth_index(mid) == truth_index(lo) else (lo, mid)
    p = dict(base, c_xy=lo * (1 + 1e-4) * base["c_z"])
    kappa = relative_condition(mod, ("x", "psi"), p)
    assert kappa > 1e4  # the case really is near-degenerate
    roots = invert(mod, ("x", "psi"), p)
    errs = [max(abs(roots.parameters[u][i] - p[u]) / p[u] for u in mod.UNKNOWN) for i in range(2)]
    assert min(errs) <= 1e-15 * kappa


def test_wrong_labelling_is_inadmissible():
    """Frequencies swapped between the modes of a block have no admissible root."""
    mod = generated("kid300")
    knowns = dict(TABLE_1)
    roots = mod.identify_x_psi(**knowns, omega_x=64.10, omega_psi=17.71)
    assert not roots.admissible.any()
    # a single frequency of a block given with the other unknown fixed: lands on the wrong mode
    roots = mod.identify_x_z(**knowns, omega_x=60.0, omega_z=47.46)
    assert not roots.admissible.any()


@pytest.mark.parametrize("name", MACHINES)
def test_a_given_frequency_that_is_no_frequency_has_no_root(name):
    """A negative, zero or non-finite given omega leaves its row without an admissible root in every inverse set,
    closed-form and numeric (squared, a negative omega was its positive twin: every root admissible), while the
    rows of the batch beside it keep theirs."""
    mod = generated(name)
    p = {a: mod.PARAMETERS[a]["value"] for a in mod.FORWARD_ARGUMENTS}
    omega = mod.frequencies(**p)
    knowns = {a: p[a] for a in mod.FORWARD_ARGUMENTS if a not in mod.UNKNOWN}
    key = next(k for k in mod.INVERSES if mod.INVERSES[k] is not None)
    first = omega[mod.MODES.index(key[0])]
    batch = np.array([first, -first, 0.0, np.nan, np.inf, 1e300])  # 1e300: its square overflows
    given_ = {f"omega_{k}": omega[mod.MODES.index(k)] for k in key} | {f"omega_{key[0]}": batch}
    with np.errstate(over="ignore"):  # the square of 1e300 overflows as the caller's state says (Machine raises)
        roots = mod.INVERSES[key](**knowns, **given_)
    assert roots.admissible[:, 0].any()
    assert not roots.admissible[:, 1:].any()
    # a batch row of known parameters without modes (a negative or NaN mass): no root there, the others solved
    # (a numerically solved block's eigh raised for the whole batch)
    mass = next(a for a in knowns if mod.PARAMETERS[a]["kind"] == "mass")
    given_ = {f"omega_{k}": omega[mod.MODES.index(k)] for k in key}
    with np.errstate(invalid="ignore"):
        roots = mod.INVERSES[key](**{**knowns, mass: np.array([p[mass], -p[mass], np.nan])}, **given_)
    assert roots.admissible.any(axis=0).tolist() == [True, False, False]


def test_frequency_standard_deviations_are_checked():
    """InverseRoots.std takes a non-negative finite standard deviation per given frequency (a negative one was
    squared into a valid-looking answer)."""
    mod = generated("kid300")
    roots = mod.identify_x_psi(**TABLE_1, omega_x=17.71, omega_psi=64.10)
    good = roots.std([0.45, 0.45])
    assert np.all(np.isfinite(good["c_z"][roots.admissible]))
    for bad in ([-0.45, 0.45], [0.45, np.nan]):
        with pytest.raises(ValueError, match="frequency_std"):
            roots.std(bad)


def test_the_readme_example_of_the_generated_functions_runs():
    """The README's "Using the generated functions" block, executed as written: the paper's x and psi give two
    admissible roots, c_z = 472 kN/m among them, each with a condition number and standard deviations."""
    lines = Path("README.md").read_text(encoding="utf-8").split("## Using the generated functions\n\n", 1)[1]
    block = lines.split("\n\n", 1)[0].splitlines()
    assert block[0] == "    from mountid.generated import kid300" and len(block) == 5
    scope: dict = {}
    exec("\n".join(line[4:] for line in block[:-2]), scope)  # the README's own lines
    admissible = eval(block[-2][4:].split("#")[0], scope)
    condition, std = eval(block[-1][4:].split("#")[0], scope)
    assert admissible.shape == (2,) and np.min(np.abs(admissible / 472.3e3 - 1)) < 1e-3
    assert np.all(np.isfinite(condition)) and set(std) == {"c_xy", "c_z"}


def test_vectorised_inverse_matches_scalar_calls():
    mod = generated("kid300")
    knowns = dict(TABLE_1)
    w1 = np.linspace(15, 20, 7)
    roots = mod.identify_x_psi(**knowns, omega_x=w1, omega_psi=64.1)
    assert roots.parameters["c_z"].shape == (2, 7)
    for i, w in enumerate(w1):
        single = mod.identify_x_psi(**knowns, omega_x=w, omega_psi=64.1)
        np.testing.assert_array_equal(single.parameters["c_z"], roots.parameters["c_z"][:, i])


@pytest.mark.parametrize("name", MACHINES)
def test_inverse_agrees_with_a_direct_scipy_solve(name):
    """Independent numerics: scipy.optimize.least_squares on the forward map from a perturbed start."""
    mod = generated(name)
    rng = np.random.default_rng(7)
    p = {a: mod.PARAMETERS[a]["value"] for a in mod.FORWARD_ARGUMENTS}
    knowns = {a: v for a, v in p.items() if a not in mod.UNKNOWN}
    truth = np.array([p[u] for u in mod.UNKNOWN])
    checked = 0
    for key, fn in mod.INVERSES.items():
        idx = [mod.MODES.index(k) for k in key]
        target = mod.frequencies(**p)[idx]

        def residual(logc, idx=idx, target=target):
            c = dict(zip(mod.UNKNOWN, np.exp(logc), strict=True))
            return mod.frequencies(**knowns, **c)[idx] / target - 1

        start = np.log(truth * rng.uniform(0.7, 1.4, size=truth.size))
        sol = scipy.optimize.least_squares(residual, start, xtol=1e-15, ftol=1e-15, gtol=1e-15)
        if np.max(np.abs(sol.fun)) > 1e-12:
            continue  # converged elsewhere; the closed form is checked by the round trips
        roots = fn(**knowns, **{f"omega_{k}": w for k, w in zip(key, target, strict=True)})
        found = np.array([roots.parameters[u] for u in mod.UNKNOWN])
        scipy_c = np.exp(sol.x)
        match = np.max(np.abs(found - scipy_c[:, None]) / scipy_c[:, None], axis=0)
        assert np.min(match[roots.admissible]) < 1e-7, key
        checked += 1
    assert checked >= len(mod.INVERSES) - 2, f"scipy converged on only {checked} of {len(mod.INVERSES)} sets"


def test_upright_screen_isolators_where_the_closed_form_is_0_over_0():
    """At alpha = 0 some eliminations divide by sin(alpha)^2 (0/0 at that very point) although the set stays
    well determined: the engine derives the solution with alpha = 0 substituted and the run time takes its
    candidates there. Before that (x, y, phi) had no admissible root here. Sets that alpha = 0 makes
    unidentifiable (a corner stiffness then acts only through sin(alpha)) are left out by their condition
    number."""
    assert "alpha" in generated("screen6").SPECIAL_POINTS
    mod = generated("screen6")
    p = {"m": 10.0, "J_x": 1.0, "J_y": 1.0, "J_z": 1.0, "a": 1.0, "b": 1.0, "h": 1.0, "alpha": 0.0}
    p |= {"c_h": 1e3, "c_v": 2e3, "c_m": 1.5e3}
    truth = np.array([p[u] for u in mod.UNKNOWN])
    checked = []
    for key in mod.INVERSES:
        if relative_condition(mod, key, p) > 1e3:
            continue
        roots = invert(mod, key, p)
        found = np.array([roots.parameters[u] for u in mod.UNKNOWN])
        err = np.max(np.abs(found - truth[:, None]) / truth[:, None], axis=0)
        assert np.min(np.where(roots.admissible, err, np.inf)) <= 1e-12, key
        checked.append(key)
    assert ("x", "y", "phi") in checked
    assert len(checked) >= len(mod.INVERSES) // 2


FOUND_BY_HYPOTHESIS = [
    (
        ("x", "y", "phi"),
        {
            "m": 1e4,
            "J_x": 1.0,
            "J_y": 1e3,
            "J_z": 1.0,
            "a": 1.0,
            "b": 1.0,
            "h": 0.1**0.5,
            "c_x": 1e3,
            "c_y": 1e3,
            "c_z": 1e4,
        },
    ),
    (
        ("x", "psi", "phi"),
        {
            "m": 7498.942093324558,
            "J_x": 1.0,
            "J_y": 10**0.5,
            "J_z": 1.0,
            "a": 0.042169650342858224,
            "b": 1.0,
            "h": 0.6493816315762113,
            "c_x": 1e4,
            "c_y": 1e3,
            "c_z": 1e7,
        },
    ),
    (
        ("y", "theta", "phi"),
        {
            "m": 10**4.5,
            "J_x": 1.7782794100389228,
            "J_y": 1.0,
            "J_z": 1.0,
            "a": 1.0,
            "b": 0.03162277660168379,
            "h": 0.6853895838650083,
            "c_x": 1e3,
            "c_y": 1e4,
            "c_z": 3522694.651473101,
        },
    ),
]


@pytest.mark.parametrize(("key", "p"), FOUND_BY_HYPOTHESIS)
def test_each_solution_is_reported_once_and_converged(key, p):
    """Found by hypothesis: candidates polished onto the same solution, one stopping short of it."""
    mod = generated("rectangular")
    roots = invert(mod, key, p)
    assert roots.admissible.sum() == 1
    k = int(np.flatnonzero(roots.admissible)[0])
    kappa = relative_condition(mod, key, p)
    for u in mod.UNKNOWN:
        assert roots.parameters[u][k] == pytest.approx(p[u], rel=max(1e-12, 1e-15 * kappa))


# Legitimate designs where frequency sets stop determining the unknowns: isolators in the plane of the
# centre of mass (a coupling vanishes) and upright isolators (the closed form divides by sin(alpha)^2).
DEGENERATE_POINTS = [("kid300", {"L_z": 0.0}), ("rectangular", {"h": 0.0}), ("screen6", {"alpha": 0.0})]


@pytest.mark.parametrize(("name", "case"), DEGENERATE_POINTS, ids=[f"{n}:{c}" for n, c in DEGENERATE_POINTS])
def test_degenerate_points_are_reported_not_guessed(name, case):
    """Frequencies from a 50-digit evaluation of the symbolic closed form at the special point: every set
    either gives back the true unknowns (to 1e-12) or reports a root that reproduces the frequencies but
    leaves named unknowns undetermined; an admissible root is never one of a continuum (full rank)."""
    from test_generated_forward import HighPrecision

    mod = generated(name)
    p = {a: mod.PARAMETERS[a]["value"] for a in mod.FORWARD_ARGUMENTS} | case
    lam = [float(v) for v in HighPrecision(name)([p[a] for a in mod.FORWARD_ARGUMENTS])]
    knowns = {a: p[a] for a in mod.FORWARD_ARGUMENTS if a not in mod.UNKNOWN}
    truth = np.array([p[u] for u in mod.UNKNOWN])
    outcome = {}
    for key, fn in mod.INVERSES.items():
        roots = fn(**knowns, **{f"omega_{k}": np.sqrt(lam[mod.MODES.index(k)]) for k in key})
        found = np.array([roots.parameters[u] for u in mod.UNKNOWN])
        err = np.max(np.abs(found - truth[:, None]) / truth[:, None], axis=0)
        assert np.all(roots.condition[roots.admissible] < 1 / runtime.RANK_RTOL)
        if np.any(roots.admissible & (err <= 1e-12)):
            outcome[key] = "truth"
        else:
            outcome[key] = roots.most_specific_undetermined()
            assert outcome[key], f"{key}: neither the truth nor an undetermined unknown reported"
    assert any(v == "truth" for v in outcome.values())
    if name == "kid300":  # x = 4 c_xy / m and phi = 4 c_xy L_xy^2 / J_z: both c_xy only
        assert outcome[("x", "phi")] == ("c_z",) and outcome[("z", "psi")] == ("c_xy",)
    if name == "rectangular":  # c_z only moves theta, which the set leaves out (Newton may stop where theta
        # meets x, a double root whose eigenvectors are arbitrary: the naming is then over-inclusive)
        assert "c_z" in outcome[("x", "y", "phi")]


@pytest.mark.parametrize(
    ("name", "key", "values"),
    [
        (  # three exact solutions; the start factors (0.1, 1, 10) found two, not the truth
            "skid1plane",
            ("z", "phi"),
            {"m": 1500.0, "J_x": 260.0, "J_y": 610.0, "J_z": 720.0, "e": 0.18, "a": 0.9, "b": 1.739252713092609,
             "h": 0.4, "c_h": 569209.9788303083, "c_z": 750000.0},
        ),
        (  # both groups at one x (a1 = a2): three solutions, the truth missed by 3^4 starts
            "genset8",
            ("x", "y", "psi", "theta"),
            {"m": 10.0, "J_x": 1.0, "J_y": 1.0, "J_z": 1.0, "a1": 1.0, "a2": 1.0, "b": 0.1, "h": 1.0, "gamma": 0.375,
             "c_x": 521702.2152455641, "c_y": 160000.0, "c_v1": 800000.0, "c_v2": 337404.79511420947},
        ),
    ],
    ids=["skid1plane-z_phi", "genset8-x_y_psi_theta"],
)  # fmt: skip
def test_numeric_inverse_finds_pinned(name, key, values):
    """Finds of hypothesis (hypothesis 6.170 draws in the gating profile) against the numeric inverses
    with three start factors per unknown: now every exact solution, the truth among them."""
    check_round_trip(name, key, values, pinned=True)
