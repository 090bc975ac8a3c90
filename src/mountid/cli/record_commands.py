"""Commands on records: simulate, process, identify-record, forced."""

from __future__ import annotations

import argparse
import itertools
import math
from dataclasses import asdict, replace
from typing import TYPE_CHECKING

from mountid.cli.arguments import (
    HIT_PEAK_LIMIT,
    HIT_TIME,
    NOISE_LIMIT,
    beyond_first_order,
    bounded,
    check_unbalance,
    direction,
    file_to_write,
    finite_number,
    pairs,
    paper_unbalance,
    placements,
    point_on_machine,
    print_json,
    read_runs,
    record_size,
    unbalance_within,
    unbalances_of,
)
from mountid.errors import InputError
from mountid.machine import Machine
from mountid.nomenclature import counted
from mountid.validation.paper import HIT_PEAK

if TYPE_CHECKING:
    from collections.abc import Callable, Sequence

    from numpy.typing import NDArray

    from mountid.identification.from_records import Identification
    from mountid.identification.planning import Plan
    from mountid.measurement.records import ModeTable, Record
    from mountid.measurement.rig import Hammer, RandomForce, Rig, Sensor, Shaker, Unbalance


def cmd_simulate(args: argparse.Namespace) -> None:
    from mountid.measurement.rig import Rig

    out = file_to_write(args.out, "--out", {suffix: FORMATS[kind] for suffix, kind in WRITERS.items()})
    record_size(args.duration, args.rate)
    if args.seed < 0:
        raise InputError("--seed", f"must be a non-negative integer, got {args.seed}")
    bounded(args.noise, "--noise", NOISE_LIMIT, " x RMS", strict=False)
    bounded(args.hit_peak, "--hit-peak", HIT_PEAK_LIMIT, " N", strict=False)
    _hit_times(args.hit_time, args.duration)
    if args.force_channel is not None and args.speed:
        raise InputError("--force-channel", "a rotating unbalance (--speed) has no hammer whose force it would record")
    filled = paper_unbalance(args)  # the paper's eccentric weight where not given, said only under --speed
    check_unbalance(args)
    rig = Rig.of(args.machine, pairs(args.set, "--set"))
    if args.speed:
        unbalance_within(args, float(rig.M[0, 0]))
    sensors = _sensors(args.sensor, args.noise)
    if not sensors:
        from mountid.validation.paper import paper_sensors

        sensors = paper_sensors(args.noise)
    hit = _hit(args)
    shakers = _shakers(args, hit)
    forces = _force_channels(args, shakers, sensors)
    ambient = _ambient(args, rig, shakers)
    _no_hit_options(args, shakers, ambient)
    hits = not (args.speed or shakers or ambient)
    hammers = [replace(hit, peak=args.hit_peak, time=t) for t in args.hit_time] if hits else []
    unbalances = unbalances_of(args)
    record = rig.simulate(
        sensors,
        args.duration,
        args.rate,
        hammers,
        unbalances,
        seed=args.seed,
        force_channel=forces,
        shakers=shakers,
        ambient=ambient,
    )
    kind = WRITERS[out.suffix.lower()]
    _writer(kind)(record, args.out)
    notes = [n for u in unbalances for n in _small_motion_note(rig, u.speed, _steady_amplitude(rig, u))]
    notes += _close_hits_note(args.hit_time) if hits else []
    notes += _ambient_note(rig, args.duration, args.rate) if ambient else []
    if args.shaker_random and math.isfinite(rig.slowest_decay()):
        notes += random_length_note(args.duration, rig.slowest_decay())
    elif shakers and not args.shaker_random and args.duration < 3 * args.shaker_period:
        block = "periods" if args.shaker_burst is None else "bursts"
        needs = "the periods after the first and needs two of them" if block == "periods" else "them and needs three"
        notes.append(
            f"{args.duration:g} s holds fewer than 3 {block} of {args.shaker_period:g} s: the records chain averages "
            f"{needs}"
        )
    # the hit's point and direction (a shaker's too) where a hammer or shaker uses them and they were not given
    hit_default = (hits or shakers) and not (args.hit_point or args.hit_direction)
    defaults = _paper_defaults(rig.machine, sensors if not args.sensor else [], hit if hit_default else None)
    notes += [defaults] if defaults else []
    notes += _paper_unbalance_note(rig.machine, filled) if args.speed else []
    from mountid.identification.planning import steady_modes, steady_note

    notes += [note] if (note := steady_note(rig, steady_modes(rig))) else []
    if args.json:
        print_json(
            {
                "file": args.out,
                "format": kind,
                "samples": len(record.time),
                "rate": args.rate,
                "duration": args.duration,
                "channels": list(record.names),
                "notes": notes,
            }
        )
        return
    count = counted(len(record.channels), "channel")
    print(f"wrote {args.out}: {len(record.time)} samples x {count} ({', '.join(record.names)})")
    for note in notes:
        print(f"note: {note}")


