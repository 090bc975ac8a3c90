"""How each kind of candidate effect enters the candidate model: one strategy per kind of the effect
registry (:data:`mountid.effects.EFFECT_KINDS`), so the diagnosis never dispatches on an effect's name.

A strategy gives the matrices M, C, B at the parameter values, the model frequencies from the eigenvalues,
the body motion the mode shapes are compared in, whether the effect can act on a campaign at all, and
the variants it is fitted once each for (isolators, channels); and for the analytic Jacobian of a fit
(mountid.diagnosis.jacobian) the derivatives of each: d(M, C, B)/dq from the engine's generated derivatives,
and the chain rule through the frequencies and shapes. The nominal model is the base strategy (no change).
"""

from __future__ import annotations

import functools
import itertools
import math
from typing import TYPE_CHECKING, NamedTuple, cast

import numpy as np
from scipy.spatial.transform import Rotation

from mountid.effects import Effect, Pair
from mountid.machine import (
    GeneratedModule,
    call,
    damped_pole_derivatives,
    damped_poles,
    pole_damping_ratios,
    ratio_derivatives,
    undamped_modes,
)
from mountid.machine.symmetry import mirror_planes, parity_signs, with_parity_signs
from mountid.runtime import eigen_derivatives

if TYPE_CHECKING:
    from mountid.diagnosis.campaign import Campaign
    from mountid.diagnosis.candidate_model import CandidateModel, Evaluation

Matrices = tuple[np.ndarray, np.ndarray, np.ndarray | None]
Derivatives = tuple[np.ndarray, np.ndarray]
"""d(M, C, B)/dq [SI per unit of q] stacked, shape (3, n_q, n, n) for M, C, B in the order of the fit's parameters
(CandidateModel.parameter_names), zeros where a parameter does not enter a matrix; and per q whether it enters the
strategy's matrices at all (Strategy.derivatives)."""

Stacked = np.ndarray
"""d(M, C, B)/dq stacked, shape (3, n_q, n, n): the first part of :data:`Derivatives`, what the analytic Jacobian
takes (unpacked, its three (n_q, n, n) parts)."""


