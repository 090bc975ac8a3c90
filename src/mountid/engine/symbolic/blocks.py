"""Symmetry blocks of (M, C) and their eigen-solutions.

Mirror symmetry makes M and C block diagonal; for two vertical planes the blocks are {x, theta}, {y, psi},
{z}, {phi}. The blocks are read off the derived matrices (connected components of their non-zero pattern),
never assumed, and each block gets its own characteristic polynomial det(C_b - lambda M_b): a 6x6 determinant
of a general mount is intractable, a 1x1 or 2x2 block is trivial.

Closed forms for 2x2 blocks are produced in a numerically stable arrangement: with M_b = L L^T (Cholesky) and
S = L^-1 C_b L^-T,

    lambda_upper = (s11 + s22)/2 + sqrt(((s11 - s22)/2)^2 + s12^2)
    lambda_lower = (det C_b / det M_b) / lambda_upper

which has no difference of nearly equal numbers: the square root is of a sum of squares and the lower root
comes from the product of the roots (det C_b is a polynomial in which sympy has already cancelled the
terms that would cancel numerically).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from functools import cached_property

import sympy as sp

from mountid.engine.description import MIRROR_PLANES, ModeSpec
from mountid.engine.settings import ENGINE, EngineSettings
from mountid.engine.symbolic.factoring import factor
from mountid.engine.symbolic.model import SymbolicModel, rational_point
from mountid.errors import DescriptionError
from mountid.nomenclature import COORDINATES

LAMBDA = sp.Symbol("lambda", positive=True)
"""Eigenvalue symbol: squared natural frequency [rad^2/s^2]."""

# Sign of each coordinate under the reflection of each mirror plane (rotations are pseudo-vectors).
_PARITY = {
    "yz": {"x": -1, "y": 1, "z": 1, "psi": 1, "theta": -1, "phi": -1},
    "xz": {"x": 1, "y": -1, "z": 1, "psi": -1, "theta": 1, "phi": -1},
}


def square(expr: sp.Expr) -> sp.Expr:
    """expr^2 with the square kept a square: (N / D)^2 as N^2 / cancel(D^2), N unexpanded.

    A signed coupling term N (terms of both signs, e.g. c_h h - c_v a sin(alpha) cos(alpha)) expanded inside
    its square is a sum of large terms of both signs whose rounding can leave a small negative number where
    N vanishes (a decoupled crossing); kept as N**2 it is never negative. D^2 loses the square roots of the
    Cholesky factor.
    """
    num, den = sp.fraction(sp.together(expr))
    return sp.Pow(num, 2) / sp.cancel(den**2)


@dataclass(frozen=True)
class Block:
    """One symmetry block: its coordinate indices into q and its sub-matrices."""

    index: tuple[int, ...]
    M: sp.Matrix
    C: sp.Matrix
    symbolic_limit: int
    """Largest size whose characteristic polynomial is expanded (EngineSettings.max_symbolic_block)."""

    @property
    def coordinates(self) -> tuple[str, ...]:
        return tuple(COORDINATES[i] for i in self.index)

    @property
    def size(self) -> int:
        return len(self.index)

    @cached_property
    def charpoly(self) -> sp.Poly | None:
        """det(C_b - lambda M_b) as a polynomial in lambda, or None for a block too large to expand."""
        if self.size > self.symbolic_limit:
            return None
        det = (self.C - LAMBDA * self.M).det(method="berkowitz")
        return sp.Poly(sp.expand(det), LAMBDA)

    @cached_property
    def stable_terms(self) -> dict[str, sp.Expr]:
        """For a 2x2 block: s11, s22, s12 of S = L^-1 C L^-T, s12^2 (what the eigenvalues need, free of the
        square roots of the Cholesky factor where M_b is diagonal) and det C / det M (see module docstring)."""
        assert self.size == 2
        chol = self.M.cholesky(hermitian=False)
        inv = chol.inv()
        s = (inv * self.C * inv.T).applyfunc(sp.cancel)
        ratio = factor(sp.cancel(sp.expand(self.C.det()) / sp.expand(self.M.det())))
        return {
            "s11": s[0, 0],
            "s22": s[1, 1],
            "s12": s[0, 1],
            "s12_squared": square(s[0, 1]),
            "det_ratio": ratio,
        }

    def eigenvalue_exprs(self) -> list[sp.Expr]:
        """Closed-form eigenvalues, ascending, for blocks of size 1 and 2 (the textbook form, for checks)."""
        if self.size == 1:
            return [sp.cancel(self.C[0, 0] / self.M[0, 0])]
        if self.size == 2:
            t = self.stable_terms
            mean, gap = (t["s11"] + t["s22"]) / 2, sp.sqrt(((t["s11"] - t["s22"]) / 2) ** 2 + t["s12"] ** 2)
            return [mean - gap, mean + gap]
        raise ValueError("closed forms only for blocks of size 1 and 2")


@dataclass(frozen=True)
class Mode:
    """A labelled natural mode: root ``rank`` (1 = lowest) of block ``block`` (index into blocks)."""

    label: str
    block: int
    rank: int
    representative: str
    """The label of the unique frequency this mode shares (itself unless repeated by symmetry)."""


class ModalStructure:
    """Blocks, labelled modes and repeated frequencies of a symbolic model."""

    def __init__(self, model: SymbolicModel, settings: EngineSettings = ENGINE) -> None:
        self.model = model
        self.settings = settings
        self.blocks = self._find_blocks()
        self._check_parity()
        self.twin: list[int] = []
        """For each block, the first block with the same characteristic polynomial (itself if none)."""
        self.modes = self._label_modes()

    def _find_blocks(self) -> tuple[Block, ...]:
        n = len(COORDINATES)
        coupled = [[i == j or self.model.M[i, j] != 0 or self.model.C[i, j] != 0 for j in range(n)] for i in range(n)]
        seen: set[int] = set()
        blocks = []
        for start in range(n):
            if start in seen:
                continue
            component, stack = set(), [start]
            while stack:
                i = stack.pop()
                if i in component:
                    continue
                component.add(i)
                stack.extend(j for j in range(n) if coupled[i][j] and j not in component)
            seen |= component
            idx = tuple(sorted(component))
            blocks.append(
                Block(
                    idx,
                    self.model.M.extract(idx, idx),
                    self.model.C.extract(idx, idx),
                    self.settings.max_symbolic_block,
                )
            )
        return tuple(blocks)

    def _check_parity(self) -> None:
        """A block must not mix coordinates of different parity under a declared plane."""
        for plane in self.model.description.symmetry:
            for block in self.blocks:
                signs = {_PARITY[plane][c] for c in block.coordinates}
                if len(signs) > 1:
                    raise DescriptionError(
                        "symmetry",
                        f"the derived matrices couple {block.coordinates}, which mirror plane {plane} "
                        f"(axis {'xy'[MIRROR_PLANES[plane]]}) keeps apart",
                    )

    def _label_modes(self) -> tuple[Mode, ...]:
        specs = self.model.description.modes
        by_coords = {b.coordinates: k for k, b in enumerate(self.blocks)}
        if specs is None:  # default: within a block, rank r is labelled by the block's r-th coordinate
            specs = tuple(ModeSpec(b.coordinates[r], b.coordinates, r + 1) for b in self.blocks for r in range(b.size))
            specs = tuple(sorted(specs, key=lambda s: COORDINATES.index(s.label)))
        claimed: dict[tuple[int, int], int] = {}
        for i, spec in enumerate(specs):
            if spec.block not in by_coords:
                raise DescriptionError(
                    f"modes[{i}].block",
                    f"{list(spec.block)} is not a symmetry block of the derived matrices; the blocks are "
                    f"{[list(b.coordinates) for b in self.blocks]}",
                )
            key = (by_coords[spec.block], spec.rank)
            if key in claimed:
                raise DescriptionError(
                    f"modes[{i}]",
                    f"block {list(spec.block)} rank {spec.rank} is already labelled by modes[{claimed[key]}]",
                )
            claimed[key] = i
        total = sum(b.size for b in self.blocks)
        if len(claimed) != total:
            raise DescriptionError("modes", f"{total} modes need labels, {len(claimed)} are given")
        # blocks with the same characteristic polynomial share their frequencies (e.g. J_x = J_y, c_x = c_y)
        twin = list(range(len(self.blocks)))
        for k, b in enumerate(self.blocks):
            for j in range(k):
                if twin[j] == j and self._same_spectrum(self.blocks[j], b):
                    twin[k] = j
                    break
        self.twin = twin
        first_label: dict[tuple[int, int], str] = {}
        modes = []
        for spec in specs:
            k = by_coords[spec.block]
            key = (twin[k], spec.rank)
            first_label.setdefault(key, spec.label)
            modes.append(Mode(spec.label, k, spec.rank, first_label[key]))
        return tuple(modes)

    @staticmethod
    def _same_spectrum(a: Block, b: Block) -> bool:
        if a.size != b.size or a.charpoly is None or b.charpoly is None:
            return False
        pa, pb = a.charpoly.all_coeffs(), b.charpoly.all_coeffs()
        return all(sp.cancel(x * pb[0] - y * pa[0]) == 0 for x, y in zip(pa, pb, strict=True))

    def twin_map(self) -> tuple[tuple[str, str, int], ...]:
        """Coordinates exchanged by the symmetry that makes two blocks twins (same characteristic polynomial):
        (coordinate of the first block, its image in the twin block, sign) such that, with s the signs,
        M[image_i, image_j] = s_i s_j M[i, j] and the same for C (e.g. kid300: x -> y with +1, theta -> psi
        with -1, so C[y, psi] = -C[x, theta]). Found by trying every coordinate permutation and sign pattern
        against the derived matrices at two pseudo-random rational points."""
        points = [rational_point(self.model.symbols.values(), seed) for seed in (5, 6)]
        out: list[tuple[str, str, int]] = []
        for k, first in enumerate(self.twin):
            if first == k:
                continue
            a, b = self.blocks[first], self.blocks[k]
            found = None
            for perm in itertools.permutations(range(b.size)):
                for signs in itertools.product((1, -1), repeat=a.size):
                    if signs[0] != 1:  # an overall sign changes nothing: fix the first
                        continue
                    if all(
                        (mb[perm[i], perm[j]] - signs[i] * signs[j] * ma[i, j]).xreplace(pt) == 0
                        for ma, mb in ((a.M, b.M), (a.C, b.C))
                        for pt in points
                        for i in range(a.size)
                        for j in range(i, a.size)
                    ):
                        found = (perm, signs)
                        break
                if found:
                    break
            if found is None:
                raise DescriptionError(
                    "symmetry", f"blocks {a.coordinates} and {b.coordinates} share their spectrum but no map"
                )
            perm, signs = found
            out += [(a.coordinates[i], b.coordinates[perm[i]], signs[i]) for i in range(a.size)]
        return tuple(out)

    @property
    def labels(self) -> tuple[str, ...]:
        return tuple(m.label for m in self.modes)

    @property
    def unique_labels(self) -> tuple[str, ...]:
        """One label per distinct natural frequency, in mode order."""
        return tuple(m.label for m in self.modes if m.representative == m.label)

    def mode(self, label: str) -> Mode:
        return next(m for m in self.modes if m.label == label)

    @property
    def closed_form(self) -> bool:
        """Whether every block has a closed-form eigen-solution (sizes 1 and 2)."""
        return all(b.size <= 2 for b in self.blocks)
