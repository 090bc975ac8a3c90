"""The paper's numbers, the command-line contract, and reproducible generation."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import call

from mountid.cli import main
from mountid.machine import Machine
from mountid.validation.paper import MEASURED, PUBLISHED, TABLE_1, paper_choice

ROOT = Path(__file__).resolve().parents[1]


def test_paper_identification_from_w1_w4():
    sols = Machine.resolve("kid300").identify(TABLE_1, {"x": MEASURED["x"], "psi": MEASURED["psi"]})
    assert len(sols) == 2  # two roots, the paper keeps c_z > c_xy
    best = paper_choice(sols)
    # the paper prints 4 significant digits
    assert best.parameters["c_z"] == pytest.approx(PUBLISHED["c_z"], abs=0.05e3)
    assert best.parameters["c_xy"] == pytest.approx(PUBLISHED["c_xy"], abs=0.05e3)
    # the paper computed w3, w6 from its rounded stiffnesses and truncated to two decimals (36.937 -> 36.93)
    rounded = Machine.resolve("kid300").frequencies({"c_z": PUBLISHED["c_z"], "c_xy": PUBLISHED["c_xy"]})
    assert math.floor(rounded["z"] * 100) / 100 == PUBLISHED["z"]
    assert math.floor(rounded["phi"] * 100) / 100 == PUBLISHED["phi"]


def run(capsys, *argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_frequencies_json_contract(capsys):
    code, out, _ = run(capsys, "frequencies", "kid300", "--set", "c_xy=74.4e3", "c_z=472.3e3", "--json")
    assert code == 0
    freqs = json.loads(out)["frequencies"]
    assert list(freqs) == ["x", "y", "z", "psi", "theta", "phi"]
    assert freqs["z"] == pytest.approx(47.46, abs=0.005)


def test_identify_json_contract(capsys):
    code, out, _ = run(capsys, "identify", "kid300", "--measured", "x=17.71", "psi=64.10", "--json")
    assert code == 0
    sols = json.loads(out)["solutions"]
    assert len(sols) == 2
    assert set(sols[0]) == {"parameters", "frequencies", "condition"}
    assert 1 <= sols[0]["condition"] < 10
    assert set(sols[0]["parameters"]) == {"c_xy", "c_z"}


@pytest.mark.parametrize(
    ("argv", "named"),
    [
        (["frequencies", "kid300", "--set", "m=-5"], "error: --set m:"),
        (["frequencies", "kid300", "--set", "J_z=0"], "error: --set J_z:"),
        (["frequencies", "kid300", "--set", "L_xy=nan"], "error: --set L_xy:"),
        (["frequencies", "kid300", "--set", "c_z=-1"], "error: --set c_z:"),
        (["frequencies", "kid300", "--set", "foo=1"], "error: --set foo:"),
        (["frequencies", "nosuchmachine"], "machine:"),
        (["identify", "kid300", "--measured", "x=64.1", "psi=17.71"], "measured:"),
        (["identify", "kid300", "--measured", "q=3", "psi=17.71"], "q:"),
        (["identify", "kid300", "--measured", "x=17.71"], "measured:"),
        (["identify", "kid300", "--measured", "x=17.71", "y=17.8"], "y:"),
        (["identify", "kid300", "--measured", "x=0", "psi=64.1"], "x:"),
        (["identify", "rectangular", "--measured", "x=10", "z=30", "theta=50"], "measured: "),
        # values beyond double precision or beyond any test: named, never a traceback, a warning or a hang
        (["identify", "kid300", "--measured", "x=1e300", "z=46.6"], "measured: x = 1e+300 rad/s puts the model"),
        (["plan", "kid300", "--duration", "1e300"], "--duration: 1e+300 s at 2048 Hz is 2.05e+303 samples"),
        (["plan", "kid300", "--rate", "1e300"], "--duration: 4 s at 1e+300 Hz is 4e+300 samples"),
        (["plan", "kid300", "--noise", "1e300"], "--noise: 1e+300 x RMS is beyond 100 x RMS"),
        (["plan", "kid300", "--hit-point", "0,0,1e300"], "--hit-point: '0,0,1e300': a point on the machine lies"),
        (["plan", "kid300", "--sensor", "A=1e300,0,0:1,0,0"], "--sensor: '1e300,0,0': a point on the machine lies"),
        (["simulate", "kid300", "--out", "r.csv", "--hit-peak", "1e300"], "--hit-peak: 1e+300 N is beyond 1e+07 N"),
    ],
)
def test_bad_input_is_one_line_exit_2(capsys, argv, named):
    code, out, err = run(capsys, *argv)
    assert code == 2
    assert out == ""
    assert err.count("\n") == 1 and named in err and "Traceback" not in err


def test_identify_cold_start_does_not_import_sympy():
    code = (
        "import sys; from mountid.cli import main; "
        "rc = main(['identify', 'kid300', '--measured', 'x=17.71', 'psi=64.10', '--json']); "
        "assert rc == 0; assert 'sympy' not in sys.modules, 'sympy imported'"
    )
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr


def test_python_dash_m_and_process_exit_code():
    result = subprocess.run(
        [sys.executable, "-m", "mountid", "frequencies", "kid300", "--set", "m=-1"],
        capture_output=True,
        text=True,
    )
    assert result.returncode == 2 and result.stderr.startswith("mountid: error: --set m:")


def test_generation_is_independent_of_hash_seed():
    script = (
        "import sys; from mountid.engine.codegen.numpy_module import render; "
        "from mountid.engine.description import load; from mountid.engine.settings import SHIPPED; "
        f"sys.stdout.write(render(load({str(ROOT / 'derivations' / 'kid300.toml')!r}), settings=SHIPPED))"
    )
    outs = []
    for seed in ("1", "4242"):
        env = dict(os.environ, PYTHONHASHSEED=seed)
        outs.append(
            subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, env=env, check=True).stdout
        )
    assert outs[0] == outs[1] == (ROOT / "generated" / "kid300.py").read_text()


def test_description_file_path_generates_on_the_fly(tmp_path):
    """A description outside derivations/, as a new user writes it: frequencies vs eigh, inverse round trip."""
    import numpy as np
    import scipy.linalg

    machine = Machine.resolve(str(ROOT / "tests" / "data" / "press.toml"))
    mod = machine.module
    p = {a: mod.PARAMETERS[a]["value"] for a in mod.FORWARD_ARGUMENTS}
    lam = np.sort(mod.squared_frequencies(**p))
    ref = scipy.linalg.eigh(call(mod, "stiffness_matrix", p), call(mod, "mass_matrix", p), eigvals_only=True)
    np.testing.assert_allclose(lam, ref, rtol=1e-10)
    freqs = machine.frequencies({})
    for key in mod.INVERSES:
        sols = machine.identify({}, {k: freqs[k] for k in key})
        assert any(all(abs(s.parameters[u] / p[u] - 1) < 1e-9 for u in mod.UNKNOWN) for s in sols), key


def test_a_description_file_is_generated_once_and_cached_by_content(tmp_path):
    """The second use of the same description file imports no sympy; a changed file is generated anew."""
    desc = tmp_path / "press.toml"
    desc.write_text((ROOT / "tests" / "data" / "press.toml").read_text())
    script = (
        "import sys; from mountid.machine import Machine; "
        f"Machine.resolve({str(desc)!r}).frequencies({{}}); print('sympy' in sys.modules)"
    )
    env = {**os.environ, "MOUNTID_CACHE": str(tmp_path / "cache")}

    def run() -> str:
        return subprocess.run(
            [sys.executable, "-c", script], env=env, capture_output=True, text=True, check=True
        ).stdout

    assert run().strip() == "True"  # first use: generated
    assert run().strip() == "False"  # second use: from the cache
    assert len(list((tmp_path / "cache").glob("press-*.py"))) == 1
    desc.write_text(desc.read_text().replace("5200.0", "5300.0"))
    assert run().strip() == "True"
    assert len(list((tmp_path / "cache").glob("press-*.py"))) == 2


README_TRANSCRIPT = "    $ mountid diagnose examples/"


def _readme_transcripts() -> list[tuple[str, list[str]]]:
    """The README's `mountid diagnose` transcripts: (example file, the lines shown, without their indent)."""
    lines = (ROOT / "README.md").read_text(encoding="utf-8").splitlines()
    out = []
    for i, line in enumerate(lines):
        if line.startswith(README_TRANSCRIPT):
            shown = []
            for following in lines[i + 1 :]:
                if not following.startswith("    "):
                    break
                shown.append(following[4:].rstrip())
            out.append((line[len(README_TRANSCRIPT) :].split()[0], shown))
    return out


