"""The diagnose command: a measurement campaign to a gap diagnosis."""

from __future__ import annotations

import argparse
from pathlib import Path

from mountid.cli.arguments import print_json, writable
from mountid.report.text import print_diagnosis


def cmd_diagnose(args: argparse.Namespace) -> None:
    from mountid.diagnosis.campaign import load
    from mountid.diagnosis.gap import diagnose

    campaign = load(args.campaign)
    diagnosis = diagnose(campaign)
    report, effects = diagnosis.where, diagnosis.effects
    figure = None
    if not args.no_figure:
        from mountid.report.figures import diagnosis_figure

        figure = args.figure or f"{Path(args.campaign).stem}-diagnosis.png"
        writable(figure, "--figure")
        diagnosis_figure(diagnosis, figure, title=campaign.name or Path(args.campaign).stem)
    residuals = [
        {
            "mode": r.label,
            "measured": r.measured,
            "predicted": r.predicted,
            "residual": r.residual,
            "uncertainty": r.uncertainty,
            "z": r.z,
            "significant": r.significant,
            "held_out": r.held_out,
        }
        for r in report.residuals
    ]
    localisation = [
        {
            "matrix": loc.matrix,
            "entries": [list(e) for e in loc.entries],
            "change": loc.change,
            "unit": loc.unit,
            "explained": loc.explained,
            "text": loc.describe(),
        }
        for loc in report.localisation
    ]
    if args.json:
        print_json(
            {
                "campaign": campaign.name,
                "machine": campaign.machine.name,
                "parameters": report.parameters,
                "parameter_std": report.parameter_std,
                "residuals": residuals,
                "sensitivities": report.sensitivities,
                "localisation": localisation,
                "broken_symmetry": report.broken_symmetry,
                "isolator_force_residual": [
                    {"isolator": f.isolator, "stiffness_change": f.change, "std": f.std} for f in diagnosis.isolators
                ],
                "modal_force_residual": diagnosis.force_residual,
                "nominal": effects.nominal.to_json(),
                "candidates": [f.to_json() for f in effects.ranked],
                "gap": diagnosis.gap_table(),
                "p_value": effects.p_value,
                "significant": effects.significant,
                "tie": effects.tie,
                "separation": effects.separation,
                "confident": effects.confident,
                "verdict": diagnosis.verdict,
                "where_verdict": report.verdict,
                "notes": [*report.notes, *effects.notes],
                "figure": figure,
            }
        )
        return
    print_diagnosis(diagnosis, campaign.name or args.campaign, figure)
