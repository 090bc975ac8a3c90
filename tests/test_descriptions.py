"""Description validation: contradictions with the declared symmetry are rejected, naming the entry."""

from __future__ import annotations

import pytest
import tomllib

from mountid.engine.description import parse, shipped_descriptions
from mountid.engine.symbolic.blocks import ModalStructure
from mountid.engine.symbolic.model import SymbolicModel
from mountid.errors import DescriptionError


def kid300_data() -> dict:
    with shipped_descriptions()["kid300"].open("rb") as f:
        return tomllib.load(f)


def build(data: dict) -> ModalStructure:
    return ModalStructure(SymbolicModel(parse(data)))


def test_shipped_descriptions_build():
    for path in shipped_descriptions().values():
        with path.open("rb") as f:
            build(tomllib.load(f))


@pytest.mark.parametrize(
    ("edit", "entry"),
    [
        (lambda d: d["body"].__setitem__("centre_of_mass", ["0.01", 0, 0]), "body.centre_of_mass[0]"),
        (
            lambda d: d["body"].__setitem__("products_of_inertia", [0, 0, "J_z/10"]),
            "body.products_of_inertia",
        ),
        (
            lambda d: d["isolators"][0].__setitem__("point", [0, "L_xy", "-L_z"])
            or d["isolators"][0].__setitem__("inclination", [0, "pi/12", 0]),
            "isolators.corner.inclination",
        ),
        (lambda d: d["parameters"]["m"].__setitem__("value", -3.0), "parameters.m.value"),
        (lambda d: d["isolators"][0].__setitem__("point", ["L_q", 0, 0]), "isolators.corner.point[0]"),
        (lambda d: d["modes"][0].__setitem__("block", ["x", "psi"]), "modes[0].block"),
        (lambda d: d["modes"][1].__setitem__("rank", 2), "modes[3]"),
        (lambda d: d.__setitem__("symmetry", ["xy"]), "symmetry"),
        (lambda d: d["parameters"]["m"].__setitem__("role", "unknown"), "parameters.m.role"),
    ],
)
def test_contradictions_name_the_entry(edit, entry):
    data = kid300_data()
    edit(data)
    with pytest.raises(DescriptionError) as info:
        build(data)
    assert info.value.parameter == entry


def test_less_symmetric_description_gets_numeric_blocks():
    data = kid300_data()
    data["symmetry"] = ["xz"]
    data["body"]["centre_of_mass"] = ["0.02", 0, 0]
    del data["modes"]
    structure = build(data)
    assert sorted(b.coordinates for b in structure.blocks) == [("x", "z", "theta"), ("y", "psi", "phi")]
    assert not structure.closed_form
