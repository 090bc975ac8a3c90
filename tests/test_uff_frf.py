"""A bench's frequency response functions in a UFF file (datasets 58 of function type 4): read as the impulse
responses they transform back to (mountid.measurement.uff, Record.impulse), against the rig's impulse response
from its state-space solution; through the records chain and the command line to the rig's poles; a roving
hammer's inputs as runs; units; files mountid does not read named."""

from __future__ import annotations

import json

import numpy as np
import pytest
import pyuff
import scipy.linalg

from mountid.cli import main
from mountid.errors import InputError
from mountid.measurement.records import Channel
from mountid.measurement.rig import Rig
from mountid.measurement.uff import dataset_58, placement, read_uff, read_uff_runs
from mountid.validation.paper import PUBLISHED_STIFFNESS, TABLE_1, TRUE_DAMPING, paper_hit, paper_sensors

SPACING, TOP = 1 / 8, 50.0
"""The lines [Hz]: 0 to TOP by SPACING (an 8 s window)."""

HITS = ((0.35, 0.25, 0.3), (-0.35, 0.25, 0.3))
"""Two hammer points (a roving hammer's inputs), each hit along paper_hit's direction."""


def _rig() -> Rig:
    return Rig.of("kid300", {**TABLE_1, **PUBLISHED_STIFFNESS, **TRUE_DAMPING})


def _accelerance(rig: Rig, freq: np.ndarray, hit_point, sensor, window: float = 0.0) -> np.ndarray:
    """The exact acceleration per force [m/s^2 per N] of a sensor for a hit at ``hit_point`` (paper_hit's
    direction), at ``freq`` [Hz]; with an exponential window exp(-``window`` t) on the response, its transform:
    s^2 H(s) at s = i omega + ``window``."""
    s = 2j * np.pi * freq + window
    column = rig.force_column(hit_point, paper_hit().direction)
    stiffness = rig.C[None] + s[:, None, None] ** 2 * rig.M[None] + s[:, None, None] * rig.B[None]
    response = np.linalg.solve(stiffness, np.broadcast_to(column[:, None], (len(s), len(column), 1)))[..., 0]
    return s**2 * (response @ rig.sensor_row(sensor.point, sensor.direction))


def _dataset(sensor, node: int, reference: int, freq, values, unit: str = "m/s^2", per: str = "N") -> dict:
    """One frequency response function as pyuff's dataset 58 (complex, double precision ASCII)."""
    return pyuff.prepare_58(
        binary=0,
        id1=sensor.name,
        id2="FRF",
        id3="",
        id4=placement(sensor),
        id5="",
        func_type=4,
        rsp_node=node,
        rsp_dir=1,
        ref_node=reference,
        ref_dir=1,
        ord_data_type=6,
        num_pts=len(freq),
        abscissa_spacing=1,
        abscissa_min=float(freq[0]),
        abscissa_inc=SPACING,
        abscissa_spec_data_type=18,
        ordinate_spec_data_type=12,
        orddenom_spec_data_type=13,
        abscissa_axis_units_lab="Hz",
        ordinate_axis_units_lab=unit,
        orddenom_axis_units_lab=per,
        data=np.asarray(values, dtype=complex),
        x=np.asarray(freq, dtype=float),
    )


def _write(path, sets: list[dict]) -> None:
    pyuff.UFF(str(path)).write_sets(sets, mode="add")


def _frf_file(
    path, hits=HITS[:1], noise=0.0, first=0.0, unit="m/s^2", per="N", seed=0, top=TOP, labels=None, window=0.0
):
    """The paper sensors' accelerances for each hit (a run each), lines from ``first`` [Hz] to ``top``, with complex
    white noise of ``noise`` x the largest magnitude per line; ``unit`` and ``per`` the file's units (the values
    converted), written as the ordinate's and the denominator's labels unless ``labels`` gives those; ``window``
    [1/s] an exponential window on the responses."""
    from mountid.measurement.records import UNITS

    rig, rng, sets = _rig(), np.random.default_rng(seed), []
    freq = np.arange(first, top + SPACING / 2, SPACING)
    for r, hit in enumerate(hits):
        for k, sensor in enumerate(paper_sensors()):
            a = _accelerance(rig, freq, hit, sensor, window)
            a = a + noise * np.abs(a).max() * (rng.normal(size=len(a)) + 1j * rng.normal(size=len(a))) / np.sqrt(2)
            scaled = a / UNITS["acceleration"][unit] * UNITS["force"][per]
            sets.append(_dataset(sensor, k + 1, 100 + r, freq, scaled, *(labels or (unit, per))))
    _write(path, sets)


