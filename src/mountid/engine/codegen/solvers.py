"""The generated solvers of a machine module: the eigen-solve of every symmetry block (closed form for
2 x 2, numeric otherwise) and the inverse solutions (closed-form roots with back-substitution, specialised
forms at special points, numeric inverses from a start grid)."""

from __future__ import annotations

import sympy as sp

from mountid.engine.codegen.layouts import (
    Call,
    ClosedFormEigen,
    Function,
    Inverse,
    NumericBlock,
    NumericEigen,
    PairBlock,
    Roots,
    SingleBlock,
    Step,
)
from mountid.engine.codegen.printing import describe, print_function
from mountid.engine.settings import EngineSettings
from mountid.engine.symbolic.blocks import ModalStructure
from mountid.engine.symbolic.inverse import InverseSet
from mountid.engine.symbolic.model import SymbolicModel
from mountid.errors import DescriptionError


def eigen_function(structure: ModalStructure, model: SymbolicModel) -> Function:
    """squared_frequencies(): closed form per block where every block is 2x2 or smaller (one fused numexpr pass
    per distinct eigenvalue with ``structure.settings.fused``, plain numpy code otherwise), else a numeric
    eigen-solve per block."""
    blocks = structure.blocks
    args = model.parameters_of(model.M, model.C)
    labels = structure.labels
    doc_lines = []
    if structure.closed_form:
        # each distinct eigenvalue is written into its row of (modes, *batch), returned with the modes on the
        # last axis; fused: one numexpr pass each (a chain of numpy operations on large batches is bound by
        # memory traffic and by the first touch of every temporary)
        twin = structure.twin  # a block with a twin's characteristic polynomial reuses its roots
        laid_out: list[PairBlock | SingleBlock] = []
        rows: dict[tuple[int, int], int] = {}  # (block, rank) -> row holding that root
        for k, b in enumerate(blocks):
            coords = ", ".join(b.coordinates)
            if twin[k] != k:
                doc_lines.append(
                    f"        block {{{coords}}}: the roots of block {{{', '.join(blocks[twin[k]].coordinates)}}}"
                )
                continue
            first = {m.rank: i for i, m in reversed(list(enumerate(structure.modes))) if twin[m.block] == k}
            if b.size == 2:
                t = b.stable_terms
                laid_out.append(
                    PairBlock(b.coordinates, first[2], first[1], t["s11"], t["s22"], t["s12_squared"], t["det_ratio"])
                )
                lo, hi = b.eigenvalue_exprs()
                doc_lines.append(f"        block {{{coords}}}: lambda = {describe(lo)}  and  {describe(hi)}")
            else:
                laid_out.append(SingleBlock(b.coordinates, first[1], b.eigenvalue_exprs()[0]))
                doc_lines.append(f"        block {{{coords}}}: lambda = {describe(b.eigenvalue_exprs()[0])}")
            rows.update({(k, r): i for r, i in first.items()})
        copies = tuple(
            (i, rows[(twin[m.block], m.rank)])
            for i, m in enumerate(structure.modes)
            if rows[(twin[m.block], m.rank)] != i
        )
        fused = structure.settings.fused
        layout = ClosedFormEigen(len(structure.modes), tuple(laid_out), copies, fused)
        method = (
            "Closed form per symmetry block (textbook form below; evaluated in the stable arrangement of\n"
            "    mountid.engine.symbolic.blocks: no difference of nearly equal numbers)"
        )
        printer = "numexpr" if fused else "numpy"
    else:
        numeric = []
        for k, b in enumerate(blocks):
            pos = tuple(i for i, m in enumerate(structure.modes) if m.block == k)
            numeric.append(NumericBlock(b.index, pos, tuple(structure.modes[i].rank - 1 for i in pos)))
            doc_lines.append(f"        block {{{', '.join(b.coordinates)}}}: numeric (size {b.size})")
        layout = NumericEigen(
            Call("mass_matrix", model.parameters_of(model.M)),
            Call("stiffness_matrix", model.parameters_of(model.C)),
            tuple(numeric),
        )
        method = "Numeric generalised eigen-solve per symmetry block (no closed form for blocks above 2x2)"
        printer = "numpy"
    doc = (
        f"Squared natural frequencies lambda = omega^2 [rad^2/s^2], shape (..., {len(labels)}), modes\n"
        f"    {', '.join(labels)}.\n\n    {method}:\n\n" + "\n".join(doc_lines) + "\n"
    )
    return print_function(Function("squared_frequencies", args, doc, layout, cse=False, printer=printer))


