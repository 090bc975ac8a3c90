"""Hardening rubber (the catalogue's rubber_hardening, strategy ``amplitude``): the isolators split along their
principal axes, each mode at its own fixed point, checked against the blind harness's independent hardening
isolators and against the linear model; the verdicts of the one-level blind seeds where a drive belt mimics it."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.linalg
from test_jacobian import residual_difference

from mountid.diagnosis import campaign as campaign_module
from mountid.diagnosis import strategies
from mountid.diagnosis.candidate_model import CandidateModel
from mountid.diagnosis.fitting import Data
from mountid.diagnosis.jacobian import jacobian
from mountid.diagnosis.strategies import isolator_split
from mountid.effects import CATALOGUE, EFFECTS, pair
from mountid.machine import Machine, call, state_matrix, undamped_modes
from mountid.machine.symmetry import MIRRORS
from mountid.measurement.modes import scaled_unit
from mountid.validation import blind, blind_truth

HARDENING = EFFECTS["rubber_hardening"]


def _model(seed: int, machine: str, kind: str = "shapes") -> tuple[CandidateModel, blind_truth.Truth]:
    data, truth = blind.make_case(seed, "nonlinear_isolator", kind=kind, machine=machine)
    return CandidateModel(campaign_module.parse(data), HARDENING), truth


def _axes(model: CandidateModel, values: dict[str, float]) -> tuple[np.ndarray, np.ndarray]:
    parts, along, _ = isolator_split(
        np.asarray(call(model.mod, "isolator_stiffness", values)),
        np.asarray(call(model.mod, "isolator_axial_stiffness", values)),
    )
    return parts, along


def _theta(model: CandidateModel, unknowns: dict[str, float], h: float) -> np.ndarray:
    return np.array([*(math.log(unknowns[u]) for u in model.unknown), math.log(h)])


@pytest.mark.parametrize("machine", ["kid300", "rectangular", "genset8"])
def test_the_axes_of_each_isolator_add_up_to_its_stiffness(machine):
    """C_i = sum over its axes of g g^T / k: the parts of every isolator add up to C, each axis' part is of rank
    one (a plane of equal stiffness two), and phi^T part phi / k is the squared deformation along the axis."""
    model = Machine.resolve(machine)
    values = dict(blind_truth.TruthMachine(machine).nominal)
    each = np.asarray(call(model.module, "isolator_stiffness", values))
    parts, along, _ = isolator_split(each, np.asarray(call(model.module, "isolator_axial_stiffness", values)))
    c = np.asarray(call(model.module, "stiffness_matrix", values))
    assert np.allclose(parts.sum(axis=0), c, rtol=0, atol=1e-9 * np.abs(c).max())
    assert np.all(along > 0) and len(parts) >= 2 * len(each)
    ranks = [np.linalg.matrix_rank(p, tol=1e-9 * np.abs(p).max()) for p in parts]
    assert sum(ranks) == 3 * len(each)
    # a pure translation along x deforms every isolator by one metre in all: its squared deformations add to 1
    x = np.eye(6)[0]
    squared = np.einsum("a,kab,b->k", x, parts, x) / along
    assert squared.sum() == pytest.approx(len(each), rel=1e-12)


def test_hardened_modes_are_the_blind_truths_where_the_isolators_axes_are_distinct():
    """On the rectangular machine (shear stiffnesses c_x != c_y: every isolator's principal axes are the
    description's local axes) the candidate at the truth's unknowns and h = gamma gives the blind harness's
    hardening isolators, an implementation of its own (per local axis, from the truth's isolator geometry):
    frequencies to 1e-9, shapes to 1e-7."""
    model, truth = _model(225, "rectangular")
    prediction = model.predict(_theta(model, truth.unknowns, truth.size["gamma"]))
    omega, shapes = blind_truth.true_modes(
        blind_truth.TruthMachine("rectangular"), Machine.resolve("rectangular"), truth
    )
    assert prediction.frequencies == pytest.approx(omega, rel=1e-9)
    unit = scaled_unit(shapes, model.length)
    mac = np.einsum("ij,ji->i", prediction.shapes, unit) ** 2
    assert np.all(mac > 1 - 1e-7)


def test_each_hardened_mode_is_the_mode_of_its_own_stiffening():
    """The fixed point: C_j, rebuilt from mode j's own deformations, has (lambda_j, phi_j) as an eigenpair; every
    mode keeps the mirror parity of its linear shape; h -> 0 is the linear model."""
    model, truth = _model(3, "kid300")
    theta = _theta(model, truth.unknowns, 0.2)
    e = model.evaluate(theta)
    m, c, _ = e.mats
    parts, along = _axes(model, e.values)
    lam0, vec0 = undamped_modes(c, m)
    for j in range(6):
        phi = e.vec[:, j]
        squared = np.einsum("a,kab,b->k", phi, parts, phi) / along
        cj = c + 0.2 * np.tensordot(squared / squared.max(), parts, axes=1)
        assert np.allclose(cj @ phi, e.lam[j] * (m @ phi), rtol=0, atol=1e-9 * e.lam[j])
        assert e.lam[j] > lam0[j] * (1 - 1e-12)  # stiffer rubber: no mode drops
        for mirror in MIRRORS:
            before = vec0[:, j] @ m @ mirror @ vec0[:, j]
            if abs(abs(before) - 1) < 1e-9:
                assert phi @ m @ mirror @ phi == pytest.approx(before, abs=1e-9)
    linear = model.evaluate(_theta(model, truth.unknowns, 1e-12))
    assert linear.lam == pytest.approx(lam0, rel=1e-10)


def test_hardening_rubber_is_never_paired():
    """No change of M and C common to the modes: no pair adds it."""
    assert all(pair(HARDENING, other) is None for other in CATALOGUE)


@pytest.mark.parametrize(
    ("seed", "machine", "kind", "h"),
    [
        (225, "rectangular", "shapes", 0.05),  # distinct shear axes
        (3, "kid300", "shapes", 0.2),  # exact twins: each its own fixed point, their span compared
        (5, "genset8", "shapes", 0.3),
        (18, "screen6", "damping", 0.3),  # the damping ratios of each mode's own (M, C_j, B)
        (2, "skid1plane", "frequencies", 0.5),
    ],
)
def test_the_jacobian_of_hardened_modes_is_their_fixed_points_differentiated(seed, machine, kind, h):
    """The analytic Jacobian (implicit differentiation of every mode's fixed point, strategies.hardened_derivatives)
    matches a central difference of the residuals, column by column, beside the truth."""
    model, truth = _model(seed, machine, kind)
    unknowns = {u: truth.unknowns.get(u, model.start_unknowns.get(u)) for u in model.unknown}
    theta = _theta(model, unknowns, h) + np.random.default_rng(1).normal(0, 0.02, len(model.parameter_names))
    analytic = jacobian(model, Data(model.campaign, model.length), theta)
    assert analytic is not None
    # each hardened mode's fixed point is solved to 1e-12 on either side: a step of 1e-5 keeps that noise below 1e-7
    numeric = residual_difference(model, theta, step=1e-5)[: len(analytic)]
    scale = np.abs(numeric).max(axis=0)
    assert np.all(scale > 0)
    assert np.all(np.abs(analytic - numeric).max(axis=0) <= 1e-6 * scale)


def test_a_hardened_mode_with_a_neighbour_in_its_own_problem_is_left_to_differences():
    """Where h is so small that a mode's twin in (C_j, M) lies within SEPARATE_MODES of it (kid300), its shape is
    not differentiable: the Jacobian declines the point (the fit takes differences)."""
    model, truth = _model(3, "kid300")
    data = Data(model.campaign, model.length)
    assert jacobian(model, data, _theta(model, truth.unknowns, 1e-9)) is None
    assert jacobian(model, data, _theta(model, truth.unknowns, 1e-2)) is not None  # the lower end of h's range


def test_hardened_modes_short_of_their_fixed_point_are_left_to_differences(monkeypatch):
    """A fixed point not reached within HARDENING_ITERATIONS (here one step) has no implicit derivative: the Jacobian
    declines the point."""
    monkeypatch.setattr(strategies, "HARDENING_ITERATIONS", 1)
    model, truth = _model(225, "rectangular")
    theta = _theta(model, truth.unknowns, 0.05)
    assert jacobian(model, Data(model.campaign, model.length), theta) is None
    monkeypatch.undo()
    fresh = _model(225, "rectangular")[0]
    assert jacobian(fresh, Data(fresh.campaign, fresh.length), theta) is not None


def test_an_isolator_whose_axes_turn_with_a_parameter_is_left_to_differences(monkeypatch):
    """The derivative holds each isolator's axes where they are: a stiffness gradient that turns them (an
    off-diagonal entry in the isolator's axes, here 1e-6 of the largest) makes the Jacobian decline the point."""
    model, truth = _model(225, "rectangular")
    data = Data(model.campaign, model.length)
    theta = _theta(model, truth.unknowns, 0.05)
    assert jacobian(model, data, theta) is not None
    generated = strategies.call

    def turned(module, function, values):
        out = generated(module, function, values)
        if function != "isolator_stiffness_gradient":
            return out
        out = np.array(out)
        size = np.abs(out[0, 0, :3, :3]).max()
        out[0, 0, 0, 1] += 1e-6 * size
        out[0, 0, 1, 0] += 1e-6 * size
        return out

    monkeypatch.setattr(strategies, "call", turned)
    fresh = _model(225, "rectangular")[0]
    assert jacobian(fresh, Data(fresh.campaign, fresh.length), theta) is None


def test_damping_ratios_of_hardened_modes_are_their_own_poles():
    """With damping ratios measured each hardened mode's ratio is that of the pole of its own stiffened C with
    the described B (checked against scipy's eigenvalues of the first-order form, the pole nearest the hardened
    undamped frequency): stiffer, the same B, a smaller ratio than the linear mode's."""
    model, truth = _model(18, "screen6", kind="damping")
    unknowns = {u: truth.unknowns.get(u, model.start_unknowns.get(u)) for u in model.unknown}
    theta = _theta(model, unknowns, 0.3)
    hard, soft = model.predict(theta), model.predict(_theta(model, unknowns, 1e-9))
    assert np.all(hard.damping < soft.damping) and np.all(hard.frequencies > soft.frequencies)
    e = model.evaluate(theta)
    m, c, _ = e.mats
    b = np.asarray(call(model.mod, "damping_matrix", e.values))
    parts, along = _axes(model, e.values)
    for k, j in enumerate(e.index):
        phi = e.vec[:, j]
        squared = np.einsum("a,kab,b->k", phi, parts, phi) / along
        cj = c + 0.3 * np.tensordot(squared / squared.max(), parts, axes=1)
        poles = scipy.linalg.eigvals(state_matrix(m, cj, b))
        p = poles[np.argmin(np.abs(np.abs(poles) - math.sqrt(e.lam[j])) + (poles.imag < 0))]
        assert hard.damping[k] == pytest.approx(-p.real / abs(p), rel=1e-9)


def test_a_step_in_a_damping_parameter_finds_the_hardened_modes_kept(monkeypatch):
    """The hardened modes depend on M and C alone: a forward difference in a fitted damping parameter finds them
    kept (no fixed point solved again) and gets to the bit what a model that never saw the first point computes."""
    model, truth = _model(18, "screen6", kind="damping")
    unknowns = {u: truth.unknowns.get(u, model.start_unknowns.get(u)) for u in model.unknown}
    theta = _theta(model, unknowns, 0.3)
    model.evaluate(theta)
    stepped = theta.copy()
    stepped[model.unknown.index(model.damping_unknown[0])] += 1e-3
    solved = []
    fixed_point = strategies._hardened_modes
    monkeypatch.setattr(strategies, "_hardened_modes", lambda *args: solved.append(1) or fixed_point(*args))
    kept = model.evaluate(stepped)
    assert not solved
    fresh = _model(18, "screen6", kind="damping")[0].evaluate(stepped)
    assert solved
    for name in ("lam", "vec", "omega", "zeta"):
        assert np.array_equal(getattr(kept, name), getattr(fresh, name)), name
    assert not np.array_equal(kept.zeta, model.evaluate(theta).zeta)  # the step did move the damping ratios
