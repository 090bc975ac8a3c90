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


def _print_json(obj: object) -> None:
    print(json.dumps(obj, indent=2, allow_nan=False))


def cmd_frequencies(args: argparse.Namespace) -> None:
    machine = Machine.resolve(args.machine)
    freqs = machine.frequencies(_pairs(args.set, "--set"))
    if args.json:
        _print_json({"machine": machine.name, "unit": "rad/s", "frequencies": freqs})
        return
    print(f"{machine.name}: natural frequencies")
    for label, w in freqs.items():
        print(f"  {label:>8s}  {w:12.6g} rad/s  {w / (2 * math.pi):10.5g} Hz")


def cmd_identify(args: argparse.Namespace) -> None:
    machine = Machine.resolve(args.machine)
    measured = _pairs(args.measured, "--measured")
    if not measured:
        raise InputError("--measured", "give the measured frequencies as label=rad/s")
    solutions = machine.identify(_pairs(args.set, "--set"), measured)
    if args.json:
        _print_json(
            {
                "machine": machine.name,
                "measured": measured,
                "solutions": [{"parameters": s.parameters, "frequencies": s.frequencies} for s in solutions],
            }
        )
        return
    print(f"{machine.name}: {len(solutions)} admissible solution(s) for {measured}")
    for k, s in enumerate(solutions, 1):
        params = ", ".join(f"{n} = {v:.6g} {machine.parameters[n]['unit']}" for n, v in s.parameters.items())
        print(f"  [{k}] {params}")
        print("      frequencies: " + ", ".join(f"{lab} {w:.5g}" for lab, w in s.frequencies.items()) + " rad/s")


def cmd_modes(args: argparse.Namespace) -> None:
    machine = Machine.resolve(args.machine)
    m = machine.module
    values = machine.values(_pairs(args.set, "--set"), m.FORWARD_ARGUMENTS)
    phi = m.modal_matrix(**values)
    energy = m.kinetic_energy_distribution(**values)
    freqs = m.frequencies(**values)
    if args.json:
        _print_json(
            {
                "machine": machine.name,
                "modes": list(m.MODES),
                "coordinates": list(m.COORDINATES),
                "frequencies": dict(zip(m.MODES, map(float, freqs), strict=True)),
                "modal_matrix": phi.tolist(),
                "kinetic_energy_distribution": energy.tolist(),
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
    for key, n in m.INVERSE_ROOTS.items():
        print(f"  {', '.join(key):24s} solvable, {n} candidate root(s)")
    for key, reason in m.UNIDENTIFIABLE.items():
        print(f"  {', '.join(key):24s} NOT identifiable: {reason}")


def cmd_demo(args: argparse.Namespace) -> None:
    from mountid.paper import print_reproduction

    print_reproduction()


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
    p.set_defaults(func=cmd_identify)
    machine_command("modes", "mode shapes and kinetic-energy distribution").set_defaults(func=cmd_modes)
    machine_command("describe", "parameters, modes and inverse sets of a machine").set_defaults(func=cmd_describe)
    sub.add_parser("demo", help="reproduce the reference paper's numbers").set_defaults(func=cmd_demo)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    try:
        args = build_parser().parse_args(argv)
        args.func(args)
    except InputError as exc:
        print(f"mountid: error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
