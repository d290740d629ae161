"""``shadowsurvey report RUN_DIR``: (re-)generate a run folder's dive report.

Reads the run folder's files (events, navigation, filter and tilt series, plan, targets,
summary and, in simulation, the truth), writes the figures into ``RUN_DIR/report/`` and
the report into ``RUN_DIR/report.md``, and prints the report's path. Exit 0 on success,
2 when RUN_DIR is not a folder or one of its files is malformed (the message names it).
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from planner.commands import args as args_types
from planner.errors import UsageError
from planner.report.markdown import DEFAULT_MATCH_RADIUS_M, generate_report


def register(subparsers: Any) -> None:
    """Add the ``report`` subcommand."""
    parser = subparsers.add_parser(
        "report",
        help="write a run folder's dive report (report.md with figures)",
        description=__doc__.split("\n\n")[1] if __doc__ else None,
    )
    parser.add_argument("run_dir", metavar="RUN_DIR", help="the run folder of a dive")
    parser.add_argument("--match-radius-m", type=args_types.number(0.0, 1000.0, lo_open=True, unit="m"),
                        default=DEFAULT_MATCH_RADIUS_M, metavar="M",
                        help="largest distance between an estimated and a true target to score them as one, m "
                        f"(simulation runs; default {DEFAULT_MATCH_RADIUS_M:g})")
    parser.add_argument("--dpi", type=args_types.integer(20, 600), default=110,
                        help="figure resolution, dots per inch, 20..600 (default 110)")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run the command; 0 on success (bad input raises and the CLI exits 2)."""
    run_dir = Path(args.run_dir)
    if not run_dir.is_dir():
        raise UsageError(f"{run_dir}: not a run folder (no such directory)")
    print(generate_report(run_dir, match_radius_m=args.match_radius_m, dpi=args.dpi))
    return 0
