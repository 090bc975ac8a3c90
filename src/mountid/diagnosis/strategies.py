"""How each kind of candidate effect enters the candidate model: one strategy per kind of the effect
registry (:data:`mountid.effects.EFFECT_KINDS`), so the diagnosis never dispatches on an effect's name.

A strategy gives the matrices M, C, B at the parameter values, the model frequencies from the eigenvalues,
the body motion the mode shapes are compared in, whether the effect can act on a campaign at all, and
whether it is fitted once per isolator. The nominal model is the base strategy (no change).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from mountid.effects import Effect
from mountid.machine import GeneratedModule, call, damped_poles

if TYPE_CHECKING:
    from mountid.diagnosis.candidate_model import CandidateModel

Matrices = tuple[np.ndarray, np.ndarray, np.ndarray | None]


class Strategy:
    """The nominal model: M and C of the generated module, undamped frequencies, shapes in q."""

    per_isolator = False
    """Fitted once per isolator (the variant names the isolator), the best one reported."""

    def matrices(self, model: CandidateModel, values: dict[str, float]) -> Matrices:
        """M, C and (where the strategy uses it) B [SI] at ``values``."""
        return call(model.mod, "mass_matrix", values), call(model.mod, "stiffness_matrix", values), None

    def frequencies(self, model: CandidateModel, values: dict[str, float], mats: Matrices, lam: np.ndarray):
        """Model frequencies [rad/s] of every mode, from the generalised eigenvalues ``lam`` of (C, M)."""
        return np.sqrt(np.abs(lam))

    def shapes(self, model: CandidateModel, values: dict[str, float], vectors: np.ndarray) -> np.ndarray:
        """The body motion (6 x n) the measured shapes are compared with."""
        return vectors[:6, :]

    def inapplicable(self, model: CandidateModel, has_shapes: bool) -> str:
        """Why the effect cannot act on this campaign ('' when it can)."""
        return ""


class Generated(Strategy):
    """Energy extensions: the engine's ``effect_<name>()`` gives the extended M, C, B."""

    def matrices(self, model: CandidateModel, values: dict[str, float]) -> Matrices:
        return tuple(call(model.mod, f"effect_{model.effect.name}", values))


class Isolator(Strategy):
    """One isolator's stiffness matrix (the generated ``isolator_stiffness()``) scaled by (1 + scatter)."""

    per_isolator = True

    def matrices(self, model: CandidateModel, values: dict[str, float]) -> Matrices:
        m, c, _ = super().matrices(model, values)
        per = call(model.mod, "isolator_stiffness", values)
        return m, c + values["scatter"] * per[model.isolator], None


class Frequency(Strategy):
    """Rubber stiffening with frequency (standard linear solid): omega^2 = g(omega) lambda."""

    def frequencies(self, model: CandidateModel, values: dict[str, float], mats: Matrices, lam: np.ndarray):
        return stiffened_frequencies(np.abs(lam), values["rubber_strength"], values["rubber_corner"] * model.omega_ref)


class Damping(Strategy):
    """The measured frequencies are damped ones: Im p of M p^2 + eta B p + C = 0."""

    def matrices(self, model: CandidateModel, values: dict[str, float]) -> Matrices:
        m, c, _ = super().matrices(model, values)
        return m, c, call(model.mod, "damping_matrix", values)

    def frequencies(self, model: CandidateModel, values: dict[str, float], mats: Matrices, lam: np.ndarray):
        m, c, b = mats
        return damped_poles(m, c, values["damping_scale"] * b, lam).imag

    def inapplicable(self, model: CandidateModel, has_shapes: bool) -> str:
        if not np.any(call(model.mod, "damping_matrix", model.known | model.start_unknowns)):
            return "the description has no damping: nothing to scale"
        return ""


class Sensor(Strategy):
    """The shapes were read through a sensor frame turned by a yaw angle, its reference point off in height."""

    def shapes(self, model: CandidateModel, values: dict[str, float], vectors: np.ndarray) -> np.ndarray:
        return sensor_transform(model.mod, values["sensor_yaw"], values["sensor_dz"]) @ vectors[:6, :]

    def inapplicable(self, model: CandidateModel, has_shapes: bool) -> str:
        if not has_shapes:
            return "no mode shapes measured: a sensor error leaves the frequencies exactly unchanged"
        return ""


STRATEGIES: dict[str, Strategy] = {
    "generated": Generated(),
    "isolator": Isolator(),
    "frequency": Frequency(),
    "damping": Damping(),
    "sensor": Sensor(),
}
"""One strategy per effect kind; ``tests/test_effect_registry.py`` checks that every kind has one."""

NOMINAL = Strategy()


def strategy(effect: Effect | None) -> Strategy:
    """The strategy of ``effect`` (None: the nominal model)."""
    return NOMINAL if effect is None else STRATEGIES[effect.kind]


def stiffened_frequencies(lam: np.ndarray, beta: float, corner: float) -> np.ndarray:
    """omega solving omega^2 = g(omega) lam, g = 1 + beta y / (y + c), y = omega^2, c = corner^2, for each
    eigenvalue lam of the static stiffness. Multiplied out, y^2 + b y - lam c = 0 with b = c - lam (1 + beta):
    one positive root (the product of the roots is -lam c), taken in the form without cancellation."""
    c = corner**2
    b = c - lam * (1 + beta)
    root = np.sqrt(b * b + 4 * lam * c)
    y = np.where(b > 0, 2 * lam * c / (b + root), (root - b) / 2)
    return np.sqrt(y)


def sensor_transform(mod: GeneratedModule, yaw: float, dz: float) -> np.ndarray:
    """Shapes as read by a sensor frame turned by ``yaw`` [rad] about z whose reference point is ``dz`` [m]
    above the origin: translations of that point (the generated point_jacobian) and rotations, both in the
    turned frame (6 x 6)."""
    jac = np.asarray(mod.point_jacobian(0.0, 0.0, dz))
    cz, sz = math.cos(yaw), math.sin(yaw)
    rot = np.array([[cz, sz, 0.0], [-sz, cz, 0.0], [0.0, 0.0, 1.0]])  # global -> turned frame
    out = np.zeros((6, 6))
    out[:3] = rot @ jac
    out[3:, 3:] = rot
    return out
