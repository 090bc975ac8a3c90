"""Frequencies and speeds in the units a test engineer's software gives them (mountid.nomenclature.FREQUENCY_UNITS,
SPEED_UNITS): converted to rad/s where they come in (the command line's --measured, --std and --speed, a campaign's
frequency_unit), so that a campaign in hertz is the campaign in rad/s."""

from __future__ import annotations

import copy
import json
import math

import pytest

from mountid.cli import main
from mountid.diagnosis import campaign as campaign_module
from mountid.nomenclature import FREQUENCY_UNITS, SPEED_UNITS, in_rad_per_s
from mountid.validation import blind


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("17.71", 17.71),
        ("17.71rad/s", 17.71),
        ("2.82Hz", 2.82 * 2 * math.pi),
        (" 2.82 hz ", 2.82 * 2 * math.pi),
        ("1500 rpm", 1500 * 2 * math.pi / 60),
        ("1e3RPM", 1e3 * 2 * math.pi / 60),
    ],
)
def test_a_value_with_its_unit_in_rad_per_s(text, expected):
    assert in_rad_per_s(text, SPEED_UNITS) == pytest.approx(expected, rel=1e-15)


@pytest.mark.parametrize("text", ["2.82kHz", "Hz", "", "fast", "1500rpm"])
def test_what_is_no_frequency_names_the_units(text):
    with pytest.raises(ValueError, match=r"not a number in rad/s or with its unit \(rad/s, Hz\)"):
        in_rad_per_s(text, FREQUENCY_UNITS)


def test_identify_takes_hertz_as_the_same_frequencies_in_rad_per_s(capsys):
    rad = ["x=17.7105", "psi=64.0977"]
    hertz = [f"x={17.7105 / (2 * math.pi)!r}Hz", f"psi={64.0977 / (2 * math.pi)!r} Hz"]
    outputs = []
    stds = (["x=0.0177", "psi=0.064"], [f"x={0.0177 / (2 * math.pi)!r}Hz", f"psi={0.064 / (2 * math.pi)!r}hz"])
    for measured, std in zip((rad, hertz), stds, strict=True):
        assert main(["identify", "kid300", "--measured", *measured, "--std", *std, "--json"]) == 0
        outputs.append(json.loads(capsys.readouterr().out))
    (a,), (b,) = (o["solutions"][:1] for o in outputs)
    for name in ("c_xy", "c_z"):
        assert b["parameters"][name] == pytest.approx(a["parameters"][name], rel=1e-12)
        assert b["parameter_std"][name] == pytest.approx(a["parameter_std"][name], rel=1e-9)
    assert main(["identify", "kid300", "--measured", "x=2.8kHz", "psi=64"]) == 2
    assert capsys.readouterr().err.strip() == (
        "mountid: error: --measured x: not a number in rad/s or with its unit (rad/s, Hz): '2.8kHz'"
    )


def test_forced_takes_a_speed_in_rpm(capsys):
    assert main(["forced", "kid300", "--speed", "1500rpm", "--json"]) == 0
    rpm = json.loads(capsys.readouterr().out)
    assert main(["forced", "kid300", "--speed", repr(1500 * 2 * math.pi / 60), "--json"]) == 0
    rad = json.loads(capsys.readouterr().out)
    assert list(rpm["amplitudes"].values()) == list(rad["amplitudes"].values())
    assert main(["forced", "kid300", "--speed", "fast"]) == 2
    assert "--speed: not a number in rad/s or with its unit (rad/s, Hz, rpm): 'fast'" in capsys.readouterr().err
    # a negative speed with its unit is a value (it was taken for an option: "expected at least one argument")
    assert main(["forced", "kid300", "--speed", "-5rpm"]) == 2
    assert capsys.readouterr().err.strip() == "mountid: error: --speed: must be positive and finite, got " + (
        f"{-5 * 2 * math.pi / 60} rad/s"
    )


def _in_hertz(data: dict) -> dict:
    """The campaign with every frequency and frequency uncertainty of its modes and levels in Hz."""
    out = copy.deepcopy(data)
    for modes in [out["modes"], *(level["modes"] for level in out.get("levels", ()))]:
        for entry in modes.values():
            for key in ("frequency", "uncertainty"):
                if entry.get(key) is not None:
                    entry[key] = entry[key] / (2 * math.pi)
    return {**out, "frequency_unit": "Hz"}


def test_a_campaign_in_hertz_is_the_campaign_in_rad_per_s():
    data, _ = blind.make_case(5, "drive_belt", kind="shapes", machine="kid300", level=0.5)
    assert data["levels"] and all("uncertainty" in e for e in data["modes"].values())
    rad, hertz = campaign_module.parse(data), campaign_module.parse(_in_hertz(data))
    for label, mode in rad.modes.items():
        assert hertz.modes[label].frequency == pytest.approx(mode.frequency, rel=1e-14)
        assert hertz.modes[label].frequency_std == pytest.approx(mode.frequency_std, rel=1e-14)
        assert hertz.modes[label].damping_ratio == mode.damping_ratio
    for a, b in zip(rad.levels.shifts, hertz.levels.shifts, strict=True):
        assert (b.frequency, b.at_level, b.std) == pytest.approx((a.frequency, a.at_level, a.std), rel=1e-14)
    assert rad.conventions()["frequencies"].startswith("undamped natural frequencies [rad/s]")
    assert "given in Hz and converted" in hertz.conventions()["frequencies"]
    assert "given in Hz" not in rad.conventions()["frequencies"]