@pytest.mark.parametrize(("example", "shown"), _readme_transcripts(), ids=lambda v: v if isinstance(v, str) else "")
def test_the_readme_diagnosis_transcripts_are_what_the_command_prints(capsys, tmp_path, monkeypatch, example, shown):
    """Every line of a README transcript is a line the command prints, in order; a line with '...' is its
    fragments in one printed line (a transcript shows a selection). A README that drifts from the code fails."""
    monkeypatch.chdir(tmp_path)
    code, out, _ = run(capsys, "diagnose", str(ROOT / "examples" / example), "--no-figure")
    assert code == 0
    printed = [line.rstrip() for line in out.splitlines()]
    at = 0
    for line in shown:
        found = next((k for k in range(at, len(printed)) if _shows(line, printed[k])), None)
        assert found is not None, f"{example}: the README shows {line!r}, the command does not print it (in order)"
        at = found + 1 if any(f.strip() for f in line.split("...")) else found  # a bare '...' matches any line


def _shows(line: str, printed: str) -> bool:
    """Whether a transcript line shows a printed one: equal, or with '...' its fragments in it."""
    if "..." not in line:
        return line == printed
    return all(f.strip() in printed for f in line.split("...") if f.strip())


def test_the_readme_has_a_transcript_for_every_verdict_example():
    """The transcript test above is not empty: the paper's campaign, the five blind examples and the belt's table of
    modes from a bench, each a file."""
    examples = [example for example, _ in _readme_transcripts()]
    assert examples == [
        "kid300-paper.json",
        "kid300-blind-belt.json",
        "kid300-bench-modes.json",
        "kid300-blind-pair.json",
        "kid300-blind-tie.json",
        "kid300-blind-not-explained.json",
        "rectangular-blind-two-levels.json",
    ]
    assert all((ROOT / "examples" / e).is_file() for e in examples)


