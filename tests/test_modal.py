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


def test_quality_checks_name_clipping_double_hits_short_records_and_an_early_start():
    rig = Rig.of("kid300")
    sensors = [Sensor("a", (0.4, 0.0, 0.1), (1, 0, 0), noise=0.01), Sensor("b", (0.4, 0.0, 0.1), (0, 0, 1), clip=0.05)]
    good = rig.simulate(sensors[:1], 4.0, 2000.0, hammers=[Hammer((0.4, 0.3, 0.3), (1, 0.7, -0.6))])
    assert modal.hammer_test_quality(good, 17.7, start=0.07) == []
    assert [w.kind for w in modal.hammer_test_quality(good, 17.7, start=0.0)] == ["impact_in_segment"]
    assert modal.hammer_test_quality(good, 17.7, start=0.07, highest_frequency=64.1) == []
    slow = rig.simulate(sensors[:1], 4.0, 50.0, hammers=[Hammer((0.4, 0.3, 0.3), (1, 0.7, -0.6))])
    assert [w.kind for w in modal.hammer_test_quality(slow, 17.7, 0.3, highest_frequency=64.1)] == ["low_rate"]
    bad = rig.simulate(
        sensors, 0.5, 2000.0, hammers=[Hammer((0.4, 0.3, 0.3), (1, 0.7, -0.6), peak=5000.0, second_hit=(0.08, 0.6))]
    )
    kinds = {(w.kind, w.channel) for w in modal.hammer_test_quality(bad, 17.7, start=0.07)}
    assert kinds == {("clipping", "b"), ("double_hit", "all"), ("too_short", "all")}