def _impulse_response(rig: Rig, t: np.ndarray, hit_point, sensor, period: float) -> np.ndarray:
    """The sensor's acceleration per unit impulse [m/s^2 per N s] at times 0 < ``t`` < ``period`` from the
    state-space solution (q(0) = 0, q'(0) = M^-1 f, q'' = -M^-1 (C q + B q')) summed over the impulses one
    ``period`` apart before it: lines ``1 / period`` apart are the transform of that periodic response (the sum
    (I - exp(A period))^-1 in closed form)."""
    n = rig.M.shape[0]
    m_inv = np.linalg.inv(rig.M)
    system = np.block([[np.zeros((n, n)), np.eye(n)], [-m_inv @ rig.C, -m_inv @ rig.B]])
    state0 = np.concatenate([np.zeros(n), m_inv @ rig.force_column(hit_point, paper_hit().direction)])
    state0 = np.linalg.solve(np.eye(2 * n) - scipy.linalg.expm(system * period), state0)
    row = rig.sensor_row(sensor.point, sensor.direction)
    return np.array([row @ (system @ scipy.linalg.expm(system * ti) @ state0)[n:] for ti in t])


def test_frequency_response_functions_are_read_as_their_impulse_responses(tmp_path):
    """Noise-free accelerances of the paper's sensors on lines 0-800 Hz by 1/8 Hz: the impulse responses read back
    agree with the rig's state-space impulse response, wrapped with the 8 s period lines 1/8 Hz apart give (the
    responses before add the same damped modes with other amplitudes: the poles and shapes stay), past the first
    second to 0.1 % of the response's peak there (what differs is the accelerance's tail above the last line, which
    the lines leave out: it falls as 1 / the last line, on A_z 1 % with lines to 50 Hz, 0.05 % to 800 Hz; unwrapped,
    the responses differ by 0.5 %); every channel placed as written; an 8 s window at 1600 Hz."""
    _frf_file(tmp_path / "frf.uff", top=800.0)
    record = read_uff(tmp_path / "frf.uff")
    assert record.impulse and record.rate == pytest.approx(1600.0) and len(record.time) == 12800
    assert [c.point for c in record.channels] == [s.point for s in paper_sensors()]
    rig = _rig()
    late = np.flatnonzero((record.time > 1.0) & (record.time < 6.0))[::80]
    for k, sensor in enumerate(paper_sensors()):
        exact = _impulse_response(rig, record.time[late], HITS[0], sensor, 1 / SPACING)
        assert np.max(np.abs(record.data[late, k] - exact)) < 1e-3 * np.max(np.abs(exact)), sensor.name


def test_lines_above_zero_and_other_units_read_alike(tmp_path):
    """A bench that exports lines from its first spacing (1/8 Hz, not 0) and in g per lbf gives the same impulse
    responses as lines from 0 in m/s^2 per N: the missing line is 0 for an accelerance, the units converted; so
    does one whose ordinate label names both units ("(g)/lbf", the denominator's label empty), and one whose lines
    are in rad/s."""
    _frf_file(tmp_path / "si.uff")
    _frf_file(tmp_path / "bench.uff", first=SPACING, unit="g", per="lbf")
    si, bench = read_uff(tmp_path / "si.uff"), read_uff(tmp_path / "bench.uff")
    assert [c.unit for c in bench.channels] == ["m/s^2"] * len(paper_sensors())
    np.testing.assert_allclose(bench.data, si.data, rtol=0, atol=1e-9 * np.abs(si.data).max())
    _frf_file(tmp_path / "labels.uff", unit="g", per="lbf", labels=("(g)/lbf", ""))
    np.testing.assert_allclose(read_uff(tmp_path / "labels.uff").data, si.data, atol=1e-9 * np.abs(si.data).max())
    sets = pyuff.UFF(str(tmp_path / "si.uff")).read_sets()
    radians = [
        _dataset(sensor, k + 1, 100, 2 * np.pi * d["x"], d["data"])
        for k, (sensor, d) in enumerate(zip(paper_sensors(), sets, strict=True))
    ]
    for d in radians:
        d.update(abscissa_axis_units_lab="rad/s", abscissa_inc=2 * np.pi * SPACING)
    _write(tmp_path / "radians.uff", radians)
    # the spacing in rad/s is written to six digits (UFF 58's E13.5): the rate, and every response with it, to 1e-6
    np.testing.assert_allclose(read_uff(tmp_path / "radians.uff").data, si.data, rtol=1e-6, atol=0)


