"""Build the numpy module of one description: the functions as data (functions, solvers: layouts with sympy
leaves, printed in one pass), laid out by ``templates/numpy_module.py.jinja`` and its macros in
``templates/numpy_layouts.jinja``, formatted by ruff.

Every formula in the output comes from :mod:`mountid.engine.symbolic`; this module only gathers the functions
and the module's constants for the template.
"""

from __future__ import annotations

import json
from collections.abc import Iterable
from importlib import resources

import jinja2
import sympy as sp

from mountid.engine.codegen.formatting import format_source
from mountid.engine.codegen.functions import (
    EffectFunctions,
    derivative_functions,
    effect_functions,
    fitted_parameters,
    gradient_function,
    matrix_function,
    model_function,
    point_function,
)
from mountid.engine.codegen.solvers import eigen_function, inverse_functions, root_slots
from mountid.engine.description import Description
from mountid.engine.settings import ENGINE, EngineSettings
from mountid.engine.symbolic.blocks import ModalStructure
from mountid.engine.symbolic.inverse import InverseDerivation, InverseSet
from mountid.engine.symbolic.model import SymbolicModel
from mountid.nomenclature import COORDINATES

TEMPLATE = "numpy_module.py.jinja"
SYMPY_VERSION = "1.14.0"
"""The sympy release generation is pinned to (cse output and printing change between releases)."""


def module_context(
    description: Description,
    template: str = TEMPLATE,
    inverse_sets: list[InverseSet] | None = None,
    effects: EffectFunctions | None = None,
    settings: EngineSettings = ENGINE,
) -> dict:
    """Everything the template needs for one description. ``inverse_sets`` and ``effects``: the derived
    inverse sets and candidate-effect functions when already at hand (derived here otherwise); ``settings``:
    the engine's size limits (those the inverse sets were derived with)."""
    model = SymbolicModel(description)
    structure = ModalStructure(model, settings)
    functions = [
        matrix_function("mass_matrix", model.M, model, "Mass matrix M", "kg, kg m, kg m^2"),
        matrix_function("stiffness_matrix", model.C, model, "Stiffness matrix C", "N/m, N/rad, N m/rad"),
        matrix_function("damping_matrix", model.B, model, "Damping matrix B", "N s/m, N s/rad, N m s/rad"),
    ]
    functions.append(gradient_function(model))
    functions.append(point_function(model))
    eigen = eigen_function(structure, model)
    functions.append(eigen)
    fwd_args = eigen.args
    functions += derivative_functions(model, fwd_args)
    derivation = InverseDerivation(structure)
    if inverse_sets is None:
        inverse_sets = derivation.all_sets()
    inverses = [f for s in inverse_sets if s.identifiable for f in inverse_functions(s, structure, model, fwd_args)]
    if inverses:
        functions += [model_function(model, fwd_args), *inverses]
    effects = effects or effect_functions(model)
    functions += effects.functions
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
        "arguments": {fn.name: fn.args for fn in functions},
        "depends": {
            fn.name: fn.depends
            for fn in functions
            if not fn.name.startswith("_") and fn.depends is not None and fn.depends != fn.args
        },
        "inverses": [
            (s.labels, f"identify_{s.name}", root_slots(s, len(description.unknown), settings))
            for s in inverse_sets
            if s.identifiable
        ],
        "numeric_inverses": [(s.labels, s.reason) for s in inverse_sets if s.numeric],
        "unidentifiable": [(s.labels, s.reason) for s in inverse_sets if not s.identifiable],
        "undetermined": [(s.labels, s.undetermined) for s in inverse_sets if s.undetermined],
        "inverse_enumerated": bool(inverse_sets),
        "special_points": derivation.special_points,
        "derivative_parameters": model.parameters_of(model.M, model.C, model.B),
        "fitted_parameters": fitted_parameters(model),
        "twin_coordinates": structure.twin_map(),
        "effect_coordinates": effects.coordinates,
        "effect_derivative_parameters": effects.derivative_parameters,
        "isolators": effects.isolators,
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
    env.filters["pyrepr"] = repr
    return env


def _pytuple(items: Iterable[object]) -> str:
    """A Python tuple literal of strings with double quotes, as ruff formats it: ("a", "b") or ("a",)."""
    quoted = [json.dumps(str(i)) for i in items]
    return f"({quoted[0]},)" if len(quoted) == 1 else f"({', '.join(quoted)})"  # () when empty


def render(
    description: Description,
    template: str = TEMPLATE,
    inverse_sets: list[InverseSet] | None = None,
    effects: EffectFunctions | None = None,
    settings: EngineSettings = ENGINE,
) -> str:
    """The source of the generated module for a description (``inverse_sets``, ``effects`` as in
    module_context), laid out by the template and formatted by ruff (engine.codegen.formatting)."""
    if sp.__version__ != SYMPY_VERSION:
        raise RuntimeError(
            f"generation is pinned to sympy {SYMPY_VERSION} (found {sp.__version__}): "
            "other releases change cse output; install the pinned version"
        )
    context = module_context(description, template, inverse_sets, effects, settings)
    return format_source(_environment().get_template(template).render(**context))
