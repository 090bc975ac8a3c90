"""Figures of an experiment (matplotlib, written to files; nothing else in mountid imports this module).

The paper's Figs. 4-6 and the mode shapes: record and band-passed record, spectrum with the picked peaks,
the decay fit of Eq. (25), response under the rotating unbalance, and each mode drawn on the machine; and
the gap diagnosis (residuals before and after, candidate effects ranked).
"""

from __future__ import annotations

import textwrap
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from mountid.machine import Machine
from mountid.measurement import modal
from mountid.measurement.records import Record
from mountid.measurement.settings import RECORDS, RecordSettings


def _save(fig, path: str | Path) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def record_figure(record: Record, channel: str, low: float, high: float, path: str | Path) -> Path:
    """Paper Fig. 4 a): one channel as recorded and band-passed to [low, high] rad/s."""
    y = record.channel(channel)
    fig, ax = plt.subplots(2, 1, figsize=(8, 5), sharex=True)
    ax[0].plot(record.time, y, lw=0.6)
    ax[0].set_ylabel(f"{channel} [{record.channels[record.names.index(channel)].unit}]")
    ax[0].set_title("record")
    ax[1].plot(record.time, modal.band_pass(y, 1 / record.rate, low, high), lw=0.6, color="C1")
    ax[1].set_title(f"band-passed {low:g}-{high:g} rad/s")
    ax[1].set_xlabel("t [s]")
    return _save(fig, path)


def spectrum_figure(record: Record, channel: str, start: float, labels: dict[str, float], path: str | Path) -> Path:
    """Paper Fig. 4 b): Hann-windowed amplitude spectrum of the free decay, the matrix-pencil frequencies
    (lines, labelled) and the raw FFT bin size for comparison."""
    keep = record.time >= start
    omega, amp = modal.spectrum(record.channel(channel)[keep], 1 / record.rate)
    top = 1.6 * max(list(labels.values()) or [omega[-1] / 4])
    sel = omega <= top
    fig, ax = plt.subplots(figsize=(8, 4))
    ax.semilogy(omega[sel], amp[sel], lw=0.8)
    for i, (label, w) in enumerate(sorted(labels.items(), key=lambda kv: kv[1])):
        ax.axvline(w, color="C3", lw=0.8, ls="--")
        ax.text(w, amp[sel].max() * 0.3**i, f" {label} {w:.2f}", color="C3", va="top", fontsize=8)
    bin_ = 2 * np.pi / (record.time[keep][-1] - record.time[keep][0])
    ax.set_title(f"spectrum of {channel} (raw FFT bin {bin_:.2f} rad/s); dashed: matrix-pencil frequencies")
    ax.set_xlabel("omega [rad/s]")
    ax.set_ylabel("amplitude")
    return _save(fig, path)


def decay_figure(
    record: Record,
    channel: str,
    start: float,
    omega: float,
    path: str | Path,
    settings: RecordSettings = RECORDS,
) -> tuple[Path, float, float]:
    """Paper Fig. 5: one mode band-passed as the fit does it (``settings.decay_bandwidth``), and the fitted
    A0 exp(-n t) (Eq. 25). Returns (path, A0, n)."""
    keep = record.time >= start
    t = record.time[keep] - record.time[keep][0]
    bw = settings.decay_bandwidth
    y = modal.band_pass(record.channel(channel)[keep], 1 / record.rate, (1 - bw) * omega, (1 + bw) * omega)
    a0, n = modal.decay_envelope(record.channel(channel)[keep], 1 / record.rate, omega, bw)
    fig, ax = plt.subplots(figsize=(8, 4))
    ax.plot(t, y, lw=0.6, label=f"band-passed at {omega:.2f} rad/s")
    ax.plot(t, a0 * np.exp(-n * t), color="C3", label=f"A0 exp(-n t): A0 = {a0:.3g}, n = {n:.3f} 1/s")
    ax.plot(t, -a0 * np.exp(-n * t), color="C3")
    ax.set_xlabel("t [s]")
    ax.legend()
    return _save(fig, path), a0, n


def unbalance_figure(t: np.ndarray, measured: np.ndarray, model: np.ndarray, speed: float, path: str | Path) -> Path:
    """Paper Fig. 6: a channel's acceleration under the rotating unbalance, measured and from the model."""
    fig, ax = plt.subplots(figsize=(8, 3.5))
    ax.plot(t, measured, lw=0.8, label="measured (rig)")
    ax.plot(t, model, lw=0.8, ls="--", label="identified model, steady state")
    ax.set_title(f"rotating unbalance at {speed:g} rad/s")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("acceleration [m/s^2]")
    ax.legend()
    return _save(fig, path)


