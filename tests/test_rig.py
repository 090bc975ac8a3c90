"""The virtual test rig: time integration against the closed-form harmonic response."""

from __future__ import annotations

import numpy as np
import pytest

from mountid.errors import InputError
from mountid.measurement.rig import Hammer, Rig, Sensor, Unbalance

UNBALANCE = Unbalance(mass=43.1, eccentricity=0.03, speed=113.0, point=(0.05, -0.02, 0.1))  # paper Sec. 5


def _integration_error(rig: Rig, rate: float) -> float:
    """Max relative difference of q'' between time integration started on the steady state and the
    closed-form steady state, over 2 s at the given internal rate [Hz]."""
    t = np.arange(int(2.0 * rate)) / rate
    w = UNBALANCE.speed
    q, qdd = rig.steady_state(UNBALANCE, t)
    qd = w * rig.steady_state(UNBALANCE, t + np.pi / (2 * w))[0]  # d/dt Re(a e^{iwt}) = w Re(a e^{i(wt + pi/2)})
    _, _, qdd_int = rig.respond(t, rig.unbalance_force(UNBALANCE, t), np.concatenate([q[0], qd[0]]))
    return float(np.max(np.abs(qdd_int - qdd)) / np.max(np.abs(qdd)))


@pytest.mark.parametrize("machine", ["kid300", "rectangular", "screen6"])
def test_time_integration_matches_the_frequency_response(machine):
    """Started on the steady state, the integration must stay on it; its only error is the first-order
    hold of the force between samples, O((w h)^2): halving the step divides it by about 4."""
    rig = Rig.of(machine)
    coarse, fine = _integration_error(rig, 4000.0), _integration_error(rig, 8000.0)
    assert fine < 2e-5
    assert 3.0 < coarse / fine < 5.0


def test_unbalance_force_follows_eqs_29_30():
    rig = Rig.of("kid300")
    t = np.array([0.0, 0.01])
    f = rig.unbalance_force(Unbalance(43.1, 0.03, 157.0), t)
    amp = 43.1 * 0.03 * 157.0**2
    np.testing.assert_allclose(f[:, 0], amp * np.sin(157.0 * t), atol=1e-9 * amp)  # F_x = m_v e w^2 sin wt
    np.testing.assert_allclose(f[:, 1], amp * np.cos(157.0 * t), atol=1e-9 * amp)  # F_y = m_v e w^2 cos wt
    np.testing.assert_allclose(f[:, 2:], 0.0, atol=1e-9 * amp)  # through the origin: no moments


def test_hammer_moves_the_body_by_its_impulse():
    """Right after a short hit the momentum m v equals the force impulse (2/pi peak duration)."""
    rig = Rig.of("kid300")
    hammer = Hammer(point=(0.0, 0.0, 0.0), direction=(1.0, 0.0, 0.0), peak=1000.0, duration=0.002, time=0.001)
    t = np.arange(200) / 40000.0
    force = np.outer(hammer.force(t), rig.force_column(hammer.point, hammer.direction))
    _, qd, _ = rig.respond(t, force)
    impulse = 2 / np.pi * hammer.peak * hammer.duration
    k = np.searchsorted(t, hammer.time + hammer.duration)
    assert rig.values["m"] * qd[k, 0] == pytest.approx(impulse, rel=2e-3)  # springs act little within 2 ms


def test_a_record_at_a_low_rate_samples_the_same_motion():
    """The physics does not depend on how the record is sampled: at 30 Hz (x 8 = 240 Hz, slower than a 4 ms
    hit) the hit fell between the samples and the record was silent. Without the anti-alias filter the 30 Hz
    record is the 1920 Hz one's every 64th sample, to the first-order hold of the force between fine steps
    (RESOLVED = 16 samples per pulse: about (pi/16)^2/12 = 3e-3 of the response)."""
    rig = Rig.of("kid300")
    sensors, hits = [Sensor("a", (0.3, 0, 0.2), (1, 0, 0))], [Hammer((0.3, 0, 0.2), (1, 0, 0))]
    slow = rig.simulate(sensors, 3.0, 30.0, hits, anti_alias=False).data[:, 0]
    fast = rig.simulate(sensors, 3.0, 30.0 * 64, hits, anti_alias=False).data[::64, 0]
    assert np.max(np.abs(slow - fast)) < 1e-2 * np.max(np.abs(fast))


@pytest.mark.parametrize("block", [1001, 4096])
def test_a_record_simulated_in_blocks_is_the_record_simulated_at_once(monkeypatch, block):
    """Rig.simulate integrates long records in blocks (memory): each continues from the state and the anti-alias
    filter's memory of the one before, and the decimation keeps the same fine samples (1001 is no multiple of
    the oversampling). The blocks change nothing beyond rounding, the force channel and noise included."""
    import mountid.measurement.rig as rig_module

    rig = Rig.of("kid300")
    sensors = [Sensor("a", (0.3, 0, 0.2), (1, 0, 0), noise=0.01), Sensor("v", (0.3, 0.1, 0.2), (0, 0, 1))]
    hits = [Hammer((0.3, 0, 0.2), (1, 0, 0.5))]
    whole = rig.simulate(sensors, 2.0, 1024.0, hits, [UNBALANCE], force_channel="F")
    monkeypatch.setattr(rig_module, "BLOCK", block)
    blocked = rig.simulate(sensors, 2.0, 1024.0, hits, [UNBALANCE], force_channel="F")
    assert blocked.data.shape == whole.data.shape
    error = np.abs(blocked.data - whole.data).max(axis=0) / np.abs(whole.data).max(axis=0)
    assert error.max() < 1e-12, error


def test_simulated_record_has_its_sensors_noise_and_clipping():
    rig = Rig.of("kid300")
    sensors = [Sensor("a", (0.3, 0, 0.2), (1, 0, 0)), Sensor("b", (0.3, 0, 0.2), (1, 0, 0), noise=0.05, clip=0.2)]
    rec = rig.simulate(sensors, 2.0, 1000.0, hammers=[Hammer((0.3, 0, 0.2), (1, 0, 0))])
    assert rec.data.shape == (2000, 2) and rec.rate == pytest.approx(1000.0)
    assert np.max(np.abs(rec.channel("b"))) <= 0.2 < np.max(np.abs(rec.channel("a")))
    unclipped = np.abs(rec.channel("a")) < 0.2
    noise = rec.channel("b")[unclipped] - rec.channel("a")[unclipped]
    assert np.std(noise) == pytest.approx(0.05 * np.sqrt(np.mean(rec.channel("a") ** 2)), rel=0.1)


def test_bad_rig_input_is_named():
    rig = Rig.of("kid300")
    with pytest.raises(InputError, match="^duration"):
        rig.simulate([Sensor("a", (0, 0, 0), (1, 0, 0))], 0.0, 1000.0)
    with pytest.raises(InputError, match="^a.direction"):
        rig.simulate([Sensor("a", (0, 0, 0), (0, 0, 0))], 1.0, 1000.0)
