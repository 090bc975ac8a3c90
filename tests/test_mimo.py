"""Several shakers at once (MIMO): each force's frequency responses with the others' share of the response taken out
(measurement.frf.several_inputs), against the rig's exact ones where H1 of one force is far off; the modes from
the force that drives each most strongly (identification.references.every_input); what cannot be told apart (one
signal on two shakers, a periodic excitation beside another force) named; the command line's shakers and their
refusals."""

from __future__ import annotations

import json
from dataclasses import dataclass, replace
from functools import cache

import numpy as np
import pytest
import pyuff
from conftest import budget
from hypothesis import given, settings
from hypothesis import strategies as st

from mountid.cli import main
from mountid.errors import InputError
from mountid.identification.from_records import modal_data
from mountid.measurement import frf, uff
from mountid.measurement.records import Record
from mountid.measurement.rig import Hammer, Rig, Shaker
from mountid.validation.paper import PUBLISHED_STIFFNESS, TABLE_1, TRUE_DAMPING, paper_sensors

RIG_VALUES = {**TABLE_1, **PUBLISHED_STIFFNESS, **TRUE_DAMPING}

FIRST = ((0.35, 0.25, 0.3), (0.5, 0.6, -0.62))
"""The first shaker's point [m] and direction on kid300: every mode driven."""
SECOND = ((0.3, -0.5, 0.2), (0.0, 1.0, 0.0))
"""The second's: along y on the other side."""


@cache
def _rig() -> Rig:
    return Rig.of("kid300", RIG_VALUES)


def _shakers(**kind: object) -> list[Shaker]:
    """Two shakers 0.5-40 Hz, each with its own signal (``kind``: random=True or burst=share)."""
    return [
        Shaker(*FIRST, high=40.0, period=16.0, seed=0, **kind),
        Shaker(*SECOND, high=40.0, period=16.0, seed=7, **kind),
    ]


@cache
def _record(kind: str, noise: float = 0.01) -> Record:
    """kid300 under two shakers at once, random (128 s) or burst random (6 bursts of 16 s), the paper's channels
    and each force on its own channel (F1, F2), at 200 Hz."""
    shakers = _shakers(random=True) if kind == "random" else _shakers(burst=0.5)
    duration = 128.0 if kind == "random" else 96.0
    return _rig().simulate(paper_sensors(noise), duration, 200.0, shakers=shakers, seed=1, force_channel=["F1", "F2"])


def _accelerance(estimate: frf.FrfEstimate, shaker: Shaker) -> np.ndarray:
    """The rig's exact accelerances at the paper's channels per N of ``shaker`` on the estimate's lines but 0 Hz."""
    rig = _rig()
    rows = np.array([rig.sensor_row(s.point, s.direction, s.name) for s in paper_sensors()])
    column = rig.force_column(shaker.point, shaker.direction)
    omega = estimate.omega[1:]
    return -(omega**2)[:, None] * np.einsum("cq,lqr,r->lc", rows, rig.frf(omega), column)


