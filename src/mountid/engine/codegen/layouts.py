"""What a generated function is, as data: its signature, docstring and a layout, the body's content with
sympy expressions as leaves and names as strings.

Each layout dataclass is laid out by the template macro of the same name in
``templates/numpy_layouts.jinja``; :func:`mountid.engine.codegen.printing.print_function` turns the sympy
leaves into numpy (or numexpr) source in one pass, with one common-subexpression elimination per function.
No Python source is assembled here: the macros write the statements, ruff formats them.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import sympy as sp

Leaf = Any
"""A sympy expression before printing, its source text after (printing.print_function)."""


@dataclass(frozen=True)
class Call:
    """A call of another generated function by name: ``function(*args)``."""

    function: str
    args: tuple[str, ...]


@dataclass(frozen=True)
class SymmetricMatrix:
    """A symmetric ``size`` x ``size`` matrix output: its non-zero upper-triangle entries (i, j, value),
    assembled at run time by runtime.stack_symmetric (a stack of them: their entries set into one zero array)."""

    size: int
    entries: tuple[tuple[int, int, Leaf], ...]

    @classmethod
    def of(cls, matrix: sp.Matrix) -> SymmetricMatrix:
        n = matrix.shape[0]
        return cls(n, tuple((i, j, matrix[i, j]) for i in range(n) for j in range(i, n) if matrix[i, j] != 0))


@dataclass(frozen=True)
class Matrices:
    """Layout ``matrices``: symmetric matrices from one cse over all their entries, returned alone or as a
    tuple; ``bases``: calls whose results the matrices are added to, in order, and further calls returned
    after them; ``stacked``: instead, the matrices stacked on a new axis -3 (``()``), reshaped to
    (*batch, *stacked) when not empty."""

    matrices: tuple[SymmetricMatrix, ...]
    bases: tuple[Call, ...] = ()
    stacked: tuple[int, ...] | None = None


@dataclass(frozen=True)
class Filled:
    """Layout ``filled``: a zero array of shape (*batch, *shape) with ``entries`` (i, j, value) set."""

    shape: tuple[int, int]
    entries: tuple[tuple[int, int, Leaf], ...]


@dataclass(frozen=True)
class Mapping:
    """Layout ``mapping``: a dict of named values from one cse."""

    items: tuple[tuple[str, Leaf], ...]


@dataclass(frozen=True)
class PairBlock:
    """A 2x2 symmetry block of a closed-form eigen-solve, in the stable arrangement of
    mountid.engine.symbolic.blocks: the upper root from a sum of squares (s11, s22, s12^2 of the
    Cholesky-scaled stiffness), the lower from the root product det C / det M."""

    coordinates: tuple[str, ...]
    upper: int
    lower: int
    s11: Leaf
    s22: Leaf
    s12_squared: Leaf
    det_ratio: Leaf


@dataclass(frozen=True)
class SingleBlock:
    """A 1x1 symmetry block of a closed-form eigen-solve: its one eigenvalue into row ``row``."""

    coordinates: tuple[str, ...]
    row: int
    value: Leaf


@dataclass(frozen=True)
class ClosedFormEigen:
    """Layout ``closed_form_eigen``: the squared frequencies block by block into rows of (modes, *batch);
    ``copies`` (row, source): modes repeated by symmetry; ``fused``: each root in one numexpr pass over
    ``variables`` (runtime.fused) instead of numpy operations."""

    modes: int
    blocks: tuple[PairBlock | SingleBlock, ...]
    copies: tuple[tuple[int, int], ...]
    fused: bool


@dataclass(frozen=True)
class NumericBlock:
    """One block of a numeric eigen-solve: its coordinate indices, the modes it holds and their ranks."""

    index: tuple[int, ...]
    positions: tuple[int, ...]
    ranks: tuple[int, ...]


@dataclass(frozen=True)
class NumericEigen:
    """Layout ``numeric_eigen``: a generalised eigen-solve per block (runtime.block_eigen) of the matrices
    the two calls return."""

    mass: Call
    stiffness: Call
    blocks: tuple[NumericBlock, ...]


@dataclass(frozen=True)
class ForwardModel:
    """Layout ``forward_model``: the flat-parameter forward map the Newton polish of every inverse works on."""

    known: tuple[str, ...]
    unknowns: tuple[str, ...]
    frequencies: Call
    mass: Call
    stiffness: Call
    gradient: Call


@dataclass(frozen=True)
class Step:
    """``unknown = value`` after the unknowns assigned before it (back-substitution): printed with its own
    cse, so no subexpression is hoisted above the assignment of an unknown it contains."""

    unknown: str
    value: Leaf
    temporaries: tuple[tuple[str, str], ...] = ()


@dataclass(frozen=True)
class Roots:
    """Layout ``roots``: the candidate roots of a closed-form inverse. ``last`` is a root of each factor
    (its coefficients, highest power first, from one cse), then ``steps`` give the other unknowns."""

    factors: tuple[tuple[Leaf, ...], ...]
    last: str
    steps: tuple[Step, ...]
    unknowns: tuple[str, ...]


@dataclass(frozen=True)
class Inverse:
    """Layout ``inverse``: an identify_<set>() function, runtime.solve_inverse on candidate roots (the
    closed-form ``roots`` function, with ``special`` (index into ``known``, function) where a known
    parameter is 0), or a start grid (``start``, ``factors``) of Newton steps when ``roots`` is None."""

    roots: str | None
    known: tuple[str, ...]
    omegas: tuple[str, ...]
    mode_index: tuple[int, ...]
    n_roots: int
    start: tuple[float, ...] | None
    special: tuple[tuple[int, str], ...] = ()
    factors: tuple[float, ...] = ()


Layout = Matrices | Filled | Mapping | ClosedFormEigen | NumericEigen | ForwardModel | Roots | Inverse


@dataclass(frozen=True)
class Function:
    """One generated function: signature, docstring, the layout of its body (``layout``, whose class names
    the template macro), and how its sympy leaves are printed: ``cse`` over all of them at once or each
    alone, with the numpy or the numexpr printer. ``temporaries``: the cse's assignments, once printed."""

    name: str
    args: tuple[str, ...]
    doc: str
    layout: Layout
    cse: bool = True
    printer: str = "numpy"
    convert: bool = True
    """Whether the arguments are converted to float arrays on entry (public functions)."""
    temporaries: tuple[tuple[str, str], ...] = ()
    depends: tuple[str, ...] | None = None
    """The arguments its result depends on, in the order of ``args`` (the others only broadcast its batch shape),
    once printed: the free symbols of its sympy leaves and the arguments of the functions it calls, for the
    layouts whose leaves and calls are all of its body (matrices, filled, mapping); None for the others."""

    @property
    def macro(self) -> str:
        """The template macro laying out the body: the layout's class name in snake case."""
        name = type(self.layout).__name__
        return "".join(f"_{c.lower()}" if c.isupper() else c for c in name).lstrip("_")
