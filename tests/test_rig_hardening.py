"""The rig's hardening isolators: their law against the harness's equivalent linearisation, their integration
against the exact linear one."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mountid.errors import InputError
from mountid.machine import Machine
from mountid.measurement.rig import Hammer, Hardening, Rig, Sensor, Unbalance
from mountid.validation.blind_truth import Truth, TruthMachine, hardening, true_modes, truth_matrices


def _truth(gamma: float) -> tuple[TruthMachine, Truth]:
    tm = TruthMachine("kid300")
    return tm, Truth("nonlinear_isolator", {"gamma": gamma}, {}, "kid300")


def test_the_law_stiffens_by_gamma_at_the_reference_amplitude_in_harmonic_balance():
    """k x (1 + 4/3 gamma (x/ref)^2) at x = A cos(t): its fundamental is k A (1 + gamma (A/ref)^2), the
    harness's stiffening of a mode excited to A (blind_truth._hardened)."""
    law = Hardening(np.array([[1.0]]), np.array([3.0e5]), gamma=0.12, reference=2e-4)
    t = np.linspace(0.0, 2 * math.pi, 4001)[:-1]
    for amplitude in (1e-4, 2e-4, 5e-4):
        beyond = law.force(amplitude * np.cos(t)[:, None])[:, 0]
        fundamental = 2 * np.mean(beyond * np.cos(t))
        assert fundamental == pytest.approx(3.0e5 * amplitude * 0.12 * (amplitude / 2e-4) ** 2, rel=1e-12)


def test_without_hardening_the_integration_is_the_exact_one():
    """gamma = 0: DOP853 through the hammer pulse and an unbalance reproduces the exact modal integration (whose
    only error is the first-order hold of the force between samples, about 1e-5 at this step)."""
    tm, t = _truth(0.0)
    matrices = truth_matrices(tm, t)
    linear = Rig.from_matrices("kid300", *matrices)
    still = Rig.from_matrices("kid300", *matrices, hardening(tm, t, 1e-4))
    hit = Hammer((0.3, 0.3, 0.25), (1.0, 0.7, -0.6), peak=2000.0)
    turning = Unbalance(mass=43.1, eccentricity=0.03, speed=113.0, point=(0.05, -0.02, 0.1))
    time = np.arange(0.0, 2.0, 1 / 40000)
    exact = linear.respond(time, linear.forcing([hit], [turning])(time))
    integrated = still.respond_hardening(time, [hit], [turning])
    for a, b in zip(exact, integrated, strict=True):
        assert np.max(np.abs(a - b)) < 1e-4 * np.max(np.abs(a))
    sensors = [Sensor("S1_z", (0.3, 0.3, 0.25), (0.0, 0.0, 1.0)), Sensor("S2_x", (0.3, -0.3, 0.25), (1.0, 0.0, 0.0))]
    records = [r.simulate(sensors, 3.0, 200.0, hammers=[hit], seed=1, oversample=64) for r in (linear, still)]
    assert np.max(np.abs(records[0].data - records[1].data)) < 2e-4 * np.max(np.abs(records[0].data))


@pytest.mark.parametrize("scale", [1.0, 0.5])
def test_a_hardening_rig_rings_at_the_harness_s_equivalent_frequency(scale):
    """Undamped and hit vertically at the centre, the body rings in its vertical mode alone at a constant
    amplitude: its frequency (zero crossings over 20 periods) is the one the harness's equivalent linearisation
    gives that mode at that amplitude (true_modes at the level A / reference), the stiffening within 3 % of
    itself (harmonic balance neglects O(gamma^2)); half the force gives a quarter of the stiffening."""
    tm, t = _truth(0.15)
    m, c, _ = truth_matrices(tm, t)
    model = Machine.resolve("kid300")
    nominal, _ = true_modes(tm, model, Truth("none", {}, {}, "kid300"))
    z = model.modes.index("z")
    reference = 1e-4
    rig = Rig.from_matrices("kid300", m, c, np.zeros_like(m), hardening(tm, t, reference))
    hit = Hammer((0.0, 0.0, 0.3), (0.0, 0.0, -1.0), peak=scale * 3.5e3, duration=0.002, time=0.0)
    period = 2 * math.pi / nominal[z]
    time = np.arange(0.0, 22 * period, period / 400)
    q, _, _ = rig.respond_hardening(time, [hit])
    free = time > 1.5 * hit.duration
    level = float(np.max(np.abs(q[free] @ rig.hardening.deformation.T))) / reference
    heave = q[free, 2]
    crossing = np.flatnonzero(np.sign(heave[:-1]) != np.sign(heave[1:]))
    at = time[free][crossing] - heave[crossing] * (period / 400) / (heave[crossing + 1] - heave[crossing])
    measured = math.pi * (len(at) - 1) / (at[-1] - at[0])
    expected, _ = true_modes(tm, model, t, level)
    assert 0.5 * scale < level < 2.0 * scale  # the hit reaches the law's range
    assert measured / nominal[z] - 1 == pytest.approx(expected[z] / nominal[z] - 1, rel=0.03)


def test_bad_hardening_is_named():
    rows, k = np.ones((2, 6)), np.ones(2)
    with pytest.raises(InputError, match="gamma"):
        Hardening(rows, k, -0.1, 1e-4)
    with pytest.raises(InputError, match="reference"):
        Hardening(rows, k, 0.1, 0.0)
    with pytest.raises(InputError, match="stiffness"):
        Hardening(rows, np.ones(3), 0.1, 1e-4)
    with pytest.raises(ValueError, match="hardening"):
        Rig.of("kid300").respond_hardening(np.linspace(0, 1, 10), [])
    tm, t = _truth(0.1)
    with pytest.raises(InputError, match="hardening: its deformation rows need one column per coordinate"):
        Rig.from_matrices("kid300", *truth_matrices(tm, t), Hardening(np.ones((2, 5)), np.ones(2), 0.1, 1e-4))


def test_a_hardening_record_simulated_in_blocks_is_the_record_simulated_at_once(monkeypatch):
    """Rig.simulate's blocks (memory) each continue the integration from the state at the last sample before them:
    with hardening isolators (gamma 0.2, the hit reaching about the reference deformation), the blocked record is
    the one simulated at once to the integration's tolerance. (Not under an unbalance as well: a forced hardening
    oscillator can be chaotic, and two integrations then part at any tolerance.)"""
    import mountid.measurement.rig as rig_module

    tm, t = _truth(0.2)
    rig = Rig.from_matrices("kid300", *truth_matrices(tm, t), hardening(tm, t, 3e-4))
    sensors = [Sensor("a", (0.3, 0.0, 0.2), (1.0, 0.0, 0.0)), Sensor("v", (0.3, 0.1, 0.2), (0.0, 0.0, 1.0))]
    hits = [Hammer((0.3, 0.0, 0.2), (1.0, 0.0, 0.5))]
    whole = rig.simulate(sensors, 2.0, 512.0, hits)
    monkeypatch.setattr(rig_module, "BLOCK", 1001)
    blocked = rig.simulate(sensors, 2.0, 512.0, hits)
    assert np.max(np.abs(blocked.data - whole.data)) < 1e-8 * np.max(np.abs(whole.data))  # 1.6e-2 from the linear rig