@pytest.mark.parametrize(("kind", "above", "below"), [("random", 1e-3, 1e-2), ("burst", 5e-3, 3e-2)])
def test_each_forces_frequency_responses_are_the_rigs(kind, above, below):
    """Random and burst random on two shakers at once (noise-free channels): each force's frequency responses on
    every line both forces excite from 2 to 40 Hz within ``above`` of the line's largest exact accelerance (random
    5e-4 seen, burst 1.8e-3: the responses' remnant at a burst's end leaks), from 0.625 Hz, where the accelerance
    falls towards 0, within ``below`` (5.8e-3, 2e-2); the multiple coherence above 0.9999. H1 of one force alone, the
    other's response taken for noise, is off by a third of the largest or more."""
    record = _record(kind, 0.0)
    estimates = frf.several_inputs(record, ("F1", "F2"))
    assert [e.force for e in estimates] == ["F1", "F2"]
    for estimate, shaker, name in zip(estimates, _shakers(), ("F1", "F2"), strict=True):
        exact = _accelerance(estimate, shaker)
        omega = estimate.omega[1:]
        both = estimate.coherence[1:, 0] > 0  # a line where one force falls below RecordSettings.shaker_floor: 0
        assert np.count_nonzero(~both[omega < 2 * np.pi * 40]) <= 1
        error = np.abs(estimate.h1[1:] - exact).max(axis=1) / np.abs(exact).max(axis=1)
        high = both & (omega >= 2 * np.pi * 2)
        low = both & (omega >= 2 * np.pi * 0.625) & ~high
        assert error[high].max() < above and error[low].max() < below, (name, error[high].max(), error[low].max())
        assert estimate.coherence[1:][high].min() > 0.9999
        assert estimate.averaged.startswith(f"{name}'s share of ")
    alone = frf.continuous_h1(record, "F1")
    exact = _accelerance(alone, _shakers()[0])
    lines = alone.omega[1:] > 2.0
    assert np.abs(alone.h1[1:] - exact)[lines].max() / np.abs(exact).max() > 0.3


@dataclass(frozen=True)
class _Mixed:
    """A shaker whose signal is ``share`` of another's and the rest its own (the rig asks a point, a direction, the
    highest frequency and the force)."""

    point: tuple[float, float, float]
    direction: tuple[float, float, float]
    first: Shaker
    own: Shaker
    share: float
    high: float = 40.0

    def force(self, t: np.ndarray) -> np.ndarray:
        return self.share * self.first.force(t) + (1 - self.share) * self.own.force(t)


def test_forces_that_correlate_are_parted_and_one_signal_is_named():
    """Two shakers whose forces correlate (the second's signal 60 % the first's: coherence about 0.7, as a machine's
    motion makes two shakers' forces correlate near its modes; noise-free channels) give each one's frequency
    responses from 2 to 40 Hz within 1e-3 of each line's largest; one signal on both is an error naming the second
    force and saying why."""
    first, own = _shakers(random=True)
    for share in (0.6, 1.0):
        mixed = _Mixed(*SECOND, first, own, share)
        record = _rig().simulate(
            paper_sensors(0.0), 128.0, 200.0, shakers=[first, mixed], seed=1, force_channel=["F1", "F2"]
        )
        if share == 1.0:
            with pytest.raises(InputError, match=r"^F2: correlates with F1 \(coherence 1.000 .*one signal drives both"):
                frf.several_inputs(record, ("F1", "F2"))
            continue
        for estimate, shaker in zip(frf.several_inputs(record, ("F1", "F2")), [first, mixed], strict=True):
            exact = _accelerance(estimate, shaker)
            lines = estimate.omega[1:] >= 2 * np.pi * 2
            error = np.abs(estimate.h1[1:] - exact).max(axis=1) / np.abs(exact).max(axis=1)
            assert error[lines].max() < 1e-3, (estimate.force, error[lines].max())


def test_a_periodic_excitation_beside_another_force_is_named():
    """A multisine repeats its spectrum every period: beside a second force, one record cannot tell their frequency
    responses apart; the error names the periodic force and says what can (and that --ignore reads one alone)."""
    periodic = Shaker(*FIRST, high=40.0, period=16.0)
    record = _rig().simulate(
        paper_sensors(), 64.0, 200.0, shakers=[periodic, _shakers(random=True)[1]], force_channel=["F1", "F2"]
    )
    with pytest.raises(InputError, match="^F1: a periodic excitation beside 1 other force: .*--ignore"):
        modal_data(_rig().machine, record, {})


