"""The command-line contract on the bad inputs a new user tried: one line naming the parameter and the
reason, exit code 2, no traceback and no RuntimeWarning (pytest turns warnings into errors here); and the
notes a user needs: nominal values taken from the description, conditioning, undetermined unknowns."""

from __future__ import annotations

import io
import json
import re
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import description_without_values

from mountid.cli import main
from mountid.effects import CATALOGUE
from mountid.errors import InputError
from mountid.generated import kid300
from mountid.validation.paper import TABLE_1

PAPER = "examples/kid300-paper.json"
OFFCENTRE = "tests/data/offcentre.toml"  # no plane of symmetry, a product of inertia
FAN3_CAMPAIGN = "tests/data/fan3-frequencies.json"  # fan3.toml: three isolators, no plane of symmetry declared


def run(capsys, *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture
def files(tmp_path):
    """Bad files: binary and UTF-16 campaigns, a binary CSV, a text file named .uff or .tdms, a plain file, a CSV
    with a tachometer's channel."""
    (tmp_path / "binary.json").write_bytes(b"\x00\x01\x02\xff")
    text = Path(PAPER).read_text(encoding="utf-8")
    (tmp_path / "utf16.json").write_bytes(text.encode("utf-16"))
    (tmp_path / "binary.csv").write_bytes(b"\x00\x01\xff\xfe")
    (tmp_path / "text.uff").write_text("hello\n")
    (tmp_path / "text.tdms").write_text("hello\n")
    (tmp_path / "afile").write_text("")
    rows = "".join(f"{k / 1000!r},{(-1) ** k * 0.01!r},5.0\n" for k in range(400))
    (tmp_path / "tacho.csv").write_text("time,A_x [g],Tacho [V]\n" + rows, encoding="utf-8")
    campaign = json.loads(Path("examples/kid300-blind-belt.json").read_text(encoding="utf-8"))
    campaign["sensors"][0]["direction"] = [0, 0, 0]
    (tmp_path / "zero_direction.json").write_text(json.dumps(campaign), encoding="utf-8")
    return tmp_path


CASES = [
    (["diagnose", "{d}/binary.json", "--no-figure"], "campaign:"),
    (["diagnose", "{d}/utf16.json", "--no-figure"], "campaign:"),
    (["identify-record", "kid300", "{d}/binary.csv"], "record:"),
    (["identify-record", "kid300", "{d}/text.uff"], "record:"),
    (["process", "kid300", "{d}/text.tdms"], "record: text.tdms is not a TDMS file"),
    # a bench's channel mountid does not read: named, with how to leave it out; a name to leave out the file lacks
    (["process", "kid300", "{d}/tacho.csv"], "Tacho: is a raw voltage in V: give its sensor's sensitivity, as"),
    (["process", "kid300", "{d}/tacho.csv", "--sensitivity", "A_x=100mV/g"], "--sensitivity: A_x: is recorded in g"),
    (["process", "kid300", "{d}/tacho.csv", "--sensitivity", "Tacho=-1mV/g"], "--sensitivity Tacho: '-1mV/g': must"),
    (["process", "kid300", "{d}/tacho.csv", "--ignore", "Rpm"], "--ignore: Rpm: no such column in tacho.csv (columns"),
    (["process", "kid300", "{d}/tacho.csv", "--ignore", "Tacho", "--run", "2"], "--run: 2: tacho.csv is a CSV of one"),
    (["simulate", "kid300", "--out", "{d}/missing/x.csv"], "--out:"),
    (["simulate", "kid300", "--out", "{d}/x.wav"], "--out:"),  # a record the name would misdescribe
    # no sample, or fewer than a record holds: named as the option, before the machine is built
    (["simulate", "kid300", "--out", "{d}/x.csv", "--duration", "1e-4", "--rate", "1000"], "--duration: 0.0001 s"),
    # a hit at or after the record's end would leave a record of noise
    (
        ["simulate", "kid300", "--out", "{d}/x.csv", "--hit-time", "4"],
        "--hit-time: 4 s is at or after the record's end",
    ),
    (["simulate", "kid300", "--out", "{d}/x.csv", "--hit-time", "-0.1"], "--hit-time: must be >= 0 and finite"),
    (["simulate", "kid300", "--out", "{d}/x.csv", "--rate", "200", "--shaker", "0.5", "90"], "--shaker: 0.5 90: a"),
    (["simulate", "kid300", "--out", "{d}/x.csv", "--shaker", "1", "20", "--speed", "100"], "--shaker: a shaker and"),
    (["simulate", "kid300", "--out", "{d}/x.csv", "--shaker", "1", "20", "--hit-time", "1"], "--shaker: drives the"),
    (["simulate", "kid300", "--out", "{d}/x.csv", "--shaker", "1", "20", "--shaker-period", "0"], "--shaker-period:"),
    (
        ["simulate", "kid300", "--out", "{d}/x.csv", "--shaker", "1", "20", "--duration", "64", "--shaker-burst", "1"],
        "--shaker-burst: 1:",
    ),
    (["simulate", "kid300", "--out", "{d}/x.csv", "--shaker-burst", "0.5"], "--shaker-burst: is a shaker's"),
    (["simulate", "kid300", "--out", "{d}/x.csv", "--shaker-random"], "--shaker-random: is a shaker's"),
    (
        ["simulate", "kid300", "--out", "{d}/x.csv", "--shaker", "1", "20", "--shaker-random", "--shaker-burst", "0.5"],
        "--shaker-random: and --shaker-burst are two",
    ),
    # a hit's options beside a test without hits: refused, not ignored (a shaker takes the point and direction)
    (["simulate", "kid300", "--out", "{d}/x.csv", "--speed", "113", "--hit-point", "0,0,0"], "--hit-point: is a hit"),
    (["simulate", "kid300", "--out", "{d}/x.csv", "--speed", "113", "--hit-time", "0.2"], "--hit-time: is a hit's:"),
    (
        ["simulate", "kid300", "--out", "{d}/x.csv", "--ambient", "100", "--hit-direction", "1,0,0"],
        "--hit-direction: is a hit's: --ambient gives a test without hits, where it would be ignored",
    ),
    (["simulate", "kid300", "--out", "{d}/x.csv", "--ambient", "100", "--hit-peak", "20"], "--hit-peak: is a hit's"),
    (
        ["simulate", "kid300", "--out", "{d}/x.csv", "--shaker", "1", "20", "--duration", "40", "--hit-peak", "20"],
        "--hit-peak: is a hit's: --shaker gives",
    ),
    # several hits of one hammer: in increasing order, each after the pulse before
    (["simulate", "kid300", "--out", "{d}/x.csv", "--hit-time", "1", "0.5"], "--hit-time: 0.5 s is not after the hit"),
    (["simulate", "kid300", "--out", "{d}/x.csv", "--hit-time", "1", "1.002"], "--hit-time: 1.002 s is not after"),
    (["simulate", "kid300", "--out", "{d}/x.csv", "--hit-time", "1", "5"], "--hit-time: 5 s is at or after the"),
    # a load cell: not under an unbalance, not of a response channel's name (two columns of one name)
    (["simulate", "kid300", "--out", "{d}/x.csv", "--force-channel", "F", "--speed", "50"], "--force-channel: a rot"),
    (["simulate", "kid300", "--out", "{d}/x.csv", "--force-channel", "A_x"], "--force-channel: 'A_x' is a response"),
    (["simulate", "kid300", "--out", "{d}/x.csv", "--force-channel", ""], "--force-channel: '' is empty"),
    (["plan", "kid300", "--rate", "1"], "--duration: 4 s at 1 Hz is 4 samples per channel; a record needs at least"),
    # a zero direction named as the option that gave it (was "force.direction", "A.direction")
    (["plan", "kid300", "--hit-direction", "0,0,0"], "--hit-direction: '0,0,0': a direction must not be zero"),
    (["plan", "kid300", "--sensor", "A=0,0,0:0,0,0"], "--sensor A: '0,0,0': a direction must not be zero"),
    # one name for two channels: the second silently replaced the first
    (["plan", "kid300", "--sensor", "A=0,0,0:1,0,0", "A=1,0,0:0,1,0"], "--sensor A: given twice"),
    (["simulate", "kid300", "--out", "{d}/x.csv", "--sensor", "A=0,0,0:1,0,0", "A=0,0,0:0,0,1"], "--sensor A: given"),
    (["diagnose", PAPER, "--figure", "{d}/afile/x.png"], "--figure:"),
    # checked before the diagnosis: a folder was written to as "<folder>.png", ".txt" a traceback after the work
    (["diagnose", PAPER, "--figure", "{d}"], "--figure: {d} is a folder: name a figure file in it"),
    (["diagnose", PAPER, "--figure", "{d}/x.txt"], "--figure: x.txt: name a figure file ending in one of .avif"),
    # the vector as given, not numpy's repr of its entries (np.float64(0.0))
    (
        ["diagnose", "{d}/zero_direction.json", "--no-figure"],
        "sensors[0].direction: must be a non-zero 3-vector, got [0.0, 0.0, 0.0]",
    ),
    (["forced", "kid300", "--speed", "1e308"], "--speed:"),
    (["forced", "kid300", "--speed", "inf"], "--speed:"),
    (["forced", "kid300", "--speed", "100", "--unbalance-mass", "nan"], "--unbalance-mass:"),
    # an unbalance heavier than the machine it turns in, or 1e300 m off its axis (amplitudes of 1e297 m, exit 0)
    (["forced", "kid300", "--speed", "100", "--unbalance-mass", "1e300"], "--unbalance-mass: 1e+300 kg is more"),
    (["forced", "kid300", "--speed", "100", "--eccentricity", "1e300"], "--eccentricity: 1e+300 m is beyond"),
    (["simulate", "kid300", "--out", "{d}/x.csv", "--speed", "9", "--unbalance-mass", "900"], "--unbalance-mass:"),
    (["forced", "kid300", "--speed", "100", "--unbalance-axis", "0,0,0"], "--unbalance-axis: '0,0,0': a direction"),
    (["simulate", "kid300", "--out", "{d}/x.csv", "--speed", "9", "--unbalance-point", "1,2"], "--unbalance-point:"),
    (["simulate", "kid300", "--out", "{d}/x.csv", "--duration", "1e9"], "--duration:"),
    (["simulate", "kid300", "--out", "{d}/x.csv", "--rate", "-5"], "--rate:"),
    (["simulate", "kid300", "--out", "{d}/x.csv", "--seed", "-1"], "--seed: must be a non-negative integer"),
    (["frequencies", "kid300", "--set", "c_xy=1e308"], "--set c_xy:"),
    (["frequencies", "kid300", "--set", "c_xy=1e200"], "--set c_xy:"),  # was x = 0 with exit 0
    (["frequencies", "kid300", "--set", "J_xy=1e-300"], "--set J_xy:"),
    (["modes", "kid300", "--set", "c_z=1e300"], "--set c_z:"),
    (["frequencies", "kid300", "--set", "L_z=-0.1"], "--set L_z:"),
    (["identify", "kid300", "--measured", "x=17.71", "psi=64.1", "--std", "x=0.4"], "--std psi:"),
    (["identify", "kid300", "--measured", "x=17.71", "psi=64.1", "--std", "x=0.4", "psi=-1"], "--std psi:"),
    (["identify", "kid300", "--measured", "x=17.71", "psi=64.1", "--std", "x=0.4", "psi=nan"], "--std psi: is NaN"),
    (["identify", "kid300", "--measured", "x=17.71", "psi=64.1", "--std", "x=0.4", "z=1"], "--std z:"),
    # a label in --measured and in --std: each error names the option that gave the bad value
    (["identify", "kid300", "--measured", "x=-17.71", "psi=64.1", "--std", "x=0.4", "psi=1"], "--measured x:"),
    (["identify", "kid300", "--measured", "q=17.71", "psi=64.1"], "--measured q:"),
    (["identify", "kid300", "--measured", "x=17.71", "x=18", "psi=64.1"], "--measured x: given twice"),
    # twins given at once: equal, a repeat; apart, the split said with what it means (it said "repeats")
    (["identify", "kid300", "--measured", "x=17.6", "y=17.6", "psi=64.1"], "--measured y: repeats the frequency of x"),
    (
        ["identify", "kid300", "--measured", "x=17.6", "y=17.8", "psi=64.1"],
        "--measured y: x and y are one frequency of kid300's model (equal by symmetry), measured 17.6 and 17.8 rad/s "
        "(1.14% apart): give one of them, or their mean",
    ),
    (["frequencies", "kid300", "--set", "m=abc"], "--set m: not a number"),
    # mass properties no body has: was "out of the range of double precision (Matrix is not positive definite)"
    (["frequencies", OFFCENTRE, "--set", "J_xz=500"], "--set J_xz: 500 kg m^2: the mass matrix is not positive"),
    (["frequencies", OFFCENTRE, "--set", "J_xz=-5"], "--set J_xz: an inertia must be positive"),
]


@pytest.mark.parametrize(("argv", "named"), CASES, ids=[" ".join(a[:3]) for a, _ in CASES])
def test_bad_input_is_one_line_exit_2(capsys, files, argv, named):
    code, out, err = run(capsys, *(a.format(d=files) for a in argv))
    assert code == 2, (out, err)
    said = named.format(d=files)
    assert err.count("\n") == 1 and err.startswith(f"mountid: error: {said}") and "Traceback" not in err


def test_length_zero_is_a_design_and_an_undetermined_unknown_is_named(capsys):
    """L_z = 0 (isolators in the plane of the centre of mass): x and phi then depend on c_xy alone."""
    omega = kid300.frequencies(**(TABLE_1 | {"L_z": 0.0, "c_xy": 74.4e3, "c_z": 472.3e3}))
    x, phi = float(omega[kid300.MODES.index("x")]), float(omega[kid300.MODES.index("phi")])
    code, _, err = run(capsys, "identify", "kid300", "--measured", f"x={x!r}", f"phi={phi!r}", "--set", "L_z=0")
    assert code == 2
    assert err == "mountid: error: --measured: c_z is not determined by x, phi when L_z = 0 " + (
        "(the frequencies are reproduced, but the Jacobian is rank-deficient): measure another mode\n"
    )
    code, out, _ = run(capsys, "frequencies", "kid300", "--set", "L_z=0", "--json")
    assert code == 0 and np.isclose(json.loads(out)["frequencies"]["x"], x)


def test_nominal_values_are_named_when_used(capsys):
    code, out, _ = run(capsys, "frequencies", "kid300", "--set", "c_xy=74.4e3", "c_z=472.3e3", "m=838.6")
    assert code == 0
    assert out.splitlines()[-1].startswith("note: not given, the description's nominal values are used: J_xy = 61.44")
    assert "m = " not in out.splitlines()[-1]
    code, out, _ = run(capsys, "frequencies", "kid300", "--set", "J_z=51.52", "--json")
    defaults = json.loads(out)["defaults"]
    assert "J_z" not in defaults and defaults["c_xy"] == 74.4e3
    full = {**TABLE_1, "c_xy": 74.4e3, "c_z": 472.3e3}
    code, out, _ = run(capsys, "frequencies", "kid300", "--set", *(f"{k}={v}" for k, v in full.items()), "--json")
    assert json.loads(out)["defaults"] == {}


def test_identify_reports_conditioning_and_standard_deviations(capsys):
    """The paper's w1, w4 with 0.45 rad/s each: the unknowns' std from J^-1 agree with a Monte Carlo."""
    code, out, _ = run(
        capsys, "identify", "kid300", "--measured", "x=17.71", "psi=64.10", "--std", "x=0.45", "psi=0.45", "--json"
    )
    assert code == 0
    sols = json.loads(out)["solutions"]
    rng = np.random.default_rng(3)
    w1 = 17.71 + 0.45 * rng.standard_normal(4000)
    w4 = 64.10 + 0.45 * rng.standard_normal(4000)
    roots = kid300.identify_x_psi(**TABLE_1, omega_x=w1, omega_psi=w4)
    for k, sol in enumerate(sols):
        assert sol["condition"] > 1
        for u in ("c_xy", "c_z"):
            sample = roots.parameters[u][k][roots.admissible[k]]
            assert sol["parameter_std"][u] == pytest.approx(np.std(sample), rel=0.1)


def test_empty_batches_give_empty_arrays():
    empty = np.array([])
    roots = kid300.identify_x_psi(**TABLE_1, omega_x=empty, omega_psi=empty)
    assert roots.parameters["c_xy"].shape == (2, 0) and roots.admissible.shape == (2, 0)
    assert roots.jacobian.shape == (2, 0, 2, 2)
    assert kid300.frequencies(**TABLE_1, c_xy=empty, c_z=empty).shape == (0, 6)


def test_a_reader_that_stops_early_gets_no_error_message(capsys, monkeypatch, tmp_path):
    """`mountid ... | head -1`: the pipe's reader closes it and the next write raises BrokenPipeError; the command
    stops quietly (exit 1, nothing on stderr) instead of reporting 'file: Broken pipe'."""
    target = (tmp_path / "stdout").open("w")

    class ClosedPipe(io.StringIO):
        def write(self, text: str) -> int:
            raise BrokenPipeError(32, "Broken pipe")

        def fileno(self) -> int:
            return target.fileno()

    monkeypatch.setattr(sys, "stdout", ClosedPipe())
    assert main(["frequencies", "kid300"]) == 1
    target.close()
    assert capsys.readouterr().err == ""


@pytest.mark.parametrize("setting", [[], ["--set", "c_z=1e20"], ["--set", "m=1e5", "c_xy=1e3"]])
def test_the_modes_table_reads_back_as_the_json_numbers(capsys, setting):
    """Every row of `mountid modes` is six separated numbers that agree with --json to their printed digits, the
    frequencies too where they are wider than the column (kid300's z at c_z = 1e20 N/m: 6.91e+08 rad/s), and
    no entry prints as a negative zero."""
    code, out, _ = run(capsys, "modes", "kid300", *setting)
    assert code == 0
    code, text, _ = run(capsys, "modes", "kid300", *setting, "--json")
    data = json.loads(text)
    lines = out.splitlines()
    rows = {line.split()[0]: line.split()[1:] for line in lines[2:9]}
    shares = {line.split()[0]: line.split()[1:] for line in lines[12:18]}
    np.testing.assert_allclose([float(v) for v in rows["rad/s"]], list(data["frequencies"].values()), rtol=5e-3)
    for i, c in enumerate(data["coordinates"]):
        assert len(rows[c]) == len(shares[c]) == 6
        np.testing.assert_allclose([float(v) for v in rows[c]], data["modal_matrix"][i], atol=5e-5)
        np.testing.assert_allclose(
            [float(v) for v in shares[c]], np.multiply(data["kinetic_energy_distribution"][i], 100), atol=0.05
        )
    assert "-0.0 " not in out + " " and "-0.0000" not in out


def test_a_mount_that_leaves_a_motion_free_is_named_as_such(capsys, tmp_path):
    """A mechanism is not a range problem: kid300's isolators all at one point (L_xy = 0) leave x, y and phi
    without stiffness, and the error names L_xy; a description that declares one plane of symmetry where its
    isolators need two (two isolators on one line) names the machine at its nominal values and the motion left
    free (it named the mode "y" alone, which the isolators' shear holds as a translation). Stiffnesses or
    masses decades apart stay a range error naming that parameter."""
    for argv in (
        ["frequencies", "kid300"],
        ["identify", "kid300", "--measured", "x=17.71", "psi=64.1"],  # was "no physical mount produces these"
        ["identify", "kid300", "--measured", "x=17.71", "z=47", "psi=64.1", "phi=37"],  # was a traceback
    ):
        code, _, err = run(capsys, *argv, "--set", "L_xy=0")
        assert code == 2
        assert err.startswith("mountid: error: --set L_xy: 0 m: the isolators leave x, y, phi without stiffness")
    # before identifying, a stiffness 1e-10 of the others is a motion left free; y is as free as its twin x
    code, _, err = run(capsys, "identify", "kid300", "--measured", "x=17.71", "psi=64.1", "--set", "L_xy=1e-12")
    assert code == 2 and "L_xy: 1e-12 m: the isolators leave x, y, phi without stiffness" in err
    text = Path("derivations/rectangular.toml").read_text(encoding="utf-8")
    one_plane = tmp_path / "one_plane.toml"
    one_plane.write_text(text.replace('symmetry = ["yz", "xz"]', 'symmetry = ["yz"]'), encoding="utf-8")
    code, _, err = run(capsys, "frequencies", str(one_plane))
    assert code == 2
    # the one motion they leave is named as the rigid-body motion it is: a rotation about their line (y = b, z = -h)
    assert err.startswith(
        "mountid: error: machine: at rectangular's nominal values the isolators leave y (a rotation about the axis "
        "through (0, 0.5, -0.35) m along (1, 0, 0)) without stiffness"
    ), err
    for setting, named in (
        ("c_z=1e300", "--set c_z: 1e+300 N/m puts the model out of the range"),
        ("m=1e-300", "--set m: 1e-300"),
    ):
        code, _, err = run(capsys, "frequencies", "kid300", "--set", setting)
        assert code == 2 and err.startswith(f"mountid: error: {named}") and "without stiffness" not in err


def _strict(text: str):
    """JSON as other tools read it: NaN and Infinity are not JSON."""

    def refuse(constant: str):
        raise ValueError(f"{constant} in JSON output")

    return json.loads(text, parse_constant=refuse)


def test_every_command_with_json_prints_json(capsys, tmp_path):
    """Every command that takes --json prints strict JSON with it (describe and simulate ignored it and printed
    text); a record simulated here feeds process and identify-record."""
    record = str(tmp_path / "hit.csv")
    code, out, _ = run(capsys, "simulate", "kid300", "--out", record, "--duration", "4", "--json")
    assert code == 0 and _strict(out) == {
        "file": record,
        "format": "csv",
        "samples": 8000,
        "rate": 2000.0,
        "duration": 4.0,
        "channels": ["A_x", "A_y", "B_y", "A_z", "C_x"],
        "notes": [],
    }
    code, out, _ = run(capsys, "describe", "kid300", "--json")
    described = _strict(out)
    assert code == 0 and described["unknown"] == ["c_xy", "c_z"] and described["parameters"]["m"]["unit"] == "kg"
    assert {"modes": ["x", "psi"], "roots": 2, "numeric": None} in described["inverse_sets"]
    commands = [
        ["frequencies", "kid300"],
        ["identify", "kid300", "--measured", "x=17.71", "psi=64.10"],
        ["modes", "kid300"],
        ["plan", "kid300", "--rate", "10"],  # unstated stiffness spreads (nan inside) among them
        ["process", "kid300", record],
        ["identify-record", "kid300", record],
        ["forced", "kid300", "--speed", "50"],
        ["diagnose", PAPER, "--no-figure"],
    ]
    for argv in commands:
        code, out, _ = run(capsys, *argv, "--json")
        assert code == 0 and isinstance(_strict(out), dict), argv


def test_a_description_without_nominal_unknowns_is_diagnosed_from_the_identification(capsys, tmp_path):
    """Unknowns may come without a nominal value in a description (identify needs none, and a test engineer who
    measures to find the stiffness may know none). The diagnosis starts its fits at the nominal values and
    bounds them around there: without them it takes the identification on every measured frequency, says so,
    and reaches the verdict and nominal fit the description's values give (it failed with 'c_xy: missing')."""
    description = description_without_values(tmp_path, ("c_xy", "c_z"))
    campaign = json.loads(Path(PAPER).read_text(encoding="utf-8"))
    campaign["machine"] = str(description)
    (tmp_path / "c.json").write_text(json.dumps(campaign), encoding="utf-8")
    code, out, _ = run(capsys, "diagnose", str(tmp_path / "c.json"), "--no-figure", "--json")
    code_given, given, _ = run(capsys, "diagnose", PAPER, "--no-figure", "--json")
    out, given = json.loads(out), json.loads(given)
    assert code == code_given == 0 and out["kind"] == given["kind"] == "no significant gap"
    note = next(n for n in out["campaign_notes"] if n.startswith("nominal values identified"))
    assert re.search(r"c_xy = 7\.4\d+e\+04 N/m, c_z = 4\.\d+e\+05 N/m", note)
    assert out["parameters"] == pytest.approx(given["parameters"], rel=1e-9)  # the nominal identification
    assert out["nominal"]["parameters"] == pytest.approx(given["nominal"]["parameters"], rel=1e-6)  # its fit
    code, out, _ = run(capsys, "identify", str(description), "--measured", "x=17.71", "psi=64.10", "--json")
    assert code == 0 and len(json.loads(out)["solutions"]) == 2


def test_records_on_a_description_without_nominal_unknowns_are_labelled_at_given_values(capsys, tmp_path):
    """The records chain labels a record's poles against the model at the unknowns' nominal values: without them
    in the description it says so by name (it was 'c_xy: missing'), and --nominal gives the values to label with
    (identify-record then identifies the unknowns as with the description's values)."""
    description = str(description_without_values(tmp_path, ("c_xy", "c_z")))
    record = str(tmp_path / "hit.csv")
    assert run(capsys, "simulate", "kid300", "--out", record, "--duration", "4")[0] == 0
    code, _, err = run(capsys, "identify-record", description, record)
    assert code == 2 and err.startswith("mountid: error: --nominal: kid300 gives no nominal value for c_xy, c_z:")
    code, _, err = run(capsys, "frequencies", description)  # a forward command: the option that gives them
    assert code == 2 and err.startswith("mountid: error: c_xy: missing:") and "--set c_xy=VALUE" in err
    assert run(capsys, "frequencies", description, "--set", "c_xy=7e4", "c_z=4e5")[0] == 0
    _, given, _ = run(capsys, "identify-record", "kid300", record, "--json")
    given = json.loads(given)
    code, out, _ = run(capsys, "identify-record", description, record, "--nominal", "c_xy=74.4e3", "c_z=472.3e3")
    assert code == 0 and "c_xy = 74400" in out  # the description's values given: the same identification
    code, out, _ = run(
        capsys, "identify-record", description, record, "--nominal", "c_xy=74.4e3", "c_z=472.3e3", "--json"
    )
    assert json.loads(out)["parameters"] == given["parameters"]
    guess = ("--nominal", "c_xy=5e4", "c_z=3e5")  # another guess: another band for the pole fit, within the spread
    code, out, _ = run(capsys, "identify-record", description, record, *guess, "--json")
    for name, value in json.loads(out)["parameters"].items():
        assert abs(value - given["parameters"][name]) < given["parameter_std"][name], name
    code, out, _ = run(capsys, "process", description, record, *guess, "--json")
    assert code == 0 and {"x", "z", "psi", "phi"} <= set(json.loads(out)["modes"])
    code, _, err = run(capsys, "process", description, record, "--nominal", "m=900")
    assert code == 2 and err.startswith("mountid: error: --nominal: m is not an unknown of kid300 (c_xy, c_z)")
    code, _, err = run(capsys, "process", description, record, "--nominal", "c_xy=1e300", "c_z=1")
    assert code == 2 and "c_xy: 1e+300 N/m puts the model out of the range" in err
    assert err.rstrip().endswith("the description gives no nominal value")


def test_the_python_api_names_a_value_that_is_not_a_number():
    """Machine's values, measured frequencies and standard deviations are real numbers (numpy's scalars too): a
    string, None, a bool or an array is an InputError naming the parameter (float() took "4e5" and True = 1 rad/s
    silently; None and arrays were TypeErrors naming nothing)."""
    from mountid.machine import Machine

    kid = Machine.resolve("kid300")
    expected = kid.identify({}, {"x": 17.71, "psi": 64.1})[0].parameters
    assert kid.identify({}, {"x": np.float32(17.71), "psi": np.float64(64.1)})[0].parameters == pytest.approx(expected)
    for bad in ("17.71", None, True, np.array([17.71, 17.8])):
        with pytest.raises(InputError, match=r"^x: must be a real number, got "):
            kid.identify({}, {"x": bad, "psi": 64.1})
        with pytest.raises(InputError, match=r"^x: must be a real number, got "):
            kid.identify({}, {"x": 17.71, "psi": 64.1}, {"x": bad, "psi": 0.4})
        with pytest.raises(InputError, match=r"^c_z: must be a real number, got "):
            kid.frequencies({"c_z": bad})


def test_simulating_a_machine_without_damping_says_what_its_record_is(capsys, tmp_path):
    """A description without damping simulates a decay that never decays; the note says so and what the records
    chain makes of it (it took 3 of rectangular's 6 modes without damping, with no word; it takes none now: every
    pole is a steady oscillation to it). A damped machine's record has no note."""
    code, out, _ = run(capsys, "simulate", OFFCENTRE, "--out", str(tmp_path / "r.csv"))
    assert code == 0 and "note: offcentre has no damping: its modes do not decay, and the records chain takes" in out
    code, out, _ = run(capsys, "simulate", "kid300", "--out", str(tmp_path / "k.csv"), "--json")
    assert code == 0 and json.loads(out)["notes"] == []


def test_an_output_only_plan_without_damping_says_it_simulated_no_record(capsys):
    """plan --ambient simulates no record where every mode is a steady oscillation to the records chain; its
    header said "4 simulated records" above the note that none was simulated."""
    code, out, _ = run(capsys, "plan", OFFCENTRE, "--ambient", "100", "--duration", "600")
    assert code == 0, out
    assert out.splitlines()[0].endswith("noise 0.01 x RMS, no record simulated"), out
    assert "note: no record simulated: every mode is a steady oscillation" in out


def test_an_error_in_a_description_file_names_the_file(capsys, tmp_path):
    """A campaign or a command names its description by path: an entry's error says which file holds it."""
    text = Path("derivations/rectangular.toml").read_text(encoding="utf-8")
    bad = tmp_path / "skid.toml"
    bad.write_text(text.replace("[body]", 'zz = { kind = "length", value = 0.1 }\n\n[body]', 1), encoding="utf-8")
    code, _, err = run(capsys, "frequencies", str(bad))
    assert code == 2 and err.startswith("mountid: error: skid.toml: parameters.zz: is declared but no entry")


def test_a_steady_state_beyond_small_motions_is_named(capsys, tmp_path):
    """An unbalance of 400 kg at 1 m turns kid300 by 2.4 rad at its lowest mode, and an undamped machine driven at
    its natural frequency moves by 1e12 m: the numbers came out with exit 0 as if the linear model held. The note
    names the coordinates beyond small motions (and the missing damping); the paper's speeds give none."""
    code, out, _ = run(capsys, "forced", "kid300", "--speed", "17.71", "--unbalance-mass", "400", "--eccentricity", "1")
    assert code == 0 and "note: at 17.71 rad/s x 6.28 m, y 6.28 m, psi 2.44 rad, theta 2.44 rad: beyond the" in out
    omega = json.loads(run(capsys, "frequencies", OFFCENTRE, "--json")[1])["frequencies"]["x"]
    code, out, _ = run(capsys, "forced", OFFCENTRE, "--speed", repr(omega), "--json")
    note, paper = json.loads(out)["notes"]  # and that the unbalance is the paper's, on another machine
    assert code == 0 and note.endswith(
        "the machine has no damping: at a natural frequency its response grows without bound"
    )
    assert paper.startswith("the paper's unbalance mass 43.1 kg and eccentricity 0.03 m: KID-300's vibrator")
    code, out, _ = run(capsys, "forced", "kid300", "--speed", "113", "157", "--json")
    assert code == 0 and json.loads(out)["notes"] == []
    # a record simulated under that unbalance says the same
    unbalance = ["--speed", "17.71", "--unbalance-mass", "400", "--eccentricity", "1"]
    code, out, _ = run(capsys, "simulate", "kid300", "--out", str(tmp_path / "u.csv"), *unbalance)
    assert code == 0 and "note: at 17.71 rad/s x 6.28 m, y 6.28 m, psi 2.44 rad, theta 2.44 rad: beyond the" in out


def test_describe_says_a_label_in_a_big_block_names_a_rank(capsys):
    """Without symmetry the lowest mode is labelled x whatever it moves (offcentre's is mostly y): describe says a
    label of a block beyond 2 x 2 names a rank; kid300's 2 x 2 blocks get no such note."""
    code, out, _ = run(capsys, "describe", OFFCENTRE)
    assert code == 0 and "note: x, y, z, psi, theta, phi are the roots of one block (x, y, z, psi, theta, phi)" in out
    code, out, _ = run(capsys, "describe", "kid300")
    assert code == 0 and "note:" not in out


def test_a_first_candidate_the_frequencies_cannot_test_is_said_so_and_its_gaps_not_held_out(capsys):
    """fan3 (three isolators, no plane of symmetry declared) with six frequencies off by up to 1 %: the tie
    names an attached mass first, whose six parameters with the two unknown stiffnesses are more than the six
    data. The verdict says the frequencies cannot test it whether or not it passes the held-out check (it
    said so only where it did, and named only the others with too many parameters), and the gap table shows its
    held-out gaps, for which no mode can be left out, as '-' (it printed '+nan'). Its probability is not pinned to
    its digits: eight parameters fitted to six data leave a flat valley, and its Laplace evidence rests on where
    the fit stops in it, which the host's rounding moves (0.58 on one host, 0.589 on another)."""
    code, out, _ = run(capsys, "diagnose", FAN3_CAMPAIGN, "--no-figure")
    verdict = out.splitlines()[-1]
    stated = verdict.removeprefix("verdict: significant gap; explained equally well by added_mass (")
    assert code == 0 and stated != verdict and float(stated[: stated.index(")")]) > 0.5
    assert "cannot test added_mass" in verdict
    table = out[out.index("gap [rad/s] before (nominal) -> after (added_mass)") :].splitlines()[1:8]
    assert [line.split()[0] for line in table] == ["x", "y", "z", "psi", "theta", "phi", "RMS"]
    assert all(line.split()[-1] == "-" for line in table) and "nan" not in out


def test_describe_lists_every_frequency_set_before_the_special_points(capsys):
    """rectangular has frequency sets that determine its unknowns, sets that do not, and a special point (h):
    the unidentifiable sets were printed below the special points, as if they belonged to them. Every set
    follows the heading of the inverse sets; the special points close the listing."""
    code, out, _ = run(capsys, "describe", "rectangular")
    lines = out.splitlines()
    heading = next(i for i, line in enumerate(lines) if line.startswith("inverse sets for the unknowns"))
    sets = lines[heading + 1 : -1]
    assert code == 0 and lines[-1] == "special points (0 is a legitimate design, solved there by the engine): h"
    assert sets and all(line.startswith("  ") for line in sets)
    assert any("NOT identifiable: these frequencies fix only 2 independent combinations of the 3" in s for s in sets)


def test_the_sensor_effects_a_campaign_without_shapes_cannot_test_are_named_in_one_sentence(capsys):
    """The paper's four frequencies, no shapes: each sensor effect is listed as not applicable with one sentence
    that reads for every one of them ("two turned sensors leaves the frequencies ..." did not)."""
    code, out, _ = run(capsys, "diagnose", PAPER, "--no-figure")
    reasons = {
        line.split()[0]: line.split("not applicable: ")[1] for line in out.splitlines() if "not applicable: " in line
    }
    assert code == 0 and set(reasons) == {e.name for e in CATALOGUE if "sensor" in e.name}  # the six of them
    assert (
        reasons["two_sensors_turned"]
        == "no mode shapes measured: the frequencies are exactly unchanged by two turned sensors"
    )
    assert all(
        r.startswith("no mode shapes measured: the frequencies are exactly unchanged by a")
        for k, r in reasons.items()
        if k != "two_sensors_turned"
    )


def test_a_point_on_the_negative_side_is_a_value_not_an_option(capsys):
    """argparse takes a value beginning with "-" for an option unless it is a negative number: a hit at
    -0.35,0.25,0.3 was "expected one argument" (cli.arguments.NEGATIVE_VALUES reads points and directions of
    numbers as values); it now reads as the same value after "=" did; an option is still an option; a negative axis
    ("-z") is a direction."""
    spaced = run(capsys, "plan", "kid300", "--hit-point", "-0.35,0.25,0.3", "--hit-direction", "-1,0,-5e-1", "--json")
    joined = run(capsys, "plan", "kid300", "--hit-point=-0.35,0.25,0.3", "--hit-direction=-1,0,-5e-1", "--json")
    assert spaced[0] == 0 and spaced == joined
    code, _, err = run(capsys, "plan", "kid300", "--hit-point", "--json")
    assert code == 2 and err.strip() == "mountid: error: arguments: argument --hit-point: expected one argument"
    axis = run(capsys, "plan", "kid300", "--hit-point", "-0.35,0.25,0.3", "--hit-direction", "-z", "--json")
    vector = run(capsys, "plan", "kid300", "--hit-point", "-0.35,0.25,0.3", "--hit-direction", "0,0,-2", "--json")
    assert axis[0] == 0 and axis == vector  # a signed axis, as a test engineer labels one (nomenclature.AXES)
    code, _, err = run(capsys, "plan", "kid300", "--hit-point", "-x")
    assert code == 2 and "--hit-point: expected three numbers x,y,z, got '-x'" in err
