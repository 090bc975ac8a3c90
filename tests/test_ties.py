"""Ties the physics makes exact, decided by rules rather than by the last bits of a computation
(docs/validation.md, "Ties, not kernels"): labels of twins parted along a diagonal, fits at mirror-image
isolators, the sign of a mode with two equally large entries, the sign of a blind truth's mode."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest
import scipy.linalg

from mountid.diagnosis.candidate_model import label_modes
from mountid.diagnosis.candidates import SAME_CHI2, ranked_by_fit
from mountid.machine import Machine
from mountid.measurement.modes import scaled_unit
from mountid.runtime.eigen import with_positive_largest, with_real_positive_largest
from mountid.validation import blind, blind_truth

DIAGONAL = 1 / math.sqrt(2.0)


def _parted_twins(order: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """Six unit body shapes and squared frequencies [rad^2/s^2]: the twins x and y parted along the diagonals,
    (x + y)/sqrt(2) at 1.01 and (x - y)/sqrt(2) at 0.99, in the column ``order``, the other four pure."""
    body = np.eye(6)
    parted = {
        0: (np.array([DIAGONAL, DIAGONAL, 0, 0, 0, 0]), 1.01),
        1: (np.array([DIAGONAL, -DIAGONAL, 0, 0, 0, 0]), 0.99),
    }
    lam = np.array([0.0, 0.0, 4.0, 9.0, 16.0, 25.0])
    for column, which in enumerate(order):
        body[:, column], lam[column] = parted[which]
    return body, lam


@pytest.mark.parametrize("order", [(0, 1), (1, 0)])
def test_twins_parted_along_a_diagonal_take_their_labels_in_the_order_of_frequency(order):
    """Each parted mode has MAC 1/2 with either twin's nominal shape, and with the twins' equal nominal
    frequencies both pairings cost the same: the first label (x) takes the lower mode, whichever column LAPACK
    put it in; with measured frequencies the lower measured label takes it."""
    body, lam = _parted_twins(order)
    lower = int(np.argmin(lam[:2]))
    nominal = np.array([1.0, 1.0, 4.0, 9.0, 16.0, 25.0])
    assert list(label_modes(lam, body, nominal, np.eye(6))) == [lower, 1 - lower, 2, 3, 4, 5]
    measured = np.array([1.02, 0.98, 4.0, 9.0, 16.0, 25.0])  # y measured below x
    assert list(label_modes(lam, body, measured, np.eye(6))) == [1 - lower, lower, 2, 3, 4, 5]


def test_a_shape_that_tells_the_parted_twins_apart_labels_them_whatever_their_frequencies():
    """Not a tie: parted along the axes, the mode along x is x even where it is the higher."""
    body, lam = np.eye(6), np.array([1.01, 0.99, 4.0, 9.0, 16.0, 25.0])
    assert list(label_modes(lam, body, np.array([1.0, 1.0, 4.0, 9.0, 16.0, 25.0]), np.eye(6))) == [0, 1, 2, 3, 4, 5]


def _fit(chi2: float, variant: int) -> SimpleNamespace:
    return SimpleNamespace(chi2=chi2, state=SimpleNamespace(model=SimpleNamespace(variant=variant)))


def test_fits_equally_good_at_mirror_image_isolators_are_ranked_in_the_description_order():
    fits = [_fit(5.0 + SAME_CHI2 / 100, 2), _fit(5.0, 3), _fit(5.0 + SAME_CHI2 / 2, 0), _fit(7.0, 1), _fit(6.0, 4)]
    assert [f.state.model.variant for f in ranked_by_fit(fits)] == [0, 2, 3, 4, 1]
    apart = [_fit(5.0 + 2 * SAME_CHI2, 0), _fit(5.0, 1)]
    assert [f.state.model.variant for f in ranked_by_fit(apart)] == [1, 0]
    assert len(ranked_by_fit([_fit(math.nan, 0), _fit(1.0, 1)])) == 2  # a failed fit ends the ranking, not the loop


def test_of_two_equally_large_entries_the_first_sets_a_modes_sign():
    """x and y moved alike (a mode parted along a diagonal): whichever the last bit makes larger, the first
    entry is made positive."""
    a = np.array([[-0.7071067811865476], [0.7071067811865475]])
    b = np.array([[-0.7071067811865475], [0.7071067811865476]])
    for phi in (a, b):
        out = with_positive_largest(phi, np.eye(2))
        assert out[0, 0] > 0 > out[1, 0]
    clear = np.array([[-0.1], [0.9]])
    assert with_positive_largest(clear, np.eye(2))[1, 0] > 0


@pytest.mark.parametrize("tilt", [-1e-8, 1e-8])
def test_parted_twins_whose_pairings_cost_alike_to_rounding_take_their_labels_in_the_order_of_frequency(tilt):
    """Near-twins on a support (blind seed 66, kid300: two modes 5e-6 apart, MAC 0.4996 with both twins'
    labels): the two pairings cost the same to about 1e-9, which the rounding of another BLAS kernel turned the
    other way. Shapes tilted by ``tilt`` off the diagonals (the pairings then differ by about 4 tilt): the first
    label still takes the lower mode."""
    body, lam = _parted_twins((0, 1))
    turn = np.array([[math.cos(tilt), -math.sin(tilt)], [math.sin(tilt), math.cos(tilt)]])
    body[:2, :2] = turn @ body[:2, :2]
    nominal = np.array([1.0, 1.0, 4.0, 9.0, 16.0, 25.0])
    assert list(label_modes(lam, body, nominal, np.eye(6))) == [1, 0, 2, 3, 4, 5]


@pytest.mark.parametrize(("machine", "seed", "truth"), [("kid300", 20, "drive_belt"), ("screen6", 66, "foundation")])
def test_a_truths_modes_take_their_nominal_modes_sign_whatever_lapack_returns(machine, seed, truth, monkeypatch):
    """The blind truth's noisy shapes are its modes plus noise, so a mode's sign is part of the campaign: each
    takes its nominal mode's (a non-negative dot product of the scaled unit shapes), and eigenvectors returned
    with every sign turned give the same modes (LAPACK's sign differs between BLAS kernels: kid300 seed 20's psi,
    README worked example 2, was another campaign under Haswell's kernels)."""
    model, tm = Machine.resolve(machine), blind_truth.TruthMachine(machine)
    _, t = blind.make_case(seed, truth, machine=machine)
    _, lam, modes = blind_truth.labelled_modes(tm, model, t)
    reference, _ = blind_truth._reference(tm, model, t)
    assert np.all(np.einsum("ij,ij->j", scaled_unit(modes[:6], tm.length), reference) > 0)
    eigh = scipy.linalg.eigh

    def turned(a, b):
        w, v = eigh(a, b)
        return w, -v

    monkeypatch.setattr(blind_truth.scipy.linalg, "eigh", turned)
    _, lam_turned, modes_turned = blind_truth.labelled_modes(tm, model, t)
    assert np.array_equal(lam_turned, lam) and np.array_equal(modes_turned, modes)


def test_a_complex_modes_phase_is_the_conventions_not_the_eigensolvers():
    """Complex modes of any phase (what two LAPACK builds gave: the same rig's modes of opposite signs) come out
    alike, their largest mass-weighted entry real and positive, of two equally large ones the first."""
    rng = np.random.default_rng(3)
    vectors = rng.standard_normal((4, 3)) + 1j * rng.standard_normal((4, 3))
    mass = np.diag([1.0, 2.0, 0.5, 3.0])
    out = with_real_positive_largest(vectors, mass)
    for phase in (-1.0, 1j, np.exp(0.7j)):
        np.testing.assert_allclose(with_real_positive_largest(vectors * phase, mass), out, rtol=1e-14, atol=0)
    weight = np.abs(out) * np.sqrt(np.diag(mass))[:, None]
    pick = out[np.argmax(weight, axis=0), np.arange(3)]
    assert np.all(pick.real > 0) and np.all(pick.imag == 0)
    np.testing.assert_allclose(np.abs(out), np.abs(vectors), rtol=1e-15)
    tie = np.array([[-0.7071067811865476j], [0.7071067811865475j]])
    for twin in (tie, tie[::-1] * -1):
        assert with_real_positive_largest(twin, np.eye(2))[0, 0] == pytest.approx(0.7071067811865476, rel=1e-15)