def test_the_modes_come_from_the_force_that_drives_each_most_strongly():
    """Through the records chain: every mode within 3 of its standard deviations of the rig's pole (frequency and
    damping ratio), each from one force (a note says which), the frequency responses kept those of the force most
    modes came from; a force named fits its own; a name that is not one of the forces is an error naming the
    parameter. The same shakers with one channel of their summed force: x 3.1 deviations off (beyond 2.5 asserted)."""
    rig = _rig()
    record = _record("random")
    found = modal_data(rig.machine, record, {})
    poles = rig.poles
    for label, mode in found.modes.items():
        p = poles[np.argmin(np.abs(np.abs(poles) - mode.frequency))]
        assert abs(mode.frequency - abs(p)) < 3 * mode.frequency_std, label
        assert abs(mode.damping_ratio - (-p.real / abs(p))) < 3 * mode.damping_std, label
    assert set(found.modes) == {"x", "phi", "z", "psi"}
    summary = next(n for n in found.notes if n.startswith("2 shakers at once (F1, F2): each mode from the force"))
    assert found.frf is not None and f"from {found.frf.force}" in summary
    own = modal_data(rig.machine, record, {}, force="F1")
    assert own.frf is not None and own.frf.force == "F1"
    with pytest.raises(InputError, match="^force: 'G': one of the forces of a record of several shakers at once"):
        modal_data(rig.machine, record, {}, force="G")
    summed = rig.simulate(paper_sensors(0.01), 128.0, 200.0, shakers=_shakers(random=True), seed=1, force_channel="F")
    off = [
        abs(m.frequency - abs(poles[np.argmin(np.abs(np.abs(poles) - m.frequency))])) / m.frequency_std
        for m in modal_data(rig.machine, summed, {}).modes.values()
    ]
    assert max(off) > 2.5


def test_the_rig_records_each_shakers_force_on_its_own_channel():
    """Rig.simulate with a name per shaker: each force on its channel, their sum the one channel of one name; a name
    per shaker with a hammer, or a count that differs, is an error naming force_channel."""
    rig, shakers = _rig(), _shakers(random=True)
    each = rig.simulate(paper_sensors(0.0), 8.0, 100.0, shakers=shakers, force_channel=["F1", "F2"])
    both = rig.simulate(paper_sensors(0.0), 8.0, 100.0, shakers=shakers, force_channel="F")
    assert each.forces == ("F1", "F2")
    np.testing.assert_allclose(each.channel("F1") + each.channel("F2"), both.channel("F"), atol=1e-9)
    np.testing.assert_array_equal(each.select(each.responses).data, both.select(both.responses).data)
    for names, hammers in ((["F1", "F2", "F3"], []), (["F1", "F2"], [Hammer(*FIRST)]), (["F", "F"], [])):
        with pytest.raises(InputError, match="^force_channel: .*one per shaker"):
            rig.simulate(paper_sensors(), 8.0, 100.0, hammers, shakers=shakers, force_channel=names)


def test_the_command_line_runs_several_shakers(tmp_path, capsys):
    """simulate --shaker-at with a force channel per shaker, then identify-record: the paper's stiffnesses within 3
    of their standard deviations; --frf-out writes both inputs' frequency responses, --figures draws each; the
    refusals name the option."""
    out = tmp_path / "mimo.csv"
    base = ["simulate", "kid300", "--out", str(out), "--duration", "128", "--rate", "200"]
    base += ["--hit-point", "0.35,0.25,0.3", "--hit-direction", "0.5,0.6,-0.62"]
    common = [*base, "--shaker", "0.5", "40"]
    assert main([*common, "--shaker-random", "--shaker-at", "0.3,-0.5,0.2", "+y", "--force-channel", "F1", "F2"]) == 0
    capsys.readouterr()
    frfs = tmp_path / "mimo.uff"
    figures = tmp_path / "figures"
    assert (
        main(["identify-record", "kid300", str(out), "--json", "--frf-out", str(frfs), "--figures", str(figures)]) == 0
    )
    result = json.loads(capsys.readouterr().out)
    assert {f.name for f in figures.iterdir()} >= {"frf_F1.png", "frf_F2.png", "stabilisation.png"}
    for name, value in PUBLISHED_STIFFNESS.items():
        assert abs(result["parameters"][name] - value) < 3 * result["parameter_std"][name], name
    assert any(note.endswith("5 frequency response functions per input, 2 inputs") for note in result["notes"])
    refusals = [
        (["--shaker-at", "0.3,-0.5,0.2", "+y"], "--shaker-at: several shakers at once need --shaker-random"),
        (["--shaker-random", "--shaker-at", "0.3,-0.5,0.2", "+y", "--force-channel", "F"], "--force-channel: 1 name"),
        (["--shaker-random", "--force-channel", "F1", "F2"], "--force-channel: 2 names: several are for several"),
        (["--shaker-random", "--shaker-at", "0.3,-0.5,0.2", "+y", "--force-channel", "F", "F"], "--force-channel: F F"),
        (["--shaker-at", "0.3,-0.5", "+y", "--shaker-random"], "--shaker-at"),
    ]
    for extra, message in refusals:
        assert main([*common, *extra]) == 2
        assert message in capsys.readouterr().err
    assert main([*base, "--shaker-at", "0.3,-0.5,0.2", "+y"]) == 2
    assert "--shaker-at: is a further shaker's: give the first with --shaker" in capsys.readouterr().err