def mode_shapes_figure(
    machine: Machine, parameters: dict[str, float], half_size: tuple[float, float, float], path: str | Path
) -> Path:
    """Each mode drawn on the machine: a box of the given half sizes [m] around the origin, at rest (grey)
    and displaced by the mode (scaled for visibility), seen from the side (x-z), the front (y-z) and above (x-y)."""
    mod = machine.module
    args = machine.values(parameters, mod.FORWARD_ARGUMENTS)
    phi = mod.modal_matrix(**args)
    omega = mod.frequencies(**args)
    hx, hy, hz = half_size
    corners = np.array([[sx * hx, sy * hy, sz * hz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    edges = [(i, j) for i in range(8) for j in range(i + 1, 8) if bin(i ^ j).count("1") == 1]
    jac = mod.point_jacobian(corners[:, 0], corners[:, 1], corners[:, 2])  # (8, 3, 6)
    fig, axes = plt.subplots(3, len(mod.MODES), figsize=(2.6 * len(mod.MODES), 7.8))
    for k, label in enumerate(mod.MODES):
        u = jac @ phi[:, k]
        moved = corners + 0.25 * max(hx, hy, hz) * u / np.max(np.abs(u))
        for row, (a, b, name) in enumerate([(0, 2, "x-z"), (1, 2, "y-z"), (0, 1, "x-y")]):
            ax = axes[row, k]
            for i, j in edges:
                ax.plot(corners[[i, j], a], corners[[i, j], b], color="0.75", lw=0.8)
                ax.plot(moved[[i, j], a], moved[[i, j], b], color="C0", lw=1.2)
            ax.set_aspect("equal")
            ax.set_xticks([])
            ax.set_yticks([])
            if row == 0:
                ax.set_title(f"{label}: {omega[k]:.2f} rad/s", fontsize=9)
            if k == 0:
                ax.set_ylabel(name)
    return _save(fig, path)


def diagnosis_figure(diagnosis, path: str | Path, title: str = "") -> Path:
    """Left: each mode's gap in units of its uncertainty, before (nominal) and after the best candidate,
    fitted and held out. Right: the candidates by posterior probability (tie shaded, implausible
    hatched), with the nominal model for reference."""
    effects = diagnosis.effects
    nominal, best = effects.nominal, effects.best
    labels = list(nominal.frequency_gap)
    sigma = np.array([diagnosis.campaign.modes[label].frequency_std for label in labels])
    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4.2), gridspec_kw={"width_ratios": [1.1, 1]})
    x = np.arange(len(labels))
    series = [
        ("before, fitted", nominal.frequency_gap, "#999999"),
        ("before, held out", nominal.held_out_gap, "#cccccc"),
    ]
    if best is not None:
        series += [
            (f"{best.effect}, fitted", best.frequency_gap, "#1f77b4"),
            (f"{best.effect}, held out", best.held_out_gap, "#9ecae1"),
        ]
    width = 0.8 / len(series)
    for k, (name, gap, colour) in enumerate(series):
        z = np.array([gap.get(label, np.nan) for label in labels]) / sigma
        left.bar(x + (k - (len(series) - 1) / 2) * width, z, width, label=name, color=colour)
    left.axhspan(-2, 2, color="#2ca02c", alpha=0.08, label="within 2 sigma")
    left.axhline(0, color="black", lw=0.6)
    left.set_xticks(x, labels)
    left.set_ylabel("measured - model [sigma]")
    left.set_title("gap per mode")
    left.legend(fontsize=7)
    ranked = [f for f in effects.ranked if f.applicable]
    if ranked:
        names = [*(f.effect for f in ranked), "none (nominal)"]
        values = [*(f.probability for f in ranked), nominal.probability]
        colours = ["#1f77b4" if f.effect in effects.tie else "#aaaaaa" for f in ranked] + ["#d62728"]
        hatches = ["" if f.plausible else "//" for f in ranked] + [""]
        y = np.arange(len(names))[::-1]
        bars = right.barh(y, np.maximum(values, 1e-6), color=colours)  # zero stays visible on the log axis
        for bar, hatch, value in zip(bars, hatches, values, strict=True):
            bar.set_hatch(hatch)
            right.text(max(value, 1e-6), bar.get_y() + bar.get_height() / 2, f" {value:.2g}", va="center", fontsize=7)
        right.set_yticks(y, names, fontsize=8)
        right.set_xscale("log")
        right.set_xlim(1e-6, 2)
        right.set_xlabel("posterior probability (tie shaded blue, implausible hatched)")
    else:
        right.text(0.5, 0.5, "too few data to rank candidate effects", ha="center", va="center")
        right.set_axis_off()
    right.set_title("candidate effects")
    heading = f"{title}: {diagnosis.verdict}" if title else diagnosis.verdict
    fig.suptitle(textwrap.fill(heading, 150), fontsize=8)
    return _save(fig, path)
