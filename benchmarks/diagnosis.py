"""Gap diagnosis benchmarks (issue 12): one diagnosis with every candidate on a six-mode campaign with shapes
(target < 1 s), and the blind validation over every shipped machine and campaign kind, scored per machine and
kind and pooled per kind against the issue's targets (in-catalogue identifiable cases: top-1 >= 90 %; truth
inside the reported tie >= 98 %; confident and wrong <= 1 % (2 % with frequencies only), 0 without an effect
and outside the catalogue; outside the catalogue 'not explained' or a tie >= 90 %; calibration error <= 0.05;
held-out gap reduction median >= 80 %), through dask (1000 cases < 10 minutes on 2 cores).

The blind cases use seeds from 0 (``--first-seed``); DiagnosisSettings.evidence_temperature was calibrated on
seeds 5000-5039, 6000-6039 and 7000-7099. The diagnosis was developed looking at the results of seeds 0-263;
seeds from 264 on are held out from that. ``python -m benchmarks.diagnosis --cases N --first-seed S``
(``make bench-blind BLIND_CASES=N BLIND_FIRST_SEED=S``) runs these alone with N cases per machine and kind, then
the studies beside the benchmark's cycle (``--beside-cases``, 12 per machine and kind by default, 0 for none): a
reversed channel beside a physical effect (blind_truth.REVERSED_BESIDE), truths outside the catalogue
(blind_truth.OUTSIDE_BESIDE, with shapes), and truths represented by a candidate added since the cycle was fixed
(blind_truth.REPRESENTED_BESIDE: a tilted isolator), from the same first seed."""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any

import numpy as np
import scipy.linalg

from mountid.diagnosis import campaign, fitting
from mountid.diagnosis.gap import diagnose
from mountid.errors import InputError
from mountid.machine import Machine, description_file
from mountid.validation import blind, blind_truth

CASES = ((1, "drive_belt"), (2, "cog_height"), (3, "none"))

FIGURE = Path(__file__).resolve().parents[1] / "out" / "bench" / "reliability.png"
"""Where the validation's reliability diagram goes (out/ is not tracked)."""


def _per_diagnosis(machine: str = "kid300") -> float:
    """Mean time [s] of the full diagnosis (gap report and candidates) of the CASES on ``machine``."""
    t = time.perf_counter()
    for seed, effect in CASES:
        diagnose(campaign.parse(blind.make_case(seed, effect, machine=machine)[0]))
    return (time.perf_counter() - t) / len(CASES)


def _warm_up(machine: str) -> None:
    """Imports and the generated module, on a campaign none of the CASES repeats (nothing it computes is kept
    for them)."""
    diagnose(campaign.parse(blind.make_case(0, "none", machine=machine)[0]))


HOST_UNIT_SOLVES = 2000
"""Eigenproblems in one host unit (host_unit)."""


def host_unit(repeats: int = 5) -> float:
    """The host's speed, measured in the same run as what it is compared with: the time [s] of a fixed workload
    of the diagnosis's kind that no change of mountid touches, HOST_UNIT_SOLVES solutions of one generalised
    6 x 6 symmetric eigenproblem (scipy.linalg.eigh, a fixed stiffness and mass matrix) with a few array
    operations each, the best of ``repeats``. A time in host units is the code's cost apart from the host's (the
    same code took five times as long on one host as on another: docs/validation.md, "A slower host")."""
    rng = np.random.default_rng(0)
    a = rng.standard_normal((6, 6))
    stiffness = a @ a.T + 6 * np.eye(6)
    mass = np.diag(np.linspace(1.0, 2.0, 6))
    best = math.inf
    for _ in range(repeats):
        t = time.perf_counter()
        for _ in range(HOST_UNIT_SOLVES):
            lam, vec = scipy.linalg.eigh(stiffness, mass)
            np.sqrt(np.abs(lam)) @ np.abs(vec).max(axis=0)
        best = min(best, time.perf_counter() - t)
    return best


