"""The generated source laid out by ruff's formatter (the same formatter and settings as the project's own
code), so a generated module reads like a hand-written one: long dictionaries and expressions wrapped,
consistent quotes. The formatter is pinned (the ``generate`` extra) because its output changes between
releases and generated/ must be byte-for-byte reproducible."""

from __future__ import annotations

import functools
import subprocess
import sys

RUFF_VERSION = "0.8.6"
"""The ruff release generation is pinned to."""

_COMMAND = (sys.executable, "-m", "ruff")
_OPTIONS = ("--isolated", "--line-length", "120", "--target-version", "py310")


@functools.cache
def _check_version() -> None:
    try:
        found = subprocess.run([*_COMMAND, "--version"], capture_output=True, text=True, check=True).stdout.split()[-1]
    except (OSError, subprocess.CalledProcessError, IndexError) as exc:  # not installed: the extra's name
        raise ModuleNotFoundError(f"generation formats with ruff {RUFF_VERSION}", name="ruff") from exc
    if found != RUFF_VERSION:
        raise RuntimeError(
            f"generation is pinned to ruff {RUFF_VERSION} (found {found}): other releases format differently"
        )


def format_source(source: str) -> str:
    """``source`` formatted by ruff (pinned release, the project's line length)."""
    _check_version()
    done = subprocess.run(
        [*_COMMAND, "format", *_OPTIONS, "--stdin-filename", "generated.py", "-"],
        input=source,
        capture_output=True,
        text=True,
    )
    if done.returncode != 0:
        raise RuntimeError(f"ruff could not format the generated source: {done.stderr.strip()}")
    return done.stdout
