"""mountid.identification.frequency_fit: the unknowns fitted to more measured frequencies than unknowns, against
an independent scipy fit of the generated forward map, a Monte Carlo of its standard deviations, round trips
from exact frequencies, and the command line's output and errors."""

from __future__ import annotations

import json
import shlex
from pathlib import Path

import numpy as np
import pytest
import scipy.optimize
import scipy.stats
from conftest import budget, log_uniform
from hypothesis import given, settings
from hypothesis import strategies as st

from mountid.cli import main
from mountid.errors import InputError
from mountid.generated import kid300
from mountid.identification.frequency_fit import fit_frequencies
from mountid.machine import Machine
from mountid.validation.paper import MEASURED, TABLE_1

STD = {label: 0.45 for label in MEASURED}
"""0.45 rad/s on each of the paper's four measured frequencies."""


def _independent_fit(measured: dict[str, float], std: dict[str, float]) -> np.ndarray:
    """c_xy, c_z minimising sum(((omega_model - omega) / std)^2) with kid300.frequencies and scipy's own
    finite differences, from the description's nominal stiffnesses."""
    idx = [kid300.MODES.index(label) for label in measured]
    omega = np.array(list(measured.values()))
    sigma = np.array([std[label] for label in measured])

    def residual(log_c):
        c_xy, c_z = np.exp(log_c)
        return (kid300.frequencies(**TABLE_1, c_xy=c_xy, c_z=c_z)[idx] - omega) / sigma

    start = np.log([kid300.PARAMETERS["c_xy"]["value"], kid300.PARAMETERS["c_z"]["value"]])
    return np.exp(scipy.optimize.least_squares(residual, start, xtol=1e-15, ftol=1e-15, gtol=1e-15).x)


def test_the_papers_four_frequencies_fit_as_an_independent_least_squares_does():
    fit = fit_frequencies(Machine.resolve("kid300"), TABLE_1, MEASURED, STD)
    c_xy, c_z = _independent_fit(MEASURED, STD)
    assert fit.parameters["c_xy"] == pytest.approx(c_xy, rel=1e-7)
    assert fit.parameters["c_z"] == pytest.approx(c_z, rel=1e-7)
    assert fit.dof == 2
    model = kid300.frequencies(**TABLE_1, c_xy=c_xy, c_z=c_z)
    chi2 = sum(((model[kid300.MODES.index(k)] - w) / STD[k]) ** 2 for k, w in MEASURED.items())
    assert fit.chi2 == pytest.approx(chi2, rel=1e-6)
    assert fit.p_value == pytest.approx(scipy.stats.chi2.sf(chi2, 2), rel=1e-6)
    assert 0.01 < fit.p_value < 0.99  # the paper's frequencies fit within 0.45 rad/s


def test_the_standard_deviations_match_a_monte_carlo_of_the_fit():
    """The frequencies scattered by their standard deviation around the fitted model's: the spread of the
    refitted unknowns against the stated std (chi^2 of the paper's data is below its dof, so no inflation)."""
    machine = Machine.resolve("kid300")
    fit = fit_frequencies(machine, TABLE_1, MEASURED, STD)
    rng = np.random.default_rng(7)
    draws = []
    for _ in range(200):
        noisy = {k: w + STD[k] * rng.standard_normal() for k, w in fit.fitted.items()}
        draws.append(list(fit_frequencies(machine, TABLE_1, noisy, STD).parameters.values()))
    spread = np.std(draws, axis=0)
    for k, u in enumerate(("c_xy", "c_z")):
        assert fit.std[u] == pytest.approx(spread[k], rel=0.15)


@settings(max_examples=budget(10))
@given(
    c_xy=log_uniform(2e4, 3e5),
    c_z=log_uniform(1e5, 2e6),
    labels=st.sampled_from([("x", "z", "psi"), ("x", "psi", "phi"), ("z", "psi", "phi"), ("x", "z", "psi", "phi")]),
)
def test_exact_frequencies_give_back_the_stiffnesses(c_xy, c_z, labels):
    omega = kid300.frequencies(**TABLE_1, c_xy=c_xy, c_z=c_z)
    measured = {label: float(omega[kid300.MODES.index(label)]) for label in labels}
    fit = fit_frequencies(Machine.resolve("kid300"), TABLE_1, measured, dict.fromkeys(labels, 0.01))
    assert fit.parameters["c_xy"] == pytest.approx(c_xy, rel=1e-7)
    assert fit.parameters["c_z"] == pytest.approx(c_z, rel=1e-7)
    assert fit.chi2 < 1e-6


