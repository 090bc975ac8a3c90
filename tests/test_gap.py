"""Campaign files and where the gap lies (issue 4, first half): checked on campaigns with a known truth."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest
from conftest import description_without_values

from mountid.cli import main
from mountid.diagnosis.campaign import load, parse
from mountid.diagnosis.gap import diagnose, diagnose_where
from mountid.effects import CATALOGUE
from mountid.errors import InputError
from mountid.machine import Machine
from mountid.validation.paper import TABLE_1

ROOT = Path(__file__).resolve().parents[1]
TRUTH = {"c_xy": 74.4e3, "c_z": 472.3e3}


def _campaign(freqs: dict[str, float], sigma: float | None = 0.01, **extra) -> dict:
    modes = {k: {"frequency": w, **({"uncertainty": sigma} if sigma else {})} for k, w in freqs.items()}
    return {"name": "test", "machine": "kid300", "known": dict(TABLE_1), "modes": modes, **extra}


def _measured(**changes) -> dict[str, float]:
    w = Machine.resolve("kid300").frequencies({**TABLE_1, **TRUTH, **changes})
    return {k: w[k] for k in ("x", "z", "psi", "phi")}


def test_no_gap_when_the_model_is_the_truth():
    report = diagnose_where(parse(_campaign(_measured())))
    assert report.verdict.startswith("no significant gap")
    assert report.parameters["c_z"] == pytest.approx(TRUTH["c_z"], rel=1e-9)
    assert report.localisation == []
    held = [r for r in report.residuals if r.held_out]
    assert len(held) == 4 and all(abs(r.z) < 1e-6 for r in held)  # leave-one-out predicts each exactly


def test_the_leave_one_out_fits_reuse_the_inverse_roots_of_the_full_fit():
    """Every subset of modes a leave-one-out fit solves the generated inverse on, the fit to all modes solved
    already (at the same frequencies): the roots are kept, and the report is the same without them kept."""
    from mountid.identification import from_records

    c = parse(_campaign(_measured(J_xy=TABLE_1["J_xy"] * 1.15)))
    from_records._inverse_starts.cache_clear()
    report = diagnose_where(c)
    kept = from_records._inverse_starts.cache_info()
    assert kept.misses == 6 and kept.hits == 12  # four distinct frequencies: six pairs, each in two of the 3-sets
    from_records._inverse_starts.cache_clear()
    assert repr(diagnose_where(c)) == repr(report)


def test_an_inertia_error_is_found_significant_and_localised_in_the_rocking_block():
    """Truth: J_xy 15 % larger than the campaign's known value (9.2 kg m^2). The gap is significant; a change
    of the rocking inertia M[psi,psi] = M[theta,theta], fitted together with the unknowns, removes it and
    comes out near the truth (first order). Four frequencies and two unknowns leave one degree of freedom,
    so other single entries can remove it too (a tie the candidate effects must break); the phi entries,
    which only the torsion feels, cannot."""
    report = diagnose_where(parse(_campaign(_measured(J_xy=TABLE_1["J_xy"] * 1.15))))
    assert report.verdict.startswith("significant gap")
    rocking = next(loc for loc in report.localisation if loc.matrix == "M" and ("psi", "psi") in loc.entries)
    assert rocking.explained > 0.99
    assert rocking.change == pytest.approx(0.15 * TABLE_1["J_xy"], rel=0.2)
    torsion = next(loc for loc in report.localisation if loc.matrix == "M" and loc.entries == (("phi", "phi"),))
    assert torsion.explained < 0.5


def test_a_localisation_beside_no_significant_gap_says_it_fits_misses_within_their_uncertainty(capsys):
    """The paper's four frequencies: no significant gap (p = 0.34), yet single matrix changes remove their small
    misses. Those are a lead only were the misses real, and the report says so on every matrix-level line and in
    the tie's note; where the gap is significant (J_xy 15 % off the known value) it says they remove the gap."""
    main(["diagnose", str(ROOT / "examples" / "kid300-paper.json"), "--no-figure"])
    text = capsys.readouterr().out
    assert "verdict: no significant gap" in text
    located = [line for line in text.splitlines() if "matrix level" in line]
    assert located and all(line.startswith("  matrix level (of misses within their uncertainty): ") for line in located)
    assert "single changes of matrix entries would remove the misses (within their uncertainty) equally well" in text
    report = diagnose(parse(_campaign(_measured(J_xy=TABLE_1["J_xy"] * 1.15)))).where
    assert not report.within_noise
    assert any("single changes of matrix entries remove the gap equally well" in note for note in report.notes)


def test_split_twins_are_reported_as_broken_symmetry():
    freqs = _measured()
    data = _campaign({**freqs, "y": freqs["x"] + 0.5}, sigma=0.05)
    report = diagnose_where(parse(data))
    assert report.verdict.startswith("broken symmetry") and "x and y" in report.broken_symmetry[0]


def _all_six(**changes) -> dict[str, float]:
    w = Machine.resolve("kid300").frequencies({**TABLE_1, **TRUTH, **changes})
    return {k: float(w[k]) for k in ("x", "y", "z", "psi", "theta", "phi")}


