"""Commands on a machine model: frequencies, identify, modes, describe, demo."""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable
from typing import TypeVar

from mountid.cli.arguments import (
    beyond_first_order,
    defaults_note,
    file_to_write,
    pairs,
    point_on_machine,
    print_json,
)
from mountid.errors import InputError
from mountid.machine import Machine
from mountid.nomenclature import FREQUENCY_UNITS, counted
from mountid.report.text import print_diagnosis

T = TypeVar("T")


def cmd_frequencies(args: argparse.Namespace) -> None:
    machine = Machine.resolve(args.machine)
    given = pairs(args.set, "--set")
    freqs = machine.frequencies(given)
    defaults = machine.defaults(given, machine.module.FORWARD_ARGUMENTS)
    if args.json:
        print_json({"machine": machine.name, "unit": "rad/s", "frequencies": freqs, "defaults": defaults})
        return
    print(f"{machine.name}: natural frequencies")
    for label, w in freqs.items():
        print(f"  {label:>8s}  {w:12.6g} rad/s  {w / (2 * math.pi):10.5g} Hz")
    defaults_note(machine, defaults)


def cmd_identify(args: argparse.Namespace) -> None:
    machine = Machine.resolve(args.machine)
    measured = pairs(args.measured, "--measured", FREQUENCY_UNITS)
    if not measured:
        raise InputError("--measured", "give the measured frequencies as label=rad/s (or in hertz: x=2.82Hz)")
    given = pairs(args.set, "--set")
    std = pairs(args.std, "--std", FREQUENCY_UNITS) if args.std else None
    chosen = _named_as_option(lambda: machine.distinct_measured(measured), "--measured")
    _named_as_option(lambda: machine.measured_std(chosen, std), "--std")
    if len(chosen) > len(machine.unknown):
        _identify_least_squares(args, machine, given, measured, std)
        return
    if args.root:
        raise InputError("--root", "picks between least-squares fits: give more frequencies than unknowns")
    solutions = machine.identify(given, measured, std)
    defaults = _known_defaults(machine, given)
    if args.json:
        print_json(
            {
                "machine": machine.name,
                "measured": measured,
                "solutions": [
                    {
                        "parameters": s.parameters,
                        "frequencies": s.frequencies,
                        "condition": s.condition,
                        **({"parameter_std": s.std} if s.std is not None else {}),
                    }
                    for s in solutions
                ],
                "defaults": defaults,
            }
        )
        return
    given = ", ".join(f"{label} {value:.6g}" for label, value in measured.items())
    print(f"{machine.name}: {counted(len(solutions), 'admissible solution')} for {given} rad/s")
    for k, s in enumerate(solutions, 1):
        params = ", ".join(
            f"{n} = {v:.6g}"
            + (f" +- {s.std[n]:.2g}" if s.std is not None else "")
            + f" {machine.parameters[n]['unit']}"
            for n, v in s.parameters.items()
        )
        print(f"  [{k}] {params}")
        print("      frequencies: " + ", ".join(f"{lab} {w:.5g}" for lab, w in s.frequencies.items()) + " rad/s")
        print(f"      relative condition number {s.condition:.3g} (relative change of the unknowns per relative change")
        print("      of the measured frequencies)")
        beyond_first_order(s.parameters, s.std)
    defaults_note(machine, defaults)


def _named_as_option(check: Callable[[], T], option: str) -> T:
    """``check()``, its InputError (which names a mode label) naming the option that gave the label, as the
    command line gave it: "--std psi: ..." (a label may be in --measured and in --std)."""
    try:
        return check()
    except InputError as exc:
        raise InputError(f"{option} {exc.parameter}", exc.reason) from None


def _known_defaults(machine: Machine, given: dict[str, float]) -> dict[str, float]:
    """The known parameters not given that take the description's nominal value (the note of identify)."""
    return machine.defaults(given, tuple(a for a in machine.module.FORWARD_ARGUMENTS if a not in machine.unknown))