def test_a_second_shakers_force_channel_of_zeros_is_named_as_such():
    """Two shakers ran and the second's force channel recorded zeros (a transducer not connected): the warning says
    that a second shaker's response then counts as noise in the first's frequency responses (not "no impact
    recorded", a hammer's words), and how to read a record where no second shaker ran."""
    rig, record = _rig(), _record("random")
    dead = replace(record, data=np.column_stack([record.data[:, :-1], np.zeros(len(record.time))]))
    warning = next(w for w in modal_data(rig.machine, dead, {}).warnings if w.kind == "no_hit")
    assert warning.channel == "F2"
    assert warning.message.startswith("the force channel is zero throughout beside the continuous excitation on F1")
    assert "counts as noise in F1's frequency responses; where none did, --ignore F2" in warning.message


def test_a_roving_hammers_two_force_channels_are_not_shakers():
    """Two force channels of hits (a roving hammer's runs in one record) are not several shakers at once: the first
    force's H1, the other named as not used (frf.at_once is for continuous forces only)."""
    rig = _rig()
    record = rig.simulate(paper_sensors(), 4.0, 400.0, [Hammer(*FIRST)], force_channel="F")
    two = replace(
        record,
        data=np.column_stack([record.data, np.roll(record.data[:, -1], 200)]),
        channels=(*record.channels, replace(record.channels[-1], name="G")),
    )
    assert frf.at_once(two) == ()
    assert (
        "1 force channel not used (G): the H1 frequency responses are of one input, F"
        in modal_data(rig.machine, two, {}).notes
    )


@settings(max_examples=budget(40), deadline=None)
@given(
    taps=st.integers(1, 60),
    forces=st.integers(1, 3),
    responses=st.integers(1, 3),
    seed=st.integers(0, 2**32 - 1),
    skew=st.floats(0.0, 0.3),
)
def test_block_levinson_solves_what_a_dense_solve_does(taps, forces, responses, seed, skew):
    """frf._block_levinson against numpy's dense solve of the block Toeplitz matrix it stands for: the correlations
    of random forces (a moving average of a common noise with each one's own, so that the forces correlate), made
    unsymmetric by ``skew`` as the normal equations of _random_inputs are (c_ab(d) of f' and f), any length, forces
    and right-hand sides; within 1e-9 of the solution's largest."""
    rng = np.random.default_rng(seed)
    n = 20 * taps + 200
    common = rng.standard_normal(n + 2 * taps)
    f = np.column_stack([np.convolve(common, rng.uniform(-1, 1, 3), "same") for _ in range(forces)])
    f += rng.standard_normal((n + 2 * taps, forces))

    def correlation(d: int) -> np.ndarray:
        return f[taps : taps + n].T @ f[taps + d : taps + d + n] / n

    column = np.array([correlation(d) for d in range(taps)])
    row = np.array([correlation(-d) for d in range(taps)])
    column[1:] += skew * rng.standard_normal(column[1:].shape) / np.sqrt(taps)
    dense = np.block([[column[k - j] if k >= j else row[j - k] for j in range(taps)] for k in range(taps)])
    rhs = rng.standard_normal((taps, forces, responses))
    expected = np.linalg.solve(dense, rhs.reshape(taps * forces, responses)).reshape(taps, forces, responses)
    solved = frf._block_levinson(column, row, rhs)
    assert np.abs(solved - expected).max() <= 1e-9 * np.abs(expected).max()


