"""Command line of the experiment: simulate -> record file -> identify-record, forced response, demo."""

from __future__ import annotations

import json
import os

import numpy as np
import pytest

from mountid.cli import main
from mountid.measurement.rig import Rig, Unbalance
from mountid.validation.paper import UNBALANCE


def run(capsys, *argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


@pytest.mark.parametrize("suffix", ["csv", "uff"])
def test_simulate_then_identify_record(capsys, tmp_path, suffix):
    path = tmp_path / f"hit.{suffix}"
    code, out, _ = run(capsys, "simulate", "kid300", "--out", str(path), "--seed", "3")
    assert code == 0 and "5 channels" in out
    code, out, _ = run(capsys, "identify-record", "kid300", str(path), "--json", "--figures", str(tmp_path / "f"))
    assert code == 0
    result = json.loads(out)
    assert sorted(result["modes"]) == ["phi", "psi", "x", "z"]
    assert result["parameters"]["c_xy"] == pytest.approx(74.4e3, rel=5e-3)
    assert result["parameters"]["c_z"] == pytest.approx(472.3e3, rel=5e-3)
    assert result["warnings"] == []
    for name in ("modes.png", "spectrum.png", "stabilisation.png"):
        assert (tmp_path / "f" / name).stat().st_size > 10_000, name


@pytest.mark.parametrize(
    ("machine", "where"),
    [
        ("kid300", ()),  # the paper's: the vertical axis through the origin
        ("genset8", ("--unbalance-point", "0.2,0,0.3", "--unbalance-axis", "2,0,0")),  # a horizontal shaft
    ],
)
def test_forced_response_json(capsys, machine, where):
    """The printed amplitude is the largest of 64 samples per period: within 1 - cos(pi/64) of |q| from
    the frequency response, for the unbalance the options place (the axis was always the paper's vertical one
    through the origin: a generator's horizontal shaft could not be given)."""
    code, out, _ = run(capsys, "forced", machine, "--speed", "113", "157", *where, "--json")
    assert code == 0
    report = json.loads(out)
    amp = report["amplitudes"]
    point, axis = ((0.2, 0.0, 0.3), (1.0, 0.0, 0.0)) if where else ((0.0, 0.0, 0.0), (0.0, 0.0, 1.0))
    unbalance = {"mass": UNBALANCE["mass"], "eccentricity": UNBALANCE["eccentricity"]}
    assert report["unbalance"] == {**unbalance, "point": list(point), "axis": list(axis)}
    rig = Rig.of(machine)
    for w in (113.0, 157.0):
        unb = Unbalance(UNBALANCE["mass"], UNBALANCE["eccentricity"], w, point, axis)
        e_s, e_c = unb.plane()
        force = unb.amplitude * (rig.force_column(unb.point, e_c) - 1j * rig.force_column(unb.point, e_s))
        exact = np.abs(rig.frf(np.array([w]))[0] @ force)
        assert np.count_nonzero(exact > 1e-3 * exact.max()) >= 3
        for i, c in enumerate(rig.machine.module.COORDINATES):
            assert amp[f"{w:g}"][c] == pytest.approx(exact[i], rel=1.5e-3, abs=1e-9 * exact.max())


@pytest.mark.parametrize(
    ("argv", "start"),
    [
        (["identify-record", "kid300", "missing.csv"], "mountid: error: record: no such file"),
        (["identify-record", "kid300", "."], "mountid: error: record: . is a directory, not a file to read"),
        (["process", "kid300", os.devnull], f"mountid: error: record: {os.devnull} is not a regular file"),
        (["diagnose", "."], "mountid: error: campaign: . is a directory, not a file to read"),
        (["simulate", "kid300", "--out", "x.csv", "--hit-point", "1,2"], "mountid: error: --hit-point:"),
        (["simulate", "kid300", "--out", "x.csv", "--duration", "0"], "mountid: error: --duration: must be positive"),
        (["forced", "kid300", "--speed", "-3"], "mountid: error: --speed: must be positive"),
        (
            ["forced", "kid300", "--speed", "100", "--set", "c_z=-1"],
            "mountid: error: --set c_z: a stiffness must be positive",
        ),
    ],
)
def test_bad_experiment_input_is_one_line_exit_2(capsys, tmp_path, monkeypatch, argv, start):
    monkeypatch.chdir(tmp_path)
    code, out, err = run(capsys, *argv)
    assert code == 2 and out == ""
    assert err.startswith(start) and err.count("\n") == 1


def test_demo_runs_the_simulated_experiment(capsys, tmp_path):
    code, out, _ = run(capsys, "demo", "--figures", str(tmp_path))
    assert code == 0
    assert "Simulated experiment" in out and "c_xy" in out
    # the README's diagnosis examples run too
    assert "$ mountid diagnose examples/kid300-paper.json" in out
    assert "verdict: significant gap, explained by drive_belt" in out
    assert {p.name for p in tmp_path.iterdir()} == {
        "record.png",
        "spectrum.png",
        "stabilisation.png",
        "decay.png",
        "unbalance.png",
        "modes.png",
        "kid300-paper-diagnosis.png",
        "kid300-blind-belt-diagnosis.png",
    }


def test_process_gives_modal_data_and_use_picks_the_papers_pair(capsys, tmp_path):
    path = tmp_path / "hit.csv"
    assert run(capsys, "simulate", "kid300", "--out", str(path), "--seed", "4")[0] == 0
    code, out, _ = run(capsys, "process", "kid300", str(path), "--json")
    assert code == 0
    modes = json.loads(out)["modes"]
    assert sorted(modes) == ["phi", "psi", "x", "z"] and json.loads(out)["frequency_type"] == "pole"
    assert modes["x"]["frequency"] == pytest.approx(17.71, rel=2e-3) and modes["x"]["frequency_std"] > 0
    # three channels do not fix a shape in the six coordinates: no shape, no shape noise
    assert all(m["shape"] is None and m["shape_std"] is None for m in modes.values())
    code, text, _ = run(capsys, "process", "kid300", str(path))
    header = 'the poles\' |p| [rad/s, Hz] and zeta = -Re p / |p| (in a campaign: "frequency_type": "pole")'
    assert code == 0 and header in text
    # the table identify-record prints: what it comes from, and each mode's MAC (process printed neither)
    assert text.startswith(f"kid300: 4 modes from {path}\n")
    # why there is no shape: what the paper's five channels do not see
    assert text.splitlines()[1] == (
        "  note: no mode shapes: the channels see 5 of the six rigid-body motions, not a rotation about the axis "
        "through (0.45, 0, 0.1) m along (0, 1, 0); a channel that moves in it would give them"
    )
    rows = [line.split() for line in text.splitlines()[3:]]
    assert [r[0] for r in rows] == list(modes) and all(r[-2] == "MAC" for r in rows)
    assert [float(r[-1]) for r in rows] == [round(m["mac"], 2) for m in modes.values()]
    code, out, _ = run(capsys, "identify-record", "kid300", str(path), "--use", "x", "psi", "--json")
    assert code == 0
    assert json.loads(out)["parameters"]["c_z"] == pytest.approx(472.3e3, rel=5e-3)
    # a twin is found with the pole of its twins (theta with psi; it was "theta not found in the record")
    code, twins, _ = run(capsys, "identify-record", "kid300", str(path), "--use", "y", "theta", "--json")
    assert code == 0 and json.loads(twins)["parameters"] == json.loads(out)["parameters"]
    code, _, err = run(capsys, "identify-record", "kid300", str(path), "--use", "x", "X")
    assert code == 2 and err.startswith("mountid: error: --use: X: not a mode label of kid300 (x, y, z, psi, theta")


def test_an_unknown_set_as_known_is_named_before_the_record_is_read(capsys, tmp_path):
    """--set c_xy=1 on identify-record: the unknown is named (the labelling read the model at c_xy = 1 N/m first
    and called a 4 s record too short for its 0.07 rad/s lowest mode)."""
    path = tmp_path / "hit.csv"
    assert run(capsys, "simulate", "kid300", "--out", str(path))[0] == 0
    code, out, err = run(capsys, "identify-record", "kid300", str(path), "--set", "c_xy=1")
    assert code == 2 and out == ""
    assert err == "mountid: error: --set c_xy: is an unknown to identify; do not --set it\n"


def test_a_plain_csv_is_placed_on_the_command_line(capsys, tmp_path):
    """A bench export without mountid's channel lines (a header and the columns): the labelling needs each
    channel's place, which --channel gives (its direction made unit); a channel it does not hold and a zero
    direction are one-line errors naming the option."""
    from mountid.measurement.records import read_record, write_csv

    path = tmp_path / "hit.csv"
    assert run(capsys, "simulate", "kid300", "--out", str(path), "--seed", "3")[0] == 0
    placed = read_record(path)
    plain = tmp_path / "plain.csv"
    write_csv(placed, plain)
    plain.write_text("".join(ln for ln in plain.read_text().splitlines(True) if not ln.startswith("#")))
    code, _, err = run(capsys, "process", "kid300", str(plain))
    assert code == 2 and "A_x: channel has no point and direction" in err
    given = [
        f"{c.name}={','.join(map(str, c.point))}:{','.join(str(2 * v) for v in c.direction)}" for c in placed.channels
    ]
    code, out, _ = run(capsys, "identify-record", "kid300", str(plain), "--json", "--channel", *given)
    assert code == 0 and sorted(json.loads(out)["modes"]) == ["phi", "psi", "x", "z"]
    code, out2, _ = run(capsys, "identify-record", "kid300", str(path), "--json")
    assert json.loads(out)["parameters"] == json.loads(out2)["parameters"]  # the file's own placement, to the bit
    for bad, message in (
        ("Q=0,0,0:1,0,0", "--channel: Q: no such channel"),
        ("A_x=0,0,0:0,0,0", "--channel A_x: '0,0,0': a direction must not be zero"),
    ):
        code, _, err = run(capsys, "process", "kid300", str(plain), "--channel", bad)
        assert code == 2 and message in err and len(err.strip().splitlines()) == 1


def test_a_simulated_shaker_test_goes_through_the_records_chain(capsys, tmp_path):
    """`simulate --shaker LOW HIGH` drives the machine with a multisine at the hit's point and records its force;
    `identify-record` averages the periods and gives the four modes, its figures those of the H1 fitted (the
    spectrum and stabilisation of its impulse responses, H1 and coherence); fewer than three periods are said."""
    path = tmp_path / "shaker.csv"
    argv = ["simulate", "kid300", "--out", str(path), "--shaker", "0.5", "40", "--rate", "200", "--force-channel", "F"]
    assert run(capsys, *argv, "--duration", "64")[0] == 0
    figures = tmp_path / "figures"
    code, out, _ = run(capsys, "identify-record", "kid300", str(path), "--json", "--figures", str(figures))
    found = json.loads(out)
    assert code == 0 and sorted(found["modes"]) == ["phi", "psi", "x", "z"]
    assert any("periodic excitation on F" in note for note in found["notes"])
    assert {f.name for f in figures.iterdir()} == {"frf.png", "modes.png", "spectrum.png", "stabilisation.png"}
    code, out, _ = run(capsys, *argv, "--duration", "30")
    assert code == 0 and "30 s holds fewer than 3 periods of 16 s" in out


def test_a_simulated_random_excitation_goes_through_the_records_chain(capsys, tmp_path):
    """`simulate --shaker LOW HIGH --shaker-random` drives the machine with a force that never repeats;
    `identify-record` fits its impulse responses by least squares and gives the four modes; a record too short for
    them to die out is said by simulate (with the length it needs) and is an error of identify-record naming the
    force channel and the length to record."""
    path = tmp_path / "random.csv"
    argv = ["simulate", "kid300", "--out", str(path), "--shaker", "0.5", "40", "--shaker-random", "--rate", "200"]
    assert run(capsys, *argv, "--force-channel", "F", "--duration", "128")[0] == 0
    code, out, _ = run(capsys, "identify-record", "kid300", str(path), "--json")
    found = json.loads(out)
    assert code == 0 and sorted(found["modes"]) == ["phi", "psi", "x", "z"]
    assert any("128 s of a random excitation on F (impulse responses of 16 s" in note for note in found["notes"])
    code, out, _ = run(capsys, *argv, "--force-channel", "F", "--duration", "64")
    assert code == 0 and "(time constant 1.5 s) 8 times: record 96.3 s or more" in out
    code, _, err = run(capsys, "identify-record", "kid300", str(path))
    assert code == 2 and err.startswith("mountid: error: F: random excitation: ") and "s or more" in err