@pytest.mark.parametrize(
    ("z_xy", "z_rocking", "flagged"),
    [
        (2.1, 2.1, []),  # each beyond 2 sigma alone, neither among two tests (Holm: 2.24 sigma for the first)
        (5.0, 2.1, ["x and y", "psi and theta"]),  # step-down: after the first, the second against 2 sigma
        (5.0, 1.9, ["x and y"]),
    ],
)
def test_broken_symmetry_holds_its_level_over_several_pairs(z_xy, z_rocking, flagged):
    sigma = 0.01
    freqs = _all_six()
    step = sigma * 2**0.5  # the standard deviation of a difference of two frequencies
    freqs["y"] = freqs["x"] + z_xy * step
    freqs["theta"] = freqs["psi"] + z_rocking * step
    report = diagnose_where(parse(_campaign(freqs, sigma=sigma)))
    assert [" and ".join(b.split(" and ")[:2]).split(" are")[0] for b in report.broken_symmetry] == flagged


def test_sensitivities_match_the_closed_form_of_the_vertical_mode():
    """omega_z = 2 sqrt(c_z / m): d ln w / d ln c_z = 1/2, d ln w / d ln m = -1/2, nothing else."""
    report = diagnose_where(parse(_campaign(_measured())))
    s = report.sensitivities["z"]
    assert s["c_z"] == pytest.approx(0.5, abs=1e-12) and s["m"] == pytest.approx(-0.5, abs=1e-12)
    assert abs(s["c_xy"]) < 1e-12 and abs(s["J_xy"]) < 1e-12


@pytest.mark.parametrize("name", ["kid300", "rectangular", "screen6", "genset8", "skid1plane"])
def test_sensitivities_match_a_central_difference_of_the_forward_map(name):
    """d ln omega / d ln p from the generated d lambda / d p, against central differences (relative step 1e-5)
    of the generated frequencies in every forward argument, at the description's nominal values."""
    from mountid.diagnosis.gap import sensitivities
    from mountid.machine import Machine

    machine = Machine.resolve(name)
    mod = machine.module
    values = machine.values({}, mod.FORWARD_ARGUMENTS)
    modes = {
        label: {"frequency": w}
        for label, w in machine.frequencies(machine.values({}, tuple(machine.parameters))).items()
    }
    campaign = parse(
        {"machine": name, "known": {k: v for k, v in values.items() if k not in machine.unknown}, "modes": modes}
    )
    got = sensitivities(campaign, {u: values[u] for u in machine.unknown})
    h = 1e-5
    for arg in mod.FORWARD_ARGUMENTS:
        up, down = dict(values), dict(values)
        up[arg] *= 1 + h
        down[arg] *= 1 - h
        numeric = (np.log(mod.frequencies(**up)) - np.log(mod.frequencies(**down))) / (np.log1p(h) - np.log1p(-h))
        for label in campaign.modes:
            assert got[label][arg] == pytest.approx(numeric[mod.MODES.index(label)], abs=1e-7), (arg, label)


@pytest.mark.parametrize(
    ("edit", "start"),
    [
        (lambda d: d["modes"]["z"].update(frequency=-1.0), "modes.z.frequency: -1.0 is less than or equal"),
        (lambda d: d["modes"].update(w9={"frequency": 3.0}), "modes.w9: not a mode of kid300"),
        (lambda d: d.update(fit=["x", "theta"]), "fit: theta is not among the measured modes"),
        (lambda d: d["known"].update(c_z=1.0), "known.c_z: is an unknown to identify"),
        (lambda d: d.update(colour="red"), "campaign: Additional properties are not allowed"),
        # JSON files may hold NaN and Infinity (Python's json reads them); they passed the schema's bounds
        (lambda d: d["modes"]["z"].update(frequency=math.nan), "modes.z.frequency: must be a finite number"),
        (lambda d: d["known"].update(L_z=math.inf), "known.L_z: must be a finite number"),
        (lambda d: d.pop("modes"), "campaign: needs one of: 'modes' is a required property; or 'records'"),
        # a record entry of the object form: the fault inside it, not the whole entry against either form
        (lambda d: d.update(records=[{"file": "r.csv", "start": -1}]), "records.0.start: -1 is less than the minimum"),
        # values a double-precision model cannot take: a named error each (they were tracebacks, warnings or nan)
        (lambda d: d["modes"]["z"].update(frequency=1e300), "modes.z.frequency: 1e+300 rad/s is more than 10000"),
        (lambda d: d["modes"]["z"].update(frequency=1e-300), "modes.z.frequency: 1e-300 rad/s is more than 10000"),
        (lambda d: d["modes"]["z"].update(uncertainty=1e-12), "modes.z.uncertainty: 1e-12 rad/s is below 1e-09"),
        (lambda d: d["modes"]["z"].update(uncertainty=1e300), "modes.z.uncertainty: 1e+300 rad/s is as large as"),
        (lambda d: d["modes"]["z"].update(shape=[0, 0, 1, 0, 0, 0], shape_uncertainty=1e-300), "modes.z.shape_unc"),
        (lambda d: d["modes"]["z"].update(damping_ratio=0.1, damping_uncertainty=1e-300), "modes.z.damping_unc"),
        (lambda d: d["known"].update(b_z=1e300), "known.b_z: 1e+300 N s/m is 9.62e+296 times above"),
        (lambda d: d["known"].update(m=1e-3), "known.m: 0.001 kg is 8.39e+05 times below"),
        # a known value its kind cannot take, named where the campaign gives it (it was named "m" alone)
        (lambda d: d["known"].update(m=-1.0), "known.m: a mass must be positive, got -1 kg"),
        (lambda d: d["known"].update(L_z=-0.1), "known.L_z: a length must not be negative, got -0.1 m"),
        # frequencies at another excitation level: only of modes the campaign gives, as the same mode
        (
            lambda d: d.update(levels=[{"name": "soft", "modes": {"y": {"frequency": 9.0}}}]),
            "levels.0.modes.y: not among the campaign's modes (x, z, psi, phi)",
        ),
        (
            lambda d: d.update(levels=[{"name": "soft", "modes": {"w9": {"frequency": 9.0}}}]),
            "levels.0.modes.w9: not a mode of kid300",
        ),
        (
            lambda d: d.update(levels=[{"name": "soft", "modes": {"x": {"frequency": 1.0}}}]),
            "levels.0.modes.x.frequency: 1 rad/s is 0.0",
        ),
        (lambda d: d.update(levels=[{"name": "soft", "modes": {}}]), "levels.0.modes: {} should be non-empty"),
        (lambda d: d.update(levels=[{"modes": {"x": {"frequency": 9.0}}}]), "levels.0: 'name' is a required property"),
        (lambda d: d.update(nominal={"m": 900.0}), "nominal.m: not an unknown of kid300 (c_xy, c_z)"),
        (lambda d: d.update(nominal={"c_z": 1e12}), "nominal.c_z: 1e+12 N/m is 2.12e+06 times above"),
        (lambda d: d.update(nominal={"c_z": -1.0}), "nominal.c_z: -1.0 is less than or equal to the minimum of 0"),
        # an array or object the schema rejects is told briefly (it was quoted in full on the one line)
        (lambda d: d["modes"]["z"].update(shape=[0.0, 0.0, 1.0, 0.0, 0.0]), "modes.z.shape: a list of 5 items is too"),
        (lambda d: d["modes"]["z"].update(frequency={"value": 46.6}), "modes.z.frequency: an object is not of type"),
        (lambda d: d["modes"]["z"].update(shape=[0.0] * 6), "modes.z.shape: is all zeros"),
    ],
)
def test_bad_campaigns_are_rejected_by_entry(edit, start):
    data = _campaign(_measured())
    edit(data)
    with pytest.raises(InputError) as err:
        parse(data)
    assert str(err.value).startswith(start)


