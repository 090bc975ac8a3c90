"""Frequency responses from a force channel (mountid.measurement.frf) and the modal fit on them: H1 against the
rig's exact frequency response, the coherence where an input is not measured, and hammer tests the free decay
cannot use (several hits in one record, a double hit) giving modes within their stated spread."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from mountid.cli import main
from mountid.errors import InputError
from mountid.identification.from_records import identify_from_record, modal_data, pole_frequencies
from mountid.machine import damped_poles
from mountid.measurement import frf
from mountid.measurement.records import Record, write_csv
from mountid.measurement.rig import Hammer, Rig
from mountid.measurement.settings import RECORDS
from mountid.validation.paper import PUBLISHED_STIFFNESS, TABLE_1, TRUE_DAMPING, paper_hit, paper_sensors

RIG_VALUES = {**TABLE_1, **PUBLISHED_STIFFNESS, **TRUE_DAMPING}


def _rig() -> Rig:
    return Rig.of("kid300", RIG_VALUES)


def _hits(count: int, spacing: float, **changes) -> list[Hammer]:
    hit = paper_hit()
    return [
        Hammer(hit.point, hit.direction, hit.peak, hit.duration, 0.05 + spacing * k, **changes) for k in range(count)
    ]


def _exact(rig: Rig, omega: float, decay: float) -> np.ndarray:
    """The acceleration per force at each paper sensor for the hit, at s = i omega + decay (an exponential
    window of decay [1/s] multiplies the impulse response by exp(-decay t): its transform is taken there)."""
    hit = paper_hit()
    rows = np.array([rig.sensor_row(s.point, s.direction, s.name) for s in paper_sensors()])
    col = rig.force_column(hit.point, hit.direction, "hammer")
    s = 1j * omega + decay
    return s**2 * rows @ np.linalg.solve(rig.C + s**2 * rig.M + s * rig.B, col)


def test_h1_of_one_hit_is_the_exact_frequency_response():
    """One hit in a 20 s record (1 % noise on the responses): H1 within a few percent of the rig's exact
    frequency response at the modes and between them; a single hit has coherence 1 (one average)."""
    rig = _rig()
    record = rig.simulate(paper_sensors(), 20.0, 2000.0, hammers=_hits(1, 20.0), seed=1, force_channel="F")
    estimate = frf.h1(record, "F")
    assert estimate.hits == pytest.approx((0.0515,), abs=1e-3) and estimate.h1.shape[1] == len(paper_sensors())
    for omega in (17.71, 25.0, 36.94, 47.46, 64.1):
        k = int(np.argmin(np.abs(estimate.omega - omega)))
        exact = _exact(rig, estimate.omega[k], estimate.window_decay)
        assert np.max(np.abs(estimate.h1[k] / exact - 1)) < 0.05, omega
        assert np.all(estimate.coherence[k] > 1 - 1e-9)


def test_coherence_falls_where_an_unmeasured_input_acts():
    """Four hits, the responses also driven by a second hammer the force channel does not record: coherence
    near 1 on the first three modes (which the measured hits drive hard), below it where the other input
    drives a mode the measured hit barely excites."""
    rig = _rig()
    hits = _hits(4, 4.0)
    measured = rig.simulate(paper_sensors(), 16.0, 2000.0, hammers=hits, seed=1, force_channel="F")
    other = [
        Hammer((0.0, 0.45, 0.3), (1.0, 0.0, 0.0), 600.0, 0.004, h.time + 1.3 + 0.4 * k) for k, h in enumerate(hits)
    ]
    unmeasured = rig.simulate(paper_sensors(), 16.0, 2000.0, hammers=other, seed=2)
    data = measured.data.copy()
    data[:, :-1] += unmeasured.data
    estimate = frf.h1(Record(measured.time, data, measured.channels), "F")
    clean = frf.h1(measured, "F")
    for omega in (17.71, 36.94, 47.46):
        assert np.max(clean.at(omega)[1]) > 0.99
    for omega in (17.71, 64.1):  # where the measured hits dominate: still coherent
        assert np.max(estimate.at(omega)[1]) > 0.95
    coherence = np.array([estimate.at(w)[1] for w in np.linspace(30, 55, 26)])
    assert coherence.min() < 0.5  # where the unmeasured input dominates a channel


def _truth(rig: Rig) -> dict[str, complex]:
    mod = rig.machine.module
    lam = np.asarray(mod.squared_frequencies(**{a: rig.values[a] for a in mod.FORWARD_ARGUMENTS}))
    return dict(zip(rig.machine.modes, damped_poles(rig.M, rig.C, rig.B, lam), strict=True))


def test_modes_from_the_frequency_responses_are_within_their_stated_spread():
    """Over eight noise seeds the frequencies and damping ratios fitted on the impulse responses of H1 miss
    the truth by their stated standard deviation (RMS of error/std within [0.5, 1.6]), for one hit in 8 s and
    for four hits in 16 s, of which the free decay uses the first alone (it ends at the second hit); the four
    averaged hits state (and have) a smaller spread than the one, and than the first hit's free decay."""
    rig = _rig()
    truth = _truth(rig)
    spread = {}
    for count, spacing in ((1, 8.0), (4, 4.0)):
        z_freq, z_zeta = [], []
        for seed in range(8):
            hits = _hits(count, spacing)
            record = rig.simulate(paper_sensors(), count * spacing, 2000.0, hammers=hits, seed=seed, force_channel="F")
            result = identify_from_record(rig.machine, record, TABLE_1, start=0.07)
            assert result.frf is not None and len(result.frf.hits) == count
            assert any("H1 frequency responses" in note for note in result.notes)
            for label, m in result.modes.items():
                p = truth[label]
                z_freq.append((m.frequency - abs(p)) / m.frequency_std)
                z_zeta.append((m.damping_ratio + p.real / abs(p)) / m.damping_std)
                spread.setdefault((count, label), []).append(m.frequency_std / m.frequency)
            if count > 1:  # the free decay ends at the second hit: the first hit's decay alone, a wider spread
                decay = identify_from_record(rig.machine, record, TABLE_1, start=0.07, use_force=False)
                assert any(n.startswith("free decay until t = 4.0") for n in decay.notes)
                assert decay.modes.keys() == result.modes.keys()
                for label, m in decay.modes.items():
                    spread.setdefault((0, label), []).append(m.frequency_std / m.frequency)
        for z in (z_freq, z_zeta):
            assert 0.5 < np.sqrt(np.mean(np.square(z))) < 1.6, count
    for label in rig.machine.unique_modes:
        if (1, label) in spread:
            assert np.median(spread[(4, label)]) < np.median(spread[(1, label)]), label
            assert np.median(spread[(4, label)]) < np.median(spread[(0, label)]), label