def _roots_function(s: InverseSet, name: str, known: tuple[str, ...], unknowns: tuple[str, ...], doc: str) -> Function:
    """The closed-form candidate roots of one inverse solution: roots of the univariate factors (their
    coefficients from one cse), then the back-substitutions, each unknown of shape (n_roots, ...)."""
    lam_subs = {sp.Symbol(f"lambda_{lab}", positive=True): sp.Symbol(f"_lam_{lab}") for lab in s.labels}
    layout = Roots(
        tuple(tuple(c.subs(lam_subs) for c in f.all_coeffs()) for f in s.factors),
        s.last,
        tuple(Step(u, e.subs(lam_subs)) for u, e in s.back_substitution),
        unknowns,
    )
    args = known + tuple(f"_lam_{lab}" for lab in s.labels)
    return print_function(Function(name, args, doc, layout, convert=False))


def start_factors(n_unknowns: int, max_starts: int) -> tuple[float, ...]:
    """Factors on the (level-matched) nominal unknowns whose every combination starts a numeric inverse
    (runtime.start_grid): 10^(-1 .. 1) in the most equal steps (an odd count, so 1 is one of them) that
    keep the grid within ``max_starts`` (EngineSettings). Three per decade pair missed genuine roots of
    2-unknown problems (skid1plane z, phi has three exact solutions; 0.1, 1, 10 found two of them)."""
    count = 3
    while (count + 2) ** n_unknowns <= max_starts and count < 9:
        count += 2
    return tuple(round(10 ** (2 * i / (count - 1) - 1), 12) for i in range(count))


def root_slots(s: InverseSet, n_unknowns: int, settings: EngineSettings) -> int:
    """Candidate roots per row of an inverse: the start grid of a numeric one, else the closed forms' most."""
    if s.numeric:
        return len(start_factors(n_unknowns, settings.max_starts)) ** n_unknowns
    return max((s.n_roots, *(special.n_roots for _, special in s.special)))


def _numeric_inverse_function(
    s: InverseSet, structure: ModalStructure, model: SymbolicModel, fwd_args: tuple[str, ...]
) -> Function:
    """identify_<set> for a set the frequencies determine but with no closed form of manageable size:
    Newton (runtime.eigen_newton) from a grid of starts around the nominal unknowns, then the same
    admissibility, deduplication and conditioning as a closed-form inverse."""
    d = model.description
    omegas = tuple(f"omega_{label}" for label in s.labels)
    known = tuple(a for a in fwd_args if a not in d.unknown)
    start = tuple(d.parameters[u].value for u in d.unknown)
    for u, v in zip(d.unknown, start, strict=True):
        if v is None:
            raise DescriptionError(f"parameters.{u}.value", f"needed as the start of the numeric inverse {s.name}")
    n_roots = root_slots(s, len(d.unknown), structure.settings)
    mode_index = tuple(structure.labels.index(lab) for lab in s.labels)
    factors = start_factors(len(d.unknown), structure.settings.max_starts)
    layout = Inverse(None, known, omegas, mode_index, n_roots, start, factors=factors)
    doc = (
        f"Unknowns {', '.join(d.unknown)} from the natural frequencies {', '.join(omegas)} [rad/s], numerically.\n\n"
        f"    These frequencies determine the unknowns, but the engine found {s.reason.split(' (')[0]}: damped\n"
        "    (Levenberg-Marquardt) steps in the logarithms of the unknowns, then Newton steps, on the stable\n"
        "    forward map start from the nominal unknowns, scaled to the level of the given frequencies, times\n"
        f"    every combination of {len(factors)} factors from 0.1 to 10 in equal ratios ({n_roots} starts), then\n"
        "    midway between every two roots found (a root between two others has a narrow basin). A start whose\n"
        "    steps stop halving its residual is given up (mountid.runtime.inverse: LM_STALL, STALL_STEPS). A root\n"
        "    outside all their basins (unknowns in ratios far from the nominal ones) is missed.\n"
        "    Returns InverseRoots (mountid.runtime) as a closed-form inverse does, one row per start.\n"
    )
    return Function(f"identify_{s.name}", known + omegas, doc, layout)


