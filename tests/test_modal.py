"""Modal estimation pieces: spectrum peaks, MAC, hammer-test quality checks."""

from __future__ import annotations

import numpy as np
import pytest

from mountid.measurement import modal
from mountid.measurement.rig import Hammer, Rig, Sensor


def test_spectrum_peak_is_refined_below_the_bin():
    """A 4 s record has a 1.57 rad/s bin; the interpolated peak of a lightly damped sine lands within a
    small fraction of it."""
    dt, w = 1 / 200.0, 17.71
    t = np.arange(800) * dt
    y = np.exp(-0.1 * t) * np.sin(w * t)
    omega, amp = modal.spectrum(y, dt, pad=1)
    assert omega[1] - omega[0] == pytest.approx(2 * np.pi / 4.0)
    (peak,) = modal.spectrum_peaks(omega, amp, 1)
    assert abs(peak - w) < 0.05 * (omega[1] - omega[0])


def test_mac_is_scale_and_phase_invariant():
    a = np.array([1.0, 2.0, -0.5])
    assert modal.mac(a, -3j * a) == pytest.approx(1.0)
    assert modal.mac(a, np.array([2.0, -1.0, 0.0])) == pytest.approx(0.0, abs=1e-15)


def test_mac_matrix_pairs_every_column():
    rng = np.random.default_rng(3)
    a = rng.normal(size=(6, 3)) + 1j * rng.normal(size=(6, 3))
    b = np.column_stack([rng.normal(size=(6, 3)), np.zeros(6)])
    got = modal.mac_matrix(a, b)
    vdot = [
        [
            abs(np.vdot(a[:, i], b[:, j])) ** 2 / (np.vdot(a[:, i], a[:, i]).real * np.vdot(b[:, j], b[:, j]).real)
            if j < 3
            else 0.0
            for j in range(4)
        ]
        for i in range(3)
    ]
    assert got.shape == (3, 4)
    np.testing.assert_allclose(got, vdot, rtol=1e-13, atol=0)
    # the same definition, not the same bits: a one-column product may take another BLAS kernel than the matrix's
    assert modal.mac(a[:, 0], b[:, 0]) == pytest.approx(got[0, 0], rel=1e-14, abs=0)


def test_quality_checks_name_clipping_double_hits_short_records_and_an_early_start():
    rig = Rig.of("kid300")
    sensors = [Sensor("a", (0.4, 0.0, 0.1), (1, 0, 0), noise=0.01), Sensor("b", (0.4, 0.0, 0.1), (0, 0, 1), clip=0.05)]
    good = rig.simulate(sensors[:1], 4.0, 2000.0, hammers=[Hammer((0.4, 0.3, 0.3), (1, 0.7, -0.6))])
    assert modal.hammer_test_quality(good, 17.7, start=0.07) == []
    assert [w.kind for w in modal.hammer_test_quality(good, 17.7, start=0.0)] == ["impact_in_segment"]
    early = modal.hammer_test_quality(good, 17.7, start=0.01)[0].message
    assert early.endswith("lies in the analysed segment (from 0.01 s)")
    # a start before the first sample: the segment starts where the record does (it read "from -1 s")
    assert modal.hammer_test_quality(good, 17.7, start=-1.0)[0].message.endswith("(from the record's start)")
    assert modal.hammer_test_quality(good, 17.7, start=0.07, highest_frequency=64.1) == []
    slow = rig.simulate(sensors[:1], 4.0, 50.0, hammers=[Hammer((0.4, 0.3, 0.3), (1, 0.7, -0.6))])
    assert [w.kind for w in modal.hammer_test_quality(slow, 17.7, 0.3, highest_frequency=64.1)] == ["low_rate"]
    bad = rig.simulate(
        sensors, 0.5, 2000.0, hammers=[Hammer((0.4, 0.3, 0.3), (1, 0.7, -0.6), peak=5000.0, second_hit=(0.08, 0.6))]
    )
    kinds = {(w.kind, w.channel) for w in modal.hammer_test_quality(bad, 17.7, start=0.07)}
    assert kinds == {("clipping", "b"), ("double_hit", "all"), ("too_short", "all")}


@pytest.mark.parametrize("factor", [2, 3, 7, 12, 16])
def test_numpy_decimation_is_scipys(factor):
    """modal.decimate is scipy.signal.decimate (FIR, zero phase) without importing scipy.signal."""
    import scipy.signal

    x = np.random.default_rng(factor).standard_normal((997 + factor, 3))
    reference = scipy.signal.decimate(x, factor, ftype="fir", zero_phase=True, axis=0)
    assert np.allclose(modal.decimate(x, factor), reference, rtol=0, atol=1e-13)
    assert modal.decimate(x[:0], factor).shape == (0, 3)  # an empty segment stays empty


