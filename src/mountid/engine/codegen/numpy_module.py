"""Build the numpy module of one description: function bodies from sympy, laid out by a jinja2 template.

Every formula in the output comes from :mod:`mountid.engine.symbolic`; this module only arranges them
(argument lists, cse, array assembly) and hands them to ``templates/numpy_module.py.jinja``.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from importlib import resources

import jinja2
import sympy as sp

from mountid.effects import EFFECTS
from mountid.engine.codegen.printing import code, describe, eliminate, fused
from mountid.engine.description import Description
from mountid.engine.symbolic.blocks import ModalStructure
from mountid.engine.symbolic.effects import GENERATED_EFFECTS, ExtendedModel, isolator_stiffness, scales
from mountid.engine.symbolic.inverse import InverseDerivation, InverseSet
from mountid.engine.symbolic.model import SymbolicModel
from mountid.errors import DescriptionError
from mountid.nomenclature import COORDINATES

TEMPLATE = "numpy_module.py.jinja"
SYMPY_VERSION = "1.14.0"
"""The sympy release generation is pinned to (cse output and printing change between releases)."""


@dataclass
class Function:
    """One generated function: signature, docstring, body lines and return expression."""

    name: str
    args: tuple[str, ...]
    doc: str
    body: list[str] = field(default_factory=list)
    returns: str = ""
    convert: bool = True
    """Whether the arguments are converted to float arrays on entry (public functions)."""


def _shape_line(args: tuple[str, ...]) -> str:
    """The generated line computing the broadcast batch shape of a function's arguments."""
    return f"_shape = numpy.broadcast_shapes({', '.join(f'numpy.shape({a})' for a in args)})"


def _matrix_function(name: str, matrix: sp.Matrix, model: SymbolicModel, what: str, unit_note: str) -> Function:
    args = model.parameters_of(matrix)
    entries = {(i, j): matrix[i, j] for i in range(6) for j in range(i, 6) if matrix[i, j] != 0}
    cse = eliminate(list(entries.values()))
    formula = "\n".join(
        f"        [{COORDINATES[i]}, {COORDINATES[j]}] = {describe(e)}" for (i, j), e in entries.items()
    )
    doc = (
        f"{what} [{unit_note}], shape (..., 6, 6), coordinates {', '.join(COORDINATES)}.\n\n"
        f"    Non-zero entries of the upper triangle (the matrix is symmetric):\n\n{formula}\n"
    )
    fn = Function(name, args, doc)
    fn.body = [f"{lhs} = {rhs}" for lhs, rhs in cse.lines]
    pairs = ", ".join(f"({i}, {j}): {out}" for (i, j), out in zip(entries, cse.outputs, strict=True))
    fn.body.append(_shape_line(args))
    fn.returns = f"_runtime.stack_matrix(_shape, 6, {{{pairs}}})"
    return fn


def _matrices_function(
    name: str,
    matrices: dict[str, sp.Matrix],
    coordinates: tuple[str, ...],
    args: tuple[str, ...],
    doc: str,
    base: dict[str, str] | None = None,
) -> Function:
    """A function returning several symmetric matrices (one cse over all of them) as a tuple; ``base``: per
    matrix, code of a matrix the entries are added to, and further outputs (label -> code) after them."""
    n = len(coordinates)
    entries = [(k, i, j, mat[i, j]) for k, mat in enumerate(matrices.values()) for i in range(n) for j in range(i, n)]
    entries = [e for e in entries if e[3] != 0]
    cse = eliminate([e[3] for e in entries])
    lines = []
    for k, label in enumerate(matrices):
        lines.append(f"        {label}:")
        lines += [
            f"          [{coordinates[i]}, {coordinates[j]}] = {describe(e)}" for kk, i, j, e in entries if kk == k
        ]
    fn = Function(name, args, doc + "\n    Non-zero upper-triangle entries:\n\n" + "\n".join(lines) + "\n")
    fn.body = [f"{lhs} = {rhs}" for lhs, rhs in cse.lines]
    fn.body.append(_shape_line(args))
    outs = []
    for k in range(len(matrices)):
        pairs = ", ".join(
            f"({i}, {j}): {out}" for (kk, i, j, _), out in zip(entries, cse.outputs, strict=True) if kk == k
        )
        outs.append(f"_runtime.stack_matrix(_shape, {n}, {{{pairs}}})")
    if base:
        outs = [f"{base[label]} + {out}" for label, out in zip(matrices, outs, strict=True)]
        outs += [code for label, code in base.items() if label not in matrices]
    fn.returns = f"({', '.join(outs)})" if len(outs) > 1 else outs[0]
    return fn