def _identify_least_squares(
    args: argparse.Namespace,
    machine: Machine,
    given: dict[str, float],
    measured: dict[str, float],
    std: dict[str, float] | None,
) -> None:
    """More distinct frequencies than unknowns: one least-squares fit, its residuals and goodness of fit."""
    from mountid.identification.frequency_fit import fit_frequencies

    fit = fit_frequencies(machine, given, measured, std, args.root)
    defaults = _known_defaults(machine, given)
    if args.json:
        print_json(
            {
                "machine": machine.name,
                "measured": measured,
                "fit": {
                    "parameters": fit.parameters,
                    "parameter_std": fit.std,
                    "frequencies": fit.fitted,
                    "dof": fit.dof,
                    **({"chi2": fit.chi2, "p_value": fit.p_value} if fit.frequency_std is not None else {}),
                    "notes": list(fit.notes),
                },
                "defaults": defaults,
            }
        )
        return
    n = len(fit.measured)
    print(
        f"{machine.name}: least-squares fit of {', '.join(machine.unknown)} to {n} measured frequencies "
        f"({counted(fit.dof, 'degree')} of freedom)"
    )
    params = ", ".join(
        f"{k} = {v:.6g} +- {float(f'{fit.std[k]:.2g}'):g} {machine.parameters[k]['unit']}"
        for k, v in fit.parameters.items()
    )
    print(f"  {params}")
    beyond_first_order(fit.parameters, fit.std, "  ")
    print(
        f"  {'mode':>8s}  {'measured':>10s}  {'fitted':>10s}  {'residual':>9s}"
        + ("  [sigma]" if fit.frequency_std is not None else "")
    )
    for label, w in fit.measured.items():
        model = fit.fitted[label]
        line = f"  {label:>8s}  {w:10.5g}  {model:10.5g}  {100 * (model - w) / w:+8.2f}%"
        if fit.frequency_std is not None:
            z = (model - w) / fit.frequency_std[label]
            line += f"  {z:+7.2f}" if abs(z) < 1e4 else f"  {z:+7.2g}"
        print(line)
    if fit.frequency_std is not None:
        verdict = "within their uncertainty" if fit.p_value >= 0.01 else "beyond their uncertainty"
        print(
            f"  chi^2 = {fit.chi2:.3g} on {counted(fit.dof, 'degree')} of freedom "
            f"(p = {fit.p_value:.2g}): the model fits the frequencies {verdict}"
        )
        if fit.p_value < 0.01:
            print(
                "  note: which unmodelled effect explains the gap, and how far adding it closes it: `mountid diagnose`"
                " on a campaign file of these frequencies (README, gap diagnosis)"
            )
    else:
        print(
            "  no --std given: the standard deviations come from the scatter of the frequencies about the fit "
            f"(RMS {100 * fit.rms_scatter:.2g} % of the frequencies)"
        )
    for note in fit.notes:
        print(f"  note: {note}")
    defaults_note(machine, defaults)


def cmd_modes(args: argparse.Namespace) -> None:
    machine = Machine.resolve(args.machine)
    m = machine.module
    given = pairs(args.set, "--set")
    values = machine.values(given, m.FORWARD_ARGUMENTS)
    freqs = machine.evaluate("frequencies", values)
    phi = machine.evaluate("modal_matrix", values)
    energy = machine.evaluate("kinetic_energy_distribution", values)
    defaults = machine.defaults(given, m.FORWARD_ARGUMENTS)
    if args.point and not args.uff:
        raise InputError("--point", "gives the nodes of --uff: give the file to write")
    if args.uff:
        file_to_write(args.uff, "--uff", {".uff": "UFF mode shapes", ".unv": "UFF mode shapes"})  # before any work
    written = _modes_uff(machine, given, args.uff, args.point) if args.uff else None
    if args.json:
        print_json(
            {
                "machine": machine.name,
                "modes": list(m.MODES),
                "coordinates": list(m.COORDINATES),
                "frequencies": dict(zip(m.MODES, map(float, freqs), strict=True)),
                "modal_matrix": phi.tolist(),
                "kinetic_energy_distribution": energy.tolist(),
                "defaults": defaults,
                **({"uff": written} if written else {}),
            }
        )
        return
    head = "".join(f"{lab:>9s}" for lab in m.MODES)
    print(f"{machine.name}: mass-normalised modal matrix (rows: coordinates, columns: modes)")
    print(f"{'':>8s}{head}\n{'rad/s':>8s}" + "".join(_cell(w, 3) for w in freqs))
    for i, c in enumerate(m.COORDINATES):
        print(f"{c:>8s}" + "".join(_cell(v, 4) for v in phi[i]))
    print("\nkinetic-energy distribution (share of each mode's kinetic energy per coordinate, %)")
    print(f"{'':>8s}{head}")
    for i, c in enumerate(m.COORDINATES):
        print(f"{c:>8s}" + "".join(_cell(100 * v, 1) for v in energy[i]))
    if written:
        nodes = ", ".join(f"{k} ({', '.join(f'{v:g}' for v in p)})" for k, p in enumerate(written["nodes"], start=1))
        print(f"\nwrote {written['file']}: the {len(m.MODES)} modes as UFF mode shapes at nodes {nodes} [m]")
    defaults_note(machine, defaults)


