"""The ``mountid`` command (also ``python -m mountid``).

Contract (other tools rely on it): SI units; ``--json`` output as documented in the README; bad input gives
one line ``mountid: error: <parameter>: <reason>`` on stderr and exit code 2, never a traceback.
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Sequence

from mountid.cli.arguments import HIT_TIME, Parser, speed
from mountid.cli.diagnose_command import cmd_diagnose
from mountid.cli.machine_commands import cmd_demo, cmd_describe, cmd_frequencies, cmd_identify, cmd_modes
from mountid.cli.record_commands import cmd_forced, cmd_identify_record, cmd_plan, cmd_process, cmd_simulate
from mountid.errors import InputError
from mountid.validation.paper import HIT_PEAK, UNBALANCE

EXTRAS = {
    "sympy": "generate",
    "jinja2": "generate",
    "ruff": "generate",
    "matplotlib": "figures",
    "pyuff": "records",
    "nptdms": "records",
    "lvm_read": "records",
    "jsonschema": "campaigns",
}
"""Optional dependencies and the extra that installs each (pyproject.toml)."""


def build_parser() -> argparse.ArgumentParser:
    parser = Parser(prog="mountid", description="Rigid machines on rubber isolators: dynamics and identification.")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=Parser)

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
        help="measured natural frequencies [rad/s, or with the unit: x=2.82Hz]",
    )
    p.add_argument(
        "--std",
        nargs="+",
        action="extend",
        metavar="LABEL=RAD_S",
        help="standard deviation of each measured frequency [rad/s, or with the unit: x=0.003Hz]: the unknowns' "
        "standard deviations",
    )
    p.add_argument(
        "--root",
        metavar="RULE",
        help="with more frequencies than unknowns: pick between equally good fits, e.g. c_z>c_xy "
        "(default: the description's rule)",
    )
    p.set_defaults(func=cmd_identify)
    p = machine_command("modes", "mode shapes and kinetic-energy distribution")
    p.add_argument(
        "--uff",
        metavar="FILE",
        help="write the modes at --point as UFF mode shapes (datasets 55 with the nodes, 15): a bench's modal "
        "software compares its test with them",
    )
    p.add_argument(
        "--point",
        nargs="+",
        action="extend",
        metavar="x,y,z",
        help="the nodes of --uff [m] (default: the isolator points), node 1 the first",
    )
    p.set_defaults(func=cmd_modes)
    machine_command("describe", "parameters, modes and inverse sets of a machine").set_defaults(func=cmd_describe)
    p = sub.add_parser("demo", help="reproduce the reference paper's numbers and its simulated experiment")
    p.add_argument("--figures", default="out/figures", help="folder for the figures (default out/figures)")
    p.set_defaults(func=cmd_demo)

    def add_record_options(p: argparse.ArgumentParser) -> None:
        """The record file and how the records chain reads it (process, identify-record): its free decay's start,
        the free decay where a force channel would give H1, the sampling rate, where its channels sit, which are
        left unread, the unknowns its poles are labelled at, and which run of a file of several is read."""
        p.add_argument("record", help="record file (.csv, .uff, .unv, .tdms or .lvm)")
        p.add_argument(
            "--start",
            type=float,
            help="start of the free decay [s] (default 0.07, or 0.03 after the impact the record shows where that "
            "is later: a pre-trigger; with a force channel, only where the record's checks look, unless --free-decay)",
        )
        p.add_argument(
            "--free-decay",
            action="store_true",
            help="fit the free decay after --start even where the record has a force channel (default: H1 from it)",
        )
        p.add_argument(
            "--rate",
            type=float,
            help="sampling rate [Hz]: a uniform grid from the first time instead of the time column (a CSV of "
            "channels only: every column a channel, from t = 0)",
        )
        p.add_argument(
            "--exponential-window",
            type=float,
            metavar="RATE",
            help="frequency response functions (a UFF file of them): the exponential window exp(-RATE t) the bench "
            "put on the responses [1/s: 1 / its time constant], divided out (it adds RATE / omega to each damping "
            "ratio)",
        )
        for option, metavar, help_ in (
            (
                "--channel",
                "NAME=x,y,z:dx,dy,dz",
                "point [m] and direction of a record's channel (a plain CSV states none; replaces the file's)",
            ),
            (
                "--sensitivity",
                "NAME=SENSITIVITY",
                "a sensor's sensitivity, as 100mV/g or 2.25mV/N, for a channel the file holds in volts (an acquisition "
                "that records raw voltages): its samples divided by it",
            ),
            (
                "--ignore",
                "NAME",
                "a channel of the record left unread: a tachometer, a microphone, a spare channel (any unit, any "
                "content)",
            ),
            (
                "--nominal",
                "NAME=VALUE",
                "values of the unknowns [SI] the record's poles are labelled against (default: the description's)",
            ),
        ):
            p.add_argument(option, nargs="+", action="extend", metavar=metavar, help=help_)
        p.add_argument(
            "--channels",
            metavar="FILE",
            help="a channel table (CSV: name, x, y, z [m], direction as +x or 'dx dy dz', sensitivity): where each "
            "channel sits and its sensor's sensitivity, for the channels the record holds",
        )
        p.add_argument(
            "--frf-out",
            metavar="FILE",
            help="also write the H1 frequency responses (and coherence) of the record's force channel as a UFF file "
            "(.uff or .unv: datasets 58, as a bench exports them; a run per input)",
        )
        p.add_argument(
            "--run",
            type=int,
            metavar="K",
            help="which run of a UFF or TDMS file of several (hits exported one after another, a dataset per channel "
            "or a group each) to read: 1, 2, ...; without it, every run, combined per mode",
        )

    def add_unbalance(p: argparse.ArgumentParser) -> None:
        p.add_argument(
            "--unbalance-mass", type=float, help=f"eccentric mass m_v [kg] (default: the paper's {UNBALANCE['mass']:g})"
        )
        p.add_argument(
            "--eccentricity",
            type=float,
            help=f"eccentricity e [m] (default: the paper's {UNBALANCE['eccentricity']:g})",
        )
        p.add_argument(
            "--unbalance-point",
            default="0,0,0",
            help="a point x,y,z [m] of the rotation axis (default: the origin, the paper's vibrator on the vertical "
            "axis through the centre of mass)",
        )
        p.add_argument(
            "--unbalance-axis", default="0,0,1", help="direction of the rotation axis (default: vertical, the paper's)"
        )

    p = machine_command("simulate", "simulate an experiment on the virtual rig and write a record (.csv, .uff, .tdms)")
    p.add_argument(
        "--out",
        required=True,
        help="record file to write (.csv or .txt for text, .uff/.unv for UFF dataset 58, .tdms for TDMS)",
    )
    p.add_argument("--duration", type=float, default=4.0, help="record length [s]")
    p.add_argument("--rate", type=float, default=2000.0, help="sampling rate [Hz]")
    p.add_argument("--noise", type=float, default=0.01, help="white noise std relative to each channel's RMS")
    p.add_argument("--seed", type=int, default=0, help="seed of the noise (a non-negative integer)")
    p.add_argument(
        "--sensor",
        nargs="+",
        action="extend",
        metavar="NAME=x,y,z:dx,dy,dz",
        help="accelerometer channels (default: the paper's layout plus A_z and C_x)",
    )
    p.add_argument("--hit-point", help="impact point x,y,z [m] (default: the paper's oblique hit)")
    p.add_argument("--hit-direction", help="impact direction")
    p.add_argument("--hit-peak", type=float, default=HIT_PEAK, help="peak impact force [N]")
    p.add_argument(
        "--hit-time",
        type=float,
        nargs="+",
        default=[HIT_TIME],
        metavar="T",
        help="when the hit begins [s] from the record's start (later: a pre-trigger, as bench exports keep one); "
        "several times: a hit at each, in one record",
    )
    p.add_argument(
        "--shaker",
        nargs=2,
        type=float,
        metavar=("LOW", "HIGH"),
        help="a shaker at --hit-point along --hit-direction instead of hits: a multisine (periodic random) over LOW to "
        "HIGH [Hz], repeating every --shaker-period (record its force with --force-channel; the records chain "
        "averages the periods after the first)",
    )
    p.add_argument(
        "--shaker-period", type=float, default=16.0, metavar="S", help="the shaker's period [s] (default 16)"
    )
    p.add_argument("--shaker-rms", type=float, default=200.0, metavar="N", help="the shaker's RMS force [N]")
    p.add_argument(
        "--shaker-burst",
        type=float,
        metavar="SHARE",
        help="burst random instead: the shaker on for this share of each period (new phases each time), then quiet "
        "while the response dies out",
    )
    p.add_argument(
        "--shaker-random",
        action="store_true",
        help="random instead: new phases each period, back to back (it never repeats: the records chain fits the "
        "impulse responses by least squares over the record; record eight times the machine's decay or more)",
    )
    p.add_argument(
        "--shaker-at",
        nargs=2,
        action="append",
        metavar=("POINT", "DIRECTION"),
        help="a further shaker beside --shaker's, at POINT x,y,z [m] along DIRECTION, with its own signal (repeat for "
        "more: a MIMO test, --shaker-random or --shaker-burst); give a --force-channel name per shaker",
    )
    p.add_argument(
        "--ambient",
        type=float,
        metavar="N",
        help="output-only instead of hits: unmeasured random forces of N [N] RMS each, white to 0.4 x the rate, "
        "along x, y and z at every isolator (the ground's vibration; with --speed, a running machine's operation); "
        "the records chain fits the correlation functions of the responses",
    )
    p.add_argument(
        "--force-channel",
        nargs="+",
        metavar="NAME",
        help="record the hammer's force [N] as a last channel of this name (an impact hammer's load cell: the "
        "records chain then fits the modes on the H1 frequency responses); one name per shaker with --shaker-at",
    )
    p.add_argument(
        "--speed",
        nargs="+",
        type=speed,
        help="rotating-unbalance speeds [rad/s, or with the unit: 1500rpm, 25Hz] instead of a hit",
    )
    add_unbalance(p)
    p.set_defaults(func=cmd_simulate)
    p = machine_command("identify-record", "modal data, stiffness and damping from an impact record")
    p.add_argument("--figures", help="folder for the spectrum and mode-shape figures")
    p.add_argument("--use", nargs="+", metavar="LABEL", help="fit only these measured modes (default: all found)")
    p.add_argument(
        "--root", metavar="RULE", help="pick between equally good solutions no measured mode decides, e.g. c_z>c_xy"
    )
    add_record_options(p)
    p.set_defaults(func=cmd_identify_record)
    p = machine_command("plan", "before the test: what a sensor layout, hit and record length will measure")
    p.add_argument(
        "--sensor",
        nargs="+",
        action="extend",
        metavar="NAME=x,y,z:dx,dy,dz",
        help="accelerometer channels (default: the paper's three, A_x, A_y, B_y)",
    )
    p.add_argument("--hit-point", help="impact point x,y,z [m] (default: the paper's oblique hit)")
    p.add_argument("--hit-direction", help="impact direction")
    p.add_argument(
        "--duration",
        type=float,
        help="record length [s] (default 4; with --ambient twenty times the shortest the records chain reads)",
    )
    p.add_argument(
        "--rate", type=float, help="sampling rate [Hz] (default 2048; with --ambient 100, doubled above a mode's band)"
    )
    p.add_argument("--noise", type=float, default=0.01, help="white noise std relative to each channel's RMS")
    p.add_argument(
        "--ambient",
        type=float,
        metavar="N",
        help="an output-only test instead of a hit: random forces of N [N] RMS along x, y and z at every isolator "
        "(as simulate --ambient); the plan simulates records of it and runs the records chain on each",
    )
    p.add_argument(
        "--draws", type=int, default=4, help="with --ambient: how many records to simulate (default 4, at most 100)"
    )
    p.set_defaults(func=cmd_plan)
    p = machine_command("process", "modal data (labelled frequencies, damping, MAC) from an impact record")
    add_record_options(p)
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
    p.add_argument(
        "--speed", nargs="+", type=speed, required=True, help="speeds [rad/s, or with the unit: 1500rpm, 25Hz]"
    )
    add_unbalance(p)
    p.set_defaults(func=cmd_forced)
    for command in sub.choices.values():  # an error about an option's value names the option (_as_given)
        options = {a.dest: a.option_strings[-1] for a in command._actions if a.option_strings}
        command.set_defaults(options=options)
    return parser


def _as_given(error: InputError, args: argparse.Namespace | None) -> str:
    """The error, its parameter named as the command line gave it: a value of ``--set`` as "--set m: ..." (a
    campaign's as "known.m: ..."), the value of an option of the command as the option ("--start: ...", where
    the Python API says "start: ...")."""
    for attr, option in (("set", "--set"), ("nominal", "--nominal")):
        given = {item.partition("=")[0].strip() for item in (getattr(args, attr, None) or ())}
        if error.parameter in given:
            return f"{option} {error}"
    option = (getattr(args, "options", None) or {}).get(error.parameter)
    return f"{option}: {error.reason}" if option else str(error)


def main(argv: Sequence[str] | None = None) -> int:
    args = None
    try:
        args = build_parser().parse_args(argv)
        args.func(args)
    except InputError as exc:
        print(f"mountid: error: {_as_given(exc, args)}", file=sys.stderr)
        return 2
    except ModuleNotFoundError as exc:  # an optional dependency (extra) that is not installed
        top = (exc.name or "").split(".")[0]
        if top not in EXTRAS:
            raise
        print(
            f"mountid: error: {top}: not installed; this command needs it: pip install 'mountid[{EXTRAS[top]}]'",
            file=sys.stderr,
        )
        return 2
    except BrokenPipeError:  # the reader of the output stopped early (mountid ... | head): nothing to report
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())  # the interpreter's final flush of stdout would fail again
        return 1
    except OSError as exc:  # a file that cannot be read or written: named, one line
        print(f"mountid: error: {exc.filename or 'file'}: {exc.strerror or exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