def test_a_campaign_that_is_not_an_object_is_named_briefly():
    with pytest.raises(InputError, match=r"^campaign: a list of 1 item is not of type 'object'$"):
        parse([_campaign(_measured())])


@pytest.mark.parametrize("scale", [1e-300, 1e-120, 1e120, 1e300])
def test_a_shape_at_any_scale_is_the_same_shape(scale):
    """A measured shape's scale carries nothing: one whose squares underflow or overflow (it ended in "SVD did not
    converge" with a traceback, or in overflow warnings) gives the same data rows and isolator force residuals."""
    from mountid.diagnosis.fitting import Data
    from mountid.diagnosis.gap import isolator_forces

    data = json.loads((ROOT / "examples" / "kid300-blind-tie.json").read_text())
    scaled = json.loads(json.dumps(data))
    for mode in scaled["modes"].values():
        mode["shape"] = [v * scale for v in mode["shape"]]
    given, extreme = parse(data), parse(scaled)
    length = given.machine.length_scale(given.known)
    assert np.allclose(Data(extreme, length).shape_matrix, Data(given, length).shape_matrix, rtol=1e-14, atol=1e-15)
    forces = [[f.change for f in isolator_forces(c, TRUTH)[0]] for c in (given, extreme)]
    assert np.allclose(forces[1], forces[0], rtol=1e-12, atol=1e-15)


def test_known_values_a_campaign_leaves_out_are_named_in_the_report(capsys):
    """A known parameter not in the campaign takes the description's value: the conventions say which, and the
    text report names them with their values (a damping parameter fitted to measured damping ratios is not one)."""
    nominal = {n: float(p["value"]) for n, p in Machine.resolve("kid300").parameters.items()}
    data = _campaign(_measured())  # the known values of Table 1, without the damping parameters
    del data["known"]["m"]
    assert parse(data).conventions()["known_from_description"] == {n: nominal[n] for n in ("m", "b_xy", "b_z")}
    data["known"].update(m=900.0, b_xy=300.0, b_z=1000.0)
    assert parse(data).conventions()["known_from_description"] == {}
    for k, mode in enumerate(data["modes"].values()):
        mode.update(damping_ratio=0.05 + 0.01 * k, damping_uncertainty=0.005)
    for name in ("m", "b_xy", "b_z"):
        del data["known"][name]
    assert parse(data).conventions()["known_from_description"] == {"m": nominal["m"]}
    main(["diagnose", str(ROOT / "examples" / "kid300-paper.json"), "--no-figure"])
    text = capsys.readouterr().out
    assert "known values not in the campaign, the description's used: b_xy = 337.2 N s/m, b_z = 1039 N s/m" in text


