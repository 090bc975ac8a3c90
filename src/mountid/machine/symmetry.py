"""The mirror symmetry of a machine on its isolators and of its modes: a mode symmetric or antisymmetric in a mirror
plane of the machine stays so under any change that keeps the plane (hardening rubber, mountid.diagnosis.strategies;
the blind harness's hardening isolators, mountid.validation.blind_truth). Rounding does not: where a mode of the
other parity lies close, an iteration amplifies it, and keeping each mode's parity keeps it where it was."""

from __future__ import annotations

import math

import numpy as np

MIRRORS = (np.diag([-1.0, 1.0, 1.0, 1.0, -1.0, -1.0]), np.diag([1.0, -1.0, 1.0, -1.0, 1.0, -1.0]))
"""The body's coordinates (x, y, z, rotations about x, y, z) mirrored in the yz and in the xz plane (the rotations
pseudo-vectors)."""


def mirror_planes(m: np.ndarray, c: np.ndarray) -> list[np.ndarray]:
    """The MIRRORS the body's mass and stiffness (``m``, ``c``: 6 x 6) are symmetric in (none for a model with
    more coordinates)."""
    if m.shape != (6, 6):
        return []
    return [
        mirror
        for mirror in MIRRORS
        if all(np.allclose(mirror @ a @ mirror, a, rtol=0, atol=1e-12 * np.abs(a).max()) for a in (m, c))
    ]


def parities(mirrors: list[np.ndarray], m: np.ndarray, phi: np.ndarray) -> list[tuple[np.ndarray, float]]:
    """Of the machine's ``mirrors`` (mirror_planes), those the shape ``phi`` is symmetric or antisymmetric in (to
    1e-6 of its norm in ``m``), with its sign (+1 or -1) in each."""
    out = []
    for mirror in mirrors:
        sign = float(phi @ m @ (mirror @ phi) / (phi @ m @ phi))
        if abs(abs(sign) - 1) < 1e-6:
            out.append((mirror, math.copysign(1.0, sign)))
    return out


def with_parities(step: np.ndarray, kept: list[tuple[np.ndarray, float]], m: np.ndarray) -> np.ndarray:
    """``step`` projected on the parities ``kept`` (parities) and M-normalised again (itself where none is kept)."""
    if not kept:
        return step
    for mirror, sign in kept:
        step = (step + sign * (mirror @ step)) / 2
    return step / math.sqrt(step @ m @ step)


def parity_signs(mirrors: list[np.ndarray], m: np.ndarray, shapes: np.ndarray) -> np.ndarray:
    """Each shape's (columns of ``shapes``) sign in each of ``mirrors`` (parities): shape (mirrors, shapes), 0 where
    the shape has no parity in that mirror."""
    signs = np.zeros((len(mirrors), shapes.shape[1]))
    for j in range(shapes.shape[1]):
        for mirror, sign in parities(mirrors, m, shapes[:, j]):
            signs[next(k for k, other in enumerate(mirrors) if other is mirror), j] = sign
    return signs


def with_parity_signs(steps: np.ndarray, signs: np.ndarray, mirrors: list[np.ndarray], m: np.ndarray) -> np.ndarray:
    """with_parities for every column of ``steps`` at once, each by its ``signs`` (parity_signs), in place."""
    for k, mirror in enumerate(mirrors):
        half = signs[k] != 0
        steps[:, half] = (steps[:, half] + signs[k, half] * (mirror @ steps[:, half])) / 2
    keeps = signs.any(axis=0)
    steps[:, keeps] /= np.sqrt(np.einsum("aj,ab,bj->j", steps[:, keeps], m, steps[:, keeps]))
    return steps