def _force_channels(args: argparse.Namespace, shakers: list[Shaker], sensors: list[Sensor]) -> str | list[str] | None:
    """The force channels --force-channel names: one for the hammer or shaker, one per shaker with --shaker-at; an
    InputError naming the option for a name that is empty, a response channel's or given twice, or a count that
    differs (a sum of several shakers' forces measures none of them)."""
    names = args.force_channel
    if names is None:
        return None
    for force in names:
        if not force.strip() or force in {s.name for s in sensors}:
            what = "a response channel's name" if force.strip() else "empty"
            raise InputError("--force-channel", f"{force!r} is {what}")
    if len(set(names)) != len(names):
        raise InputError("--force-channel", f"{' '.join(names)}: each force's channel needs its own name")
    if len(shakers) > 1 and len(names) != len(shakers):
        raise InputError(
            "--force-channel",
            f"{counted(len(names), 'name')} for {len(shakers)} shakers: one per shaker, each force on its own channel "
            "(the sum of their forces measures none of them)",
        )
    if len(shakers) <= 1 and len(names) > 1:
        several = f"{counted(len(names), 'name')}: several are for several shakers (--shaker-at)"
        raise InputError("--force-channel", several)
    return names[0] if len(names) == 1 else names


def _ambient(args: argparse.Namespace, rig: Rig, shakers: list[Shaker]) -> list[RandomForce]:
    """The random forces --ambient gives at the isolators (rig.ambient_forces, white to 0.4 x the rate; [] without
    it); an InputError naming the option that does not go with them."""
    from mountid.measurement.rig import ANTI_ALIAS, ambient_forces

    if args.ambient is None:
        return []
    bounded(args.ambient, "--ambient", HIT_PEAK_LIMIT, " N")
    if shakers:
        raise InputError("--ambient", "and --shaker are two tests: an output-only one and one whose force is measured")
    if args.force_channel is not None:
        raise InputError("--force-channel", "ambient forces are not measured: an output-only record has no force")
    if args.hit_time != [HIT_TIME]:
        raise InputError("--ambient", "drives the machine from the start: --hit-time is for hits")
    return ambient_forces(rig, args.ambient, ANTI_ALIAS * args.rate, args.seed)


def _no_hit_options(args: argparse.Namespace, shakers: list[Shaker], ambient: list[RandomForce]) -> None:
    """An InputError naming a hit's option given to a simulated test without hits, where it would be ignored:
    --hit-point and --hit-direction beside --ambient or --speed (a shaker takes them as its own), --hit-peak and
    --hit-time beside any of them (--ambient and --shaker refuse --hit-time first, in their own words)."""
    test = "--ambient" if ambient else "--speed" if args.speed else "--shaker" if shakers else ""
    if not test:
        return
    given = {"--hit-peak": args.hit_peak != HIT_PEAK, "--hit-time": args.hit_time != [HIT_TIME]}
    if not shakers:
        given |= {"--hit-point": bool(args.hit_point), "--hit-direction": bool(args.hit_direction)}
    for option, is_given in given.items():
        if is_given:
            raise InputError(option, f"is a hit's: {test} gives a test without hits, where it would be ignored")


def _ambient_note(rig: Rig, duration: float, rate: float) -> list[str]:
    """simulate's note on an output-only record: how long the records chain needs it at the ``rate`` [Hz] it is
    sampled at, where it is shorter (none where a motion is free: no lowest mode to hold)."""
    from mountid.measurement.ambient import SEGMENTS, shortest_record
    from mountid.measurement.settings import RECORDS

    lowest = rig.lowest_frequency()
    if not lowest > 0:
        return []
    needed = shortest_record(lowest, RECORDS.min_periods, rate=rate)
    said = (
        f"an output-only record: the records chain fits the correlation functions of the responses over {SEGMENTS} "
        f"segments, to {RECORDS.min_periods:g} periods of the lowest mode at least; it needs {needed:.4g} s or more"
    )
    if duration < needed:
        return [f"{said}, {duration:g} s is shorter"]
    return [f"{said}, and their uncertainty shrinks as the square root of the record's length"]


