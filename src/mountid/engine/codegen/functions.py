"""The generated functions of a machine module described as data (name, arguments, body from sympy,
docstring): the matrices, point Jacobian, gradients and derivatives, the candidate-effect matrices and the
forward model the numeric inverses use. numpy_module lays them out with the template."""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from mountid.effects import EFFECTS
from mountid.engine.codegen.layouts import Call, Filled, ForwardModel, Function, Mapping, Matrices, SymmetricMatrix
from mountid.engine.codegen.printing import describe, print_function
from mountid.engine.symbolic.effects import (
    GENERATED_EFFECTS,
    SUPPORT_EFFECTS,
    ExtendedModel,
    isolator_axial_stiffness,
    isolator_damping,
    isolator_stiffness,
    scales,
    support_feet,
)
from mountid.engine.symbolic.model import SymbolicModel
from mountid.nomenclature import COORDINATES


def _entry_lines(matrix: sp.Matrix, coordinates: tuple[str, ...], indent: str) -> list[str]:
    """Docstring lines ``[row, column] = entry`` of a symmetric matrix's non-zero upper triangle."""
    return [
        f"{indent}[{coordinates[i]}, {coordinates[j]}] = {describe(e)}"
        for i, j, e in SymmetricMatrix.of(matrix).entries
    ]


def _matrices_function(
    name: str,
    matrices: dict[str, sp.Matrix],
    coordinates: tuple[str, ...],
    args: tuple[str, ...],
    doc: str,
    bases: tuple[Call, ...] = (),
    stacked: tuple[int, ...] | None = None,
) -> Function:
    """A function returning several symmetric matrices (one cse over all of them), as laid out by
    layouts.Matrices (``bases``, ``stacked`` as there), its docstring listing their entries."""
    lines = []
    for label, mat in matrices.items():
        lines += [f"        {label}:", *_entry_lines(mat, coordinates, "          ")]
    doc += "\n    Non-zero upper-triangle entries:\n\n" + "\n".join(lines) + "\n"
    layout = Matrices(tuple(SymmetricMatrix.of(m) for m in matrices.values()), bases, stacked)
    return print_function(Function(name, args, doc, layout))


def matrix_function(name: str, matrix: sp.Matrix, model: SymbolicModel, what: str, unit_note: str) -> Function:
    """One symmetric 6 x 6 matrix of the model (M, C or B)."""
    formula = "\n".join(_entry_lines(matrix, COORDINATES, "        "))
    doc = (
        f"{what} [{unit_note}], shape (..., 6, 6), coordinates {', '.join(COORDINATES)}.\n\n"
        f"    Non-zero entries of the upper triangle (the matrix is symmetric):\n\n{formula}\n"
    )
    layout = Matrices((SymmetricMatrix.of(matrix),))
    return print_function(Function(name, model.parameters_of(matrix), doc, layout))


@dataclass(frozen=True)
class EffectFunctions:
    """The candidate-effect part of a generated module: its functions (printed), the coordinates of each effect's
    extended model, the parameters of each effect_<name>_derivatives(), and the isolator names."""

    functions: list[Function]
    coordinates: dict[str, tuple[str, ...]]
    derivative_parameters: dict[str, tuple[str, ...]]
    isolators: tuple[str, ...]


def effect_functions(model: SymbolicModel) -> EffectFunctions:
    """Extended matrices of every generated effect and their derivatives, the isolators' own stiffness
    matrices and their gradient, the scales."""
    functions = []
    coords = {}
    derivative_parameters = {}
    nominal = (
        Call("mass_matrix", model.parameters_of(model.M)),
        Call("stiffness_matrix", model.parameters_of(model.C)),
        Call("damping_matrix", model.parameters_of(model.B)),
    )
    for name in GENERATED_EFFECTS:
        ext = ExtendedModel(model, EFFECTS[name])
        coords[name] = ext.coordinates
        derivative_parameters[name] = effect_derivative_parameters(model, ext)
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
            fn = _matrices_function(
                f"effect_{name}",
                added,
                ext.coordinates,
                own + extra,
                doc + "    The nominal matrices plus the Hessians of the added energies (B is the nominal one):\n",
                bases=nominal,
            )
        functions.append(fn)
        functions.append(_effect_derivative_function(model, ext))
    names = tuple(iso.name for iso in model.isolators)
    functions += _isolator_functions(model, "", COORDINATES)
    for name in SUPPORT_EFFECTS:
        functions += _isolator_functions(model, name, coords[name])
    functions.append(_isolator_points_function(model))
    functions.append(_support_feet_function(model))
    sc = scales(model)
    args = model.parameters_of(*sc.values())
    doc = (
        "Machine scales for the plausible ranges of the candidate effects (mountid.effects), as a dict:\n\n"
        + "\n".join(f"        {k} = {describe(v)}" for k, v in sc.items())
        + "\n"
    )
    functions.append(print_function(Function("effect_scales", args, doc, Mapping(tuple(sc.items())))))
    return EffectFunctions(functions, coords, derivative_parameters, names)


