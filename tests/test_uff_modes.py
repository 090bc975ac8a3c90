"""A bench's modal analysis results in a UFF file (datasets 55: mode shapes at nodes, mountid.measurement.uff_modes):
read as a table of modes (records.ModeTable), against the rig's complex modes from a direct state-space solve
(scipy.linalg.eig); through the records chain, the command line and a campaign to the rig's poles and the paper's
stiffnesses; the format's zeros of unmeasured directions, load cases as runs, units of the geometry; what is no
table of modes named."""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import pyuff
import scipy.linalg

from mountid.cli import main
from mountid.diagnosis import campaign
from mountid.errors import InputError
from mountid.identification.combination import every_decay
from mountid.identification.from_records import identify_from_records
from mountid.machine import Machine
from mountid.measurement.modes import DEFAULT_FREQUENCY_STD
from mountid.measurement.records import ModeTable, named_runs, read_record, read_runs
from mountid.measurement.rig import Rig
from mountid.measurement.uff_modes import write_table
from mountid.validation.paper import PUBLISHED_STIFFNESS, TABLE_1, TRUE_DAMPING

NODES = {
    11: (0.45, 0.0, 0.1),
    12: (0.0, 0.45, 0.1),
    13: (-0.45, 0.0, 0.312),
    14: (0.0, -0.45, 0.312),
}
"""Four triaxial accelerometers on the body of kid300 [m] (node numbers as a bench's geometry gives them)."""

MILLIMETRE = 1000.0
"""The geometry written in mm (dataset 164's length factor: file value / factor = m)."""


def _rig() -> Rig:
    return Rig.of("kid300", {**TABLE_1, **PUBLISHED_STIFFNESS, **TRUE_DAMPING})


def _complex_modes(rig: Rig) -> tuple[np.ndarray, np.ndarray]:
    """The rig's poles p [rad/s] (Im p > 0, by frequency) and their displacement shapes in the coordinates q, from
    the first-order form [[0, I], [-M^-1 C, -M^-1 B]] by scipy.linalg.eig: independent of the records chain."""
    n = rig.M.shape[0]
    inverse = np.linalg.inv(rig.M)
    state = np.block([[np.zeros((n, n)), np.eye(n)], [-inverse @ rig.C, -inverse @ rig.B]])
    poles, vectors = scipy.linalg.eig(state)
    upper = np.flatnonzero(poles.imag > 0)
    order = upper[np.argsort(np.abs(poles[upper]))]
    return poles[order], vectors[:n, order]


def _node_shapes(rig: Rig, shapes: np.ndarray) -> dict[int, np.ndarray]:
    """Each node's x, y, z displacement per mode (3 x modes)."""
    return {
        node: np.array([rig.sensor_row(point, axis) for axis in np.eye(3)]) @ shapes for node, point in NODES.items()
    }


def _write(path, rig: Rig, kind: str = "complex", drop=(), load_cases=(1,), nodes=NODES, rotations=False) -> None:
    """A bench's export: the geometry (datasets 164 in mm and 15) and a dataset 55 per mode and load case,
    complex modes (analysis type 3: the eigenvalue) or normal modes (2: frequency |p| / 2 pi [Hz], the viscous
    damping ratio, the real part of the shape). ``drop``: (node, axis) not measured (written as 0)."""
    poles, shapes = _complex_modes(rig)
    at = _node_shapes(rig, shapes)
    sets = [
        pyuff.prepare_164(
            units_code=1, units_description="mm", temp_mode=1, length=MILLIMETRE, force=1.0, temp=1.0, temp_offset=0.0
        ),
        pyuff.prepare_15(
            node_nums=list(nodes),
            def_cs=[0] * len(nodes),
            disp_cs=[0] * len(nodes),
            color=[1] * len(nodes),
            x=[p[0] * MILLIMETRE for p in nodes.values()],
            y=[p[1] * MILLIMETRE for p in nodes.values()],
            z=[p[2] * MILLIMETRE for p in nodes.values()],
        ),
    ]
    for case in load_cases:
        for k, p in enumerate(poles):
            values = np.array([at[node][:, k] for node in nodes])  # nodes x 3
            phase = values.flat[np.argmax(np.abs(values))]
            values = values / phase * abs(phase)  # the largest entry real: how a bench normalises
            for node, axis in drop:
                values[list(nodes).index(node), axis - 1] = 0.0
            common = {
                "id1": f"mode {k + 1}",
                "model_type": 1,
                "data_ch": 3 if rotations else 2,
                "spec_data_type": 8,
                "load_case": case,
                "mode_n": k + 1,
                "node_nums": np.array(list(nodes)),
            }
            if kind == "complex":
                shape = {f"r{a + 1}": values[:, a] for a in range(3)}
                sets.append(pyuff.prepare_55(analysis_type=3, eig=p, modal_a=0j, modal_b=0j, **common, **shape))
            else:
                shape = {f"r{a + 1}": values[:, a].real for a in range(3)}
                if rotations:
                    shape |= {f"r{a + 4}": np.full(len(nodes), 1e-3) for a in range(3)}
                sets.append(
                    pyuff.prepare_55(
                        analysis_type=2,
                        freq=float(abs(p) / (2 * np.pi)),
                        modal_m=1.0,
                        modal_damp_vis=float(-p.real / abs(p)),
                        modal_damp_his=0.0,
                        **common,
                        **shape,
                    )
                )
    pyuff.UFF(str(path)).write_sets(sets, mode="add")