def speed(machines: tuple[str, ...] = blind.MACHINES) -> None:
    """One diagnosis with the analytic Jacobian, and the same diagnoses with every Jacobian taken by forward
    differences (what the fits did before the engine emitted the effect derivatives), in the same run; then one
    diagnosis on every machine of ``machines`` (the shipped ones); each also in host units (host_unit, measured
    before and after them: the host's own drift during the run shows as their difference)."""
    unit = host_unit()
    _warm_up("kid300")
    per = _per_diagnosis()
    analytic = fitting.jacobian
    fitting.jacobian = lambda model, data, theta: None  # every point takes the difference fallback
    try:
        before = _per_diagnosis()
    finally:
        fitting.jacobian = analytic
    print(
        f"diagnosis with all {len(blind.CATALOGUE)} candidates, six modes with shapes and a 12-channel layout: "
        f"{per:.2f} s with analytic derivatives (target < 1 s), {before:.2f} s with finite differences "
        f"({before / per:.1f}x)"
    )
    times = {"kid300": per}
    for machine in machines:
        if machine not in times:
            _warm_up(machine)
            times[machine] = _per_diagnosis(machine)
    print(
        "one diagnosis, six modes with shapes, per machine (target < 1 s): "
        + ", ".join(f"{_name(m)} {t:.2f} s" for m, t in times.items())
        + f"; over 1 s: {', '.join(_name(m) for m, t in times.items() if t >= 1) or 'none'}"
    )
    after = host_unit()
    print(
        f"host unit ({HOST_UNIT_SOLVES} solutions of a 6 x 6 eigenproblem): {unit * 1e3:.0f} ms before the diagnoses, "
        f"{after * 1e3:.0f} ms after; one diagnosis in host units: "
        + ", ".join(f"{_name(m)} {t / unit:.1f}" for m, t in times.items())
    )


HEADER = (
    f"{'machine':11s} {'campaign':11s} {'cases':>5s} {'top-1':>6s} {'in tie':>6s} {'c&w':>4s} {'c none':>6s} "
    f"{'c out':>5s} {'honest':>6s} {'calib.':>6s} {'floor':>5s} {'logloss':>7s} {'reduct.':>7s} {'tie':>4s}  targets"
)


def _name(machine: str) -> str:
    """A machine as the tables name it: a shipped one by its name, a description file by its file's stem."""
    path = description_file(machine)
    return machine if path is None else path.stem


def _refused(machine: str) -> str | None:
    """Why the benchmark refuses a machine given to --machines (None: it takes it): a name or file that is no
    machine, or a machine on which no campaign can be diagnosed (blind.undiagnosable_because)."""
    try:
        return blind.undiagnosable_because(Machine.resolve(machine))
    except InputError as err:
        return str(err)


def _row(machine: str, kind: str, s: blind.Score) -> str:
    return (
        f"{_name(machine):11s} {kind:11s} {s.n:5d} {_share(s.top1_identifiable)} {_share(s.truth_in_tie)} "
        f"{s.confident_and_wrong:4d} {s.confident_on_none:6d} {s.confident_outside:5d} {_share(s.honest_outside)} "
        f"{_cell(s.calibration_error, '6.3f')} {_cell(s.calibration_floor, '5.3f')} {_cell(s.log_loss, '7.3f')} "
        f"{_share(s.median_reduction, 7)} {_cell(s.mean_tie, '4.1f')}  "
        + ("met" if s.targets_met else "missed: " + ", ".join(s.missed()))
    )


def _cell(value: float, spec: str) -> str:
    """A number of the table in ``spec``; '-' where it was taken over no case (genset8 with frequencies only has no
    identifiable case: its top-1 is none, not nan)."""
    if math.isfinite(value):
        return f"{value:{spec}}"
    return f"{'-':>{int(spec.split('.')[0])}s}"


def _share(value: float, width: int = 6) -> str:
    """A rate of the table in percent (_cell)."""
    return _cell(value, f"{width}.1%")


def _table(
    results: list[blind.CaseResult], kinds: tuple[str, ...], machines: tuple[str, ...]
) -> dict[str, blind.Score]:
    """Print the table's head and one line per machine and kind with the pooled line of each kind; returns the
    pooled scores by kind."""
    print(HEADER)
    pooled = {}
    for kind in kinds:
        for machine in machines:
            unmeasured = blind.unmeasured_because(blind_truth.TruthMachine.of(machine), kind)
            if unmeasured:
                print(f"{_name(machine):11s} {kind:11s} no cases: {unmeasured}")
                continue
            s = blind.score([r for r in results if r.campaign == kind and r.machine == machine])
            print(_row(machine, kind, s))
        if any(r.campaign == kind for r in results):
            pooled[kind] = blind.score([r for r in results if r.campaign == kind])
            print(_row("all", kind, pooled[kind]))
    return pooled