def _shakers(args: argparse.Namespace, hit: Hammer) -> list[Shaker]:
    """The shaker --shaker gives at the hit's point and direction ([] without it); an InputError naming the option
    for a band outside 0 to 0.4 x the rate (the acquisition's anti-alias filter), a period or force that is not
    positive, or --speed or --hit-time beside it."""
    from mountid.measurement.rig import ANTI_ALIAS, Shaker

    if args.shaker is None:
        if args.shaker_at:
            raise InputError("--shaker-at", "is a further shaker's: give the first with --shaker LOW HIGH")
        if args.shaker_burst is not None:
            raise InputError("--shaker-burst", "is a shaker's: give its band with --shaker LOW HIGH")
        if args.shaker_random:
            raise InputError("--shaker-random", "is a shaker's: give its band with --shaker LOW HIGH")
        return []
    if args.shaker_random and args.shaker_burst is not None:
        raise InputError("--shaker-random", "and --shaker-burst are two excitations: give one")
    if args.speed:
        raise InputError("--shaker", "a shaker and a rotating unbalance (--speed) are two experiments: give one")
    if args.hit_time != [HIT_TIME]:
        raise InputError("--shaker", "drives the machine from the start: --hit-time is for hits")
    low, high = args.shaker
    if not (math.isfinite(low) and math.isfinite(high) and 0 <= low < high <= ANTI_ALIAS * args.rate):
        raise InputError(
            "--shaker", f"{low:g} {high:g}: a band 0 <= LOW < HIGH <= {ANTI_ALIAS * args.rate:g} Hz (0.4 x the rate)"
        )
    bounded(args.shaker_period, "--shaker-period", args.duration, " s")
    bounded(args.shaker_rms, "--shaker-rms", HIT_PEAK_LIMIT, " N")
    if args.shaker_burst is not None and not 0 < args.shaker_burst < 1:
        raise InputError("--shaker-burst", f"{args.shaker_burst:g}: a share of the period between 0 and 1")
    if args.shaker_at and not args.shaker_random and args.shaker_burst is None:
        raise InputError(
            "--shaker-at",
            "several shakers at once need --shaker-random or --shaker-burst: a periodic excitation repeats each "
            "period, and one record cannot tell the shakers' frequency responses apart",
        )
    shaker = Shaker(hit.point, hit.direction, args.shaker_rms, low, high, args.shaker_period, args.seed)
    shaker = replace(shaker, burst=args.shaker_burst, random=args.shaker_random)
    return [shaker] + [
        replace(
            shaker,
            point=point_on_machine(point, "--shaker-at"),
            direction=direction(axis, "--shaker-at"),
            seed=args.seed + k,
        )
        for k, (point, axis) in enumerate(args.shaker_at or [], start=1)
    ]


def random_length_note(duration: float, slowest: float) -> list[str]:
    """What a random excitation's record of ``duration`` [s] lacks for a machine whose slowest decay has the time
    constant ``slowest`` [s] ([] where nothing): impulse responses of 1/RecordSettings.random_blocks of it that
    outlast that decay frf.RANDOM_DECAYS times (frf.shaker_lengths)."""
    from mountid.measurement.frf import RANDOM_DECAYS, shaker_lengths
    from mountid.measurement.settings import RECORDS

    needed = shaker_lengths(slowest)["random"]
    if duration >= needed:
        return []
    return [
        f"random excitation: the records chain fits impulse responses of 1/{RECORDS.random_blocks} of the record, "
        f"which must outlast the slowest decay (time constant {slowest:.3g} s) {RANDOM_DECAYS:g} times: record "
        f"{needed:.3g} s or more"
    ]


