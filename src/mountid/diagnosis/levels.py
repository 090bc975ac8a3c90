"""Frequencies measured again at other excitation levels: whether the isolators' stiffness depends on the
amplitude.

Every model of the catalogue is linear: a mode's frequency does not depend on how hard the machine is hit.
Rubber is not quite linear (it hardens or softens with the deformation amplitude), and at one excitation
level a gently hardening isolator gives six frequencies that a linear effect (a drive belt, stiffer rubber)
can reproduce within their uncertainty. The same modes measured at a second level tell them apart: their
frequencies move with the level where the stiffness depends on the amplitude and stay within their
uncertainty where it does not. A campaign's ``levels`` list such repeats; :class:`LevelTest` is the test the
diagnosis takes: the chi^2 of the standardised shifts, and what remains of it once the machine's unknown
stiffnesses are fitted to each level in a model (the nominal one, or a candidate of the tie with its effect
held). Rubber whose stiffness changes alike in every mode moves the frequencies as a change of stiffness does,
and the fitted stiffnesses absorb it; what no change of stiffness makes in any model that fits the campaign's
level is a stiffening that differs from mode to mode, which the linear catalogue cannot represent, or a machine
whose modes depend on the stiffness otherwise than in those models. Either way no verdict is confident on it.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TypeVar

import numpy as np
import scipy.optimize
import scipy.stats

LEVEL_RATIO_LIMIT = 2.0
"""How far (a factor either way) a frequency at another level may lie from the campaign's frequency of the same
mode: rubber whose dynamic stiffness changed by more than a factor 4 between two hits is not one isolator state,
and such a value is another mode, another unit or a typing error."""


@dataclass(frozen=True)
class LevelShift:
    """One mode's frequency at another excitation level against the campaign's."""

    level: str
    """The level's name (as the campaign gives it)."""
    mode: str
    frequency: float
    """The campaign's frequency of the mode [rad/s]."""
    at_level: float
    """Its frequency at the level [rad/s]."""
    std: float
    """Standard deviation of their difference [rad/s] (the two measurements' in quadrature)."""

    @property
    def z(self) -> float:
        """The shift in standard deviations (positive: higher at the level)."""
        return (self.at_level - self.frequency) / self.std

    @property
    def relative(self) -> float:
        """The shift relative to the campaign's frequency (0.01: 1 % higher at the level)."""
        return self.at_level / self.frequency - 1


@dataclass(frozen=True)
class DampingShift:
    """One mode's damping ratio at another excitation level against the campaign's."""

    level: str
    mode: str
    ratio: float
    """The campaign's damping ratio of the mode."""
    at_level: float
    """Its damping ratio at the level."""
    std: float
    """Standard deviation of their difference (the two measurements' in quadrature)."""

    @property
    def z(self) -> float:
        """The shift in standard deviations (positive: more damped at the level)."""
        return (self.at_level - self.ratio) / self.std

    @property
    def relative(self) -> float:
        """The shift relative to the campaign's damping ratio (nan where that is 0)."""
        return self.at_level / self.ratio - 1 if self.ratio > 0 else math.nan


_S = TypeVar("_S", LevelShift, DampingShift)


@dataclass(frozen=True)
class StiffnessChange:
    """What a change of the isolators' stiffness alone makes of the shifts (:meth:`LevelTest.against_stiffness`):
    the machine's unknown stiffnesses fitted to each level's frequencies from their fit at the campaign's level."""

    model: str
    """The model whose stiffnesses changed ("the nominal model" or a candidate's name)."""
    fits: bool
    """Whether that model fits the campaign's level within its uncertainty (its sensitivities to the stiffnesses
    are then the machine's)."""
    relative: dict[str, dict[str, float]]
    """Per level name, each unknown's relative change (0.03: 3 % stiffer at the level)."""
    chi2: float
    """What remains of the shifts' chi^2 after the change."""
    dof: int
    """Repeated frequencies less the stiffness combinations they determine."""
    other_solution: bool = False
    """Whether the model's effect was held at another solution than the one fitted (fitting.other_solutions)."""
    damping_chi2: float = math.nan
    """What remains of the damping ratios' shifts (LevelTest.damping) once the model's damping ratios at each
    level's fitted stiffnesses are taken off, its damping held (nan without damping ratios at a level): a stiffer
    isolator of the same viscous damping lowers a mode's damping ratio as 1 / sqrt(stiffness)."""

    @property
    def p_value(self) -> float:
        """Probability of this chi^2 or more if the stiffness alone changed with the level (nan without a degree
        of freedom)."""
        return float(scipy.stats.chi2.sf(self.chi2, self.dof)) if self.dof > 0 else math.nan

    def absorbs(self, p_value: float) -> bool:
        """Whether the change leaves the shifts within their uncertainty: what remains below its 1 - ``p_value``
        quantile, with a degree of freedom left to tell."""
        return self.dof > 0 and self.p_value >= p_value


