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

LEVEL = "hit at half the force"


@pytest.fixture(scope="module")
def folder(tmp_path_factory) -> Path:
    """Two records of the nominal machine (the campaign's level), two with every isolator stiffness STIFFER times
    the nominal one, two with the moment of inertia about z 4 % lower (no change of stiffness makes that)."""
    out = tmp_path_factory.mktemp("levels")
    hits = [Hammer((0.4, 0.3, 0.3), (1, 0.7, -0.6)), Hammer((-0.4, 0.3, 0.3), (0.3, -1, -0.5))]
    states = {
        "hit": {},
        "soft": {"c_xy": 74.4e3 * STIFFER, "c_z": 472.3e3 * STIFFER},
        "jz": {"J_z": KNOWN["J_z"] * 0.96},
    }
    for tag, values in states.items():
        rig = Rig.of("kid300", values)
        for k, hit in enumerate(hits):
            write_csv(rig.simulate(_eight_channels(), 20.0, 500.0, hammers=[hit], seed=k), out / f"{tag}{k}.csv")
    for tag in ("soft", "jz"):
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
    assert out["kind"] == "no significant gap"
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


def test_a_level_no_stiffness_change_makes_is_said_in_the_verdict(folder, capsys):
    """The level's torsion mode higher, the others where they were: no change of the isolators' stiffness makes
    that, and the verdict says so."""
    assert main(["diagnose", str(folder / "jz.json"), "--no-figure"]) == 0
    verdict = capsys.readouterr().out.strip().splitlines()[-1]
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