def test_nominal_values_a_description_leaves_out_are_identified_from_the_campaign(tmp_path):
    """Stiffnesses from every measured frequency, damping parameters from the measured damping ratios
    (fit_damping, as the records chain identifies them); a damping parameter the campaign cannot identify and
    does not know is named under known, and so is a ratio set that identifies no damping."""
    from dataclasses import replace

    from mountid.diagnosis.campaign import damping_std
    from mountid.identification.from_records import fit_damping

    description = str(description_without_values(tmp_path, ("c_xy", "c_z", "b_xy", "b_z")))
    ratios = {"x": 0.04, "z": 0.06, "psi": 0.05, "phi": 0.03}
    data = _campaign(_measured(), machine=description)
    for label, zeta in ratios.items():
        data["modes"][label]["damping_ratio"] = zeta
    c = parse(data)
    nominal = {n: c.machine.parameters[n]["value"] for n in ("c_xy", "c_z", "b_xy", "b_z")}
    assert nominal["c_xy"] == pytest.approx(TRUTH["c_xy"], rel=1e-9) and nominal["c_z"] == pytest.approx(TRUTH["c_z"])
    stated = {label: replace(m, damping_std=damping_std(m)) for label, m in c.modes.items()}  # the diagnosis's
    expected, _ = fit_damping(c.machine, {**TABLE_1, **nominal}, stated, ("b_xy", "b_z"))
    assert nominal["b_xy"] == pytest.approx(expected["b_xy"]) and nominal["b_z"] == pytest.approx(expected["b_z"])
    assert c.notes[0].startswith("nominal values identified from the measured frequencies and damping ratios")
    assert Machine.resolve(description).parameters["c_xy"]["value"] is None  # the description is not changed
    for label in ratios:
        del data["modes"][label]["damping_ratio"]
    with pytest.raises(InputError, match=r"^known\.b_xy: .* no measured mode has a damping ratio"):
        parse(data)
    parse({**data, "known": {**data["known"], "b_xy": 300.0, "b_z": 1000.0}})
    data["modes"]["x"]["damping_ratio"], data["modes"]["psi"]["damping_ratio"] = 0.9, 1e-4
    with pytest.raises(InputError, match=r"^machine: .* identify -?[0-9.]+ N s/m, not a damping"):
        parse(data)
    with pytest.raises(InputError, match=r"^machine: .* do not identify them: measured: 1 distinct frequency f"):
        parse(
            {**_campaign({"x": _measured()["x"]}, machine=description), "known": {**TABLE_1, "b_xy": 1.0, "b_z": 1.0}}
        )


def test_a_campaigns_nominal_values_replace_the_descriptions(tmp_path):
    """A campaign's ``nominal`` values of the unknowns are where the diagnosis starts and searches: the
    description's own values given there give the same report, other ones are echoed with the description's."""
    paper = json.loads((ROOT / "examples" / "kid300-paper.json").read_text(encoding="utf-8"))
    same = parse({**paper, "nominal": {"c_xy": 74.4e3, "c_z": 472.3e3}}, ROOT / "examples")
    assert same.notes == (
        "nominal values from the campaign: c_xy = 7.44e+04 N/m (the description's: 7.44e+04), "
        "c_z = 4.723e+05 N/m (the description's: 4.723e+05)",
    )
    assert (
        diagnose(same).to_dict() | {"campaign_notes": []}
        == diagnose(load(ROOT / "examples" / "kid300-paper.json")).to_dict()
    )
    other = parse({**paper, "nominal": {"c_xy": 50e3}}, ROOT / "examples")
    assert other.machine.parameters["c_xy"]["value"] == 50e3 and other.machine.parameters["c_z"]["value"] == 472.3e3
    # "identified": from the measured frequencies whatever the description gives, as for a description without them
    identified = parse({**paper, "nominal": "identified"}, ROOT / "examples")
    assert identified.notes[0].startswith("nominal values identified from the measured frequencies (the campaign asks")
    assert "c_xy = 7.465e+04 N/m (the description's: 7.44e+04)" in identified.notes[0]
    stripped = description_without_values(tmp_path, ("c_xy", "c_z"))
    without = parse({**paper, "machine": str(stripped)})
    for name in ("c_xy", "c_z"):
        assert identified.machine.parameters[name]["value"] == without.machine.parameters[name]["value"]
    with pytest.raises(
        InputError, match=r"^nominal: needs one of: 'guess' is not of type 'object'; or 'identified' was expected"
    ):
        parse({**paper, "nominal": "guess"})


def test_paper_worked_example_on_the_command_line(capsys, tmp_path):
    figure = tmp_path / "paper.png"
    code = main(["diagnose", str(ROOT / "examples" / "kid300-paper.json"), "--json", "--figure", str(figure)])
    out = json.loads(capsys.readouterr().out)
    assert code == 0 and figure.stat().st_size > 10_000
    z = next(r for r in out["residuals"] if r["mode"] == "z")
    assert z["held_out"] and z["residual"] == pytest.approx(46.60 - 47.466, abs=2e-3)
    assert out["parameters"]["c_z"] == pytest.approx(472.3e3, rel=1e-3)  # the paper's root, chosen by z and phi
    assert out["verdict"].startswith("no significant gap")  # 0.87 rad/s is 1.9 sigma of a raw 4 s FFT peak
    # four frequencies, two unknowns: every candidate is listed, none can be ranked, and the report says why
    names = {c["effect"] for c in out["candidates"]}
    assert names == {e.name for e in CATALOGUE}
    assert all(c["aicc"] is None for c in out["candidates"])
    assert any("too few to fit any candidate" in n for n in out["notes"])
    sensor = next(c for c in out["candidates"] if c["effect"] == "sensor_error")
    assert not sensor["applicable"] and "no mode shapes" in sensor["note"]


def test_campaign_file_errors_are_one_line(capsys, tmp_path):
    (tmp_path / "c.json").write_text("{not json")
    assert main(["diagnose", str(tmp_path / "c.json")]) == 2
    assert capsys.readouterr().err.startswith("mountid: error: campaign: c.json is not JSON")
    assert load(ROOT / "examples" / "kid300-paper.json").fit == ("x", "psi")


