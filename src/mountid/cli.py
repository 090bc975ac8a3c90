"""The ``mountid`` command (also ``python -m mountid``).

Contract (other tools rely on it): SI units; ``--json`` output as documented in the README; bad input gives
one line ``mountid: error: <parameter>: <reason>`` on stderr and exit code 2, never a traceback.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Sequence
from pathlib import Path

from mountid.errors import InputError
from mountid.machine import Machine


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # one line, exit 2 (argparse would print the usage too)
        raise InputError("arguments", message)


def _pairs(items: Sequence[str] | None, option: str) -> dict[str, float]:
    out: dict[str, float] = {}
    for item in items or ():
        name, sep, text = item.partition("=")
        name = name.strip()
        if not sep or not name:
            raise InputError(option, f"expected name=value, got {item!r}")
        try:
            value = float(text)
        except ValueError:
            raise InputError(name, f"not a number: {text!r}") from None
        if math.isnan(value):
            raise InputError(name, "is NaN")
        if name in out:
            raise InputError(name, "given twice")
        out[name] = value
    return out


def _finite(obj: object) -> object:
    """NaN and infinities (a quantity that does not exist, e.g. a held-out error where leaving the mode out
    leaves a parameter undetermined) as null: JSON has no NaN."""
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: _finite(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_finite(v) for v in obj]
    return obj


def _print_json(obj: object) -> None:
    print(json.dumps(_finite(obj), indent=2, allow_nan=False))


def _defaults_note(machine: Machine, defaults: dict[str, float]) -> None:
    """The text note naming the parameters that took the description's nominal value."""
    if defaults:
        values = ", ".join(f"{n} = {v:g} {machine.parameters[n]['unit']}" for n, v in defaults.items())
        print(f"note: not given, the description's nominal values are used: {values}")


def _finite_number(value: float, option: str, minimum: float = 0.0, strict: bool = True) -> float:
    """A command-line number that must be finite and above (``strict``) or at least ``minimum``."""
    if not math.isfinite(value) or value < minimum or (strict and value == minimum):
        bound = "positive" if strict and minimum == 0 else f"{'>' if strict else '>='} {minimum:g}"
        raise InputError(option, f"must be {bound} and finite, got {value}")
    return value


def _check_unbalance(args: argparse.Namespace) -> None:
    """The rotating-unbalance options of simulate and forced: speeds positive, mass and eccentricity >= 0."""
    for w in args.speed or ():
        _finite_number(w, "--speed")
    _finite_number(args.unbalance_mass, "--unbalance-mass", strict=False)
    _finite_number(args.eccentricity, "--eccentricity", strict=False)


def cmd_frequencies(args: argparse.Namespace) -> None:
    machine = Machine.resolve(args.machine)
    given = _pairs(args.set, "--set")
    freqs = machine.frequencies(given)
    defaults = machine.defaults(given, machine.module.FORWARD_ARGUMENTS)
    if args.json:
        _print_json({"machine": machine.name, "unit": "rad/s", "frequencies": freqs, "defaults": defaults})
        return
    print(f"{machine.name}: natural frequencies")
    for label, w in freqs.items():
        print(f"  {label:>8s}  {w:12.6g} rad/s  {w / (2 * math.pi):10.5g} Hz")
    _defaults_note(machine, defaults)


MAX_SAMPLES = 10_000_000
"""Most samples per channel a simulated record may hold (80 MB per channel in memory)."""


def _writable(path: str, option: str) -> None:
    """Refuse a file path whose folder is a file (or under one): the write would fail after the work."""
    for parent in Path(path).parents:
        if parent.exists():
            if not parent.is_dir():
                raise InputError(option, f"{str(parent)!r} is a file, not a folder")
            return