def test_a_double_hit_is_divided_out():
    """A second hit 30 ms after the first at 60 % (the hammer bounced): the force channel names it, and the
    frequency responses divide it out; the free decay from after both hits needs a later start."""
    rig = _rig()
    record = rig.simulate(
        paper_sensors(), 8.0, 2000.0, hammers=_hits(1, 8.0, second_hit=(0.03, 0.6)), seed=3, force_channel="F"
    )
    found = modal_data(rig.machine, record, TABLE_1, start=0.07)
    assert [w.kind for w in found.warnings] == ["double_hit"]
    true_w = dict(zip(rig.machine.modes, pole_frequencies(rig.machine, rig.values), strict=True))
    for label, m in found.modes.items():
        assert abs(m.frequency - true_w[label]) < 4 * m.frequency_std, label


def test_frequency_responses_need_a_hit():
    rig = _rig()
    record = rig.simulate(paper_sensors(), 4.0, 2000.0, hammers=_hits(1, 4.0), force_channel="F")
    silent = Record(record.time, np.column_stack([record.data[:, :-1], np.zeros(len(record.time))]), record.channels)
    with pytest.raises(InputError, match="F: the force channel is zero throughout"):
        frf.h1(silent, "F")


def test_identify_record_on_the_command_line_uses_the_force_and_draws_the_frequency_responses(tmp_path, capsys):
    rig = _rig()
    record = rig.simulate(paper_sensors(), 16.0, 2000.0, hammers=_hits(4, 4.0), seed=1, force_channel="F")
    path = tmp_path / "hits.csv"
    write_csv(record, path)
    assert main(["identify-record", "kid300", str(path), "--figures", str(tmp_path / "figures")]) == 0
    out = capsys.readouterr().out
    assert "modes from the H1 frequency responses of 4 hits on F" in out and "c_z = " in out
    assert (tmp_path / "figures" / "frf.png").is_file()
    # without the force: a free decay after each hit, each until the next (one ran over all four, found no mode)
    assert main(["identify-record", "kid300", str(path), "--free-decay"]) == 0
    out = capsys.readouterr().out
    assert f"note: {path}: 4 hits, a free decay after each (from t = 0.07, 4.0" in out and "c_z = " in out
    assert "H1" not in out  # each later decay is one too, not the frequency responses of all four hits again
    assert main(["identify-record", "kid300", str(path), "--free-decay", "--start", "0.07"]) == 0
    assert "note: free decay until t = 4.0" in capsys.readouterr().out


