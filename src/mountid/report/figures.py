"""Figures of an experiment (matplotlib, written to files; nothing else in mountid imports this module).

The paper's Figs. 4-6 and the mode shapes: record and band-passed record, spectrum with the picked peaks,
the decay fit of Eq. (25), response under the rotating unbalance, and each mode drawn on the machine; the
gap diagnosis (residuals before and after, candidate effects ranked); and the blind validation's reliability
diagram (stated probability against share right).
"""

from __future__ import annotations

import functools
import itertools
import re
import textwrap
from pathlib import Path
from typing import TYPE_CHECKING

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from mountid.errors import InputError
from mountid.identification.from_records import IRF_START
from mountid.machine import Machine
from mountid.measurement import ambient, modal
from mountid.measurement.records import ModeTable, Record
from mountid.measurement.settings import RECORDS, RecordSettings
from mountid.nomenclature import counted

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from mountid.diagnosis.gap import Diagnosis
    from mountid.identification.from_records import Identification
    from mountid.measurement.frf import FrfEstimate


def figure_file(path: str | Path, parameter: str) -> Path:
    """``path`` as a figure file to write, checked before the work that draws it: not a folder, and ending in a
    format matplotlib writes (.png, .pdf, .svg, ...); an InputError naming ``parameter`` otherwise. A folder was
    written to as "<folder>.png" and reported under its own name; ".txt" ended in matplotlib's ValueError after
    the whole diagnosis."""
    from matplotlib.backend_bases import FigureCanvasBase

    path = Path(path)
    if path.is_dir():
        raise InputError(parameter, f"{path} is a folder: name a figure file in it (e.g. {path / 'diagnosis.png'})")
    formats = FigureCanvasBase.get_supported_filetypes()
    if path.suffix.lower().removeprefix(".") not in formats:
        raise InputError(
            parameter,
            f"{path.name}: name a figure file ending in one of {', '.join('.' + f for f in sorted(formats))}",
        )
    return path


def _save(fig: Figure, path: str | Path) -> Path:
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


def spectrum_figure(
    record: Record,
    channels: list[str] | tuple[str, ...] | None,
    start: float,
    poles: dict[str, tuple[float, float]],
    path: str | Path,
    end: float | None = None,
    what: str = "",
) -> Path:
    """Paper Fig. 4 b), every channel: Hann-windowed amplitude spectra of the free decay from ``start`` [s] to
    ``end`` [s] (None: the record's end; a later hit's) (``channels``, default all but force channels), in each
    channel's unit, against rad/s (below) and Hz (above); the picked poles {label: (frequency [rad/s], damping
    ratio)} as labelled lines; the raw FFT bin size for comparison. ``what`` the samples are, for the title (default:
    the free decay, or the impulse responses of frequency response functions)."""
    names = list(channels) if channels else list(record.responses)
    keep = (record.time >= start) & (record.time < (np.inf if end is None else end))
    fig, ax = plt.subplots(figsize=(9, 4.5))
    top = 1.6 * max([w for w, _ in poles.values()] or [np.pi * record.rate / 4])
    units = set()
    peak = 0.0
    for name in names:
        omega, amp = modal.spectrum(record.channel(name)[keep], 1 / record.rate)
        sel = omega <= top
        ax.semilogy(omega[sel], amp[sel], lw=0.7, label=name)
        units.add(record.channels[record.names.index(name)].unit)
        peak = max(peak, float(amp[sel].max()))
    for i, (label, (w, zeta)) in enumerate(sorted(poles.items(), key=lambda kv: kv[1][0])):
        ax.axvline(w, color="k", lw=0.7, ls="--")
        ax.text(w, peak * 0.35**i, f" {label} {w:.2f} rad/s\n zeta {zeta:.3f}", va="top", fontsize=7)
    bin_ = 2 * np.pi / (record.time[keep][-1] - record.time[keep][0])
    until = "" if end is None else f" to {end:.4g} s"
    what = what or ("free decay" if record.impulse is None else "impulse responses")
    ax.set_title(f"spectra of the {what} from {start:g} s{until} (raw FFT bin {bin_:.2f} rad/s); dashed: picked poles")
    ax.set_xlabel("omega [rad/s]")
    ax.set_ylabel(f"amplitude spectrum [{', '.join(sorted(units))}]")
    hz = ax.secondary_xaxis("top", functions=(lambda w: w / (2 * np.pi), lambda f: 2 * np.pi * f))
    hz.set_xlabel("f [Hz]")
    ax.legend(fontsize=7, ncol=2, loc="upper right")
    return _save(fig, path)


