"""The unknown stiffnesses fitted by least squares to more measured natural frequencies than unknowns (what
`mountid identify` does when the frequencies over-determine them; an exactly determined set goes to the
generated inverse, Machine.identify).

Units: frequencies and their standard deviations [rad/s], parameters [SI]."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import scipy.stats

from mountid.errors import InputError
from mountid.identification.from_records import fit_stiffness
from mountid.machine import Machine
from mountid.nomenclature import distinct_frequencies

NOT_NOISE_SCATTER = 0.05
"""Relative RMS scatter of measured frequencies about the fit beyond which the fit notes that it is not
measurement noise: a natural frequency read from an accelerometer record carries well under a few percent (the
reference paper's largest, 0.45 rad/s at 17.71 rad/s, is 2.5 %); twice that is a mode the model misses or a
mislabelled mode."""


@dataclass(frozen=True)
class FrequencyFit:
    """The unknowns fitted to every measured distinct frequency."""

    parameters: dict[str, float]
    """The fitted unknowns [SI]."""
    std: dict[str, float]
    """Standard deviation of each unknown [SI]: from the given frequency standard deviations, scaled up by
    sqrt(chi^2 / dof) where the frequencies scatter more than stated; without them, from the scatter about the
    fit alone (weights relative to each frequency; no less than a relative scatter of 1e-6 gives)."""
    measured: dict[str, float]
    """The measured frequencies [rad/s] by the labels as given."""
    fitted: dict[str, float]
    """The fitted model's frequency of each measured mode [rad/s], by the same labels."""
    frequency_std: dict[str, float] | None
    """The given standard deviations [rad/s] by the same labels (None: not given)."""
    dof: int
    """Degrees of freedom: measured distinct frequencies minus unknowns."""
    notes: tuple[str, ...] = ()
    """How a solution was chosen where several fit equally (the description's physical rule)."""

    @property
    def chi2(self) -> float:
        """Sum of the squared residuals in units of the given standard deviations (nan without them)."""
        if self.frequency_std is None:
            return math.nan
        return sum(((self.fitted[k] - w) / self.frequency_std[k]) ** 2 for k, w in self.measured.items())

    @property
    def p_value(self) -> float:
        """Probability of a chi^2 at least this large if the model is right and the standard deviations are
        (nan without them): small values say the model misses the frequencies beyond their uncertainty."""
        return float(scipy.stats.chi2.sf(self.chi2, self.dof)) if math.isfinite(self.chi2) else math.nan

    @property
    def relative_residuals(self) -> dict[str, float]:
        """(fitted - measured) / measured of each measured mode [-], by label."""
        return {k: (self.fitted[k] - w) / w for k, w in self.measured.items()}

    @property
    def rms_scatter(self) -> float:
        """Root mean square of the relative residuals [-]: what the standard deviations come from where none
        are given."""
        r = self.relative_residuals.values()
        return math.sqrt(sum(x * x for x in r) / len(r))


def fit_frequencies(
    machine: Machine,
    known: dict[str, float],
    measured: dict[str, float],
    std: dict[str, float] | None = None,
    root: str | None = None,
) -> FrequencyFit:
    """The unknowns fitted to measured natural frequencies [rad/s] of more distinct modes than unknowns, from
    every admissible root of every exactly determined subset (fit_stiffness), with ``std`` the standard
    deviation of each [rad/s]. Where several solutions fit equally, the physical rule ``root`` ("A>B", e.g.
    "c_z>c_xy"; default the description's ROOT_RULE) chooses, named in the notes."""
    chosen = machine.distinct_measured(measured)
    machine.check_known(known)
    n = len(machine.unknown)
    if len(chosen) <= n:
        raise InputError("measured", f"{distinct_frequencies(len(chosen))} for {n} unknowns: no least squares fit")
    sigma = machine.measured_std(chosen, std)
    data = {k: (w, sigma[k] if sigma else 0.0) for k, (_, w) in chosen.items()}
    rule = root or getattr(machine.module, "ROOT_RULE", "") or None
    source = f"the rule {rule}" if root else f"the description's rule {rule}"
    notes: list[str] = []
    params, stds, _ = fit_stiffness(machine, known, data, root=rule, notes=notes, rule_source=source)
    model = machine.frequencies({**known, **params})
    fit = FrequencyFit(
        params,
        stds,
        {label: w for label, w in chosen.values()},
        {label: model[label] for label, _ in chosen.values()},
        {chosen[k][0]: v for k, v in sigma.items()} if sigma else None,
        len(chosen) - n,
        tuple(notes),
    )
    if sigma or fit.rms_scatter <= NOT_NOISE_SCATTER:
        return fit
    worst, r = max(fit.relative_residuals.items(), key=lambda kv: abs(kv[1]))
    scatter = (
        f"the frequencies scatter about the fit by {100 * fit.rms_scatter:.2g} % RMS (largest {worst}, "
        f"{100 * r:+.3g} %), more than a measured frequency carries (well under {100 * NOT_NOISE_SCATTER:.0f} %): "
        "not noise but a mode the model misses or a mislabelled mode; given standard deviations, the fit is tested"
    )
    return dataclasses.replace(fit, notes=(*fit.notes, scatter))
