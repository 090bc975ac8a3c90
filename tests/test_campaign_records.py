"""A campaign that lists impact records: the records chain runs on them inside `mountid diagnose`, and the
report echoes its conventions (the description, the shape coordinates, the isolator layout)."""

from __future__ import annotations

import json
import math
import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from conftest import description_without_values

from mountid.cli import main
from mountid.diagnosis import campaign
from mountid.diagnosis.gap import diagnose
from mountid.errors import InputError
from mountid.measurement import modal
from mountid.measurement.records import write_csv
from mountid.measurement.rig import Hammer, Rig, Sensor
from mountid.validation.paper import paper_hit, paper_sensors

KNOWN = {"m": 838.6, "J_xy": 61.44, "J_z": 51.52, "L_xy": 0.486, "L_z": 0.3, "b_xy": 337.2, "b_z": 1039.0}
CORNERS = ((0.4, 0.3, 0.25), (-0.4, -0.3, 0.25))


def _eight_channels() -> list[Sensor]:
    """Two triaxial sensors and two single axes: the channels span the six motions."""
    axes = dict(zip("xyz", np.eye(3), strict=True))
    out = [Sensor(f"{c}{i}", p, d, noise=0.01) for i, p in enumerate(CORNERS) for c, d in axes.items()]
    return [
        *out,
        Sensor("z2", (0.4, -0.3, 0.25), (0, 0, 1), noise=0.01),
        Sensor("y3", (-0.4, 0.3, 0.25), (0, 1, 0), noise=0.01),
    ]


@pytest.fixture(scope="module")
def folder(tmp_path_factory) -> Path:
    """Two records of the nominal machine (hit at a corner and at the top), and a campaign of records only."""
    out = tmp_path_factory.mktemp("records")
    rig = Rig.of("kid300")
    hits = [Hammer((0.4, 0.3, 0.3), (1, 0.7, -0.6)), Hammer((-0.4, 0.3, 0.3), (0.3, -1, -0.5))]
    for k, hit in enumerate(hits):
        write_csv(rig.simulate(_eight_channels(), 20.0, 500.0, hammers=[hit], seed=k), out / f"hit{k}.csv")
    data = {"name": "records only", "machine": "kid300", "known": KNOWN}
    data["records"] = ["hit0.csv", {"file": "hit1.csv", "start": 0.08}]
    (out / "campaign.json").write_text(json.dumps(data), encoding="utf-8")
    return out


def test_records_become_modal_data_with_shapes(folder):
    c = campaign.load(folder / "campaign.json")
    assert [r.path.name for r in c.records] == ["hit0.csv", "hit1.csv"] and c.records[1].start == 0.08
    assert set(c.modes) >= {"x", "z", "psi", "phi"}
    for mode in c.modes.values():
        assert mode.damping_ratio is not None and mode.shape is not None
        # the record's noise and the default for what a record does not show, in quadrature
        assert campaign.DEFAULT_SHAPE_STD < mode.shape_std < 1.01 * campaign.DEFAULT_SHAPE_STD
    (note,) = [n for n in c.record_notes if n.startswith("shape uncertainty per component: the record's noise")]
    assert all(f"{label} " in note for label in c.modes)
    truth = Rig.of("kid300").machine.frequencies(KNOWN | {"c_xy": 74.4e3, "c_z": 472.3e3})
    for label, mode in c.modes.items():
        # measured |p| against the undamped model: within the damping's second-order shift and 5 sigma
        assert abs(mode.frequency - truth[label]) < 5 * mode.frequency_std + 2e-3 * truth[label], label
    assert any("from hit" in note for note in c.record_notes)