def test_simulate_writes_several_hits_and_the_hammers_force(tmp_path, capsys):
    """simulate --hit-time T1 T2 --force-channel F writes the record Rig.simulate gives for those hits with a load
    cell (the force [N] its last channel), and the records chain fits its modes on the H1 frequency responses of
    both hits; with --free-decay, on the decay after each."""
    from mountid.measurement.records import read_record

    path = tmp_path / "hits.csv"
    argv = ["simulate", "kid300", "--out", str(path), "--duration", "8", "--seed", "2"]
    assert main([*argv, "--hit-time", "0.05", "4", "--force-channel", "F"]) == 0
    assert "(A_x, A_y, B_y, A_z, C_x, F)" in capsys.readouterr().out
    written = read_record(path)
    rig = Rig.of("kid300")
    hits = [Hammer(paper_hit().point, paper_hit().direction, 3000.0, time=t) for t in (0.05, 4.0)]
    sensors = paper_sensors(0.01)
    expected = rig.simulate(sensors, 8.0, 2000.0, hits, seed=2, force_channel="F")
    assert written.names == expected.names and written.channels[-1].quantity == "force"
    np.testing.assert_allclose(written.data, expected.data, rtol=1e-12, atol=1e-12 * np.abs(expected.data).max())
    assert main(["process", "kid300", str(path)]) == 0
    assert "modes from the H1 frequency responses of 2 hits on F" in capsys.readouterr().out
    assert main(["identify-record", "kid300", str(path), "--free-decay"]) == 0
    assert f"{path}: 2 hits, a free decay after each (from t = 0.07, 4.0" in capsys.readouterr().out
    # hits closer than the chain's separate hits are named as its double hits
    assert main([*argv, "--hit-time", "0.05", "0.3", "4", "--force-channel", "F"]) == 0
    out = capsys.readouterr().out
    assert "note: the hits at 0.3 s lie within 0.5 s of the one before (at 0.05 s): the records chain takes each" in out


def test_the_hit_summary_names_every_hit():
    """A record of several hits with a load cell: the note describes each (it described the first alone, beside
    "the H1 frequency responses of 2 hits"), as ranges over them; one hit, as before; a double hit belongs to its
    hit."""
    from mountid.measurement import modal

    rig = _rig()
    hit, peak = paper_hit(), paper_hit().peak
    hits = [*_hits(1, 4.0), Hammer(hit.point, hit.direction, peak / 2, hit.duration, 4.05, second_hit=(0.03, 0.6))]
    record = rig.simulate(paper_sensors(), 8.0, 2000.0, hammers=hits, seed=1, force_channel="F")
    said = modal.hit_summary(record, "F")
    assert said.startswith("2 hits on F at t = 0.0510, 4.0510 s: peak ") and " N, 4.5 ms above 5 % of it" in said
    low, high = (float(v) for v in said.split("peak ")[1].split(" N")[0].split(" to "))
    assert low == pytest.approx(peak / 2, rel=2e-3) and high == pytest.approx(peak, rel=2e-3)
    first = rig.simulate(paper_sensors(), 4.0, 2000.0, hammers=hits[:1], seed=1, force_channel="F")
    assert modal.hit_summary(first, "F").startswith(f"hit on F at t = 0.0510 s: peak {high:.4g} N, 4.5 ms above")


def test_a_start_with_a_force_channel_places_the_checks_and_free_decay_uses_it(tmp_path, capsys):
    """With a force channel the modes come from H1: a --start there was read as a time of the impulse responses by
    the sensor check (20 s on a 4 s record: warnings of empty means) and gave a "too_short" warning of -16 s; it is a
    time of the record, checked against its end and said to place the record's checks only. process takes
    --free-decay as identify-record does."""
    from mountid.measurement.rig import Sensor

    rig = _rig()
    corners = [(sx * 0.4, sy * 0.4, 0.3) for sx, sy in ((1, 1), (-1, 1), (-1, -1))]
    axes = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
    sensors = [Sensor(f"s{k}{j}", p, d, noise=0.01) for k, p in enumerate(corners) for j, d in enumerate(axes)]
    seven = [*sensors[:6], sensors[8]]  # their rows span the six motions
    record = rig.simulate(seven, 8.0, 2000.0, hammers=_hits(2, 4.0), seed=1, force_channel="F")
    path = tmp_path / "hits.csv"
    write_csv(record, path)
    for command in ("process", "identify-record"):
        assert main([command, "kid300", str(path), "--start", "20"]) == 2
        assert "--start: 20 s is at or after the record's end (7.9995 s)\n" in capsys.readouterr().err
    # 5 s: within the record, beyond the impulse responses (3.96 s): the sensor check of seven channels had none
    assert main(["process", "kid300", str(path), "--start", "5"]) == 0
    out = capsys.readouterr().out
    assert "note: the start given (5 s) places the record's checks only: the modes come from the H1" in out
    assert main(["process", "kid300", str(path), "--start", "0.07", "--free-decay"]) == 0
    out = capsys.readouterr().out
    assert "H1" not in out and "note: free decay until t = 4.0" in out


