"""A campaign's second excitation level from impact records: the records chain at that level gives the
frequencies the level test compares with the campaign's (mountid.diagnosis.campaign._levels)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest
from test_campaign_records import KNOWN, _eight_channels

from mountid.cli import main
from mountid.diagnosis import campaign
from mountid.errors import InputError
from mountid.measurement.records import write_csv
from mountid.measurement.rig import Hammer, Rig

STIFFER = 1.04
"""The rubber at the second level: every isolator stiffness 4 % higher (a hit at half the force on rubber that
softens with the amplitude)."""

LOSSIER = 1.2
"""The rubber's damping at another level: every isolator's damping 20 % higher, its stiffness the same."""

LEVEL = "hit at half the force"


@pytest.fixture(scope="module")
def folder(tmp_path_factory) -> Path:
    """Two records of the nominal machine (the campaign's level), two with every isolator stiffness STIFFER times
    the nominal one, two with the moment of inertia about z 4 % lower (no change of stiffness makes that), two with
    the isolators' damping LOSSIER times the nominal."""
    out = tmp_path_factory.mktemp("levels")
    hits = [Hammer((0.4, 0.3, 0.3), (1, 0.7, -0.6)), Hammer((-0.4, 0.3, 0.3), (0.3, -1, -0.5))]
    states = {
        "hit": {},
        "soft": {"c_xy": 74.4e3 * STIFFER, "c_z": 472.3e3 * STIFFER},
        "jz": {"J_z": KNOWN["J_z"] * 0.96},
        "lossy": {"b_xy": KNOWN["b_xy"] * LOSSIER, "b_z": KNOWN["b_z"] * LOSSIER},
    }
    for tag, values in states.items():
        rig = Rig.of("kid300", values)
        for k, hit in enumerate(hits):
            write_csv(rig.simulate(_eight_channels(), 20.0, 500.0, hammers=[hit], seed=k), out / f"{tag}{k}.csv")
    for tag in ("soft", "jz", "lossy"):
        level = {"name": LEVEL, "records": [f"{tag}0.csv", f"{tag}1.csv"]}
        (out / f"{tag}.json").write_text(json.dumps(_data(level)), encoding="utf-8")
    return out


def _data(*levels: dict) -> dict:
    return {"machine": "kid300", "known": KNOWN, "records": ["hit0.csv", "hit1.csv"], "levels": list(levels)}


def test_a_level_from_records_compares_undamped_frequencies(folder):
    """Every frequency of the stiffer level is sqrt(STIFFER) times the campaign's, to a few standard deviations of
    the difference: both converted from the records' poles to undamped frequencies alike (their damped
    frequencies would differ by the damping's second-order shift, 1e-4 of x and psi)."""
    c = campaign.load(folder / "soft.json")
    assert [r.path.name for r in c.level_records[LEVEL]] == ["soft0.csv", "soft1.csv"]
    shifts = {s.mode: s for s in c.levels.shifts}
    assert set(shifts) == set(c.modes) == {"x", "phi", "z", "psi"}
    for label, s in shifts.items():
        assert s.level == LEVEL and s.frequency == c.modes[label].frequency
        expected = s.frequency * math.sqrt(STIFFER)
        assert abs(s.at_level - expected) < 5 * s.std, (label, s.at_level, expected, s.std)
    assert f"level '{LEVEL}': z: frequency, damping ratio from soft0.csv, soft1.csv (weighted means" in " ".join(
        c.record_notes
    )


def test_a_stiffer_level_is_absorbed_by_the_stiffnesses(folder, capsys):
    assert main(["diagnose", str(folder / "soft.json"), "--json", "--no-figure"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["kind"] == "no significant gap" and out["levels_move"] is False
    assert [Path(p).name for p in out["level_records"][LEVEL]] == ["soft0.csv", "soft1.csv"]
    assert {s["mode"] for s in out["levels"]} == {"x", "phi", "z", "psi"}
    assert main(["diagnose", str(folder / "soft.json"), "--no-figure"]) == 0
    text = capsys.readouterr().out
    # the nominal model's stiffnesses, 4 % higher at the level, leave the shifts within their noise
    absorbed = (
        f"as a change of the isolators' stiffness alone makes them in the nominal model (at '{LEVEL}' c_xy +4 %, "
    )
    assert absorbed in text
    assert "c_z +4 %" in text and "beyond any change" not in text
    # the damping ratios are 2 % lower at the level, many sigma: what the stiffer rubber of the same damping makes
    assert (
        "note: the damping ratios agree between the excitation levels with what the change of stiffness in the " in text
    )


def test_damping_that_moves_with_the_level_is_noted(folder, capsys):
    """The isolators' damping 20 % higher at the level, their stiffness the same: the frequencies agree, the damping
    ratios move (each about 20 % up), and a note says that the damping depends on the amplitude."""
    c = campaign.load(folder / "lossy.json")
    assert {s.mode for s in c.levels.damping} == {"x", "phi", "z", "psi"}
    for s in c.levels.damping:
        assert s.relative == pytest.approx(LOSSIER - 1, abs=0.03) and s.z > 5
    assert main(["diagnose", str(folder / "lossy.json"), "--json", "--no-figure"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert {d["mode"] for d in out["level_damping"]} == {"x", "phi", "z", "psi"}
    notes = out["notes"]
    (note,) = [n for n in notes if n.startswith("the damping ratios move with the excitation level (chi^2")]
    assert "the isolators' damping depends on the amplitude" in note
    assert any(n.startswith("the frequencies agree between the excitation levels") for n in notes)


def test_a_damping_ratio_by_hand_at_a_level_is_compared_where_the_campaign_gives_one():
    """Levels by hand: a damping ratio is compared with the campaign's where it gives one, and said not compared
    where it does not."""
    modes = {"x": {"frequency": 17.71, "damping_ratio": 0.04}, "z": {"frequency": 46.6}, "psi": {"frequency": 64.1}}
    modes["phi"] = {"frequency": 36.91}
    level = {
        "name": LEVEL,
        "modes": {
            "x": {"frequency": 17.72, "damping_ratio": 0.05, "damping_uncertainty": 0.002},
            "z": {"frequency": 46.6, "damping_ratio": 0.05},
        },
    }
    c = campaign.parse({"machine": "kid300", "known": KNOWN, "modes": modes, "levels": [level]})
    (shift,) = c.levels.damping
    assert (shift.mode, shift.ratio, shift.at_level) == ("x", 0.04, 0.05)
    assert shift.std == pytest.approx(math.hypot(0.05 * 0.04, 0.002))  # the campaign's default: 5 % of its ratio
    assert f"level '{LEVEL}': damping ratios of z not compared (the campaign gives none)" in c.notes


def test_a_level_no_stiffness_change_makes_is_said_in_the_verdict(folder, capsys):
    """The level's torsion mode higher, the others where they were: no change of the isolators' stiffness makes
    that, and the verdict says so."""
    assert main(["diagnose", str(folder / "jz.json"), "--json", "--no-figure"]) == 0
    assert json.loads(capsys.readouterr().out)["levels_move"] is True
    assert main(["diagnose", str(folder / "jz.json"), "--no-figure"]) == 0
    out = capsys.readouterr().out
    # no model says what the damping ratios should do there
    assert "note: the damping ratios at the levels are not compared with a model (largest shift phi" in out
    verdict = out.strip().splitlines()[-1]
    assert "beyond any change of the isolators' stiffness in the models that fit the campaign's level" in verdict
    assert "phi +2.1 % at 'hit at half the force'" in verdict and "none is named confidently" in verdict


def test_a_levels_mode_by_hand_overrides_its_records(folder):
    """A level's frequency given by hand replaces its records' one for that mode; the others come from them."""
    hand = {"frequency": 47.9, "uncertainty": 0.01}
    level = {"name": LEVEL, "records": ["soft0.csv", "soft1.csv"], "modes": {"z": hand}}
    c = campaign.parse(_data(level), folder)
    shifts = {s.mode: s for s in c.levels.shifts}
    assert shifts["z"].at_level == 47.9
    assert shifts["z"].std == pytest.approx(math.hypot(0.01, c.modes["z"].frequency_std))
    assert shifts["x"].at_level == pytest.approx(c.modes["x"].frequency * math.sqrt(STIFFER), rel=1e-4)


@pytest.mark.parametrize(
    ("levels", "path", "reason"),
    [
        (
            [{"name": LEVEL, "records": ["soft0.csv"]}, {"name": LEVEL, "modes": {"z": {"frequency": 47.5}}}],
            r"levels\.1\.name",
            "repeats the name of levels.0: one entry per excitation level",
        ),
        ([{"name": LEVEL}], r"levels\.0", "needs one of"),
        ([{"name": LEVEL, "records": ["soft0.csv", "gone.csv"]}], r"levels\.0\.records\.1 \(gone\.csv\)", "no such"),
        ([{"name": LEVEL, "records": [{"file": "soft0.csv", "start": -1}]}], r"levels\.0\.records\.0\.start", "min"),
    ],
)
def test_a_bad_level_is_named(folder, levels, path, reason):
    with pytest.raises(InputError, match=rf"^{path}: .*{reason}"):
        campaign.parse(_data(*levels), folder)


def test_a_pole_by_hand_against_an_undamped_mode_from_records_is_refused(folder, capsys):
    """frequency_type "pole": a level's frequency by hand is a pole's |p|; the campaign's mode from its records is
    undamped. Their difference would hold the damping's shift: refused, naming the entry."""
    data = {**_data({"name": LEVEL, "modes": {"x": {"frequency": 18.0}}}), "frequency_type": "pole"}
    data["known"] = KNOWN  # the damping known: pole frequencies can be converted
    with pytest.raises(InputError, match=r"^levels\.0\.modes\.x: the campaign's x comes from its records"):
        campaign.parse(data, folder)
    bad = folder / "pole.json"
    bad.write_text(json.dumps(data), encoding="utf-8")
    assert main(["diagnose", str(bad), "--no-figure"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "levels.0.modes.x" in err