def frf_figure(estimate: FrfEstimate, poles: dict[str, tuple[float, float]], path: str | Path) -> Path:
    """The H1 frequency responses of every response channel (magnitude, in its unit per N, logarithmic) and
    their coherence below, against rad/s (and Hz above), the picked poles as labelled lines; the number of
    hits averaged and the exponential window in the title."""
    fig, (mag, coh) = plt.subplots(2, 1, figsize=(9, 6), sharex=True, gridspec_kw={"height_ratios": [2.2, 1]})
    top = 1.6 * max([w for w, _ in poles.values()] or [float(estimate.omega[-1]) / 4])
    sel = (estimate.omega > 0) & (estimate.omega <= top)
    for j, channel in enumerate(estimate.responses):
        mag.semilogy(estimate.omega[sel], np.abs(estimate.h1[sel, j]), lw=0.8, label=channel.name)
        coh.plot(estimate.omega[sel], estimate.coherence[sel, j], lw=0.8)
    units = sorted({c.unit for c in estimate.responses})
    for ax in (mag, coh):
        for w, _ in poles.values():
            ax.axvline(w, color="k", lw=0.7, ls="--")
    for label, (w, zeta) in poles.items():
        mag.text(w, mag.get_ylim()[1], f" {label}\n zeta {zeta:.3f}", va="top", fontsize=7)
    hits = len(estimate.hits)
    window = f", exponential window {estimate.window_decay:.3g} 1/s" if estimate.window_decay else ""
    if estimate.averages:  # a shaker's: what it averages ("3 periods of 16 s of a periodic excitation on F (...)")
        mag.set_title(textwrap.fill(f"H1 of {estimate.averaged}", 110) + "\ndashed: picked poles", fontsize=9)
    else:
        mag.set_title(f"H1 from {counted(hits, 'hit')} on {estimate.force}{window}; dashed: picked poles")
    mag.set_ylabel(f"|H1| [{', '.join(units)} per N]")
    mag.legend(fontsize=7, ncol=2, loc="upper right")
    coh.set_ylim(0, 1.05)
    one = f" (one {estimate.block or 'hit'}: 1)" if (estimate.averages or hits) == 1 else ""
    coh.set_ylabel("coherence" + one)
    coh.set_xlabel("omega [rad/s]")
    hz = mag.secondary_xaxis("top", functions=(lambda w: w / (2 * np.pi), lambda f: 2 * np.pi * f))
    hz.set_xlabel("f [Hz]")
    return _save(fig, path)


def stabilisation_figure(
    runs: list[tuple[int, np.ndarray, np.ndarray]],
    poles: dict[str, tuple[float, float]],
    path: str | Path,
    of: str = "",
) -> Path:
    """The stabilisation diagram (modal.stabilisation): each model order's poles against frequency, stable
    ones (recurring from the previous order within the chain's tolerance, same damping) filled, new ones
    hollow, steady oscillations (|zeta| below RECORDS.steady_damping: a running machine, no mode) as crosses;
    the picked poles as labelled lines; ``of``: what the pencil ran on, for the title (default: not said)."""
    fig, ax = plt.subplots(figsize=(9, 4.5))
    for order, p, stable in runs:
        w = np.abs(p)
        tone = modal.is_tone(p)
        for shown, style in ((stable & ~tone, {"color": "C2"}), (~stable & ~tone, {"mfc": "none", "color": "C1"})):
            ax.plot(w[shown], np.full(shown.sum(), order), "o", ms=4, **style)
        ax.plot(w[tone], np.full(tone.sum(), order), "x", color="C3", ms=5)
    for label, (w, zeta) in poles.items():
        ax.axvline(w, color="k", lw=0.7, ls="--")
        ax.text(w, ax.get_ylim()[1], f" {label}\n zeta {zeta:.3f}", va="top", fontsize=7)
    ax.plot([], [], "o", color="C2", label="stable (recurs from the previous order)")
    ax.plot([], [], "o", mfc="none", color="C1", label="new or moved")
    ax.plot([], [], "x", color="C3", label=f"steady oscillation (|zeta| < {RECORDS.steady_damping:g}): no mode")
    ax.set_xlabel("|p| [rad/s]")
    ax.set_ylabel("model order")
    hz = ax.secondary_xaxis("top", functions=(lambda w: w / (2 * np.pi), lambda f: 2 * np.pi * f))
    hz.set_xlabel("f [Hz]")
    ax.set_title("stabilisation diagram of the matrix pencil" + (f" on {of}" if of else ""))
    ax.legend(fontsize=7, loc="lower right")
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


