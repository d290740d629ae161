"""The ``shadowsurvey`` command line.

Subcommands live one per module in :mod:`planner.commands`; each module exposes
``register(subparsers)`` and sets ``func`` on its parser with ``set_defaults``. The
function returns an exit code. Bad input (``ValueError``/``OSError`` subclasses raised by
the packages) is reported on stderr with exit code 2.
"""

from __future__ import annotations

import argparse
import importlib
import pkgutil
import sys
from collections.abc import Sequence

import planner.commands

EXIT_BAD_INPUT = 2


def build_parser() -> argparse.ArgumentParser:
    """Build the parser with every subcommand found in :mod:`planner.commands`."""
    parser = argparse.ArgumentParser(
        prog="shadowsurvey",
        description=(
            "Dual-altitude sonar surveys for ArduSub ROVs: plan, fly (or dry-run in the "
            "simulator), and measure seabed target heights from cast shadows."
        ),
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for info in sorted(pkgutil.iter_modules(planner.commands.__path__), key=lambda m: m.name):
        if info.name.startswith("_"):
            continue
        module = importlib.import_module(f"planner.commands.{info.name}")
        module.register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``shadowsurvey`` console script; returns the exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        code = int(args.func(args))
    except (ValueError, OSError) as exc:
        print(f"shadowsurvey {args.command}: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print(f"shadowsurvey {args.command}: interrupted", file=sys.stderr)
        return 130
    return code


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