def test_complex_modes_read_as_the_rigs_poles_and_shapes(tmp_path):
    rig = _rig()
    path = tmp_path / "modes.uff"
    _write(path, rig)
    table = read_record(path)
    assert isinstance(table, ModeTable)
    poles, shapes = _complex_modes(rig)
    # the format writes six significant digits (E13.5)
    np.testing.assert_allclose(table.poles, poles, rtol=1e-5)
    assert [c.name for c in table.channels] == [f"node{n}:{a}" for n in NODES for a in (1, 2, 3)]
    for c in table.channels:
        np.testing.assert_allclose(c.point, NODES[int(c.name[4:6])], rtol=0, atol=1e-9)  # mm to m
    expected = np.concatenate([_node_shapes(rig, shapes)[n] for n in NODES])
    for k in range(len(poles)):
        # the same complex shape up to a complex factor (the bench's normalisation): |<a, b>| = |a| |b|
        a, b = table.shapes[:, k], expected[:, k]
        assert abs(np.vdot(a, b)) / (np.linalg.norm(a) * np.linalg.norm(b)) == pytest.approx(1.0, abs=1e-9)


def test_a_table_of_modes_through_the_records_chain_gives_the_rigs_modes_and_the_stiffnesses(tmp_path):
    rig = _rig()
    path = tmp_path / "modes.uff"
    _write(path, rig)
    machine = Machine.resolve("kid300")
    runs = named_runs(path, "modes.uff")
    found = every_decay(machine, runs, TABLE_1)
    poles, _ = _complex_modes(rig)
    # the bench parted the twins (x and y, psi and theta of the symmetric machine): both are labelled
    assert sorted(found.modes) == sorted(machine.modes)
    assert found.unlabelled == [] and found.warnings == []
    np.testing.assert_allclose(sorted(m.frequency for m in found.modes.values()), np.abs(poles), rtol=1e-5)
    undamped = machine.frequencies({**TABLE_1, **PUBLISHED_STIFFNESS})  # each label at its own mode's pole
    for label, m in found.modes.items():
        k = int(np.argmin(np.abs(np.abs(poles) - undamped[label])))
        assert m.frequency == pytest.approx(abs(poles[k]), rel=1e-5)
        assert m.damping_ratio == pytest.approx(-poles[k].real / abs(poles[k]), rel=1e-4)
        assert m.frequency_std == pytest.approx(DEFAULT_FREQUENCY_STD * m.frequency)
        assert not m.frequency_std_stated
        # against the description's nominal model (not the rig's stiffnesses); twins in their span
        assert m.mac > 0.999
        assert m.shape is not None
    assert any("table of 6 modes (complex modes) at 12 channels" in n for n in found.notes)
    result = identify_from_records(machine, runs, TABLE_1)
    for name, value in PUBLISHED_STIFFNESS.items():
        assert result.parameters[name] == pytest.approx(value, rel=1e-4)
    for name, value in TRUE_DAMPING.items():
        assert result.damping[name] == pytest.approx(value, rel=1e-3)