@settings(max_examples=budget(10), deadline=None)
@given(scale=st.tuples(*[log_uniform(0.3, 3.0)] * 4))
def test_genset8s_six_frequencies_give_back_its_four_stiffnesses(scale):
    """A machine with a ROOT_RULE-free description and isolator groups whose inverses are numeric: exact
    frequencies of all six modes return the stiffnesses, and no unknown is taken for one that ran off."""
    machine = Machine.resolve("genset8")
    truth = {u: machine.module.PARAMETERS[u]["value"] * f for u, f in zip(machine.unknown, scale, strict=True)}
    measured = machine.frequencies(truth)
    fit = fit_frequencies(machine, {}, measured)
    for u, c in truth.items():
        assert fit.parameters[u] == pytest.approx(c, rel=1e-6)


def test_frequencies_no_mount_fits_are_an_error_naming_the_stiffness_that_ran_off(capsys):
    """Six made-up frequencies for genset8: the closest fit takes c_v2 to zero (it left three starts tied at
    c_v2 = 1e-72 .. 1e-86, reported as three equal solutions): one line naming the stiffness and the miss."""
    args = ["identify", "genset8", "--measured", "x=10", "y=12", "z=20", "psi=25", "theta=30", "phi=35"]
    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert "error: --measured: no mount of this description fits" in err and "c_v2 to zero" in err
    assert "misses phi by 26.4%" in err


def test_a_scatter_beyond_any_measurement_is_noted_as_a_model_or_labelling_gap():
    """Without standard deviations the fit takes its uncertainty from the scatter: the paper's four frequencies
    (0.61 % RMS) pass without a note, phi mistyped as 360.91 rad/s (88 % off the fit) is named as no noise."""
    machine = Machine.resolve("kid300")
    paper = fit_frequencies(machine, TABLE_1, MEASURED)
    assert paper.rms_scatter == pytest.approx(0.0061, abs=5e-4)
    assert not any("scatter" in note for note in paper.notes)
    wrong = fit_frequencies(machine, TABLE_1, {**MEASURED, "phi": 360.91})
    assert wrong.rms_scatter > 0.4
    (note,) = [note for note in wrong.notes if "scatter" in note]
    assert "largest phi, -88.3 %" in note and "not noise" in note
    assert not any("scatter" in n for n in fit_frequencies(machine, TABLE_1, {**MEASURED, "phi": 360.91}, STD).notes)


def test_an_exactly_determined_set_is_not_a_least_squares_fit():
    with pytest.raises(InputError, match="2 distinct frequencies for 2 unknowns"):
        fit_frequencies(Machine.resolve("kid300"), TABLE_1, {"x": 17.71, "psi": 64.10})


def test_the_command_line_reports_the_fit_its_residuals_and_its_goodness(capsys):
    args = ["identify", "kid300", "--measured", *(f"{k}={w}" for k, w in MEASURED.items())]
    args += ["--std", *(f"{k}=0.45" for k in MEASURED)]
    assert main(args) == 0
    out = capsys.readouterr().out
    assert "least-squares fit of c_xy, c_z to 4 measured frequencies (2 degrees of freedom)" in out
    assert "chi^2 = 2.14 on 2 degrees of freedom (p = 0.34): the model fits the frequencies within" in out
    assert main([*args, "--json"]) == 0
    fit = json.loads(capsys.readouterr().out)["fit"]
    assert set(fit) == {"parameters", "parameter_std", "frequencies", "dof", "chi2", "p_value", "notes"}
    assert fit["parameters"]["c_z"] == pytest.approx(_independent_fit(MEASURED, STD)[1], rel=1e-7)
    # without standard deviations: the spread of the frequencies about the fit instead of a chi^2
    assert main(args[: args.index("--std")]) == 0
    assert "no --std given" in capsys.readouterr().out


