"""Gap diagnosis benchmarks (issue 4): one diagnosis with every candidate on a six-mode campaign (target
< 5 s), and the blind validation over 200 synthetic campaigns (targets: top-1 >= 80 % on identifiable
cases, truth inside the reported tie >= 95 %, median held-out gap reduction >= 70 %, no confident verdict
without an injected effect; the whole run < 10 minutes on 2 cores)."""

from __future__ import annotations

import time

from mountid.diagnosis import campaign, fitting
from mountid.diagnosis.gap import diagnose
from mountid.validation import blind

CASES = ((1, "drive_belt"), (2, "cog_height"), (3, "none"))


def _per_diagnosis() -> float:
    t = time.perf_counter()
    for seed, effect in CASES:
        diagnose(campaign.parse(blind.make_case(seed, effect)[0]))
    return (time.perf_counter() - t) / len(CASES)


def speed() -> None:
    """One diagnosis with the analytic Jacobian, and the same diagnoses with every Jacobian taken by forward
    differences (what the fits did before the engine emitted the effect derivatives), in the same run."""
    data, _ = blind.make_case(1, "drive_belt")
    diagnose(campaign.parse(data))  # warm-up: imports, generated module
    per = _per_diagnosis()
    analytic = fitting.jacobian
    fitting.jacobian = lambda model, data, theta: None  # every point takes the difference fallback
    try:
        before = _per_diagnosis()
    finally:
        fitting.jacobian = analytic
    print(
        f"diagnosis with all {len(blind.CATALOGUE)} candidates, six modes with shapes: "
        f"{per:.2f} s with analytic derivatives, {before:.2f} s with finite differences "
        f"({before / per:.1f}x; target < 5 s)"
    )


def validation(n: int = 96, workers: int = 2, kinds: tuple[str, ...] = blind.CAMPAIGN_KINDS) -> None:
    """n blind cases per campaign kind (six of each truth at n = 96), scored per kind, through dask."""
    t = time.perf_counter()
    results = blind.run(n, workers=workers, kinds=kinds)
    elapsed = time.perf_counter() - t
    met = []
    for kind in kinds:
        score = blind.score([r for r in results if r.campaign == kind])
        print(score.text())
        met.append(score.targets_met)
        print(f"targets for campaigns measuring {kind}: {'met' if score.targets_met else 'NOT met'}")
    per = elapsed / len(results)
    print(
        f"blind benchmark: {len(results)} cases in {elapsed:.0f} s on {workers} processes through dask, "
        f"{per:.2f} s per case: 1000 cases would take {1000 * per / 60:.1f} min (target < 10 min)"
    )
