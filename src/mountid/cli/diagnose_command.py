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
    figure = None
    if not args.no_figure:
        from mountid.report.figures import figure_file

        figure = args.figure or f"{Path(args.campaign).stem}-diagnosis.png"
        writable(figure, "--figure")
        figure_file(figure, "--figure")  # before the diagnosis: a name matplotlib cannot write fails at once
    diagnosis = diagnose(campaign)
    if figure is not None:
        from mountid.report.figures import diagnosis_figure

        diagnosis_figure(diagnosis, figure, title=campaign.name or Path(args.campaign).stem)
    if args.json:
        print_json({**diagnosis.to_dict(), "figure": figure})
        return
    print_diagnosis(diagnosis, campaign.name or args.campaign, figure)