def test_one_degree_of_freedom_is_said_in_the_singular(capsys):
    three = {k: MEASURED[k] for k in list(MEASURED)[:3]}
    args = ["identify", "kid300", "--measured", *(f"{k}={w}" for k, w in three.items())]
    assert main([*args, "--std", *(f"{k}=0.45" for k in three)]) == 0
    out = capsys.readouterr().out
    assert "to 3 measured frequencies (1 degree of freedom)" in out
    assert " on 1 degree of freedom (p = " in out


@pytest.mark.parametrize(
    ("extra", "named"),
    [
        (["--std", "x=0.45", "psi=0.45", "phi=0.45"], "--std z:"),
        (["--std", "x=0.45", "z=0.45", "psi=0.45", "phi=0"], "--std phi:"),
        (["--set", "c_xy=7e4"], "--set c_xy:"),
        (["--root", "c_q>c_xy"], "--root:"),  # not a rule, though no tie needs one here
    ],
)
def test_bad_input_to_the_fit_is_one_line_naming_the_parameter(capsys, extra, named):
    args = ["identify", "kid300", "--measured", *(f"{k}={w}" for k, w in MEASURED.items()), *extra]
    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and f"error: {named}" in err


def test_the_readme_transcript_is_what_the_command_prints(capsys):
    """The README's least-squares `mountid identify` transcript, line by line."""
    lines = Path("README.md").read_text(encoding="utf-8").splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("    $ mountid identify kid300 --measured x="))
    shown = []
    for line in lines[start + 1 :]:
        if not line.startswith("    "):
            break
        shown.append(line[4:])
    assert main(shlex.split(lines[start][len("    $ mountid ") :])) == 0
    printed = capsys.readouterr().out.splitlines()
    assert printed[: len(shown)] == shown


def test_a_root_rule_is_for_least_squares_fits_only(capsys):
    """With exactly as many frequencies as unknowns every admissible root is listed: --root is an error there."""
    assert main(["identify", "kid300", "--measured", "x=17.71", "psi=64.1", "--root", "c_z>c_xy"]) == 2
    assert "error: --root:" in capsys.readouterr().err


def test_a_third_frequency_decides_before_any_root_rule():
    """Two frequencies of kid300's x, psi and a third from one of the two exact solutions of (x, psi): the two
    solutions would tie for (x, psi) alone; the third frequency decides, so neither rule is consulted. Each
    exact solution's own third frequency returns that solution, whatever the rule, and no note names a rule.
    (A tie that a rule breaks is tested through identify-record, test_bench_records.)"""
    machine = Machine.resolve("kid300")
    roots = kid300.identify_x_psi(**TABLE_1, omega_x=17.71, omega_psi=64.10)
    for k in np.flatnonzero(roots.admissible):
        c = {u: float(roots.parameters[u][k]) for u in ("c_xy", "c_z")}
        z = float(kid300.frequencies(**TABLE_1, **c)[kid300.MODES.index("z")])
        for rule in ("c_z>c_xy", "c_z<c_xy"):
            fit = fit_frequencies(machine, TABLE_1, {"x": 17.71, "psi": 64.10, "z": z}, root=rule)
            assert fit.parameters["c_z"] == pytest.approx(c["c_z"], rel=1e-6)
            assert fit.notes == ()


def test_a_fit_whose_model_leaves_double_precision_is_an_error_not_a_traceback(monkeypatch):
    """scipy stops on a non-finite residual with a ValueError: a start whose model frequencies are not finite
    is dropped, and with none left the error names the measured frequencies."""
    machine = Machine.resolve("kid300")
    finite = kid300.frequencies
    monkeypatch.setattr(kid300, "frequencies", lambda **v: finite(**v) * np.nan)
    with pytest.raises(InputError, match="^measured: every fit .* left the range of double precision"):
        fit_frequencies(machine, TABLE_1, MEASURED, STD)


