"""The support's motion that a tie names as its separating measurement (candidates.separate), checked against the
hidden support of blind cases: for each support truth (a frame on ground springs, a slab on pads) on every shipped
machine, six modes with shapes, the fitted support candidate's predicted motion of the support below an isolator
over the machine's above it (CandidateModel.support_motion, with its first-order standard deviation,
fitting.predictive_std) at the mode a report would name, against the same ratio of the hidden support's own
modes (the blind truth's numpy model and kinematics, apart from the engine).

``python -m benchmarks.separation [--seeds 600 605]`` (5 seeds: 60 cases, about two minutes)."""

from __future__ import annotations

import argparse

import numpy as np

from mountid.diagnosis import campaign
from mountid.diagnosis.candidates import diagnose_effects
from mountid.diagnosis.fitting import predictive_std
from mountid.machine import Machine
from mountid.validation import blind, blind_truth

SUPPORT_TRUTHS = ("support_frame", "foundation")


def hidden_support_motion(seed: int, effect: str, machine: str) -> np.ndarray:
    """Per mode (the machine's order), the hidden support's largest motion at an isolator's foot over the
    machine's largest at an isolator, from the truth's own modes (12 coordinates: body, then support about its
    own origin: the feet's centre for the slab, the machine's origin for the frame)."""
    _, truth = blind.make_case(seed, effect, machine=machine)
    tm = blind_truth.TruthMachine(machine)
    _, _, modes = blind_truth.labelled_modes(tm, Machine.resolve(machine), truth)
    values = {**tm.nominal, **truth.known, **truth.unknowns}
    points = [i.point for i in tm.isolators(values)]
    origin = np.mean(points, axis=0) if effect == "foundation" else np.zeros(3)
    body = np.array([[np.linalg.norm(blind_truth._jac(r) @ modes[:6, j]) for r in points] for j in range(6)])
    below = np.array([[np.linalg.norm(blind_truth._jac(r - origin) @ modes[6:, j]) for r in points] for j in range(6)])
    return below.max(axis=1) / body.max(axis=1)


def check(seeds: range) -> None:
    print("machine      truth          seed  mode     hidden  predicted +- sd      z  in tie  named")
    z = []
    for machine in blind.MACHINES:
        for effect in SUPPORT_TRUTHS:
            for seed in seeds:
                data, _ = blind.make_case(seed, effect, machine=machine)
                report = diagnose_effects(campaign.parse(data))
                fit = {f.effect: f for f in report.ranked}.get("foundation")
                if fit is None or fit.state is None:
                    continue
                model = fit.state.model
                labels = tuple(model.mod.MODES)
                predicted = model.support_motion(fit.state.theta, labels)
                sd = predictive_std(fit, lambda x, model=model, labels=labels: model.support_motion(x, labels))
                k = int(np.argmax(predicted / np.where(sd > 0, sd, np.inf)))  # the mode a report names
                hidden = hidden_support_motion(seed, effect, machine)[k]
                z.append((predicted[k] - hidden) / sd[k])
                named = sum("support below" in line for line in report.separation)
                print(
                    f"{machine:12s} {effect:13s} {seed:5d}  {labels[k]:6s} {hidden:8.2%} {predicted[k]:8.2%} +- "
                    f"{sd[k]:6.2%} {z[-1]:+6.2f}  {'foundation' in report.tie!s:6s} {named:5d}"
                )
    z = np.abs(np.array(z))
    print(
        f"{len(z)} cases: within 2 standard deviations in {np.sum(z <= 2)} ({np.mean(z <= 2):.0%}), median |z| "
        f"{np.median(z):.2f} (a calibrated Gaussian: 95 %, 0.67)"
    )


if __name__ == "__main__":
    parser = argparse.ArgumentParser(prog="python -m benchmarks.separation", description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs=2, default=(600, 605), help="first and last+1 seed")
    args = parser.parse_args()
    check(range(*args.seeds))