@pytest.mark.parametrize("seed", range(6))
def test_burst_peaks_are_scipys_find_peaks(seed):
    """modal.find_bursts against scipy.signal.find_peaks with height, distance and prominence, on the burst
    levels of records with and without second hits (the signals impact_bursts gives it)."""
    import scipy.signal

    rng = np.random.default_rng(seed)
    second = None if seed % 2 else (float(rng.uniform(0.02, 0.2)), float(rng.uniform(0.1, 1.0)))
    hit = Hammer((0.4, 0.3, 0.3), (1, 0.7, -0.6), duration=float(rng.uniform(0.002, 0.01)), second_hit=second)
    record = Rig.of("kid300").simulate(
        [Sensor("a", (0.4, 0.0, 0.1), (1, 0, 0), noise=0.01)], 2.0, 2048.0, hammers=[hit], seed=seed
    )
    level = np.abs(np.diff(record.data[:, 0]))
    smooth = np.convolve(level, np.ones(20) / 20, mode="same")
    for height, distance, prominence in ((0.1, 30, 0.05), (0.02, 5, 0.01), (0.3, 60, 0.2)):
        h = height * smooth.max()
        ours = modal.find_bursts(smooth, h, distance, prominence * smooth.max())
        theirs, _ = scipy.signal.find_peaks(smooth, height=h, distance=distance, prominence=prominence * smooth.max())
        assert ours.tolist() == theirs.tolist()


def test_amplitude_standard_deviations_match_their_scatter():
    """modal.amplitude_standard_deviations against 300 noisy records of three known damped exponentials in four
    channels of different noise (two modes 0.5 Hz apart): the RMS error of every complex amplitude lies within
    15 % of its stated standard deviation (sampling error of 600 degrees of freedom about 3 %)."""
    rng = np.random.default_rng(1)
    dt, n = 0.002, 3000
    t = np.arange(n) * dt
    poles = np.array([-0.5 + 2j * np.pi * 3, -1.0 + 2j * np.pi * 7.5, -0.8 + 2j * np.pi * 8.0])
    both = np.concatenate([poles, poles.conj()])
    amp = rng.normal(size=(3, 4)) + 1j * rng.normal(size=(3, 4))
    clean = 2 * np.real(np.exp(np.outer(t, poles)) @ amp)
    sigma = np.array([0.05, 0.2, 0.1, 0.5])
    errors, stated = [], []
    for _ in range(300):
        y = clean + rng.normal(size=clean.shape) * sigma
        errors.append(modal.amplitudes(y, dt, both)[:3] - amp)
        stated.append(modal.amplitude_standard_deviations(y, dt, both)[:3])
    ratio = np.sqrt(np.mean(np.abs(np.array(errors)) ** 2, axis=0)) / np.mean(stated, axis=0)
    assert np.all(np.abs(ratio - 1) < 0.15), ratio


def test_the_matrix_pencil_recovers_the_poles_of_noise_free_decays():
    """Three damped exponentials (two of them 1.5 % apart) in four channels, no noise: every pole to 1e-8
    relative at both pencil sizes; the Gram matrix accumulated channel by channel is that of the stacked Hankel
    matrices (its definition) to rounding."""
    dt, n = 0.005, 3000
    poles = np.array([-0.9 + 18.0j, -1.0 + 18.27j, -2.5 + 40.0j])
    t = np.arange(n) * dt
    rng = np.random.default_rng(2)
    weights = rng.normal(size=(len(poles), 4)) + 1j * rng.normal(size=(len(poles), 4))
    samples = np.real(np.exp(np.outer(t, poles)) @ weights)
    for size in modal.PENCIL_SIZES:
        found = modal.matrix_pencil(samples, dt, 6, size)
        found = np.sort_complex(found[found.imag > 0])
        assert np.allclose(found, np.sort_complex(poles), rtol=1e-8, atol=0)
    L = modal.PENCIL_SIZES[0]
    idx = np.arange(n - L)[:, None] + np.arange(L + 1)[None, :]
    stacked = np.concatenate([samples[:, j][idx] for j in range(samples.shape[1])], axis=0)
    reference = np.linalg.eigh(stacked.T @ stacked)[1][:, ::-1][:, :6]
    basis = modal._signal_basis(samples, 6, L)[:, :6]
    assert np.allclose(np.abs(basis.T @ reference), np.eye(6), atol=1e-9)