def validation(
    n: int = 69,
    workers: int = 2,
    kinds: tuple[str, ...] = blind.CAMPAIGN_KINDS,
    machines: tuple[str, ...] = blind.MACHINES,
    first_seed: int = 0,
    figure: str | Path | None = FIGURE,
    nominal: str = "description",
    level: float | None = None,
) -> list[blind.CaseResult]:
    """n blind cases per machine and campaign kind (three of each truth at n = 69), seeds from ``first_seed``,
    through dask: one line per machine and kind, then per kind over every machine the full score (reliability
    table, confusion matrix); the reliability diagram per kind written to ``figure`` (None: not drawn).
    ``nominal``: where the fits start (blind.NOMINAL_SOURCES); ``level``: every campaign's frequencies measured
    again at this many times the force (blind.make_case)."""
    unit = host_unit()
    t = time.perf_counter()
    results = blind.run(
        n, workers=workers, first_seed=first_seed, kinds=kinds, machines=machines, nominal=nominal, level=level
    )
    if nominal != "description":
        print(f"every campaign starts from nominal values {nominal} from its measured frequencies")
    if level is not None:
        print(f"every campaign has its frequencies measured again at {level:g} times the force")
    elapsed = time.perf_counter() - t
    print("blind validation per machine and campaign kind (top-1 on identifiable cases; truth in the tie of testable")
    print("cases with a gap; c&w confident and wrong, c none on cases without an effect, c out outside the catalogue;")
    print("honest: outside the catalogue 'not explained' or a tie; calib.: calibration error; floor: the calibration")
    print("error a perfectly calibrated diagnosis shows on average at the same counts (sampling noise; pooled over")
    print("the machines, which share seeds, widened by the design effect); logloss: log loss of the same stated")
    print("probabilities, a proper score (no target: lower is better); reduct.: held-out gap reduction, median;")
    print("tie: mean size of the reported tie)")
    pooled = _table(results, kinds, machines)
    for kind in pooled:
        print(pooled[kind].text())
    per = elapsed / len(results)
    print(
        f"blind benchmark: {len(results)} cases in {elapsed:.0f} s on {workers} processes through dask, "
        f"{per:.2f} s per case: 1000 cases would take {1000 * per / 60:.1f} min (target < 10 min); "
        f"{per / unit:.1f} host units per case (host_unit: {unit * 1e3:.0f} ms before the run)"
    )
    if figure is None:
        return results
    panels = blind.reliability_panels(results)
    if not panels:
        # a run of a few cases may end without a verdict that states a probability (--cases 1)
        print("reliability diagram: not drawn, no verdict on a truth the catalogue represents states a probability")
    else:
        from mountid.report.figures import reliability_figure

        last = first_seed + n - 1
        path = reliability_figure(
            panels,
            figure,
            blind.RELIABILITY_BINS,
            f"blind validation, seeds {first_seed}-{last}, {_machines_title(machines)}: the stated probability of the "
            "first-ranked candidate against how often it is right, by what the first place rests on",
        )
        print(f"reliability diagram: {path}")
    return results


def _machines_title(machines: tuple[str, ...]) -> str:
    """How a figure's title names the machines of a run."""
    return "every shipped machine" if machines == blind.MACHINES else ", ".join(_name(m) for m in machines)


def reversed_beside(n: int = 12, **options: Any) -> list[blind.CaseResult]:
    """The study beside the benchmark's cycle: n blind cases per machine and campaign kind (three of each at
    n = 12) of a reversed channel beside a physical effect (blind_truth.REVERSED_BESIDE), one line per machine and
    kind as in :func:`validation`, the pooled line per kind and its confusion rows. Its few cases per line make
    the calibration column sampling noise (floor); the targets that count are the confident and wrong ones.
    ``options``: workers (2), kinds (every campaign kind), machines (every shipped one), first_seed (0), nominal
    ('description') and level (None), as blind.run takes them."""
    return _beside(
        tuple(blind_truth.REVERSED_BESIDE),
        "a reversed channel beside a physical effect",
        "each represented by its pair",
        n,
        **options,
    )


def outside_beside(
    n: int = 12,
    workers: int = 2,
    machines: tuple[str, ...] = blind.MACHINES,
    first_seed: int = 0,
    nominal: str = "description",
    level: float | None = None,
) -> list[blind.CaseResult]:
    """The study beside the benchmark's cycle of truths outside the catalogue (blind_truth.OUTSIDE_BESIDE: two
    misplaced channels, a scattered isolator with a turned channel, a tilted isolator with a higher centre of mass),
    n blind cases per machine with shapes (four of each truth at n = 12; without shapes a channel's slip leaves no
    gap), as :func:`reversed_beside`: the targets that count are the confident and wrong ones and 'not explained' or
    a tie where no part alone explains the noise-free data."""
    return _beside(
        blind_truth.OUTSIDE_BESIDE,
        "outside the catalogue",
        "no candidate represents them",
        n,
        workers,
        ("shapes",),
        machines,
        first_seed,
        nominal,
        level,
    )