EffectFunctions = tuple[list[Function], dict[str, tuple[str, ...]], tuple[str, ...]]


def effect_functions(model: SymbolicModel) -> EffectFunctions:
    """Extended matrices of every generated effect, the isolators' own stiffness matrices, the scales.

    Returns the functions, the coordinates of each effect's extended model, and the isolator names.
    """
    functions = []
    coords = {}
    nominal_args = {
        "M": model.parameters_of(model.M),
        "C": model.parameters_of(model.C),
        "B": model.parameters_of(model.B),
    }
    for name in GENERATED_EFFECTS:
        ext = ExtendedModel(model, EFFECTS[name])
        coords[name] = ext.coordinates
        n = len(ext.coordinates)
        doc = (
            f"M, C, B of the model extended by the candidate effect {name} ({EFFECTS[name].title}),\n"
            f"    each of shape (..., {n}, {n}), coordinates {', '.join(ext.coordinates)}; derived from the\n"
            "    extended energies (mountid.engine.symbolic.effects).\n"
        )
        if n > 6:
            fn = _matrices_function(
                f"effect_{name}", {"M": ext.M, "C": ext.C, "B": ext.B}, ext.coordinates, ext.arguments(), doc
            )
        else:
            added = {"M": ext.added_M, "C": ext.added_C}
            own = model.parameters_of(model.M, model.C, model.B)
            extra = tuple(p.name for p in EFFECTS[name].parameters)
            calls = {
                k: f"{fn_name}({', '.join(nominal_args[k])})"
                for k, fn_name in (("M", "mass_matrix"), ("C", "stiffness_matrix"), ("B", "damping_matrix"))
            }
            fn = _matrices_function(
                f"effect_{name}",
                added,
                ext.coordinates,
                own + extra,
                doc + "    The nominal matrices plus the Hessians of the added energies (B is the nominal one):\n",
                base=calls,
            )
        functions.append(fn)
    per = isolator_stiffness(model)
    names = tuple(iso.name for iso in model.isolators)
    args = model.parameters_of(*per)
    fn = _matrices_function(
        "isolator_stiffness",
        dict(zip(names, per, strict=True)),
        COORDINATES,
        args,
        f"Stiffness matrix of each isolator alone, shape (..., {len(per)}, 6, 6), isolators in the order of\n"
        "    ISOLATORS; their sum is stiffness_matrix().\n",
    )
    fn.returns = f"numpy.stack([{fn.returns[1:-1]}], axis=-3)" if len(per) > 1 else f"{fn.returns}[..., None, :, :]"
    functions.append(fn)
    sc = scales(model)
    args = model.parameters_of(*sc.values())
    cse = eliminate(list(sc.values()))
    fn = Function(
        "effect_scales",
        args,
        "Machine scales for the plausible ranges of the candidate effects (mountid.effects), as a dict:\n\n"
        + "\n".join(f"        {k} = {describe(v)}" for k, v in sc.items())
        + "\n",
    )
    fn.body = [f"{lhs} = {rhs}" for lhs, rhs in cse.lines]
    fn.returns = "{" + ", ".join(f'"{k}": {out}' for k, out in zip(sc, cse.outputs, strict=True)) + "}"
    functions.append(fn)
    return functions, coords, names


