"""Benchmarks of the records chain: speed (simulation, file -> stiffness) and accuracy against sdypy-EMA.

Baselines are measured in the same run: scipy.signal.lsim on the same state-space model for the
simulation, and sdypy-EMA's LSCF (an established modal-identification library) on the same records for
accuracy; the issue's absolute targets (< 2 s, < 1 s) are printed beside the times.
"""

from __future__ import annotations

import contextlib
import io
import tempfile
import time
from pathlib import Path

import numpy as np
import scipy.signal

from mountid.identification.from_records import identify_from_record
from mountid.measurement.records import read_csv, write_csv
from mountid.measurement.rig import Hammer, Rig, Sensor
from mountid.validation.paper import TABLE_1, paper_hit, paper_sensors

POINTS = [(0.5, 0.0, 0.1), (0.0, 0.5, 0.1), (-0.5, 0.0, -0.2), (0.0, -0.5, 0.3)]
SENSORS = [
    Sensor(f"p{i}{'xyz'[j]}", p, tuple(float(j == k) for k in range(3)), noise=0.01)
    for i, p in enumerate(POINTS)
    for j in range(3)
]
HIT = Hammer(point=(0.4, 0.3, 0.3), direction=(1.0, 0.7, -0.6))


def speed() -> None:
    rig = Rig.of("kid300")
    t0 = time.perf_counter()
    rig.simulate(SENSORS[:3], 10.0, 2000.0, hammers=[HIT])
    t_sim = time.perf_counter() - t0
    n = 6
    system = scipy.signal.StateSpace(
        rig.A, np.vstack([np.zeros((n, n)), rig._minv]), np.eye(2 * n), np.zeros((2 * n, n))
    )
    t = np.arange(int(10.0 * 2000 * 8)) / 16000.0
    force = np.outer(HIT.force(t), rig.force_column(HIT.point, HIT.direction))
    t0 = time.perf_counter()
    scipy.signal.lsim(system, force, t)
    t_lsim = time.perf_counter() - t0
    print(
        f"simulate 10 s of the 6-DOF model at 2 kHz: {t_sim:.2f} s (target < 2 s); "
        f"scipy.signal.lsim on the same 160k internal steps {t_lsim:.2f} s, ratio {t_lsim / t_sim:.1f}x"
    )
    record = rig.simulate(paper_sensors()[:3], 4.0, 2000.0, hammers=[paper_hit()])
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "r.csv"
        write_csv(record, path)
        t0 = time.perf_counter()
        result = identify_from_record(rig.machine, read_csv(path), TABLE_1, start=0.07)
        t_proc = time.perf_counter() - t0
    print(
        f"4 s, 3-channel, 2 kHz record from file to stiffnesses: {t_proc:.2f} s (target < 1 s); "
        f"c_xy {result.parameters['c_xy']:.0f}, c_z {result.parameters['c_z']:.0f} N/m"
    )


def _lscf(record, force, lower_hz: float, upper_hz: float, approx_hz: list[float]):
    from sdypy import EMA

    spectrum = np.fft.rfft(record.data, axis=0) / np.fft.rfft(force)[:, None]
    freq = np.fft.rfftfreq(len(force), 1 / record.rate)
    with contextlib.redirect_stderr(io.StringIO()), contextlib.redirect_stdout(io.StringIO()):
        model = EMA.Model(frf=spectrum.T, freq=freq, lower=lower_hz, upper=upper_hz, pol_order_high=40)
        model.get_poles("lscf", show_progress=False)
        model.select_closest_poles(approx_hz, f_window=2)
    return 2 * np.pi * np.asarray(model.nat_freq), np.asarray(model.nat_xi)


def accuracy(seeds: tuple[int, ...] = (1, 2, 3)) -> None:
    """Per distinct mode: relative error of frequency and damping ratio, mountid vs sdypy-EMA LSCF, on the
    same kid300 records (12 channels, 1 % noise, one oblique hit). A pole more than 1 % off the mode counts
    as missed."""
    rig = Rig.of("kid300")
    poles = rig.poles[rig.poles.imag > 0]
    w_true, z_true = np.abs(poles), -poles.real / np.abs(poles)
    values = rig.machine.values(rig.values, rig.machine.module.FORWARD_ARGUMENTS)
    nominal = dict(zip(rig.machine.modes, rig.machine.module.frequencies(**values), strict=True))
    print(
        "accuracy per mode, |relative error| of frequency / damping ratio (worst over seeds "
        f"{', '.join(map(str, seeds))}); '-' = missed"
    )
    print(f"  {'record':8s}{'mode':6s}{'mountid':>22s}{'sdypy-EMA LSCF':>24s}")
    for duration in (4.0, 20.0):
        worst: dict[str, list] = {lab: [0.0, 0.0, 0.0, 0.0, False, False] for lab in rig.machine.unique_modes}
        for seed in seeds:
            record = rig.simulate(SENSORS, duration, 2000.0, hammers=[HIT], seed=seed)
            ours = identify_from_record(rig.machine, record, TABLE_1, start=0.06, nominal={"c_xy": 5e4, "c_z": 7e5})
            approx = sorted({nominal[lab] / (2 * np.pi) for lab in rig.machine.unique_modes})
            w_l, z_l = _lscf(record, HIT.force(record.time), 0.5, 25.0, approx)
            for lab in rig.machine.unique_modes:
                j = int(np.argmin(np.abs(w_true - nominal[lab])))
                row = worst[lab]
                if lab in ours.modes:
                    m = ours.modes[lab]
                    row[0] = max(row[0], abs(m.frequency / w_true[j] - 1))
                    row[1] = max(row[1], abs(m.damping_ratio / z_true[j] - 1))
                else:
                    row[4] = True
                k = int(np.argmin(np.abs(w_l - w_true[j]))) if len(w_l) else -1
                if k < 0 or abs(w_l[k] / w_true[j] - 1) > 0.01:
                    row[5] = True
                else:
                    row[2] = max(row[2], abs(w_l[k] / w_true[j] - 1))
                    row[3] = max(row[3], abs(z_l[k] / z_true[j] - 1))
        for lab, (f1, d1, f2, d2, miss1, miss2) in worst.items():
            a = "-" if miss1 else f"{f1:9.1e} / {d1:8.1e}"
            b = "-" if miss2 else f"{f2:9.1e} / {d2:8.1e}"
            print(f"  {duration:4.0f} s   {lab:6s}{a:>22s}{b:>24s}")