def _hit_times(times: Sequence[float], duration: float) -> None:
    """--hit-time's times [s]: each from the record's start (later: a pre-trigger, as bench exports keep one) to
    before its end (at or after it, none), in increasing order, each after the pulse of the one before (one
    hammer); an InputError naming the option otherwise."""
    from mountid.measurement.rig import Hammer

    pulse = Hammer((0.0, 0.0, 0.0), (0.0, 0.0, 1.0)).duration
    for k, t in enumerate(times):
        finite_number(t, "--hit-time", strict=False)
        if t >= duration:
            raise InputError("--hit-time", f"{t:g} s is at or after the record's end ({duration:g} s)")
        if k and t <= times[k - 1] + pulse:
            raise InputError(
                "--hit-time",
                f"{t:g} s is not after the hit at {times[k - 1]:g} s and its pulse of {pulse * 1e3:g} ms (one hammer: "
                "give the times in increasing order)",
            )


def _close_hits_note(times: Sequence[float]) -> list[str]:
    """The note (a list of none or one) naming hits [s] closer than the records chain's separate hits
    (RecordSettings.hit_spacing): it takes the later for a double hit of the earlier."""
    from mountid.measurement.settings import RECORDS

    close = [(a, b) for a, b in itertools.pairwise(times) if b - a <= RECORDS.hit_spacing]
    if not close:
        return []
    later, before = (", ".join(f"{t:g}" for t in column) for column in ([b for _, b in close], [a for a, _ in close]))
    return [
        f"the hits at {later} s lie within {RECORDS.hit_spacing:g} s of the one before (at {before} s): the records "
        "chain takes each for a double hit of that one, not a hit of its own"
    ]


WRITERS = {".csv": "csv", ".txt": "csv", ".uff": "uff58", ".unv": "uff58", ".tdms": "tdms"}
"""The record formats simulate writes, by the file's suffix."""

FORMATS = {"csv": "text", "uff58": "UFF dataset 58", "tdms": "TDMS"}
"""What each record format of WRITERS is called in errors."""


def _writer(kind: str) -> Callable[[Record, str], None]:
    """The writer of a record format (WRITERS); the UFF and TDMS writers' libraries are imported only for them."""
    if kind == "uff58":
        from mountid.measurement.uff import write_uff

        return write_uff
    if kind == "tdms":
        from mountid.measurement.tdms import write_tdms

        return write_tdms
    from mountid.measurement.records import write_csv

    return write_csv


def _hit(args: argparse.Namespace) -> Hammer:
    """The hit --hit-point and --hit-direction give, each the paper's oblique hit's where left out."""
    from mountid.measurement.rig import Hammer
    from mountid.validation.paper import paper_hit

    hit = paper_hit()
    return Hammer(
        point_on_machine(args.hit_point, "--hit-point") if args.hit_point else hit.point,
        direction(args.hit_direction, "--hit-direction") if args.hit_direction else hit.direction,
    )


def _paper_defaults(machine: Machine, sensors: list[Sensor], hit: Hammer | None) -> str:
    """The note that says which of a planned or simulated test's channels (``sensors``: those left to the default)
    and hit (``hit``: where left to the default) are the paper's, on a ``machine`` that is not the paper's
    (validation.paper.PAPER_MACHINES): points of KID-300. "" where there is nothing to say."""
    from mountid.validation.paper import PAPER_MACHINES

    if machine.name in PAPER_MACHINES or not (sensors or hit):
        return ""
    what = [
        "channels " + ", ".join(f"{s.name} at {s.point} along {s.direction}" for s in sensors) if sensors else "",
        f"hit at {hit.point} along {hit.direction}" if hit else "",
    ]
    options = (["--sensor"] if sensors else []) + (["--hit-point", "--hit-direction"] if hit else [])
    give = "give" if len(options) > 1 else "gives"
    return (
        f"the paper's {' and '.join(w for w in what if w)}: points of KID-300, not of {machine.name} "
        f"({', '.join(options)} {give} its own)"
    )


def _paper_unbalance_note(machine: Machine, filled: dict[str, str]) -> list[str]:
    """The note that says which of the paper's eccentric weight's values (``filled``: paper_unbalance's) a
    simulated or forced response of another machine than the paper's takes (validation.paper.PAPER_MACHINES):
    KID-300's vibrator. Empty where there is nothing to say."""
    from mountid.validation.paper import PAPER_MACHINES

    if machine.name in PAPER_MACHINES or not filled:
        return []
    give = "give" if len(filled) > 1 else "gives"
    return [
        f"the paper's {' and '.join(filled.values())}: KID-300's vibrator, not {machine.name}'s "
        f"({', '.join(filled)} {give} its own)"
    ]