def _point_function(model: SymbolicModel) -> Function:
    """du/dq at body points: sensors read it, forces act through its transpose."""
    jac = model.point_jacobian
    args = tuple(str(s) for s in model.POINT)
    entries = {(i, j): jac[i, j] for i in range(3) for j in range(6) if jac[i, j] != 0}
    formula = "\n".join(f"        [{'xyz'[i]}, {COORDINATES[j]}] = {describe(e)}" for (i, j), e in entries.items())
    doc = (
        "Jacobian du/dq of the displacement u [m] of the body point (r_x, r_y, r_z) [m] (from the coordinate\n"
        "    origin) with respect to q, shape (..., 3, 6). A sensor there along the unit direction d reads\n"
        "    d^T (du/dq) q; a force F there acts on the coordinates as (du/dq)^T F.\n\n"
        f"    Non-zero entries:\n\n{formula}\n"
    )
    fn = Function("point_jacobian", args, doc)
    fn.body = [_shape_line(args), "_out = numpy.zeros((*_shape, 3, 6))"]
    fn.body += [f"_out[..., {i}, {j}] = {code(e)}" for (i, j), e in entries.items()]
    fn.returns = "_out"
    return fn


def _stiffness_gradient(model: SymbolicModel) -> list[sp.Matrix]:
    return [model.C.diff(model.symbols[u]) for u in model.description.unknown]


def gradient_arguments(model: SymbolicModel) -> tuple[str, ...]:
    """Arguments of the generated stiffness_gradient(): the parameters dC/d(unknowns) depends on."""
    return model.parameters_of(*_stiffness_gradient(model))


def _gradient_function(model: SymbolicModel) -> Function:
    """dC/d(unknown) for each unknown: the matrices of the eigenvalue derivatives phi^T dC phi."""
    args = gradient_arguments(model)
    unknowns = model.description.unknown
    mats = _stiffness_gradient(model)
    entries = [
        ((k, i, j), mat[i, j]) for k, mat in enumerate(mats) for i in range(6) for j in range(i, 6) if mat[i, j] != 0
    ]
    cse = eliminate([e for _, e in entries])
    fn = Function(
        "stiffness_gradient",
        args,
        f"Derivatives dC/d({', '.join(unknowns)}) of the stiffness matrix, shape (..., {len(unknowns)}, 6, 6).\n",
    )
    fn.body = [f"{lhs} = {rhs}" for lhs, rhs in cse.lines]
    fn.body.append(_shape_line(args))
    per = []
    for k in range(len(unknowns)):
        pairs = ", ".join(
            f"({i}, {j}): {out}" for ((kk, i, j), _), out in zip(entries, cse.outputs, strict=True) if kk == k
        )
        per.append(f"_runtime.stack_matrix(_shape, 6, {{{pairs}}})")
    fn.returns = f"numpy.stack([{', '.join(per)}], axis=-3)"
    return fn


def _derivative_function(
    name: str, model: SymbolicModel, parameters: tuple[str, ...], matrices: dict[str, sp.Matrix], doc: str
) -> Function:
    """Derivatives of ``matrices`` with respect to each of ``parameters``, differentiated by sympy, stacked
    as (..., n_parameters, n_matrices, 6, 6)."""
    derivs = {f"d{k}/d{p}": mat.diff(model.symbols[p]) for p in parameters for k, mat in matrices.items()}
    args = model.parameters_of(*matrices.values())
    fn = _matrices_function(name, derivs, COORDINATES, args, doc)
    inner = fn.returns[1:-1] if len(derivs) > 1 else fn.returns
    fn.returns = f"numpy.stack([{inner}], axis=-3).reshape(*_shape, {len(parameters)}, {len(matrices)}, 6, 6)"
    return fn