def test_a_files_inputs_measured_at_once_give_each_mode_from_one(tmp_path, capsys):
    """Several shakers' frequency responses written to a UFF file (--frf-out: uff.write_frf) carry their multiple
    coherence (function type 26, once per response), which a bench's MIMO export carries too: read back, every
    input's run has it as its coherence and is marked as one measurement (Lines.together), also where the multiple
    coherence names the first input as its reference. Each mode then comes from one input, as from the record
    itself (the same frequencies and deviations to the file's 12 digits), not from a weighted mean of runs that
    share their samples (which gave deviations below either run's); a campaign of the file likewise. Such inputs
    beside another's estimate in one file are an error naming --frf-out."""
    from mountid.identification.combination import every_decay
    from mountid.measurement.records import named_runs
    from mountid.measurement.uff import read_uff_runs, write_frf

    rig, record = _rig(), _record("random")
    estimates = frf.several_inputs(record, ("F1", "F2"))
    forces = [next(c for c in record.channels if c.name == e.force) for e in estimates]
    path = tmp_path / "mimo.uff"
    write_frf(list(zip(estimates, forces, strict=True)), path)
    types = [int(s["func_type"]) for s in pyuff.UFF(str(path)).read_sets()]
    assert types.count(26) == len(record.responses) and types.count(4) == 2 * len(record.responses)
    runs = read_uff_runs(path)
    assert len(runs) == 2 and runs[0].impulse.together == runs[1].impulse.together != ""
    for run in runs:
        for (name, coherence), channel in zip(run.impulse.coherence, record.responses, strict=True):
            assert name == channel
            j = record.responses.index(name)
            np.testing.assert_allclose(coherence, estimates[0].coherence[:, j], atol=1e-10)
    own = modal_data(rig.machine, record, {})
    found = every_decay(rig.machine, named_runs(path, "mimo.uff"), {})
    alone = [modal_data(rig.machine, run, {}) for run in runs]
    assert list(found.modes) == list(own.modes)
    for label, mode in found.modes.items():
        assert mode.frequency == pytest.approx(own.modes[label].frequency, rel=1e-9), label
        assert mode.frequency_std == pytest.approx(own.modes[label].frequency_std, rel=1e-6), label
        assert any(mode.frequency_std == a.modes[label].frequency_std for a in alone if label in a.modes), label
    assert any("at once (its multiple coherence): each mode from the input" in note for note in found.notes)
    assert not any("weighted means" in note for note in found.notes)
    first = pyuff.UFF(str(path)).read_sets()
    for s in first:
        if int(s["func_type"]) == 26:
            s.update(func_type=6, ref_node=1001, ref_dir=int(s["rsp_dir"]))  # written as 6, typed 26 again below
    bench = tmp_path / "bench.uff"
    pyuff.UFF(str(bench)).write_sets(first, mode="add")
    uff._typed_multiple(bench)
    assert [r.impulse.together != "" for r in read_uff_runs(bench)] == [True, True]
    campaign = tmp_path / "campaign.json"
    campaign.write_text(json.dumps({"name": "mimo", "machine": "kid300", "known": TABLE_1, "records": ["mimo.uff"]}))
    assert main(["diagnose", str(campaign)]) == 0
    out = capsys.readouterr().out
    assert "each mode from the input whose frequency responses show it most strongly" in out
    assert "weighted means" not in out
    with pytest.raises(InputError, match="^--frf-out: the frequency responses of several shakers at once"):
        write_frf([*zip(estimates, forces, strict=True), (frf.of_record(record), forces[0])], tmp_path / "x.uff")