def _sensors(items: list[str] | None, noise: float) -> list[Sensor]:
    """Sensors from --sensor NAME=x,y,z:dx,dy,dz options, each with white noise of ``noise`` x its RMS."""
    from mountid.measurement.rig import Sensor

    return [Sensor(name, p, d, noise=noise) for name, (p, d) in placements(items, "--sensor").items()]


def cmd_plan(args: argparse.Namespace) -> None:
    from mountid.identification.planning import plan
    from mountid.measurement.rig import ANTI_ALIAS
    from mountid.validation.paper import paper_sensors

    bounded(args.noise, "--noise", NOISE_LIMIT, " x RMS")
    machine = Machine.resolve(args.machine)
    sensors = _sensors(args.sensor, args.noise) or paper_sensors(args.noise)[:3]
    if args.ambient is not None:
        _plan_output_only(args, machine, sensors)
        return
    if args.draws != 4:
        raise InputError("--draws", "is for an output-only plan (--ambient): a hit's plan simulates no records")
    args.duration = 4.0 if args.duration is None else args.duration
    args.rate = 2048.0 if args.rate is None else args.rate
    record_size(args.duration, args.rate)
    hit = _hit(args)
    result = plan(machine, sensors, hit, args.duration, args.rate, args.noise, pairs(args.set, "--set"))
    if args.json:
        print_json(result.to_dict())
        return
    print(
        f"{machine.name}: {counted(len(sensors), 'channel')} "
        f"({', '.join(s.name for s in sensors)}), a hit at "
        f"{hit.point} along {hit.direction}, {args.duration:g} s at {args.rate:g} Hz, noise {args.noise:g} x RMS"
    )
    defaults = _paper_defaults(
        machine, sensors if not args.sensor else [], None if args.hit_point or args.hit_direction else hit
    )
    if defaults:
        print(f"  note: {defaults}")
    print(f"  {'mode':8s}{'frequency':>11s}{'zeta':>8s}  {'expected std: frequency':>24s}{'zeta':>10s}")
    for m in result.modes:
        if m.measured:
            tail = f"{m.frequency_std:>17.2g} rad/s{m.damping_std:>10.2g}"
            tail += f"  (one pole with {m.pole_of})" if m.pole_of != m.label else ""
        else:
            tail = "  not seen by these channels" if not m.seen else "  not excited by this hit"
            if m.seen and m.excited:
                tail = f"  above the record's band (the anti-alias filter at {ANTI_ALIAS:g} x {args.rate:g} Hz)"
            if m.seen and m.excited and m.in_band:
                tail = "  a steady oscillation to the records chain (see the note)"
        print(f"  {m.label:8s}{m.frequency:11.4f}{round(m.damping_ratio, 4) + 0.0:8.4f}  {tail}")
    _print_plan_end(machine, result)


def _print_plan_end(machine: Machine, result: Plan) -> None:
    """The lines every plan ends with: each unknown's expected standard deviation, the notes, the six most
    informative channels."""
    for name, value in result.parameter_std.items():
        shown = f"{value:.3g} {machine.parameters[name]['unit']}" if math.isfinite(value) else "none (see the note)"
        print(f"  expected std of {name}: {shown}")
    for note in result.notes:
        print(f"  note: {note}")
    best = ", ".join(c for c, _ in result.ranking[:6])
    print(f"  six most informative channels (effective independence, candidates at the sensors and isolators): {best}")