def test_a_roving_hammer_export_is_read_as_runs(tmp_path, capsys):
    """A roving-hammer test exported to one UFF file: each run the same response nodes and directions, the force at
    the node hit (node 100, then 101), a bench's one description in every ID line 1. Read as one record it was ten
    responses, half of them of the other hit, divided by the first hit's force (MAC of phi 0.53, psi 0.69, no
    word of the second force channel); each run is a record of its own now, combined per mode. A record of two
    force channels says which one its H1 is of."""
    import pyuff

    from mountid.measurement.records import read_runs
    from mountid.measurement.uff import write_uff

    rig, sets, records = Rig.of("kid300"), [], []
    for k, point in enumerate(((0.4, 0.3, 0.3), (-0.4, 0.3, 0.3))):
        record = rig.simulate(paper_sensors(), 4.0, 2000.0, [Hammer(point, (1, 0.7, -0.6))], seed=k, force_channel="F")
        write_uff(record, tmp_path / f"run{k}.uff")
        run = pyuff.UFF(str(tmp_path / f"run{k}.uff")).read_sets()
        run[-1]["rsp_node"] = 100 + k
        sets += [{**s, "id1": "Time Response"} for s in run]
        records.append(record)
    pyuff.UFF(str(tmp_path / "roving.uff")).write_sets(sets, mode="add")
    runs = read_runs(tmp_path / "roving.uff")
    assert [r.names[-1] for r in runs] == ["node100:0", "node101:0"]
    for got, expected in zip(runs, records, strict=True):
        np.testing.assert_allclose(got.data, expected.data, rtol=1e-11, atol=1e-12 * np.abs(expected.data).max())
    assert main(["process", "kid300", str(tmp_path / "roving.uff"), "--json"]) == 0
    modes = json.loads(capsys.readouterr().out)["modes"]
    assert set(modes) == {"x", "z", "phi", "psi"} and all(m["mac"] > 0.99 for m in modes.values())
    both = Record(
        records[0].time,
        np.column_stack([records[0].data, records[1].data[:, -1]]),
        (*records[0].channels, replace(records[1].channels[-1], name="G")),
    )
    found = modal_data(rig.machine, both, {})
    assert "1 force channel not used (G): the H1 frequency responses are of one input, F" in found.notes


def test_channels_at_one_place_are_named():
    """Two runs of a file the reader cannot part (of different sizes) read as one record: each channel has a twin of
    the other hit at its point and direction, and the mode shapes mix the hits. The records chain names them (a
    spare sensor measures so too); a record of distinct placements has no such warning."""
    from mountid.measurement import modal

    rig = _rig()
    first = rig.simulate(paper_sensors(), 4.0, 2000.0, hammers=_hits(1, 4.0), seed=1)
    second = rig.simulate(paper_sensors()[:2], 4.0, 2000.0, hammers=_hits(1, 4.0), seed=2)
    twins = tuple(replace(c, name=f"{c.name}#2") for c in second.channels)
    both = Record(first.time, np.column_stack([first.data, second.data]), (*first.channels, *twins))
    found = modal_data(rig.machine, both, TABLE_1)
    [said] = [w for w in found.warnings if w.kind == "same_place"]
    assert said.channel == "A_x, A_x#2, A_y, A_y#2"
    assert said.message.startswith("A_x and A_x#2; A_y and A_y#2 measure at one point along one direction each")
    assert modal.same_place(first) == []
    assert not any(w.kind == "same_place" for w in modal_data(rig.machine, first, TABLE_1).warnings)


SHAKER = ((0.35, 0.25, 0.3), (0.5, 0.6, -0.62))
"""A shaker's point [m] and direction on kid300: every mode excited."""


def periodic(record: Record, force: str) -> Record:
    """The impulse responses the records chain fits of a periodic excitation on ``force``."""
    return frf.continuous_h1(record, force).as_impulse_record()


def _shaker_record(duration: float = 64.0, noise: float = 0.01, **changes) -> Record:
    """kid300 under a shaker's multisine (0.5-40 Hz, 16 s period), the paper's channels and the force, at 200 Hz."""
    from mountid.measurement.rig import Shaker

    shaker = Shaker(*SHAKER, high=40.0, period=16.0, **changes)
    return _rig().simulate(paper_sensors(noise), duration, 200.0, shakers=[shaker], seed=1, force_channel="F")