def derivative_functions(model: SymbolicModel, fwd_args: tuple[str, ...]) -> list[Function]:
    """matrix_derivatives() (M, C, B with respect to every parameter they depend on) and the private
    _mc_derivatives() (M, C with respect to the forward arguments) that squared_frequency_derivatives() uses."""
    every = model.parameters_of(model.M, model.C, model.B)
    return [
        _derivative_function(
            "matrix_derivatives",
            model,
            every,
            {"M": model.M, "C": model.C, "B": model.B},
            "Derivatives of M, C, B with respect to every parameter they depend on, shape\n"
            f"    (..., {len(every)}, 3, 6, 6): [..., k, (M, C, B), :, :] = d(matrix)/d(DERIVATIVE_PARAMETERS[k]),\n"
            "    differentiated by sympy.\n",
        ),
        _derivative_function(
            "_mc_derivatives",
            model,
            fwd_args,
            {"M": model.M, "C": model.C},
            "dM/dp and dC/dp for p in FORWARD_ARGUMENTS, shape (..., n, 2, 6, 6).\n",
        ),
    ]


def _model_function(model: SymbolicModel, fwd_args: tuple[str, ...]) -> Function:
    """The forward model the Newton polish of every inverse works on (runtime.eigen_newton).

    The polish works on the frequencies themselves (stable forward map, dlambda/dtheta = phi^T dC/dtheta phi):
    the elimination formulas can lose digits where a mode sits near an uncoupled frequency.
    """
    d = model.description
    known = tuple(a for a in fwd_args if a not in d.unknown)
    m_args, c_args = model.parameters_of(model.M), model.parameters_of(model.C)
    body = [
        f"{', '.join(known)}{',' if len(known) == 1 else ''} = _known",
        f"{', '.join(d.unknown)}{',' if len(d.unknown) == 1 else ''} = _unknowns.T",
        f"_lam = squared_frequencies({', '.join(fwd_args)})",
        "if not _modes:",
        "    return _lam, None, None",
        f"_phi = _runtime.modal_matrix(mass_matrix({', '.join(m_args)}), stiffness_matrix({', '.join(c_args)}), "
        "_lam, BLOCKS, MODE_BLOCK, MODE_RANK)",
    ]
    g_args = gradient_arguments(model)
    doc = (
        "Squared frequencies, and with ``_modes`` the modal matrix and dC/d(unknowns), at flat parameters:\n"
        f"    ``_known`` = ({', '.join(known)}) of shape (N,), ``_unknowns`` of shape (N, {len(d.unknown)}).\n"
    )
    return Function(
        "_model",
        ("_known", "_unknowns", "_modes"),
        doc,
        body,
        f"_lam, _phi, stiffness_gradient({', '.join(g_args)})",
        convert=False,
    )