def _plan_output_only(args: argparse.Namespace, machine: Machine, sensors: list[Sensor]) -> None:
    """plan --ambient: the output-only test's plan (planning.plan_output_only), printed or as JSON; its defaults
    (a duration twenty times the shortest record the chain reads, rounded up to 10 s; 100 Hz, doubled while the
    highest mode lies above a quarter of the rate) and refusals (a hit's options, --draws out of 1-100)."""
    from mountid.identification.planning import plan_output_only
    from mountid.measurement.ambient import shortest_record
    from mountid.measurement.rig import Rig
    from mountid.measurement.settings import RECORDS

    bounded(args.ambient, "--ambient", HIT_PEAK_LIMIT, " N")
    for option, given in (("--hit-point", args.hit_point), ("--hit-direction", args.hit_direction)):
        if given:
            raise InputError(option, "an output-only plan has no hit: its random forces act at every isolator")
    if not 1 <= args.draws <= 100:
        raise InputError("--draws", f"{args.draws}: simulate 1 to 100 records")
    values = pairs(args.set, "--set")
    rig = Rig.of(machine, values)
    lowest, highest = rig.lowest_frequency(), max(abs(complex(p)) for p in rig.poles) / (2 * math.pi)
    if args.duration is None:
        args.duration = 10.0 * math.ceil(2.0 * shortest_record(lowest, RECORDS.min_periods)) if lowest > 0 else 600.0
    if args.rate is None:
        args.rate = 100.0
        while highest > args.rate / 4:
            args.rate *= 2
    record_size(args.duration, args.rate)
    result = plan_output_only(machine, sensors, args.duration, args.rate, args.ambient, args.draws, values)
    if args.json:
        print_json(result.to_dict())
        return
    simulated = result.modes[0].found[1]  # 0 where no record would give a mode (the plan's first note says why)
    print(
        f"{machine.name}: {counted(len(sensors), 'channel')} ({', '.join(s.name for s in sensors)}), output-only "
        f"(random forces of {args.ambient:g} N RMS at every isolator), {args.duration:g} s at {args.rate:g} Hz, "
        f"noise {args.noise:g} x RMS, {counted(simulated, 'simulated record') if simulated else 'no record simulated'}"
    )
    defaults = _paper_defaults(machine, sensors if not args.sensor else [], None)
    if defaults:
        print(f"  note: {defaults}")
    print(f"  {'mode':8s}{'frequency':>11s}{'zeta':>8s}  {'expected std: frequency':>24s}{'zeta':>10s}  found in")
    for m in result.modes:
        count = f"{m.found[0]} of {m.found[1]}"
        if not m.seen:
            tail = "  not seen by these channels"
        elif m.steady:
            tail = "  a steady oscillation to the records chain (see the note)"
        elif not m.found[0]:
            tail = f"  not found in any of {m.found[1]} records"
        else:
            tail = f"{m.frequency_std:>17.2g} rad/s{m.damping_std:>10.2g}  {count}"
            tail += f"  (one pole with {m.pole_of})" if m.pole_of != m.label else ""
        print(f"  {m.label:8s}{m.frequency:11.4f}{round(m.damping_ratio, 4) + 0.0:8.4f}  {tail}")
    _print_plan_end(machine, result)


def _modal_json(machine: Machine, modes: dict, unlabelled: list, warnings: list) -> dict:
    """The JSON of labelled modal data (process, identify-record)."""
    fields = ("frequency", "frequency_std", "damping_ratio", "damping_std", "mac", "shape", "shape_std")
    return {
        "machine": machine.name,
        "frequency_type": "pole",  # |p| of each pole (a campaign of these modes says "frequency_type": "pole")
        "modes": {k: {f: getattr(m, f) for f in fields} for k, m in modes.items()},
        "unlabelled_poles": [{"frequency": p.frequency, "damping_ratio": p.damping_ratio} for p in unlabelled],
        "warnings": [asdict(w) for w in warnings],
    }


def _identification_json(machine: Machine, result: Identification) -> dict:
    return {
        **_modal_json(machine, result.modes, result.unlabelled, result.warnings),
        "parameters": result.parameters,
        "parameter_std": result.parameter_std,
        "damping": result.damping,
        "damping_std": result.damping_std,
        "frequencies": result.frequencies,
        "notes": result.notes,
    }


def cmd_identify_record(args: argparse.Namespace) -> None:
    from mountid.identification.from_records import identify_from_records

    machine = Machine.resolve(args.machine)
    runs = read_runs(args)
    use = tuple(args.use) if args.use else None
    result = identify_from_records(
        machine,
        runs,
        pairs(args.set, "--set"),
        start=args.start,
        nominal=pairs(args.nominal, "--nominal"),
        use=use,
        root=args.root,
        use_force=not args.free_decay,
    )
    written = _frf_out(args, runs)
    if written:
        result = replace(result, notes=[*result.notes, *written])
    if args.figures:
        from mountid.report import figures

        figures.experiment_figures(machine, runs[0][1], result, pairs(args.set, "--set"), args.figures)
        if len(runs) > 1:
            which = f"figures: the spectra and the stabilisation diagram of {runs[0][0]}, its first decay"
            result = replace(result, notes=[*result.notes, which])
    if args.json:
        print_json(_identification_json(machine, result))
        return
    _print_modes(machine, _source(args, runs), result.modes, result.unlabelled, result.warnings, result.notes)
    for name, value in result.parameters.items():
        print(f"  {name} = {value:.6g} +- {result.parameter_std[name]:.2g} {machine.parameters[name]['unit']}")
    for name, value in result.damping.items():
        print(f"  {name} = {value:.6g} +- {result.damping_std[name]:.2g} {machine.parameters[name]['unit']}")
    beyond_first_order({**result.parameters, **result.damping}, {**result.parameter_std, **result.damping_std}, "  ")