def test_a_record_without_noise_gives_its_modes_at_the_models_resolution(tmp_path, capsys):
    """A simulated record without noise gives its poles to 1e-14 of their frequency: its campaign was refused with
    "modes.x.uncertainty: ... below 1e-09 of the frequency", an entry the campaign does not have. The records'
    standard deviations are raised to the model's resolution with a note, and the nominal machine then shows no
    gap (the pole frequencies are converted to undamped ones through damping fitted to the poles' own damping
    ratios, not to first order: that left 8e-9 of the frequency, a chi^2 of 81 at this resolution). At 2 kHz:
    at 500 Hz the rig's anti-alias filter (8th order at 200 Hz) still rings from the hit at 4e-8 of the response
    when the decay starts, which moves the poles beyond a noise-free record's standard deviations (any real
    record's noise hides it)."""
    quiet = [Sensor(s.name, s.point, s.direction, noise=0.0) for s in _eight_channels()]
    hit = Hammer((0.4, 0.3, 0.3), (1, 0.7, -0.6))
    write_csv(Rig.of("kid300").simulate(quiet, 4.0, 2000.0, hammers=[hit]), tmp_path / "quiet.csv")
    data = {"machine": "kid300", "known": KNOWN, "records": ["quiet.csv"]}
    (tmp_path / "campaign.json").write_text(json.dumps(data), encoding="utf-8")
    assert main(["diagnose", str(tmp_path / "campaign.json"), "--json", "--no-figure"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["kind"] == "no significant gap" and out["p_value"] > 0.5
    (raised,) = [n for n in out["record_notes"] if "below the model's resolution" in n]
    assert raised.startswith(", ".join(label for label in out["nominal"]["gap_after"]) + ": ")


def test_diagnose_runs_the_records_chain_and_echoes_the_conventions(folder, capsys):
    code = main(["diagnose", str(folder / "campaign.json"), "--json", "--no-figure"])
    out = json.loads(capsys.readouterr().out)
    assert code == 0 and out["kind"] == "no significant gap"  # the records are of the nominal machine
    assert [Path(r).name for r in out["records"]] == ["hit0.csv", "hit1.csv"]
    conventions = out["conventions"]
    assert conventions["shape_coordinates"] == ["x", "y", "z", "psi", "theta", "phi"]
    a = KNOWN["L_xy"] / np.sqrt(2)
    assert conventions["isolators"]["corner[+x-y]"] == pytest.approx([a, -a, -KNOWN["L_z"]], rel=1e-15)
    main(["diagnose", str(folder / "campaign.json"), "--no-figure"])
    text = capsys.readouterr().out
    assert "isolators at [m]: corner[+x+y] (0.344, 0.344, -0.3)" in text and "record: x:" in text


def test_a_missing_record_is_named(folder, capsys):
    data = {"machine": "kid300", "known": KNOWN, "records": ["hit0.csv", "nowhere.csv"]}
    with pytest.raises(InputError, match=r"^records\.1 \(nowhere\.csv\): no such file"):
        campaign.parse(data, folder)
    bad = folder / "bad.json"
    bad.write_text(json.dumps({**data, "records": [{"start": 0.1}]}), encoding="utf-8")
    assert main(["diagnose", str(bad), "--no-figure"]) == 2
    assert "records.0" in capsys.readouterr().err


def test_the_runs_of_a_uff_file_of_several_are_records_of_their_own(folder, tmp_path, capsys):
    """A bench's UFF export of two hits, a dataset per channel each, one after another: read at once it was one
    record of 16 channels, each pair at one point with the data of different hits. A campaign lists the file once
    per run ("run": k), or once without a run for every run: the modes are those of the two records as separate
    files (to the UFF's 12 digits), named by run; one run twice, or the file beside one of its runs, is named.
    process and identify-record read every run where --run does not pick one, combined per mode (weighted
    means)."""
    import pyuff

    from mountid.measurement.records import read_csv
    from mountid.measurement.uff import write_uff

    sets = []
    for k in range(2):
        write_uff(read_csv(folder / f"hit{k}.csv"), tmp_path / f"hit{k}.uff")
        sets += pyuff.UFF(str(tmp_path / f"hit{k}.uff")).read_sets()
    pyuff.UFF(str(tmp_path / "runs.uff")).write_sets(sets, mode="add")
    runs = [{"file": "runs.uff", "run": 1}, {"file": "runs.uff", "run": 2, "start": 0.08}]
    c = campaign.parse({"machine": "kid300", "known": KNOWN, "records": runs}, tmp_path)
    files = campaign.load(folder / "campaign.json")
    assert c.modes.keys() == files.modes.keys()
    for label, mode in c.modes.items():
        assert mode.frequency == pytest.approx(files.modes[label].frequency, rel=1e-9)
    assert any(n.startswith("x: frequency, damping ratio from runs.uff run 1, runs.uff run 2") for n in c.record_notes)
    # the file without a run: every run, as the runs listed one by one
    each = campaign.parse({"machine": "kid300", "known": KNOWN, "records": [{"file": "runs.uff"}]}, tmp_path)
    listed = [{"file": "runs.uff", "run": 1}, {"file": "runs.uff", "run": 2}]
    one_by_one = campaign.parse({"machine": "kid300", "known": KNOWN, "records": listed}, tmp_path)
    assert each.modes == one_by_one.modes and each.record_notes == one_by_one.record_notes
    for twice, named in (
        ([runs[0], {"file": "runs.uff", "run": 1}], r"^records\.1 \(runs\.uff run 1\): the same file as records\.0"),
        ([runs[1], "runs.uff"], r"^records\.1 \(runs\.uff\): the same file as records\.0 \(runs\.uff run 2\)"),
    ):
        with pytest.raises(InputError, match=named):
            campaign.parse({"machine": "kid300", "known": KNOWN, "records": twice}, tmp_path)
    # the command line: one run where --run gives it, named in the report; else both, combined per mode
    assert main(["process", "kid300", str(tmp_path / "runs.uff"), "--run", "2"]) == 0
    assert capsys.readouterr().out.startswith(f"kid300: 4 modes from {tmp_path / 'runs.uff'} run 2\n")
    single = []
    for run in ("1", "2"):
        assert main(["process", "kid300", str(tmp_path / "runs.uff"), "--run", run, "--json"]) == 0
        single.append(json.loads(capsys.readouterr().out)["modes"])
    assert main(["process", "kid300", str(tmp_path / "runs.uff"), "--json"]) == 0
    both = json.loads(capsys.readouterr().out)["modes"]
    assert both.keys() == single[0].keys() == single[1].keys()
    for label, mode in both.items():
        w = [1 / s[label]["frequency_std"] ** 2 for s in single]
        mean = sum(wk * s[label]["frequency"] for wk, s in zip(w, single, strict=True)) / sum(w)
        assert mode["frequency"] == pytest.approx(mean, rel=1e-12), label
        assert mode["frequency_std"] >= 1 / math.sqrt(sum(w)) * (1 - 1e-12), label
    assert main(["identify-record", "kid300", str(tmp_path / "runs.uff"), "--figures", str(tmp_path / "f")]) == 0
    out = capsys.readouterr().out
    assert f"note: figures: the spectra and the stabilisation diagram of {tmp_path / 'runs.uff'} run 1," in out
    assert out.startswith(f"kid300: 4 modes from {tmp_path / 'runs.uff'} (2 runs)\n")
    assert f"note: x: frequency, damping ratio from {tmp_path / 'runs.uff'} run 1, {tmp_path / 'runs.uff'} run 2" in out
    assert "c_z = " in out


def test_a_record_listed_twice_is_named(folder, tmp_path):
    """One record twice (or a copy under another name) would count its modes twice, halving their variance; the
    campaign's record at a level would stand for two excitation levels."""
    data = {"machine": "kid300", "known": KNOWN, "records": ["hit0.csv", "hit1.csv", {"file": "hit0.csv"}]}
    with pytest.raises(InputError, match=r"^records\.2 \(hit0\.csv\): the same file as records\.0 \(hit0\.csv\)"):
        campaign.parse(data, folder)
    (tmp_path / "copy.csv").write_bytes((folder / "hit1.csv").read_bytes())
    data["records"] = [str(folder / "hit1.csv"), "copy.csv"]
    with pytest.raises(InputError, match=r"^records\.1 \(copy\.csv\): the same content as records\.0 \(hit1\.csv\)"):
        campaign.parse(data, tmp_path)
    # the campaign's record again at another excitation level: it would compare the record with itself
    data = {"machine": "kid300", "known": KNOWN, "records": ["hit0.csv"]}
    data["levels"] = [{"name": "soft", "records": ["hit1.csv"]}, {"name": "hard", "records": ["hit0.csv"]}]
    with pytest.raises(InputError, match=r"^levels\.1\.records\.0 \(hit0\.csv\): the same file as records\.0"):
        campaign.parse(data, folder)


def test_a_mode_given_by_hand_over_the_records_is_said_with_how_far_apart_they_lie(folder):
    """A mode under ``modes`` overrides the records' estimate of it (its frequency, damping ratio and shape): the
    notes say so, with both frequencies, instead of naming the records as its source, and ask whether it is the
    same mode where they lie beyond RECORDS_DISAGREE of their combined standard deviation apart."""
    records = campaign.parse({"machine": "kid300", "known": KNOWN, "records": ["hit0.csv"]}, folder)
    x = records.modes["x"]
    for frequency, far in ((x.frequency + 0.5 * x.frequency_std, False), (30.0, True)):
        data = {
            "machine": "kid300",
            "known": KNOWN,
            "records": ["hit0.csv"],
            "modes": {"x": {"frequency": frequency, "uncertainty": x.frequency_std}},
        }
        c = campaign.parse(data, folder)
        assert c.modes["x"].frequency == frequency and c.modes["x"].damping_ratio is None
        assert not any(n.startswith("x: frequency") for n in c.record_notes)
        (note,) = [n for n in c.record_notes if n.startswith("x: given by hand")]
        assert f"({frequency:.6g} rad/s), in place of the records' (hit0.csv: {x.frequency:.6g} +- " in note
        assert note.endswith("sigma apart: the same mode?") == far
        assert c.record_modes == tuple(k for k in records.modes if k != "x")


def test_an_unreadable_uff_record_names_its_file_once(tmp_path):
    """The reader's reason names the file (mountid.measurement.uff: `identify-record` shows only the reason's
    parameter, "record"); in a campaign the entry names it, and the reason does not again."""
    (tmp_path / "garbled.uff").write_text("    -1\n    58\nnot a dataset\n    -1\n")
    data = {"machine": "kid300", "known": KNOWN, "records": ["garbled.uff"]}
    with pytest.raises(InputError, match=r"^records\.0 \(garbled\.uff\): dataset 1 \(type 58\) is not readable"):
        campaign.parse(data, tmp_path)


def test_records_on_a_description_without_nominal_unknowns(folder):
    """The records chain labels its poles against the model at its nominal values: a campaign of records alone on
    a description without them is a named error, and with measured frequencies under modes the records are
    labelled against the model identified from those."""
    description = description_without_values(folder, ("c_xy", "c_z"))
    data = {"machine": str(description), "known": KNOWN, "records": ["hit0.csv"]}
    with pytest.raises(InputError, match=r"^machine: kid300 gives no nominal value for c_xy, c_z: the records are"):
        campaign.parse(data, folder)
    given = campaign.parse({**data, "nominal": {"c_xy": 60e3, "c_z": 400e3}}, folder)  # values to label with
    with pytest.raises(InputError, match=r"^nominal: the campaign asks for nominal values identified from its"):
        campaign.parse({**data, "machine": "kid300", "nominal": "identified"}, folder)  # from no frequency
    assert {"x", "z", "psi", "phi"} <= set(given.modes) and given.notes[0].startswith(
        "nominal values from the campaign"
    )
    truth = Rig.of("kid300").machine.frequencies(KNOWN | {"c_xy": 74.4e3, "c_z": 472.3e3})
    c = campaign.parse({**data, "modes": {k: {"frequency": truth[k]} for k in ("x", "psi", "z")}}, folder)
    assert c.machine.parameters["c_z"]["value"] == pytest.approx(472.3e3, rel=1e-6)
    assert set(c.modes) > {"x", "psi", "z"} and any("from hit0.csv" in n for n in c.record_notes)


def test_records_of_two_states_are_named_and_a_frequency_only_report_prints(tmp_path, capsys):
    """Records without shapes (the paper's five channels) of two states of the machine (c_z 472 and 240 kN/m):
    the campaign notes the modes whose records disagree, and the text report (which compares the tie's mode
    shapes against the campaign's typical shape uncertainty) prints without a shape measured."""
    for name, c_z in (("a.csv", 472.3e3), ("b.csv", 240e3)):
        record = Rig.of("kid300", {"c_z": c_z}).simulate(paper_sensors(), 4.0, 500.0, hammers=[paper_hit()], seed=1)
        write_csv(record, tmp_path / name)
    data = {"machine": "kid300", "known": KNOWN, "records": ["a.csv", "b.csv"]}
    (tmp_path / "c.json").write_text(json.dumps(data), encoding="utf-8")
    c = campaign.load(tmp_path / "c.json")
    assert all(mode.shape is None for mode in c.modes.values())
    disagree = [n for n in c.record_notes if "the records disagree" in n]
    assert {n.split(":")[0] for n in disagree} >= {"z", "psi"}, c.record_notes
    assert main(["diagnose", str(tmp_path / "c.json"), "--no-figure"]) == 0
    out = capsys.readouterr().out
    assert "record: z: the records disagree beyond their uncertainty (a.csv 47.4" in out and "verdict:" in out
    assert {"z", "psi"} <= set(c.records_disagree)
    verdict = out.strip().splitlines()[-1]
    assert verdict.startswith("verdict: ") and "(but the records disagree on" in verdict, verdict


def test_records_of_one_state_agree_and_are_combined(folder):
    """The two nominal records of the fixture: no mode is named as disagreeing; each frequency is their
    inverse-variance weighted mean, its standard deviation the mean's (widened by the Birge ratio where they
    scatter beyond it)."""
    from mountid.identification.from_records import modal_data
    from mountid.measurement.records import read_record

    c = campaign.load(folder / "campaign.json")
    assert not [n for n in c.record_notes if "disagree" in n], c.record_notes
    each = [modal_data(c.machine, read_record(r.path), KNOWN, r.start).modes for r in c.records]
    for label in ("z", "phi"):  # no damping shift to convert: the means as combined
        (f0, s0), (f1, s1) = ((e[label].frequency, e[label].frequency_std) for e in each)
        w0, w1 = s0**-2, s1**-2
        mean, std = (w0 * f0 + w1 * f1) / (w0 + w1), (w0 + w1) ** -0.5
        birge = max(1.0, abs(f0 - f1) / math.hypot(s0, s1))  # sqrt(chi^2 / 1) for two
        assert c.modes[label].frequency == pytest.approx(mean, rel=1e-12)
        assert c.modes[label].frequency_std == pytest.approx(std * birge, rel=1e-12)
        assert any(
            n.startswith(f"{label}: frequency, damping ratio from hit0.csv, hit1.csv (weighted means")
            for n in c.record_notes
        )


def test_long_records_of_the_nominal_machine_show_no_gap(tmp_path):
    """60 s records of the nominal machine state kid300's x and psi to 1e-5: its non-proportional damping puts
    their poles' |p| 1e-4 off the undamped frequencies, which the diagnosis compares. Read as undamped, they were
    a significant gap 'explained by cog_height (probability 1.00)', confident and wrong on a clean machine;
    converted through the identified damped model they fit within their uncertainty."""
    rig = Rig.of("kid300")
    hits = [Hammer((0.4, 0.3, 0.3), (1, 0.7, -0.6)), Hammer((-0.4, 0.3, 0.3), (0.3, -1, -0.5))]
    for k, hit in enumerate(hits):
        write_csv(rig.simulate(_eight_channels(), 60.0, 500.0, hammers=[hit], seed=k), tmp_path / f"long{k}.csv")
    data = {"machine": "kid300", "known": KNOWN, "records": ["long0.csv", "long1.csv"]}
    (tmp_path / "c.json").write_text(json.dumps(data), encoding="utf-8")
    c = campaign.load(tmp_path / "c.json")
    truth = rig.machine.frequencies(KNOWN | {"c_xy": 74.4e3, "c_z": 472.3e3})
    for label, mode in c.modes.items():
        assert abs(mode.frequency - truth[label]) < 4 * mode.frequency_std, (label, mode.frequency, truth[label])
    assert any("pole frequencies |p| as undamped ones" in n and "x 17.712" in n for n in c.record_notes)
    assert diagnose(c).effects.kind == "no significant gap"


def test_a_turned_channel_in_the_records_is_tested_on_the_records_layout(tmp_path):
    """Every shape from records of one layout: that layout is the campaign's sensors (the turned-sensor and
    misplaced-sensor candidates need it), and channel y1, turned 15 degrees on its mount while its header
    states y, is what the diagnosis puts first."""
    turn = math.radians(15.0)
    sensors = [
        replace(s, direction=(np.sin(turn), np.cos(turn), 0.0)) if s.name == "y1" else s for s in _eight_channels()
    ]
    rig = Rig.of("kid300")
    record = rig.simulate(sensors, 20.0, 500.0, hammers=[Hammer((0.4, 0.3, 0.3), (1, 0.7, -0.6))], seed=3)
    stated = tuple(replace(c, direction=(0.0, 1.0, 0.0)) if c.name == "y1" else c for c in record.channels)
    write_csv(replace(record, channels=stated), tmp_path / "turned.csv")
    data = {"machine": "kid300", "known": KNOWN, "records": ["turned.csv"]}
    (tmp_path / "c.json").write_text(json.dumps(data), encoding="utf-8")
    c = campaign.load(tmp_path / "c.json")
    assert [s.name for s in c.sensors] == [s.name for s in sensors] and c.sensors[4].direction == (0.0, 1.0, 0.0)
    assert any(n.startswith("sensor layout of the shapes: the records' 8 channels") for n in c.record_notes)
    effects = diagnose(c).effects
    assert effects.best is not None and (effects.best.effect, effects.best.variant) == ("sensor_turned", "y1")


def test_a_campaign_places_the_channels_of_a_plain_csv(tmp_path, capsys):
    """A record entry's `channels` gives the points and directions a plain CSV lacks, its `ignore` the columns
    left unread (a tachometer in V: an error naming the entry and the channel without it); a channel the record
    does not hold is an error naming the entry."""
    rig = Rig.of("kid300")
    record = rig.simulate(paper_sensors(), 4.0, 500.0, hammers=[paper_hit()], seed=1)
    write_csv(record, tmp_path / "plain.csv")
    lines = [ln for ln in (tmp_path / "plain.csv").read_text(encoding="utf-8").splitlines() if not ln.startswith("#")]
    tacho = [lines[0] + ",Tacho [V]"] + [ln + ",4.99" for ln in lines[1:]]
    (tmp_path / "plain.csv").write_text("\n".join(tacho) + "\n", encoding="utf-8")
    channels = {c.name: {"point": list(c.point), "direction": list(c.direction)} for c in record.channels}
    data = {"machine": "kid300", "known": KNOWN, "records": [{"file": "plain.csv", "channels": channels}]}
    with pytest.raises(InputError, match=r"^records\.0 \(plain\.csv\): Tacho: is a raw voltage in V: .*\"ignore\""):
        campaign.parse(data, tmp_path)
    data["records"][0]["ignore"] = ["Tacho"]
    c = campaign.parse(data, tmp_path)
    assert {"x", "z", "psi", "phi"} <= set(c.modes)
    assert "plain.csv: left unread as the campaign says: Tacho" in c.record_notes
    data["records"][0]["channels"]["C_q"] = data["records"][0]["channels"].pop("C_x")
    with pytest.raises(InputError, match=r"^records\.0 \(plain\.csv\): channels: C_q: no such channel"):
        campaign.parse(data, tmp_path)


@pytest.mark.parametrize("damping", ["known", "fitted", "misstated"])
def test_pole_frequencies_given_by_hand_are_converted(damping, capsys, tmp_path):
    """Modes as modal-analysis software reports them (|p| and zeta of kid300's exact damped poles, 1e-5
    uncertainty) under `"frequency_type": "pole"`: the campaign holds the undamped frequencies, to 0.1 of
    their uncertainty whether the damping is known, fitted to the ratios, or known but misstated (the machine's
    twice the known values: the conversion takes the damping its ratios measure); the report says so. Without
    damping ratios or known damping the conversion is an error naming frequency_type."""
    from mountid.machine import Machine, damped_poles, matrices

    machine = Machine.resolve("kid300")
    factor = 2.0 if damping == "misstated" else 1.0
    values = machine.values(
        KNOWN | {"c_xy": 74.4e3, "c_z": 472.3e3, "b_xy": factor * KNOWN["b_xy"], "b_z": factor * KNOWN["b_z"]},
        tuple(machine.parameters),
    )
    undamped = machine.frequencies(values)
    lam = np.array([undamped[label] ** 2 for label in machine.module.MODES])
    p = dict(zip(machine.module.MODES, damped_poles(*matrices(machine.module, values), lam), strict=True))
    modes = {
        label: {
            "frequency": abs(p[label]),
            "uncertainty": 1e-5 * abs(p[label]),
            "damping_ratio": -p[label].real / abs(p[label]),
            "damping_uncertainty": 1e-3,
        }
        for label in ("x", "z", "psi", "phi")
    }
    known = KNOWN if damping != "fitted" else {k: v for k, v in KNOWN.items() if not k.startswith("b_")}
    data = {"machine": "kid300", "known": known, "modes": modes, "frequency_type": "pole"}
    c = campaign.parse(data)
    for label, mode in c.modes.items():
        assert abs(mode.frequency - undamped[label]) < 0.1 * mode.frequency_std, label
    assert abs(modes["x"]["frequency"] - undamped["x"]) > 5 * c.modes["x"].frequency_std  # a shift that matters
    assert len(c.notes) == 1 and c.notes[0].startswith("the modes' pole frequencies |p| as undamped ones")
    (tmp_path / "c.json").write_text(json.dumps(data), encoding="utf-8")
    assert main(["diagnose", str(tmp_path / "c.json"), "--no-figure"]) == 0
    out = capsys.readouterr().out
    assert "the modes' given as poles' |p| and converted" in out and "campaign: the modes' pole frequencies" in out
    bare = {label: {"frequency": m["frequency"]} for label, m in modes.items()}
    with pytest.raises(InputError, match=r"^frequency_type: .*give damping ratios or the damping parameters"):
        campaign.parse({**data, "known": {k: v for k, v in KNOWN.items() if not k.startswith("b_")}, "modes": bare})


def test_a_record_of_several_hits_gives_a_free_decay_per_hit(tmp_path):
    """A record hit three times without a force channel: a campaign that lists it without a start takes the free
    decay after each hit as a record of its own ("hits.csv hit 2"), combined per mode as records are (only the
    first hit's was used); each decay's own note no longer says the others are unused. With a start, the one
    decay from there, as before."""
    from mountid.identification.from_records import modal_data

    rig = Rig.of("kid300")
    hits = [
        Hammer((0.4, 0.3, 0.3), (1, 0.7, -0.6), time=0.05),
        Hammer((-0.4, 0.3, 0.3), (0.3, -1, -0.5), time=6.05),
        Hammer((0.4, -0.3, 0.3), (-1, 0.4, -0.7), time=12.05),
    ]
    record = rig.simulate(_eight_channels(), 18.0, 500.0, hammers=hits, seed=4)
    write_csv(record, tmp_path / "hits.csv")
    data = {"machine": "kid300", "known": KNOWN, "records": ["hits.csv"]}
    (tmp_path / "c.json").write_text(json.dumps(data), encoding="utf-8")
    c = campaign.load(tmp_path / "c.json")
    (said,) = [n for n in c.record_notes if n.startswith("hits.csv: 3 hits, a free decay after each (from t = 0.07, ")]
    first = modal_data(c.machine, record, KNOWN)
    assert first.hits == pytest.approx((0.05, 6.05, 12.05), abs=0.0075)  # an onset up to half the burst window early
    assert said.startswith(f"hits.csv: 3 hits, a free decay after each (from t = 0.07, {first.hits[1] + 0.03:.4g}, ")
    assert not [n for n in c.record_notes if "not used" in n]
    each = [first.modes] + [modal_data(c.machine, record, KNOWN, t + modal.AFTER_IMPACT).modes for t in first.hits[1:]]
    for label in ("z", "phi"):  # no damping shift to convert: the means as combined
        values = [(e[label].frequency, e[label].frequency_std) for e in each]
        w = np.array([s**-2 for _, s in values])
        mean = float(np.sum(w * [f for f, _ in values]) / np.sum(w))
        assert c.modes[label].frequency == pytest.approx(mean, rel=1e-12)
        assert any(
            n.startswith(f"{label}: frequency, damping ratio from hits.csv, hits.csv hit 2, hits.csv hit 3 (weighted")
            for n in c.record_notes
        )
    assert not [n for n in c.record_notes if "disagree" in n], c.record_notes
    assert diagnose(c).effects.kind == "no significant gap"
    data["records"] = [{"file": "hits.csv", "start": 0.07}]
    (tmp_path / "c.json").write_text(json.dumps(data), encoding="utf-8")
    one = campaign.load(tmp_path / "c.json")
    assert one.modes["z"].frequency == pytest.approx(each[0]["z"].frequency, rel=1e-12)
    assert [n for n in one.record_notes if "others' decays not used" in n and "without a start, process, " in n]


def test_process_and_identify_record_use_every_hit_of_a_record(tmp_path, capsys):
    """process and identify-record on a record hit three times without a force channel used the first hit's decay
    alone (a note said a campaign would use each): they take every decay too, combined per mode as a campaign
    does (combination.every_decay), and say so; with --start, the one decay from there, as before."""
    from mountid.identification.from_records import modal_data

    hits = [Hammer((0.4, 0.3, 0.3), (1, 0.7, -0.6), time=t) for t in (0.05, 6.05, 12.05)]
    record = Rig.of("kid300").simulate(_eight_channels(), 18.0, 500.0, hammers=hits, seed=4)
    write_csv(record, tmp_path / "hits.csv")
    machine = Rig.of("kid300").machine
    first = modal_data(machine, record, KNOWN)
    each = [first.modes] + [modal_data(machine, record, KNOWN, t + modal.AFTER_IMPACT).modes for t in first.hits[1:]]
    assert main(["process", "kid300", str(tmp_path / "hits.csv"), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["notes"][0].startswith(f"{tmp_path / 'hits.csv'}: 3 hits, a free decay after each (from t = 0.07, ")
    for label in ("x", "z", "psi", "phi"):
        values = [(e[label].frequency, e[label].frequency_std) for e in each]
        w = np.array([s**-2 for _, s in values])
        assert out["modes"][label]["frequency"] == pytest.approx(float(np.sum(w * [f for f, _ in values]) / w.sum()))
        assert out["modes"][label]["frequency_std"] < min(s for _, s in values)  # three decays know it better
    assert main(["process", "kid300", str(tmp_path / "hits.csv"), "--json", "--start", "0.07"]) == 0
    one = json.loads(capsys.readouterr().out)
    assert one["modes"]["z"]["frequency"] == pytest.approx(each[0]["z"].frequency, rel=1e-12)
    assert [n for n in one["notes"] if "others' decays not used" in n]
    known = [f"{k}={v}" for k, v in KNOWN.items() if not k.startswith("b_")]
    assert main(["identify-record", "kid300", str(tmp_path / "hits.csv"), "--json", "--set", *known]) == 0
    result = json.loads(capsys.readouterr().out)
    assert [n for n in result["notes"] if "3 hits, a free decay after each" in n]
    assert result["modes"]["z"]["frequency"] == pytest.approx(out["modes"]["z"]["frequency"], rel=1e-12)


def test_too_few_modes_from_records_say_what_the_records_show(tmp_path):
    """A campaign of one record of the machine running under its unbalance, not a hit: two modes were 'too few
    for 2 unknowns plus one held out' and nothing more; now the modes found and those not measured are named, and
    the records' warnings follow, the one that says the record is a steady oscillation among them."""
    from mountid.measurement.rig import Unbalance

    steady = Rig.of("kid300").simulate(_eight_channels(), 4.0, 500.0, unbalances=[Unbalance(43.1, 0.03, 100.0)])
    write_csv(steady, tmp_path / "running.csv")
    data = {"machine": "kid300", "known": KNOWN, "records": ["running.csv"]}
    (tmp_path / "c.json").write_text(json.dumps(data), encoding="utf-8")
    with pytest.raises(InputError) as err:
        campaign.load(tmp_path / "c.json")
    assert err.value.parameter == "modes" and " [the records also show: " in err.value.reason
    said = re.match(
        r"(\d) distinct frequenc\w+ \((.*?)\) for 2 unknowns \(c_xy, c_z\) plus one held out: 3 needed; "
        r"not measured: (.*?); the records gave too few",
        err.value.reason,
    )
    assert said is not None, err.value.reason
    found, missing = said.group(2).split(", "), said.group(3).split(", ")
    assert int(said.group(1)) == len(found) < 3 and not set(found) & set(missing)
    assert "running.csv: steady (all): a pole at 100.0000 rad/s (15.92 Hz) of damping ratio" in err.value.reason


@pytest.mark.parametrize(("ratio", "said"), [(0.5, ""), (1.0004, ""), (math.sqrt(2), "1.41 times")])
def test_a_widening_is_named_where_its_three_digits_show_it(ratio, said):
    """Two estimates of a mode that scatter ``ratio`` times their standard deviations (the Birge ratio): the means'
    standard deviations widen by it where it exceeds 1, and the note says so where the widening shows in its three
    digits (a record of two runs said "the damping ratios 1 times theirs, widened as much" at 1.0004)."""
    from mountid.identification.combination import combined
    from mountid.measurement.modes import MeasuredMode

    s, zs = 0.01, 0.001
    a = MeasuredMode("x", 17.7, s, damping_ratio=0.04, damping_std=zs)
    b = replace(a, frequency=17.7 + ratio * math.sqrt(2) * s, damping_ratio=0.04 + ratio * math.sqrt(2) * zs)
    mode, note = combined([(a, "run 1"), (b, "run 2")], a)
    assert mode.frequency_std == pytest.approx(s / math.sqrt(2) * max(1.0, ratio), rel=1e-9)
    assert mode.damping_std == pytest.approx(zs / math.sqrt(2) * max(1.0, ratio), rel=1e-9)
    if said:
        assert f"the frequencies scatter {said}" in note and f"the damping ratios {said} theirs" in note
    else:
        assert note == ""
