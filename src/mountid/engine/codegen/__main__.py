"""``python -m mountid.engine.codegen [--check] [NAME ...]``: regenerate generated/ from derivations/.

Without --check, writes generated/<name>.py for every description (or the named ones) and removes
generated modules whose description is gone. With --check, writes nothing and exits 1 listing every
file that differs from a fresh generation (the golden test CI runs).
"""

from __future__ import annotations

import argparse
import sys
from concurrent.futures import ProcessPoolExecutor
from functools import cache
from pathlib import Path

from mountid.engine.codegen.functions import EffectFunctions, effect_functions
from mountid.engine.codegen.numpy_module import render
from mountid.engine.description import load
from mountid.engine.settings import SHIPPED
from mountid.engine.symbolic.blocks import ModalStructure
from mountid.engine.symbolic.inverse import InverseDerivation, InverseSet
from mountid.engine.symbolic.model import SymbolicModel

ROOT = Path(__file__).resolve().parents[4]  # src/mountid/engine/codegen/__main__.py -> the project root


@cache
def _derivation(path: Path) -> InverseDerivation:
    """One InverseDerivation per description and worker process (the settings of the shipped modules)."""
    return InverseDerivation(ModalStructure(SymbolicModel(load(path)), SHIPPED))


def _candidates(path: Path) -> list[tuple[str, ...]]:
    return _derivation(path).candidates()


def _derive(path: Path, labels: tuple[str, ...]) -> InverseSet:
    return _derivation(path).derive(labels)


def _effects(path: Path) -> EffectFunctions:
    return effect_functions(SymbolicModel(load(path)))


def _render(path: Path, sets: list[InverseSet], effects: EffectFunctions) -> str:
    return render(load(path), inverse_sets=sets, effects=effects, settings=SHIPPED)


def generate(sources: list[Path], workers: int = 2) -> dict[str, str]:
    """Module source per description name. The inverse sets (most of the work) are derived one per task
    over ``workers`` processes, the candidate-effect functions one task per description alongside; each
    result is independent of the process it came from."""
    with ProcessPoolExecutor(max_workers=workers) as pool:
        effects = [pool.submit(_effects, path) for path in sources]
        candidates = list(pool.map(_candidates, sources))
        tasks = [
            [pool.submit(_derive, path, labels) for labels in sets]
            for path, sets in zip(sources, candidates, strict=True)
        ]
        sets = [[t.result() for t in row] for row in tasks]
        done = [e.result() for e in effects]
        return {p.stem: text for p, text in zip(sources, pool.map(_render, sources, sets, done), strict=True)}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m mountid.engine.codegen", description=__doc__.splitlines()[0])
    parser.add_argument("names", nargs="*", help="descriptions to generate (default: all)")
    parser.add_argument("--check", action="store_true", help="compare with the checked-in files, write nothing")
    parser.add_argument("--root", type=Path, default=ROOT, help="project root holding derivations/ and generated/")
    args = parser.parse_args(argv)
    sources = sorted((args.root / "derivations").glob("*.toml"))
    if args.names:
        sources = [s for s in sources if s.stem in args.names]
    out_dir = args.root / "generated"
    rendered = generate(sources)
    expected = {f"{name}.py": text for name, text in rendered.items()}
    if not args.names:
        expected["__init__.py"] = (
            '"""Generated modules, one per description in derivations/ (see `make generate`)."""\n'
        )
    stale = [] if args.names else [p.name for p in out_dir.glob("*.py") if p.name not in expected]
    differ = [n for n, t in expected.items() if not (out_dir / n).exists() or (out_dir / n).read_text() != t]
    if args.check:
        for name in differ + stale:
            print(f"generated/{name} differs from a fresh generation: run `make generate`", file=sys.stderr)
        return 1 if differ or stale else 0
    out_dir.mkdir(exist_ok=True)
    for name in differ:
        (out_dir / name).write_text(expected[name])
        print(f"wrote generated/{name}")
    for name in stale:
        (out_dir / name).unlink()
        print(f"removed generated/{name} (no description)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
