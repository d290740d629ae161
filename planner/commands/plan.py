"""``shadowsurvey plan AREA.geojson --config survey.toml --out DIR``: plan a dual-altitude
survey and write the mission files, a plot and a summary."""

from __future__ import annotations

import argparse
import math
import sys
from typing import Any

from planner.config import default_settings, load_settings
from planner.errors import UsageError
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
    parser.add_argument("--out", required=True, help="output folder (created if needed)")
    parser.add_argument("--stay-inside", action="store_true",
                        help="keep every path inside the boundary; report the coverage lost")
    parser.add_argument("--origin", metavar="LAT,LON",
                        help="origin of the local frame in degrees (default: the area's centre)")
    parser.add_argument("--lane-heading-deg", type=float,
                        help="lane heading, overriding the settings")
    parser.add_argument("--no-plot", action="store_true", help="skip the PNG")
    parser.set_defaults(func=run)


def _origin(text: str | None) -> tuple[float, float] | None:
    if text is None:
        return None
    try:
        lat_s, lon_s = text.split(",")
        lat, lon = float(lat_s), float(lon_s)
    except ValueError as exc:
        raise UsageError(f"--origin must be LAT,LON in degrees, got {text!r}") from exc
    if not (-90 <= lat <= 90 and -180 <= lon <= 180):
        raise UsageError(f"--origin out of range: {text!r}")
    return lat, lon


def run(args: argparse.Namespace) -> int:
    """Plan and write the outputs; returns the exit code."""
    settings = load_settings(args.config) if args.config else default_settings()
    area = load_area(args.area, origin=_origin(args.origin))
    heading = None if args.lane_heading_deg is None else math.radians(args.lane_heading_deg)
    plan = plan_survey(area, settings, stay_inside=args.stay_inside, heading_rad=heading)
    paths = write_outputs(plan, area, args.out, altitude_reference=settings.mission.altitude_reference)
    if not args.no_plot:
        from planner.survey.plot import plot_plan  # matplotlib only when a plot is wanted

        png = paths["plan_json"].parent / "survey.png"
        plot_plan(plan, area, png)
        paths["png"] = png
    sys.stdout.write(summary_text(plan))
    sys.stdout.write("wrote " + ", ".join(str(p) for p in paths.values()) + "\n")
    return 0