def test_the_shape_uncertainty_of_two_close_poles_holds_what_their_error_moves_between_them():
    """Two modes 0.15 rad/s apart at zeta 0.03 (half-power bandwidth 0.6 rad/s), four channels, 40 noise seeds:
    the stated standard deviation of each pole's channel amplitudes describes the error of its shape (after the
    complex scale a normalised shape removes) within 0.7-1.4 in RMS; the least squares' own, the poles taken as
    exact (amplitude_standard_deviations), understates it about twice (the other pole's error moves amplitude
    between the two)."""
    dt, n = 0.01, 4000
    t = np.arange(n) * dt
    poles = np.array([complex(-0.03 * w, w * np.sqrt(1 - 0.03**2)) for w in (10.0, 10.15)])
    shapes = np.array([[1.0, 0.5, -0.3, 0.8], [0.2, -1.0, 0.7, 0.4]], dtype=complex)
    clean = sum(2 * np.real(np.outer(np.exp(p * t), s)) for p, s in zip(poles, shapes, strict=True))
    error, stated, exact = [], [], []
    for seed in range(40):
        y = clean + 0.05 * np.random.default_rng(seed).standard_normal(clean.shape)
        fit = modal._refined(y, dt, poles)
        found = np.array([p.p for p in fit])
        for i, p in enumerate(fit):
            scaled = p.shape * (np.vdot(p.shape, shapes[i]) / np.vdot(p.shape, p.shape))
            error.append(np.sum(np.abs(scaled - shapes[i]) ** 2))
            stated.append(np.sum(p.shape_std**2))
        exact += list(
            np.sum(modal.amplitude_standard_deviations(y, dt, np.concatenate([found, found.conj()]))[:2] ** 2, axis=1)
        )
    assert 0.7 < np.sqrt(np.mean(error) / np.mean(stated)) < 1.4
    assert np.sqrt(np.mean(error) / np.mean(exact)) > 1.8


def _two_modes_in_noise() -> tuple[float, np.ndarray, np.ndarray]:
    """Three channels of two damped modes (17.7 and 36.9 rad/s, zeta 0.034 and 0.081) for 40 s at 100 Hz with
    white noise of 0.01: (dt [s], samples, the true poles)."""
    dt, n = 0.01, 4000
    t = np.arange(n) * dt
    truth = np.array([-0.6 + 17.7j, -3.0 + 36.9j])
    rng = np.random.default_rng(4)
    samples = np.column_stack(
        [np.real(np.exp(np.outer(t, truth)) @ np.array([1.0, 0.7j * (c + 1)])) for c in range(3)]
    ) + 0.01 * rng.standard_normal((n, 3))
    return dt, samples, truth


def test_a_clipped_refinement_goes_on_past_a_pole_the_data_do_not_hold():
    """Two damped modes in noise, refined from seeds 1 % off, with a third seed where the data hold nothing (the
    estimate's noise in correlation functions gives such poles): its first Gauss-Newton step is long, and the plain
    refinement stops there, every pole left at its seed; clipped (each pole's step cut to 5 % of |p| and half its way
    to the imaginary axis) the two modes reach where the refinement of them alone does, to 1 % of the way their
    seeds were off (7e-4 seen: the stray pole takes up a little of the noise), the stray one moved at most 5 % of
    |p| per step."""
    dt, samples, truth = _two_modes_in_noise()
    seeds = truth * 1.01
    alone, _ = modal.refine_poles(samples, dt, seeds)
    stray = np.append(seeds, -0.01 + 60.0j)
    plain, _ = modal.refine_poles(samples, dt, stray)
    np.testing.assert_array_equal(plain, stray)
    clipped, _ = modal.refine_poles(samples, dt, stray, clipped=True)
    assert np.all(np.abs(clipped[:2] - alone) < 0.01 * np.abs(seeds - alone))
    assert abs(clipped[2] - stray[2]) <= 10 * 0.05 * 1.05**10 * abs(stray[2])


def test_a_clipped_refinement_walks_a_far_seed_to_its_pole_in_short_steps():
    """A seed 6 to 25 % off its pole (beyond one 5 % step) walks there in clipped steps, to where a seed 1 % off
    goes, for every offset: the step cut to exactly 5 % of |p| is not then taken for a long one by the rounding of
    the cut (which stopped the refinement part of the way in 14 of these 20 offsets)."""
    dt, samples, truth = _two_modes_in_noise()
    near, _ = modal.refine_poles(samples, dt, truth * 1.01)
    for off in np.linspace(1.06, 1.25, 20):
        seeds = np.array([truth[0] * 1.01, truth[1] * off])
        walked, _ = modal.refine_poles(samples, dt, seeds, clipped=True, max_steps=20)
        np.testing.assert_allclose(walked, near, rtol=1e-6, err_msg=f"seed {off:.2f} of the pole")
