"""The thresholds of the diagnosis as one settings object, passed explicitly (defaults as shipped)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class DiagnosisSettings:
    """Decision thresholds of the gap diagnosis."""

    gap_p_value: float = 1e-3
    """The nominal model has a significant gap when its chi^2 exceeds the 1 - gap_p_value quantile."""
    tie: float = 7.0
    """Candidates within this AICc of the best cannot be told apart by the data (Burnham and Anderson's rule
    of thumb: up to 7 above the best a model keeps some support)."""
    significance: float = 2.0
    """A single residual (or a twin pair's difference) is flagged beyond this many standard deviations."""


DIAGNOSIS = DiagnosisSettings()
"""The default settings."""