def test_blind_belt_example_on_the_command_line(capsys, tmp_path):
    """The README's second worked example: a drive belt hidden in a campaign with six modes and shapes."""
    figure = tmp_path / "belt.png"
    code = main(["diagnose", str(ROOT / "examples" / "kid300-blind-belt.json"), "--json", "--figure", str(figure)])
    out = json.loads(capsys.readouterr().out)
    assert code == 0 and figure.is_file()
    first = out["candidates"][0]
    assert first["effect"] == "drive_belt" and out["confident"]
    assert first["parameters"]["k_belt"] == pytest.approx(11846.7, rel=0.1)  # hidden truth (validation.blind)
    assert out["verdict"] == "significant gap, explained by drive_belt (probability 1.00)"
    assert out["kind"] == "confident"
    gap = out["gap"]
    sigma = json.loads((ROOT / "examples" / "kid300-blind-belt.json").read_text())["modes"]
    noise = float(np.sqrt(np.mean([m["uncertainty"] ** 2 for m in sigma.values()])))
    assert gap["before"]["rms_fitted"] > 10 * noise and gap["after"]["rms_fitted"] < 2 * noise
    assert len(out["isolator_force_residual"]) == 4


def test_diagnose_text_names_the_candidates_and_the_verdict(capsys, tmp_path):
    main(["diagnose", str(ROOT / "examples" / "kid300-blind-belt.json"), "--no-figure"])
    text = capsys.readouterr().out
    assert "drive_belt" in text and "gap [rad/s] before (nominal) -> after (drive_belt)" in text
    assert text.rstrip().endswith("verdict: significant gap, explained by drive_belt (probability 1.00)")
    # the belt's row: held-out RMS, median in the measurement's sigma, median in the prediction's own sigma
    row = next(line.split() for line in text.splitlines() if line.strip().startswith("drive_belt "))
    assert row[4] == row[6] == "|" and float(row[5]) > float(row[7]) > 0


def test_twin_map_carries_the_sign_of_each_coupling_entry():
    """The engine's twin map: kid300 C[y, psi] = -C[x, theta] (u_x = x + theta r_z, u_y = y - psi r_z)."""
    mod = Machine.resolve("kid300").module
    assert set(mod.TWIN_COORDINATES) == {("x", "y", 1), ("theta", "psi", -1)}
    C = mod.stiffness_matrix(c_xy=74.4e3, c_z=472.3e3, L_xy=0.486, L_z=0.3)
    x, y, psi, theta = (mod.COORDINATES.index(c) for c in ("x", "y", "psi", "theta"))
    assert C[y, psi] == -C[x, theta] != 0


def test_localise_finds_a_symmetric_change_of_a_coupled_twin_entry():
    """A coupling changed the way the symmetry allows (C[x, theta] by +d, C[y, psi] by -d) is found with its
    size and explains the whole gap; changing both by +d (the old, sign-blind pairing) would break the x/y
    symmetry and could not explain it."""
    import numpy as np
    import scipy.linalg

    from mountid.diagnosis.gap import Residual, localise

    campaign = load("examples/kid300-paper.json")
    mod = campaign.machine.module
    params = {"c_xy": 74.4e3, "c_z": 472.3e3}
    values = campaign.machine.values({**campaign.known, **params}, mod.FORWARD_ARGUMENTS)
    M = mod.mass_matrix(*(values[a] for a in mod.ARGUMENTS["mass_matrix"]))
    C = mod.stiffness_matrix(*(values[a] for a in mod.ARGUMENTS["stiffness_matrix"]))
    x, y, psi, theta = (mod.COORDINATES.index(c) for c in ("x", "y", "psi", "theta"))
    d = 0.002 * abs(C[x, theta])  # small: localise works to first order
    changed = C.copy()
    changed[x, theta] = changed[theta, x] = C[x, theta] + d
    changed[y, psi] = changed[psi, y] = C[y, psi] - d
    lam_nominal = mod.squared_frequencies(**values)
    residuals = []
    for k, label in enumerate(mod.MODES):
        idx = list(mod.BLOCKS[mod.MODE_BLOCK[k]])
        lam = scipy.linalg.eigh(changed[np.ix_(idx, idx)], M[np.ix_(idx, idx)], eigvals_only=True)
        residuals.append(
            Residual(label, float(np.sqrt(lam[mod.MODE_RANK[k] - 1])), float(np.sqrt(lam_nominal[k])), 1e-3, False)
        )
    best = localise(campaign, params, residuals)[0]
    assert best.matrix == "C" and best.entries == (("x", "theta"), ("y", "psi"))
    assert best.change == pytest.approx(d, rel=0.02)
    assert best.explained > 0.999


def test_frequencies_no_mount_fits_are_diagnosed_with_the_reason_noted(capsys, tmp_path):
    """Six made-up genset8 frequencies: the nominal identification's closest fit runs c_v2 to zero (three starts
    ended at 1e-72 .. 1e-86 N/m, one boundary; the diagnosis stopped on '3 solutions fit equally'). The gap
    diagnosis goes on from that fit, notes why, ends as not explained, and prints no nan."""
    modes = dict(zip(("x", "y", "z", "psi", "theta", "phi"), (10.0, 12.0, 20.0, 25.0, 30.0, 35.0), strict=True))
    campaign = {"machine": "genset8", "modes": {k: {"frequency": w, "uncertainty": 0.05} for k, w in modes.items()}}
    path = tmp_path / "made_up.json"
    path.write_text(json.dumps(campaign), encoding="utf-8")
    assert main(["diagnose", str(path), "--no-figure"]) == 0
    out = capsys.readouterr().out
    assert "note: no mount of this description fits these frequencies: the closest fit takes c_v2 to zero" in out
    assert "verdict: significant gap, not explained by any effect in the catalogue" in out
    assert not re.search(r"\bnan\b", out)


