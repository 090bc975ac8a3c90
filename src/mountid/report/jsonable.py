"""JSON output: the one place where non-finite numbers become null (JSON has no NaN)."""

from __future__ import annotations

import json
import math


def jsonable(obj: object) -> object:
    """NaN and infinities (a quantity that does not exist, e.g. a held-out error where leaving the mode out
    leaves a parameter undetermined) as null: JSON has no NaN."""
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    return obj


def dumps(obj: object) -> str:
    """``obj`` as indented JSON text, non-finite numbers as null."""
    return json.dumps(jsonable(obj), indent=2, allow_nan=False)