@dataclass(frozen=True)
class LevelTest:
    """Whether the repeated frequencies move with the excitation level beyond their uncertainty."""

    shifts: tuple[LevelShift, ...]
    damping: tuple[DampingShift, ...] = ()
    """The damping ratios measured at the levels against the campaign's (where both give one): reported in a note
    (:meth:`damping_text`), not in the verdict (the damping a diagnosis fits or holds is the campaign level's)."""

    @property
    def chi2(self) -> float:
        """Sum of the squared standardised shifts."""
        return _chi2(self.shifts)

    @property
    def p_value(self) -> float:
        """Probability of this chi^2 or more if every frequency were the same at every level."""
        return float(scipy.stats.chi2.sf(self.chi2, len(self.shifts)))

    def by_level(self) -> dict[str, list[LevelShift]]:
        """The shifts grouped by their level's name, in the campaign's order."""
        return _by_level(self.shifts)

    def damping_by_level(self) -> dict[str, list[DampingShift]]:
        """The damping ratios' shifts grouped by their level's name, in the campaign's order."""
        return _by_level(self.damping)

    @property
    def largest(self) -> LevelShift:
        """The shift of most standard deviations."""
        return max(self.shifts, key=lambda s: abs(s.z))

    def damping_text(self, p_value: float, change: StiffnessChange | None = None) -> str:
        """What the damping ratios at the levels say, for a note ('' without any): whether they move with the level
        beyond their uncertainty (chi^2 of the standardised shifts against its 1 - ``p_value`` quantile), where the
        frequencies move against what remains once the stiffness ``change`` that absorbs them is taken off (the
        damping ratios of a stiffer isolator are lower at the same damping), and not at all where no change does.
        Rubber's damping commonly depends on the amplitude; the catalogue's damping is linear, so a damping fitted or
        held describes the campaign's level."""
        if not self.damping:
            return ""
        big = max(self.damping, key=lambda s: abs(s.z))
        largest = f"largest shift {big.mode} {big.ratio:.3g} -> {big.at_level:.3g} at '{big.level}', {big.z:+.1f} sigma"
        n = len(self.damping)
        if self.p_value >= p_value:  # the stiffness the same at every level: the damping ratios should be too
            chi2, agree, move = _chi2(self.damping), "", ""
        elif change is not None and change.absorbs(p_value) and math.isfinite(change.damping_chi2):
            chi2 = change.damping_chi2
            made = f"what the change of stiffness in {change.model} makes of them"
            agree, move = f" with {made}", f" beyond {made}"
        else:
            return (
                f"the damping ratios at the levels are not compared with a model ({largest}): the frequencies move "
                "beyond a change of the isolators' stiffness"
            )
        p = float(scipy.stats.chi2.sf(chi2, n))
        stats = f"chi^2 = {chi2:.3g} for {n} repeated damping ratios, {_p(p)}; {largest}"
        if p >= p_value:
            return f"the damping ratios agree between the excitation levels{agree} ({stats})"
        return (
            f"the damping ratios move with the excitation level{move} ({stats}): the isolators' damping depends on "
            "the amplitude, and the damping the diagnosis fits or holds is the campaign level's"
        )

    def against_stiffness(
        self,
        frequencies: Callable[[np.ndarray], dict[str, float]],
        theta: np.ndarray,
        names: tuple[str, ...],
        bounds: tuple[np.ndarray, np.ndarray],
        model: str = "the nominal model",
        fits: bool = True,
        other_solution: bool = False,
        damping: Callable[[np.ndarray], dict[str, float]] | None = None,
    ) -> StiffnessChange:
        """The shifts against what a change of the isolators' stiffness alone makes of them: for each level, the
        log stiffnesses ``theta`` (``names``, within ``bounds``; their fit at the campaign's level in ``model``,
        which ``fits`` that level or not, its effect at ``other_solution`` or at the one fitted) fitted to the shifts
        of the model's ``frequencies`` [rad/s] (per mode label, a function of the log stiffnesses), exactly: the
        frequencies are not linear in them (with kid300's shear 10 % softer and its compression 5 % stiffer, the
        linearised change misses the shifts by up to 7e-4 of the frequency, chi^2 6.2 over six frequencies known to
        0.03 %). ``damping``: the model's damping ratios (per mode label, a function of the log stiffnesses, its
        damping held), for what remains of the damping ratios' shifts at each level's fitted stiffnesses."""
        base = frequencies(theta)
        relative, chi2, dof = {}, 0.0, 0
        damping_shifts = self.damping_by_level() if damping is not None else {}
        damping_chi2 = 0.0 if damping_shifts else math.nan
        for level, shifts in self.by_level().items():
            fit = scipy.optimize.least_squares(
                _shift_residuals, theta, bounds=bounds, xtol=1e-12, ftol=1e-12, args=(shifts, frequencies, base)
            )
            rank = int(np.linalg.matrix_rank(fit.jac, tol=1e-8 * max(1.0, float(np.abs(fit.jac).max()))))
            relative[level] = {n: float(math.expm1(d)) for n, d in zip(names, fit.x - theta, strict=True)}
            chi2 += float(fit.fun @ fit.fun)
            dof += len(shifts) - rank
            if level in damping_shifts:
                at, before = damping(fit.x), damping(theta)
                damping_chi2 += sum(
                    ((s.at_level - s.ratio - (at[s.mode] - before[s.mode])) / s.std) ** 2 for s in damping_shifts[level]
                )
        return StiffnessChange(model, fits, relative, chi2, dof, other_solution, float(damping_chi2))

    def text(self, changes: Sequence[StiffnessChange], p_value: float) -> str:
        """What the test says, for a verdict or a note: the shifts, and against the stiffness ``changes`` tried (in
        the order tried; the last one absorbs the shifts where any does); ``p_value``: the threshold of
        :func:`amplitude_dependent`."""
        big = self.largest
        stats = f"chi^2 = {self.chi2:.3g} for {len(self.shifts)} repeated frequencies, {_p(self.p_value)}"
        if self.p_value >= p_value:
            return (
                f"the frequencies agree between the excitation levels ({stats}; largest shift {big.mode} "
                f"{100 * big.relative:+.2g} % at '{big.level}', {big.z:+.1f} sigma): no sign that the isolators' "
                "stiffness depends on the amplitude"
            )
        moved = (
            f"the frequencies move with the excitation level ({stats}; {big.mode} {100 * big.relative:+.2g} % at "
            f"'{big.level}', {big.z:+.1f} sigma)"
        )
        told = [c for c in changes if c.dof > 0]
        if told and told[-1].absorbs(p_value):
            change = told[-1]
            return (
                f"{moved} as a change of the isolators' stiffness alone makes them in {change.model} "
                f"({_each(change)}; what remains: {_remains(change)}): the rubber's stiffness depends on the amplitude "
                "alike in every mode, which the fitted stiffnesses absorb (they are the equivalents at the campaign's "
                "level)"
                + (
                    "; the levels pick that solution of the effect, which the modes at the campaign's level alone do "
                    "not tell from the one fitted"
                    if change.other_solution
                    else ""
                )
            )
        unsaid = "; the candidates describe the modes at the campaign's level only and none is named confidently"
        if not told:
            return (
                f"{moved}, with too few repeated frequencies to tell a change of the isolators' stiffness from more: "
                f"the isolators' stiffness may depend on the amplitude differently in each mode{unsaid}"
            )
        remains = "; ".join(f"{c.model}: {_remains(c)}" for c in told)
        if not any(c.fits for c in told):
            return (
                f"{moved}, beyond any change of the isolators' stiffness in the closest models (what remains: "
                f"{remains}), which miss the modes at the campaign's level themselves: an amplitude dependence that "
                "differs from mode to mode, or a machine whose modes depend on the stiffness as no model of the "
                f"catalogue's{unsaid}"
            )
        return (
            f"{moved}, beyond any change of the isolators' stiffness in the models that fit the campaign's level "
            f"(what remains: {remains}): the isolators' stiffness depends on the amplitude differently in each mode "
            "(rubber hardening or softening, which the candidates, hardening rubber among them, describe at the "
            "campaign's level alone), or the machine's "
            f"modes depend on the stiffness otherwise than in these models (their effect is not the machine's){unsaid}"
        )