def _modes_uff(machine: Machine, given: dict[str, float], path: str, points: list[str] | None) -> dict:
    """Write the machine's modes at ``points`` (--point, x,y,z [m] each; default the isolator points at the given
    values) to the UFF file ``path`` (records.ModeTable.of_model, uff_modes.write_table: ID line 1 the mode's
    label); what was written, for the output."""
    from mountid.measurement.records import ModeTable
    from mountid.measurement.uff_modes import write_table  # pyuff is an extra: imported only for UFF files

    mod = machine.module
    if points:
        nodes = [point_on_machine(text, "--point") for text in points]
    else:
        nodes = [tuple(float(v) for v in point) for point in machine.isolator_points(given).T]
    write_table(ModeTable.of_model(machine, given, nodes), path, titles=list(mod.MODES))
    return {"file": path, "nodes": [list(p) for p in nodes]}


def _cell(value: float, decimals: int) -> str:
    """One column of the modes table: ``decimals`` places, three significant digits where that is wider than
    the column; never a negative zero (a share or a shape entry rounding to zero)."""
    text = f"{round(float(value), decimals) + 0.0:.{decimals}f}"
    if len(text) > 8:
        text = f"{value:.3g}"
    return f"{text:>9s}"


def cmd_describe(args: argparse.Namespace) -> None:
    machine = Machine.resolve(args.machine)
    m = machine.module
    numeric = getattr(m, "NUMERIC_INVERSES", {})
    every = machine.undetermined_by(machine.unique_modes)  # what all the distinct frequencies leave undetermined
    if args.json:
        print_json(
            {
                "machine": machine.name,
                "title": m.TITLE,
                "parameters": {n: dict(p) for n, p in m.PARAMETERS.items()},
                "modes": list(m.MODES),
                "distinct_modes": list(m.UNIQUE_MODES),
                "unknown": list(m.UNKNOWN),
                "inverse_sets": [
                    {"modes": list(key), "roots": n, "numeric": numeric.get(key)} for key, n in m.INVERSE_ROOTS.items()
                ],
                "special_points": list(getattr(m, "SPECIAL_POINTS", ())),
                "unidentifiable": [{"modes": list(key), "reason": why} for key, why in m.UNIDENTIFIABLE.items()],
                "undetermined_by_all": list(every.unknowns) if every else [],
            }
        )
        return
    print(f"{machine.name}: {m.TITLE}")
    print("parameters:")
    for n, p in m.PARAMETERS.items():
        value = "" if p["value"] is None else f"{p['value']:g} {p['unit']}"
        print(f"  {n:>8s}  {p['role']:8s} {p['kind']:22s} {value:16s} {p['description']}")
    print(f"modes: {', '.join(m.MODES)}; distinct frequencies: {', '.join(m.UNIQUE_MODES)}")
    for index, block in enumerate(m.BLOCKS):
        if len(block) > 2:
            labels = [label for label, k in zip(m.MODES, m.MODE_BLOCK, strict=True) if k == index]
            coordinates = ", ".join(m.COORDINATES[i] for i in block)
            print(
                f"  note: {', '.join(labels)} are the roots of one block ({coordinates}) in ascending order: a label "
                "names a rank, not the motion (`mountid modes` shows each one's)"
            )
    print(f"inverse sets for the unknowns {', '.join(m.UNKNOWN)}:")
    for key, n in m.INVERSE_ROOTS.items():
        if key in numeric:
            print(f"  {', '.join(key):24s} solvable numerically ({n} starts): {numeric[key]}")
        else:
            print(f"  {', '.join(key):24s} solvable, {counted(n, 'candidate root')}")
    for key, reason in m.UNIDENTIFIABLE.items():
        print(f"  {', '.join(key):24s} NOT identifiable: {reason}")
    if every:  # each set's line says so; this says that no measurement of these frequencies ever will
        print(f"  all together: {every.describe()}: {every.advice()}")
    if getattr(m, "SPECIAL_POINTS", ()):  # after the sets, which it would split
        print(f"special points (0 is a legitimate design, solved there by the engine): {', '.join(m.SPECIAL_POINTS)}")


def cmd_demo(args: argparse.Namespace) -> None:
    from importlib import resources

    from mountid.diagnosis.campaign import load
    from mountid.diagnosis.gap import diagnose
    from mountid.report.figures import diagnosis_figure
    from mountid.validation.paper import print_reproduction, run_simulated_experiment

    print_reproduction()
    run_simulated_experiment(figures=args.figures)
    for name in ("kid300-paper", "kid300-blind-belt"):
        path = resources.files("mountid.examples").joinpath(f"{name}.json")
        campaign = load(str(path))
        diagnosis = diagnose(campaign)
        figure = f"{args.figures}/{name}-diagnosis.png"
        diagnosis_figure(diagnosis, figure, title=campaign.name)
        print(f"\n$ mountid diagnose examples/{name}.json")
        print_diagnosis(diagnosis, campaign.name, figure)