TWINS_EQUAL = 1e-9
"""Modes whose frequencies differ by less than this (relative) are twins equal at the parameters drawn: any mix of
them is a mode (mode_shapes_figure)."""


def mode_shapes_figure(
    machine: Machine,
    parameters: dict[str, float],
    half_size: tuple[float, float, float],
    path: str | Path,
    measured: dict | None = None,
    sensors: list[tuple[float, float, float]] | None = None,
) -> Path:
    """Each mode drawn on the machine, seen from the side (x-z), the front (y-z) and above (x-y): a box of
    the given half sizes [m] around the origin at rest (grey), displaced by the model's mode at the
    identified ``parameters`` (blue), and where ``measured`` ({label: MeasuredMode}) has its shape in q, by
    the measured one (red, dashed), titled with both frequencies and the MAC of the channel shape; modes the
    record did not give are marked so. A measured shape on twins equal at these parameters (kid300's x and y, psi
    and theta) is any mix of them: the model's mode drawn beside it is the twins' mix nearest it (its corner
    motions projected onto theirs; the MAC of such a shape is its share in their span). The isolators (triangles)
    and the ``sensors`` (dots) are drawn; every shape is scaled so that its largest corner motion is a quarter of
    the box's largest half size."""
    mod = machine.module
    args = machine.values(parameters, mod.FORWARD_ARGUMENTS)
    phi = mod.modal_matrix(**args)
    omega = mod.frequencies(**args)
    measured = measured or {}
    hx, hy, hz = half_size
    corners = np.array([[sx * hx, sy * hy, sz * hz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    edges = [(i, j) for i in range(8) for j in range(i + 1, 8) if bin(i ^ j).count("1") == 1]
    jac = mod.point_jacobian(corners[:, 0], corners[:, 1], corners[:, 2])  # (8, 3, 6)
    isolators = machine.isolator_points(parameters)
    scale = 0.25 * max(hx, hy, hz)
    fig, axes = plt.subplots(3, len(mod.MODES), figsize=(2.6 * len(mod.MODES), 8.2))

    def moved(q: np.ndarray) -> np.ndarray:
        u = jac @ np.asarray(q, dtype=float)
        sign = 1.0 if np.vdot(u.ravel(), (jac @ phi[:, k]).ravel()) >= 0 else -1.0
        return corners + sign * scale * u / np.max(np.abs(u))

    def nearest_mix(k: int, shape: tuple[float, ...]) -> tuple[np.ndarray, bool]:
        """The model's mode k, or where twins of equal frequency share it, their mix nearest ``shape``."""
        twins = [j for j, lab in enumerate(mod.MODES) if mod.REPRESENTATIVE[lab] == mod.REPRESENTATIVE[mod.MODES[k]]]
        if len(twins) < 2 or np.ptp(omega[twins]) > TWINS_EQUAL * omega[k]:
            return phi[:, k], False
        basis = (jac @ phi[:, twins]).reshape(-1, len(twins))
        weights = np.linalg.lstsq(basis, (jac @ np.asarray(shape, dtype=float)).ravel(), rcond=None)[0]
        return phi[:, twins] @ weights, True

    for k, label in enumerate(mod.MODES):
        rep = mod.REPRESENTATIVE[label]
        m = measured.get(label) or (measured.get(rep) if rep == label else None)
        mixed = False
        if m is not None and m.shape is not None:
            mode, mixed = nearest_mix(k, m.shape)
        model = moved(mode if mixed else phi[:, k])
        shown = moved(m.shape) if m is not None and m.shape is not None else None
        for row, (a, b, name) in enumerate([(0, 2, "x-z"), (1, 2, "y-z"), (0, 1, "x-y")]):
            ax = axes[row, k]
            for i, j in edges:
                ax.plot(corners[[i, j], a], corners[[i, j], b], color="0.8", lw=0.8)
                ax.plot(model[[i, j], a], model[[i, j], b], color="C0", lw=1.2)
                if shown is not None:
                    ax.plot(shown[[i, j], a], shown[[i, j], b], color="C3", lw=1.0, ls="--")
            ax.plot(isolators[a], isolators[b], "^", color="0.3", ms=5)
            for point in sensors or ():
                ax.plot(point[a], point[b], "o", color="C1", ms=3)
            ax.set_aspect("equal")
            ax.set_xticks([])
            ax.set_yticks([])
            if k == 0:
                ax.set_ylabel(name)
        title = f"{label}: model {omega[k]:.2f} rad/s" + (" (its twins' mix)" if mixed else "")
        if m is not None:
            title += f"\nmeasured {m.frequency:.2f}" + (f", MAC {m.mac:.2f}" if m.mac is not None else "")
        elif measured and rep in measured:
            title += f"\none pole with {rep}"
        elif measured:
            title += "\nnot in the record"
        axes[0, k].set_title(title, fontsize=8)
    if any(m.shape is not None for m in measured.values()):
        drawn = "red dashed: measured (shape in q); "
    else:  # a legend for lines that are not there read as a measured shape that coincides with the model's
        drawn = "no measured shape (the channels do not span the six motions); " if measured else ""
    fig.suptitle(
        f"blue: model at the identified values; {drawn}triangles: isolators; dots: sensors; largest motion drawn "
        f"as {scale:.2g} m",
        fontsize=8,
    )
    return _save(fig, path)


def experiment_figures(
    machine: Machine,
    record: Record | ModeTable,
    result: Identification,
    known: dict[str, float],
    folder: str | Path,
) -> list[Path]:
    """The figures of an identified record (identify-record --figures, the demo): spectra of every channel
    with the picked poles, the stabilisation diagram, the mode shapes measured beside the model's, and where
    the modes came from a force channel's frequency responses, those with their coherence. A bench's table of modes
    (records.ModeTable) has no samples: the mode shapes only."""
    folder = Path(folder)
    poles = {k: (m.frequency, m.damping_ratio) for k, m in result.modes.items()}
    shapes = functools.partial(
        mode_shapes_figure, machine, {**known, **result.parameters}, (0.5, 0.5, 0.4), folder / "modes.png", result.modes
    )
    if isinstance(record, ModeTable):
        return [shapes([c.point for c in record.channels])]
    si = record.in_si()
    if result.frf is not None and result.frf.averages:  # a shaker's: the impulse responses of its H1, as fitted
        si = result.frf.as_impulse_record()
    responses = si.select(si.responses)
    top = 2.0 * float(max(result.frequencies.values()))
    output_only = bool(result.reference)  # the modes came from correlation functions with it
    if result.frf is not None and not result.frf.averages:  # the poles were fitted on the impulse responses of H1
        runs = modal.stabilisation(result.frf.impulse_responses(), IRF_START, top, len(machine.module.MODES))
    elif output_only:  # the correlation functions with the reference most modes came from
        fitted = ambient.correlations(responses, result.reference).mean
        runs = modal.stabilisation(fitted, ambient.START, top, len(machine.module.MODES))
    else:  # the free decay they were fitted on (until a later hit), or a shaker's or bench's impulse responses
        analysed = responses if result.end is None else responses.before(result.end)
        runs = modal.stabilisation(analysed, result.start, top, len(machine.module.MODES))
    sensors = [c.point for c in responses.channels if np.all(np.isfinite(c.point))]
    out = [
        spectrum_figure(
            si,
            None,
            result.start,
            poles,
            folder / "spectrum.png",
            result.end,
            "output-only record" if output_only else "",
        ),
        stabilisation_figure(
            runs,
            poles,
            folder / "stabilisation.png",
            f"the correlation functions with {result.reference}" if output_only else "",
        ),
        shapes(sensors),
    ]
    if result.inputs:  # several shakers at once: each force's frequency responses
        for estimate in result.inputs:
            name = re.sub(r"[^A-Za-z0-9_.-]", "_", estimate.force)  # a UFF channel's "node100:0"
            out.append(frf_figure(estimate, poles, folder / f"frf_{name}.png"))
    elif result.frf is not None:
        out.append(frf_figure(result.frf, poles, folder / "frf.png"))
    return out


def diagnosis_figure(diagnosis: Diagnosis, path: str | Path, title: str = "") -> Path:
    """Left: each mode's gap in units of its uncertainty, before (nominal) and after the best candidate,
    fitted and held out (linear within 2 sigma, logarithmic beyond; a held-out gap with its prediction's own
    standard deviation as an error bar), and each measured damping ratio's (fitted).
    Right: the candidates by posterior probability (tie shaded, implausible hatched, those the data fit as well as
    the first marked: candidates.alike), with the nominal model for reference."""
    effects = diagnosis.effects
    nominal, best = effects.nominal, effects.best
    labels = list(nominal.frequency_gap)
    sigma = np.array([diagnosis.campaign.modes[label].frequency_std for label in labels])
    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4.2), gridspec_kw={"width_ratios": [1.1, 1]})
    x = np.arange(len(labels))
    # (name, frequency gaps, colour, damping-ratio gaps: the fitted series only, held-out variances: the held-out)
    series = [
        ("before, fitted", nominal.frequency_gap, "#999999", nominal.damping_gap, None),
        ("before, held out", nominal.held_out_gap, "#cccccc", None, nominal.held_out_variance),
    ]
    if best is not None:
        series += [
            (f"{best.effect}, fitted", best.frequency_gap, "#1f77b4", best.damping_gap, None),
            (f"{best.effect}, held out", best.held_out_gap, "#9ecae1", None, best.held_out_variance),
        ]
    width = 0.8 / len(series)
    for k, (name, gap, colour, _, variance) in enumerate(series):
        z = np.array([gap.get(label, np.nan) for label in labels]) / sigma
        # a held-out prediction's own standard deviation (the refit without the mode, propagated): a mode that
        # alone determines a parameter is predicted hundreds of sigma off within a spread as wide
        spread = None if variance is None else np.sqrt([variance.get(label, np.nan) for label in labels])
        left.bar(
            x + (k - (len(series) - 1) / 2) * width,
            z,
            width,
            # a series without a bar (held out where no mode can be left out: as many parameters as data) is
            # left out of the legend, which would promise it
            label=name if np.isfinite(z).any() else f"_{name}",
            color=colour,
            yerr=spread,
            error_kw={"lw": 0.7, "capsize": 1.5, "ecolor": "#555555"},
        )
    damped = list(nominal.damping_gap)  # the damping ratios' gaps beside the frequencies'
    if damped:
        from mountid.diagnosis.fitting import damping_std

        xd = len(labels) + 0.5 + np.arange(len(damped))
        std = np.array([damping_std(diagnosis.campaign.modes[label]) for label in damped])
        for k, (_, _, colour, damping_gap, _) in enumerate(series):
            if damping_gap is not None:
                z = np.array([damping_gap.get(label, np.nan) for label in damped]) / std
                left.bar(xd + (k - (len(series) - 1) / 2) * width, z, width, color=colour)
        left.axvline(len(labels) - 0.25, color="#888888", lw=0.6, ls=":")
        x = np.concatenate([x, xd])
        labels = [*labels, *(f"\u03b6 {label}" for label in damped)]
    left.axhspan(-2, 2, color="#2ca02c", alpha=0.08, label="within 2 sigma")
    left.axhline(0, color="black", lw=0.6)
    # gaps span from a fraction of a sigma to hundreds (a held-out mode that alone determined a parameter):
    # linear within 2 sigma, logarithmic beyond
    left.set_yscale("symlog", linthresh=2.0)
    left.set_xticks(x, labels)
    left.set_ylabel(
        "measured - model [sigma] (logarithmic beyond 2)\nwhiskers: a held-out prediction's own std", fontsize=8
    )
    left.set_title("gap per mode")
    left.legend(fontsize=7)
    ranked = [f for f in effects.ranked if f.applicable]
    if ranked:
        alike = {s.rival for s in effects.alike()}  # the data fit them as well as the first: the order is the priors'
        names = [*(f.effect + (" (fits as well)" if f.effect in alike else "") for f in ranked), "none (nominal)"]
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
        right.set_xlabel(
            "posterior probability (tie: blue, implausible: hatched;\n"
            "fits as well: as the first, their order is the priors')"
        )
    else:
        right.text(0.5, 0.5, "too few data to rank candidate effects", ha="center", va="center")
        right.set_axis_off()
    right.set_title("candidate effects")
    heading = f"{title}: {diagnosis.verdict}" if title else diagnosis.verdict
    fig.suptitle(textwrap.fill(heading, 150), fontsize=8)
    return _save(fig, path)


RELIABILITY_INTERVAL = 0.9
"""Confidence of the Wilson interval drawn about each bin's observed share right (reliability_figure)."""


def reliability_figure(
    panels: dict[str, dict[str, tuple[np.ndarray, np.ndarray]]],
    path: str | Path,
    bins: tuple[float, ...] = (0.0, 0.5, 0.8, 0.95, 0.99, 1.0 + 1e-12),
    title: str = "",
    columns: int = 3,
) -> Path:
    """Reliability diagram: one panel per entry of ``panels`` (``columns`` to a row), in it one series per entry
    (stated probabilities of the first-ranked candidate and whether it was right, 1 or 0, as two arrays). Per
    non-empty bin of ``bins`` a point at (mean stated, observed share right), its area proportional to the
    verdicts in the bin, with the RELIABILITY_INTERVAL Wilson interval of the share (scipy.stats.binomtest); on
    the diagonal the probabilities mean what they say."""
    from scipy.stats import binomtest

    rows = -(-len(panels) // columns)
    width = min(columns, len(panels))
    fig, axes = plt.subplots(rows, width, figsize=(4.2 * width, 4.0 * rows), squeeze=False, sharex=True, sharey=True)
    markers = ("o", "s", "^", "D", "v")
    left = 0.3  # the axis starts here unless a bin's mean stated probability lies below it
    for ax, (name, series) in zip(axes.flat, panels.items(), strict=False):
        ax.plot([0, 1], [0, 1], color="black", lw=0.6, label="stated = observed")
        for k, (label, (stated, right)) in enumerate(series.items()):
            stated, right = np.asarray(stated, dtype=float), np.asarray(right, dtype=float)
            x, y, low, high, count = [], [], [], [], []
            for lo, hi in itertools.pairwise(bins):
                inside = (stated >= lo) & (stated < hi)
                n = int(inside.sum())
                if not n:
                    continue
                hits = int(round(right[inside].sum()))
                interval = binomtest(hits, n).proportion_ci(RELIABILITY_INTERVAL, method="wilson")
                x.append(float(stated[inside].mean()))
                y.append(hits / n)
                low.append(hits / n - interval.low)
                high.append(interval.high - hits / n)
                count.append(n)
            if not x:
                continue
            total = sum(count)
            left = min(left, min(x) - 0.05)
            colour = f"C{k}"
            ax.errorbar(x, y, yerr=[low, high], fmt="none", ecolor=colour, elinewidth=0.8, capsize=2)
            ax.scatter(
                x,
                y,
                s=[12 + 300 * n / total for n in count],
                color=colour,
                marker=markers[k % len(markers)],
                alpha=0.75,
                label=f"{label}: {total}",
                zorder=3,
            )
        ax.set_ylim(0.0, 1.02)
        ax.set_title(name, fontsize=9)
        ax.legend(fontsize=7, loc="lower right")
    axes[0][0].set_xlim(max(left, 0.0), 1.01)  # shared by every panel
    for ax in axes.flat[len(panels) :]:
        ax.set_axis_off()
    for ax in axes[-1]:
        ax.set_xlabel("stated probability of the first-ranked candidate")
    for ax in axes[:, 0]:
        ax.set_ylabel(f"share right ({RELIABILITY_INTERVAL:.0%} Wilson interval)")
    if title:
        fig.suptitle(textwrap.fill(title, 150), fontsize=9)
    return _save(fig, path)