def _eigen_function(structure: ModalStructure, model: SymbolicModel) -> Function:
    blocks = structure.blocks
    matrices = (model.M, model.C)
    args = model.parameters_of(*matrices)
    labels = structure.labels
    doc_lines = []
    if structure.closed_form:
        # each distinct eigenvalue is one fused numexpr pass (a chain of numpy operations on large batches
        # is bound by memory traffic and by the first touch of every temporary): written into its row of
        # _out (a view, 0-d for scalar input, hence [i, ...]), returned with the modes on the last axis
        twin = structure.twin  # a block with a twin's characteristic polynomial reuses its roots
        variables = ", ".join(f"{a!r}: {a}" for a in map(str, args))
        body = [_shape_line(args), f"_out = numpy.empty(({len(structure.modes)}, *_shape))", f"_v = {{{variables}}}"]
        rows: dict[tuple[int, int], int] = {}  # (block, rank) -> row of _out holding that root
        for k, b in enumerate(blocks):
            coords = ", ".join(b.coordinates)
            if twin[k] != k:
                doc_lines.append(
                    f"        block {{{coords}}}: the roots of block {{{', '.join(blocks[twin[k]].coordinates)}}}"
                )
                continue
            first = {m.rank: i for i, m in reversed(list(enumerate(structure.modes))) if twin[m.block] == k}
            if b.size == 2:
                t = {n: f"({fused(e)})" for n, e in b.stable_terms.items()}
                upper = f"0.5*({t['s11']} + {t['s22']}) + sqrt((0.5*({t['s11']} - {t['s22']}))**2 + {t['s12_squared']})"
                lower = t["det_ratio"] + " / _upper"
                body += [
                    f"# block {{{coords}}}: upper root from a sum of squares, lower from the root product",
                    f"_runtime.fused({upper!r}, _v, _out[{first[2]}, ...])",
                    f"_runtime.fused({lower!r}, {{**_v, '_upper': _out[{first[2]}, ...]}}, _out[{first[1]}, ...])",
                ]
                lo, hi = b.eigenvalue_exprs()
                doc_lines.append(f"        block {{{coords}}}: lambda = {describe(lo)}  and  {describe(hi)}")
            else:
                body.append(f"_runtime.fused({fused(b.eigenvalue_exprs()[0])!r}, _v, _out[{first[1]}, ...])")
                doc_lines.append(f"        block {{{coords}}}: lambda = {describe(b.eigenvalue_exprs()[0])}")
            rows.update({(k, r): i for r, i in first.items()})
        for i, m in enumerate(structure.modes):
            source = rows[(twin[m.block], m.rank)]
            if source != i:
                body.append(f"_out[{i}] = _out[{source}]")
        body.append("return numpy.moveaxis(_out, 0, -1)")
        method = (
            "Closed form per symmetry block (textbook form below; evaluated in the stable arrangement of\n"
            "    mountid.engine.symbolic.blocks: no difference of nearly equal numbers)"
        )
    else:
        margs = model.parameters_of(model.M)
        cargs = model.parameters_of(model.C)
        body = [
            f"_M = mass_matrix({', '.join(margs)})",
            f"_C = stiffness_matrix({', '.join(cargs)})",
            "_M, _C = numpy.broadcast_arrays(_M, _C)",
            "_out = numpy.empty(_M.shape[:-1])",
        ]
        for k, b in enumerate(blocks):
            pos = [i for i, m in enumerate(structure.modes) if m.block == k]
            ranks = [structure.modes[i].rank - 1 for i in pos]
            body.append(f"_lam = _runtime.block_eigen(_M, _C, {b.index!r})[0]")
            body.append(f"_out[..., {pos!r}] = _lam[..., {ranks!r}]")
            doc_lines.append(f"        block {{{', '.join(b.coordinates)}}}: numeric (size {b.size})")
        body.append("return _out")
        method = "Numeric generalised eigen-solve per symmetry block (no closed form for blocks above 2x2)"
    doc = (
        f"Squared natural frequencies lambda = omega^2 [rad^2/s^2], shape (..., {len(labels)}), modes\n"
        f"    {', '.join(labels)}.\n\n    {method}:\n\n" + "\n".join(doc_lines) + "\n"
    )
    fn = Function("squared_frequencies", args, doc, body[:-1], body[-1].removeprefix("return "))
    return fn


def _roots_function(s: InverseSet, name: str, known: tuple[str, ...], unknowns: tuple[str, ...], doc: str) -> Function:
    """The closed-form candidate roots of one inverse solution: roots of the univariate factors, then the
    back-substitutions, each unknown of shape (n_roots, ...)."""
    lam_subs = {sp.Symbol(f"lambda_{lab}", positive=True): sp.Symbol(f"_lam_{lab}") for lab in s.labels}
    coeff_exprs = [c.subs(lam_subs) for f in s.factors for c in f.all_coeffs()]
    cse = eliminate(coeff_exprs)
    body = [f"{lhs} = {rhs}" for lhs, rhs in cse.lines]
    outs = iter(cse.outputs)
    root_calls = []
    for f in s.factors:
        cs = [next(outs) for _ in f.all_coeffs()]
        root_calls.append(f"_runtime.polynomial_roots({', '.join(cs)})")
    body.append(f"{s.last} = numpy.concatenate([{', '.join(root_calls)}])")
    # one cse per back-substitution, in order: each may use the unknowns assigned before it, so a joint cse
    # could hoist a subexpression above the assignment of an unknown it contains
    start = len(cse.lines)
    for u, e in s.back_substitution:
        back = eliminate([e.subs(lam_subs)], start=start)
        body += [f"{lhs} = {rhs}" for lhs, rhs in back.lines]
        body.append(f"{u} = numpy.broadcast_to({back.outputs[0]}, {s.last}.shape)")
        start += len(back.lines)
    # degenerate inputs give divisions by zero in roots that admissibility then rejects: no warnings
    return Function(
        name,
        known + tuple(f"_lam_{lab}" for lab in s.labels),
        doc,
        ['with numpy.errstate(divide="ignore", invalid="ignore", over="ignore"):'] + [f"    {b}" for b in body],
        f"({', '.join(unknowns)},)",
        convert=False,
    )


