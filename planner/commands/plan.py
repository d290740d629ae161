"""``shadowsurvey plan AREA.geojson --config survey.toml --out DIR``: plan a dual-altitude
survey and write the mission files, a plot and a summary."""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Any

from planner.commands import args as args_types
from planner.config import default_settings, load_settings
from planner.errors import InfeasibleError
from planner.mission.output_folder import staged_folder
from planner.survey.area import load_area
from planner.survey.lawnmower import plan_survey
from planner.survey.mission_files import summary_text, write_outputs


def register(subparsers: Any) -> None:
    """Add the ``plan`` subcommand."""
    parser = subparsers.add_parser(
        "plan",
        help="plan a dual-altitude lawnmower survey of an area",
        description=(
            "Choose the two altitudes and tilts, lay lanes over the area (GeoJSON, holes and "
            "keep-out polygons avoided) and write plan.json, a QGroundControl .plan, a Mission "
            "Planner .waypoints, a GeoJSON, a PNG plot and summary.txt to --out."
        ),
    )
    parser.add_argument("area", help="survey area (GeoJSON; see planner/data/example_area.geojson)")
    parser.add_argument("--config", help="settings TOML (default: the shipped survey.toml)")
    parser.add_argument("--out", required=True, help="output folder (created; an existing plan needs --overwrite)")
    parser.add_argument("--overwrite", action="store_true",
                        help="replace an existing plan folder at --out (it is replaced whole, never mixed)")
    parser.add_argument("--stay-inside", action="store_true",
                        help="keep every path inside the boundary; report the coverage lost")
    parser.add_argument("--origin", metavar="LAT,LON", type=args_types.lat_lon,
                        help="origin of the local frame in degrees (default: the area's centre)")
    parser.add_argument("--lane-heading-deg", type=args_types.heading_deg, metavar="DEG",
                        help="lane heading, -360..360 deg, overriding the settings")
    parser.add_argument("--no-plot", action="store_true", help="skip the PNG")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Plan and write the outputs; returns the exit code."""
    settings = load_settings(args.config) if args.config else default_settings()
    area = load_area(args.area, origin=args.origin)
    heading = None if args.lane_heading_deg is None else math.radians(args.lane_heading_deg)
    try:
        plan = plan_survey(area, settings, stay_inside=args.stay_inside, heading_rad=heading)
    except InfeasibleError as exc:
        raise InfeasibleError(f"cannot plan {args.area} with {settings.source}: {exc.reason}") from exc
    out = Path(args.out)
    with staged_folder(out, kind="plan", overwrite=args.overwrite, keep_partial=False) as stage:
        paths = write_outputs(plan, area, stage,
                              altitude_reference=settings.mission.altitude_reference)
        if not args.no_plot:
            from planner.survey.plot import plot_plan  # matplotlib only when a plot is wanted

            paths["png"] = stage / "survey.png"
            plot_plan(plan, area, paths["png"])
    sys.stdout.write(summary_text(plan))
    sys.stdout.write("wrote " + ", ".join(str(out / p.relative_to(stage)) for p in paths.values()) + "\n")
    return 0