def test_a_periodic_excitation_gives_the_exact_frequency_responses():
    """A shaker's multisine, whole periods after the first averaged without a window: the impulse responses of H1
    on the lines it excites (0.5-40 Hz by 1/16 Hz) transform to the rig's exact accelerances (noise-free channels:
    to 1e-3 of each one's largest, the anti-alias filter's rounding), coherence 1."""
    record = _shaker_record(noise=0.0)
    impulse = periodic(record, "F")
    lines = impulse.impulse
    assert (lines.spacing, lines.top) == (pytest.approx(1 / 16), pytest.approx(40.0))
    assert lines.origin.startswith("3 periods of 16 s of a periodic excitation on F")
    n = len(impulse.time)
    h = np.fft.rfft(impulse.data, axis=0) / (n * lines.spacing)  # back to the lines [m/s^2 per N]
    rig = _rig()
    rows = np.array([rig.sensor_row(s.point, s.direction, s.name) for s in paper_sensors()])
    column = rig.force_column(*SHAKER, "shaker")
    for k in range(8, int(40 * 16) + 1, 7):  # 0.5 Hz up, every seventh line
        s = 2j * np.pi * k * lines.spacing
        exact = s**2 * rows @ np.linalg.solve(rig.C + s**2 * rig.M + s * rig.B, column)
        assert np.max(np.abs(h[k] - exact)) < 1e-3 * np.max(np.abs(exact)), k
    assert all(np.min(c[8:]) > 1 - 1e-6 for _, c in lines.coherence)