def test_the_residual_table_keeps_its_columns_apart_at_any_size():
    """Residuals from 1e-4 rad/s (records) to thousands of sigma: every row splits into its seven cells, the
    frequencies carry the decimals their uncertainty needs, and no gap or z prints as a negative zero."""
    from mountid.diagnosis.gap import Residual
    from mountid.report.text import _residual_table

    rows = [
        Residual("x", 16.662013, 17.705961, 0.0002, True),
        Residual("psi", 64.097791, 64.097952, 0.000744, False),
        Residual("phi", 36.91, 36.91 + 1e-12, 0.45, False),
        Residual("z", 47.46709, 47.88671, None, True),
    ]
    head, *lines = _residual_table(rows)
    assert head.split() == ["mode", "measured", "predicted", "gap", "sigma", "z", "use"]
    cells = [line.split() for line in lines]
    assert [c[0] for c in cells] == ["x", "psi", "phi", "z"]
    assert cells[0][1:6] == ["16.66201", "17.70596", "-1.04395", "0.0002", "-5219.74"]
    assert cells[1][1:4] == ["64.09779", "64.09795", "-0.00016"] and cells[2][3:6] == ["+0.00000", "0.45", "+0.00"]
    assert cells[3][-2:] == ["held", "out"] and len(cells[3]) == 6  # no uncertainty: sigma and z left blank
    assert not [c for row in cells for c in row if re.fullmatch(r"-0\.0+", c)]


def test_a_gap_in_the_damping_ratios_is_shown_and_named(capsys, tmp_path, monkeypatch):
    """Every mode at the same damping ratio (rubber with a loss factor, which viscous b_xy, b_z cannot give):
    frequencies exact, damping ratios 0.05 +- 0.002. The report shows each ratio's gap in sigma, splits the
    nominal chi^2 by kind, and the verdict leads to the damping ratios, not to a frequency effect."""
    known = {"m": 838.6, "J_xy": 61.44, "J_z": 51.52, "L_xy": 0.486, "L_z": 0.3}
    machine = Machine.resolve("kid300")
    f = machine.frequencies(machine.values(known | {"c_xy": 74.4e3, "c_z": 472.3e3}, tuple(machine.parameters)))
    modes = {
        lab: {"frequency": f[lab], "uncertainty": 1e-4 * f[lab], "damping_ratio": 0.05, "damping_uncertainty": 0.002}
        for lab in ("x", "z", "psi", "phi")
    }
    path = tmp_path / "loss.json"
    path.write_text(json.dumps({"machine": "kid300", "known": known, "modes": modes}), encoding="utf-8")
    assert main(["diagnose", str(path), "--no-figure"]) == 0
    out = capsys.readouterr().out
    assert re.search(r"nominal chi\^2 = [\d.]+ \(frequencies [\de.+-]+, damping ratios [\d.]+\)", out)
    rows = dict(re.findall(r"^  (x|z|psi|phi) +0\.0500 \+- 0\.002 +([+-][\d.]+)", out, flags=re.M))
    assert set(rows) == {"x", "z", "psi", "phi"} and abs(float(rows["x"])) > 5
    verdict = out.strip().splitlines()[-1]
    assert "not explained" in verdict and "lead: the damping ratios (chi^2" in verdict, verdict
    assert "removes -0%" not in verdict
    # the figure draws the damping ratios' gaps beside the frequencies'
    from mountid.diagnosis.campaign import load
    from mountid.diagnosis.gap import diagnose
    from mountid.report import figures

    drawn = []

    def keep(fig, where):
        drawn.append([t.get_text() for t in fig.axes[0].get_xticklabels()])
        return real_save(fig, where)

    real_save = figures._save
    monkeypatch.setattr(figures, "_save", keep)
    figures.diagnosis_figure(diagnose(load(path)), tmp_path / "f.png")
    assert drawn == [["x", "z", "psi", "phi", "\u03b6 x", "\u03b6 z", "\u03b6 psi", "\u03b6 phi"]]


def test_the_diagnosis_figure_draws_each_held_out_prediction_with_its_own_spread(monkeypatch, tmp_path):
    """The README's belt: held out, x is predicted 700 sigma off by the belt, whose parameters only x determines
    well. Drawn without its spread that read as a failed prediction beside the verdict "explained"; each held-out
    bar carries its prediction's own standard deviation (sqrt(held_out_variance), in sigma) as a whisker."""
    from mountid.diagnosis.campaign import load
    from mountid.diagnosis.gap import diagnose
    from mountid.report import figures

    diagnosis = diagnose(load(Path("examples/kid300-blind-belt.json")))
    drawn = []

    def keep(fig, where):
        drawn.append({c.get_label(): c for c in fig.axes[0].containers})
        figures.plt.close(fig)

    monkeypatch.setattr(figures, "_save", keep)
    figures.diagnosis_figure(diagnosis, tmp_path / "f.png")
    best = diagnosis.effects.best
    labels = list(diagnosis.effects.nominal.frequency_gap)
    for name, fit in (("before, held out", diagnosis.effects.nominal), (f"{best.effect}, held out", best)):
        whiskers = drawn[0][name].errorbar.lines[2][0].get_segments()
        half = [abs(w[1][1] - w[0][1]) / 2 for w in whiskers]
        np.testing.assert_allclose(half, np.sqrt([fit.held_out_variance[k] for k in labels]), rtol=1e-12)
    assert drawn[0]["before, fitted"].errorbar is None
    x = labels.index("x")
    # the belt's x held out: a gap of more than 100 sigma, drawn with a spread of more than 100 sigma
    assert abs(best.held_out_gap["x"]) / diagnosis.campaign.modes["x"].frequency_std > 100
    assert half[x] > 100


