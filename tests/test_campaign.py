"""A campaign's modes given by hand (mountid.diagnosis.campaign): shapes read at the campaign's sensors, as a bench's
modal software tabulates them (sensor_shape), taken to the coordinates q as a record's channel shapes are."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from mountid.diagnosis import campaign as campaign_module
from mountid.diagnosis.candidates import diagnose_effects
from mountid.errors import InputError
from mountid.machine import Machine, sensor_row
from mountid.validation import blind


def _at_sensors(data: dict) -> dict:
    """The campaign with each mode's shape in q replaced by its readings at the campaign's sensors, by name."""
    module = Machine.resolve(data["machine"]).module
    out = copy.deepcopy(data)
    for entry in out["modes"].values():
        q = np.array(entry.pop("shape"))
        entry["sensor_shape"] = {
            s["name"]: float(sensor_row(module, s["point"], s["direction"], s["name"]) @ q) for s in out["sensors"]
        }
    return out


def _parallel(a, b) -> float:
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return abs(float(a @ b)) / float(np.linalg.norm(a) * np.linalg.norm(b))


def test_shapes_at_the_sensors_are_the_shapes_in_q():
    data, _ = blind.make_case(1, "drive_belt", kind="shapes", machine="kid300")
    in_q, at_sensors = campaign_module.parse(data), campaign_module.parse(_at_sensors(data))
    for label, mode in in_q.modes.items():
        assert _parallel(at_sensors.modes[label].shape, mode.shape) == pytest.approx(1.0, abs=1e-12)
        assert at_sensors.modes[label].shape_std == mode.shape_std
    assert diagnose_effects(at_sensors).verdict == diagnose_effects(in_q).verdict


def test_shapes_at_sensors_that_cannot_give_them_are_named():
    data, _ = blind.make_case(1, "drive_belt", kind="shapes", machine="kid300")
    given = _at_sensors(data)
    both = copy.deepcopy(given)
    both["modes"]["x"]["shape"] = data["modes"]["x"]["shape"]
    with pytest.raises(InputError, match=r"^modes.x: give its shape in q \(shape\) or at the sensors"):
        campaign_module.parse(both)
    stranger = copy.deepcopy(given)
    stranger["modes"]["x"]["sensor_shape"]["Q_z"] = 0.1
    with pytest.raises(InputError, match=r"^modes.x.sensor_shape.Q_z: not a sensor of the campaign \(sensors: S1_x"):
        campaign_module.parse(stranger)
    blind_to_y = copy.deepcopy(given)  # the z channels and two along x at one y: z, psi, theta, x with phi
    blind_to_y["modes"]["x"]["sensor_shape"] = {
        name: value
        for name, value in given["modes"]["x"]["sensor_shape"].items()
        if name.endswith("_z") or name in ("S1_x", "S2_x")
    }
    with pytest.raises(InputError, match=r"^modes.x.sensor_shape: the sensors named see 4 of the six motions"):
        campaign_module.parse(blind_to_y)
    alone = {k: v for k, v in given.items() if k != "sensors"}
    with pytest.raises(InputError, match=r"^modes.x.sensor_shape: needs the campaign's sensors"):
        campaign_module.parse(alone)


def test_directions_given_as_signed_axes_are_the_vectors():
    """A sensor's or a record channel's direction as a test engineer labels it ("+x", "-y", "Z"): the campaign of
    the vectors (same sensors, modes and verdict); text that is no axis is named by the schema."""
    data, _ = blind.make_case(1, "drive_belt", kind="shapes", machine="kid300")
    named = copy.deepcopy(data)
    positive, negative = ("+{a}", "{A}", "{a}+"), ("-{a}", "{A}-")  # the ways benches write an axis
    turned = 0
    for sensor in named["sensors"]:
        d = np.asarray(sensor["direction"], dtype=float)
        if np.count_nonzero(d) == 1:
            k = int(np.flatnonzero(d)[0])
            forms = positive if d[k] > 0 else negative
            sensor["direction"] = forms[turned % len(forms)].format(a="xyz"[k], A="XYZ"[k])
            turned += 1
    assert turned >= 6
    vectors, axes = campaign_module.parse(data), campaign_module.parse(named)
    assert axes.sensors == vectors.sensors
    assert diagnose_effects(axes).verdict == diagnose_effects(vectors).verdict
    named["sensors"][0]["direction"] = "w"
    with pytest.raises(InputError, match=r"^sensors\.0\.direction"):
        campaign_module.parse(named)


def test_damping_ratios_on_a_description_without_damping_are_left_out_and_said():
    """tests/data/press.toml describes no damping: every model damping ratio is 0. Two measured ratios (5 % and 4 %)
    were compared with it, +20 sigma each, and their chi^2 of 800 drowned the frequencies' 11 in the verdict ("not
    explained ... the model's damping () does not reproduce them"). They are left out of the campaign with a note,
    and the frequencies alone are diagnosed."""
    from pathlib import Path

    from mountid.diagnosis.gap import diagnose

    path = str(Path(__file__).parent / "data" / "press.toml")
    w = Machine.resolve(path).frequencies({})
    modes = {k: {"frequency": w[k], "uncertainty": 0.02} for k in ("x", "y", "z", "psi", "phi")}
    modes["x"]["damping_ratio"], modes["z"]["damping_ratio"] = 0.05, 0.04
    campaign = campaign_module.parse({"machine": path, "modes": modes})
    assert all(m.damping_ratio is None and m.damping_std is None for m in campaign.modes.values())
    assert campaign.notes == (
        "damping ratios of x, z not compared: press's description has no damping (its model's ratios are all 0); "
        "describe the isolators' damping to compare them",
    )
    diagnosis = diagnose(campaign)
    assert diagnosis.effects.nominal.damping_gap == {} and diagnosis.effects.kind == "no significant gap"
    # a description with damping compares them as before
    w = Machine.resolve("kid300").frequencies({})
    kid = campaign_module.parse(
        {
            "machine": "kid300",
            "modes": {k: {"frequency": w[k], "damping_ratio": 0.05} for k in ("x", "z", "psi", "phi")},
        }
    )
    assert kid.notes == () and all(m.damping_ratio == 0.05 for m in kid.modes.values())