def inverse_functions(
    s: InverseSet, structure: ModalStructure, model: SymbolicModel, fwd_args: tuple[str, ...]
) -> list[Function]:
    if s.numeric:
        return [_numeric_inverse_function(s, structure, model, fwd_args)]
    d = model.description
    omegas = tuple(f"omega_{label}" for label in s.labels)
    known = tuple(a for a in fwd_args if a not in d.unknown)
    unknowns = d.unknown
    candidates = [
        _roots_function(
            s,
            f"_roots_{s.name}",
            known,
            unknowns,
            f"Candidate roots of identify_{s.name}() in closed form, each unknown of shape ({s.n_roots}, ...).\n",
        )
    ]
    for param, special in s.special:
        candidates.append(
            _roots_function(
                special,
                f"_roots_{s.name}__{param}_0",
                known,
                unknowns,
                f"Candidate roots of identify_{s.name}() where {param} = 0 (the general closed form is 0/0\n"
                f"    there), each unknown of shape ({special.n_roots}, ...); solved by the engine with {param} = 0.\n",
            )
        )
    mode_index = tuple(structure.labels.index(lab) for lab in s.labels)
    n_roots = root_slots(s, len(unknowns), structure.settings)
    special = tuple((known.index(param), f"_roots_{s.name}__{param}_0") for param, _ in s.special)
    start = tuple(d.parameters[u].value for u in unknowns)
    layout = Inverse(f"_roots_{s.name}", known, omegas, mode_index, n_roots, None if None in start else start, special)
    poly_text = "\n".join(f"        {describe(f.as_expr())} = 0" for f in s.factors)
    back_text = "\n".join(f"        {u} = {describe(e)}" for u, e in s.back_substitution)
    given = ", ".join(f"omega_{lab}" for lab in s.labels)
    special_text = "".join(
        f"\n    Where {param} = 0 the closed form above is 0/0; there {sp_.last} is a root of\n\n"
        + "\n".join(f"        {describe(f.as_expr())} = 0" for f in sp_.factors)
        + "\n"
        + (
            "\n    and then\n\n" + "\n".join(f"        {u} = {describe(e)}" for u, e in sp_.back_substitution) + "\n"
            if sp_.back_substitution
            else ""
        )
        for param, sp_ in s.special
    )
    doc = (
        f"Unknowns {', '.join(unknowns)} from the natural frequencies {given} [rad/s].\n\n"
        f"    Returns InverseRoots (mountid.runtime): each unknown as an array of shape ({n_roots}, ...) [SI\n"
        "    units], one row per root, the mask of the admissible ones, each root's relative condition number\n"
        "    and Jacobian d(omega)/d(unknowns) (InverseRoots.std() gives the unknowns' standard deviations from\n"
        "    the frequencies'), and the mask of roots that reproduce the frequencies but leave an unknown\n"
        "    undetermined (a rank-deficient point; InverseRoots.undetermined() names it).\n\n"
        f"    Derivation (lambda = omega^2): {s.last} is a root of\n\n{poly_text}\n"
        + (f"\n    and then\n\n{back_text}\n" if back_text else "")
        + special_text
        + "\n    Root choice: a root is admissible when every unknown is positive and finite, each given\n"
        "    frequency is reproduced by the mode it is labelled as (rel. 1e-11) and the frequencies determine\n"
        "    the unknowns there (full rank): a root that puts a given frequency on the other mode of its block\n"
        "    is rejected, and a row whose given frequency is not positive and finite has none (a negative\n"
        "    omega is not its positive twin). All admissible roots are returned; where several remain (both\n"
        "    roots of a block given), the data alone cannot choose between them and the choice is physical\n"
        "    (the paper keeps c_z > c_xy for its isolators).\n"
    )
    return [*candidates, Function(f"identify_{s.name}", known + omegas, doc, layout)]