def test_the_diagnosis_figure_leaves_a_series_without_bars_out_of_its_legend(monkeypatch, tmp_path):
    """fan3's six frequencies (tests/data/fan3-frequencies.json): the first candidate, an attached mass, has more
    parameters than data, so no mode can be left out for it and its held-out series has no bar; the legend
    listed it all the same. The fitted series and the nominal model's held-out one stay. The verdict names the tie's
    foundation (more parameters than data too) once: it named it in the tie and again as "not ruled out"."""
    from mountid.diagnosis.campaign import load
    from mountid.diagnosis.gap import diagnose
    from mountid.report import figures

    diagnosis = diagnose(load(Path(__file__).parent / "data" / "fan3-frequencies.json"))
    drawn = []

    def keep(fig, where):
        drawn.append([t.get_text() for t in fig.axes[0].get_legend().get_texts()])
        figures.plt.close(fig)

    monkeypatch.setattr(figures, "_save", keep)
    figures.diagnosis_figure(diagnosis, tmp_path / "f.png")
    assert diagnosis.effects.best.effect == "added_mass"
    assert drawn == [["within 2 sigma", "before, fitted", "before, held out", "added_mass, fitted"]]
    best = diagnosis.effects.best
    assert "foundation" in diagnosis.effects.tie and best.n_data <= best.n_parameters
    assert diagnosis.effects.verdict.count("foundation") == 1, diagnosis.effects.verdict
    # six frequencies, no shapes: what separates the tie is a shape not measured
    lines = diagnosis.effects.separation
    assert lines and all(" measure the mode shape of " in line for line in lines), lines


RECORD_SIGMA = {"y": 0.0009, "x": 0.00106, "phi": 0.0312, "z": 0.00582, "psi": 0.00997, "theta": 0.0122}
"""Standard deviations [rad/s] of the rectangular machine's modes from one 20 s record with 2 % sensor noise
(`mountid simulate rectangular --noise 0.02`, eight channels): precise where the hit drives a mode hard."""


def _rectangular(shift: dict[str, float]) -> dict:
    """A campaign of the rectangular machine's true frequencies (its description's values) with RECORD_SIGMA,
    each moved by ``shift`` of its own standard deviations."""
    w = Machine.resolve("rectangular").frequencies({})
    modes = {k: {"frequency": w[k] + shift.get(k, 0.0) * s, "uncertainty": s} for k, s in RECORD_SIGMA.items()}
    return {"machine": "rectangular", "modes": modes}


def test_a_held_out_gap_is_judged_with_the_predictions_own_uncertainty():
    """The nominal machine, its phi frequency 1.8 of its (large) standard deviations high: the fit to the other
    modes predicts y and x by 0.02-0.07 rad/s off, 20-60 standard deviations of their precise measurements but
    about one of the prediction's own. Judged on the measurement's alone they were a significant gap on a clean
    machine ('held out *', localised); with the prediction's in quadrature nothing is significant."""
    report = diagnose_where(parse(_rectangular({"phi": 1.8})))
    held = {r.label: r for r in report.residuals if r.held_out}
    assert abs(held["y"].residual) > 20 * held["y"].uncertainty  # what was called significant
    assert held["y"].prediction_std > 10 * held["y"].uncertainty
    assert not any(r.significant for r in report.residuals)
    assert report.verdict.startswith("no significant gap")


def test_the_prediction_uncertainty_of_a_held_out_mode_matches_a_monte_carlo():
    """Residual.prediction_std (first order) against 150 fits to the other five modes drawn with their stated
    standard deviations: the spread of the predicted y frequency agrees within 20 % (sampling error about 6 %)."""
    from mountid.identification.from_records import fit_stiffness

    machine = Machine.resolve("rectangular")
    truth = machine.frequencies({})
    stated = next(r for r in diagnose_where(parse(_rectangular({}))).residuals if r.held_out and r.label == "y")
    rng = np.random.default_rng(7)
    predicted = []
    for _ in range(150):
        data = {k: (truth[k] + rng.normal() * s, s) for k, s in RECORD_SIGMA.items() if k != "y"}
        params, _, _ = fit_stiffness(machine, {}, data, boundary_ok=True)
        predicted.append(machine.frequencies(params)["y"])
    assert np.std(predicted) == pytest.approx(stated.prediction_std, rel=0.2)


