"""scipy's trust-region iteration called past least_squares (mountid.identification.least_squares): the fits of
the gap diagnosis and of the stiffnesses end where least_squares ends, to the bit, after as many evaluations."""

from __future__ import annotations

import numpy as np
import pytest
from test_fitting import CASES  # blind cases and a candidate fitted to them, the convergence rule stopping its fits

from mountid.diagnosis import fitting
from mountid.diagnosis.campaign import parse
from mountid.diagnosis.gap import diagnose_where
from mountid.effects import EFFECTS
from mountid.identification import from_records, least_squares
from mountid.validation import blind

needs_direct = pytest.mark.skipif(
    least_squares._TRF is None, reason="this scipy's private trust-region modules differ: least_squares is called"
)


def _logged(runs: list, module: object, monkeypatch: pytest.MonkeyPatch) -> None:
    """Every trust_region result of ``module`` appended to ``runs`` as (x, residuals, cost, status, nfev, njev)."""
    solve = least_squares.trust_region

    def run(*args, **kwargs):
        res = solve(*args, **kwargs)
        runs.append((res.x.tobytes(), res.fun.tobytes(), res.cost, res.status, res.nfev, res.njev))
        return res

    monkeypatch.setattr(module, "trust_region", run)


@needs_direct
@pytest.mark.parametrize(("seed", "truth", "kind", "machine", "fitted"), CASES)
def test_candidate_fits_end_where_least_squares_ends(seed, truth, kind, machine, fitted, monkeypatch):
    """Every fit of a candidate (multi-start, spread, held and released, stopped by the convergence rule,
    leave-one-out refits) ends identically both ways; the test fails when an argument passed differs."""
    campaign = parse(blind.make_case(seed, truth, kind=kind, machine=machine)[0])
    direct, wrapped = [], []
    _logged(direct, fitting, monkeypatch)
    one = fitting.exact_leave_one_out(fitting.fit_candidate(campaign, EFFECTS[fitted]))
    monkeypatch.setattr(least_squares, "_TRF", None)
    _logged(wrapped, fitting, monkeypatch)
    other = fitting.exact_leave_one_out(fitting.fit_candidate(campaign, EFFECTS[fitted]))
    assert len(direct) > 1
    assert direct == wrapped
    assert one.theta.tobytes() == other.theta.tobytes()
    assert one.held_out_gap == other.held_out_gap


@needs_direct
@pytest.mark.parametrize(("seed", "truth", "kind", "machine"), [(c[0], c[1], c[2], c[3]) for c in CASES[2:]])
def test_stiffness_fits_end_where_least_squares_ends(seed, truth, kind, machine, monkeypatch):
    """The gap report's fits of the stiffnesses (fit_stiffness: every start, every mode left out in turn;
    unbounded, unit scales, tolerances 1e-14) end identically both ways."""
    campaign = parse(blind.make_case(seed, truth, kind=kind, machine=machine)[0])
    direct, wrapped = [], []
    _logged(direct, from_records, monkeypatch)
    one = diagnose_where(campaign)
    monkeypatch.setattr(least_squares, "_TRF", None)
    _logged(wrapped, from_records, monkeypatch)
    other = diagnose_where(campaign)
    assert len(direct) > len(campaign.modes)
    assert direct == wrapped
    assert one.parameters == other.parameters
    assert [r.predicted for r in one.residuals] == [r.predicted for r in other.residuals]


@pytest.mark.parametrize("direct", [True, False])
def test_residuals_not_finite_at_the_start_are_an_error_either_way(direct, monkeypatch):
    """As least_squares: a start whose residuals are not finite raises ValueError (fit_stiffness drops that start)."""
    if not direct:
        monkeypatch.setattr(least_squares, "_TRF", None)
    with pytest.raises(ValueError, match="not finite"):
        least_squares.trust_region(
            lambda x: np.array([np.nan, 1.0]), lambda x: np.eye(2), np.zeros(2), ftol=1e-8, xtol=1e-8
        )


def test_a_linear_problem_is_solved_with_bounds_and_without():
    """trust_region on a linear least-squares problem: its solution unbounded, and clipped to a bound that cuts it."""
    a = np.array([[1.0, 0.0], [0.0, 2.0], [1.0, 1.0]])
    b = np.array([1.0, 2.0, 3.0])
    exact = np.linalg.lstsq(a, b, rcond=None)[0]
    free = least_squares.trust_region(lambda x: a @ x - b, lambda x: a, np.zeros(2), ftol=1e-12, xtol=1e-12)
    assert free.x == pytest.approx(exact, rel=1e-8)
    held = least_squares.trust_region(
        lambda x: a @ x - b, lambda x: a, np.zeros(2), [-np.inf, -np.inf], [np.inf, 1.0], ftol=1e-12, xtol=1e-12
    )
    assert held.x[1] == pytest.approx(1.0, abs=1e-6)
    assert held.cost > free.cost