def test_residuals_of_millions_of_sigma_keep_their_column(capsys):
    """Standard deviations of 1e-9 rad/s put the residuals at 1e6-1e8 sigma: printed in three significant digits
    (they printed as -9543866.99, wider than the column)."""
    args = ["identify", "kid300", "--measured", *(f"{k}={w}" for k, w in MEASURED.items())]
    assert main([*args, "--std", *(f"{k}=1e-9" for k in MEASURED)]) == 0
    out = capsys.readouterr().out
    assert "`mountid diagnose`" in out  # chi^2 beyond the uncertainty points to the gap diagnosis
    rows = out.splitlines()[3:7]
    assert all(len(row) <= len("         x       17.71      17.719     +0.05%    +0.02") + 1 for row in rows)
    assert all("e+0" in row.split()[-1] for row in rows)


def test_standard_deviations_beyond_first_order_are_noted(capsys):
    """A standard deviation of half the value or more is first order out of its depth: a note names the unknown,
    in the exactly determined and the least-squares output; the paper's 0.45 rad/s gets none."""
    exact = ["identify", "kid300", "--measured", "x=17.71", "psi=64.1", "--std"]
    assert main([*exact, "x=100", "psi=0.4"]) == 0
    assert "note: the standard deviations of c_xy, c_z are half their values or more" in capsys.readouterr().out
    fit = ["identify", "kid300", "--measured", *(f"{k}={w}" for k, w in MEASURED.items()), "--std"]
    assert main([*fit, "x=30", "z=0.3", "psi=30", "phi=30"]) == 0
    out = capsys.readouterr().out
    assert "  note: the standard deviation of c_xy is half its value or more" in out
    for argv in ([*exact, "x=0.45", "psi=0.45"], [*fit, *(f"{k}=0.45" for k in MEASURED)]):
        assert main(argv) == 0
        out = capsys.readouterr().out
        assert "first order does not hold" not in out and "mountid diagnose" not in out


@settings(max_examples=60)
@given(
    points=st.lists(
        st.tuples(st.integers(0, 3), st.integers(0, 2), st.floats(-0.2, 0.2), st.floats(0.0, 10.0)),
        min_size=1,
        max_size=30,
    )
)
def test_starting_points_are_thinned_as_the_rule_says(points):
    """from_records._distinct_starts against its definition: in order of chi^2 (ties by position), a root is kept
    unless it lies within START_SPACING (in every ln unknown) of a root kept before from another subset. Roots
    drawn around a few centres with offsets on both sides of the spacing, from four subsets."""
    from mountid.identification import from_records

    centres = np.log([[1.0, 2.0], [1.5, 2.0], [1.0, 9.0]])
    roots = [((f"s{subset}",), centres[c] + np.array([offset, -offset / 2])) for subset, c, offset, _ in points]
    chi2 = {id(start): cost for (_, start), (*_, cost) in zip(roots, points, strict=True)}
    expected: list[tuple[tuple[str, ...], np.ndarray]] = []
    for i in sorted(range(len(roots)), key=lambda i: (points[i][3], i)):
        key, start = roots[i]
        if not any(k != key and np.max(np.abs(start - s)) < from_records.START_SPACING for k, s in expected):
            expected.append(roots[i])

    def residual(start):
        return np.array([np.sqrt(chi2[id(start)])])

    got = from_records._distinct_starts(roots, residual)
    assert [id(s) for s in got] == [id(s) for _, s in expected]


def test_close_roots_of_one_inverse_are_both_fitted():
    """An exactly determined set whose two admissible roots lie within START_SPACING of each other (kid300's x
    and psi just above the frequency where the two roots meet) still lists both: the roots of one inverse are
    distinct solutions, never thinned."""
    from mountid.identification import from_records

    machine = Machine.resolve("kid300")
    psi = np.linspace(46.0, 46.2, 2001)
    roots = kid300.identify_x_psi(**TABLE_1, omega_x=17.71, omega_psi=psi)
    ln = np.log(np.stack([roots.parameters[u] for u in ("c_xy", "c_z")], axis=-1))
    apart = np.max(np.abs(ln[0] - ln[1]), axis=-1)
    close = np.flatnonzero(roots.admissible.all(axis=0) & (apart < from_records.START_SPACING / 2))
    assert close.size
    with pytest.raises(InputError, match="2 solutions fit equally"):
        from_records.fit_stiffness(machine, TABLE_1, {"x": (17.71, 1e-5), "psi": (float(psi[close[-1]]), 1e-5)})
