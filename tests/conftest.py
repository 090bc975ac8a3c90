"""Shared helpers: the shipped generated modules and random physical parameters."""

from __future__ import annotations

import importlib
import os
import re
import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, settings
from hypothesis import strategies as st

# The gating profile (make test, .ci/run): derandomized, no example database, so every run draws the same
# examples and CI passes or fails for a reason. `make fuzz` explores with random seeds and many more
# examples (not part of CI); every find is pinned as an explicit example in the test it broke.
settings.register_profile("ci", derandomize=True, database=None, deadline=None, print_blob=True)
settings.register_profile(
    "fuzz",
    derandomize=False,
    deadline=None,
    print_blob=True,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much],
)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))

# Modules generated from description files during the tests are cached in a folder of this run, not in the
# user's cache.
os.environ["MOUNTID_CACHE"] = tempfile.mkdtemp(prefix="mountid-cache-")

FUZZ_FACTOR = 20 if settings.default.derandomize is False else 1
"""How many times more examples each property draws under `make fuzz`."""


def budget(n: int) -> int:
    """max_examples of a property test: ``n`` in the gating run, FUZZ_FACTOR times more under `make fuzz`."""
    return n * FUZZ_FACTOR


MACHINES = ("kid300", "kid300axes", "rectangular", "screen6", "genset8", "skid1plane")
CLOSED_FORM_MACHINES = ("kid300", "kid300axes", "rectangular", "screen6", "genset8")
"""Machines whose blocks are at most 2x2 (closed-form eigenvalues; skid1plane has 3x3 blocks)."""


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


def description_without_values(folder: Path, names: tuple[str, ...], machine: str = "kid300") -> Path:
    """The shipped description ``machine`` written to ``folder`` with the nominal values of ``names`` left out
    (the format makes them optional)."""
    lines = Path(f"derivations/{machine}.toml").read_text(encoding="utf-8").splitlines()
    value = re.compile(r",\s*value = [0-9.e+-]+")
    keep = [value.sub("", line) if line.split("=")[0].strip() in names else line for line in lines]
    out = folder / f"{machine}_without_{'_'.join(names)}.toml"
    out.write_text("\n".join(keep) + "\n", encoding="utf-8")
    return out