def cmd_process(args: argparse.Namespace) -> None:
    from mountid.identification.combination import every_decay

    machine = Machine.resolve(args.machine)
    runs = read_runs(args)
    # every decay of every run (a record of several hits, a file of several runs), combined per mode
    known, nominal = pairs(args.set, "--set"), pairs(args.nominal, "--nominal")
    found = every_decay(machine, runs, known, args.start, nominal, use_force=not args.free_decay)
    notes = [*found.notes, *_frf_out(args, runs)]
    out = _modal_json(machine, found.modes, found.unlabelled, found.warnings)
    if args.json:
        print_json({**out, "notes": notes})
        return
    _print_modes(machine, _source(args, runs), found.modes, found.unlabelled, found.warnings, notes)


def _frf_out(args: argparse.Namespace, runs: Sequence[tuple[str, Record | ModeTable]]) -> list[str]:
    """--frf-out: the frequency responses of every run (frf.of_inputs: of each force of several shakers at once)
    written as a UFF file (uff.write_frf), and the note that says so ([] without the option); an InputError naming
    the option for a file or a run it cannot write (a table of modes, frequency response functions already, no force
    channel)."""
    if not args.frf_out:
        return []
    path = file_to_write(args.frf_out, "--frf-out", {".uff": "UFF", ".unv": "UFF"})
    from mountid.measurement import frf
    from mountid.measurement.records import ModeTable
    from mountid.measurement.uff import write_frf

    estimates = []
    for name, record in runs:
        if isinstance(record, ModeTable):
            raise InputError("--frf-out", f"{name} is a table of modes: no force to estimate frequency responses from")
        try:
            inputs = frf.of_inputs(record)
        except InputError as err:
            raise InputError("--frf-out", f"{name}: {err}") from None
        estimates += [(e, next(c for c in record.channels if c.name == e.force)) for e in inputs]
    write_frf(estimates, path)
    windows = sorted({e.window_decay for e, _ in estimates if e.window_decay})
    read_back = (
        f"; the responses carry an exponential window of {', '.join(f'{w:.9g}' for w in windows)} 1/s: read back "
        f"with --exponential-window {windows[0]:.9g}"
        if windows
        else ""
    )
    responses = counted(len(estimates[0][0].responses), "frequency response function")
    inputs = counted(len(estimates), "run") if len(estimates) == len(runs) else counted(len(estimates), "input")
    each = "run" if len(estimates) == len(runs) else "input"
    return [f"wrote {path}: {responses} per {each}, {inputs}{read_back}"]


def _source(args: argparse.Namespace, runs: Sequence[tuple[str, Record | ModeTable]]) -> str:
    """The record a command read: its file, with the run where --run chose one or the runs it read."""
    return runs[0][0] if len(runs) == 1 else f"{args.record} ({counted(len(runs), 'run')})"


def _print_modes(
    machine: Machine, record: str, modes: dict, unlabelled: list, warnings: list, notes: Sequence[str] = ()
) -> None:
    """The labelled modes of a record as process and identify-record print them: what they come from, the
    record's warnings and notes, each mode's pole (|p| and zeta, with the MAC against the model's shape where
    the channels give one) and what the table does not show (_not_found)."""
    print(f"{machine.name}: {counted(len(modes), 'mode')} from {record}")
    for w in warnings:
        print(f"  warning ({w.kind}, {w.channel}): " + (f"{w.record}: " if w.record else "") + w.message)
    for note in notes:
        print(f"  note: {note}")
    print('  the poles\' |p| [rad/s, Hz] and zeta = -Re p / |p| (in a campaign: "frequency_type": "pole")')
    for k, m in modes.items():
        print(
            f"  {k:>8s}  {m.frequency:10.4f} +- {m.frequency_std:.2g} rad/s ({m.frequency / (2 * math.pi):.4f} Hz)"
            f"  zeta {m.damping_ratio:.4f}" + (f"  MAC {m.mac:.2f}" if m.mac is not None else "")
        )
    for line in _not_found(machine, modes, unlabelled):
        print(f"  {line}")