def test_with_no_datum_to_spare_no_mode_is_held_out_and_the_report_says_what_the_probabilities_are(capsys, tmp_path):
    """Two frequencies fitted for two unknowns: every candidate has at least as many parameters as data, so each
    mode's leverage is 1 and none can be held out. The hat matrix from J^T J gave leverages of 1 +- 1e-8, held-out
    variances of +-1e9..1e16 (negative ones among them: the figure's error bars warned, sqrt of a negative); from
    the SVD of J every held-out error and variance is nan. The report says the candidates' probabilities are
    their priors' share, not a fit's, and singles none out as the best (the gap table's 'after', the figure's
    bars)."""
    from mountid.report.figures import diagnosis_figure
    from mountid.report.text import print_diagnosis

    w = _measured(J_xy=TABLE_1["J_xy"] * 1.15)
    diagnosis = diagnose(parse(_campaign({k: w[k] for k in ("x", "z")}, fit=["x", "z"])))
    assert diagnosis.effects.kind == "cannot judge"
    fitted = [f for f in diagnosis.effects.ranked if f.applicable]
    assert len(fitted) > 5
    for f in fitted:
        assert f.n_parameters >= f.n_data
        assert all(math.isnan(v) for v in (*f.held_out_variance.values(), *f.held_out_gap.values())), f.effect
    diagnosis_figure(diagnosis, tmp_path / "f.png", title="two for two")  # warnings are errors in the tests
    print_diagnosis(diagnosis, "two for two", None)
    text = capsys.readouterr().out
    assert "(2 data for 2 unknowns: every candidate fits them exactly and has no mode to hold out;" in text
    assert diagnosis.effects.best is None and "after" not in diagnosis.gap_table()  # no candidate singled out
    assert "gap [rad/s] before (nominal) -> after" not in text


def test_a_gap_report_goes_on_where_some_modes_have_no_inverse_root():
    """screen6 on a heavy slab, as its records label it: the inverses over five of the six modes (leaving psi out)
    have no admissible root, and the leave-one-out fit stopped the whole diagnosis with 'no generated inverse
    has an admissible root'. It starts from the description's values instead; every mode gets its held-out
    prediction and the gap is significant."""
    measured = {"x": 16.922, "z": 32.776, "psi": 37.414, "y": 47.374, "theta": 73.535, "phi": 26.554}
    data = {"machine": "screen6", "modes": {k: {"frequency": w, "uncertainty": 0.01} for k, w in measured.items()}}
    report = diagnose_where(parse(data))
    assert {r.label for r in report.residuals if r.held_out} == set(measured)
    assert report.verdict.startswith("significant gap")


def _inverse_calls(monkeypatch) -> list[tuple[str, ...]]:
    """The subsets of modes whose generated inverse fit_stiffness solves from here on (the kept roots cleared)."""
    from mountid.identification import from_records

    solved: list[tuple[str, ...]] = []
    real = from_records._inverse_starts.__wrapped__

    def counting(mod, key, *args):
        solved.append(key)
        return real(mod, key, *args)

    monkeypatch.setattr(from_records, "_inverse_starts", counting)
    return solved


def test_the_gap_report_fits_near_the_description_without_the_numeric_inverses(monkeypatch):
    """skid1plane's fifteen inverses over two of its six modes are numeric (a grid of 81 starts each), 0.39 s of
    a 0.89 s diagnosis: the gap report starts its fits from the description's nominal values instead and reports
    what the grid search does (checked on 198 blind campaigns: parameters within 1e-8). Identification outside
    the gap report still searches them."""
    from mountid.identification.from_records import fit_stiffness
    from mountid.validation import blind

    c = parse(blind.make_case(2003, "cog_height", machine="skid1plane")[0])
    solved = _inverse_calls(monkeypatch)
    report = diagnose_where(c)
    assert solved == []
    data = {lab: (m.frequency, m.stated_frequency_std) for lab, m in c.modes.items()}
    searched = fit_stiffness(c.machine, c.known, data, boundary_ok=True)
    assert len(solved) == 15
    for name, value in searched.parameters.items():
        assert report.parameters[name] == pytest.approx(value, rel=1e-8)
    assert report.verdict.startswith("significant gap")


def test_the_gap_report_searches_the_numeric_inverses_where_the_fit_near_the_description_ends_at_a_boundary(
    monkeypatch,
):
    """Where every fit from the closed forms' roots and the description's values runs an unknown to zero or
    without bound (here made so: such fits count as left behind until a numeric inverse has been solved), the
    numeric inverses are searched after all, and the report is the full search's."""
    from mountid.identification import from_records
    from mountid.validation import blind

    c = parse(blind.make_case(2003, "cog_height", machine="skid1plane")[0])
    expected = diagnose_where(c)
    solved = _inverse_calls(monkeypatch)
    real = from_records._left_behind
    monkeypatch.setattr(from_records, "_left_behind", lambda jac: real(jac) | (not solved))
    report = diagnose_where(c)
    assert len(set(solved)) == 15
    assert report.parameters == pytest.approx(expected.parameters, rel=1e-8)


def test_single_changes_that_explain_the_gap_equally_keep_the_order_they_were_found_in():
    """C[phi,phi] and M[phi,phi] of a mode alone in its block explain the same share; which one the verdict names
    first no longer rests on the last bits of that share (genset8, two fits 1e-11 apart named either)."""
    from mountid.diagnosis.gap import Localisation, _by_share

    def loc(matrix: str, share: float) -> Localisation:
        return Localisation(matrix, (("phi", "phi"),), 1.0, "", share)

    for tiny in (1e-12, -1e-12):
        found = [loc("C", 0.87), loc("M", 0.87 + tiny), loc("C", 0.9), loc("M", 0.5)]
        assert [(x.matrix, x.explained) for x in _by_share(found)] == [
            ("C", 0.9),
            ("C", 0.87),
            ("M", 0.87 + tiny),
            ("M", 0.5),
        ]
