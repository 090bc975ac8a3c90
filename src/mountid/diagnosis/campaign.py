"""Measurement campaigns: a machine, known values, measured modal data, and what is fitted vs held out.

The format is JSON, described by ``mountid/schemas/campaign.schema.json`` (validated with jsonschema; every
violation is reported as one line naming the entry). Example (the paper's four frequencies)::

    {"name": "KID-300, reference paper",
     "machine": "kid300",
     "known": {"m": 838.6, "J_xy": 61.44, "J_z": 51.52, "L_xy": 0.486, "L_z": 0.3},
     "modes": {"x": {"frequency": 17.71}, "psi": {"frequency": 64.10},
               "z": {"frequency": 46.60}, "phi": {"frequency": 36.91}},
     "fit": ["x", "psi"]}

A campaign may list impact records instead of (or beside) the modal data: ``"records": ["hit1.csv",
{"file": "hit2.uff", "start": 0.1}]``; an entry may also give the sampling ``rate`` [Hz], the ``channels``' points
and directions (a plain CSV states none; or a ``channel_table``, measurement.channel_table), the ``sensitivity`` of
channels recorded in volts ("100mV/g"), the channels to ``ignore`` (a tachometer, a microphone) and the ``run`` of a
UFF file of several (without one, each run is a record of its own). Each is read (CSV with mountid channel metadata,
UFF with its geometry, TDMS or LVM) and run through the records chain (identification.from_records.modal_data):
frequencies with their standard deviations, damping ratios and, where the channels span the six motions, mode
shapes.
A mode given under "modes" overrides the records'; a mode several records give has the weighted means of
their frequencies and damping ratios (the standard deviations widened where the records scatter beyond them)
and the shape of the one with the smallest frequency standard deviation. The records' poles are converted to
undamped frequencies, their channel layout becomes the campaign's sensors where every shape came from one
layout, and their quality warnings travel with the campaign.

A campaign may give the frequencies of its modes again at other excitation levels (a hit at half the force):
``"levels": [{"name": "hit at half the force", "modes": {"z": {"frequency": 46.1, "uncertainty": 0.02}}}]``,
in the convention of its ``modes``, or through records at that level (``"records": ["soft1.csv"]``, converted to
undamped frequencies and compared with the campaign's undamped ones, as the campaign's records are). A linear
model predicts the same frequencies at every level: the diagnosis tests whether they move beyond what a change of
the isolators' stiffness alone makes of them (mountid.diagnosis.levels), an amplitude dependence no effect of
the catalogue represents.

The fits start from the unknowns' nominal values: the campaign's ``"nominal": {"c_xy": 6e4}``, else the
description's, else (or with ``"nominal": "identified"``) the identification on the measured frequencies
(_nominal_from_modes).
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import dataclass, field, replace
from importlib import resources
from pathlib import Path

import jsonschema
import numpy as np

from mountid.diagnosis.levels import LEVEL_RATIO_LIMIT, DampingShift, LevelTest, level_shift
from mountid.errors import InputError, NoModeFound, existing_file
from mountid.identification.combination import RECORDS_DISAGREE, at_once, combine, decays_of
from mountid.identification.from_records import ModalData
from mountid.identification.labelling import LABELLING, same_modes
from mountid.machine import Machine, sensor_row, unit_vector
from mountid.measurement.modal import QualityWarning
from mountid.measurement.modes import DEFAULT_FREQUENCY_STD, MeasuredMode, default_damping_std, scaled_unit
from mountid.measurement.records import Channel, Record
from mountid.nomenclature import FREQUENCY_UNITS, POSITIVE_KINDS, axis_direction, counted, distinct_frequencies


def schema() -> dict:
    """The campaign JSON Schema."""
    return json.loads(resources.files("mountid.schemas").joinpath("campaign.schema.json").read_text("utf-8"))


DEFAULT_SHAPE_STD = 0.02
"""Standard deviation per component of a unit-length scaled mode shape given without shape_uncertainty."""


def record_shape_std(noise: float | None) -> float:
    """Standard deviation per component of a shape from a record: the noise's (the records chain's estimate,
    MeasuredMode.shape_std; None where it gives none) and DEFAULT_SHAPE_STD in quadrature. The default stands
    for what a record does not show, the sensors' placement and calibration: a clean record's shape is not
    known better than a campaign's shape given without uncertainty, a noisy one's is known worse."""
    return DEFAULT_SHAPE_STD if noise is None else math.hypot(noise, DEFAULT_SHAPE_STD)


def damping_std(mode: MeasuredMode) -> float:
    """Standard deviation of a measured damping ratio: as stated, else DEFAULT_DAMPING_STD of it (at least
    DAMPING_STD_FLOOR: modes.default_damping_std)."""
    return mode.damping_std or default_damping_std(mode.damping_ratio)


RESOLUTION = 1e-9
"""The smallest uncertainty a campaign may state: relative to the frequency for a frequency, absolute for a damping
ratio and for each component of a unit-length shape. Below it the fits would weigh the double-precision model's own
rounding (eigenvalues to 1e-12 - 1e-11 relative where twins or far-apart modes condition them) as a sizable part of
a standard deviation, and chi^2 would measure rounding (at 1e-12 the report's held-out predictions were nan; at
1e-300 a traceback)."""

SCALE_LIMIT = 1e4
"""How far (a factor either way) a measured frequency may lie outside the frequencies of the description at its
nominal values with the campaign's known ones, and a known value from the description's nominal value. The fits
reach a factor 100 in frequency (unknowns within candidate_model.UNKNOWN_RANGE, 1e4 in stiffness); beyond this
the value is another machine, another unit or a typing error, and the model's products leave double precision
(a frequency of 1e200 rad/s or a damping of 1e300 N s/m overflowed where a traceback was the answer)."""


@dataclass(frozen=True)
class RecordSource:
    """A record file of a campaign and where its free decay starts [s] (None: after the impact the record shows,
    measurement.modal.free_decay, as the command line's --start left out)."""

    path: Path
    start: float | None = None
    rate: float | None = None
    """Sampling rate [Hz] that replaces the file's time column (None: the column)."""
    channels: tuple[tuple[str, tuple[float, float, float], tuple[float, float, float]], ...] = ()
    """(name, point [m], direction) of channels whose placement the campaign gives or replaces."""
    ignore: tuple[str, ...] = ()
    """Names of channels left unread (a tachometer, a microphone: records.read_csv)."""
    run: int | None = None
    """Which run of a UFF or TDMS file of several (records.read_record; None: every run, each a record of its own)."""
    exponential_window: float | None = None
    """[1/s] The exponential window a bench put on frequency response functions, divided out (records.without_window;
    None: none)."""
    sensitivity: tuple[tuple[str, str], ...] = ()
    """(name, sensitivity as written: "100mV/g") of channels the file holds in volts (records.with_sensitivities)."""
    channel_table: Path | None = None
    """A channel table (measurement.channel_table) placing the file's channels, with their sensitivities."""

    @property
    def name(self) -> str:
        """The record's name in notes and warnings: the file's, with its run where one is given."""
        return self.path.name if self.run is None else f"{self.path.name} run {self.run}"


@dataclass(frozen=True)
class Campaign:
    """A validated campaign (see the module docstring)."""

    machine: Machine
    known: dict[str, float]
    modes: dict[str, MeasuredMode]
    fit: tuple[str, ...] | None = None
    """Labels fitted; None: leave-one-out over all."""
    name: str = ""
    records: tuple[RecordSource, ...] = ()
    record_notes: tuple[str, ...] = ()
    """What the records chain said about the records (quality warnings, which record gave which mode)."""
    sensors: tuple[Channel, ...] = ()
    """The channels (acceleration sensors at a point along a unit direction) the mode shapes were estimated from
    (empty when the campaign does not say)."""
    frequency_type: str = "undamped"
    """What the frequencies under the campaign's ``modes`` were: "undamped" or "pole" (|p|, converted)."""
    notes: tuple[str, ...] = ()
    """What reading the campaign's ``modes`` said (pole frequencies converted: ``frequency_type``)."""
    records_disagree: tuple[str, ...] = ()
    """The modes taken from records that disagree on their frequency beyond RECORDS_DISAGREE sigma."""
    record_modes: tuple[str, ...] = ()
    """The modes taken from the records (their frequencies poles' |p|, converted)."""
    record_warnings: tuple[QualityWarning, ...] = ()
    """The records chain's quality warnings on the records, each with its record's file name (in ``record_notes``
    as text too)."""
    levels: LevelTest | None = None
    """The modes' frequencies measured again at other excitation levels against the campaign's (its ``levels``;
    None where it gives none): whether the isolators' stiffness depends on the amplitude."""
    level_records: dict[str, tuple[RecordSource, ...]] = field(default_factory=dict)
    """Per level name, the records its frequencies came from (levels given by hand only: none)."""
    frequency_unit: str = "rad/s"
    """The unit the campaign gave its modes' and levels' frequencies in (nomenclature.FREQUENCY_UNITS), converted
    to rad/s on reading."""

    @property
    def frequencies_from_poles(self) -> bool:
        """Whether every frequency was a pole's |p|, converted to an undamped one (``frequency_type`` "pole", or
        every mode from the records): the damping effect then acts on the damping ratios alone (a damped
        frequency read as an undamped one is no misreading such a campaign can hold)."""
        return self.frequency_type == "pole" or (bool(self.record_modes) and set(self.record_modes) == set(self.modes))

    def conventions(self) -> dict:
        """What the campaign's numbers refer to, for the report to echo: the description used, the known
        parameters the campaign does not give (they take the description's nominal values [SI]: a mass left out
        is the description's mass, which the report says), the coordinates of the mode shapes and their reference
        point, the isolator layout [m] at the known values, and where damping ratios are measured, the damping
        parameters of the model's ratios: the campaign's known values, else fitted with the stiffnesses (the value
        given is then the description's, where the fit starts)."""
        mod = self.machine.module
        points = self.machine.isolator_points(self.known)
        measured = any(m.damping_ratio is not None for m in self.modes.values())
        fitted = set(self.machine.damping) if measured else set()
        return {
            "known_from_description": self.machine.defaults(
                self.known,
                tuple(n for n in self.machine.parameters if n not in self.machine.unknown and n not in fitted),
            ),
            "damping_parameters": {
                n: {
                    "value": self.machine.values(self.known, (n,))[n],
                    "from": "known" if n in self.known else "fitted",
                }
                for n in self.machine.damping
            }
            if measured
            else {},
            "description": f"{self.machine.name}: {mod.TITLE}",
            "frequencies": "undamped natural frequencies [rad/s] (the model's sqrt of the eigenvalues of (C, M))"
            + (f"; given in {self.frequency_unit} and converted" if self.frequency_unit != "rad/s" else "")
            + ("; the modes' given as poles' |p| and converted" if self.frequency_type == "pole" else "")
            + ("; the records' poles' |p| converted (the record notes say where)" if self.records else ""),
            "shape_coordinates": list(mod.COORDINATES),
            "shape_reference": "translations of the description's coordinate origin [m], rotations about its "
            "axes [rad]",
            "isolators": {name: [float(v) for v in points[:, k]] for k, name in enumerate(mod.ISOLATORS)},
        }


def _path(error: jsonschema.ValidationError) -> str:
    return ".".join(str(p) for p in error.absolute_path) or "campaign"


def _explained(error: jsonschema.ValidationError) -> tuple[str, str]:
    """Where and what the schema error is. For a rule of alternatives (anyOf, oneOf): the error inside the
    one alternative whose shape the entry has (a record given as an object with a negative start), else the
    alternatives' own messages joined (neither 'modes' nor 'records'); never the whole instance."""
    if error.validator not in ("anyOf", "oneOf") or not error.context:
        return _path(error), _brief_message(error)
    inside = [e for e in error.context if len(e.absolute_path) > len(error.absolute_path)]
    if inside:
        best = jsonschema.exceptions.best_match(inside)
        return _path(best), _brief_message(best)
    return _path(error), "needs one of: " + "; or ".join(dict.fromkeys(e.message for e in error.context))


def _brief_message(error: jsonschema.ValidationError) -> str:
    """The schema's message with an array or object it quotes in full (a whole campaign given as a list, a shape
    of five components) told briefly: "a list of 5 items is too short", "an object is not of type 'number'"."""
    instance = error.instance
    if not isinstance(instance, (list, dict)) or not instance:
        return error.message
    brief = f"a list of {counted(len(instance), 'item')}" if isinstance(instance, list) else "an object"
    return error.message.replace(repr(instance), brief)


def _non_finite(value: object, path: str) -> str | None:
    """The path of the first number in ``value`` that is not finite (JSON files may hold NaN and Infinity,
    which Python's json module reads), else None."""
    if isinstance(value, float) and not math.isfinite(value):
        return path
    items = value.items() if isinstance(value, dict) else enumerate(value) if isinstance(value, list) else ()
    for key, item in items:
        found = _non_finite(item, f"{path}.{key}" if isinstance(key, str) else f"{path}[{key}]")
        if found is not None:
            return found
    return None


def frequencies_needed(machine: Machine, fit: tuple[str, ...] | None = None) -> int:
    """How many distinct frequencies a campaign on ``machine`` must measure: one per unknown, and one more that
    the gap report and the candidates hold out of the fit in turn (leave-one-out), unless the campaign names the
    frequencies to ``fit``."""
    return len(machine.unknown) + (0 if fit else 1)


def parse(data: dict, base: Path | None = None) -> Campaign:
    """A campaign from its JSON data (``base``: folder that relative description paths start from)."""
    validator = jsonschema.Draft202012Validator(schema())
    errors = sorted(validator.iter_errors(data), key=lambda e: list(e.absolute_path))
    if errors:
        raise InputError(*_explained(errors[0]))
    bad = _non_finite(data, "campaign")
    if bad is not None:
        raise InputError(bad.removeprefix("campaign."), "must be a finite number (NaN or infinity given)")
    data = _in_rad_per_s(data)
    target = data["machine"]
    if base is not None and target.endswith(".toml") and not Path(target).is_absolute():
        target = str(base / target)
    machine = Machine.resolve(target)
    data = _shapes_from_sensors(data, machine)
    known = dict(data.get("known", {}))
    for name in known:
        if name not in machine.parameters:
            raise InputError(f"known.{name}", f"not a parameter of {machine.name}")
        if name in machine.unknown:
            raise InputError(f"known.{name}", "is an unknown to identify")
    _check_known_scale(machine, known)
    identified = data.get("nominal") == "identified"
    machine, nominal_notes = _campaign_nominal(machine, {} if identified else dict(data.get("nominal", {})))
    seen: dict[str, str] = {}
    modes = {}
    for label, entry in data.get("modes", {}).items():
        if label not in machine.modes:
            raise InputError(f"modes.{label}", f"not a mode of {machine.name} (modes: {', '.join(machine.modes)})")
        modes[label] = _by_hand(label, entry)
        if modes[label].shape is not None and not any(modes[label].shape):
            raise InputError(f"modes.{label}.shape", "is all zeros")
        seen[label] = machine.module.REPRESENTATIVE[label]
    given = dict(modes)  # as the campaign gives them, before any conversion: what a level's modes compare with
    machine, notes_on_modes = _nominal_from_modes(machine, known, modes, identified)
    notes_on_modes = nominal_notes + notes_on_modes
    _check_modes_scale(machine, known, modes)
    if data.get("frequency_type") == "pole" and modes:
        modes, converted = _poles_as_undamped(machine, known, modes)
        notes_on_modes += converted
    sources = tuple(_source(entry, base) for entry in data.get("records", []))
    _distinct_files(
        [(f"records.{i}", source) for i, source in enumerate(sources)]
        + [
            (f"levels.{k}.records.{i}", _source(entry, base))
            for k, level in enumerate(data.get("levels", []))
            for i, entry in enumerate(level.get("records", []))
        ]
    )  # before any record goes through the records chain
    records = _modes_from_records(machine, known, sources, by_hand=modes)
    from_records, notes, layout = records.modes, records.notes, records.layout
    shaped_by_hand = any(mode.shape is not None for mode in modes.values())
    for label, mode in from_records.items():
        if label not in modes:
            modes[label] = mode
            seen[label] = machine.module.REPRESENTATIVE[label]
    if not modes:
        raise InputError("records", "no mode found in the records: " + "; ".join(notes))
    _check_modes_scale(machine, known, {k: v for k, v in from_records.items() if modes[k] is v})
    levels, level_records, level_record_notes, level_notes = _levels(machine, known, data, given, modes, base)
    notes += level_record_notes
    notes_on_modes += level_notes
    modes, uncompared = _damping_compared(machine, modes)
    notes_on_modes += uncompared
    fit = tuple(data["fit"]) if "fit" in data else None
    for label in fit or ():
        if label not in modes:
            raise InputError("fit", f"{label} is not among the measured modes ({', '.join(modes)})")
    distinct = {seen[label] for label in (fit or modes)}
    need = frequencies_needed(machine, fit)
    if len(distinct) < need:
        from mountid.identification.from_records import with_warnings

        rep = machine.module.REPRESENTATIVE
        have = [label for label in machine.module.MODES if label in distinct]
        missing = [label for label in machine.module.MODES if rep[label] == label and label not in distinct]
        too_few = InputError(
            "fit" if fit else "modes",
            f"{distinct_frequencies(len(distinct))} ({', '.join(have)}) for {len(machine.unknown)} unknowns "
            f"({', '.join(machine.unknown)})"
            + ("" if fit else f" plus one held out: {need} needed")
            + (f"; not measured: {', '.join(missing)}" if missing and not fit else "")
            + (
                "; the records gave too few (a longer record, more channels, another excitation point)"
                if from_records and not fit and missing
                else ""
            )
            + (
                f'; {machine.name} has no more distinct modes: name the frequencies to fit ("fit") and measure '
                "mode shapes, which then test the model"
                if not fit and len(machine.unique_modes) < need
                else ""
            ),
        )
        raise with_warnings(too_few, list(records.warnings), "the records also show")  # they may say why so few
    sensors = tuple(_channel(entry, i) for i, entry in enumerate(data.get("sensors", [])))
    if not sensors and layout and not shaped_by_hand:
        # every measured shape came from records of one channel layout: the layout a turned sensor is tested on
        sensors = layout
        notes.append(
            f"sensor layout of the shapes: the records' {len(layout)} channels ({', '.join(c.name for c in layout)})"
        )
    if sensors:
        rows = np.array(
            [sensor_row(machine.module, c.point, c.direction, f"sensors[{i}]") for i, c in enumerate(sensors)]
        )
        if np.linalg.matrix_rank(rows) < 6:
            raise InputError(
                "sensors", "the channels do not see all six rigid-body motions (their readings have rank < 6)"
            )
    return Campaign(
        machine,
        known,
        modes,
        fit,
        data.get("name", ""),
        sources,
        tuple(notes),
        sensors,
        data.get("frequency_type", "undamped"),
        tuple(notes_on_modes),
        tuple(label for label in records.disagree if label not in data.get("modes", {})),
        tuple(label for label in from_records if label not in data.get("modes", {})),
        records.warnings,
        levels,
        level_records,
        data.get("frequency_unit", "rad/s"),
    )


def _in_rad_per_s(data: dict) -> dict:
    """The campaign's data with the frequencies and frequency uncertainties of its modes and levels in rad/s, from
    its ``frequency_unit`` (nomenclature.FREQUENCY_UNITS; the schema has checked it)."""
    factor = FREQUENCY_UNITS[data.get("frequency_unit", "rad/s")]
    if factor == 1.0:
        return data

    def converted(modes: dict) -> dict:
        return {
            label: {
                key: value * factor if key in ("frequency", "uncertainty") and value is not None else value
                for key, value in entry.items()
            }
            for label, entry in modes.items()
        }

    out = dict(data)
    if "modes" in data:
        out["modes"] = converted(data["modes"])
    if "levels" in data:
        out["levels"] = [
            {**level, "modes": converted(level["modes"])} if "modes" in level else level for level in data["levels"]
        ]
    return out


def _shapes_from_sensors(data: dict, machine: Machine) -> dict:
    """The campaign's data with each mode's ``sensor_shape`` (its real shape read at the campaign's sensors, by
    name: what a bench's modal software tabulates) as a ``shape`` in the coordinates q, by least squares through the
    sensors' rows (identification.shapes.coordinate_shape, as a record's channel shape); an InputError naming the
    entry where the campaign has no such sensors, the mode gives both, or the sensors named do not see the six
    motions."""
    if not any("sensor_shape" in entry for entry in data.get("modes", {}).values()):
        return data
    from mountid.identification.shapes import coordinate_shape

    sensors = {c.name: c for c in (_channel(entry, i) for i, entry in enumerate(data.get("sensors", [])))}
    modes = {}
    for label, entry in data["modes"].items():
        given = entry.get("sensor_shape")
        if given is None:
            modes[label] = entry
            continue
        where = f"modes.{label}.sensor_shape"
        if "shape" in entry:
            raise InputError(f"modes.{label}", "give its shape in q (shape) or at the sensors (sensor_shape), not both")
        if not sensors:
            raise InputError(where, "needs the campaign's sensors (each one's name, point and direction)")
        unknown = [name for name in given if name not in sensors]
        if unknown:
            raise InputError(f"{where}.{unknown[0]}", f"not a sensor of the campaign (sensors: {', '.join(sensors)})")
        rows = np.array([sensor_row(machine.module, sensors[n].point, sensors[n].direction, n) for n in given])
        seen = int(np.linalg.matrix_rank(rows))
        if seen < rows.shape[1]:
            raise InputError(where, f"the sensors named see {seen} of the six motions (their readings' rank)")
        shape = coordinate_shape(rows, np.array([float(v) for v in given.values()], dtype=complex))
        modes[label] = {**{k: v for k, v in entry.items() if k != "sensor_shape"}, "shape": list(shape)}
    return {**data, "modes": modes}


def _by_hand(label: str, entry: dict) -> MeasuredMode:
    """A mode as a campaign's ``modes`` (or a level's) give it."""
    return MeasuredMode(
        label,
        float(entry["frequency"]),
        _frequency_std(entry),
        frequency_std_stated=entry.get("uncertainty") is not None,
        damping_ratio=entry.get("damping_ratio"),
        damping_std=entry.get("damping_uncertainty"),
        shape=_in_range(tuple(map(float, entry["shape"]))) if "shape" in entry else None,
        shape_std=float(entry.get("shape_uncertainty") or DEFAULT_SHAPE_STD),
    )


SHAPE_SCALE = (1e-100, 1e100)
"""The range of a measured shape's largest |component| taken as given; one beyond it is divided by it (a shape's
scale carries nothing: the fits compare directions), as its squares would underflow or overflow."""


def _in_range(shape: tuple[float, ...]) -> tuple[float, ...]:
    """``shape`` as given where its largest |component| lies within SHAPE_SCALE (or is zero: an error the caller
    names), else divided by it. A shape of 1e-300 in every component ended in "SVD did not converge" with a
    traceback, one of 1e300 in overflow warnings."""
    largest = max(map(abs, shape), default=0.0)
    if largest == 0 or SHAPE_SCALE[0] <= largest <= SHAPE_SCALE[1]:
        return shape
    return tuple(v / largest for v in shape)


def _frequency_std(entry: dict) -> float:
    """The standard deviation [rad/s] of a frequency entry (a mode's or a level's): its ``uncertainty``, else
    DEFAULT_FREQUENCY_STD of the frequency."""
    std = entry.get("uncertainty")
    return float(std) if std is not None else DEFAULT_FREQUENCY_STD * float(entry["frequency"])


def _levels(
    machine: Machine,
    known: dict[str, float],
    data: dict,
    given: dict[str, MeasuredMode],
    modes: dict[str, MeasuredMode],
    base: Path | None,
) -> tuple[LevelTest | None, dict[str, tuple[RecordSource, ...]], list[str], list[str]]:
    """The campaign's ``levels`` (its modes' frequencies measured again at other excitation levels) as a
    LevelTest (None without any), the records of each level that lists some, the notes of the records chain on
    them, and what of a level was not compared. A level's frequency given by hand is compared with the
    campaign's as given (``given``, in the convention of ``frequency_type``: the shift is the same in either);
    one from the level's records, a pole converted to an undamped frequency as the campaign's records are, with
    the campaign's undamped frequency (``modes``). A level's mode given by hand overrides its records'. Damping
    ratios at a level are compared with the campaign's where both give one (LevelTest.damping)."""
    shifts, damping, notes, compared = [], [], [], []
    named: dict[str, int] = {}
    recorded: dict[str, tuple[RecordSource, ...]] = {}
    for i, level in enumerate(data.get("levels", [])):
        name = level["name"]
        if name in named:
            raise InputError(
                f"levels.{i}.name",
                f"repeats the name of levels.{named[name]}: one entry per excitation level (its modes and records "
                "together)",
            )
        named[name] = i
        by_hand = level.get("modes", {})
        sources = tuple(_source(entry, base) for entry in level.get("records", []))
        hand_modes = {label: _by_hand(label, entry) for label, entry in by_hand.items() if label in machine.modes}
        found = _modes_from_records(machine, known, sources, f"levels.{i}.records", hand_modes)
        if sources:
            recorded[name] = sources
        notes += [f"level {name!r}: {note}" for note in found.notes]
        beyond = sorted(set(found.modes) - set(modes) - set(by_hand))
        if beyond:
            compared.append(
                f"level {name!r}: its records find {', '.join(beyond)}, which the campaign does not give: not compared"
            )
        at_level, paired = _paired_by_shape(
            machine, known, modes, {k: v for k, v in found.modes.items() if k not in by_hand}
        )
        if paired:
            compared.append(f"level {name!r}: {paired}")
        repeats = [(f"levels.{i}.modes.{label}", _by_hand(label, entry), True) for label, entry in by_hand.items()]
        repeats += [(f"levels.{i}.records", mode, False) for label, mode in at_level.items() if label in modes]
        if sources and not repeats:
            raise InputError(
                f"levels.{i}.records",
                f"no mode of the campaign's ({', '.join(modes)}) found in the level's records"
                + (f" (they find {', '.join(beyond)})" if beyond else ""),
            )
        undamped = []  # the level's damping ratios of modes the campaign gives none for
        for path, at, hand in repeats:
            label = at.label
            if label not in modes:
                raise InputError(
                    path,
                    f"not among the campaign's modes ({', '.join(modes)}): a level repeats modes the campaign gives"
                    if label in machine.modes
                    else f"not a mode of {machine.name} (modes: {', '.join(machine.modes)})",
                )
            if hand and label not in given and data.get("frequency_type") == "pole":
                raise InputError(
                    path,
                    f"the campaign's {label} comes from its records (an undamped frequency) and this level's is a "
                    "pole's |p| (frequency_type): give the level's records, or the campaign's mode by hand",
                )
            mode = given[label] if hand and label in given else modes[label]
            try:
                shifts.append(
                    level_shift(name, label, mode.frequency, mode.frequency_std, at.frequency, at.frequency_std)
                )
            except ValueError as reason:
                if hand:
                    raise InputError(f"{path}.frequency", str(reason)) from None
                raise InputError(path, f"{label}: {reason}") from None
            if at.damping_ratio is not None and modes[label].damping_ratio is not None:
                reference = modes[label]  # a damping ratio is one whichever frequency convention
                std = math.hypot(damping_std(reference), damping_std(at))
                damping.append(DampingShift(name, label, reference.damping_ratio, at.damping_ratio, std))
            elif at.damping_ratio is not None:
                undamped.append(label)
        if undamped:
            compared.append(
                f"level {name!r}: damping ratios of {', '.join(undamped)} not compared (the campaign gives none)"
            )
    test = LevelTest(tuple(shifts), tuple(damping)) if shifts else None
    return test, recorded, notes, compared


def _paired_by_shape(
    machine: Machine, known: dict[str, float], modes: dict[str, MeasuredMode], found: dict[str, MeasuredMode]
) -> tuple[dict[str, MeasuredMode], str]:
    """A level's modes from its records (``found``) paired with the campaign's ``modes`` by their shapes where both
    give the shapes of two or more of the same labels (labelling.same_modes on the shapes with rotations times the
    machine's length scale, as the diagnosis compares them, and on their frequencies with the records chain's
    weight), and a note where that pairing differs from the labels:
    the records chain labels each test's poles apart by the nominal model, and where the machine differs from it
    two close modes can take each other's labels at one level (genset8 with a component on its own springs: x and
    phi swapped between two levels 3 % apart, x read 25 % higher)."""
    shaped = [lab for lab, m in found.items() if m.shape is not None and lab in modes and modes[lab].shape is not None]
    if len(shaped) < 2:
        return found, ""
    length = machine.length_scale(known)
    ours = scaled_unit(np.array([modes[lab].shape for lab in shaped], dtype=float).T, length)
    theirs = scaled_unit(np.array([found[lab].shape for lab in shaped], dtype=float).T, length)
    log_ratio = np.log(np.array([[found[b].frequency / modes[a].frequency for b in shaped] for a in shaped]))
    pairs = same_modes(ours, theirs, log_ratio, LABELLING.record_frequency_weight)
    moved = [(lab, shaped[j]) for lab, j in zip(shaped, pairs, strict=True) if shaped[j] != lab]
    if not moved or np.abs(log_ratio[np.arange(len(shaped)), pairs]).max() > math.log(LEVEL_RATIO_LIMIT):
        # a pairing that puts a mode with one more than LEVEL_RATIO_LIMIT away is not the same mode's: the labels
        # stand (a slab under rectangular: a body mode of the support's at 73 rad/s shaped like phi at 32)
        return found, ""
    out = {**found, **{lab: replace(found[other], label=lab) for lab, other in moved}}
    said = ", ".join(f"its {other} as the campaign's {lab}" for lab, other in moved)
    return out, f"modes from its records paired with the campaign's by their shapes: {said}"


def _nominal_from_modes(
    machine: Machine, known: dict[str, float], modes: dict[str, MeasuredMode], identified: bool = False
) -> tuple[Machine, list[str]]:
    """``machine`` with nominal values where its description gives none (every unknown's: ``identified``),
    identified from the campaign's ``modes``, and a note saying so. The diagnosis starts its fits from the
    unknowns' nominal values and keeps them within candidate_model.UNKNOWN_RANGE of them, and a description need
    not give them (``identify`` needs none): the stiffnesses come from every measured frequency (fit_stiffness,
    the description's root rule deciding between equal solutions), damping parameters the campaign neither knows
    nor can do without from the measured damping ratios (fit_damping). Any other parameter without a value must
    be given under ``known``."""
    params = machine.parameters
    missing = [
        n for n in params if n not in known and (params[n]["value"] is None or (identified and n in machine.unknown))
    ]
    if not missing:
        return machine, []
    ratios = {label: m for label, m in modes.items() if m.damping_ratio is not None}
    stiffness = [n for n in missing if n in machine.unknown]
    damping = [n for n in missing if n in machine.damping and ratios]
    for name in missing:
        if name not in stiffness and name not in damping:
            raise InputError(
                f"known.{name}",
                f"{machine.name} gives no value for it"
                + (" and no measured mode has a damping ratio to identify it from" if name in machine.damping else "")
                + ": give it under known",
            )
    if not modes:
        raise InputError(
            "nominal" if identified else "machine",
            (
                "the campaign asks for nominal values identified from its measured frequencies and lists none"
                if identified
                else f"{machine.name} gives no nominal value for {', '.join(missing)}"
            )
            + ": the records are labelled against the model at its nominal values (give them under nominal, or "
            "measured frequencies under modes to identify them from)",
        )
    source = (
        f"the campaign asks for nominal values of {', '.join(missing)} identified from its measured modes"
        if identified
        else f"{machine.name} gives no nominal value for {', '.join(missing)}"
    )
    from mountid.identification.from_records import fit_damping, fit_stiffness

    notes: list[str] = []
    found = {n: float(params[n]["value"]) for n in machine.unknown if n not in stiffness}
    try:
        if stiffness:
            pairs = {label: (m.frequency, m.frequency_std) for label, m in modes.items()}
            rule = getattr(machine.module, "ROOT_RULE", "") or None
            found, _, _ = fit_stiffness(machine, known, pairs, root=rule, notes=notes, boundary_ok=True)
        if damping:
            stated = {label: replace(m, damping_std=damping_std(m)) for label, m in ratios.items()}
            found |= fit_damping(machine.with_nominal(found), {**known, **found}, stated, tuple(damping))[0]
    except InputError as err:
        raise InputError(
            "nominal" if identified else "machine",
            f"{source}, and the measured modes do not identify them: {err.parameter}: {err.reason}",
        ) from None
    for name in damping:
        if found[name] <= 0:
            raise InputError(
                "machine",
                f"{machine.name} gives no nominal value for {name}, and the measured damping ratios identify "
                f"{found[name]:.4g} {params[name]['unit']}, not a damping: give it under known",
            )
    filled = {n: found[n] for n in missing}
    values = _beside_description(machine, filled)
    whence = " and ".join(w for w, names in (("frequencies", stiffness), ("damping ratios", damping)) if names)
    why = "the campaign asks for them" if identified else f"{machine.name} gives none"
    notes.insert(
        0,
        f"nominal values identified from the measured {whence} ({why}; the diagnosis's fits start there and search "
        f"around them): {values}",
    )
    return machine.with_nominal(filled), notes


def _campaign_nominal(machine: Machine, nominal: dict[str, float]) -> tuple[Machine, list[str]]:
    """``machine`` with the campaign's ``nominal`` values of its unknowns in place of the description's, and a note
    saying so; an error naming a value that is not an unknown's or lies more than SCALE_LIMIT from the
    description's."""
    if not nominal:
        return machine, []
    for name in nominal:
        if name not in machine.unknown:
            raise InputError(
                f"nominal.{name}",
                f"not an unknown of {machine.name} ({', '.join(machine.unknown)}): known values go under known",
            )
    _check_known_scale(machine, nominal, "nominal")
    return machine.with_nominal(nominal), [f"nominal values from the campaign: {_beside_description(machine, nominal)}"]


def _beside_description(machine: Machine, values: dict[str, float]) -> str:
    """``values`` as a report note lists them, each beside the description's nominal value where it gives one."""
    params = machine.parameters
    return ", ".join(
        f"{n} = {v:.4g} {params[n]['unit']}"
        + (f" (the description's: {params[n]['value']:.4g})" if params[n]["value"] is not None else "")
        for n, v in values.items()
    )


def _check_known_scale(machine: Machine, known: dict[str, float], section: str = "known") -> None:
    """An error naming the first known value that is no value of its kind (not finite, or not positive where
    the kind must be) or (of a positive kind) more than SCALE_LIMIT from the description's nominal value
    (``section``: where the campaign gives it, the error's name begins with it)."""
    try:
        machine.values(known, tuple(known))
    except InputError as error:
        raise InputError(f"{section}.{error.parameter}", error.reason) from None
    for name, value in known.items():
        spec = machine.parameters[name]
        nominal = spec["value"]
        if (
            spec["kind"] in POSITIVE_KINDS
            and nominal
            and value > 0
            and not (nominal / SCALE_LIMIT <= value <= nominal * SCALE_LIMIT)
        ):
            raise InputError(
                f"{section}.{name}",
                f"{value:g} {spec['unit']} is {max(value / nominal, nominal / value):.3g} times "
                f"{'above' if value > nominal else 'below'} the description's nominal value {nominal:g} "
                f"{spec['unit']}, more than {SCALE_LIMIT:g} (another unit, or another machine?)",
            )


def _check_modes_scale(machine: Machine, known: dict[str, float], modes: dict[str, MeasuredMode]) -> None:
    """An error naming the first measured frequency more than SCALE_LIMIT outside the frequencies of the model
    at its nominal values with the ``known`` ones, or the first stated uncertainty below RESOLUTION or as large
    as the frequency."""
    if not modes:
        return
    model = machine.frequencies(known)
    low, high = min(model.values()), max(model.values())
    for label, mode in modes.items():
        if not low / SCALE_LIMIT <= mode.frequency <= high * SCALE_LIMIT:
            side, bound = ("below the lowest", low) if mode.frequency < low else ("above the highest", high)
            raise InputError(
                f"modes.{label}.frequency",
                f"{mode.frequency:.6g} rad/s is more than {SCALE_LIMIT:g} times {side} frequency of "
                f"{machine.name} at its nominal values with the known ones ({bound:.4g} rad/s): another unit, or "
                "a typing error?",
            )
    for label, mode in modes.items():
        if mode.frequency_std < RESOLUTION * mode.frequency:
            raise InputError(
                f"modes.{label}.uncertainty",
                f"{mode.frequency_std:.3g} rad/s is below {RESOLUTION:g} of the frequency {mode.frequency:.6g} rad/s, "
                "below the rounding of the double-precision model",
            )
        if mode.frequency_std >= mode.frequency:
            raise InputError(
                f"modes.{label}.uncertainty",
                f"{mode.frequency_std:.3g} rad/s is as large as the frequency {mode.frequency:.6g} rad/s: the "
                "measurement does not determine it (leave the mode out)",
            )
        stated = {
            "shape_uncertainty": mode.shape_std if mode.shape is not None else None,
            "damping_uncertainty": mode.damping_std if mode.damping_ratio is not None else None,
        }
        for entry, std in stated.items():
            if std is not None and std < RESOLUTION:
                raise InputError(
                    f"modes.{label}.{entry}",
                    f"{std:.3g} is below {RESOLUTION:g}, below the rounding of the double-precision model",
                )


def _damping_compared(machine: Machine, modes: dict[str, MeasuredMode]) -> tuple[dict[str, MeasuredMode], list[str]]:
    """The ``modes`` with their damping ratios left out, and a note saying so, where the description has no
    damping (no dissipation function: every model damping ratio is 0). Compared, each measured ratio was a gap of
    ratio / std (+20 sigma at 5 % +- 5 % of it) that no candidate holds, and the damping ratios' chi^2 drowned the
    frequencies' in the verdict. The ratios measured at other excitation levels are still compared with each
    other (Campaign.levels)."""
    measured = [label for label, m in modes.items() if m.damping_ratio is not None]
    if machine.damping or not measured:
        return modes, []
    kept = {label: replace(m, damping_ratio=None, damping_std=None) for label, m in modes.items()}
    return kept, [
        f"damping ratios of {', '.join(measured)} not compared: {machine.name}'s description has no damping (its "
        "model's ratios are all 0); describe the isolators' damping to compare them"
    ]


def _poles_as_undamped(
    machine: Machine, known: dict[str, float], modes: dict[str, MeasuredMode]
) -> tuple[dict[str, MeasuredMode], list[str]]:
    """The ``modes`` of a campaign whose frequencies are poles' |p| (``frequency_type`` "pole") as undamped
    frequencies (_as_undamped); an error where the campaign gives no damping to convert them with."""
    names = [n for n in machine.damping if n not in known]
    if names and not any(m.damping_ratio is not None for m in modes.values()):
        raise InputError(
            "frequency_type",
            "pole frequencies are converted through the damped model: give damping ratios or the damping "
            f"parameters under known ({', '.join(names)})",
        )
    return _as_undamped(machine, known, modes, [], "the modes'", strict=True)


def _direction(value: list[float] | str) -> tuple[float, float, float]:
    """A direction as a campaign gives it: [dx, dy, dz] or a signed axis ("+x", "-y": the schema's pattern)."""
    if isinstance(value, str):
        axis = axis_direction(value)
        if axis is None:  # unreached: the schema admits the signed axes only
            raise ValueError(f"not an axis: {value!r}")
        return axis
    return tuple(map(float, value))  # type: ignore[return-value]


def _channel(entry: dict, i: int) -> Channel:
    direction = unit_vector(_direction(entry["direction"]), f"sensors[{i}].direction")
    return Channel(entry["name"], tuple(map(float, entry["point"])), tuple(map(float, direction)))


def _source(entry: str | dict, base: Path | None) -> RecordSource:
    entry = {"file": entry} if isinstance(entry, str) else entry
    path = Path(entry["file"])
    if base is not None and not path.is_absolute():
        path = base / path
    channels = tuple(
        (name, tuple(map(float, c["point"])), _direction(c["direction"]))
        for name, c in entry.get("channels", {}).items()
    )
    start = entry.get("start")
    ignore, run = tuple(entry.get("ignore", ())), entry.get("run")
    window = entry.get("exponential_window")
    scales = tuple(entry.get("sensitivity", {}).items())
    table = entry.get("channel_table")
    if table is not None and base is not None and not Path(table).is_absolute():
        table = base / table
    return RecordSource(
        path,
        None if start is None else float(start),
        entry.get("rate"),
        channels,
        ignore,
        run,
        window,
        scales,
        None if table is None else Path(table),
    )


@dataclass(frozen=True)
class _FromRecords:
    modes: dict[str, MeasuredMode]
    notes: list[str]
    layout: tuple[Channel, ...]
    """The records' channel layout where every shape came from records of one layout, else ()."""
    disagree: tuple[str, ...]
    """The modes whose records disagree beyond RECORDS_DISAGREE."""
    warnings: tuple[QualityWarning, ...]
    """The records' quality warnings, each with its record's file name."""


def _modes_from_records(
    machine: Machine,
    known: dict[str, float],
    sources: tuple[RecordSource, ...],
    where: str = "records",
    by_hand: dict[str, MeasuredMode] | None = None,
) -> _FromRecords:
    """Each record through the records chain; per mode the records' combination (combination.combine), the notes,
    the layout of the shapes' channels and the modes the records disagree on. ``where``: the campaign entry that
    lists the records, for errors (``levels.0.records`` for a level's). ``by_hand``: the modes the campaign (or
    the level) gives by hand, which override the records': left out of what is returned, with a note each
    (_given_over_records; their records still inform the damping of the conversion to undamped frequencies).
    parse has checked that no record is listed twice (_distinct_files)."""
    if not sources:
        return _FromRecords({}, [], (), (), ())
    estimates: dict[str, list[tuple[MeasuredMode, str]]] = {}
    mixed: list[tuple[str, str]] = []  # (label, record) of lone poles on twins a fit of two does not part
    notes = []
    warned: list[QualityWarning] = []
    layouts: dict[str, tuple[Channel, ...]] = {}
    collected: list[tuple[str, ModalData]] = []
    runs = [(i, source, *named) for i, source in enumerate(sources) for named in _records_of(source, where, i)]
    for i, source, run, record in runs:
        try:
            segments, said = decays_of(machine, record, known, run, source.start)  # each hit's where it shows several
        except NoModeFound as err:
            if len(runs) == 1:
                raise InputError(f"{where}.{i} ({source.path.name or source.path})", err.reason) from None
            # one record of several without a mode it could label (a hit that excited only close modes it could
            # not separate): left out, said in the notes; the others stand
            notes.append(f"{run}: left out: {err.reason}")
            continue
        except InputError as err:  # which of the campaign's records, and what of it
            raise _named(err, source, where, i, "" if run == source.name else f"{run}: ") from None
        if source.ignore:
            notes.append(f"{run}: left unread as the campaign says: {', '.join(source.ignore)}")
        if source.sensitivity:
            given = ", ".join(f"{name} {text.strip()}" for name, text in source.sensitivity)
            notes.append(f"{run}: converted from volts by the campaign's sensitivities: {given}")
        if source.channel_table is not None:
            notes.append(f"{run}: channels placed, and converted from volts, by the table {source.channel_table.name}")
        notes += said
        layout = tuple(Channel(c.name, c.point, c.direction) for c in record.channels if c.quantity != "force")
        collected += segments
        layouts |= {name: layout for name, _ in segments}
    # a file's inputs measured at once: one measurement, each mode from one input
    collected, notes = at_once(machine, [(run, record) for *_, run, record in runs], collected, notes, known)
    for name, data in collected:
        here = [replace(w, record=name) for w in data.warnings]
        warned += here
        notes += [w.describe() for w in here]
        notes += [f"{name}: {note}" for note in data.notes]  # how the chain took it: H1, the start
        for label, mode in data.modes.items():
            estimates.setdefault(label, []).append((mode, name))
        mixed += [(label, name) for label in data.mixed]
    by_hand = by_hand or {}
    combination = combine(machine, estimates, mixed, frozenset(by_hand))  # a hand-given mode: said below
    notes += combination.notes
    disagree = combination.disagree
    modes = {label: replace(m, shape_std=record_shape_std(m.shape_std)) for label, m in combination.modes.items()}
    noisy = {
        lab: m.shape_std for lab, m in combination.modes.items() if m.shape is not None and m.shape_std is not None
    }
    if noisy:
        notes.append(
            "shape uncertainty per component: the record's noise ("
            + ", ".join(f"{lab} {v:.2g}" for lab, v in noisy.items())
            + f") with {DEFAULT_SHAPE_STD:g} for what a record does not show (sensor placement and calibration), "
            "in quadrature"
        )
    modes, notes = _as_undamped(machine, known, modes, notes)
    modes, notes = _at_resolution(modes, notes)
    for label in by_hand.keys() & modes.keys():
        notes.append(_given_over_records(label, by_hand[label], modes.pop(label), [n for _, n in estimates[label]]))
    shaped = {layouts[name] for names in combination.shape_from.values() for name in names}
    return _FromRecords(modes, notes, shaped.pop() if len(shaped) == 1 else (), disagree, tuple(warned))


def _records_of(source: RecordSource, where: str, i: int) -> list[tuple[str, Record]]:
    """The records of a campaign's record file, each with its name in notes: the file's (RecordSource.name, with
    the run it gives), or where it gives none, every run of a UFF or TDMS file of several ("NAME run K"). An InputError
    names the entry (``where``.``i``)."""
    from mountid.measurement.channel_table import read_channel_table, set_up
    from mountid.measurement.records import named_runs, sensitivity

    try:
        scales = {name: sensitivity(text, f"sensitivity.{name}") for name, text in source.sensitivity}
        table = None if source.channel_table is None else read_channel_table(source.channel_table)
        records = named_runs(
            source.path, source.path.name, source.rate, source.ignore, source.run, source.exponential_window
        )
        geometry = {name: (point, direction) for name, point, direction in source.channels}
        records = [(name, set_up(record, scales, table, geometry)) for name, record in records]
    except InputError as err:
        raise _named(err, source, where, i) from None
    return records


def _named(err: InputError, source: RecordSource, where: str, i: int, run: str = "") -> InputError:
    """A reader's or the records chain's error as the campaign's: the entry (``where``.``i``) and the file named
    once in the parameter (a reader's reason may start with it: uff_geometry.read_set), ``run`` (the run's name and
    a colon, or '') and the parameter it was about before the reason."""
    what = "" if err.parameter == "record" else f"{err.parameter}: "
    reason = err.reason.removeprefix(f"{source.path.name}: ")
    return InputError(f"{where}.{i} ({source.path.name or source.path})", f"{run}{what}{reason}")


def _as_undamped(
    machine: Machine,
    known: dict[str, float],
    modes: dict[str, MeasuredMode],
    notes: list[str],
    whose: str = "the records'",
    strict: bool = False,
) -> tuple[dict[str, MeasuredMode], list[str]]:
    """The records' frequencies as the undamped natural frequencies the diagnosis compares (its convention, as a
    campaign's ``modes``): a record gives poles, and with non-proportional damping |p| differs from the undamped
    frequency at second order (1e-4 on kid300's x and psi, several standard deviations of a 20 s record). Each
    |p| is divided by the ratio |p| / omega of the records chain's own identification (stiffness fitted to the
    damped model's |p|, every damping parameter to the measured damping ratios where they are as many, else
    those not under ``known``): an effect the nominal model lacks changes that ratio only at third order, and
    a damping the description misstates (twice its value: the ratio's shift four times) is the measured one.
    Without damping parameters, or where the identification fails or no mount of the description fits (the
    stiffness fit runs to a boundary: the ratio there would mean nothing), the frequencies are kept with a note
    (an error naming ``frequency_type`` when ``strict``: the campaign said its frequencies are poles).
    ``whose``: the notes' subject."""
    from mountid.identification.from_records import fit_damped_model, pole_frequencies

    names = machine.damping
    if not names:
        return modes, notes
    with_modes = {label: m for label, m in modes.items() if m.damping_ratio is not None}
    # the damping the records measure, where they carry its parameters, else the known values kept
    free = names if len(with_modes) >= len(names) else tuple(n for n in names if n not in known)
    pairs = {label: (m.frequency, m.frequency_std) for label, m in modes.items()}
    rule = getattr(machine.module, "ROOT_RULE", "") or None
    try:
        params, _, damping, _ = fit_damped_model(machine, known, pairs, with_modes, free, root=rule)
        values = machine.values({**known, **damping, **params}, tuple(machine.parameters))
        ratio = pole_frequencies(machine, values) / np.asarray(
            machine.module.frequencies(**{a: values[a] for a in machine.module.FORWARD_ARGUMENTS})
        )
    except (InputError, np.linalg.LinAlgError) as err:
        if strict:
            raise InputError("frequency_type", f"the pole frequencies cannot be converted: {err}") from None
        return modes, [*notes, f"{whose} pole frequencies |p| are taken as undamped ones (not converted: {err})"]
    out, shifts = {}, []
    for label, mode in modes.items():
        r = float(ratio[machine.module.MODES.index(label)])
        out[label] = replace(mode, frequency=mode.frequency / r)
        if abs(r - 1) * mode.frequency > 0.1 * mode.frequency_std:
            shifts.append(f"{label} {mode.frequency:.6g} -> {mode.frequency / r:.6g}")
    if shifts:
        notes.append(
            f"{whose} pole frequencies |p| as undamped ones through the identified damped model "
            + (
                f"(damping {', '.join(f'{n} = {damping[n]:.4g}' for n in free)} from the damping ratios; "
                if free
                else "("
            )
            + f"{', '.join(shifts)} rad/s; beyond a tenth of their standard deviation)"
        )
    return out, notes


def _at_resolution(modes: dict[str, MeasuredMode], notes: list[str]) -> tuple[dict[str, MeasuredMode], list[str]]:
    """The records' ``modes`` with standard deviations below RESOLUTION raised to it (relative for a frequency,
    absolute for a damping ratio), with a note naming them: a record without noise (a simulation's) gives its
    poles to the rounding of its samples (2e-14 relative), which a campaign may not state, yet the record is no
    error of the campaign's: its modes are known to the model's resolution."""
    out, raised = {}, []
    for label, mode in modes.items():
        frequency_std = max(mode.frequency_std, RESOLUTION * mode.frequency)
        damping_std = None if mode.damping_std is None else max(mode.damping_std, RESOLUTION)
        if frequency_std != mode.frequency_std or damping_std != mode.damping_std:
            raised.append(label)
        out[label] = replace(mode, frequency_std=frequency_std, damping_std=damping_std)
    if raised:
        notes = [
            *notes,
            f"{', '.join(raised)}: the records' standard deviations below the model's resolution (a record without "
            f"noise) taken as {RESOLUTION:g} (of the frequency; of the damping ratio)",
        ]
    return out, notes


def _distinct_files(entries: list[tuple[str, RecordSource]]) -> None:
    """An InputError naming the second of two ``entries`` (campaign entry, source) that are one file, or files of
    the same content (a copy under another name): its modes would count twice (in one list), or a level would
    compare a record with itself (across the campaign's and a level's). The runs of a file of several are
    records of their own (one run given twice is one record twice; the file without a run is every run)."""
    seen: dict[tuple[int, str], list[tuple[str, RecordSource]]] = {}
    for entry, source in entries:
        if not source.path.is_file():
            continue  # the records chain names what is there instead
        key = (source.path.stat().st_size, hashlib.sha256(source.path.read_bytes()).hexdigest())
        for first, other in seen.get(key, []):
            if None in (source.run, other.run) or source.run == other.run:
                same = "the same file as" if source.path.resolve() == other.path.resolve() else "the same content as"
                raise InputError(
                    f"{entry} ({source.name})",
                    f"{same} {first} ({other.name}): one record listed twice would count twice, or stand for "
                    "two excitation levels",
                )
        seen.setdefault(key, []).append((entry, source))


def _given_over_records(label: str, hand: MeasuredMode, record: MeasuredMode, names: list[str]) -> str:
    """The note on a mode given by hand that the records (``names``) find too: their estimate ``record`` (as the
    diagnosis compares it, undamped) is not used; how far the two lie apart in their combined standard
    deviation, and a question where beyond RECORDS_DISAGREE."""
    z = abs(hand.frequency - record.frequency) / math.hypot(hand.frequency_std, record.frequency_std)
    apart = f"; {z:.3g} sigma apart: the same mode?" if z > RECORDS_DISAGREE else ""
    return (
        f"{label}: given by hand ({hand.frequency:.6g} rad/s), in place of the records' ({', '.join(names)}: "
        f"{record.frequency:.6g} +- {record.frequency_std:.2g} rad/s){apart}"
    )


def load(path: str | Path) -> Campaign:
    """Read and validate a campaign file."""
    path = existing_file(path, "campaign")
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except UnicodeDecodeError as err:
        raise InputError(
            "campaign", f"{path.name} is not UTF-8 text (byte {err.start}): save it as UTF-8 JSON"
        ) from None
    except json.JSONDecodeError as err:
        raise InputError("campaign", f"{path.name} is not JSON: {err.msg} at line {err.lineno}") from None
    return parse(data, path.parent)
