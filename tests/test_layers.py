"""The import rule of the package layout (docs/architecture.md): each layer imports only the layers below it,
and the optional dependencies (extras) only where they are used.

runtime <- generated <- machine <- measurement <- identification <- diagnosis <- report <- {validation, cli},
with errors, nomenclature and the effect registry (``mountid.effects``) as the base every layer may use, and
the engine (sympy) beside the chain: only the machine imports it, lazily, to generate a description file.
"""

from __future__ import annotations

import ast
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "src" / "mountid"

CHAIN = ("runtime", "generated", "machine", "measurement", "identification", "diagnosis", "report")
BASE = ("errors", "nomenclature", "effects")


def _allowed() -> dict[str, set[str]]:
    allowed = {b: set(BASE) for b in BASE}
    for i, layer in enumerate(CHAIN):
        allowed[layer] = {*BASE, *CHAIN[: i + 1]}
    allowed["engine"] = {*BASE, "engine"}
    allowed["validation"] = {*BASE, *CHAIN, "validation"}  # not the engine: validation runs on generated modules
    allowed["cli"] = {*BASE, *CHAIN, "validation", "cli", "__main__"}
    allowed["__main__"] = {"cli"}
    allowed["__init__"] = {*BASE, "runtime", "machine", "measurement", "identification", "diagnosis"}
    return allowed


ALLOWED = _allowed()
LAZY = {"machine": {"engine"}}
"""Imports allowed only inside a function: the machine generates a description file with the engine (and so
needs sympy only then)."""

EXTRAS = {
    "sympy": {"engine"},
    "jinja2": {"engine"},
    "matplotlib": {"report"},
    "pyuff": {"measurement"},
    "nptdms": {"measurement"},
    "jsonschema": {"diagnosis"},
}
"""Optional dependencies and the layers that may import them (docs/architecture.md, "Dependencies")."""