class Strategy:
    """The nominal model: M and C of the generated module, undamped frequencies, shapes in q."""

    spread_starts: bool = True
    """Whether a fit whose starts all stop above noise level goes on from the most promising of starts spread
    over the plausible ranges (CandidateModel.spread)."""

    labels_as_read: bool = False
    """Whether the model's modes are labelled by their shapes as the sensors read them (shapes()), not by the
    body's own motion: where the reading distorts the shapes so far that a measured one may resemble another
    mode's body motion more than its own (a reversed channel)."""

    screened_variants: int = 0
    """For an effect of no parameter fitted per variant: how many variants are fitted, those whose one
    Gauss-Newton step from the unknowns the frequencies identify promises most (candidates._screened_variants);
    0: every variant."""

    def variants(self, campaign: Campaign) -> tuple[str, ...]:
        """The variants the effect is fitted once each for (the isolators, the channels), the best reported;
        empty for an effect fitted once."""
        return ()

    def modes(
        self, model: CandidateModel, values: dict[str, float], mats: Matrices, lam: np.ndarray, vec: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """The eigenvalues [rad^2/s^2] and M-normalised vectors of the model's modes from those of (C, M), ``lam``
        and ``vec``: here they themselves (a linear model)."""
        return lam, vec

    def matrices(self, model: CandidateModel, values: dict[str, float]) -> Matrices:
        """M, C and (where the strategy uses it) B [SI] at ``values``."""
        return call(model.mod, "mass_matrix", values), call(model.mod, "stiffness_matrix", values), None

    def frequencies(
        self, model: CandidateModel, values: dict[str, float], mats: Matrices, lam: np.ndarray
    ) -> np.ndarray:
        """Model frequencies [rad/s] of every mode, from the generalised eigenvalues ``lam`` of (C, M)."""
        return np.sqrt(np.abs(lam))

    def shapes(self, model: CandidateModel, values: dict[str, float], vectors: np.ndarray) -> np.ndarray:
        """The body motion (6 x n) the measured shapes are compared with."""
        return vectors[:6, :]

    def damping_matrix(self, model: CandidateModel, values: dict[str, float], mats: Matrices) -> np.ndarray:
        """B [N s/m, N m s/rad] of the candidate model: the strategy's own, else the description's."""
        return mats[2] if mats[2] is not None else np.asarray(call(model.mod, "damping_matrix", values))

    def damping_ratios(
        self, model: CandidateModel, values: dict[str, float], mats: Matrices, lam: np.ndarray
    ) -> np.ndarray:
        """Damping ratio -Re p / |p| of every mode (in the order of ``lam``) from the poles of
        M p^2 + B p + C = 0; 1 for a mode that does not oscillate."""
        m, c, _ = mats
        return pole_damping_ratios(damped_poles(m, c, self.damping_matrix(model, values, mats), lam))

    def damping_ratio_derivatives(self, model: CandidateModel, e: Evaluation, d_mats: Stacked) -> np.ndarray:
        """d zeta / dq of every mode, shape (n_q, n_modes), from the damped-pole derivatives of
        M p^2 + B p + C = 0 (ratio_derivatives); 0 for a mode that does not oscillate."""
        m, c, _ = e.mats
        p, dp = damped_pole_derivatives(m, c, self.damping_matrix(model, e.values, e.mats), e.lam, *d_mats)
        return ratio_derivatives(p, dp)

    def inapplicable(self, model: CandidateModel, has_shapes: bool) -> str:
        """Why the effect cannot act on this campaign ('' when it can)."""
        return ""

    # -- composition (mountid.diagnosis.strategies.Composite) ------------------------------------------
    def support(self, model: CandidateModel) -> str | None:
        """The generated effect whose support (coordinates of its own below the isolators) this strategy's
        matrices carry; None for the body's six coordinates."""
        return None

    def change(self, model: CandidateModel, values: dict[str, float], support: str | None) -> Matrices:
        """What this strategy adds to the nominal M and C, and its own B (None: the description's), when it
        acts beside another effect whose matrices carry ``support`` (see support()): its matrices less the
        nominal ones, in the body's coordinates (an effect acting on the body alone whatever stands below)."""
        m, c, b = self.matrices(model, values)
        m0, c0, _ = NOMINAL.matrices(model, values)
        return m - m0, c - c0, b

    def change_derivatives(
        self, model: CandidateModel, values: dict[str, float], support: str | None, names: tuple[str, ...]
    ) -> tuple[np.ndarray, np.ndarray]:
        """d(change())/dq stacked in the order of ``names``, shape (3, n_q, k, k) for M, C, B (a missing derivative
        as zeros), and per q whether it changes the matrices at all (the rows of the others are zeros, to be left
        out of a sum: x + 0 is not x to the bit where x is -0.0). Here the strategy's derivatives less the
        nominal ones, in the body's six coordinates."""
        own, present = self.derivatives(model, values, names, 6)
        nominal, given = NOMINAL.derivatives(model, values, names, 6)
        both = present & given
        own[:, both] -= nominal[:, both]
        return own, present

    # -- derivatives (the analytic Jacobian of a fit) ---------------------------------------------------
    def derivatives(
        self, model: CandidateModel, values: dict[str, float], names: tuple[str, ...], n: int
    ) -> Derivatives:
        """d(M, C, B)/dq of the strategy's M, C, B (n x n) stacked in the order of ``names`` (zeros where a
        parameter or a B derivative is absent), and per q whether the matrices depend on it. Here the nominal
        ones for the unknowns (the stiffnesses, and the damping parameters where damping ratios are measured;
        generated by the engine: fitted_derivatives(), in a model linear in them kept by machine.call for the whole
        fit). A fresh array: the Jacobian zeroes the rows of parameters that split twins in place, a strategy adds
        its own to the nominal ones."""
        d = np.asarray(call(model.mod, "fitted_derivatives", values))
        return stacked_rows(d, model.mod.FITTED_PARAMETERS, names, n, model.unknown)

    def mode_derivatives(
        self, model: CandidateModel, e: Evaluation, d_mats: Stacked, degenerate: float
    ) -> tuple[np.ndarray, np.ndarray] | None:
        """d lambda / dq (n_q, n_modes) [rad^2/s^2 per unit of q] and d vec / dq (n_q, n, n_modes) of the model's
        modes (e.lam, e.vec) from d(M, C, B)/dq (stacked); None where they are not differentiable at this point
        (the fit takes differences). Here the eigen-perturbation of (C, M) (runtime.eigen_derivatives), modes
        within ``degenerate`` (relative) of each other a subspace whose own motion alone is defined."""
        return eigen_derivatives(d_mats[0], d_mats[1], e.vec, e.lam, degenerate)

    def frequency_derivatives(
        self, model: CandidateModel, e: Evaluation, d_lam: np.ndarray, d_mats: Stacked
    ) -> np.ndarray:
        """d omega / dq [rad/s per unit of q] of every mode, shape (n_q, n_modes), for the fit parameters q
        in order (model.parameter_names), from d lambda / dq (n_q, n_modes) and d(M, C, B)/dq (stacked)."""
        return np.sign(e.lam) * d_lam / (2 * e.omega)

    def shape_derivatives(self, model: CandidateModel, e: Evaluation, d_vec: np.ndarray) -> np.ndarray:
        """d(shapes)/dq, shape (n_q, 6, n_modes), from the eigenvector derivatives d_vec (n_q, n, n)."""
        return d_vec[:, :6, :]


class Generated(Strategy):
    """Energy extensions: the engine's ``effect_<name>()`` gives the extended M, C, B."""

    def __init__(self, name: str = "") -> None:
        self.name = name
        """The effect (one strategy object per generated effect)."""

    def matrices(self, model: CandidateModel, values: dict[str, float]) -> Matrices:
        return tuple(call(model.mod, f"effect_{self.name}", values))

    def derivatives(
        self, model: CandidateModel, values: dict[str, float], names: tuple[str, ...], n: int
    ) -> Derivatives:
        d = np.asarray(call(model.mod, f"effect_{self.name}_derivatives", values))
        return stacked_rows(d, model.mod.EFFECT_DERIVATIVE_PARAMETERS[self.name], names, n)

    def support(self, model: CandidateModel) -> str | None:
        return self.name if len(model.mod.EFFECT_COORDINATES[self.name]) > 6 else None


class Isolator(Strategy):
    """One isolator's stiffness changed, in shear (the generated ``isolator_stiffness()`` less its axial part) by
    (1 + scatter_shear) and along its axis (``isolator_axial_stiffness()``) by (1 + scatter_axial). Beside a
    support below the isolators (the foundation), the isolator acts between the body and the support: its
    matrices there (``isolator_stiffness_on_<support>()``) have the support's coordinates too."""

    def variants(self, campaign: Campaign) -> tuple[str, ...]:
        return tuple(campaign.machine.module.ISOLATORS)

    def _parts(
        self, model: CandidateModel, values: dict[str, float], support: str | None, gradient: bool = False
    ) -> tuple[np.ndarray, np.ndarray]:
        """The shear and axial parts of the isolator's stiffness matrix (or of their gradients, by unknown)."""
        suffix = (f"_on_{support}" if support else "") + ("_gradient" if gradient else "")
        total = np.asarray(call(model.mod, "isolator_stiffness" + suffix, values))[..., model.variant, :, :]
        axial = np.asarray(call(model.mod, "isolator_axial_stiffness" + suffix, values))[..., model.variant, :, :]
        return total - axial, axial

    def matrices(self, model: CandidateModel, values: dict[str, float]) -> Matrices:
        m, c, _ = super().matrices(model, values)
        shear, axial = self._parts(model, values, None)
        return m, c + values["scatter_shear"] * shear + values["scatter_axial"] * axial, None

    def derivatives(
        self, model: CandidateModel, values: dict[str, float], names: tuple[str, ...], n: int
    ) -> Derivatives:
        out, present = super().derivatives(model, values, names, n)
        shear_grad, axial_grad = self._parts(model, values, None, gradient=True)
        s_shear, s_axial = values["scatter_shear"], values["scatter_axial"]
        for k, u in enumerate(model.mod.UNKNOWN):
            if u in names:
                # the description's B stays (matrices): its derivative too, where its damping follows a stiffness
                j = names.index(u)
                out[1, j] = out[1, j] + s_shear * shear_grad[k] + s_axial * axial_grad[k]
                present[j] = True
        shear, axial = self._parts(model, values, None)
        for q, part in (("scatter_shear", shear), ("scatter_axial", axial)):
            out[1, names.index(q)] = part
            present[names.index(q)] = True
        return out, present

    # On the ground, change() and change_derivatives() are the defaults (the matrices above less the nominal
    # ones), which keeps the rounding the benchmark's verdicts were validated with; on a support, the isolator's
    # matrices between body and support.
    def change(self, model: CandidateModel, values: dict[str, float], support: str | None) -> Matrices:
        if support is None:
            return super().change(model, values, support)
        shear, axial = self._parts(model, values, support)
        d_c = values["scatter_shear"] * shear + values["scatter_axial"] * axial
        return np.zeros_like(d_c), d_c, None

    def change_derivatives(
        self, model: CandidateModel, values: dict[str, float], support: str | None, names: tuple[str, ...]
    ) -> tuple[np.ndarray, np.ndarray]:
        if support is None:
            return super().change_derivatives(model, values, support, names)
        shear_grad, axial_grad = self._parts(model, values, support, gradient=True)
        shear, axial = self._parts(model, values, support)
        s_shear, s_axial = values["scatter_shear"], values["scatter_axial"]
        out = np.zeros((3, len(names), *shear.shape))
        present = np.zeros(len(names), dtype=bool)
        for j, q in enumerate(names):
            if q in model.mod.UNKNOWN:
                k = model.mod.UNKNOWN.index(q)
                out[1, j] = s_shear * shear_grad[k] + s_axial * axial_grad[k]
            elif q in ("scatter_shear", "scatter_axial"):
                out[1, j] = shear if q == "scatter_shear" else axial
            else:
                continue
            present[j] = True
        return out, present


class TiltedIsolator(Strategy):
    """One isolator mounted tilted (a sloping floor under its foot, a bent bracket): its stiffness axes turned by
    R = exp(tilt_1 [e1]x) exp(tilt_2 [e2]x), e1 and e2 the axes across its own axis a (axes_across: horizontal
    where a is not near-horizontal). Its stiffness matrix C_i = J^T K J (the generated ``isolator_stiffness()``:
    J (3 x n) the deformation of the isolator in the motion q, K its stiffness tensor in the machine's axes)
    becomes J^T R K R^T J. K is C_i's translational block and J = K^-1 C_i[:3, :] (a rigid translation deforms the
    isolator by itself, J = [I, ...]), so the tilt needs no matrix the engine does not generate. Where the isolator
    is round (equal shear stiffnesses) R K R^T depends on the turned axis R a alone, and the two turns reach every
    direction of it. The whole mount turns: its damping matrix B_i = J^T D J (the generated ``isolator_damping()``,
    D its damping tensor, the same J) becomes J^T R D R^T J in the description's B. Never part of a pair
    (mountid.effects.pair)."""

    def variants(self, campaign: Campaign) -> tuple[str, ...]:
        return tuple(campaign.machine.module.ISOLATORS)

    def _tilt(
        self, model: CandidateModel, values: dict[str, float]
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The isolator's deformation Jacobian J (3 x n), its stiffness tensor K (3 x 3) [N/m], the rotation R and
        its derivatives by tilt_1 and tilt_2 (2 x 3 x 3) [per rad]; kept for the point (matrices(), then the
        damping matrix and derivatives() of the same point ask for it)."""
        return model.kept("tilt", stiffness_point(model, values), lambda: self._turned(model, values))

    @staticmethod
    def _damping_tensor(model: CandidateModel, values: dict[str, float], gradient: bool = False) -> np.ndarray:
        """The isolator's damping tensor D (3 x 3) [N s/m] from the generated ``isolator_damping()``, or its
        derivatives by FITTED_PARAMETERS (``gradient``: n_fitted x 3 x 3)."""
        if gradient:
            return np.asarray(call(model.mod, "isolator_damping_gradient", values))[:, model.variant, :3, :3]
        return np.asarray(call(model.mod, "isolator_damping", values))[model.variant, :3, :3]

    @staticmethod
    def _turned(
        model: CandidateModel, values: dict[str, float]
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        total = np.asarray(call(model.mod, "isolator_stiffness", values))[model.variant]
        axial = np.asarray(call(model.mod, "isolator_axial_stiffness", values))[model.variant]
        k = total[:3, :3]
        jac = np.linalg.solve(k, total[:3, :])
        a = own_axes(axial[None])[0]
        a = a if a[np.argmax(np.abs(a))] > 0 else -a  # one sign, so that a tilt's sign means one direction
        across = axes_across(a)
        skews = [_skew(across[:, i]) for i in range(2)]
        first, second = (Rotation.from_rotvec(values[TILTS[i]] * across[:, i]).as_matrix() for i in range(2))
        rotation = first @ second
        return jac, k, rotation, np.array([skews[0] @ rotation, first @ skews[1] @ second])

    def matrices(self, model: CandidateModel, values: dict[str, float]) -> Matrices:
        m, c, _ = super().matrices(model, values)
        jac, k, r, _ = self._tilt(model, values)
        return m, c + jac.T @ (r @ k @ r.T - k) @ jac, None

    def damping_matrix(self, model: CandidateModel, values: dict[str, float], mats: Matrices) -> np.ndarray:
        jac, _, r, _ = self._tilt(model, values)
        d = self._damping_tensor(model, values)
        return super().damping_matrix(model, values, mats) + jac.T @ (r @ d @ r.T - d) @ jac

    def derivatives(
        self, model: CandidateModel, values: dict[str, float], names: tuple[str, ...], n: int
    ) -> Derivatives:
        out, present = super().derivatives(model, values, names, n)
        jac, k, r, d_r = self._tilt(model, values)
        gradient = np.asarray(call(model.mod, "isolator_stiffness_gradient", values))[:, model.variant]
        for g, u in zip(gradient, model.mod.UNKNOWN, strict=True):
            if u in names:
                d_k = g[:3, :3]
                j = names.index(u)
                out[1, j] = out[1, j] + jac.T @ (r @ d_k @ r.T - d_k) @ jac
                present[j] = True
        # the turned damping (damping_matrix): by the fitted parameters it follows, and by the turns
        damping, gradient = self._damping_tensor(model, values), self._damping_tensor(model, values, gradient=True)
        for d_d, p in zip(gradient, model.mod.FITTED_PARAMETERS, strict=True):
            if p in names and d_d.any():
                j = names.index(p)
                out[2, j] = out[2, j] + jac.T @ (r @ d_d @ r.T - d_d) @ jac
                present[j] = True
        for q, d in zip(TILTS, d_r, strict=True):
            turned, turned_damping = d @ k @ r.T, d @ damping @ r.T
            out[1, names.index(q)] = jac.T @ (turned + turned.T) @ jac
            out[2, names.index(q)] = jac.T @ (turned_damping + turned_damping.T) @ jac
            present[names.index(q)] = True
        return out, present


def stiffness_point(model: CandidateModel, values: dict[str, float]) -> bytes:
    """The key of what a strategy keeps per point of a fit (CandidateModel.kept): every value but the fitted damping
    parameters, which M and C never depend on, so that a step in one of them (a forward difference) finds what the
    point kept. Bytes of the values: -0.0 is not 0.0."""
    return np.array([values[name] for name in sorted(values) if name not in model.damping_unknown]).tobytes()


TILTS = ("tilt_1", "tilt_2")
"""The tilted isolator's two turns [rad] (TiltedIsolator), about the first and the second axis across its axis."""


def _skew(e: np.ndarray) -> np.ndarray:
    """[e]x: the matrix of the cross product e x v."""
    return np.array([[0.0, -e[2], e[1]], [e[2], 0.0, -e[0]], [-e[1], e[0], 0.0]])


class Frequency(Strategy):
    """Rubber stiffening with frequency (standard linear solid): omega^2 = g(omega) lambda."""

    def frequencies(
        self, model: CandidateModel, values: dict[str, float], mats: Matrices, lam: np.ndarray
    ) -> np.ndarray:
        return stiffened_frequencies(np.abs(lam), values["rubber_strength"], values["rubber_corner"] * model.omega_ref)

    def frequency_derivatives(
        self, model: CandidateModel, e: Evaluation, d_lam: np.ndarray, d_mats: Stacked
    ) -> np.ndarray:
        # implicit differentiation of F = y^2 + b y - lam c = 0, b = c - lam (1 + beta), y = omega^2,
        # c = corner^2: dy = -(F_lam dlam + F_beta dbeta + F_c dc) / F_y with F_y = 2 y + b > 0
        lam, y = np.abs(e.lam), e.omega**2
        beta, corner = e.values["rubber_strength"], e.values["rubber_corner"] * model.omega_ref
        c = corner**2
        f_y = 2 * y + c - lam * (1 + beta)
        dy = (((1 + beta) * y + c) * np.sign(e.lam) * d_lam) / f_y
        names = model.parameter_names
        dy[names.index("rubber_strength")] += lam * y / f_y
        dy[names.index("rubber_corner")] += -(y - lam) / f_y * 2 * corner * model.omega_ref
        return dy / (2 * e.omega)


HARDENING_ITERATIONS = 50
"""Most fixed-point steps of one mode of hardening rubber (Amplitude); it stops where the shape moves by less than
HARDENING_TOLERANCE."""

HARDENING_TOLERANCE = 1e-12
"""A hardened mode's shape (M-normalised) is at its fixed point when a step moves no entry by more than this."""


class Amplitude(Strategy):
    """Hardening rubber by equivalent linearisation: in each mode each isolator's stiffness along each of its
    local axes (isolator_split of the generated ``isolator_stiffness()``, whose sum is C) times
    1 + h (d / d_max)^2, d the deformation amplitude along that axis in the mode, d_max the largest over the
    isolators and axes (each mode excited to the same largest isolator deformation). Each mode solves the
    eigenproblem of its own stiffened C, from the linear model's mode to the fixed point where its shape makes the
    stiffening it is the mode of. The measured frequencies and shapes are those of the hardened modes, the damping
    ratios their poles' with the described B.

    Derivatives (the analytic Jacobian) by implicit differentiation of each mode's fixed point
    (hardened_derivatives)."""

    def modes(
        self, model: CandidateModel, values: dict[str, float], mats: Matrices, lam: np.ndarray, vec: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        hardened = self._hardened(model, values, mats, lam, vec)
        return hardened.lam, hardened.vec

    def damping_ratios(
        self, model: CandidateModel, values: dict[str, float], mats: Matrices, lam: np.ndarray
    ) -> np.ndarray:
        m, c, _ = mats
        b = self.damping_matrix(model, values, mats)
        hardened = self._hardened(model, values, mats, *undamped_modes(c, m))
        out = np.empty(len(lam))
        for j, (cj, i) in enumerate(zip(hardened.stiffened, hardened.picked, strict=True)):
            p = damped_poles(m, cj, b, undamped_modes(cj, m)[0])[i]
            out[j] = -p.real / abs(p) if abs(p) > 0 else 1.0
        return out

    def mode_derivatives(
        self, model: CandidateModel, e: Evaluation, d_mats: Stacked, degenerate: float
    ) -> tuple[np.ndarray, np.ndarray] | None:
        found = self._derivatives(model, e, d_mats)[1]
        return None if found is None else (found.d_lam, found.d_vec)

    def damping_ratio_derivatives(self, model: CandidateModel, e: Evaluation, d_mats: Stacked) -> np.ndarray:
        # each mode's pole of (M, C_j, B), C_j moving with the parameters and with the mode's own shape
        m, c, _ = e.mats
        b = self.damping_matrix(model, e.values, e.mats)
        d_m, _, d_b = d_mats
        hardened, found = self._derivatives(model, e, d_mats)
        if found is None:  # unreached: the Jacobian asks for these only where mode_derivatives gave its own
            raise ValueError("the hardened modes are not differentiable at this point")
        out = np.empty((len(d_m), len(e.lam)))
        for j, (cj, i) in enumerate(zip(hardened.stiffened, hardened.picked, strict=True)):
            p, dp = damped_pole_derivatives(m, cj, b, undamped_modes(cj, m)[0], d_m, found.d_stiffened[j], d_b)
            out[:, j] = ratio_derivatives(p[i : i + 1], dp[:, i : i + 1])[:, 0]
        return out

    def _hardened(
        self, model: CandidateModel, values: dict[str, float], mats: Matrices, lam: np.ndarray, vec: np.ndarray
    ) -> Hardened:
        """Every mode hardened (the linear model's ``lam`` and ``vec`` its start), kept for the point
        (stiffness_point)."""
        return model.kept(
            "hardened", stiffness_point(model, values), lambda: _hardened_modes(model, values, mats, lam, vec)
        )

    def _derivatives(
        self, model: CandidateModel, e: Evaluation, d_mats: Stacked
    ) -> tuple[Hardened, HardenedDerivatives | None]:
        """The hardened modes at the evaluation ``e`` and their hardened_derivatives, kept for the point and
        d(M, C)/dq (the shapes and the damping ratios of one Jacobian ask for them)."""
        m, c, _ = e.mats
        hardened = self._hardened(model, e.values, e.mats, *undamped_modes(c, m))
        key = stiffness_point(model, e.values) + np.asarray(d_mats[:2]).tobytes()
        return hardened, model.kept(
            "hardened derivatives", key, lambda: hardened_derivatives(model, e.values, m, hardened, d_mats[:2])
        )


class Hardened(NamedTuple):
    """The hardened modes of one point (Amplitude): per mode its eigenvalue [rad^2/s^2] and M-normalised vector
    (columns), its stiffened C_j [SI], which mode of (C_j, M) it is, and every eigenvalue of (C_j, M)
    (modes x n); and how far the shapes may still be from their fixed points."""

    lam: np.ndarray
    vec: np.ndarray
    stiffened: np.ndarray
    picked: np.ndarray
    eigenvalues: np.ndarray
    distance: float
    """How far the shapes may still be from their fixed points: the last step's largest movement times r / (1 - r),
    r its ratio to the step before (a contraction's geometric tail); infinite where the steps do not shrink or one
    step fell short of HARDENING_TOLERANCE."""


class HardenedDerivatives(NamedTuple):
    """d lambda / dq (n_q, n_modes), d vec / dq (n_q, n, n_modes) of the hardened modes, and each mode's
    d C_j / dq (n_modes, n_q, n, n) through the parameters and the mode's own motion."""

    d_lam: np.ndarray
    d_vec: np.ndarray
    d_stiffened: np.ndarray


def _hardened_modes(
    model: CandidateModel, values: dict[str, float], mats: Matrices, lam: np.ndarray, vec: np.ndarray
) -> Hardened:
    """Every mode's fixed point at once (Amplitude): per step one batched eigensolution of the modes' stiffened
    matrices in the standard form L^-1 C_j L^-T (M = L L^T), until no shape moves by more than HARDENING_TOLERANCE
    or after HARDENING_ITERATIONS steps."""
    m, c, _ = mats
    parts, along, _ = _split_at(model, values)
    h = values["hardening"]
    lower_inverse = np.linalg.inv(np.linalg.cholesky(m))
    # the description's mirror planes (its symmetry holds at every value of its unknowns): found once per model
    mirrors = model.kept("mirror planes", None, lambda: mirror_planes(m, c))
    # each mode keeps the mirror parity of its linear shape (rounding would not): its sign in each mirror plane
    signs = parity_signs(mirrors, m, vec)
    phi = np.array(vec, dtype=float)
    moved = before = math.inf
    for _ in range(HARDENING_ITERATIONS):
        squared = np.einsum("aj,kab,bj->jk", phi, parts, phi) / along  # each axis' squared deformation, per mode
        stiffened = c + h * np.einsum("jk,kab->jab", squared / squared.max(axis=1, keepdims=True), parts)
        standard = lower_inverse @ stiffened @ lower_inverse.T
        eigenvalues, vectors = np.linalg.eigh((standard + np.swapaxes(standard, 1, 2)) / 2)
        vectors = lower_inverse.T @ vectors  # (modes, n, n): M-normalised eigenvectors of each mode's (C_j, M)
        overlap = np.einsum("jai,ab,bj->ji", vectors, m, phi)
        picked = np.argmax(np.abs(overlap), axis=1)
        rows = np.arange(len(lam))
        step = vectors[rows, :, picked].T * np.sign(overlap[rows, picked])
        step = with_parity_signs(step, signs, mirrors, m)
        moved, before = float(np.abs(step - phi).max()), moved
        phi = step
        if moved <= HARDENING_TOLERANCE:
            break
    if math.isfinite(before) and moved < before:
        distance = moved * moved / (before - moved)  # moved r / (1 - r), r = moved / before
    else:  # one step, or steps that do not shrink
        distance = moved if moved <= HARDENING_TOLERANCE else math.inf
    return Hardened(eigenvalues[rows, picked], phi, stiffened, picked, eigenvalues, distance)


def _split_at(model: CandidateModel, values: dict[str, float]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """isolator_split of the generated isolator matrices at ``values``, kept by them."""
    total = np.asarray(call(model.mod, "isolator_stiffness", values))
    axial = np.asarray(call(model.mod, "isolator_axial_stiffness", values))
    return model.kept("isolator axes", total.tobytes() + axial.tobytes(), lambda: isolator_split(total, axial))


REACHED = 1e-9
"""Hardened shapes are at their fixed points for their derivatives where they may be no further from them than this,
relative to their largest entry (Hardened.distance; a slow contraction, h = 0.5 on skid1plane, leaves 5e-10 after
HARDENING_ITERATIONS steps, the derivatives right to 2e-8)."""

SEPARATE_MODES = 1e-6
"""A hardened mode's shape is differentiable where every other mode of its own (C_j, M) lies further than this
from it (relative); closer, the fit takes differences (hardened_derivatives)."""

FIXED_AXES = 1e-9
"""An isolator's axes stay where the parameters move them by no more than this: the off-diagonal entries of its
stiffness tensor K and of dK/dq in its axes, relative to their largest entry (hardened_derivatives)."""


def hardened_derivatives(
    model: CandidateModel, values: dict[str, float], mass: np.ndarray, hardened: Hardened, d_mats: np.ndarray
) -> HardenedDerivatives | None:
    """The derivatives of the hardened modes by the fit's parameters (model.parameter_names), by implicit
    differentiation of each mode's fixed point. Mode j solves (C_j(phi, q) - lambda M) phi = 0, phi^T M phi = 1,
    with C_j = C + h sum_p r_p P_p, r_p = s_p / s_max, s_p = phi^T P_p phi / k_p the squared deformation along
    axis p (isolator_split: P_p = k_p w_p w_p^T, w_p the axis' deformation per unit motion, a matter of geometry
    where the axes stay). Differentiated:

        (C_j - lambda M + G) dphi - M phi dlambda = -(dC_j/dq - lambda dM/dq) phi,  phi^T M dphi = -phi^T dM phi / 2,

    G = h sum_p P_p phi (grad r_p)^T the stiffening's response to the mode's own motion, dC_j/dq at fixed phi
    = dC/dq + h sum_p r_p (dk_p/dq / k_p) P_p (and sum_p r_p P_p by h). The axis of the largest deformation is held
    (where axes tie by symmetry, their deformations move alike). None where that does not hold: a fixed point not
    reached (Hardened.distance beyond REACHED), an isolator's axes turning with a parameter (FIXED_AXES), another
    mode of (C_j, M) within SEPARATE_MODES (relative) of the hardened one (its shape is not differentiable), or a
    singular system. ``d_mats``: d(M, C)/dq (2, n_q, n, n), ``mass`` M."""
    if not hardened.distance <= REACHED * np.abs(hardened.vec).max():
        return None
    d_m, d_c = d_mats
    names = model.parameter_names
    parts, along, axes = _split_at(model, values)
    d_along = _axis_stiffness_derivatives(model, values, axes, len(along))
    if d_along is None:
        return None
    lam, phi, stiffened, eigenvalues = hardened.lam, hardened.vec, hardened.stiffened, hardened.eigenvalues
    others = np.abs(eigenvalues - lam[:, None])
    others[np.arange(len(lam)), hardened.picked] = np.inf
    if np.any(others.min(axis=1) <= SEPARATE_MODES * np.abs(lam)):
        return None
    m, h, n_q = mass, values["hardening"], len(names)
    squared = np.einsum("aj,pab,bj->jp", phi, parts, phi) / along
    largest = np.argmax(squared, axis=1)
    rows = np.arange(phi.shape[1])
    ratio = squared / squared[rows, largest][:, None]
    pushed = np.einsum("pab,bj->jpa", parts, phi)  # P_p phi per mode
    grad_s = 2 * pushed / along[None, :, None]
    grad_r = (grad_s - ratio[:, :, None] * grad_s[rows, largest][:, None, :]) / squared[rows, largest][:, None, None]
    response = h * np.einsum("jpa,jpb->jab", pushed, grad_r)  # G per mode
    weighted = np.einsum("jp,pab->jab", ratio, parts)  # sum_p r_p P_p per mode
    d_fixed = d_c[None] + h * np.einsum("jp,qp,pab->jqab", ratio, d_along / along[None], parts)
    d_fixed[:, names.index("hardening")] += weighted
    size = len(m)
    bordered = np.zeros((phi.shape[1], size + 1, size + 1))
    bordered[:, :size, :size] = stiffened - lam[:, None, None] * m + response
    bordered[:, :size, size] = -(m @ phi).T
    bordered[:, size, :size] = (m @ phi).T
    rhs = np.zeros((phi.shape[1], size + 1, n_q))
    rhs[:, :size] = -np.einsum("jqab,bj->jaq", d_fixed - lam[:, None, None, None] * d_m[None], phi)
    rhs[:, size] = -0.5 * np.einsum("aj,qab,bj->jq", phi, d_m, phi)
    try:
        solution = np.linalg.solve(bordered, rhs)  # (modes, n + 1, n_q)
    except np.linalg.LinAlgError:
        return None
    d_phi = solution[:, :size]
    d_stiffened = d_fixed + h * np.einsum("pab,jpc,jcq->jqab", parts, grad_r, d_phi)
    return HardenedDerivatives(solution[:, size].T, np.transpose(d_phi, (2, 1, 0)), d_stiffened)


def _axis_stiffness_derivatives(
    model: CandidateModel, values: dict[str, float], axes: np.ndarray, parts: int
) -> np.ndarray | None:
    """d k_p / dq [N/m per unit of q], shape (n_q, ``parts``), of the stiffness along each isolator axis with a part
    (isolator_split: ``axes``, (isolators, 3, 3)) by the fit's parameters, from the generated
    ``isolator_stiffness_gradient()``; None where the axes do not stay (FIXED_AXES: K or dK/dq off-diagonal in an
    isolator's axes) or an axis without stiffness gains some (a part appears)."""
    names = model.parameter_names
    gradient = np.asarray(call(model.mod, "isolator_stiffness_gradient", values))  # (unknowns, isolators, n, n)
    tensor = np.asarray(call(model.mod, "isolator_stiffness", values))[:, :3, :3]
    in_axes = np.einsum("iae,iab,ibf->ief", axes, tensor, axes)
    d_in_axes = np.einsum("iae,uiab,ibf->uief", axes, gradient[..., :3, :3], axes)
    for t in (in_axes, *d_in_axes):
        diagonal = np.einsum("iee->ie", t)
        off = np.abs(t - diagonal[:, :, None] * np.eye(3)).max(axis=(1, 2))
        if np.any(off > FIXED_AXES * np.abs(t).max(axis=(1, 2))):
            return None
    keep = (np.einsum("iee->ie", in_axes) > 0).ravel()  # the axes isolator_split made parts of
    d_along = np.zeros((len(names), parts))
    for u, d in zip(model.mod.UNKNOWN, d_in_axes, strict=True):
        if u in names:
            d_k = np.einsum("iee->ie", d).ravel()
            if np.any(d_k[~keep]):
                return None
            d_along[names.index(u)] = d_k[keep]
    return d_along


EQUAL_AXES = 1e-9
"""Shear stiffnesses of an isolator this close (relative) are one: the matrix does not say its local x and y axes
(a round mount), and isolator_split takes them along the machine's x and y as far as the mount's axis allows."""


def own_axes(axial: np.ndarray) -> np.ndarray:
    """Each isolator's own axis a (unit, (isolators, 3), either sign) from its axial stiffness matrix k_a a a^T
    (``axial``: (isolators, n, n), the generated ``isolator_axial_stiffness()``): the eigenvector of the largest
    eigenvalue of its translational block."""
    return np.linalg.eigh(axial[:, :3, :3])[1][:, :, -1]


def isolator_split(stiffness: np.ndarray, axial: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each isolator's stiffness matrix (``stiffness``: (isolators, n, n), the generated ``isolator_stiffness()``)
    split along its local axes: its own axis a (local z, from ``axial``, the generated
    ``isolator_axial_stiffness()``) and the principal axes of its shear stiffness across a (local x and y; where
    they are equal, the projection of the machine's x on the plane across a, or of its y where a lies along x,
    and their cross product). The translational block K of an isolator's matrix (the body's translation moves
    every point alike) is sum_e k_e e e^T over these axes, and C_i = J^T K J = sum_e g_e g_e^T / k_e with
    g_e = C_i[:, :3] e. Returns the parts (3 per isolator, n x n) and the stiffness k_e along each, so that
    phi^T part phi / k_e is the squared deformation along e in the motion phi [m^2], and every isolator's axes
    (isolators, 3, 3), columns local x, y, z (the parts are those of the axes of positive stiffness, in order)."""
    block = stiffness[:, :3, :3]
    a = own_axes(axial)
    across = np.eye(3) - a[:, :, None] * a[:, None, :]
    k, vectors = np.linalg.eigh(across @ (block - axial[:, :3, :3]) @ across)
    shear = vectors[:, :, 1:]  # the two eigenvalues of the shear plane (the third, along a, is nil)
    round_ = np.abs(k[:, 2] - k[:, 1]) <= EQUAL_AXES * np.abs(k[:, 2])
    if round_.any():
        # along the machine's x as far as the axis allows (its y where the axis lies along x), and across both
        x_free = np.linalg.norm(across[:, :, 0], axis=1) > 0.5
        first = np.where(x_free[:, None], across[:, :, 0], across[:, :, 1])
        first /= np.linalg.norm(first, axis=1, keepdims=True)
        shear = np.where(round_[:, None, None], np.stack([first, np.cross(a, first)], axis=2), shear)
    axes = np.concatenate([shear, a[:, :, None]], axis=2)  # (isolators, 3, 3): columns local x, y, z
    along = np.einsum("iae,iab,ibe->ie", axes, block, axes)  # k_e = e^T K e
    g = stiffness[:, :, :3] @ axes  # (isolators, n, 3): the force of unit deformation along each axis
    parts = np.einsum("iae,ibe->ieab", g, g) / along[:, :, None, None]
    keep = (along > 0).ravel()
    return parts.reshape(-1, *stiffness.shape[1:])[keep], along.ravel()[keep], axes


class Damping(Strategy):
    """The measured frequencies are damped ones: Im p of M p^2 + eta B p + C = 0. In a campaign whose
    frequencies were poles' |p|, converted to undamped ones (Campaign.frequencies_from_poles: records), the
    frequencies stay undamped and eta acts on the damping ratios alone: the described damping a factor off."""

    def matrices(self, model: CandidateModel, values: dict[str, float]) -> Matrices:
        m, c, _ = super().matrices(model, values)
        return m, c, call(model.mod, "damping_matrix", values)

    def frequencies(
        self, model: CandidateModel, values: dict[str, float], mats: Matrices, lam: np.ndarray
    ) -> np.ndarray:
        if model.campaign.frequencies_from_poles:
            return super().frequencies(model, values, mats, lam)
        m, c, b = mats
        return damped_poles(m, c, values["damping_scale"] * b, lam).imag

    def damping_matrix(self, model: CandidateModel, values: dict[str, float], mats: Matrices) -> np.ndarray:
        return values["damping_scale"] * mats[2]

    def derivatives(
        self, model: CandidateModel, values: dict[str, float], names: tuple[str, ...], n: int
    ) -> Derivatives:
        # the model's B is damping_scale * B: its derivatives scale with it, and d/d(damping_scale) is B
        out, present = super().derivatives(model, values, names, n)
        out[2, present] *= values["damping_scale"]
        j = names.index("damping_scale")
        out[2, j] = call(model.mod, "damping_matrix", values)
        present[j] = True
        return out, present

    def frequency_derivatives(
        self, model: CandidateModel, e: Evaluation, d_lam: np.ndarray, d_mats: Stacked
    ) -> np.ndarray:
        if model.campaign.frequencies_from_poles:
            return super().frequency_derivatives(model, e, d_lam, d_mats)
        m, c, b = e.mats
        return damped_pole_derivatives(m, c, e.values["damping_scale"] * b, e.lam, *d_mats)[1].imag

    def inapplicable(self, model: CandidateModel, has_shapes: bool) -> str:
        if not np.any(call(model.mod, "damping_matrix", model.known | model.start_unknowns)):
            return "the description has no damping: nothing to scale"
        if model.campaign.frequencies_from_poles and not model.damped:
            return (
                "the frequencies are poles converted to undamped ones and no damping ratio is measured: nothing to fit"
            )
        return ""


class Sensor(Strategy):
    """The shapes were read through a sensor frame turned by a yaw angle, its reference point off in height."""

    spread_starts = False
    """The frame's turn and height act on the shapes alone; in the blind benchmark its fits reached their truths
    from the default starts (47 of 47 identifiable cases with shapes, seeds 0-239)."""

    def shapes(self, model: CandidateModel, values: dict[str, float], vectors: np.ndarray) -> np.ndarray:
        return sensor_transform(model.mod, values["sensor_yaw"], values["sensor_dz"]) @ vectors[:6, :]

    def shape_derivatives(self, model: CandidateModel, e: Evaluation, d_vec: np.ndarray) -> np.ndarray:
        yaw, dz = e.values["sensor_yaw"], e.values["sensor_dz"]
        transform = sensor_transform(model.mod, yaw, dz)
        out = np.einsum("ab,qbk->qak", transform, d_vec[:, :6, :])
        names = model.parameter_names
        body = e.vec[:6, :]
        out[names.index("sensor_yaw")] += sensor_transform_derivative(model.mod, yaw, dz, "yaw") @ body
        out[names.index("sensor_dz")] += sensor_transform_derivative(model.mod, yaw, dz, "dz") @ body
        return out

    def inapplicable(self, model: CandidateModel, has_shapes: bool) -> str:
        if not has_shapes:
            return "no mode shapes measured: the frequencies are exactly unchanged by a sensor error"
        return ""


class Composite(Strategy):
    """Two effects at once (mountid.effects.Pair): each one's change of M, C (its extended matrices less the
    nominal ones) added to the nominal model. Where one member carries a support below the isolators (the
    foundation's twelve coordinates), the other's change enters those matrices as Strategy.change() gives it
    for that support: in the body's block, or for an isolator between body and support in all twelve.
    Frequencies through the member that maps them (rubber stiffening), shapes through the member that reads
    them (the sensor frame)."""

    def __init__(self, first: Strategy, second: Strategy) -> None:
        self.members = (first, second)
        self.frequency_role = next((m for m in self.members if type(m).frequencies is not Strategy.frequencies), None)
        self.shape_role = next((m for m in self.members if type(m).shapes is not Strategy.shapes), None)
        self.labels_as_read = any(m.labels_as_read for m in self.members)
        """Labelled by the shapes as read where a member is (a reversed channel beside a physical effect)."""

    def _roles(self, model: CandidateModel) -> tuple[Strategy, Strategy]:
        """The member whose matrices the other's change is added to (the one with a support, else the first),
        and the other."""
        first, second = self.members
        return (second, first) if second.support(model) and not first.support(model) else (first, second)

    def variants(self, campaign: Campaign) -> tuple[str, ...]:
        """The member's variants where one member has them; where both do (a scattered isolator beside a reversed
        channel), every combination, named 'isolator & channel', the first member's varying slowest."""
        first, second = (m.variants(campaign) for m in self.members)
        if first and second:
            return tuple(both_variants(a, b) for a, b in itertools.product(first, second))
        return first or second

    def member_variants(self, campaign: Campaign, variant: int | None) -> tuple[int | None, int | None]:
        """Each member's own variant (its index among its variants; None for a member fitted once) at the pair's
        ``variant``."""
        first, second = (m.variants(campaign) for m in self.members)
        if variant is None:
            return None, None
        if first and second:
            return divmod(variant, len(second))
        return (variant, None) if first else (None, variant)

    def _seen_by(self, member: Strategy, model: CandidateModel) -> CandidateModel:
        """The model as ``member`` sees it: itself, or where both members act per variant the model at the
        member's own variant (MemberView; kept by the model)."""
        views = model.kept("member views", None, lambda: self._views(model))
        return next((v for m, v in zip(self.members, views, strict=True) if m is member), model) if views else model

    def _views(self, model: CandidateModel) -> tuple[CandidateModel, ...]:
        both = self.member_variants(model.campaign, model.variant)
        if None in both:
            return ()
        return tuple(cast("CandidateModel", MemberView(model, v)) for v in both)

    def support(self, model: CandidateModel) -> str | None:
        return self._roles(model)[0].support(model)

    def matrices(self, model: CandidateModel, values: dict[str, float]) -> Matrices:
        base, other = self._roles(model)
        m, c, b = base.matrices(self._seen_by(base, model), values)
        d_m, d_c, b2 = other.change(self._seen_by(other, model), values, base.support(model))
        m, c, n = m.copy(), c.copy(), d_m.shape[0]
        m[:n, :n] += d_m
        c[:n, :n] += d_c
        return m, c, b if b is not None else b2

    def frequencies(
        self, model: CandidateModel, values: dict[str, float], mats: Matrices, lam: np.ndarray
    ) -> np.ndarray:
        role = self.frequency_role or NOMINAL
        return role.frequencies(self._seen_by(role, model), values, mats, lam)

    def shapes(self, model: CandidateModel, values: dict[str, float], vectors: np.ndarray) -> np.ndarray:
        role = self.shape_role or NOMINAL
        return role.shapes(self._seen_by(role, model), values, vectors)

    def inapplicable(self, model: CandidateModel, has_shapes: bool) -> str:
        return next((why for m in self.members if (why := m.inapplicable(self._seen_by(m, model), has_shapes))), "")

    def derivatives(
        self, model: CandidateModel, values: dict[str, float], names: tuple[str, ...], n: int
    ) -> Derivatives:
        """d(M_base + change of the other)/dq, likewise C and B: the base's derivatives (the nominal ones for a
        parameter the base's matrices do not depend on but the other's change does) with the other's change
        added to their leading block, in place."""
        base, other = self._roles(model)
        out, own = base.derivatives(self._seen_by(base, model), values, names, n)
        change, present = other.change_derivatives(self._seen_by(other, model), values, base.support(model), names)
        borrowed = present & ~own
        if borrowed.any():
            nominal, given = NOMINAL.derivatives(model, values, names, 6)
            borrowed &= given
            out[:, borrowed, :6, :6] = nominal[:, borrowed]
        k = change.shape[-1]
        out[:, present, :k, :k] += change[:, present]
        return out, own | present

    def frequency_derivatives(
        self, model: CandidateModel, e: Evaluation, d_lam: np.ndarray, d_mats: Stacked
    ) -> np.ndarray:
        role = self.frequency_role or NOMINAL
        return role.frequency_derivatives(self._seen_by(role, model), e, d_lam, d_mats)

    def shape_derivatives(self, model: CandidateModel, e: Evaluation, d_vec: np.ndarray) -> np.ndarray:
        role = self.shape_role or NOMINAL
        return role.shape_derivatives(self._seen_by(role, model), e, d_vec)


class MemberView:
    """A candidate model as one member of a pair sees it where both members act per variant (a scattered
    isolator beside a reversed channel, Composite): the model itself with ``variant`` the member's own (its
    index among the member's variants). Everything else, what the model keeps (CandidateModel.kept) included,
    is the model's: within one pair's model each member's variant is fixed."""

    def __init__(self, model: CandidateModel, variant: int) -> None:
        self._model = model
        self.variant = variant

    def __getattr__(self, name: str) -> object:
        return getattr(self._model, name)


class LayoutReading(Strategy):
    """The shapes as estimated from the layout the campaign gives (its ``sensors``) when some of its channels
    read otherwise than the layout says: the least-squares estimate P^+ P' q, P the channels' rows d^T du/dq
    (the generated point_jacobian), P' the rows as the channels read (_transform, per subclass)."""

    parameters: tuple[str, ...] = ()
    what = "a misread channel"
    spread_starts = False
    """A channel's turn (offset) acts on the shapes alone, through the layout's estimate; in the blind benchmark
    its fits reached their truths from the default starts (57 of 58 identifiable cases with shapes named the
    channel's effect first, seeds 0-239). It is fitted once per channel (12 on four triaxial sensors), where
    the spread would cost a third of a second per diagnosis."""

    def inapplicable(self, model: CandidateModel, has_shapes: bool) -> str:
        if not has_shapes:
            return f"no mode shapes measured: the frequencies are exactly unchanged by {self.what}"
        if not model.campaign.sensors:
            return "the campaign does not give the sensor layout its shapes were estimated from"
        return ""

    def transform(self, model: CandidateModel, values: dict[str, float]) -> tuple[np.ndarray, np.ndarray]:
        """The 6 x 6 map from the body's motion to the estimated shape, and its derivatives by the
        parameters, shape (n, 6, 6); kept by the model (CandidateModel.kept): a fit asks for it at each point
        twice, for the shapes and for their derivatives."""
        key = np.array([values[a] for a in self.parameters]).tobytes()
        return model.kept("transform", key, lambda: self._transform(model, values))

    def _transform(self, model: CandidateModel, values: dict[str, float]) -> tuple[np.ndarray, np.ndarray]:
        """The map P^+ P' (6 x 6) and its derivatives by the parameters, shape (n, 6, 6)."""
        raise NotImplementedError

    def shapes(self, model: CandidateModel, values: dict[str, float], vectors: np.ndarray) -> np.ndarray:
        return self.transform(model, values)[0] @ vectors[:6, :]

    def shape_derivatives(self, model: CandidateModel, e: Evaluation, d_vec: np.ndarray) -> np.ndarray:
        transform, derivatives = self.transform(model, e.values)
        out = np.einsum("ab,qbk->qak", transform, d_vec[:, :6, :])
        names = model.parameter_names
        for i, name in enumerate(self.parameters):
            out[names.index(name)] += derivatives[i] @ e.vec[:6, :]
        return out


class Channel(LayoutReading):
    """One channel of the layout the shapes were estimated from (the campaign's sensors) reads along its axis
    turned by the rotation vector (turn_1, turn_2) [rad] across it (turned_axis): the shapes are the least-squares
    estimate P^+ P' q from the layout's readings, P the channels' rows d^T du/dq (the generated point_jacobian),
    P' with the turned channel's row."""

    parameters: tuple[str, ...] = ("turn_1", "turn_2")
    what = "a turned sensor"

    def variants(self, campaign: Campaign) -> tuple[str, ...]:
        return tuple(c.name for c in campaign.sensors)

    def _layout(self, model: CandidateModel) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The layout's rows P, their pseudo-inverse, and for the chosen channel its point Jacobian, axis d and two
        unit axes across it (kept by the model: CandidateModel.kept, under one key)."""
        return model.kept("channel layout", None, lambda: self._new_layout(model))

    @staticmethod
    def _new_layout(model: CandidateModel) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        channels = model.campaign.sensors
        jac, rows = layout_rows(model)
        d = np.asarray(channels[model.variant].direction)
        return rows, np.linalg.pinv(rows), jac[model.variant], d, axes_across(d)

    def row(self, model: CandidateModel, values: dict[str, float]) -> tuple[np.ndarray, np.ndarray]:
        """The chosen channel's row (6) and its derivatives by the two parameters (2, 6)."""
        _, _, jac, d, across = self._layout(model)
        axis, d_axis = turned_axis(d, across, np.array([values["turn_1"], values["turn_2"]]))
        return axis @ jac, d_axis @ jac

    def _transform(self, model: CandidateModel, values: dict[str, float]) -> tuple[np.ndarray, np.ndarray]:
        rows, pinv, *_ = self._layout(model)
        k = model.variant
        row, d_row = self.row(model, values)
        changed = rows.copy()
        changed[k] = row
        size = len(pinv)
        derivatives = [np.outer(pinv[:, k], d) for d in d_row]
        return pinv @ changed, np.array(derivatives) if derivatives else np.zeros((0, size, size))


class Placement(Channel):
    """One channel of the layout sits offset_1, offset_2 [m] off its stated point along two axes across its
    direction (an offset along it changes nothing): its row is d^T du/dq at the point where it sits. The
    generated point_jacobian is affine in the point, so the row is linear in the offsets, and only its rotation
    part changes."""

    parameters = ("offset_1", "offset_2")
    what = "a misplaced sensor"

    def row(self, model: CandidateModel, values: dict[str, float]) -> tuple[np.ndarray, np.ndarray]:
        rows, _, _, d, across = self._layout(model)
        d_row = model.kept("placement rows", None, lambda: np.array([d @ j for j in offset_jacobians(model, across)]))
        offset = np.array([values["offset_1"], values["offset_2"]])
        return rows[model.variant] + offset @ d_row, d_row


class TurnedPlacement(Channel):
    """One channel of the layout sits offset_1, offset_2 [m] off its stated point across its stated direction
    and reads along that direction turned by the rotation vector (turn_1, turn_2) [rad] across it (turned_axis):
    its row is the turned axis times the point Jacobian where the sensor sits (affine in the offsets,
    offset_jacobians). Both slips on one channel: the blind truth ``sensor_turned+sensor_misplaced``, which one
    turn or one offset alone left "not explained" in 15 of 66 campaigns with shapes (the tables of d3c59c6).
    Fitted at the ``screened_variants`` channels whose turn and offset promise most from the unknowns the
    frequencies identify (both leave the frequencies unchanged), as two turned channels are."""

    parameters = ("turn_1", "turn_2", "offset_1", "offset_2")
    what = "a turned and misplaced sensor"
    screened_variants = 3

    def row(self, model: CandidateModel, values: dict[str, float]) -> tuple[np.ndarray, np.ndarray]:
        _, _, jac, d, across = self._layout(model)
        d_jac = model.kept("placement jacobians", None, lambda: offset_jacobians(model, across))
        at = jac + np.tensordot(np.array([values["offset_1"], values["offset_2"]]), d_jac, axes=1)
        axis, d_axis = turned_axis(d, across, np.array([values["turn_1"], values["turn_2"]]))
        return axis @ at, np.concatenate([d_axis @ at, axis @ d_jac])


class Reversal(Channel):
    """One channel of the layout reads with its polarity reversed, along -d (a sensor mounted upside down, a
    cable wired the wrong way round): its row of the layout is negated, and the shapes are the least-squares
    estimate P^+ P' q. No parameter: the fit is the unknowns' alone. The catalogue's turned sensor turns a
    channel by 0.35 rad per component at most; a reversal is a turn by pi, which it cannot reach (the blind truth
    ``sensor_reversed`` ended "not explained" in all 18 cases with shapes on seeds 0-68 before this strategy).
    Fitted at the ``screened_variants`` channels whose reversal promises most from the unknowns the frequencies
    alone identify (a reversal leaves the frequencies unchanged), from there and from the nominal fit's: a
    channel's fit costs what the nominal fit does, twelve of them a twentieth of a diagnosis."""

    parameters: tuple[str, ...] = ()
    what = "a reversed channel"
    screened_variants = 2
    labels_as_read = True
    """A reversal distorts a mode's shape by as much as the channel reads of it: on genset8 (blind seed 1014, its
    S2_z reversed) the measured shapes of two modes resemble each other's body motion, and labelled by it the
    model at the truth's unknowns missed the frequencies by chi^2 1.4e5."""

    def row(self, model: CandidateModel, values: dict[str, float]) -> tuple[np.ndarray, np.ndarray]:
        rows, *_ = self._layout(model)
        return -rows[model.variant], np.zeros((0, rows.shape[1]))


class TurnedPair(LayoutReading):
    """Two channels of the layout read along axes turned by the rotation vectors (turn_1, turn_2) and (turn_3,
    turn_4) [rad] across them (turned_axis): the shapes are the least-squares estimate P^+ P' q with both rows of
    P' turned. Its variants are the pairs of channels (66 on twelve channels); it is fitted at the
    ``screened_variants`` pairs whose turns promise most from the unknowns the frequencies identify (turns
    leave the frequencies unchanged), its evidence the mean over all pairs (the others adding nothing). Two
    channels turned are outside what one channel's turn or offset reaches, and one misplaced channel fitted them
    within the uncertainty (kid300axes, blind seed 779 with shapes: S3_x and S4_x turned by 0.33 and 0.28 rad, one
    misplaced at S3_x named with probability 1.00)."""

    parameters = ("turn_1", "turn_2", "turn_3", "turn_4")
    what = "two turned sensors"
    screened_variants = 3

    def variants(self, campaign: Campaign) -> tuple[str, ...]:
        names = [c.name for c in campaign.sensors]
        return tuple(both_variants(a, b) for a, b in itertools.combinations(names, 2))

    def _layout(self, model: CandidateModel) -> tuple:
        """The layout's rows P, their pseudo-inverse, and for each of the two chosen channels its index, point
        Jacobian, axis d and two unit axes across it (kept by the model)."""
        return model.kept("channel pair layout", None, lambda: self._new_pair_layout(model))

    @staticmethod
    def _new_pair_layout(model: CandidateModel) -> tuple:
        channels = model.campaign.sensors
        jac, rows = layout_rows(model)
        chosen = list(itertools.combinations(range(len(channels)), 2))[model.variant]
        picked = []
        for k in chosen:
            d = np.asarray(channels[k].direction)
            picked.append((k, jac[k], d, axes_across(d)))
        return rows, np.linalg.pinv(rows), tuple(picked)

    def _transform(self, model: CandidateModel, values: dict[str, float]) -> tuple[np.ndarray, np.ndarray]:
        rows, pinv, picked = self._layout(model)
        changed = rows.copy()
        derivatives = []
        for (k, jac, d, across), names in zip(picked, (self.parameters[:2], self.parameters[2:]), strict=True):
            axis, d_axis = turned_axis(d, across, np.array([values[a] for a in names]))
            changed[k] = axis @ jac
            derivatives += [np.outer(pinv[:, k], d_row) for d_row in d_axis @ jac]
        return pinv @ changed, np.array(derivatives)


STRATEGIES: dict[str, Strategy] = {
    "generated": Generated(),
    "isolator": Isolator(),
    "tilt": TiltedIsolator(),
    "frequency": Frequency(),
    "amplitude": Amplitude(),
    "damping": Damping(),
    "sensor": Sensor(),
    "channel": Channel(),
    "placement": Placement(),
    "reversal": Reversal(),
    "channels": TurnedPair(),
    "turned_placement": TurnedPlacement(),
}
"""One strategy per effect kind; ``tests/test_effect_registry.py`` checks that every kind has one."""

NOMINAL = Strategy()


def layout_rows(model: CandidateModel) -> tuple[list[np.ndarray], np.ndarray]:
    """The point Jacobian du/dq (3 x 6, the generated point_jacobian) at each channel's stated point of the
    campaign's layout, and the layout's rows d^T du/dq (n_channels x 6)."""
    channels = model.campaign.sensors
    jac = [np.asarray(model.mod.point_jacobian(*c.point)) for c in channels]
    return jac, np.array([np.asarray(c.direction) @ j for c, j in zip(channels, jac, strict=True)])


def both_variants(a: str, b: str) -> str:
    """The name of two variants at once: two channels turned ('S2_y & S4_x'), an isolator with a channel
    ('corner[-x-y] & S1_x')."""
    return f"{a} & {b}"


def strategy(effect: Effect | Pair | None) -> Strategy:
    """The strategy of ``effect`` (None: the nominal model; a pair: the composite of its members')."""
    if effect is None:
        return NOMINAL
    if isinstance(effect, Pair):
        return Composite(strategy(effect.first), strategy(effect.second))
    if effect.kind == "generated":
        return Generated(effect.name)
    return STRATEGIES[effect.kind]


def stacked_rows(
    d: np.ndarray, rows: tuple[str, ...], names: tuple[str, ...], n: int, keep: tuple[str, ...] | None = None
) -> Derivatives:
    """The generated derivatives ``d`` (k, 3, m, m), one per parameter of ``rows``, stacked in the order of
    ``names`` into (3, n_q, n, n) zeros (their leading m x m block), for the names in ``rows`` (and in ``keep``
    where given); and which names were."""
    out = np.zeros((3, len(names), n, n))
    present, where, picks = _stacking(rows, names, keep)
    if len(where):
        m = d.shape[-1]
        out[: d.shape[1], where, :m, :m] = np.swapaxes(d[picks], 0, 1)
    return out, present.copy()  # the caller's to change


@functools.lru_cache(maxsize=1024)
def _stacking(
    rows: tuple[str, ...], names: tuple[str, ...], keep: tuple[str, ...] | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """stacked_rows' bookkeeping, the same at every point of a fit (kept, read-only): which ``names`` are in
    ``rows`` (and ``keep``), their positions among ``names``, and the rows of ``d`` they take."""
    present = np.array([q in rows and (keep is None or q in keep) for q in names], dtype=bool)
    where = np.flatnonzero(present)
    picks = np.array([rows.index(names[j]) for j in where], dtype=np.intp)
    for a in (present, where, picks):
        a.setflags(write=False)
    return present, where, picks


def stiffened_frequencies(lam: np.ndarray, beta: float, corner: float) -> np.ndarray:
    """omega solving omega^2 = g(omega) lam, g = 1 + beta y / (y + c), y = omega^2, c = corner^2, for each
    eigenvalue lam of the static stiffness. Multiplied out, y^2 + b y - lam c = 0 with b = c - lam (1 + beta):
    one positive root (the product of the roots is -lam c), taken in the form without cancellation."""
    c = corner**2
    b = c - lam * (1 + beta)
    root = np.sqrt(b * b + 4 * lam * c)
    y = np.where(b > 0, 2 * lam * c / (b + root), (root - b) / 2)
    return np.sqrt(y)


SMALL_TURN = 1e-2
"""Below this angle [rad] turned_axis takes sin(a)/a and its derivative from their series (to a^4: the first term
left out is below 1e-16 of the sum), where the quotients lose digits."""


def axes_across(d: np.ndarray) -> np.ndarray:
    """Two unit axes across the unit axis ``d`` (columns, 3 x 2): the first horizontal where ``d`` is not
    near-vertical (across z), else across x; the second d x the first."""
    helper = np.array([0.0, 0.0, 1.0]) if abs(d[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    e1 = np.cross(helper, d)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(d, e1)
    return np.column_stack([e1, e2])


def offset_jacobians(model: CandidateModel, across: np.ndarray) -> np.ndarray:
    """d(point Jacobian)/d(offset) along each of the two axes ``across`` (columns, 3 x 2) a channel's direction,
    shape (2, 3, 6): the generated point_jacobian is affine in the point, so the difference of its values at each
    axis and at the origin."""
    origin = np.asarray(model.mod.point_jacobian(0.0, 0.0, 0.0))
    return np.array([np.asarray(model.mod.point_jacobian(*across[:, i])) - origin for i in range(2)])


def turned_axis(d: np.ndarray, across: np.ndarray, turn: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The unit axis ``d`` (3) turned by the rotation vector ``turn`` [rad] (2) across it: by the angle a = |turn|
    toward across @ turn (``across``: two orthonormal axes across d, 3 x 2), cos(a) d + sin(a)/a across @ turn;
    and its derivatives by the two components (2, 3)."""
    angle = math.hypot(turn[0], turn[1])
    if angle < SMALL_TURN:
        a2 = angle * angle
        sinc = 1.0 - a2 / 6.0 + a2 * a2 / 120.0
        d_sinc = -1.0 / 3.0 + a2 / 30.0 - a2 * a2 / 840.0  # (d sinc / da) / a
    else:
        sinc = math.sin(angle) / angle
        d_sinc = (angle * math.cos(angle) - math.sin(angle)) / angle**3
    w = across @ turn
    axis = math.cos(angle) * d + sinc * w
    d_axis = np.array([sinc * (across[:, i] - turn[i] * d) + d_sinc * turn[i] * w for i in range(2)])
    return axis, d_axis


def sensor_transform(mod: GeneratedModule, yaw: float, dz: float) -> np.ndarray:
    """Shapes as read by a sensor frame turned by ``yaw`` [rad] about z whose reference point is ``dz`` [m]
    above the origin: translations of that point (the generated point_jacobian) and rotations, both in the
    turned frame (6 x 6)."""
    return _transform(np.asarray(mod.point_jacobian(0.0, 0.0, dz)), _yaw_rotation(yaw, 0))


def sensor_transform_derivative(mod: GeneratedModule, yaw: float, dz: float, wrt: str) -> np.ndarray:
    """d(sensor_transform)/d(yaw) [per rad] (``wrt`` = "yaw") or d/d(dz) [per m] ("dz"). The point
    Jacobian of a rigid body is affine in the point, so its derivative along z is the difference of the
    generated point_jacobian at heights 1 and 0."""
    if wrt == "yaw":
        return _transform(np.asarray(mod.point_jacobian(0.0, 0.0, dz)), _yaw_rotation(yaw, 1))
    along_z = np.asarray(mod.point_jacobian(0.0, 0.0, 1.0)) - np.asarray(mod.point_jacobian(0.0, 0.0, 0.0))
    out = _transform(along_z, _yaw_rotation(yaw, 0))
    out[3:, 3:] = 0.0
    return out


def _yaw_rotation(yaw: float, derivative: int) -> np.ndarray:
    """The rotation from the global to the turned frame (derivative 0) or its derivative by yaw (1)."""
    cz, sz = math.cos(yaw), math.sin(yaw)
    if derivative == 0:
        return np.array([[cz, sz, 0.0], [-sz, cz, 0.0], [0.0, 0.0, 1.0]])
    return np.array([[-sz, cz, 0.0], [-cz, -sz, 0.0], [0.0, 0.0, 0.0]])


def _transform(point_jacobian: np.ndarray, rotation: np.ndarray) -> np.ndarray:
    """Translations of the point in the turned frame (rotation @ point Jacobian), rotations turned (6 x 6)."""
    out = np.zeros((6, 6))
    out[:3] = rotation @ point_jacobian
    out[3:, 3:] = rotation
    return out