def test_a_shaker_test_gives_the_rigs_poles_and_the_papers_stiffnesses(tmp_path, capsys):
    """Through the records chain (1 % noise on the responses): each mode's frequency and damping ratio within three
    of their standard deviations of the rig's pole, said to come from the periods; identify-record gives the
    paper's stiffnesses within three of theirs; the force is summarised as an excitation, not as hits. A second
    force channel beside a periodic one is an error (test_mimo: one record cannot part their responses)."""
    record = _shaker_record()
    found = modal_data(_rig().machine, record, {})
    poles = _rig().poles
    for label, mode in found.modes.items():
        p = poles[np.argmin(np.abs(np.abs(poles) - mode.frequency))]
        assert abs(mode.frequency - abs(p)) < 3 * mode.frequency_std, label
        assert abs(mode.damping_ratio - (-p.real / abs(p))) < 3 * mode.damping_std, label
    assert set(found.modes) == {"x", "phi", "z", "psi"}
    assert any("H1 of 3 periods of 16 s of a periodic excitation on F" in note for note in found.notes)
    assert not [w for w in found.warnings if w.kind in ("double_hit", "impact_in_segment")]
    from mountid.measurement.records import Channel

    second = Channel("G", quantity="force", unit="N")  # a second shaker's force: the two cannot be told apart
    two = replace(record, data=np.column_stack([record.data, record.data[:, -1]]), channels=(*record.channels, second))
    with pytest.raises(InputError, match="^F: a periodic excitation beside 1 other force: .*--ignore"):
        modal_data(_rig().machine, two, {})
    write_csv(record, tmp_path / "shaker.csv")
    assert main(["identify-record", "kid300", str(tmp_path / "shaker.csv"), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    for name, value in PUBLISHED_STIFFNESS.items():
        assert abs(out["parameters"][name] - value) < 3 * out["parameter_std"][name], name
    assert any(n.startswith("continuous excitation on F: ") for n in out["notes"])


def test_a_short_periodic_excitation_or_a_force_the_responses_do_not_follow_is_named():
    """A periodic force of two periods is an error naming the force channel; a random force the responses do not
    follow (the force channel replaced by noise) is read as a random excitation whose impulse responses explain
    nothing: the poles leave the decay unexplained and the coherence is low, both said."""
    with pytest.raises(InputError, match=r"^F: a periodic excitation of 16 s holds 2 periods"):
        periodic(_shaker_record(duration=40.0), "F")
    record = _shaker_record(duration=64.0)
    rng = np.random.default_rng(3)
    forces = [c.quantity == "force" for c in record.channels]
    noisy = replace(record, data=np.where(forces, rng.normal(0, 200.0, record.data.shape), record.data))
    assert frf.is_continuous(noisy, "F")
    assert frf.continuous_h1(noisy, "F").block == "block"  # random: neither periods nor bursts
    found = modal_data(_rig().machine, noisy, {})  # a pole the noise gave, labelled: both warnings say what it is
    assert {"unexplained", "low_coherence"} <= {w.kind for w in found.warnings}
    hammer = _rig().simulate(paper_sensors(), 4.0, 500.0, hammers=[paper_hit()], force_channel="F")
    offset = replace(hammer, data=hammer.data + np.array([c.quantity == "force" for c in hammer.channels]) * 300.0)
    assert not frf.is_continuous(hammer, "F") and not frf.is_continuous(offset, "F")  # a hammer; with 300 N offset


def _random_record(duration: float, noise: float, seed: int = 0, rig: Rig | None = None) -> Record:
    """kid300 under a shaker's random force (0.5-40 Hz, new phases every 16 s), the paper's channels and the force,
    at 200 Hz."""
    from mountid.measurement.rig import Shaker

    shaker = Shaker(*SHAKER, high=40.0, period=16.0, random=True, seed=seed)
    rig = rig or _rig()
    return rig.simulate(paper_sensors(noise), duration, 200.0, shakers=[shaker], seed=seed + 1, force_channel="F")


def test_an_output_only_record_read_as_a_free_decay_is_named_a_steady_motion():
    """The responses to a random force whose force channel is not recorded (ambient or operational excitation looks
    alike), read as a free decay from a start given: no free decay to fit, and the error says the responses do not
    decay, what such a record is, and what mountid reads instead (without the start: its correlation functions,
    test_ambient)."""
    record = _random_record(64.0, 0.01)
    responses = record.select(record.responses)
    with pytest.raises(
        InputError, match="the responses do not decay .*: a steady motion, not a hit's free decay"
    ) as err:
        modal_data(_rig().machine, responses, {}, start=0.07)
    assert "without a start given, mountid reads a broadband one as output-only" in err.value.reason


def test_the_rigs_random_shaker_never_repeats_nor_rests():
    """Shaker(random=True): new phases every period, back to back: no period and no burst found in its force, its RMS
    the one asked for; burst random and random at once are an error naming the shaker."""
    from mountid.measurement.rig import Shaker

    shaker = Shaker(*SHAKER, rms=150.0, high=40.0, period=16.0, random=True)
    force = shaker.force(np.arange(0.0, 64.0, 1 / 200))
    assert frf._period(force, RECORDS) is None and len(frf._bursts(force, 200.0, RECORDS)) == 1
    assert float(np.sqrt(np.mean(force**2))) == pytest.approx(150.0, rel=0.05)
    with pytest.raises(InputError, match="^shaker: is burst random or random, not both"):
        Shaker(*SHAKER, burst=0.5, random=True)


def test_a_sweep_is_named():
    """A shaker swept from 0.5 to 40 Hz over the record (linear and logarithmic): no period, no burst, and not random
    either (its quarters excite different bands: the least squares need every line excited before the record's last
    eighth), an error naming the force channel and what is read."""
    from dataclasses import dataclass

    import scipy.signal

    @dataclass(frozen=True)
    class Sweep:  # what the rig asks of a shaker: a point, a direction, the highest frequency and the force
        point: tuple[float, float, float]
        direction: tuple[float, float, float]
        method: str
        high: float = 40.0

        def force(self, t: np.ndarray) -> np.ndarray:
            return 280.0 * scipy.signal.chirp(t, 0.5, 64.0, self.high, method=self.method)

    for method in ("linear", "logarithmic"):
        record = _rig().simulate(paper_sensors(), 64.0, 200.0, shakers=[Sweep(*SHAKER, method)], force_channel="F")
        with pytest.raises(InputError, match="^F: a continuous excitation whose spectrum changes over the record"):
            frf.continuous_h1(record, "F")


def test_a_random_excitation_gives_the_exact_frequency_responses():
    """A force that never repeats (noise-free channels): least squares over 128 s give impulse responses of 16 s whose
    transform is the rig's exact accelerance s^2 r^T (C + s^2 M + s B)^-1 f: from 2 to 40 Hz within 3e-4 of each
    line's largest (2e-4 seen), from 0.625 Hz, where the accelerance falls towards 0, within 5e-3 (3.2e-3 seen); the
    coherence above 0.99 on these lines. So for a record that starts while the shaker runs (the first 16 s cut off:
    the responses begin with the decay of what the force did before; correlated with the whole force, 5e-3 off), and
    the correlations over the whole record, which take the response after its end for 0, were 1.4 off at 0.56 Hz
    and 5e-3 in the median."""
    whole = _random_record(144.0, 0.0)
    from_rest = Record(whole.time[: 128 * 200], whole.data[: 128 * 200], whole.channels)
    running = Record(whole.time[16 * 200 :] - 16.0, whole.data[16 * 200 :], whole.channels)
    rig = _rig()
    rows = np.array([rig.sensor_row(s.point, s.direction, s.name) for s in paper_sensors()])
    column = rig.force_column(*SHAKER, "shaker")
    lines = range(10, 40 * 16 + 1)  # 0.625 to 40 Hz by 1/16 Hz
    for record in (from_rest, running):
        estimate = frf.continuous_h1(record, "F")
        assert (estimate.block, estimate.averages, estimate.length) == ("block", 8, pytest.approx(16.0))
        assert estimate.averaged == (
            "128 s of a random excitation on F (impulse responses of 16 s by least squares over the record)"
        )
        for k in lines:
            s = 1j * estimate.omega[k]
            exact = s**2 * rows @ np.linalg.solve(rig.C + s**2 * rig.M + s * rig.B, column)
            within = 3e-4 if k >= 2 * 16 else 5e-3
            assert np.max(np.abs(estimate.h1[k] - exact)) < within * np.max(np.abs(exact)), k
        assert np.min(estimate.coherence[list(lines)]) > 0.99


def test_a_random_excitation_gives_the_rigs_poles_within_their_spread():
    """Through the records chain (1 % noise, 96 s, three seeds): every mode's frequency and damping ratio within
    three standard deviations of the rig's pole, and the RMS of error / standard deviation over them in [0.3, 1.6]
    (the spread stated is the spread there is); said to come from the random excitation. A record whose impulse
    responses have not died out within 1/8 of it (64 s: x's time constant 1.5 s against 8 s) is named with the length
    to record, and so is one too short for impulse responses of 64 samples."""
    rig = _rig()
    scores = []
    for seed in range(3):
        found = modal_data(rig.machine, _random_record(96.0, 0.01, seed), {})
        assert set(found.modes) == {"x", "phi", "z", "psi"}
        for mode in found.modes.values():
            p = rig.poles[np.argmin(np.abs(np.abs(rig.poles) - mode.frequency))]
            scores += [
                (mode.frequency - abs(p)) / mode.frequency_std,
                (mode.damping_ratio - (-p.real / abs(p))) / mode.damping_std,
            ]
        assert any("H1 of 96 s of a random excitation on F" in note for note in found.notes)
    assert np.max(np.abs(scores)) < 3
    assert 0.3 < float(np.sqrt(np.mean(np.square(scores)))) < 1.6
    with pytest.raises(InputError, match=r"^F: random excitation: \w+'s impulse response still decays .* record \d+"):
        frf.continuous_h1(_random_record(64.0, 0.01), "F")
    with pytest.raises(InputError, match=r"^F: random excitation over 400 samples: .* need 64 samples or more"):
        frf.continuous_h1(_random_record(2.0, 0.01), "F")


def test_band_limited_frequency_responses_are_fitted_after_their_edge_rings_down():
    """A shaker's H1 through 0.5-25 Hz (noise-free): the impulse responses ring at 25 Hz from the hit, decaying as 1/t
    only; fitted from 4 of its periods (0.16 s) every mode's damping ratio is within 1e-3 of its value or its
    standard deviation of the rig's (from 0.02 s, as a hammer's H1, x's was 1e-3 low, phi's 3.6e-3 high: six
    of its standard deviations)."""
    from mountid.identification.from_records import impulse_start
    from mountid.measurement.rig import Shaker

    rig = _rig()
    shaker = Shaker(*SHAKER, high=25.0, period=16.0)
    record = rig.simulate(paper_sensors(0.0), 64.0, 200.0, shakers=[shaker], seed=1, force_channel="F")
    found = modal_data(rig.machine, record, {})
    assert impulse_start(periodic(record, "F").impulse) == pytest.approx(0.16)
    for label, mode in found.modes.items():
        p = rig.poles[np.argmin(np.abs(np.abs(rig.poles) - mode.frequency))]
        zeta = -p.real / abs(p)
        assert abs(mode.damping_ratio - zeta) < max(1e-3 * zeta, mode.damping_std), label


def test_a_lightly_damped_machine_is_averaged_once_its_response_has_settled():
    """kid300 with a tenth of its damping (x's decay time constant 15 s against a 16 s period): the periods before
    the response repeats are left out (the first alone left a tenth of the transient in the second: H1 off by
    percents); in a record too short for it to settle, named. Noise-free channels: H1 within 1e-3 of the exact
    accelerance."""
    from mountid.measurement.rig import Shaker

    rig = Rig.of("kid300", {**RIG_VALUES, "b_xy": RIG_VALUES["b_xy"] / 10, "b_z": RIG_VALUES["b_z"] / 10})
    shaker = Shaker(*SHAKER, high=40.0, period=16.0)

    def simulated(duration: float) -> Record:
        return rig.simulate(paper_sensors(0.0), duration, 200.0, shakers=[shaker], seed=1, force_channel="F")

    with pytest.raises(InputError, match=r"^F: the response to a periodic excitation of 16 s has not settled in 4"):
        periodic(simulated(64.0), "F")
    impulse = periodic(simulated(256.0), "F")
    left = int(impulse.impulse.origin.rsplit("(the first ", 1)[1].split(",")[0])  # e^(-sigma 16 k) down to 1e-4
    assert left >= 2 and impulse.impulse.origin.startswith(f"{16 - left} periods of 16 s"), impulse.impulse.origin
    h = np.fft.rfft(impulse.data, axis=0) / (len(impulse.time) * impulse.impulse.spacing)
    rows = np.array([rig.sensor_row(s.point, s.direction, s.name) for s in paper_sensors()])
    column = rig.force_column(*SHAKER, "shaker")
    for k in range(8, int(40 * 16) + 1, 7):
        s = 2j * np.pi * k / 16
        exact = s**2 * rows @ np.linalg.solve(rig.C + s**2 * rig.M + s * rig.B, column)
        assert np.max(np.abs(h[k] - exact)) < 1e-3 * np.max(np.abs(exact)), k


def test_burst_random_is_averaged_burst_by_burst():
    """Burst random (the shaker on for half of each 16 s block with new phases, then quiet): no period, so each
    burst from its start is a block without a window; noise-free channels: H1 within 1 % of the exact accelerance
    (the response's remnant at the block's end leaks: 0.5 % of x's); through the chain (1 % noise) every mode's
    frequency and damping ratio within three standard deviations of the rig's pole. A quiet time too short for the
    response to die out is named."""
    from mountid.measurement.rig import Shaker

    rig = _rig()

    def simulated(burst: float, noise: float) -> Record:
        shaker = Shaker(*SHAKER, high=40.0, period=16.0, burst=burst)
        return rig.simulate(paper_sensors(noise), 96.0, 200.0, shakers=[shaker], seed=1, force_channel="F")

    estimate = frf.continuous_h1(simulated(0.5, 0.0), "F")
    assert (estimate.block, estimate.averages) == ("burst", 6) and estimate.averaged.startswith("6 bursts of ")
    assert estimate.length == pytest.approx(16.0, abs=0.02)  # the shortest spacing of the bursts' detected starts
    rows = np.array([rig.sensor_row(s.point, s.direction, s.name) for s in paper_sensors()])
    column = rig.force_column(*SHAKER, "shaker")
    for k in range(8, int(40 * 16) - 8, 7):
        s = 1j * estimate.omega[k]
        exact = s**2 * rows @ np.linalg.solve(rig.C + s**2 * rig.M + s * rig.B, column)
        assert np.max(np.abs(estimate.h1[k] - exact)) < 1e-2 * np.max(np.abs(exact)), k
    found = modal_data(rig.machine, simulated(0.5, 0.01), {})
    for label, mode in found.modes.items():
        p = rig.poles[np.argmin(np.abs(np.abs(rig.poles) - mode.frequency))]
        assert abs(mode.frequency - abs(p)) < 3 * mode.frequency_std, label
        assert abs(mode.damping_ratio - (-p.real / abs(p))) < 3 * mode.damping_std, label
    assert set(found.modes) == {"x", "phi", "z", "psi"}
    with pytest.raises(InputError, match=r"^F: burst 1 of \d+: \w+'s response has not died out before the next"):
        frf.continuous_h1(simulated(0.9, 0.0), "F")
    shaker = Shaker(*SHAKER, high=40.0, period=16.0, burst=0.5)
    short = rig.simulate(paper_sensors(0.0), 32.0, 200.0, shakers=[shaker], seed=1, force_channel="F")
    with pytest.raises(InputError, match=r"^F: burst random of 2 bursts: three or more are needed"):
        frf.continuous_h1(short, "F")


def test_a_clipped_response_of_a_shaker_test_is_named():
    """A shaker test's response channel held at its sensor's range (clipped at 60 % of its peak): a clipping warning
    naming it, as for a hammer test (a shaker's record had no response checks)."""
    from mountid.measurement.rig import Shaker

    clean = _shaker_record(noise=0.01)
    top = float(np.max(np.abs(clean.channel("A_x"))))
    sensors = [replace(s, clip=0.6 * top) if s.name == "A_x" else s for s in paper_sensors(0.01)]
    shaker = Shaker(*SHAKER, high=40.0, period=16.0)
    record = _rig().simulate(sensors, 64.0, 200.0, shakers=[shaker], seed=1, force_channel="F")
    warned = [w for w in modal_data(_rig().machine, record, {}).warnings if w.kind == "clipping"]
    assert [w.channel for w in warned] == ["A_x"], warned
    assert not [w for w in modal_data(_rig().machine, clean, {}).warnings if w.kind == "clipping"]