def _isolator_functions(model: SymbolicModel, support: str, coordinates: tuple[str, ...]) -> list[Function]:
    """Each isolator's stiffness matrix and its axial part, and their gradients by the unknowns: on the ground
    (``support`` empty: isolator_stiffness() ...) or between the body and the support of the generated effect
    ``support`` (isolator_stiffness_on_<support>() ..., in that effect's coordinates): the matrices an isolator
    scatter changes, alone or on that support."""
    names = tuple(iso.name for iso in model.isolators)
    on = bool(support)
    suffix = f"_on_{support}" if on else ""
    where = f" between the body and the support of {support}" if on else ""
    out = []
    n = len(coordinates)
    for name, per, what in (
        ("isolator_stiffness", isolator_stiffness(model, on), "Stiffness matrix of each isolator alone"),
        (
            "isolator_axial_stiffness",
            isolator_axial_stiffness(model, on),
            "The part of each isolator's stiffness matrix along its own axis (local z, compression)",
        ),
    ):
        total = "; their sum is stiffness_matrix().\n" if name == "isolator_stiffness" and not on else ".\n"
        fn = _matrices_function(
            name + suffix,
            dict(zip(names, per, strict=True)),
            coordinates,
            model.parameters_of(*per),
            f"{what}{where},\n    shape (..., {len(per)}, {n}, {n}), isolators in the order of ISOLATORS{total}"
            f"    Coordinates {', '.join(coordinates)}.\n",
            stacked=(),
        )
        out.append(fn)
        out.append(_isolator_gradient_function(model, name + suffix, dict(zip(names, per, strict=True)), coordinates))
    if not on:
        per = isolator_damping(model)
        named = dict(zip(names, per, strict=True))
        out.append(
            _matrices_function(
                "isolator_damping",
                named,
                coordinates,
                model.parameters_of(*per),
                "Damping matrix of each isolator alone (Hessian of its dissipation),\n"
                f"    shape (..., {len(per)}, {n}, {n}), isolators in the order of ISOLATORS; "
                "their sum is damping_matrix().\n"
                f"    Coordinates {', '.join(coordinates)}.\n",
                stacked=(),
            )
        )
        out.append(_isolator_gradient_function(model, "isolator_damping", named, coordinates, fitted_parameters(model)))
    return out


def effect_derivative_parameters(model: SymbolicModel, ext: ExtendedModel) -> tuple[str, ...]:
    """What a candidate fit varies, in the order of effect_<name>_derivatives(): the unknowns the extended
    matrices depend on, the damping parameters (fitted where damping ratios are measured), then the effect's
    parameters."""
    args = ext.arguments()
    damping = tuple(n for n, p in model.description.parameters.items() if p.kind == "damping" and n in args)
    return tuple(u for u in model.description.unknown if u in args) + damping + tuple(ext.symbols)


def _effect_derivative_function(model: SymbolicModel, ext: ExtendedModel) -> Function:
    """d(M, C, B)/dp of one extended model for p in effect_derivative_parameters(), differentiated by sympy:
    the Jacobian of a candidate fit (mountid.diagnosis) without finite differences."""
    name = ext.effect.name
    params = effect_derivative_parameters(model, ext)
    symbols = {**model.symbols, **ext.symbols}
    n = len(ext.coordinates)
    if n > 6:
        mats = {"M": ext.M, "C": ext.C, "B": ext.B}
    else:  # the nominal matrices plus the Hessians of the added energies (as effect_<name>() is emitted)
        mats = {"M": model.M + ext.added_M, "C": model.C + ext.added_C, "B": model.B}
    derivs = {f"d{k}/d{p}": mat.diff(symbols[p]) for p in params for k, mat in mats.items()}
    doc = (
        f"Derivatives of the M, C, B of effect_{name}() with respect to EFFECT_DERIVATIVE_PARAMETERS[{name!r}],\n"
        f"    shape (..., {len(params)}, 3, {n}, {n}), differentiated by sympy.\n"
    )
    return _matrices_function(
        f"effect_{name}_derivatives", derivs, ext.coordinates, ext.arguments(), doc, stacked=(len(params), 3, n, n)
    )