START_FACTORS = (0.1, 1.0, 10.0)
"""Starts of a numeric inverse: every combination of the (level-matched) nominal unknowns times these
factors (runtime.start_grid)."""


def root_slots(s: InverseSet, n_unknowns: int) -> int:
    """Candidate roots per row of an inverse: the start grid of a numeric one, else the closed forms' most."""
    if s.numeric:
        return len(START_FACTORS) ** n_unknowns
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
    n_roots = root_slots(s, len(d.unknown))
    mode_index = tuple(structure.labels.index(lab) for lab in s.labels)
    call = (
        f"_runtime.solve_inverse(_runtime.start_grid({start!r}, {START_FACTORS!r}, _model, {mode_index!r}), _model, "
        f"({', '.join(known)},), "
        f"({', '.join(f'{o} ** 2' for o in omegas)},), {mode_index!r}, UNKNOWN, MODE_BLOCK, n_roots={n_roots})"
    )
    doc = (
        f"Unknowns {', '.join(d.unknown)} from the natural frequencies {', '.join(omegas)} [rad/s], numerically.\n\n"
        f"    These frequencies determine the unknowns, but the engine found {s.reason.split(' (')[0]}: Newton\n"
        "    steps on the stable forward map start from the nominal unknowns, scaled to the level of the given\n"
        f"    frequencies, times every combination of {START_FACTORS} ({n_roots} starts). A root outside all\n"
        "    their basins (unknowns in ratios far from the nominal ones) is missed.\n"
        "    Returns InverseRoots (mountid.runtime) as a closed-form inverse does, one row per start.\n"
    )
    return Function(f"identify_{s.name}", known + omegas, doc, [], call)


def _inverse_function(s: InverseSet, structure: ModalStructure, model: SymbolicModel, fwd_args: tuple[str, ...]):
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
    n_roots = root_slots(s, len(unknowns))
    specials = "".join(f"({known.index(param)}, _roots_{s.name}__{param}_0), " for param, _ in s.special)
    start = tuple(d.parameters[u].value for u in unknowns)
    call = (
        f"_runtime.solve_inverse(_roots_{s.name}, _model, ({', '.join(known)},), "
        f"({', '.join(f'{o} ** 2' for o in omegas)},), {mode_index!r}, UNKNOWN, MODE_BLOCK, "
        f"special=({specials}), n_roots={n_roots}, start={None if None in start else start!r})"
    )
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
        "    is rejected. All admissible roots are returned; where several remain (both roots of a block\n"
        "    given), the data alone cannot choose between them and the choice is physical (the paper keeps\n"
        "    c_z > c_xy for its isolators).\n"
    )
    fn = Function(f"identify_{s.name}", known + omegas, doc, [], call)
    return [*candidates, fn]


