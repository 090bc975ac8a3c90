"""Blind truths through records (``make bench-records``): every truth a record carries (blind_records.RECORD_TRUTHS:
the machine's, then its sensors' as mounted against the layout the records state, then a reversed channel beside
a physical effect, then hardening isolators integrated through their law) on every shipped machine,
simulated as two impact records of the harness's 12 channels (2 % noise), diagnosed from the records, beside the
same truth's modal-data campaign with shapes (blind.run_case). Prints each case's two verdicts and counts, for the
records: confident and wrong, effect-free truths given a significant gap, cases where the records chain stopped,
and close modes split or left out; for the sensor truths: named first, confident, no significant gap, and how
often the records chain's own check named the misread channel (and noted one where every channel reads as
stated: its false alarms); for a reversed channel beside a physical effect: the verdicts' kinds and the channel
named; for the hardening isolators: the verdicts' kinds and, with a level, how often the levels were said to move.

``python -m benchmarks.records_blind --seeds N --first-seed S [--machines kid300 screen6] [--level 0.5]``: N seeds
per machine and truth (default 1, from seed 0); ``--level``: two more records per case, of the truth hit at that
many times the force with its rubber's stiffness changed (blind_records.record_campaign; hardening isolators by
their law alone), under the campaign's ``levels``, and a count of the verdicts that say the frequencies move beyond
a change of stiffness."""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

from mountid.validation import blind
from mountid.validation.blind_records import HARDENING_TRUTHS, RECORD_TRUTHS, run_record_case
from mountid.validation.blind_truth import REVERSED_BESIDE, SENSOR_TRUTHS


def _verdict(kind: str, first: str | None, probability: float) -> str:
    return f"{kind} ({first} {probability:.2f})" if first else kind


def study(
    seeds: int = 1, first_seed: int = 0, machines: tuple[str, ...] = blind.MACHINES, level: float | None = None
) -> list:
    """Run and print the study; returns the records' cases."""
    out = []
    started = time.perf_counter()
    print(f"{'machine':11s} {'truth':30s} {'seed':>4s}  {'from records':45s}  {'from modal data (shapes)':45s}")
    with tempfile.TemporaryDirectory() as tmp:
        for machine in machines:
            for i, truth in enumerate(RECORD_TRUTHS):
                for k in range(seeds):
                    seed = first_seed + i + k * len(RECORD_TRUTHS)
                    case = run_record_case(seed, truth, machine, Path(tmp), level=level)
                    modal = blind.run_case(seed, truth, "shapes", machine)
                    shown = (
                        f"error: {case.error[:38]}" if case.error else _verdict(case.kind, case.first, case.probability)
                    )
                    other = _verdict(modal.kind, modal.ranked[0] if modal.ranked else None, modal.probability)
                    flags = " CONFIDENT AND WRONG" if case.confident_and_wrong else ""
                    flags += " [close modes]" if case.close_modes else ""
                    if case.misread:
                        flags += f" [misread {','.join(case.misread)}]" if len(case.misread) < 3 else " [misread frame]"
                    flags += " [channel noted]" if case.sensor_suspects else ""
                    flags += " [levels move]" if case.levels_move else ""
                    print(
                        f"{machine:11s} {truth:30s} {seed:4d}  {shown:45s}  " f"{other:45s}{flags}",
                        flush=True,
                    )
                    out.append(case)
    wrong = sum(c.confident_and_wrong for c in out)
    clean = [c for c in out if c.truth == "none"]
    alarms = sum(c.kind not in ("no significant gap", "error") for c in clean)
    print(
        f"records: {len(out)} cases in {time.perf_counter() - started:.0f} s; confident and wrong {wrong}; "
        f"effect-free truths with a significant gap {alarms} of {len(clean)}; the records chain stopped in "
        f"{sum(bool(c.error) for c in out)}; close modes split or left out in {sum(bool(c.close_modes) for c in out)}"
    )
    if level is not None:
        linear = [c for c in out if c.truth not in HARDENING_TRUTHS]
        moved = [c for c in linear if c.levels_move]
        print(
            f"a second level at {level:g} times the force (the linear truths, their rubber changed alike in every "
            f"mode): the verdict says the frequencies move beyond a change of stiffness in {len(moved)} of "
            f"{len(linear)} ({sum(c.kind == 'not explained' for c in moved)} of them not explained)"
        )
    hard = [c for c in out if c.truth in HARDENING_TRUTHS]
    if hard:
        kinds = ", ".join(f"{k} {sum(c.kind == k for c in hard)}" for k in sorted({c.kind for c in hard}))
        said = f"; the levels said to move in {sum(c.levels_move for c in hard)}" if level else ""
        print(
            f"hardening isolators: {len(hard)} cases; {kinds}; confident {sum(c.confident for c in hard)}, "
            f"hardening rubber first in {sum(c.first == 'rubber_hardening' for c in hard)}{said}"
        )
    sensor = [c for c in out if set(c.truth.split("+")) <= SENSOR_TRUTHS]
    one = [c for c in sensor if len(c.misread) == 1]
    stated = [c for c in out if not c.misread]
    print(
        f"sensor truths: {len(sensor)} cases; right first {sum(c.first in c.right for c in sensor)}, confident and "
        f"right {sum(c.confident and c.first in c.right for c in sensor)}, no significant gap "
        f"{sum(c.kind == 'no significant gap' for c in sensor)}; the records chain named the misread channel alone in "
        f"{sum(c.misread_named for c in one)} and among its suspects in {sum(c.misread_suspected for c in one)} of "
        f"{len(one)} with one; a channel noted in "
        f"{sum(bool(c.sensor_suspects) for c in stated)} of {len(stated)} cases whose channels read as stated"
    )
    beside = [c for c in out if c.truth in REVERSED_BESIDE]
    if beside:
        print(
            f"a reversed channel beside a physical effect: {len(beside)} cases; right first "
            f"{sum(c.first in c.right for c in beside)}, confident and right "
            f"{sum(c.confident and c.first in c.right for c in beside)}, a tie "
            f"{sum(c.kind == 'tie' for c in beside)}, not explained {sum(c.kind == 'not explained' for c in beside)}, "
            f"no significant gap {sum(c.kind == 'no significant gap' for c in beside)}; the records chain named the "
            f"reversed channel alone in {sum(c.misread_named for c in beside)} and among its suspects in "
            f"{sum(c.misread_suspected for c in beside)}"
        )
    return out


if __name__ == "__main__":
    import argparse

    parser = argparse.ArgumentParser(prog="python -m benchmarks.records_blind", description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=1, help="seeds per machine and truth")
    parser.add_argument("--first-seed", type=int, default=0)
    parser.add_argument("--machines", nargs="+", choices=blind.MACHINES, default=list(blind.MACHINES))
    parser.add_argument("--level", type=float, default=None, help="a second level at this many times the force")
    args = parser.parse_args()
    if args.seeds < 1 or args.first_seed < 0:
        parser.error("--seeds must be at least 1 and --first-seed at least 0")
    if args.level is not None and not 0 < args.level < 100:
        parser.error("--level must be a force ratio between 0 and 100")
    study(args.seeds, args.first_seed, tuple(args.machines), args.level)
