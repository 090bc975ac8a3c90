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
    figure = None
    if not args.no_figure:
        from mountid.report.figures import diagnosis_figure

        figure = args.figure or f"{Path(args.campaign).stem}-diagnosis.png"
        writable(figure, "--figure")
        diagnosis_figure(diagnosis, figure, title=campaign.name or Path(args.campaign).stem)
    if args.json:
        print_json({**diagnosis.to_dict(), "figure": figure})
        return
    print_diagnosis(diagnosis, campaign.name or args.campaign, figure)