def represented_beside(n: int = 12, **options: Any) -> list[blind.CaseResult]:
    """The study beside the benchmark's cycle of truths a candidate added since represents
    (blind_truth.REPRESENTED_BESIDE: a tilted isolator), n blind cases per machine and campaign kind, with the
    options of :func:`reversed_beside` (workers, kinds, machines, first_seed, nominal, level)."""
    return _beside(
        tuple(blind_truth.REPRESENTED_BESIDE),
        "represented by a candidate added since the cycle was fixed",
        "each by its own candidate",
        n,
        **options,
    )


def _beside(
    truths: tuple[str, ...],
    title: str,
    represented: str,
    n: int,
    workers: int = 2,
    kinds: tuple[str, ...] = blind.CAMPAIGN_KINDS,
    machines: tuple[str, ...] = blind.MACHINES,
    first_seed: int = 0,
    nominal: str = "description",
    level: float | None = None,
) -> list[blind.CaseResult]:
    """A study of ``truths`` beside the benchmark's cycle, printed under ``title`` (``represented``: by what)."""
    t = time.perf_counter()
    results = blind.run(
        n,
        workers=workers,
        first_seed=first_seed,
        kinds=kinds,
        machines=machines,
        nominal=nominal,
        truths=truths,
        level=level,
    )
    elapsed = time.perf_counter() - t
    print(f"{title} ({', '.join(truths)}; {represented}), seeds from {first_seed}, columns as above:")
    pooled = _table(results, kinds, machines)
    for kind in pooled:
        print(f"campaigns measuring {kind}, {pooled[kind].n} cases:")
        print("\n".join(pooled[kind].confusion_lines(list(truths))))
    wrong = sum(r.confident_and_wrong for r in results)
    print(f"{title}: {len(results)} cases in {elapsed:.0f} s, confident and wrong {wrong}")
    return results


if __name__ == "__main__":
    import argparse

    parser = argparse.ArgumentParser(prog="python -m benchmarks.diagnosis", description=__doc__.splitlines()[0])
    parser.add_argument("--cases", type=int, default=69, help="blind cases per machine and campaign kind")
    parser.add_argument(
        "--first-seed",
        type=int,
        default=0,
        help="seed of the first case (0: the seeds the diagnosis was developed on; 264 and above: held out)",
    )
    parser.add_argument(
        "--beside-cases",
        type=int,
        default=12,
        help="cases per machine and campaign kind of a reversed channel beside a physical effect and of a tilted "
        "isolator, and per machine of the truths outside the catalogue beside the cycle, with shapes (0: none)",
    )
    parser.add_argument("--figure", default=str(FIGURE), help="where to write the reliability diagram")
    parser.add_argument(
        "--nominal",
        choices=blind.NOMINAL_SOURCES,
        default="description",
        help="where the fits start: the description's nominal unknowns, or those identified from the measured "
        "frequencies (as for a description that gives none)",
    )
    parser.add_argument(
        "--level",
        type=float,
        default=None,
        help="measure every campaign's frequencies again at this many times the force (a second excitation "
        "level: hardening isolators stiffen by their law, every other truth's rubber by up to 10 %% per stiffness)",
    )
    parser.add_argument(
        "--machines",
        nargs="+",
        default=list(blind.MACHINES),
        help="the machines, shipped ones by name or descriptions by their .toml file (default: every shipped one)",
    )
    args = parser.parse_args()
    if args.cases < 1 or args.first_seed < 0 or args.beside_cases < 0:
        parser.error("--cases must be at least 1, --first-seed and --beside-cases at least 0")
    if args.level is not None and not 0 < args.level < 10:
        parser.error("--level must lie between 0 and 10 (times the campaign's force)")
    machines = tuple(args.machines)
    for machine in machines:  # stops here, not in a worker nor after the others' cases
        refused = _refused(machine)
        if refused:
            parser.error(f"--machines: {refused}")
    speed(machines)
    common = {"first_seed": args.first_seed, "nominal": args.nominal, "level": args.level, "machines": machines}
    validation(args.cases, figure=args.figure, **common)
    if args.beside_cases:
        reversed_beside(args.beside_cases, **common)
        outside_beside(args.beside_cases, **common)
        represented_beside(args.beside_cases, **common)