def test_process_and_identify_record_give_the_rigs_poles(tmp_path, capsys):
    """Accelerances with 0.3 % noise per line through `process`: the four distinct modes within three of their
    standard deviations of the rig's poles, the note naming the lines and the window's damping; `identify-record`
    gives the paper's stiffnesses within 3 sigma; --start and --rate, which such a file cannot take, are named."""
    _frf_file(tmp_path / "frf.uff", noise=0.003)
    assert main(["process", "kid300", str(tmp_path / "frf.uff"), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    poles = _rig().poles
    for label, mode in out["modes"].items():
        nearest = float(np.min(np.abs(np.abs(poles) - mode["frequency"])))
        assert nearest < 3 * mode["frequency_std"], label
    assert set(out["modes"]) == {"x", "phi", "z", "psi"}
    assert any(n.startswith("modes from the impulse responses of 5 frequency response functions") for n in out["notes"])
    assert main(["identify-record", "kid300", str(tmp_path / "frf.uff"), "--json"]) == 0
    found = json.loads(capsys.readouterr().out)
    for name, value in PUBLISHED_STIFFNESS.items():
        assert abs(found["parameters"][name] - value) < 3 * found["parameter_std"][name], name
    assert main(["process", "kid300", str(tmp_path / "frf.uff"), "--start", "0.1"]) == 2
    assert "--start: impulse responses (frequency response functions) start at the hit" in capsys.readouterr().err
    assert main(["process", "kid300", str(tmp_path / "frf.uff"), "--rate", "100"]) == 2
    assert "--rate: frequency response functions: their lines give" in capsys.readouterr().err


def test_a_roving_hammers_inputs_are_runs(tmp_path, capsys):
    """A roving hammer's frequency response functions, one input (reference node) after the other: a run per
    input, combined per mode as runs are (a campaign of the file too)."""
    _frf_file(tmp_path / "roving.uff", hits=HITS, noise=0.003)
    runs = read_uff_runs(tmp_path / "roving.uff")
    assert len(runs) == 2 and all(r.impulse for r in runs)
    assert main(["process", "kid300", str(tmp_path / "roving.uff"), "--json"]) == 0
    notes = json.loads(capsys.readouterr().out)["notes"]
    assert any(n.startswith("x: frequency, damping ratio from ") and "run 2" in n for n in notes)
    (tmp_path / "c.json").write_text(json.dumps({"machine": "kid300", "records": ["roving.uff"]}), encoding="utf-8")
    assert main(["diagnose", str(tmp_path / "c.json"), "--json", "--no-figure"]) == 0
    assert json.loads(capsys.readouterr().out)["kind"] == "no significant gap"


def test_files_of_frequency_response_functions_mountid_does_not_read_are_named(tmp_path):
    """A time response among frequency response functions, lines not a whole number of spacings from 0, a
    magnitude without its phase, and a response per something other than a force are errors naming the
    channel."""
    rig, sensor = _rig(), paper_sensors()[0]
    freq = np.arange(0.0, TOP, SPACING)
    frf = _dataset(sensor, 1, 100, freq, _accelerance(rig, freq, HITS[0], sensor))
    time = dataset_58(Channel("T"), np.arange(len(freq)) / 100.0, np.ones(len(freq)), 2, 1, "")
    _write(tmp_path / "mixed.uff", [frf, time])
    with pytest.raises(InputError, match="^T: is a time response beside frequency response functions"):
        read_uff(tmp_path / "mixed.uff")
    spectrum = {**_dataset(paper_sensors()[1], 2, 100, freq, frf["data"]), "func_type": 9}
    _write(tmp_path / "spectrum.uff", [frf, spectrum])
    with pytest.raises(InputError, match="^A_y: is a power spectral density beside frequency response functions"):
        read_uff(tmp_path / "spectrum.uff")
    shifted = _dataset(sensor, 1, 100, freq + SPACING / 3, frf["data"])
    _write(tmp_path / "shifted.uff", [shifted])
    with pytest.raises(InputError, match=r"^A_x: frequency lines from 0\.0416667 Hz by 0\.125 Hz: mountid reads"):
        read_uff(tmp_path / "shifted.uff")
    magnitude = _dataset(sensor, 1, 100, freq, np.abs(frf["data"]))
    _write(tmp_path / "magnitude.uff", [magnitude])
    with pytest.raises(InputError, match="^A_x: holds real values only: a frequency response function is complex"):
        read_uff(tmp_path / "magnitude.uff")
    per_volt = _dataset(sensor, 1, 100, freq, frf["data"], per="V")
    _write(tmp_path / "volt.uff", [per_volt, _dataset(paper_sensors()[1], 2, 100, freq, frf["data"])])
    with pytest.raises(InputError, match="^A_x: functions per volt beside functions per force"):
        read_uff(tmp_path / "volt.uff")
    per_pascal = _dataset(sensor, 1, 100, freq, frf["data"], per="Pa")
    _write(tmp_path / "pascal.uff", [per_pascal])
    with pytest.raises(InputError, match="^A_x: is a response per 'Pa'"):
        read_uff(tmp_path / "pascal.uff")


def test_a_benchs_exponential_window_is_divided_out(tmp_path, capsys):
    """Accelerances of responses under an exponential window of 0.5 1/s (0.3 % noise): read as they are, every
    damping ratio is 0.5 / omega too high (x: 0.066 for 0.0375, the note says why); --exponential-window 0.5 (a
    campaign record's exponential_window) divides it out: every damping ratio within three standard deviations of
    the rig's. A record of a test, or a negative rate, is named."""
    _frf_file(tmp_path / "windowed.uff", noise=0.003, window=0.5)
    poles = _rig().poles

    def truth(omega: float) -> float:  # the damping ratio of the rig's pole nearest omega
        nearest = poles[int(np.argmin(np.abs(np.abs(poles) - omega)))]
        return float(-nearest.real / abs(nearest))

    def ratios(*options: str) -> dict:
        assert main(["process", "kid300", str(tmp_path / "windowed.uff"), "--json", *options]) == 0
        return json.loads(capsys.readouterr().out)

    biased = ratios()
    for mode in biased["modes"].values():
        expected = truth(mode["frequency"]) + 0.5 / mode["frequency"]
        assert mode["damping_ratio"] == pytest.approx(expected, rel=0.05)
    assert any("give it (--exponential-window" in n for n in biased["notes"])
    fixed = ratios("--exponential-window", "0.5")
    for mode in fixed["modes"].values():
        zeta = truth(mode["frequency"])
        assert abs(mode["damping_ratio"] - zeta) < 3 * mode["damping_std"]
    assert any("the bench's exponential window of 0.5 1/s divided out" in n for n in fixed["notes"])
    campaign = {"machine": "kid300", "records": [{"file": "windowed.uff", "exponential_window": 0.5}]}
    (tmp_path / "c.json").write_text(json.dumps(campaign), encoding="utf-8")
    assert main(["diagnose", str(tmp_path / "c.json"), "--json", "--no-figure"]) == 0
    assert json.loads(capsys.readouterr().out)["kind"] == "no significant gap"
    assert main(["process", "kid300", str(tmp_path / "windowed.uff"), "--exponential-window", "-1"]) == 2
    assert "--exponential-window: must be a finite rate >= 0 [1/s], got -1.0" in capsys.readouterr().err
    from mountid.measurement.records import write_csv

    write_csv(_rig().simulate(paper_sensors(), 4.0, 500.0, hammers=[paper_hit()]), tmp_path / "hit.csv")
    assert main(["process", "kid300", str(tmp_path / "hit.csv"), "--exponential-window", "0.5"]) == 2
    assert "--exponential-window: applies to frequency response functions" in capsys.readouterr().err


def test_coherences_beside_the_functions_name_a_mode_of_low_coherence(tmp_path, capsys):
    """A file of the functions and, after them, a coherence of each (function type 6): the impulse responses are
    those of the functions alone, each coherence goes with its response's channel, and a mode whose coherence is
    below 0.8 on every channel (0.5 about the lowest, x, at 2.8 Hz; 1 elsewhere) is named (low_coherence), the
    others not."""
    _frf_file(tmp_path / "alone.uff")
    sets = pyuff.UFF(str(tmp_path / "alone.uff")).read_sets()
    freq = np.asarray(sets[0]["x"])
    values = np.where((freq > 2.5) & (freq < 3.2), 0.5, 1.0)
    coherences = []
    for k, sensor in enumerate(paper_sensors()):
        coherence = _dataset(sensor, k + 1, 100, freq, values)
        coherence.update(
            func_type=6, ord_data_type=4, data=values, ordinate_spec_data_type=0, orddenom_spec_data_type=0
        )
        coherences.append(coherence)
    frfs = [
        _dataset(s, k + 1, 100, freq, d["data"]) for k, (s, d) in enumerate(zip(paper_sensors(), sets, strict=True))
    ]
    _write(tmp_path / "both.uff", frfs + coherences)
    both, alone = read_uff(tmp_path / "both.uff"), read_uff(tmp_path / "alone.uff")
    np.testing.assert_array_equal(both.data, alone.data)
    assert [name for name, _ in both.impulse.coherence] == [s.name for s in paper_sensors()]
    assert main(["process", "kid300", str(tmp_path / "both.uff"), "--json"]) == 0
    warned = [w for w in json.loads(capsys.readouterr().out)["warnings"] if w["kind"] == "low_coherence"]
    assert len(warned) == 1 and warned[0]["message"].startswith("mode x at 17.7")
    assert "coherence 0.50 at most over the bench's averages" in warned[0]["message"]


def test_units_spelled_as_other_exporters_spell_them_are_read(tmp_path):
    """An ordinate labelled "m/s**2" over a denominator labelled "Newtons" (records.UNIT_NAMES): the same impulse
    responses as "m/s^2" over "N" (they were 'unit ... is not' and 'a response per 'Newtons'')."""
    _frf_file(tmp_path / "si.uff")
    _frf_file(tmp_path / "named.uff", labels=("m/s**2", "Newtons"))
    np.testing.assert_array_equal(read_uff(tmp_path / "named.uff").data, read_uff(tmp_path / "si.uff").data)


def _hammer_record(hits: int = 3):
    """kid300 hit ``hits`` times 3 s apart at 1 kHz with its force recorded (the responses have not died out before
    the next hit: H1 puts an exponential window on them)."""
    from mountid.measurement.rig import Hammer

    hit = paper_hit()
    hammers = [Hammer(hit.point, hit.direction, hit.peak, hit.duration, 0.05 + 3.0 * k) for k in range(hits)]
    return _rig().simulate(paper_sensors(), 3.0 * hits, 1000.0, hammers=hammers, force_channel="F")


def test_written_frequency_responses_read_back_as_estimated(tmp_path):
    """uff.write_frf of a hammer test's H1 (three hits, an exponential window on the responses) and of a shaker's
    periodic excitation: read back, the functions and their coherences are those estimated (to the file's 12
    digits), each channel at its point along its direction; the modes from the file (the hammer's window divided out
    with the rate the file states) are the record's own: to 1e-9 where the record's segment has an even number of
    samples (the shaker's periods), within 0.05 of their standard deviations where it has an odd number (the
    hammer's 2957: no line at its Nyquist frequency, so read back its impulse responses are one sample shorter and
    sampled 1/2957 slower; 0.02 seen)."""
    from mountid.identification.from_records import modal_data
    from mountid.measurement import frf
    from mountid.measurement.records import without_window
    from mountid.measurement.rig import Shaker
    from mountid.measurement.uff import write_frf

    shaker = Shaker((0.35, 0.25, 0.3), (0.5, 0.6, -0.62), high=40.0, period=16.0)
    tests = {
        "hammer": _hammer_record(),
        "shaker": _rig().simulate(paper_sensors(), 64.0, 200.0, shakers=[shaker], force_channel="F"),
    }
    for kind, record in tests.items():
        estimate = frf.of_record(record)
        path = tmp_path / f"{kind}.uff"
        write_frf([(estimate, record.channels[-1])], path)
        sets = pyuff.UFF(str(path)).read_sets()
        functions = [s for s in sets if s["func_type"] == 4]
        assert [s["id1"] for s in functions] == [c.name for c in estimate.responses]
        for k, s in enumerate(functions):
            assert np.allclose(s["data"], estimate.h1[:, k], rtol=0, atol=1e-11 * np.max(np.abs(estimate.h1[:, k])))
        read = read_uff(path)
        assert [(c.name, c.point, c.direction) for c in read.channels] == [
            (c.name, c.point, c.direction) for c in estimate.responses
        ]
        for name, coherence in read.impulse.coherence:
            k = [c.name for c in estimate.responses].index(name)
            assert np.allclose(coherence[: len(estimate.omega)], estimate.coherence[:, k], rtol=0, atol=1e-11)
        stated = functions[0]["id3"]
        if estimate.window_decay:
            assert stated.endswith(f"; exponential window {estimate.window_decay:.9g} 1/s")
            read = without_window(read, float(stated.rsplit(" ", 2)[1]))
        else:
            assert "window" not in stated
        own, back = modal_data(_rig().machine, record, {}), modal_data(_rig().machine, read, {})
        assert set(own.modes) == set(back.modes) == {"x", "phi", "z", "psi"}, kind
        odd = round(estimate.length * estimate.rate) % 2 == 1  # no line at the Nyquist frequency
        assert odd == (kind == "hammer")
        for label, mode in own.modes.items():
            read_mode = back.modes[label]
            if odd:
                within = (0.05 * mode.frequency_std, 0.05 * mode.damping_std)
            else:
                within = (1e-9 * mode.frequency, 1e-9 * mode.damping_ratio)
            assert abs(read_mode.frequency - mode.frequency) < within[0], (kind, label)
            assert abs(read_mode.damping_ratio - mode.damping_ratio) < within[1], (kind, label)


def test_frf_out_writes_the_records_frequency_responses(tmp_path, capsys):
    """`identify-record --frf-out` and `process --frf-out` write the record's H1 and say how to read it back; a record
    without a force channel, a file of frequency response functions and a file name of another kind are errors
    naming the option."""
    from mountid.measurement.records import write_csv

    write_csv(_hammer_record(), tmp_path / "hits.csv")
    out = tmp_path / "h1.uff"
    assert main(["identify-record", "kid300", str(tmp_path / "hits.csv"), "--frf-out", str(out), "--json"]) == 0
    [note] = [n for n in json.loads(capsys.readouterr().out)["notes"] if n.startswith("wrote ")]
    assert note.startswith(f"wrote {out}: 5 frequency response functions per run, 1 run; the responses carry an ")
    window = note.rsplit(" ", 1)[1]
    assert main(["process", "kid300", str(out), "--exponential-window", window, "--json"]) == 0
    assert sorted(json.loads(capsys.readouterr().out)["modes"]) == ["phi", "psi", "x", "z"]
    free = _rig().simulate(paper_sensors(), 4.0, 1000.0, hammers=[paper_hit()])
    write_csv(free, tmp_path / "free.csv")
    for record, target, message in (
        ("free.csv", "x.uff", f"--frf-out: {tmp_path / 'free.csv'}: record: has no force channel"),
        ("h1.uff", "x.uff", f"--frf-out: {tmp_path / 'h1.uff'}: record: holds frequency response functions already"),
        ("hits.csv", "x.csv", "--frf-out: x.csv: name a file ending in .uff or .unv (UFF)"),
    ):
        assert main(["process", "kid300", str(tmp_path / record), "--frf-out", str(tmp_path / target)]) == 2
        err = capsys.readouterr().err
        assert err.startswith(f"mountid: error: {message}") and len(err.strip().splitlines()) == 1, err
