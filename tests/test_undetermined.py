"""Frequencies that leave an unknown undetermined however many they are (Machine.undetermined_by, the generated
UNDETERMINED): against the rank of the forward map's Jacobian, and as errors and notes where the chain uses it."""

from __future__ import annotations

import itertools
import json
import math
from pathlib import Path

import numpy as np
import pytest

from mountid.cli import main
from mountid.diagnosis.campaign import parse
from mountid.diagnosis.gap import diagnose, diagnose_where
from mountid.errors import InputError
from mountid.identification.from_records import fit_stiffness
from mountid.machine import Machine

CENTRAL5 = str(Path(__file__).parent / "data" / "central5.toml")
"""Four corner isolators and one at the centre, whose vertical stiffness c_c moves z alone."""

CENTRAL5_KNOWN = {"m": 900.0, "J_x": 150.0, "J_y": 260.0, "J_z": 300.0, "a": 0.7, "b": 0.45, "h": 0.3}


def _null_space_support(machine: Machine, labels: tuple[str, ...]) -> tuple[str, ...] | None:
    """The unknowns with a component in the null space of d ln omega^2 / d ln c of ``labels`` (central
    differences of the generated forward map at the nominal values, each row scaled to its largest entry); None
    where the rank is full."""
    mod = machine.module
    nominal = {n: p["value"] for n, p in mod.PARAMETERS.items()}

    def squared(values: dict) -> np.ndarray:
        lam = mod.squared_frequencies(**{a: values[a] for a in mod.FORWARD_ARGUMENTS})
        return np.log(np.array([lam[mod.MODES.index(label)] for label in labels]))

    columns = []
    for u in mod.UNKNOWN:
        up, down = dict(nominal), dict(nominal)
        up[u], down[u] = nominal[u] * (1 + 1e-5), nominal[u] * (1 - 1e-5)
        columns.append((squared(up) - squared(down)) / 2e-5)
    jac = np.array(columns).T
    jac = jac / np.abs(jac).max(axis=1, keepdims=True)
    _, sv, vt = np.linalg.svd(jac)
    null = [vt[i] for i in range(len(mod.UNKNOWN)) if i >= len(sv) or sv[i] <= 1e-7 * sv[0]]
    if not null:
        return None
    return tuple(u for j, u in enumerate(mod.UNKNOWN) if any(abs(v[j]) > 0.1 for v in null))


@pytest.mark.parametrize("name", ["rectangular", "screen6", CENTRAL5])
def test_what_every_set_of_distinct_frequencies_leaves_undetermined_is_the_forward_maps_null_space(name):
    """For every set of as many distinct frequencies as unknowns or more: undetermined_by (from the engine's
    symbolic rank of each smallest set) names what the null space of the forward map's Jacobian at the nominal
    values holds, and None where that Jacobian has full rank; the modes it says would complete a set do."""
    machine = Machine.resolve(name)
    n = len(machine.unknown)
    unique = machine.unique_modes
    seen = 0
    for size in range(n, len(unique) + 1):
        for labels in itertools.combinations(unique, size):
            found = machine.undetermined_by(labels)
            expected = _null_space_support(machine, labels)
            assert (found.unknowns if found else None) == expected, labels
            if found:
                seen += 1
                assert found.modes == labels
                for label in unique:
                    if label not in labels:
                        completed = _null_space_support(machine, tuple(m for m in unique if m in {*labels, label}))
                        assert (label in found.completing) == (completed is None), (labels, label)
    assert seen == (16 if name == CENTRAL5 else 2)  # central5: every set without z (10 of three, 5 of four, 1)


def test_the_central_isolator_is_determined_by_z_alone():
    """central5: c_c moves z alone, so every set without z leaves it undetermined, five frequencies as well as
    three; fewer frequencies than unknowns are counted elsewhere (None)."""
    machine = Machine.resolve(CENTRAL5)
    others = ("x", "y", "psi", "theta", "phi")
    found = machine.undetermined_by(others)
    assert found is not None and found.unknowns == ("c_c",) and found.completing == ("z",)
    assert found.describe() == "c_c is not determined by x, y, psi, theta, phi"
    assert found.advice() == "z with them would determine it"
    assert machine.undetermined_by((*others, "z")) is None
    assert machine.undetermined_by(("x", "y")) is None