def layer_of(module: str) -> str:
    """``mountid.diagnosis.gap`` -> ``diagnosis``; ``mountid`` -> ``__init__``."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "__init__"


def _module_name(path: Path, package: Path) -> str:
    rel = path.relative_to(package.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _imports(tree: ast.AST, module: str, is_package: bool):
    """(imported module, line, inside a function) of every import in ``tree``."""
    functions = (ast.FunctionDef, ast.AsyncFunctionDef)

    def visit(node: ast.AST, lazy: bool):
        for child in ast.iter_child_nodes(node):
            inner = lazy or isinstance(child, functions)
            if isinstance(child, ast.Import):
                for alias in child.names:
                    yield alias.name, child.lineno, inner
            elif isinstance(child, ast.ImportFrom):
                if child.level:
                    base = module.split(".")
                    base = base[: len(base) - child.level + (1 if is_package else 0)]
                    name = ".".join([*base, *([child.module] if child.module else [])])
                else:
                    name = child.module or ""
                if name == "mountid":  # from mountid import runtime -> mountid.runtime
                    for alias in child.names:
                        yield f"mountid.{alias.name}", child.lineno, inner
                else:
                    yield name, child.lineno, inner
            yield from visit(child, inner)

    yield from visit(tree, False)


def violations(package: Path) -> list[str]:
    """Every import in ``package`` that breaks the layer rule or imports an extra outside its layers."""
    out = []
    for path in sorted(package.rglob("*.py")):
        module = _module_name(path, package)
        layer = layer_of(module)
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for name, line, lazy in _imports(tree, module, path.name == "__init__.py"):
            top = name.split(".")[0]
            where = f"{path.relative_to(package.parent)}:{line}"
            if top == "mountid" and name != "mountid":
                target = layer_of(name)
                ok = target in ALLOWED.get(layer, set()) or (lazy and target in LAZY.get(layer, set()))
                if not ok:
                    out.append(f"{where}: {layer} imports {target} ({name})")
            elif top in EXTRAS and layer not in EXTRAS[top]:
                out.append(f"{where}: {layer} imports the optional dependency {top}")
    return out


def test_the_package_follows_the_import_rule():
    assert violations(PACKAGE) == []


def test_the_package_has_no_module_outside_a_known_layer():
    layers = {layer_of(_module_name(p, PACKAGE)) for p in PACKAGE.rglob("*.py")}
    assert layers <= set(ALLOWED) | {"schemas"}, layers - set(ALLOWED)


@pytest.fixture
def package_with_a_forbidden_import(tmp_path: Path) -> Path:
    """A copy of the layout's skeleton in which the machine imports the diagnosis at module level, the
    runtime imports matplotlib and a measurement module imports the engine inside a function."""
    pkg = tmp_path / "mountid"
    files = {
        "__init__.py": "",
        "machine/__init__.py": "",
        "machine/model.py": "from mountid.diagnosis.gap import diagnose\n",
        "runtime/__init__.py": "import matplotlib.pyplot as plt\n",
        "measurement/rig.py": "def f():\n    from mountid.engine.description import load\n",
        "machine/modules.py": "def f():\n    from mountid.engine.codegen.numpy_module import render\n",
        "diagnosis/gap.py": "from ..identification import from_records\n",
    }
    for name, text in files.items():
        (pkg / name).parent.mkdir(parents=True, exist_ok=True)
        (pkg / name).write_text(textwrap.dedent(text))
    return pkg


def test_the_rule_catches_forbidden_imports(package_with_a_forbidden_import: Path):
    found = violations(package_with_a_forbidden_import)
    assert found == [
        "mountid/machine/model.py:1: machine imports diagnosis (mountid.diagnosis.gap)",
        "mountid/measurement/rig.py:2: measurement imports engine (mountid.engine.description)",
        "mountid/runtime/__init__.py:1: runtime imports the optional dependency matplotlib",
    ]  # the machine's lazy engine import and the diagnosis's relative import downward are allowed


BLOCK_EXTRAS = """
import importlib.abc, sys
class Block(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in {"sympy", "jinja2", "matplotlib", "pyuff", "nptdms", "jsonschema", "mpmath"}:
            raise ModuleNotFoundError(f"No module named {name!r}", name=name)
sys.meta_path.insert(0, Block())
"""


def test_the_core_runs_without_the_extras():
    """The core install (numpy, scipy): a generated module, the machine and ``mountid identify`` run with
    sympy, jinja2, matplotlib, pyuff and jsonschema unimportable (CI also installs the core alone in a fresh
    virtual environment: ``make core-check``)."""
    script = BLOCK_EXTRAS + textwrap.dedent(
        """
        import mountid
        from mountid.generated import kid300
        assert abs(kid300.frequencies(838.6, 61.44, 51.52, 0.486, 0.3, 74.4e3, 472.3e3)[0] - 17.7) < 0.1
        from mountid.cli import main
        code = main(["identify", "kid300", "--measured", "x=17.71", "psi=64.1"])
        assert code == 0, code
        assert not any(m.split(".")[0] in {"sympy", "jinja2", "matplotlib"} for m in sys.modules)
        """
    )
    run = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, cwd=ROOT)
    assert run.returncode == 0, run.stderr
    assert "c_xy" in run.stdout


def test_a_missing_extra_is_one_line_naming_it():
    """Without jsonschema, ``mountid diagnose`` says which extra to install (exit 2, no traceback)."""
    script = BLOCK_EXTRAS + textwrap.dedent(
        """
        from mountid.cli import main
        sys.exit(main(["diagnose", "examples/kid300-paper.json"]))
        """
    )
    run = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, cwd=ROOT)
    assert run.returncode == 2, run.stderr
    assert run.stderr.strip().splitlines() == [
        "mountid: error: jsonschema: not installed; this command needs it: pip install 'mountid[campaigns]'"
    ]


def test_the_public_api_resolves_every_name():
    import mountid

    for name in mountid.__all__:
        assert getattr(mountid, name) is not None, name
    with pytest.raises(AttributeError, match="no attribute 'frobnicate'"):
        _ = mountid.frobnicate