def picked_solution(changes: Sequence[StiffnessChange], p_value: float) -> bool:
    """Whether the change that absorbs the shifts (the last of ``changes``, where any does at ``p_value``) held its
    model's effect at another solution than the one fitted: the levels decide between the two."""
    return bool(changes) and changes[-1].other_solution and changes[-1].absorbs(p_value)


def amplitude_dependent(test: LevelTest, changes: Sequence[StiffnessChange], p_value: float) -> bool:
    """Whether the frequencies move with the level (at ``p_value``) beyond what a change of the isolators'
    stiffness alone makes of them in every model tried (``changes``; none where no model could be evaluated or
    no degree of freedom is left: then it cannot be told, and it counts as such)."""
    return test.p_value < p_value and not any(c.absorbs(p_value) for c in changes)


def _chi2(shifts: Sequence[LevelShift | DampingShift]) -> float:
    return float(sum(s.z**2 for s in shifts))


def _by_level(shifts: Sequence[_S]) -> dict[str, list[_S]]:
    out: dict[str, list[_S]] = {}
    for s in shifts:
        out.setdefault(s.level, []).append(s)
    return out


def _each(change: StiffnessChange) -> str:
    return "; ".join(
        f"at '{level}' " + ", ".join(f"{n} {100 * r:+.2g} %" for n, r in values.items())
        for level, values in change.relative.items()
    )


