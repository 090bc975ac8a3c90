"""How far the diagnosis's verdicts follow rounding: each blind campaign diagnosed as made and again with every
measured frequency multiplied by 1 + 4 eps u (u uniform in [-1, 1], eps the double's machine epsilon: a few units
in the last place, far below any measurement's resolution). A verdict that changes its kind or first candidate,
or its first candidate's stated probability by 0.02 or more, rests on where a fit stopped, not on the data.

``python -m benchmarks.rounding [--cases 23] [--first-seed 0]`` (23 cases per machine and campaign kind, one of
each truth, 414 cases: about eight minutes on two processes). Not part of ``make bench``."""

from __future__ import annotations

import argparse
import math
import time
from collections import Counter

import numpy as np

from mountid.diagnosis import campaign
from mountid.diagnosis.candidates import diagnose_effects
from mountid.validation import blind

ULPS = 4
"""The perturbation's half-width in units of the machine epsilon (relative)."""

MOVED = 0.02
"""A stated probability that moves this much or more under rounding is counted as moved."""


def verdicts(seed: int, truth: str, kind: str, machine: str) -> tuple[tuple, tuple]:
    """(kind, first candidate, its probability) of the campaign as made and as perturbed (the perturbation drawn
    from ``seed``)."""
    data, _ = blind.make_case(seed, truth, kind=kind, machine=machine)
    rng = np.random.default_rng(seed)
    eps = ULPS * np.finfo(float).eps
    moved = {
        label: {**mode, "frequency": mode["frequency"] * (1 + eps * rng.uniform(-1, 1))}
        for label, mode in data["modes"].items()
    }
    out = []
    for modes in (data["modes"], moved):
        report = diagnose_effects(campaign.parse({**data, "modes": modes}))
        best = report.best
        out.append((report.kind, best.effect if best else None, best.probability if best else math.nan))
    return out[0], out[1]


def run(n: int, first_seed: int, workers: int = 2) -> None:
    """n cases per machine and campaign kind (blind.cases) through dask's local processes; prints the cases whose
    verdict moved and the counts per machine."""
    import dask

    todo = blind.cases(n, first_seed, blind.CAMPAIGN_KINDS, blind.MACHINES)
    t = time.perf_counter()
    tasks = [dask.delayed(verdicts, pure=True)(*c) for c in todo]
    results = dask.compute(*tasks, scheduler="processes", num_workers=workers, chunksize=1)
    elapsed = time.perf_counter() - t
    changed, moved, cases = Counter(), Counter(), Counter()
    print(f"{'seed':>5s} {'truth':32s} {'campaign':11s} {'machine':11s}  as made -> rounded")
    for (seed, truth, kind, machine), (a, b) in zip(todo, results, strict=True):
        cases[machine] += 1
        shift = abs(a[2] - b[2]) if a[1] == b[1] and math.isfinite(a[2]) else 0.0
        if a[:2] != b[:2]:
            changed[machine] += 1
        elif shift >= MOVED:
            moved[machine] += 1
        else:
            continue
        print(
            f"{seed:5d} {truth:32s} {kind:11s} {machine:11s}  {a[0]} ({a[1]} {a[2]:.3f}) -> {b[0]} ({b[1]} {b[2]:.3f})"
        )
    print(
        f"{len(todo)} cases in {elapsed:.0f} s; under a rounding of {ULPS} eps: kind or first candidate changed in "
        f"{sum(changed.values())}, the first candidate's probability moved by {MOVED} or more in "
        f"{sum(moved.values())}; per machine (changed, moved, of): "
        + ", ".join(f"{m} {changed[m]}, {moved[m]}, {cases[m]}" for m in blind.MACHINES)
    )


if __name__ == "__main__":
    parser = argparse.ArgumentParser(prog="python -m benchmarks.rounding", description=__doc__.splitlines()[0])
    parser.add_argument("--cases", type=int, default=23, help="cases per machine and campaign kind")
    parser.add_argument("--first-seed", type=int, default=0, help="seed of the first case")
    args = parser.parse_args()
    if args.cases < 1 or args.first_seed < 0:
        parser.error("--cases must be at least 1 and --first-seed at least 0")
    run(args.cases, args.first_seed)
