"""Shared helpers: the shipped generated modules and random physical parameters."""

from __future__ import annotations

import importlib

import numpy as np
import pytest
from hypothesis import strategies as st

MACHINES = ("kid300", "rectangular", "screen6")


def generated(name: str):
    return importlib.import_module(f"mountid.generated.{name}")


def call(module, function: str, values: dict):
    """Call a generated function with its arguments picked by name from ``values`` (module.ARGUMENTS)."""
    return getattr(module, function)(*(values[a] for a in module.ARGUMENTS[function]))


def log_uniform(lo: float, hi: float) -> st.SearchStrategy[float]:
    """Floats spread evenly over decades between lo and hi."""
    return st.floats(np.log10(lo), np.log10(hi)).map(lambda e: float(10.0**e))


# Ranges per kind: several decades each, physical signs.
RANGES = {
    "mass": (10.0, 1e5),
    "inertia": (1.0, 1e5),
    "length": (0.02, 5.0),
    "stiffness": (1e3, 1e8),
    "damping": (10.0, 1e5),
}


@st.composite
def parameters(draw, module, names=None):
    """Random values for a generated module's parameters (angles within +-40 degrees)."""
    out = {}
    for name in names or module.FORWARD_ARGUMENTS:
        kind = module.PARAMETERS[name]["kind"]
        if kind == "angle":
            out[name] = draw(st.floats(-0.7, 0.7))
        else:
            out[name] = draw(log_uniform(*RANGES[kind]))
    return out


@pytest.fixture(params=MACHINES)
def module(request):
    return generated(request.param)
