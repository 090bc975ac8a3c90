"""The one error type the user sees: a bad input, named, with the reason."""

from __future__ import annotations

import numbers
from pathlib import Path


class InputError(ValueError):
    """Bad input from a user: names the offending parameter or entry and says why.

    The command line prints ``str(error)`` as one line on stderr and exits with code 2.
    """

    def __init__(self, parameter: str, reason: str) -> None:
        self.parameter = parameter
        self.reason = reason
        super().__init__(f"{parameter}: {reason}")


class NoModeFound(InputError):
    """A record in which the records chain found no mode it could label (no pole, or only poles of modes it could
    not separate): a campaign of several records leaves that one out with a note."""


class DescriptionError(InputError):
    """A machine description that is malformed or contradicts its declared symmetry."""


def existing_file(path: str | Path, parameter: str) -> Path:
    """``path`` as a Path where it names a regular file; else an InputError naming ``parameter`` that says
    what is there instead: nothing, a directory, or something that is not a regular file (a device, a pipe)."""
    path = Path(path)
    if path.is_file():
        return path
    if not path.exists():
        raise InputError(parameter, f"no such file: {path}")
    what = "a directory" if path.is_dir() else "not a regular file (a device or a pipe)"
    raise InputError(parameter, f"{path} is {what}, not a file to read")


def real_number(value: object, parameter: str) -> float:
    """``value`` as a float where it is a real number (int, float, a numpy scalar); else an InputError naming
    ``parameter``: a string, None, a bool or an array is not taken for a number (float() read "4e5" and True).
    A 0-d array (what numpy's reductions of arrays may give) is its one value."""
    if getattr(value, "ndim", None) == 0 and hasattr(value, "item"):
        value = value.item()
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise InputError(parameter, f"must be a real number, got {value!r} ({type(value).__name__})")
    return float(value)