def cmd_identify(args: argparse.Namespace) -> None:
    machine = Machine.resolve(args.machine)
    measured = _pairs(args.measured, "--measured")
    if not measured:
        raise InputError("--measured", "give the measured frequencies as label=rad/s")
    given = _pairs(args.set, "--set")
    std = _pairs(args.std, "--std") if args.std else None
    solutions = machine.identify(given, measured, std)
    defaults = machine.defaults(given, tuple(a for a in machine.module.FORWARD_ARGUMENTS if a not in machine.unknown))
    if args.json:
        _print_json(
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
    print(f"{machine.name}: {len(solutions)} admissible solution(s) for {measured}")
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
    _defaults_note(machine, defaults)


def cmd_modes(args: argparse.Namespace) -> None:
    machine = Machine.resolve(args.machine)
    m = machine.module
    given = _pairs(args.set, "--set")
    values = machine.values(given, m.FORWARD_ARGUMENTS)
    freqs = machine.evaluate("frequencies", values)
    phi = machine.evaluate("modal_matrix", values)
    energy = machine.evaluate("kinetic_energy_distribution", values)
    defaults = machine.defaults(given, m.FORWARD_ARGUMENTS)
    if args.json:
        _print_json(
            {
                "machine": machine.name,
                "modes": list(m.MODES),
                "coordinates": list(m.COORDINATES),
                "frequencies": dict(zip(m.MODES, map(float, freqs), strict=True)),
                "modal_matrix": phi.tolist(),
                "kinetic_energy_distribution": energy.tolist(),
                "defaults": defaults,
            }
        )
        return
    head = "".join(f"{lab:>9s}" for lab in m.MODES)
    print(f"{machine.name}: mass-normalised modal matrix (rows: coordinates, columns: modes)")
    print(f"{'':>8s}{head}\n{'rad/s':>8s}" + "".join(f"{w:9.3f}" for w in freqs))
    for i, c in enumerate(m.COORDINATES):
        print(f"{c:>8s}" + "".join(f"{v:9.4f}" for v in phi[i]))
    print("\nkinetic-energy distribution (share of each mode's kinetic energy per coordinate, %)")
    print(f"{'':>8s}{head}")
    for i, c in enumerate(m.COORDINATES):
        print(f"{c:>8s}" + "".join(f"{100 * v:9.1f}" for v in energy[i]))
    _defaults_note(machine, defaults)


def cmd_describe(args: argparse.Namespace) -> None:
    machine = Machine.resolve(args.machine)
    m = machine.module
    print(f"{machine.name}: {m.TITLE}")
    print("parameters:")
    for n, p in m.PARAMETERS.items():
        value = "" if p["value"] is None else f"{p['value']:g} {p['unit']}"
        print(f"  {n:>8s}  {p['role']:8s} {p['kind']:22s} {value:16s} {p['description']}")
    print(f"modes: {', '.join(m.MODES)}; distinct frequencies: {', '.join(m.UNIQUE_MODES)}")
    print(f"inverse sets for the unknowns {', '.join(m.UNKNOWN)}:")
    numeric = getattr(m, "NUMERIC_INVERSES", {})
    for key, n in m.INVERSE_ROOTS.items():
        if key in numeric:
            print(f"  {', '.join(key):24s} solvable numerically ({n} Newton starts): {numeric[key]}")
        else:
            print(f"  {', '.join(key):24s} solvable, {n} candidate root(s)")
    if getattr(m, "SPECIAL_POINTS", ()):
        print(f"special points (0 is a legitimate design, solved there by the engine): {', '.join(m.SPECIAL_POINTS)}")
    for key, reason in m.UNIDENTIFIABLE.items():
        print(f"  {', '.join(key):24s} NOT identifiable: {reason}")


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


def _triple(text: str, option: str) -> tuple[float, float, float]:
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        raise InputError(option, f"expected three numbers x,y,z, got {text!r}") from None
    if len(values) != 3 or not all(map(math.isfinite, values)):
        raise InputError(option, f"expected three finite numbers x,y,z, got {text!r}")
    return values  # type: ignore[return-value]


def _read_record(path: str):
    from mountid.measurement.records import read_csv
    from mountid.measurement.uff import read_uff

    return read_uff(path) if path.lower().endswith((".uff", ".unv")) else read_csv(path)


def cmd_simulate(args: argparse.Namespace) -> None:
    from mountid.measurement.records import write_csv
    from mountid.measurement.rig import Hammer, Rig, Sensor, Unbalance
    from mountid.measurement.uff import write_uff

    out = Path(args.out)
    if not out.parent.is_dir():
        raise InputError("--out", f"the folder {str(out.parent)!r} does not exist")
    _finite_number(args.duration, "--duration")
    _finite_number(args.rate, "--rate")
    _finite_number(args.noise, "--noise", strict=False)
    _finite_number(args.hit_peak, "--hit-peak", strict=False)
    if args.duration * args.rate > MAX_SAMPLES:
        raise InputError(
            "--duration",
            f"{args.duration:g} s at {args.rate:g} Hz is {args.duration * args.rate:.3g} samples per channel; "
            f"at most {MAX_SAMPLES:.0e}",
        )
    _check_unbalance(args)
    rig = Rig.of(args.machine, _pairs(args.set, "--set"))
    sensors = []
    for item in args.sensor or ():
        name, sep, rest = item.partition("=")
        point, sep2, direction = rest.partition(":")
        if not sep or not sep2:
            raise InputError("--sensor", f"expected NAME=x,y,z:dx,dy,dz, got {item!r}")
        sensors.append(Sensor(name, _triple(point, "--sensor"), _triple(direction, "--sensor"), noise=args.noise))
    if not sensors:
        from mountid.validation.paper import paper_sensors

        sensors = paper_sensors(args.noise)
    hammers = (
        []
        if args.speed
        else [
            Hammer(
                _triple(args.hit_point, "--hit-point"),
                _triple(args.hit_direction, "--hit-direction"),
                peak=args.hit_peak,
            )
        ]
    )
    unbalances = [Unbalance(args.unbalance_mass, args.eccentricity, w) for w in args.speed or ()]
    record = rig.simulate(sensors, args.duration, args.rate, hammers, unbalances, seed=args.seed)
    (write_uff if args.out.lower().endswith((".uff", ".unv")) else write_csv)(record, args.out)
    print(f"wrote {args.out}: {len(record.time)} samples x {len(record.channels)} channels ({', '.join(record.names)})")


def _modal_json(machine: Machine, modes: dict, unlabelled: list, warnings: list) -> dict:
    """The JSON of labelled modal data (process, identify-record)."""
    fields = ("frequency", "frequency_std", "damping_ratio", "damping_std", "mac", "shape")
    return {
        "machine": machine.name,
        "modes": {k: {f: getattr(m, f) for f in fields} for k, m in modes.items()},
        "unlabelled_poles": [{"frequency": p.frequency, "damping_ratio": p.damping_ratio} for p in unlabelled],
        "warnings": [{"kind": w.kind, "channel": w.channel, "message": w.message} for w in warnings],
    }


def _identification_json(machine: Machine, result) -> dict:
    return {
        **_modal_json(machine, result.modes, result.unlabelled, result.warnings),
        "parameters": result.parameters,
        "parameter_std": result.parameter_std,
        "damping": result.damping,
        "damping_std": result.damping_std,
        "frequencies": result.frequencies,
    }


def cmd_identify_record(args: argparse.Namespace) -> None:
    from mountid.identification.from_records import identify_from_record

    machine = Machine.resolve(args.machine)
    record = _read_record(args.record)
    use = tuple(args.use) if args.use else None
    result = identify_from_record(machine, record, _pairs(args.set, "--set"), start=args.start, use=use)
    if args.figures:
        from mountid.report import figures

        labels = {k: m.frequency for k, m in result.modes.items()}
        first = record.names[0]
        figures.spectrum_figure(record, first, args.start, labels, f"{args.figures}/spectrum.png")
        figures.mode_shapes_figure(
            machine, {**_pairs(args.set, "--set"), **result.parameters}, (0.5, 0.5, 0.4), f"{args.figures}/modes.png"
        )
    if args.json:
        _print_json(_identification_json(machine, result))
        return
    print(f"{machine.name}: {len(result.modes)} modes from {args.record}")
    for w in result.warnings:
        print(f"  warning ({w.kind}, {w.channel}): {w.message}")
    for k, m in result.modes.items():
        print(
            f"  {k:>8s}  {m.frequency:10.4f} +- {m.frequency_std:.2g} rad/s"
            f"  zeta {m.damping_ratio:.4f}  MAC {m.mac:.2f}"
        )
    for name, value in result.parameters.items():
        print(f"  {name} = {value:.6g} +- {result.parameter_std[name]:.2g} {machine.parameters[name]['unit']}")
    for name, value in result.damping.items():
        print(f"  {name} = {value:.6g} +- {result.damping_std[name]:.2g} {machine.parameters[name]['unit']}")


def cmd_process(args: argparse.Namespace) -> None:
    from mountid.identification.from_records import modal_data

    machine = Machine.resolve(args.machine)
    modes, rest, warnings = modal_data(machine, _read_record(args.record), _pairs(args.set, "--set"), args.start)
    out = _modal_json(machine, modes, rest, warnings)
    if args.json:
        _print_json(out)
        return
    for w in warnings:
        print(f"  warning ({w.kind}, {w.channel}): {w.message}")
    for k, m in modes.items():
        print(f"  {k:>8s}  {m.frequency:10.4f} +- {m.frequency_std:.2g} rad/s  zeta {m.damping_ratio:.4f}")


def cmd_diagnose(args: argparse.Namespace) -> None:
    from mountid.diagnosis.campaign import load
    from mountid.diagnosis.gap import diagnose

    campaign = load(args.campaign)
    diagnosis = diagnose(campaign)
    report, effects = diagnosis.where, diagnosis.effects
    figure = None
    if not args.no_figure:
        from mountid.report.figures import diagnosis_figure

        figure = args.figure or f"{Path(args.campaign).stem}-diagnosis.png"
        _writable(figure, "--figure")
        diagnosis_figure(diagnosis, figure, title=campaign.name or Path(args.campaign).stem)
    residuals = [
        {
            "mode": r.label,
            "measured": r.measured,
            "predicted": r.predicted,
            "residual": r.residual,
            "uncertainty": r.uncertainty,
            "z": r.z,
            "significant": r.significant,
            "held_out": r.held_out,
        }
        for r in report.residuals
    ]
    localisation = [
        {
            "matrix": loc.matrix,
            "entries": [list(e) for e in loc.entries],
            "change": loc.change,
            "unit": loc.unit,
            "explained": loc.explained,
            "text": loc.describe(),
        }
        for loc in report.localisation
    ]
    if args.json:
        _print_json(
            {
                "campaign": campaign.name,
                "machine": campaign.machine.name,
                "parameters": report.parameters,
                "parameter_std": report.parameter_std,
                "residuals": residuals,
                "sensitivities": report.sensitivities,
                "localisation": localisation,
                "broken_symmetry": report.broken_symmetry,
                "isolator_force_residual": [
                    {"isolator": f.isolator, "stiffness_change": f.change, "std": f.std} for f in diagnosis.isolators
                ],
                "modal_force_residual": diagnosis.force_residual,
                "nominal": effects.nominal.to_json(),
                "candidates": [f.to_json() for f in effects.ranked],
                "gap": diagnosis.gap_table(),
                "p_value": effects.p_value,
                "significant": effects.significant,
                "tie": effects.tie,
                "separation": effects.separation,
                "confident": effects.confident,
                "verdict": diagnosis.verdict,
                "where_verdict": report.verdict,
                "notes": [*report.notes, *effects.notes],
                "figure": figure,
            }
        )
        return
    print_diagnosis(diagnosis, campaign.name or args.campaign, figure)


def print_diagnosis(diagnosis, title: str, figure: str | None = None) -> None:
    """The readable summary of a diagnosis (``mountid diagnose`` without --json, and the demo)."""
    report, effects, campaign = diagnosis.where, diagnosis.effects, diagnosis.campaign
    print(f"{title} ({campaign.machine.name})")
    print("nominal identification: " + ", ".join(f"{k} = {v:.6g}" for k, v in report.parameters.items()))
    print(f"  {'mode':6s}{'measured':>10s}{'predicted':>11s}{'gap':>9s}{'sigma':>8s}{'z':>7s}  use")
    for r in report.residuals:
        z = "" if r.z is None else f"{r.z:+7.2f}"
        sig = "" if r.uncertainty is None else f"{r.uncertainty:8.3g}"
        flag = " *" if r.significant else ""
        use = "held out" if r.held_out else "fitted"
        print(f"  {r.label:6s}{r.measured:10.3f}{r.predicted:11.3f}{r.residual:+9.3f}{sig:>8s}{z:>7s}  {use}{flag}")
    for loc in report.localisation[:3]:
        print(f"  matrix level: {loc.describe()}")
    if diagnosis.isolators:
        print("modal force residual of the measured shapes, as a stiffness change per isolator:")
        print("  " + ", ".join(f"{f.isolator} {f.change:+.1%} +- {f.std:.1%}" for f in diagnosis.isolators))
    _print_candidates(effects)
    gaps = diagnosis.gap_table()
    if "after" in gaps:
        before, after = gaps["before"], gaps["after"]
        print(f"gap [rad/s] before (nominal) -> after ({after['effect']}), fitted | held out:")
        for label in before["fitted"]:
            b, a = before["fitted"][label], after["fitted"][label]
            hb, ha = before["held_out"].get(label, float("nan")), after["held_out"].get(label, float("nan"))
            print(f"  {label:6s}{b:+9.4f} -> {a:+9.4f} | {hb:+9.4f} -> {ha:+9.4f}")
        print(
            f"  {'RMS':6s}{before['rms_fitted']:9.4f} -> {after['rms_fitted']:9.4f} | "
            f"{before['rms_held_out'] or float('nan'):9.4f} -> {after['rms_held_out'] or float('nan'):9.4f}"
        )
    for line in effects.separation:
        print(f"  to separate the tie: {line}")
    for note in [*report.notes, *effects.notes]:
        print(f"  note: {note}")
    if figure:
        print(f"figure: {figure}")
    print(f"verdict: {diagnosis.verdict}")


def _print_candidates(effects) -> None:
    ranked = [f for f in effects.ranked if f.applicable]
    finite = [f.aicc for f in ranked if f.aicc != float("inf")]
    best = min(finite) if finite else None
    n = effects.nominal
    if n.held_out_rms == n.held_out_rms:
        print(f"nominal model held out: RMS {n.held_out_rms:.3g} sigma, median {n.held_out_median:.3g} sigma")
    print(
        f"candidate effects (fitted with the unknowns to {n.n_data} data; nominal chi^2 = {n.chi2:.4g}, "
        f"AICc = {n.aicc:.4g})" + (":" if best is not None else "; too few data to rank them, listed by chi^2:")
    )
    print(f"  {'effect':22s}{'dAICc':>8s}{'chi^2':>9s}{'held-out':>17s}  parameters (+- std)")
    print(f"  {'':22s}{'':>8s}{'':>9s}{'RMS | median':>17s}  (held-out errors in sigma)")
    for f in ranked:
        d = f"{f.aicc - best:8.1f}" if best is not None and f.aicc != float("inf") else f"{'-':>8s}"
        ho = f"{f.held_out_rms:8.3g} | {f.held_out_median:5.3g}" if f.held_out_rms == f.held_out_rms else f"{'-':>16s}"
        params = ", ".join(
            f"{k} = {v:.4g} +- {f.std[k]:.2g}" for k, v in f.parameters.items() if k not in effects.nominal.parameters
        )
        mark = " [tie]" if f.effect in effects.tie else ""
        mark += "" if f.plausible else f" [implausible: {f.implausible_reason}]"
        where = f" at {f.variant}" if f.variant else ""
        print(f"  {f.effect:22s}{d} {f.chi2:8.4g} {ho}  {params}{where}{mark}")
    for f in effects.ranked:
        if not f.applicable:
            print(f"  {f.effect:22s} not applicable: {f.note}")


def cmd_forced(args: argparse.Namespace) -> None:
    import numpy as np

    from mountid.measurement.rig import Rig, Unbalance

    _check_unbalance(args)
    rig = Rig.of(args.machine, _pairs(args.set, "--set"))
    rows = {}
    for w in args.speed:
        unb = Unbalance(args.unbalance_mass, args.eccentricity, w)
        t = np.linspace(0, 2 * np.pi / w, 64, endpoint=False)
        with np.errstate(over="raise", invalid="raise", divide="raise", under="ignore"):
            try:
                q, _ = rig.steady_state(unb, t)
                amplitude = np.max(np.abs(q), axis=0)
            except (FloatingPointError, OverflowError):
                amplitude = np.array([np.inf])
        if not np.all(np.isfinite(amplitude)):
            raise InputError("--speed", f"{w:g} rad/s puts the response out of the range of double precision")
        rows[f"{w:g}"] = dict(zip(rig.machine.module.COORDINATES, map(float, amplitude), strict=True))
    if args.json:
        _print_json({"machine": rig.machine.name, "unit": "m, rad", "amplitudes": rows})
        return
    print(f"{rig.machine.name}: steady-state amplitude under the rotating unbalance [m, rad]")
    for w, amp in rows.items():
        print(f"  {w:>8s} rad/s  " + "  ".join(f"{c} {a:.3e}" for c, a in amp.items()))


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="mountid", description="Rigid machines on rubber isolators: dynamics and identification.")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)

    def machine_command(name: str, help_: str) -> argparse.ArgumentParser:
        p = sub.add_parser(name, help=help_)
        p.add_argument("machine", help="a shipped machine name (e.g. kid300) or a description .toml file")
        p.add_argument("--set", nargs="+", action="extend", metavar="NAME=VALUE", help="parameter values [SI]")
        p.add_argument("--json", action="store_true", help="machine-readable output")
        return p

    machine_command("frequencies", "natural frequencies for given parameters").set_defaults(func=cmd_frequencies)
    p = machine_command("identify", "unknown stiffnesses from measured natural frequencies")
    p.add_argument(
        "--measured",
        nargs="+",
        action="extend",
        metavar="LABEL=RAD_S",
        help="measured natural frequencies [rad/s]",
    )
    p.add_argument(
        "--std",
        nargs="+",
        action="extend",
        metavar="LABEL=RAD_S",
        help="standard deviation of each measured frequency [rad/s]: the unknowns' standard deviations",
    )
    p.set_defaults(func=cmd_identify)
    machine_command("modes", "mode shapes and kinetic-energy distribution").set_defaults(func=cmd_modes)
    machine_command("describe", "parameters, modes and inverse sets of a machine").set_defaults(func=cmd_describe)
    p = sub.add_parser("demo", help="reproduce the reference paper's numbers and its simulated experiment")
    p.add_argument("--figures", default="out/figures", help="folder for the figures (default out/figures)")
    p.set_defaults(func=cmd_demo)

    def add_unbalance(p: argparse.ArgumentParser) -> None:
        p.add_argument("--unbalance-mass", type=float, default=43.1, help="eccentric mass m_v [kg] (paper 43.1)")
        p.add_argument("--eccentricity", type=float, default=0.03, help="eccentricity e [m] (paper 0.03)")

    p = machine_command("simulate", "simulate an experiment on the virtual rig and write a record (.csv or .uff)")
    p.add_argument("--out", required=True, help="record file to write (.csv, or .uff/.unv for UFF dataset 58)")
    p.add_argument("--duration", type=float, default=4.0, help="record length [s]")
    p.add_argument("--rate", type=float, default=2000.0, help="sampling rate [Hz]")
    p.add_argument("--noise", type=float, default=0.01, help="white noise std relative to each channel's RMS")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument(
        "--sensor",
        nargs="+",
        action="extend",
        metavar="NAME=x,y,z:dx,dy,dz",
        help="accelerometer channels (default: the paper's layout plus A_z and C_x)",
    )
    p.add_argument("--hit-point", default="0.35,0.25,0.3", help="impact point x,y,z [m]")
    p.add_argument("--hit-direction", default="1,0.8,-0.6", help="impact direction")
    p.add_argument("--hit-peak", type=float, default=3000.0, help="peak impact force [N]")
    p.add_argument("--speed", nargs="+", type=float, help="rotating-unbalance speeds [rad/s] instead of a hit")
    add_unbalance(p)
    p.set_defaults(func=cmd_simulate)
    p = machine_command("identify-record", "modal data, stiffness and damping from an impact record")
    p.add_argument("record", help="record file (.csv, .uff or .unv)")
    p.add_argument("--start", type=float, default=0.07, help="start of the free decay [s] (after the hit)")
    p.add_argument("--figures", help="folder for the spectrum and mode-shape figures")
    p.add_argument("--use", nargs="+", metavar="LABEL", help="fit only these measured modes (default: all found)")
    p.set_defaults(func=cmd_identify_record)
    p = machine_command("process", "modal data (labelled frequencies, damping, MAC) from an impact record")
    p.add_argument("record", help="record file (.csv, .uff or .unv)")
    p.add_argument("--start", type=float, default=0.07, help="start of the free decay [s] (after the hit)")
    p.set_defaults(func=cmd_process)
    p = sub.add_parser(
        "diagnose", help="where the model misses a campaign's measurements and which unmodelled effect explains it"
    )
    p.add_argument("campaign", help="campaign file (see mountid/schemas/campaign.schema.json)")
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.add_argument("--figure", help="figure file to write (default: <campaign name>-diagnosis.png here)")
    p.add_argument("--no-figure", action="store_true", help="write no figure")
    p.set_defaults(func=cmd_diagnose)
    p = machine_command("forced", "steady-state response to a rotating unbalance (Eqs. 27-30)")
    p.add_argument("--speed", nargs="+", type=float, required=True, help="speeds [rad/s]")
    add_unbalance(p)
    p.set_defaults(func=cmd_forced)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    try:
        args = build_parser().parse_args(argv)
        args.func(args)
    except InputError as exc:
        print(f"mountid: error: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:  # a file that cannot be read or written: named, one line
        print(f"mountid: error: {exc.filename or 'file'}: {exc.strerror or exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
