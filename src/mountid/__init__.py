"""mountid: the dynamics of a rigid machine on rubber isolators, derived symbolically, emitted as numpy
modules, and closed against measurements.

The public API, by layer (docs/architecture.md). Names are imported on first use, so ``import mountid`` is
cheap and needs no optional dependency; each name needs only the extras of its layer:

- machine (core: numpy): :class:`Machine`, :class:`Solution`, :func:`shipped_machines`
- measurement (core; UFF and TDMS files need the ``records`` extra): :class:`Record`, :func:`read_record`,
  :class:`ModeTable` (a bench's mode shapes: what read_record gives of a UFF file of datasets 55),
  :func:`read_csv`, :func:`write_csv`, :func:`read_uff`, :func:`read_tdms`, :class:`Rig`
- identification (core: numpy, scipy): :func:`identify_from_record`, :func:`fit_stiffness`
- diagnosis (the ``campaigns`` extra): :func:`load_campaign`, :func:`diagnose`
- errors: :class:`InputError`, :class:`DescriptionError`

Example::

    import mountid
    kid = mountid.Machine.resolve("kid300")
    kid.identify({}, {"x": 17.71, "psi": 64.1})
"""

from __future__ import annotations

import importlib
from typing import Any

_PUBLIC = {
    "InputError": "mountid.errors",
    "DescriptionError": "mountid.errors",
    "Machine": "mountid.machine",
    "Solution": "mountid.machine",
    "shipped_machines": "mountid.machine",
    "Record": "mountid.measurement.records",
    "ModeTable": "mountid.measurement.records",
    "read_csv": "mountid.measurement.records",
    "write_csv": "mountid.measurement.records",
    "read_uff": "mountid.measurement.uff",
    "read_tdms": "mountid.measurement.tdms",
    "read_record": "mountid.measurement.records",
    "Rig": "mountid.measurement.rig",
    "identify_from_record": "mountid.identification.from_records",
    "fit_stiffness": "mountid.identification.from_records",
    "load_campaign": ("mountid.diagnosis.campaign", "load"),
    "diagnose": "mountid.diagnosis.gap",
}

__all__ = sorted(_PUBLIC)


def __getattr__(name: str) -> Any:
    """Import a public name on first use (PEP 562)."""
    if name not in _PUBLIC:
        raise AttributeError(f"module 'mountid' has no attribute {name!r}")
    where = _PUBLIC[name]
    module, attribute = where if isinstance(where, tuple) else (where, name)
    value = getattr(importlib.import_module(module), attribute)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted([*globals(), *__all__])
