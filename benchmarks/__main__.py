"""Run the benchmarks: ``python -m benchmarks [name ...]`` from the repository root.

Without names, every ``benchmarks/bench_*.py`` runs in turn (alphabetical order); a name
may be given with or without its ``bench_`` prefix (``fan`` or ``bench_fan``). Each
module's ``main()`` prints its Markdown section. ``--list`` prints the names only.
Exit status: 0 when all ran, 1 when one raised (the others still run), 2 for an unknown
name.
"""

from __future__ import annotations

import argparse
import importlib
import pkgutil
import sys
import traceback
from collections.abc import Sequence
from pathlib import Path

PACKAGE = "benchmarks"
PREFIX = "bench_"


def discover() -> list[str]:
    """Names of the benchmark modules (``bench_*``), sorted."""
    here = str(Path(__file__).resolve().parent)
    return sorted(m.name for m in pkgutil.iter_modules([here]) if m.name.startswith(PREFIX))


def _resolve(names: Sequence[str], available: Sequence[str]) -> list[str]:
    chosen = []
    for name in names:
        module = name if name.startswith(PREFIX) else PREFIX + name
        module = module.removesuffix(".py")
        if module not in available:
            raise KeyError(name)
        chosen.append(module)
    return chosen


def _run_one(module_name: str) -> bool:
    """Import and run one benchmark's main(); True when it finished without raising."""
    saved_argv = sys.argv
    # Benchmarks that parse options read sys.argv: give them only their own name.
    sys.argv = [f"{PACKAGE}.{module_name}"]
    try:
        module = importlib.import_module(f"{PACKAGE}.{module_name}")
        module.main()
    except Exception:  # report and carry on with the others
        print(f"\n<!-- {module_name} failed -->", flush=True)
        traceback.print_exc()
        return False
    finally:
        sys.argv = saved_argv
    print(flush=True)
    return True


def main(argv: Sequence[str] | None = None) -> int:
    """Run the chosen (default: all) benchmarks; return the exit status."""
    available = discover()
    parser = argparse.ArgumentParser(prog="python -m benchmarks", description="Run shadowsurvey's benchmarks.")
    parser.add_argument("names", nargs="*", help=f"benchmarks to run: {', '.join(available)}")
    parser.add_argument("--list", action="store_true", help="list the benchmarks and exit")
    args = parser.parse_args(argv)
    if args.list:
        print("\n".join(available))
        return 0
    try:
        chosen = _resolve(args.names, available) if args.names else available
    except KeyError as exc:
        print(
            f"python -m benchmarks: unknown benchmark {exc.args[0]!r}; known: {', '.join(available)}",
            file=sys.stderr,
        )
        return 2
    failed = [name for name in chosen if not _run_one(name)]
    if failed:
        print(f"failed: {', '.join(failed)}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
