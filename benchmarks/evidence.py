"""The diagnosis's Laplace evidence against nested sampling (dynesty) on a few blind cases: how far the one-point
Gaussian approximation (mountid.diagnosis.fitting.log_evidence) is from the integral it approximates, per
candidate. Not part of ``make bench`` (2-11 minutes per candidate): ``make bench-evidence`` or
``python -m benchmarks.evidence [--live N] [SEED:TRUTH:KIND:MACHINE:CANDIDATE,CANDIDATE ...]``.

The integral is the one the Laplace evidence approximates, with the same constant left out: the likelihood
exp(-chi^2 / 2) over the uniform prior of every fitted parameter, the effect parameters over their plausible
range (log-uniform where positive: CandidateModel.plausible_box), each unknown stiffness over a factor 100
(fitting.UNKNOWN_PRIOR_WIDTH) centred on the nominal model's fit of the same data (one box for every candidate),
and a refining parameter held at its start with prior probability fitting.REFINED_AT_START. Nested sampling
finds the mass it explores; a narrow mode it never enters is missing from its estimate, which is then a lower
bound: the bench says so where its best point fits worse than the least-squares fit did."""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from mountid.diagnosis import campaign, fitting
from mountid.diagnosis.candidate_model import CandidateModel
from mountid.diagnosis.strategies import strategy
from mountid.effects import EFFECTS
from mountid.validation import blind

CASES = (
    # a stiff frame on ground springs that rotational stiffness is named first for (kid300, seed 168)
    "168:support_frame:shapes:kid300:rotational_stiffness,foundation",
    # rotational stiffness itself, the support second
    "114:rotational_stiffness:shapes:kid300:rotational_stiffness,foundation",
    # stiffening rubber on six frequencies: three candidates that fit it exactly
    "27:frequency_dependent:frequencies:kid300:rotational_stiffness,frequency_dependent,foundation",
    # a motor on the axis that the support is named first for
    "161:added_mass:shapes:kid300:added_mass,foundation",
)

MISSED_CHI2 = 2.0
"""Nested sampling missed the fit's mode when its best point's chi^2 exceeds the fit's by more than this."""


def nested_evidence(model: CandidateModel, data: fitting.Data, centre: np.ndarray, live: int) -> dict[str, float]:
    """log of the integral of exp(-chi^2/2) over the prior (module docstring) by dynesty's nested sampling
    (``live`` live points, slice sampling, a fixed seed): the estimate, its standard error, the best chi^2 it
    visited and its likelihood calls."""
    import dynesty  # the bench's own dependency (mountid[dev])

    lo, hi = fitting.prior_box(model, centre)
    held = model.held_first()
    start = model.start()[0]

    def chi2(x: np.ndarray) -> float:
        try:
            r = data.residuals(model.predict(x))
        except (np.linalg.LinAlgError, ValueError):
            return math.inf
        return float(r @ r) if np.isfinite(r).all() else math.inf

    parts = {}
    for mode in ("free", "held") if len(held) else ("free",):
        free = np.array([i for i in range(len(lo)) if mode == "free" or i not in held])

        def full(t: np.ndarray, free: np.ndarray = free) -> np.ndarray:
            x = start.copy()
            x[free] = t
            return x

        sampler = dynesty.NestedSampler(
            lambda t, full=full: max(-0.5 * chi2(full(t)), -1e100),
            lambda u, free=free: lo[free] + u * (hi[free] - lo[free]),
            len(free),
            nlive=live,
            bound="multi",
            sample="rslice",
            rstate=np.random.default_rng(1),
        )
        sampler.run_nested(dlogz=0.1, print_progress=False)
        r = sampler.results
        parts[mode] = (float(r.logz[-1]), float(r.logzerr[-1]), float(-2 * np.max(r.logl)), int(np.sum(r.ncall)))
    if "held" in parts:
        log_z = float(
            np.logaddexp(
                math.log(1 - fitting.REFINED_AT_START) + parts["free"][0],
                math.log(fitting.REFINED_AT_START) + parts["held"][0],
            )
        )
    else:
        log_z = parts["free"][0]
    return {
        "log_z": log_z,
        "error": max(e for _, e, _, _ in parts.values()),
        "best_chi2": min(c for _, _, c, _ in parts.values()),
        "calls": sum(n for *_, n in parts.values()),
    }