def _isolator_gradient_function(
    model: SymbolicModel,
    name: str,
    per: dict[str, sp.Matrix],
    coordinates: tuple[str, ...],
    by: tuple[str, ...] | None = None,
) -> Function:
    """d(name())/dp of per-isolator matrices for each p of ``by`` (default: the unknowns), the Jacobian of an
    isolator-scatter or tilted-isolator fit."""
    parameters = model.description.unknown if by is None else by
    what = "the unknowns" if by is None else "FITTED_PARAMETERS"
    n = len(coordinates)
    derivs = {f"d{iso}/d{p}": mat.diff(model.symbols[p]) for p in parameters for iso, mat in per.items()}
    doc = (
        f"Derivatives of {name}() with respect to {what} {', '.join(parameters)}, shape\n"
        f"    (..., {len(parameters)}, {len(per)}, {n}, {n}), differentiated by sympy.\n"
    )
    args = model.parameters_of(*per.values())
    shape = (len(parameters), len(per), n, n)
    return _matrices_function(f"{name}_gradient", derivs, coordinates, args, doc, stacked=shape)


def _points_function(model: SymbolicModel, name: str, points: list[sp.Matrix], doc: str) -> Function:
    """A generated function returning one point per isolator, shape (..., 3, isolators), ISOLATORS' order."""
    entries = tuple((i, k, p[i]) for k, p in enumerate(points) for i in range(3) if p[i] != 0)
    lines = [
        f"        {iso.name}: ({', '.join(describe(v) for v in p)})"
        for iso, p in zip(model.isolators, points, strict=True)
    ]
    doc += f", shape (..., 3, {len(points)}), isolators in the\n    order of ISOLATORS:\n\n" + "\n".join(lines) + "\n"
    args = model.parameters_of(*points)
    return print_function(Function(name, args, doc, Filled((3, len(points)), entries), cse=False))


def _isolator_points_function(model: SymbolicModel) -> Function:
    """Where each isolator acts on the body [m]: the layout a report names (the diagnosis's conventions)."""
    points = [iso.position for iso in model.isolators]
    return _points_function(model, "isolator_points", points, "Point of each isolator [m] from the coordinate origin")


def _support_feet_function(model: SymbolicModel) -> Function:
    """Where each isolator stands on a support below the isolators (the foundation), in the support's own
    coordinates [m]: the points at which the support's motion is read (CandidateModel.support_motion)."""
    doc = (
        "Foot of each isolator on a support below the isolators [m], from the point the support's coordinates\n"
        "    refer to (the mean of the isolator points)"
    )
    return _points_function(model, "support_feet", support_feet(model), doc)


def point_function(model: SymbolicModel) -> Function:
    """du/dq at body points: sensors read it, forces act through its transpose."""
    jac = model.point_jacobian
    args = tuple(str(s) for s in model.POINT)
    entries = tuple((i, j, jac[i, j]) for i in range(3) for j in range(6) if jac[i, j] != 0)
    formula = "\n".join(f"        [{'xyz'[i]}, {COORDINATES[j]}] = {describe(e)}" for i, j, e in entries)
    doc = (
        "Jacobian du/dq of the displacement u [m] of the body point (r_x, r_y, r_z) [m] (from the coordinate\n"
        "    origin) with respect to q, shape (..., 3, 6). A sensor there along the unit direction d reads\n"
        "    d^T (du/dq) q; a force F there acts on the coordinates as (du/dq)^T F.\n\n"
        f"    Non-zero entries:\n\n{formula}\n"
    )
    return print_function(Function("point_jacobian", args, doc, Filled((3, 6), entries), cse=False))


def _stiffness_gradient(model: SymbolicModel) -> list[sp.Matrix]:
    return [model.C.diff(model.symbols[u]) for u in model.description.unknown]