def test_normal_modes_take_the_frequency_as_p_and_say_what_is_not_read(tmp_path):
    rig = _rig()
    path = tmp_path / "normal.uff"
    _write(path, rig, kind="normal", rotations=True)
    table = read_record(path)
    poles, _ = _complex_modes(rig)
    np.testing.assert_allclose(np.abs(table.poles), np.abs(poles), rtol=1e-5)
    np.testing.assert_allclose(-table.poles.real / np.abs(table.poles), -poles.real / np.abs(poles), rtol=1e-4)
    assert table.kind == "normal modes"
    assert table.notes == ("the rotations at the nodes of modes 1, 2, 3, 4, 5, 6 are not read (translations only)",)
    found = every_decay(Machine.resolve("kid300"), [("normal.uff", table)], TABLE_1)
    assert len(found.modes) == 6
    assert any("not read" in n for n in found.notes)


def test_a_hysteretic_damping_ratio_alone_gives_half_of_it(tmp_path):
    path = tmp_path / "loss.uff"
    sets = [
        pyuff.prepare_55(
            analysis_type=2,
            model_type=1,
            data_ch=2,
            spec_data_type=8,
            load_case=1,
            mode_n=1,
            freq=3.0,
            modal_m=1.0,
            modal_damp_vis=0.0,
            modal_damp_his=0.08,
            node_nums=np.array([1]),
            r1=np.array([1.0]),
            r2=np.array([0.0]),
            r3=np.array([0.0]),
        )
    ]
    pyuff.UFF(str(path)).write_sets(sets, mode="add")
    table = read_record(path)
    assert abs(table.poles[0]) == pytest.approx(2 * math.pi * 3.0)
    assert -table.poles[0].real / abs(table.poles[0]) == pytest.approx(0.04)
    assert "half its hysteretic damping ratio 0.08" in table.notes[0]
    assert table.channels[0].name == "node1:1" and math.isnan(table.channels[0].point[0])  # no geometry


def test_directions_the_format_writes_as_zero_in_every_mode_are_no_channels(tmp_path):
    rig = _rig()
    path = tmp_path / "uniaxial.uff"
    drop = ((12, 1), (12, 2), (14, 1), (14, 3))  # node 12 read along z only, node 14 along y only
    _write(path, rig, drop=drop)
    table = read_record(path)
    names = [c.name for c in table.channels]
    assert len(names) == 8 and not any(f"node{n}:{a}" in names for n, a in drop)
    found = every_decay(Machine.resolve("kid300"), [("uniaxial.uff", table)], TABLE_1)
    # the eight channels still see the six motions: every mode with its shape, as from the twelve
    assert sorted(found.modes) == sorted(Machine.resolve("kid300").modes)
    assert all(m.mac > 0.999 and m.shape is not None for m in found.modes.values())


def test_load_cases_are_runs(tmp_path):
    rig = _rig()
    path = tmp_path / "cases.uff"
    _write(path, rig, load_cases=(1, 2))
    with pytest.raises(InputError) as err:
        read_record(path)
    assert err.value.parameter == "run"
    assert "holds 2 runs (tables of 6, 6 modes, a run per load case)" in err.value.reason
    assert isinstance(read_record(path, run=2), ModeTable)
    runs = named_runs(path, "cases.uff")
    assert [name for name, _ in runs] == ["cases.uff run 1", "cases.uff run 2"]
    found = every_decay(Machine.resolve("kid300"), runs, TABLE_1)
    assert len(found.modes) == 6


def test_what_is_no_table_of_modes_is_named(tmp_path):
    path = tmp_path / "response.uff"
    common = {"model_type": 1, "data_ch": 2, "spec_data_type": 8, "load_case": 1, "node_nums": np.array([1])}
    shape = {"r1": np.array([1.0]), "r2": np.array([0.0]), "r3": np.array([0.0])}
    pyuff.UFF(str(path)).write_sets(
        [pyuff.prepare_55(analysis_type=5, freq=3.0, freq_step_n=1, **common, **shape)], mode="add"
    )
    with pytest.raises(InputError) as err:
        read_record(path)
    assert err.value.reason == (
        "response.uff: dataset 55 of mode 0 holds frequency response data at nodes: a table of modes is of normal "
        "modes (analysis type 2) or complex modes (3, 7)"
    )
    growing = tmp_path / "growing.uff"
    pyuff.UFF(str(growing)).write_sets(
        [pyuff.prepare_55(analysis_type=3, eig=0.5 + 10j, mode_n=1, **common, **shape)], mode="add"
    )
    with pytest.raises(InputError, match=r"mode 1: its eigenvalue 0.5\+10j rad/s grows"):
        read_record(growing)


