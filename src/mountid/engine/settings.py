"""The size limits of the engine and the form of the code it emits, as one settings object passed
explicitly from generation down to the blocks, the inverse derivation and the code generator. The limits are
size bounds, not time limits, so generation stays byte-for-byte reproducible on any machine; a change of any
field changes what is generated (the cache of description files keys on the engine's source, where the
defaults live)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class EngineSettings:
    """Size limits of the symbolic engine, and the form of the code it generates."""

    max_symbolic_block: int = 3
    """Largest symmetry block whose characteristic polynomial is expanded symbolically (larger blocks are
    solved numerically at run time, frequencies and inverses alike: the rank of a set from the block's modes
    at a generic point, its roots by Newton from a start grid)."""
    max_terms: int = 400
    """Largest polynomial (in terms) the elimination carries on with; beyond it a set is solved numerically."""
    max_substitution: int = 20_000
    """Largest estimated size (terms of an equation times the terms of the substituted solution to the power
    of its degree) of one substitution before it is expanded."""
    factor_terms: int = 60
    """Largest equation whose linear solution is factored when choosing the next elimination step."""
    max_starts: int = 729
    """At most this many starts of a numeric inverse (every combination of the start factors), but at least
    three factors per unknown."""
    fused: bool = False
    """Evaluate each closed-form eigenvalue as one fused numexpr pass (runtime.fused; numpy evaluates the same
    string where numexpr is missing or the batch is small) instead of plain numpy code. The shipped modules
    are generated fused (`make generate`): on 10^6 parameter sets a chain of numpy temporaries is bound by
    memory traffic."""


ENGINE = EngineSettings()
"""The default settings (plain numpy code): a description generated from its file at run time."""

SHIPPED = EngineSettings(fused=True)
"""The settings of the shipped modules in generated/ (`make generate`)."""