def test_the_json_report_splits_each_rivals_odds_into_fit_and_priors(capsys, tmp_path, monkeypatch):
    """The tie example as JSON: each candidate of positive probability after the first has its log odds against
    the first (the log of their probabilities' ratio), split into fit and priors that add up to it; the rivals
    the data fit as well (fit 1 nat or less) are the ones named, in the tie, the support (the hidden truth)
    among them. The figure, which marks them, is written."""
    monkeypatch.chdir(tmp_path)
    figure = tmp_path / "tie.png"
    code, out, _ = run(
        capsys, "diagnose", str(ROOT / "examples" / "kid300-blind-tie.json"), "--json", "--figure", str(figure)
    )
    assert code == 0 and figure.stat().st_size > 0
    report = json.loads(out)
    probability = {c["effect"]: c["probability"] for c in report["candidates"]}
    first = report["candidates"][0]["effect"]
    odds = report["odds_against_first"]
    assert [o["rival"] for o in odds] == [c["effect"] for c in report["candidates"][1:] if c["probability"] > 0]
    for o in odds:
        assert o["log_odds"] == pytest.approx(math.log(probability[first] / probability[o["rival"]]), rel=1e-12)
        assert o["fit"] + o["priors"] == pytest.approx(o["log_odds"], rel=1e-12, abs=1e-12)
    assert report["fit_alike"] == [o["rival"] for o in odds if o["fit"] <= 1.0 and o["rival"] in report["tie"]]
    assert "foundation" in report["fit_alike"]


def test_plan_and_simulate_say_where_the_papers_default_channels_and_hit_are(capsys, tmp_path):
    """plan and simulate take the paper's channels and hit where none is given, on any machine: on another than
    the paper's they say so, with the points (KID-300's), and say nothing where the test engineer gave them; so
    do forced and simulate --speed of the paper's eccentric weight (43.1 kg at 0.03 m)."""
    assert main(["plan", "genset8"]) == 0
    out = capsys.readouterr().out
    assert "the paper's channels A_x at (0.45, 0.0, 0.1) along (1, 0, 0)" in out
    assert "and hit at (0.35, 0.25, 0.3) along (1.0, 0.8, -0.6): points of KID-300, not of genset8 (--sensor" in out
    given = ["--sensor", "A=1,0,0:1,0,0", "B=1,0,0.3:0,1,0", "--hit-point", "1,0.2,0.3"]
    assert main(["plan", "genset8", *given]) == 0
    assert "the paper's" not in capsys.readouterr().out
    assert main(["simulate", "genset8", "--out", str(tmp_path / "g.csv"), "--json", "--hit-point", "1,0.2,0.3"]) == 0
    (note,) = json.loads(capsys.readouterr().out)["notes"]
    assert note.startswith("the paper's channels A_x at (0.45, 0.0, 0.1)") and "hit at" not in note
    assert note.endswith("points of KID-300, not of genset8 (--sensor gives its own)")
    # an output-only record has no hit: its note names the channels alone (it named the paper's hit as well)
    ambient = ["--ambient", "100", "--duration", "60", "--rate", "100", "--json"]
    assert main(["simulate", "genset8", "--out", str(tmp_path / "a.csv"), *ambient]) == 0
    notes = json.loads(capsys.readouterr().out)["notes"]
    assert [n for n in notes if n.startswith("the paper's")] == [note]
    assert main(["plan", "kid300"]) == 0
    assert "the paper's" not in capsys.readouterr().out
    # the paper's eccentric weight, KID-300's vibrator, where forced and simulate --speed take it
    assert main(["forced", "genset8", "--speed", "157", "--json"]) == 0
    (note,) = json.loads(capsys.readouterr().out)["notes"]
    assert note == (
        "the paper's unbalance mass 43.1 kg and eccentricity 0.03 m: KID-300's vibrator, not genset8's "
        "(--unbalance-mass, --eccentricity give its own)"
    )
    assert main(["forced", "genset8", "--speed", "157", "--eccentricity", "0.01", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["notes"] == [
        "the paper's unbalance mass 43.1 kg: KID-300's vibrator, not genset8's (--unbalance-mass gives its own)"
    ]
    assert main(["forced", "kid300", "--speed", "157", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["notes"] == []
    speed = ["--speed", "40", "--sensor", "A=1,0,0:1,0,0", "--unbalance-mass", "10", "--json"]
    assert main(["simulate", "genset8", "--out", str(tmp_path / "s.csv"), *speed]) == 0
    assert json.loads(capsys.readouterr().out)["notes"][-1].startswith("the paper's eccentricity 0.03 m: KID-300's")
    assert main(["simulate", "genset8", "--out", str(tmp_path / "s.csv"), *speed[2:]]) == 0  # a hit: no weight
    assert not any("vibrator" in n for n in json.loads(capsys.readouterr().out)["notes"])