def module_context(
    description: Description,
    template: str = TEMPLATE,
    inverse_sets: list[InverseSet] | None = None,
    effects: EffectFunctions | None = None,
) -> dict:
    """Everything the template needs for one description. ``inverse_sets`` and ``effects``: the derived
    inverse sets and candidate-effect functions when already at hand (derived here otherwise)."""
    model = SymbolicModel(description)
    structure = ModalStructure(model)
    functions = [
        _matrix_function("mass_matrix", model.M, model, "Mass matrix M", "kg, kg m, kg m^2"),
        _matrix_function("stiffness_matrix", model.C, model, "Stiffness matrix C", "N/m, N/rad, N m/rad"),
        _matrix_function("damping_matrix", model.B, model, "Damping matrix B", "N s/m, N s/rad, N m s/rad"),
    ]
    functions.append(_gradient_function(model))
    functions.append(_point_function(model))
    eigen = _eigen_function(structure, model)
    functions.append(eigen)
    fwd_args = eigen.args
    functions += derivative_functions(model, fwd_args)
    derivation = InverseDerivation(structure)
    if inverse_sets is None:
        inverse_sets = derivation.all_sets()
    inverses = [f for s in inverse_sets if s.identifiable for f in _inverse_function(s, structure, model, fwd_args)]
    if inverses:
        functions += [_model_function(model, fwd_args), *inverses]
    extra, effect_coordinates, isolator_names = effects or effect_functions(model)
    functions += extra
    params = {
        n: {"kind": p.kind, "unit": p.unit, "role": p.role, "value": p.value, "description": p.description}
        for n, p in description.parameters.items()
    }
    return {
        "template": template,
        "sympy_version": sp.__version__,
        "description": description,
        "parameters": params,
        "coordinates": COORDINATES,
        "labels": structure.labels,
        "unique_labels": structure.unique_labels,
        "representative": {m.label: m.representative for m in structure.modes},
        "blocks": tuple(b.index for b in structure.blocks),
        "mode_block": tuple(m.block for m in structure.modes),
        "mode_rank": tuple(m.rank for m in structure.modes),
        "forward_args": fwd_args,
        "functions": functions,
        "inverses": [
            (s.labels, f"identify_{s.name}", root_slots(s, len(description.unknown)))
            for s in inverse_sets
            if s.identifiable
        ],
        "numeric_inverses": [(s.labels, s.reason) for s in inverse_sets if s.numeric],
        "unidentifiable": [(s.labels, s.reason) for s in inverse_sets if not s.identifiable],
        "inverse_enumerated": bool(inverse_sets),
        "special_points": derivation.special_points,
        "derivative_parameters": model.parameters_of(model.M, model.C, model.B),
        "twin_coordinates": structure.twin_map(),
        "effect_coordinates": effect_coordinates,
        "isolators": isolator_names,
        "code": code,
    }


def _environment() -> jinja2.Environment:
    folder = resources.files("mountid.templates")
    env = jinja2.Environment(
        loader=jinja2.FunctionLoader(lambda name: (folder / name).read_text(encoding="utf-8")),
        undefined=jinja2.StrictUndefined,
        keep_trailing_newline=True,
        trim_blocks=True,
        lstrip_blocks=True,
        autoescape=False,
    )
    env.filters["pytuple"] = _pytuple
    return env


def _pytuple(items) -> str:
    """A Python tuple literal of strings with double quotes, as ruff formats it: ("a", "b") or ("a",)."""
    quoted = [json.dumps(str(i)) for i in items]
    return f"({quoted[0]},)" if len(quoted) == 1 else f"({', '.join(quoted)})"  # () when empty


def render(
    description: Description,
    template: str = TEMPLATE,
    inverse_sets: list[InverseSet] | None = None,
    effects: EffectFunctions | None = None,
) -> str:
    """The source of the generated module for a description (``inverse_sets``, ``effects`` as in
    module_context)."""
    if sp.__version__ != SYMPY_VERSION:
        raise RuntimeError(
            f"generation is pinned to sympy {SYMPY_VERSION} (found {sp.__version__}): "
            "other releases change cse output; install the pinned version"
        )
    return _environment().get_template(template).render(**module_context(description, template, inverse_sets, effects))
