"""The ``shadowsurvey`` command line.

Subcommands live one per module in :mod:`planner.commands`; each module exposes
``register(subparsers)`` and sets ``func`` on its parser with ``set_defaults``. The
function returns an exit code.

Bad input ends in exit code 2 and ONE line on stderr, ``shadowsurvey COMMAND: error: ...``,
naming the file (or option) and what is wrong: argparse's own complaints (an unknown
option, a value its ``type=`` refused, see :mod:`planner.commands.args`) and every
``ValueError``/``OSError`` the packages raise (each package's ``errors.py``). Ctrl-C ends
in exit code 130. Helper modules of :mod:`planner.commands` without ``register`` (such as
:mod:`planner.commands.args`) are not subcommands.
"""

from __future__ import annotations

import argparse
import importlib
import pkgutil
import sys
from collections.abc import Sequence
from typing import NoReturn

import planner.commands

EXIT_BAD_INPUT = 2
EXIT_INTERRUPTED = 130


class _ParseFailure(Exception):
    """argparse refused the command line; ``message`` is its complaint, ``prog`` the command."""

    def __init__(self, prog: str, message: str):
        super().__init__(message)
        self.prog = prog
        self.message = message


class _Parser(argparse.ArgumentParser):
    """An ArgumentParser whose errors are one line (no usage block), raised to :func:`main`."""

    def error(self, message: str) -> NoReturn:
        raise _ParseFailure(self.prog, message)


def one_line(text: str) -> str:
    """``text`` on one line: its lines joined with "; " (a message must never span lines)."""
    return "; ".join(part.strip() for part in str(text).splitlines() if part.strip())


def _message(exc: BaseException) -> str:
    """The exception's text and notes (:meth:`BaseException.add_note`) on one line."""
    parts = [str(exc), *getattr(exc, "__notes__", ())]
    if isinstance(exc, KeyboardInterrupt):
        parts = parts[1:]
    return one_line("\n".join(p for p in parts if p)) or ("" if isinstance(exc, KeyboardInterrupt)
                                                            else type(exc).__name__)


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """Build the parser with every subcommand found in :mod:`planner.commands`, or with
    ``command``'s alone when a module of that name exists (its module is the only one
    imported: the commands' imports take seconds, most of them another command's)."""
    parser = _Parser(
        prog="shadowsurvey",
        description=(
            "Dual-altitude sonar surveys for ArduSub ROVs: plan, fly (or dry-run in the "
            "simulator), and measure seabed target heights from cast shadows."
        ),
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    names = sorted(info.name for info in pkgutil.iter_modules(planner.commands.__path__)
                   if not info.name.startswith("_"))
    wanted = command.replace("-", "_") if command else None
    if wanted in names:
        names = [wanted]
    for name in names:
        module = importlib.import_module(f"planner.commands.{name}")
        if hasattr(module, "register"):
            module.register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``shadowsurvey`` console script; returns the exit code."""
    words = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser(words[0] if words and not words[0].startswith("-") else None)
    try:
        args = parser.parse_args(words)
    except _ParseFailure as exc:
        print(f"{exc.prog}: error: {one_line(exc.message)}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except SystemExit as exc:  # --help, --version
        return exc.code if isinstance(exc.code, int) else 0
    try:
        code = int(args.func(args))
    except (ValueError, OSError) as exc:
        print(f"shadowsurvey {args.command}: error: {_message(exc)}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt as exc:
        print(f"shadowsurvey {args.command}: interrupted{'; ' + _message(exc) if _message(exc) else ''}",
              file=sys.stderr)
        return EXIT_INTERRUPTED
    return code


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
