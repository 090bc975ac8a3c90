"""The symbolic engine on the paper's machine: Eqs. (7), (8) and (11) come out of the energies."""

from __future__ import annotations

import importlib
import sys
import types

import numpy as np
import pytest
import sympy as sp

from mountid.engine.codegen import formatting
from mountid.engine.codegen.numpy_module import render
from mountid.engine.description import load, shipped_descriptions
from mountid.engine.settings import ENGINE
from mountid.engine.symbolic.blocks import LAMBDA, ModalStructure
from mountid.engine.symbolic.inverse import InverseDerivation
from mountid.engine.symbolic.model import SymbolicModel


def kid300():
    return SymbolicModel(load(shipped_descriptions()["kid300"]))


def test_mass_and_stiffness_matrices_are_the_papers_eqs_7_and_8():
    model = kid300()
    m, J_xy, J_z, L_xy, L_z, c_xy, c_z = (model.symbols[n] for n in ("m", "J_xy", "J_z", "L_xy", "L_z", "c_xy", "c_z"))
    eq7 = sp.diag(m, m, m, J_xy, J_xy, J_z)
    rock = 2 * L_xy**2 * c_z + 4 * L_z**2 * c_xy
    eq8 = sp.Matrix(
        [
            [4 * c_xy, 0, 0, 0, -4 * c_xy * L_z, 0],
            [0, 4 * c_xy, 0, 4 * c_xy * L_z, 0, 0],
            [0, 0, 4 * c_z, 0, 0, 0],
            [0, 4 * c_xy * L_z, 0, rock, 0, 0],
            [-4 * c_xy * L_z, 0, 0, 0, rock, 0],
            [0, 0, 0, 0, 0, 4 * L_xy**2 * c_xy],
        ]
    )
    assert (model.M - eq7).applyfunc(sp.expand) == sp.zeros(6)
    assert (model.C - eq8).applyfunc(sp.expand) == sp.zeros(6)
    # B is C with c replaced by b (paper, Eq. 27)
    b_sub = {c_xy: model.symbols["b_xy"], c_z: model.symbols["b_z"]}
    assert (model.B - eq8.subs(b_sub)).applyfunc(sp.expand) == sp.zeros(6)


def test_characteristic_polynomial_is_eq_11():
    model = kid300()
    structure = ModalStructure(model)
    m, J_xy, J_z, L_xy, L_z, c_xy, c_z = (model.symbols[n] for n in ("m", "J_xy", "J_z", "L_xy", "L_z", "c_xy", "c_z"))
    lam = LAMBDA
    coupled = lam * m * (lam * J_xy - 2 * L_xy**2 * c_z) - 4 * c_xy * (lam * (J_xy + m * L_z**2) - 2 * L_xy**2 * c_z)
    eq11 = (lam * m - 4 * c_z) * (lam * J_z - 4 * L_xy**2 * c_xy) * coupled**2
    product = sp.Mul(*(b.charpoly.as_expr() for b in structure.blocks))
    # det(C - lambda M) = det(M) det(H - lambda I); Eq. 11 is det(M) f(lambda) up to sign
    assert sp.expand(product - eq11) == 0 or sp.expand(product + eq11) == 0
    full = (model.C - lam * model.M).det(method="berkowitz")
    assert sp.expand(full - product) == 0


def test_blocks_labels_and_repeated_frequencies():
    structure = ModalStructure(kid300())
    assert [b.coordinates for b in structure.blocks] == [("x", "theta"), ("y", "psi"), ("z",), ("phi",)]
    assert structure.labels == ("x", "y", "z", "psi", "theta", "phi")
    assert structure.unique_labels == ("x", "z", "psi", "phi")
    assert structure.mode("theta").representative == "psi"


def test_all_six_pairings_are_solvable_with_the_papers_root_counts():
    inverse = InverseDerivation(ModalStructure(kid300()))
    sets = {s.labels: s for s in inverse.all_sets()}
    assert set(sets) == {("x", "z"), ("x", "psi"), ("x", "phi"), ("z", "psi"), ("z", "phi"), ("psi", "phi")}
    assert all(s.identifiable for s in sets.values())
    assert sets[("x", "psi")].n_roots == 2  # the paper: "the system has two solutions"
    assert all(s.n_roots == 1 for k, s in sets.items() if k != ("x", "psi"))


def test_rectangular_reports_unidentifiable_sets():
    inverse = InverseDerivation(ModalStructure(SymbolicModel(load(shipped_descriptions()["rectangular"]))))
    sets = inverse.all_sets()
    assert len(sets) == 20
    bad = {s.labels: s.reason for s in sets if not s.identifiable}
    # x, theta and z involve only c_x and c_z: c_y is left free
    assert set(bad) == {("x", "z", "theta"), ("y", "z", "psi")}
    assert all("2 independent" in r for r in bad.values())


def test_six_isolators_two_groups_mirror_counts():
    model = SymbolicModel(load(shipped_descriptions()["screen6"]))
    groups = [iso.group for iso in model.isolators]
    assert groups.count("corner") == 4 and groups.count("middle") == 2


@pytest.mark.parametrize("name", ["kid300", "rectangular"])
def test_plain_numpy_eigenvalues_match_the_fused_shipped_module(name):
    """The default code form (EngineSettings.fused = False) prints the same stable closed forms as numpy
    code: no numexpr string in the module, the same frequencies as the shipped (fused) module."""
    source = render(load(shipped_descriptions()[name]), settings=ENGINE)
    assert "_runtime.fused(" not in source
    plain = types.ModuleType(f"plain_{name}")
    exec(compile(source, f"<plain {name}>", "exec"), plain.__dict__)
    shipped = importlib.import_module(f"mountid.generated.{name}")
    rng = np.random.default_rng(5)
    values = {
        a: shipped.PARAMETERS[a]["value"] * 10 ** rng.uniform(-1, 1, 5000)
        if shipped.PARAMETERS[a]["kind"] != "angle"
        else rng.uniform(-0.5, 0.5, 5000)
        for a in shipped.FORWARD_ARGUMENTS
    }
    got, want = plain.squared_frequencies(**values), shipped.squared_frequencies(**values)
    np.testing.assert_allclose(got, want, rtol=1e-13)
    one = {a: v[0] for a, v in values.items()}
    np.testing.assert_allclose(plain.squared_frequencies(**one), want[0], rtol=1e-13)


def test_generation_without_ruff_names_the_extra(monkeypatch):
    """The formatter missing is an extra missing: ModuleNotFoundError naming ruff, which the command line
    turns into one line naming the `generate` extra."""
    monkeypatch.setattr(formatting, "_COMMAND", (sys.executable, "-m", "mountid_no_such_formatter"))
    formatting._check_version.cache_clear()
    try:
        with pytest.raises(ModuleNotFoundError) as info:
            formatting.format_source("x = 1\n")
        assert info.value.name == "ruff"
    finally:
        formatting._check_version.cache_clear()
