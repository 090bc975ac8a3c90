"""Gap diagnosis benchmarks (issue 4): one diagnosis with every candidate on a six-mode campaign (target
< 5 s), and the blind validation over 200 synthetic campaigns (targets: top-1 >= 80 % on identifiable
cases, truth inside the reported tie >= 95 %, median held-out gap reduction >= 70 %, no confident verdict
without an injected effect; the whole run < 10 minutes on 2 cores)."""

from __future__ import annotations

import time

from mountid.diagnosis import campaign
from mountid.diagnosis.gap import diagnose
from mountid.validation import blind


def speed() -> None:
    data, _ = blind.make_case(1, "drive_belt")
    c = campaign.parse(data)
    diagnose(c)  # warm-up: imports, generated module
    t = time.perf_counter()
    for seed, effect in ((1, "drive_belt"), (2, "cog_height"), (3, "none")):
        diagnose(campaign.parse(blind.make_case(seed, effect)[0]))
    per = (time.perf_counter() - t) / 3
    print(
        f"diagnosis with all {len(blind.EFFECT_NAMES) - 1} candidates, six modes with shapes: "
        f"{per:.2f} s (target < 5 s)"
    )


def validation(n: int = 200, workers: int = 2) -> None:
    t = time.perf_counter()
    results = blind.run(n, workers=workers)
    elapsed = time.perf_counter() - t
    score = blind.score(results)
    print(score.text())
    print(
        f"blind benchmark: {n} cases in {elapsed:.0f} s on {workers} processes (target < 600 s); "
        f"targets {'met' if score.targets_met else 'NOT met'}"
    )
