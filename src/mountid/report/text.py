"""Readable text summaries for the command line and the demo."""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from mountid.diagnosis.campaign import Campaign
    from mountid.diagnosis.candidates import EffectsReport
    from mountid.diagnosis.gap import Diagnosis, Residual


def print_diagnosis(diagnosis: Diagnosis, title: str, figure: str | None = None) -> None:
    """The readable summary of a diagnosis (``mountid diagnose`` without --json, and the demo)."""
    report, effects, campaign = diagnosis.where, diagnosis.effects, diagnosis.campaign
    print(f"{title} ({campaign.machine.name})")
    conventions = campaign.conventions()
    print(f"description: {conventions['description']}")
    if conventions["known_from_description"]:
        units = campaign.machine.parameters
        print(
            "known values not in the campaign, the description's used: "
            + ", ".join(f"{n} = {v:.6g} {units[n]['unit']}" for n, v in conventions["known_from_description"].items())
        )
    print(
        f"mode shapes in ({', '.join(conventions['shape_coordinates'])}): {conventions['shape_reference']}; "
        "isolators at [m]: "
        + ", ".join(f"{n} ({', '.join(f'{v:.3g}' for v in p)})" for n, p in conventions["isolators"].items())
    )
    if conventions["damping_parameters"]:
        print(
            "damping ratios compared with the model's: "
            + ", ".join(
                f"{n} = {d['value']:.6g} (known)" if d["from"] == "known" else f"{n} fitted (from {d['value']:.6g})"
                for n, d in conventions["damping_parameters"].items()
            )
        )
    print(f"frequencies: {conventions['frequencies']}")
    for note in campaign.notes:
        print(f"campaign: {note}")
    for note in campaign.record_notes:
        print(f"record: {note}")
    for level, shifts in (campaign.levels.by_level() if campaign.levels else {}).items():
        print(
            f"frequencies at '{level}' against the campaign's: "
            + ", ".join(f"{s.mode} {s.relative:+.2%} ({s.z:+.1f} sigma)" for s in shifts)
        )
    for level, shifts in (campaign.levels.damping_by_level() if campaign.levels else {}).items():
        print(
            f"damping ratios at '{level}' against the campaign's: "
            + ", ".join(f"{s.mode} {s.ratio:.3g} -> {s.at_level:.3g} ({s.z:+.1f} sigma)" for s in shifts)
        )
    print("nominal identification: " + ", ".join(f"{k} = {v:.6g}" for k, v in report.parameters.items()))
    for line in _residual_table(report.residuals):
        print(line)
    within = " (of misses within their uncertainty)" if report.within_noise else ""
    for loc in report.localisation[:3]:
        print(f"  matrix level{within}: {loc.describe()}")
    if diagnosis.isolators:
        print("modal force residual of the measured shapes, as a stiffness change per isolator:")
        print("  " + ", ".join(f"{f.isolator} {f.change:+.1%} +- {f.std:.1%}" for f in diagnosis.isolators))
    _print_candidates(effects, campaign)
    gaps = diagnosis.gap_table()
    if "after" in gaps:
        before, after = gaps["before"], gaps["after"]
        places = _places([m.frequency_std for m in campaign.modes.values()], 4)
        w = places + 5

        def cell(value: float | None, sign: str = "+") -> str:
            if value is None or not math.isfinite(value):  # not held out: a candidate with no data to spare
                return f"{'-':>{w}s}"
            return f"{round(value, places) + 0.0:{sign}{w}.{places}f}"

        print(f"gap [rad/s] before (nominal) -> after ({after['effect']}), fitted | held out:")
        for label in before["fitted"]:
            b, a = before["fitted"][label], after["fitted"][label]
            hb, ha = before["held_out"].get(label), after["held_out"].get(label)
            print(f"  {label:6s}{cell(b)} -> {cell(a)} | {cell(hb)} -> {cell(ha)}")
        print(
            f"  {'RMS':6s}{cell(before['rms_fitted'], '')} -> {cell(after['rms_fitted'], '')} | "
            f"{cell(before['rms_held_out'], '')} -> {cell(after['rms_held_out'], '')}"
        )
    _print_damping(campaign, effects)
    for line in effects.separation:
        print(f"  to separate the tie: {line}")
    for note in [*report.notes, *effects.notes]:
        print(f"  note: {note}")
    if figure:
        print(f"figure: {figure}")
    print(f"verdict: {diagnosis.verdict}")


def _print_damping(campaign: Campaign, effects: EffectsReport) -> None:
    """The measured damping ratios against the nominal fit's (and the first-ranked candidate's), in units of
    their standard deviation: the gap in damping, which the frequency tables do not show."""
    from mountid.diagnosis.fitting import damping_std  # the diagnosis's extras (jsonschema) only where it runs

    nominal, best = effects.nominal, effects.best
    if not nominal.damping_gap:
        return
    after = best is not None and best is not nominal and bool(best.damping_gap)
    print(
        "damping ratio: measured, (measured - model) / std for the nominal fit"
        + (f" -> {best.effect}" if after else "")
        + ":"
    )
    for label, gap in nominal.damping_gap.items():
        m = campaign.modes[label]
        std = damping_std(m)
        text = f"  {label:6s}{m.damping_ratio:8.4f} +- {std:.2g}  {gap / std:+8.2f}"
        print(text + (f" -> {best.damping_gap[label] / std:+8.2f}" if after else ""))