def _parallel(folder: Path, role: str = "unknown") -> Path:
    """central5 with a second isolator at each corner in place of the central one: its vertical stiffness c_w (of
    ``role``) in parallel with c_v."""
    text = Path(CENTRAL5).read_text()
    text = (
        text.replace(
            'c_c = { kind = "stiffness", role = "unknown", value = 8.0e5 }',
            f'c_w = {{ kind = "stiffness", role = "{role}", value = 3.0e5 }}',
        )
        .replace('name = "centre"\npoint = [0, 0, "-h"]', 'name = "inner"\npoint = ["a", "b", "-h"]')
        .replace('stiffness = ["c_h", "c_h", "c_c"]', 'stiffness = ["c_h", "c_h", "c_w"]')
    )
    path = folder / f"parallel_{role}.toml"
    path.write_text(text.replace('name = "central5"', f'name = "parallel_{role}"'))
    return path


def test_two_stiffnesses_in_parallel_are_determined_by_no_set_of_frequencies(capsys, tmp_path):
    """Two isolators at each corner, their vertical stiffnesses two unknowns: the frequencies see their sum only,
    so all six leave them undetermined and no mode would complete them; describe says so after the sets (each
    set's line said it of that set alone), and of central5, which z completes, says nothing more."""
    machine = Machine.resolve(str(path := _parallel(tmp_path)))
    found = machine.undetermined_by(machine.unique_modes)
    assert found is not None and found.unknowns == ("c_v", "c_w") and found.completing == () and not found.by_all
    assert found.advice() == "no set of the description's frequencies determines them"
    assert main(["describe", str(path)]) == 0
    assert capsys.readouterr().out.splitlines()[-2] == (
        "  all together: c_v, c_w are not determined by x, y, z, psi, theta, phi: no set of the description's "
        "frequencies determines them"
    )
    assert main(["describe", CENTRAL5, "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["undetermined_by_all"] == []
    assert main(["describe", CENTRAL5]) == 0
    assert "all together" not in capsys.readouterr().out


def test_a_fit_to_frequencies_that_leave_an_unknown_undetermined_is_an_error_not_a_standard_deviation_of_zero():
    """fit_stiffness returned c_c at its start with a standard deviation of 0 from five frequencies without z
    (the gap diagnosis and the plan took it so); now an error that names it and the mode that determines it."""
    machine = Machine.resolve(CENTRAL5)
    omega = machine.frequencies({**CENTRAL5_KNOWN, "c_h": 1.3e5, "c_v": 4.5e5, "c_c": 9e5})
    measured = {label: (omega[label], 1e-3 * omega[label]) for label in ("x", "y", "psi", "theta", "phi")}
    with pytest.raises(InputError, match=r"^measured: c_c is not determined by x, y, psi, theta, phi: z with them"):
        fit_stiffness(machine, CENTRAL5_KNOWN, measured)
    fit = fit_stiffness(machine, CENTRAL5_KNOWN, {**measured, "z": (omega["z"], 1e-3 * omega["z"])})
    assert fit.parameters["c_c"] == pytest.approx(9e5, rel=1e-6)


def test_identify_names_the_unknown_the_frequencies_leave_undetermined(capsys):
    """On the command line: one line, exit code 2 (it said "no generated inverse has an admissible root")."""
    measured = ["x=25.008", "y=23.883", "phi=33.27", "psi=56.05", "theta=63.387"]
    assert main(["identify", CENTRAL5, "--measured", *measured]) == 2
    err = capsys.readouterr().err.strip()
    assert err == (
        "mountid: error: --measured: c_c is not determined by x, y, psi, theta, phi: z with them would determine it"
    )


def _campaign(labels: tuple[str, ...]) -> dict:
    machine = Machine.resolve(CENTRAL5)
    omega = machine.frequencies({**CENTRAL5_KNOWN, "c_h": 1.2e5, "c_v": 5e5, "c_c": 8e5})
    rng = np.random.default_rng(5)
    return {
        "name": "central5 frequencies",
        "machine": CENTRAL5,
        "known": CENTRAL5_KNOWN,
        "modes": {
            label: {"frequency": omega[label] * (1 + 1e-3 * rng.standard_normal()), "uncertainty": 1e-3 * omega[label]}
            for label in labels
        },
    }


def test_a_mode_that_alone_determines_an_unknown_is_not_held_out():
    """The gap report's held-out prediction of z from the others was c_c's start (the nominal identification's
    table) or wherever the refit stopped (the candidates' exact leave-one-out: z 8.5 rad/s off on a record of
    the nominal machine, held-out RMS 3.5 against 0.056 after any effect): neither is a prediction. z has no
    held-out row, a note says why, and the refitted held-out error is nan, as the linearised one."""
    campaign = parse(_campaign(("x", "y", "z", "psi", "theta", "phi")))
    where = diagnose_where(campaign)
    assert [r.label for r in where.residuals if r.held_out] == ["x", "y", "psi", "theta", "phi"]
    assert "z is not predicted from the others: c_c is not determined by x, y, psi, theta, phi" in where.notes
    report = diagnose(campaign)
    assert math.isnan(report.effects.nominal.held_out_gap["z"])
    assert all(math.isfinite(report.effects.nominal.held_out_gap[label]) for label in ("x", "psi", "theta", "phi"))


def test_a_campaign_without_the_mode_that_determines_an_unknown_is_an_error(capsys, tmp_path):
    """A campaign of the five modes besides z: the nominal identification cannot give c_c (exit code 2)."""
    path = tmp_path / "c.json"
    path.write_text(json.dumps(_campaign(("x", "y", "psi", "theta", "phi"))))
    assert main(["diagnose", str(path)]) == 2
    assert "c_c is not determined by x, y, psi, theta, phi: z with them would determine it" in capsys.readouterr().err


def test_identify_record_names_the_records_mode_that_would_determine_the_unknown(capsys, tmp_path):
    """A record of every mode, five chosen by --use without z: the error names z, which the record shows."""
    record = str(tmp_path / "c5.csv")
    sensors = [
        "P=0.7,0.45,0:1,0,0",
        "Q=0.7,0.45,0:0,1,0",
        "R=0.7,0.45,0:0,0,1",
        "S=-0.7,0.2,0.3:1,0,0",
        "T=-0.7,0.2,0.3:0,0,1",
    ]
    hit = ["--hit-point", "0.5,0.3,0.2", "--hit-direction", "1,0.7,-0.5", "--hit-peak", "1500"]
    assert main(["simulate", CENTRAL5, "--out", record, "--duration", "6", "--sensor", *sensors, *hit]) == 0
    capsys.readouterr()
    assert main(["identify-record", CENTRAL5, record, "--use", "x", "y", "psi", "theta", "phi"]) == 2
    err = capsys.readouterr().err
    assert err.startswith(
        "mountid: error: --use: c_c is not determined by x, y, psi, theta, phi; z with them would determine it; "
        "the record shows z: use it"
    )


def test_a_plan_gives_the_spread_of_the_unknowns_its_frequencies_determine_beside_those_they_do_not(tmp_path):
    """The plan said "none" for every unknown where one was undetermined. With c_v and c_w in parallel (only their
    sum is seen) c_h is still determined: its spread with them free equals the fit's where c_w is known instead
    (any way of resolving the null space gives a determined combination the same variance), and differs from the
    spread with both held."""
    from mountid.identification.from_records import pole_frequencies, pole_frequency_derivatives
    from mountid.identification.planning import _stiffness_spread
    from mountid.measurement.rig import Rig

    machine, held = Machine.resolve(str(_parallel(tmp_path))), Machine.resolve(str(_parallel(tmp_path, "known")))
    rig = Rig.of(machine)
    poles = dict(zip(machine.module.MODES, pole_frequencies(machine, rig.values), strict=True))
    frequencies = {label: (float(poles[label]), 1e-3 * float(poles[label])) for label in machine.unique_modes}
    notes: list[str] = []
    spread = _stiffness_spread(rig, frequencies, notes)
    assert math.isnan(spread["c_v"]) and math.isnan(spread["c_w"]) and math.isfinite(spread["c_h"])
    assert notes == [
        "no stiffness standard deviation of c_v, c_w: c_v, c_w are not determined by x, y, z, psi, theta, phi: no set "
        "of the description's frequencies determines them; the others' standard deviations with them free"
    ]
    known = {k: v for k, v in rig.values.items() if k not in held.unknown}
    damping = {n: rig.values[n] for n in machine.damping}
    fit = fit_stiffness(held, known, frequencies, damping=damping)
    assert fit.parameters["c_v"] == pytest.approx(rig.values["c_v"], rel=1e-6)
    assert spread["c_h"] == pytest.approx(fit.stds["c_h"], rel=1e-6)
    rows = [machine.module.MODES.index(label) for label in machine.unique_modes]
    d_omega = pole_frequency_derivatives(machine, rig.values, ("c_h",))[0, rows]
    sigma = np.array([frequencies[label][1] for label in machine.unique_modes])
    both_held = 1.0 / math.sqrt(np.sum((d_omega / sigma) ** 2))  # c_h alone fitted, c_v and c_w held
    assert spread["c_h"] > 1.01 * both_held  # 151.8 against 149.6 N/m: c_h correlates with the sum