def _not_found(machine: Machine, modes: dict, unlabelled: list) -> list[str]:
    """Lines naming the model's modes without a labelled pole (twins count as found with each other) and the
    poles that were labelled as no mode: what a reader of the table would otherwise not see."""
    found = {machine.module.REPRESENTATIVE[label] for label in modes}
    missing = [label for label in machine.unique_modes if label not in found]
    lines = [f"not found in the record: {', '.join(missing)}"] if missing else []
    if unlabelled:
        poles = ", ".join(f"{p.frequency:.4g} rad/s (zeta {p.damping_ratio:.3g})" for p in unlabelled)
        lines.append(f"poles labelled as no mode of the model: {poles}")
    return lines


def _steady_amplitude(rig: Rig, unbalance: Unbalance) -> NDArray:
    """The steady-state amplitude of every coordinate [m, rad] under ``unbalance``; an InputError naming --speed
    where it leaves double precision."""
    import numpy as np

    t = np.linspace(0, 2 * np.pi / unbalance.speed, 64, endpoint=False)
    with np.errstate(over="raise", invalid="raise", divide="raise", under="ignore"):
        try:
            q, _ = rig.steady_state(unbalance, t)
            amplitude = np.max(np.abs(q), axis=0)
        except (FloatingPointError, OverflowError):
            amplitude = np.array([np.inf])
    if not np.all(np.isfinite(amplitude)):
        raise InputError("--speed", f"{unbalance.speed:g} rad/s puts the response out of the range of double precision")
    return amplitude


def _small_motion_note(rig: Rig, speed: float, amplitude: NDArray) -> list[str]:
    """The note (a list of none or one) naming the coordinates of a steady state at ``speed`` [rad/s] beyond the
    small motions the linear model describes (Rig.beyond_small_motion), and a missing damping."""
    from mountid.measurement.rig import SMALL_MOTION

    large = rig.beyond_small_motion(amplitude)
    if not large:
        return []
    why = "; the machine has no damping: at a natural frequency its response grows without bound"
    return [
        f"at {speed:g} rad/s {', '.join(large)}: beyond the small motions the linear model describes (rotations "
        f"to {SMALL_MOTION:g} rad, translations to {SMALL_MOTION:g} of the machine's length scale)"
        + ("" if rig.B.any() else why)
    ]


def cmd_forced(args: argparse.Namespace) -> None:
    from mountid.measurement.rig import Rig

    filled = paper_unbalance(args)
    check_unbalance(args)
    rig = Rig.of(args.machine, pairs(args.set, "--set"))
    unbalance_within(args, float(rig.M[0, 0]))
    rows, notes = {}, []
    turning = unbalances_of(args)
    for u in turning:
        amplitude = _steady_amplitude(rig, u)
        rows[f"{u.speed:g}"] = dict(zip(rig.machine.module.COORDINATES, map(float, amplitude), strict=True))
        notes += _small_motion_note(rig, u.speed, amplitude)
    notes += _paper_unbalance_note(rig.machine, filled)
    where = {"mass": args.unbalance_mass, "eccentricity": args.eccentricity}
    where |= {"point": list(turning[0].point), "axis": list(turning[0].axis)}
    if args.json:
        print_json(
            {"machine": rig.machine.name, "unit": "m, rad", "unbalance": where, "amplitudes": rows, "notes": notes}
        )
        return
    axis = ", ".join(f"{v:.3g}" for v in where["axis"])
    point = ", ".join(f"{v:g}" for v in where["point"])
    print(
        f"{rig.machine.name}: steady-state amplitude under the rotating unbalance [m, rad] ({args.unbalance_mass:g} kg "
        f"at {args.eccentricity:g} m, about the axis ({axis}) through ({point}) m)"
    )
    for w, amp in rows.items():
        print(f"  {w:>8s} rad/s  " + "  ".join(f"{c} {a:.3e}" for c, a in amp.items()))
    for note in notes:
        print(f"note: {note}")