def _remains(change: StiffnessChange) -> str:
    return f"chi^2 = {change.chi2:.3g} for {change.dof}, {_p(change.p_value)}"


def _p(p_value: float) -> str:
    """A p-value as the text states it (one below double precision's smallest as such)."""
    return f"p = {p_value:.2g}" if p_value > 0 else "p < 1e-300"


def _shift_residuals(
    x: np.ndarray,
    shifts: list[LevelShift],
    frequencies: Callable[[np.ndarray], dict[str, float]],
    base: dict[str, float],
) -> np.ndarray:
    """The measured ``shifts`` less the model's between log stiffnesses ``x`` and the campaign level's
    (``base``: its frequencies there), in standard deviations."""
    model = frequencies(x)
    return np.array([(s.at_level - s.frequency - (model[s.mode] - base[s.mode])) / s.std for s in shifts])


def level_shift(level: str, mode: str, frequency: float, std: float, at: float, at_std: float) -> LevelShift:
    """The shift of one repeated frequency: the campaign's ``frequency`` and ``std`` [rad/s] against ``at`` and
    ``at_std`` at the ``level``. Raises ValueError (the reason) where they lie beyond LEVEL_RATIO_LIMIT apart."""
    ratio = at / frequency
    if not 1 / LEVEL_RATIO_LIMIT <= ratio <= LEVEL_RATIO_LIMIT:
        raise ValueError(
            f"{at:.6g} rad/s is {ratio:.3g} times the campaign's frequency of {mode} ({frequency:.6g}): another "
            f"mode or unit, not the same mode at another level (at most a factor {LEVEL_RATIO_LIMIT:g} either way)"
        )
    return LevelShift(level, mode, frequency, at, math.hypot(std, at_std))