def _print_candidates(effects: EffectsReport, campaign: Campaign) -> None:
    ranked = [f for f in effects.ranked if f.applicable]
    n = effects.nominal
    if n.held_out_rms == n.held_out_rms:
        own = n.held_out_median_predictive
        print(
            f"nominal model held out: RMS {n.held_out_rms:.3g} sigma, median {n.held_out_median:.3g} sigma of the "
            "measurement" + (f" ({own:.3g} in the prediction's own sigma)" if own == own else "")
        )
    from mountid.diagnosis.fitting import chi2_by_kind

    parts = chi2_by_kind(n, campaign) if n.applicable else {}
    split = f" ({', '.join(f'{k} {v:.4g}' for k, v in parts.items())})" if len(parts) > 1 else ""
    print(
        f"candidate effects (fitted with the unknowns to {n.n_data} data; nominal chi^2 = {n.chi2:.4g}{split}, "
        f"probability {n.probability:.3g}), by posterior probability:"
    )
    if effects.kind == "cannot judge":  # no more data than unknowns
        print(
            f"  ({n.n_data} data for {n.n_parameters} unknowns: every candidate fits them exactly and has no mode to "
            "hold out; a probability says how much of its priors' range the data leave, not how well it fits)"
        )
    width = max([22, *(len(f.effect) + 1 for f in effects.ranked)])
    print(f"  {'effect':{width}s}{'prob.':>8s}{'chi^2':>9s}{'held-out':>25s}  parameters (+- std)")
    print(f"  {'':{width}s}{'':>8s}{'':>9s}{'RMS | median | pred.':>25s}  (held-out errors in sigma of the")
    print(f"  {'':{width}s}{'':>8s}{'':>9s}{'':>25s}  measurement; pred.: median in the prediction's own sigma)")
    for f in ranked:
        ho = (
            f"{f.held_out_rms:8.3g} | {f.held_out_median:6.3g} | {f.held_out_median_predictive:5.3g}"
            if f.held_out_rms == f.held_out_rms
            else f"{'-':>24s}"
        )
        params = ", ".join(
            f"{k} = {v:.4g} +- {f.std[k]:.2g}" for k, v in f.parameters.items() if k not in effects.nominal.parameters
        )
        mark = " [tie]" if f.effect in effects.tie else ""
        mark += "" if f.plausible else f" [implausible: {f.implausible_reason}]"
        if f.plausible and f.outside_range:
            mark += f" [{', '.join(f.outside_range)} beyond the plausible range]"
        where = f" at {f.variant}" if f.variant else ""
        print(f"  {f.effect:{width}s}{f.probability:8.3f} {f.chi2:8.4g} {ho}  {params}{where}{mark}")
    for f in effects.ranked:
        if not f.applicable:
            print(f"  {f.effect:{width}s} not applicable: {f.note}")


def _residual_table(residuals: Sequence[Residual]) -> list[str]:
    """The nominal identification's residuals, one row per mode and use, in columns at least two spaces apart:
    frequencies [rad/s] and gaps to the decimal of a tenth of the smallest uncertainty (three places at
    least), the gap's standard deviation (Residual.sigma: a held-out mode's with its prediction's own) and z to
    three significant digits."""
    places = _places([r.uncertainty for r in residuals], 3)
    head = ("mode", "measured", "predicted", "gap", "sigma", "z")
    rows = [
        (
            r.label,
            f"{r.measured:.{places}f}",
            f"{r.predicted:.{places}f}",
            f"{round(r.residual, places) + 0.0:+.{places}f}",
            "" if r.sigma is None else f"{r.sigma:.3g}",
            "" if r.z is None else (f"{round(r.z, 2) + 0.0:+.2f}" if abs(r.z) < 1e4 else f"{r.z:+.3g}"),
            ("held out" if r.held_out else "fitted") + (" *" if r.significant else ""),
        )
        for r in residuals
    ]
    widths = [max(len(x) for x in column) for column in zip(head, *(row[:6] for row in rows), strict=True)]

    def line(cells: Sequence[str]) -> str:
        return "  " + "  ".join(
            c.ljust(w) if i == 0 else c.rjust(w) for i, (c, w) in enumerate(zip(cells, widths, strict=True))
        )

    out = [line(head) + "  use", *(line(row[:6]) + "  " + row[6] for row in rows)]
    if any(r.held_out and r.prediction_std for r in residuals):
        out.append("  (sigma of a held-out mode: the measurement's and its prediction's from the other modes)")
    return out


def _places(stds: Iterable[float | None], least: int) -> int:
    """Decimals [rad/s] that show a tenth of the smallest of ``stds`` (None and zeros ignored): ``least`` to 9."""
    given = [v for v in stds if v]
    return max(least, min(9, 1 - math.floor(math.log10(min(given))))) if given else least
