"""Where generated modules come from: the shipped ones (``mountid.generated``) and description files
generated on first use and cached by content.

Importing this module does not import sympy; only resolving a description *file* that is not cached yet
does (the engine is imported lazily, inside :func:`module_from_description`).
"""

from __future__ import annotations

import hashlib
import importlib
import os
import types
from pathlib import Path
from typing import Any, Protocol

from mountid.errors import DescriptionError


class GeneratedModule(Protocol):
    """What every generated machine module offers (see templates/numpy_module.py.jinja): its metadata and
    the functions the library calls by parameter name through :func:`mountid.machine.dynamics.call`."""

    DESCRIPTION: str
    TITLE: str
    COORDINATES: tuple[str, ...]
    PARAMETERS: dict[str, dict[str, Any]]
    UNKNOWN: tuple[str, ...]
    MODES: tuple[str, ...]
    UNIQUE_MODES: tuple[str, ...]
    REPRESENTATIVE: dict[str, str]
    FORWARD_ARGUMENTS: tuple[str, ...]
    ARGUMENTS: dict[str, tuple[str, ...]]
    DEPENDS: dict[str, tuple[str, ...]]
    INVERSES: dict[tuple[str, ...], Any]
    UNIDENTIFIABLE: dict[tuple[str, ...], str]
    UNDETERMINED: dict[tuple[str, ...], tuple[str, ...]]


def shipped_machines() -> list[str]:
    """Names of the generated modules shipped with the package."""
    folder = Path(importlib.import_module("mountid.generated").__file__).parent
    return sorted(p.stem for p in folder.glob("*.py") if not p.stem.startswith("_"))


def description_file(machine: str) -> Path | None:
    """The description file a machine's name gives (a path ending in .toml, whether or not it exists), or None
    for the name of a shipped machine: how Machine.resolve, the blind harness and the benchmarks tell them apart."""
    path = Path(machine)
    return path if path.suffix == ".toml" else None


def cache_folder() -> Path:
    """Where modules generated from description files are kept: $MOUNTID_CACHE, else
    $XDG_CACHE_HOME/mountid, else ~/.cache/mountid."""
    if os.environ.get("MOUNTID_CACHE"):
        return Path(os.environ["MOUNTID_CACHE"])
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "mountid"


def _engine_fingerprint() -> str:
    """Hash of everything a generated module depends on besides its description: the engine, the code
    generator, the templates (a change to any of them makes every cached module stale)."""
    import mountid

    root = Path(mountid.__file__).parent
    digest = hashlib.sha256()
    files = sorted([*root.glob("engine/**/*.py"), root / "effects.py", root / "nomenclature.py", root / "errors.py"])
    templates = Path(importlib.import_module("mountid.templates").__file__).parent
    for f in [*files, *sorted(templates.glob("*.jinja"))]:
        digest.update(f.name.encode() + f.read_bytes())
    return digest.hexdigest()


def module_from_description(path: Path) -> types.ModuleType:
    """The generated module of a description file, generated once and cached by content (the description's
    bytes and the engine's fingerprint): a second use of the same file costs no sympy."""
    key = hashlib.sha256(path.read_bytes() + _engine_fingerprint().encode()).hexdigest()[:24]
    cached = cache_folder() / f"{path.stem}-{key}.py"
    if cached.is_file():
        source = cached.read_text(encoding="utf-8")
    else:
        from mountid.engine.codegen.numpy_module import render  # sympy: only for descriptions not generated yet
        from mountid.engine.description import load

        try:
            source = render(load(path))
        except DescriptionError as err:  # the entry of which file: a campaign names its description by path
            if err.parameter == "machine" or str(path) in err.parameter:
                raise
            raise DescriptionError(f"{path.name}: {err.parameter}", err.reason) from None
        try:
            cached.parent.mkdir(parents=True, exist_ok=True)
            tmp = cached.with_suffix(f".{os.getpid()}.tmp")
            tmp.write_text(source, encoding="utf-8")
            tmp.replace(cached)  # atomic: a concurrent reader sees the whole file or none
        except OSError:
            pass  # a read-only cache folder only costs the next run a new generation
    module = types.ModuleType(f"mountid_generated_{path.stem}")
    module.__file__ = str(path)
    exec(compile(source, f"<generated from {path}>", "exec"), module.__dict__)
    return module