def test_the_command_line_reads_a_table_and_names_what_applies_to_samples(tmp_path, capsys):
    rig = _rig()
    path = tmp_path / "modes.uff"
    _write(path, rig)
    assert main(["process", "kid300", str(path), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert sorted(out["modes"]) == sorted(Machine.resolve("kid300").modes)
    for option in (["--rate", "100"], ["--start", "0.1"], ["--exponential-window", "2"]):
        assert main(["process", "kid300", str(path), *option]) == 2
        err = capsys.readouterr().err.strip()
        assert err.startswith(f"mountid: error: {option[0]}: applies to ") and "table of modes" in err
        assert "\n" not in err
    figures = tmp_path / "figures"
    assert main(["identify-record", "kid300", str(path), "--figures", str(figures)]) == 0
    assert sorted(p.name for p in figures.iterdir()) == ["modes.png"]  # no samples: no spectra


def test_a_campaign_lists_a_table_of_modes_as_a_record(tmp_path, capsys):
    rig = _rig()
    _write(tmp_path / "modes.uff", rig)
    data = {"machine": "kid300", "known": TABLE_1, "records": ["modes.uff"]}
    found = campaign.parse(data, tmp_path)
    assert sorted(found.modes) == sorted(Machine.resolve("kid300").modes)
    assert all(m.shape is not None for m in found.modes.values())
    assert [c.name for c in found.sensors][:3] == ["node11:1", "node11:2", "node11:3"]
    assert any("table of 6 modes" in n for n in found.record_notes)
    # the rig is the model at the paper's stiffnesses and damping: nothing to explain
    (tmp_path / "campaign.json").write_text(json.dumps(data), encoding="utf-8")
    assert main(["diagnose", str(tmp_path / "campaign.json"), "--json", "--no-figure"]) == 0
    assert json.loads(capsys.readouterr().out)["kind"] == "no significant gap"


def test_the_model_table_written_reads_back(tmp_path):
    """records.ModeTable.of_model through uff_modes.write_table and back: the model's undamped modes at the
    isolator points, to the format's six digits."""
    machine = Machine.resolve("kid300")
    points = [(0.344, 0.344, -0.3), (-0.344, 0.344, -0.3), (0.344, -0.344, -0.3), (0.0, 0.0, 0.5)]
    table = ModeTable.of_model(machine, {}, points)
    assert table.kind == "normal modes" and np.all(table.poles.real == 0)
    np.testing.assert_allclose(table.poles.imag, list(machine.frequencies({}).values()), rtol=1e-12)  # MODES' order
    write_table(table, tmp_path / "model.unv", titles=list(machine.module.MODES))
    back = read_record(tmp_path / "model.unv")
    assert [c.name for c in back.channels] == [c.name for c in table.channels]
    for a, b in zip(back.channels, table.channels, strict=True):
        assert a.point == pytest.approx(b.point, abs=1e-12) and a.direction == b.direction
    np.testing.assert_allclose(back.poles, table.poles, rtol=1e-5)
    scale = np.abs(table.shapes).max()
    np.testing.assert_allclose(back.shapes, table.shapes, rtol=0, atol=1e-5 * scale)
    titles = [s["id1"].strip() for s in pyuff.UFF(str(tmp_path / "model.unv")).read_sets() if s["type"] == 55]
    assert titles == list(machine.module.MODES)
    found = every_decay(machine, [("model.unv", back)], {})
    assert sorted(found.modes) == sorted(machine.modes) and all(m.mac > 0.9999 for m in found.modes.values())
    # undamped modes (ratios of 0): the stiffnesses from the frequencies as undamped ones, no damping fitted (it
    # was "b_xy: a damping must be positive, got 0")
    result = identify_from_records(machine, [("model.unv", back)], {})
    nominal = machine.values({}, machine.unknown)
    assert result.parameters == pytest.approx(nominal, rel=1e-5) and result.damping == {}
    assert any("no mode has a damping ratio above 0" in n for n in result.notes)


def test_a_bench_table_written_reads_back(tmp_path):
    """A table of complex modes read, written and read again: the same poles and shapes (a round trip of the
    writer), and a channel along no axis named."""
    _write(tmp_path / "bench.uff", _rig())
    table = read_record(tmp_path / "bench.uff")
    write_table(table, tmp_path / "again.uff")
    again = read_record(tmp_path / "again.uff")
    assert again.kind == "complex modes" and [c.name for c in again.channels] == [
        f"node{k}:{a}" for k in (1, 2, 3, 4) for a in (1, 2, 3)
    ]
    np.testing.assert_allclose(again.poles, table.poles, rtol=1e-5)
    np.testing.assert_allclose(again.shapes, table.shapes, rtol=0, atol=1e-5 * np.abs(table.shapes).max())
    turned = replace(table, channels=(replace(table.channels[0], direction=(0.6, 0.8, 0.0)), *table.channels[1:]))
    with pytest.raises(InputError, match="node11:1: measures along no axis"):
        write_table(turned, tmp_path / "turned.uff")
    twice = replace(
        table,
        channels=(*table.channels[:3], replace(table.channels[3], point=table.channels[0].point), *table.channels[4:]),
    )
    with pytest.raises(InputError, match="node12:1: a second channel at node 1 along axis 1"):
        write_table(twice, tmp_path / "twice.uff")


def test_the_modes_command_writes_the_model_for_the_bench(tmp_path, capsys):
    path = tmp_path / "model.unv"
    points = ["0.45,0,0.1", "0,0.45,0.1", "-0.45,0,0.3"]  # a point on the -x side reads as a value, not an option
    assert main(["modes", "kid300", "--uff", str(path), "--point", *points, "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["uff"] == {"file": str(path), "nodes": [[0.45, 0.0, 0.1], [0.0, 0.45, 0.1], [-0.45, 0.0, 0.3]]}
    assert len(read_record(path).channels) == 9
    assert main(["modes", "kid300", "--uff", str(tmp_path / "feet.unv")]) == 0
    assert "the 6 modes as UFF mode shapes at nodes 1 (0.343654, 0.343654, -0.3)" in capsys.readouterr().out
    assert main(["modes", "kid300", "--point", "0,0,0"]) == 2
    err = capsys.readouterr().err.strip()
    assert err == "mountid: error: --point: gives the nodes of --uff: give the file to write"


def test_the_file_modes_writes_is_checked_before_any_work(tmp_path, capsys):
    """A folder that does not exist was a traceback from pyuff ("Cannot access the file"); a name of another kind
    would have been written as UFF under it."""
    assert main(["modes", "kid300", "--uff", str(tmp_path / "none" / "model.unv")]) == 2
    assert capsys.readouterr().err.strip().endswith("--uff: the folder '" + str(tmp_path / "none") + "' does not exist")
    assert main(["modes", "kid300", "--uff", str(tmp_path / "model.txt")]) == 2
    assert "model.txt: name a file ending in .uff or .unv (UFF mode shapes)" in capsys.readouterr().err
    assert not list(tmp_path.iterdir())


def test_the_worked_example_is_the_belts_table():
    """examples/kid300-bench-modes.unv (the README's worked example) is blind_records.bench_table(20, "drive_belt")
    written: read back, its poles and shapes are the table's to the format's digits."""
    from mountid.validation.blind_records import bench_table

    table = bench_table(20, "drive_belt")
    shipped = read_record(Path(__file__).resolve().parents[1] / "examples" / "kid300-bench-modes.unv")
    assert [c.name for c in shipped.channels] == [c.name for c in table.channels]
    np.testing.assert_allclose(shipped.poles, table.poles, rtol=1e-5)
    np.testing.assert_allclose(shipped.shapes, table.shapes, rtol=0, atol=1e-5 * np.abs(table.shapes).max())


def test_a_dataset_pyuff_cannot_read_says_what_it_reads(tmp_path):
    """Complex shapes of six values per node (translations and rotations) are beyond pyuff's reader: the error
    names the dataset and what pyuff reads."""
    zeros = "  0.00000e+00" * 6
    lines = ["    -1", "    55", "mode 1", *["NONE"] * 4]
    lines += [f"{1:10d}{3:10d}{3:10d}{8:10d}{5:10d}{6:10d}", f"{2:10d}{6:10d}{1:10d}{1:10d}"]
    lines += [" -6.60869e-01  1.77272e+01" + "  0.00000e+00" * 4, f"{1:10d}", "  1.00000e+00" + zeros[13:], zeros]
    (tmp_path / "six.unv").write_text("\n".join([*lines, "    -1"]) + "\n")
    with pytest.raises(InputError, match=r"six.unv: dataset 1 \(type 55\) is not readable .*; pyuff reads mode shapes"):
        read_record(tmp_path / "six.unv")


def _text_2414(s: dict, label: int, location: int = 1, drop: int = 0) -> str:
    """A dataset 55 of _write as the text of the dataset 2414 (analysis data at nodes) later software writes its
    modes in, to the format's records (I10, E13.5): the same mode number (record 10, field 6), load case as the
    solution set (field 3), frequency and damping ratios (record 12) or eigenvalue (record 13), each node's values
    (complex: real and imaginary parts in turn). ``location``: the dataset location (1 at nodes); ``drop``: values
    left off each node's end (a file pyuff does not read as it should)."""
    complex_ = s["analysis_type"] == 3
    rows = np.column_stack([np.asarray(s[f"r{a}"]) for a in range(1, 7 if s["data_ch"] == 3 else 4)])
    values = np.stack([rows.real, rows.imag], axis=-1).reshape(len(rows), -1) if complex_ else rows.real
    eig = s["eig"] if complex_ else 0j
    twelve = (0.0, s.get("freq", 0.0), 0.0, 1.0, s.get("modal_damp_vis", 0.0), s.get("modal_damp_his", 0.0))
    lines = ["    -1", "  2414", f"{label:10d}", s["id1"], f"{location:10d}", s["id1"], "", "", "", ""]
    lines.append(
        "".join(f"{v:10d}" for v in (1, s["analysis_type"], s["data_ch"], 8, 5 if complex_ else 2, rows.shape[1]))
    )
    lines.append("".join(f"{v:10d}" for v in (1, 0, s["load_case"], 0, 0, s["mode_n"], 0, 0)))
    lines.append("".join(f"{v:10d}" for v in (1, len(rows), 0, 0, 0, 0, 0, 0)))
    lines.append("".join(f"{v:13.5E}" for v in twelve))
    lines.append("".join(f"{v:13.5E}" for v in (eig.real, eig.imag, 0.0, 0.0, 0.0, 0.0)))
    for node, row in zip(np.asarray(s["node_nums"]), values, strict=True):
        kept = row[: len(row) - drop]
        lines.append(f"{int(node):10d}" if location == 1 else f"{int(node):10d}{len(kept):10d}")
        lines.append("".join(f"{v:13.5E}" for v in kept))
    return "\n".join([*lines, "    -1", ""])


@pytest.mark.parametrize(("kind", "rotations"), [("complex", False), ("normal", False), ("normal", True)])
def test_modes_in_datasets_2414_read_as_in_datasets_55(tmp_path, kind, rotations):
    """The modes a bench or an FE program writes as analysis data at nodes (dataset 2414: I-DEAS, Simcenter, Femap)
    read as the same modes in datasets 55 do: poles, channels, points, shapes and notes alike, complex and normal
    modes, with rotations, two load cases as two runs; data on elements, or a node's values fewer than its data
    characteristic says, named."""
    rig = _rig()
    fifty_five = tmp_path / "m55.uff"
    _write(fifty_five, rig, kind=kind, load_cases=(1, 2), rotations=rotations)
    sets = pyuff.UFF(str(fifty_five)).read_sets()
    geometry = tmp_path / "geometry.uff"
    pyuff.UFF(str(geometry)).write_sets([s for s in sets if s["type"] != 55], mode="add")
    modes = [s for s in sets if s["type"] == 55]

    def written(name: str, **how: int) -> Path:
        path = tmp_path / name
        path.write_text(geometry.read_text() + "".join(_text_2414(s, k, **how) for k, s in enumerate(modes, 1)))
        return path

    analysis = written("m2414.uff")
    assert 55 not in pyuff.UFF(str(analysis)).get_set_types()
    expected, found = read_runs(fifty_five), read_runs(analysis)
    assert len(found) == len(expected) == 2
    for a, b in zip(found, expected, strict=True):
        np.testing.assert_allclose(a.poles, b.poles, rtol=1e-5)
        assert a.channels == b.channels and a.kind == b.kind and a.notes == b.notes
        np.testing.assert_allclose(a.shapes, b.shapes, rtol=1e-5, atol=1e-5 * np.abs(b.shapes).max())
    with pytest.raises(InputError, match=r"dataset 2414 \(analysis dataset 1\) holds no data at nodes \(dataset lo"):
        read_record(written("elements.uff", location=2), run=1)
    with pytest.raises(InputError, match=r"analysis dataset 1\): a node with [25] values where data characteristic"):
        read_record(written("short.uff", drop=1), run=1)