def gradient_arguments(model: SymbolicModel) -> tuple[str, ...]:
    """Arguments of the generated stiffness_gradient(): the parameters dC/d(unknowns) depends on."""
    return model.parameters_of(*_stiffness_gradient(model))


def gradient_function(model: SymbolicModel) -> Function:
    """dC/d(unknown) for each unknown: the matrices of the eigenvalue derivatives phi^T dC phi."""
    args = gradient_arguments(model)
    unknowns = model.description.unknown
    layout = Matrices(tuple(SymmetricMatrix.of(m) for m in _stiffness_gradient(model)), stacked=())
    doc = f"Derivatives dC/d({', '.join(unknowns)}) of the stiffness matrix, shape (..., {len(unknowns)}, 6, 6).\n"
    return print_function(Function("stiffness_gradient", args, doc, layout))


def _derivative_function(
    name: str, model: SymbolicModel, parameters: tuple[str, ...], matrices: dict[str, sp.Matrix], doc: str
) -> Function:
    """Derivatives of ``matrices`` with respect to each of ``parameters``, differentiated by sympy, stacked
    as (..., n_parameters, n_matrices, 6, 6)."""
    derivs = {f"d{k}/d{p}": mat.diff(model.symbols[p]) for p in parameters for k, mat in matrices.items()}
    args = model.parameters_of(*matrices.values())
    return _matrices_function(name, derivs, COORDINATES, args, doc, stacked=(len(parameters), len(matrices), 6, 6))


def fitted_parameters(model: SymbolicModel) -> tuple[str, ...]:
    """The parameters a fit of the gap diagnosis may vary: the description's unknowns, then its damping
    parameters (fitted where a campaign measures damping ratios; an unknown is always a stiffness)."""
    d = model.description
    return d.unknown + tuple(n for n, p in d.parameters.items() if p.kind == "damping")


def derivative_functions(model: SymbolicModel, fwd_args: tuple[str, ...]) -> list[Function]:
    """matrix_derivatives() (M, C, B with respect to every parameter they depend on), fitted_derivatives() (its
    rows for the parameters a diagnosis fits: fitted_parameters()) and the private
    _mc_derivatives() (M, C with respect to the forward arguments) that squared_frequency_derivatives() uses."""
    every = model.parameters_of(model.M, model.C, model.B)
    fitted = fitted_parameters(model)
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
            "fitted_derivatives",
            model,
            fitted,
            {"M": model.M, "C": model.C, "B": model.B},
            "Derivatives of M, C, B with respect to the parameters a fit of the gap diagnosis may vary (the unknowns,\n"
            f"    then the damping parameters), shape (..., {len(fitted)}, 3, 6, 6): [..., k, (M, C, B), :, :] =\n"
            "    d(matrix)/d(FITTED_PARAMETERS[k]), differentiated by sympy. The rows of matrix_derivatives() for\n"
            "    them; in a model linear in them they depend on the geometry alone (DEPENDS): a fit varying them\n"
            "    computes them once.\n",
        ),
        _derivative_function(
            "_mc_derivatives",
            model,
            fwd_args,
            {"M": model.M, "C": model.C},
            "dM/dp and dC/dp for p in FORWARD_ARGUMENTS, shape (..., n, 2, 6, 6).\n",
        ),
    ]


def model_function(model: SymbolicModel, fwd_args: tuple[str, ...]) -> Function:
    """The forward model the Newton polish of every inverse works on (runtime.eigen_newton).

    The polish works on the frequencies themselves (stable forward map, dlambda/dtheta = phi^T dC/dtheta phi):
    the elimination formulas can lose digits where a mode sits near an uncoupled frequency.
    """
    d = model.description
    known = tuple(a for a in fwd_args if a not in d.unknown)
    layout = ForwardModel(
        known,
        d.unknown,
        Call("squared_frequencies", fwd_args),
        Call("mass_matrix", model.parameters_of(model.M)),
        Call("stiffness_matrix", model.parameters_of(model.C)),
        Call("stiffness_gradient", gradient_arguments(model)),
    )
    doc = (
        "Squared frequencies, and with ``_modes`` the modal matrix and dC/d(unknowns), at flat parameters:\n"
        f"    ``_known`` = ({', '.join(known)}) of shape (N,), ``_unknowns`` of shape (N, {len(d.unknown)}).\n"
    )
    return Function("_model", ("_known", "_unknowns", "_modes"), doc, layout, convert=False)