def parse_case(spec: str) -> tuple[str, campaign.Campaign, list[str]]:
    """``SEED:TRUTH:KIND:MACHINE:CANDIDATE,...`` checked (a ValueError names what is wrong): a title, the blind
    case's campaign and the candidates."""
    fields = spec.split(":")
    if len(fields) != 5:
        raise ValueError(f"case {spec!r}: expected SEED:TRUTH:KIND:MACHINE:CANDIDATE,... (five fields)")
    seed, truth, kind, machine, names = fields
    if not seed.isdigit():
        raise ValueError(f"case {spec!r}: the seed must be a non-negative integer, got {seed!r}")
    if truth not in blind.TRUTHS:
        raise ValueError(f"case {spec!r}: truth {truth!r} is not one of {', '.join(blind.TRUTHS)}")
    if kind not in blind.CAMPAIGN_KINDS:
        raise ValueError(f"case {spec!r}: kind {kind!r} is not one of {', '.join(blind.CAMPAIGN_KINDS)}")
    if machine not in blind.MACHINES:
        raise ValueError(f"case {spec!r}: machine {machine!r} is not one of {', '.join(blind.MACHINES)}")
    candidates = names.split(",")
    unknown = [n for n in candidates if n not in EFFECTS]
    if unknown:
        raise ValueError(f"case {spec!r}: {', '.join(unknown)} not in the catalogue ({', '.join(EFFECTS)})")
    camp = campaign.parse(blind.make_case(int(seed), truth, kind=kind, machine=machine)[0])
    placed = [n for n in candidates if strategy(EFFECTS[n]).variants(camp)]
    if placed:
        raise ValueError(
            f"case {spec!r}: {', '.join(placed)} acts at one isolator or channel (its evidence is a mean over them), "
            "which this check does not integrate"
        )
    return f"{machine} seed {seed}, {truth}, {kind}:", camp, candidates


def check(title: str, camp: campaign.Campaign, names: list[str], live: int) -> list[str]:
    """One case (parse_case): a line per candidate."""
    nominal = fitting.fit_candidate(camp, None)
    centre = nominal.theta[: len(nominal.state.model.unknown)]
    lines = [title]
    for name in names:
        fit = fitting.fit_candidate(camp, EFFECTS[name])
        model = CandidateModel(camp, EFFECTS[name])
        t = time.perf_counter()
        ns = nested_evidence(model, fitting.Data(camp, model.length), centre, live)
        missed = ns["best_chi2"] > fit.chi2 + MISSED_CHI2
        lines.append(
            f"  {name:22s} chi^2 {fit.chi2:7.2f}  Laplace {fit.log_evidence:8.2f}  nested {ns['log_z']:8.2f} "
            f"+- {ns['error']:.2f}  (nested - Laplace {ns['log_z'] - fit.log_evidence:+6.2f}; best chi^2 visited "
            f"{ns['best_chi2']:.2f}{', the sampler missed the fit: a lower bound' if missed else ''}; "
            f"{ns['calls']} calls, {time.perf_counter() - t:.0f} s)"
        )
    return lines


if __name__ == "__main__":
    parser = argparse.ArgumentParser(prog="python -m benchmarks.evidence", description=__doc__.splitlines()[0])
    parser.add_argument("cases", nargs="*", default=list(CASES), help="SEED:TRUTH:KIND:MACHINE:CANDIDATE,...")
    parser.add_argument("--live", type=int, default=400, help="live points of the nested sampling")
    args = parser.parse_args()
    if args.live < 50:
        parser.error("--live must be at least 50")
    try:
        cases = [parse_case(case) for case in args.cases]
    except ValueError as err:
        parser.error(str(err))
    for title, camp, names in cases:
        print("\n".join(check(title, camp, names, args.live)), flush=True)
