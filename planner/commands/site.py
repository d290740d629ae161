"""``shadowsurvey site DIR --area AREA.geojson --depth-m D``: a dry-run scenario for your own site.

Writes the folder ``DIR`` (docs/own-site.md): ``scene.toml`` (the area's origin, the
seabed at the depth and slope given, a sediment texture, example targets commented out),
``area.geojson`` (the file given, copied as it is), ``survey.toml`` (settings suiting the
depth) and ``scenario.toml``; ``shadowsurvey sim DIR --out RUN`` then flies it. The area
is read, the site checked and its survey planned before anything is written; the folder
is built aside and moved into place whole (:mod:`planner.mission.output_folder`), an
existing one replaced only with ``--overwrite`` and only if it is a scenario folder.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Any

from perception.atomic_file import atomic_write_bytes, atomic_write_text
from planner.commands import args as args_types
from planner.config import parse_settings_text
from planner.dryrun.site_survey import MAX_SITE_DEPTH_M, MIN_SITE_DEPTH_M
from planner.dryrun.site_template import (
    MAX_SITE_SLOPE_DEG,
    SiteSpec,
    check_site,
    scenario_text,
    scene_text,
    site_survey_text,
)
from planner.errors import InfeasibleError, UsageError
from planner.mission.output_folder import check_output_folder, staged_folder
from planner.survey.area import load_area
from planner.survey.lawnmower import plan_survey


def register(subparsers: Any) -> None:
    """Add the ``site`` subcommand."""
    parser = subparsers.add_parser(
        "site",
        help="write a dry-run scenario folder for your own site (then: shadowsurvey sim DIR)",
        description=(
            "Write a scenario folder for a site of your own from its survey area and seabed depth: "
            "scene.toml (origin, seabed, example targets to uncomment), area.geojson, survey.toml "
            "(settings suiting the depth) and scenario.toml. `shadowsurvey sim DIR --out RUN` flies it."
        ),
    )
    parser.add_argument("folder", metavar="DIR",
                        help="the scenario folder to write (an existing one needs --overwrite)")
    parser.add_argument("--area", required=True, metavar="AREA.geojson",
                        help="survey area (GeoJSON, docs/scenario-format.md#the-area); copied into DIR")
    parser.add_argument("--depth-m", required=True, metavar="M",
                        type=args_types.number(MIN_SITE_DEPTH_M, MAX_SITE_DEPTH_M, unit="m"),
                        help=f"seabed depth at the area's origin, {MIN_SITE_DEPTH_M:g}-{MAX_SITE_DEPTH_M:g} m")
    parser.add_argument("--slope-deg", metavar="DEG", type=args_types.number(0.0, MAX_SITE_SLOPE_DEG, unit="deg"),
                        help=f"seabed slope, 0-{MAX_SITE_SLOPE_DEG:g} deg (default: flat)")
    parser.add_argument("--slope-direction-deg", metavar="DEG", type=args_types.heading_deg,
                        help="compass direction in which the seabed deepens, -360..360 deg (with --slope-deg)")
    parser.add_argument("--name", help="the scenario's name (default: the folder's name)")
    parser.add_argument("--overwrite", action="store_true",
                        help="replace an existing scenario folder at DIR (never a folder of other files)")
    parser.set_defaults(func=run)


def _slope(args: argparse.Namespace) -> tuple[float, float]:
    """(slope_deg, slope_direction_deg) from the options, given together."""
    if args.slope_direction_deg is not None and args.slope_deg is None:
        raise UsageError("--slope-direction-deg: needs --slope-deg (the seabed's slope)")
    if args.slope_deg and args.slope_direction_deg is None:
        raise UsageError("--slope-deg: needs --slope-direction-deg (the compass direction in which the seabed deepens)")
    return args.slope_deg or 0.0, (args.slope_direction_deg or 0.0) % 360.0


def run(args: argparse.Namespace) -> int:
    """Check the site, plan it, write the folder; returns the exit code."""
    out = Path(args.folder)
    check_output_folder(out, kind="scenario", overwrite=args.overwrite, option="DIR")
    slope_deg, direction_deg = _slope(args)
    area = load_area(args.area)
    area_bytes = Path(args.area).read_bytes()
    name = args.name or out.resolve().name
    if not name.strip() or not name.isprintable():
        raise UsageError(f"{'--name' if args.name else 'DIR'}: the scenario's name must be one line of printable "
                         f"text, got {name!r}")
    spec = SiteSpec(name=name, area=area, depth_m=args.depth_m, slope_deg=slope_deg,
                    slope_direction_deg=direction_deg)
    check_site(spec)
    files = {"scene.toml": scene_text(spec), "survey.toml": site_survey_text(spec),
             "scenario.toml": scenario_text(spec)}
    settings = parse_settings_text(files["survey.toml"], path=str(out / "survey.toml"))
    try:
        plan = plan_survey(area, settings)
    except InfeasibleError as exc:
        raise InfeasibleError(f"--area {args.area}: cannot plan it with the settings for a {args.depth_m:g} m site: "
                              f"{exc.reason}") from exc
    with staged_folder(out, kind="scenario", overwrite=args.overwrite, keep_partial=False, option="DIR") as stage:
        atomic_write_bytes(stage / "area.geojson", area_bytes)
        for file_name, text in files.items():
            atomic_write_text(stage / file_name, text)
    s = plan.summary
    shallowest, deepest = spec.seabed_range_m()
    sys.stdout.write(
        f"wrote {out}: scene.toml, area.geojson, survey.toml ({spec.preset.name} settings), scenario.toml\n"
        f"origin {area.origin_lat_deg:.7f}, {area.origin_lon_deg:.7f}; seabed {shallowest:.2f}-{deepest:.2f} m "
        f"over {s.area_m2:,.0f} m^2\n"
        f"plan: {s.n_lanes} lanes at heading {math.degrees(s.lane_heading_rad):.0f} deg, two passes at "
        f"{plan.passes[0].altitude_m:.2f} and {plan.passes[-1].altitude_m:.2f} m, "
        f"{s.total_duration_s / 60:.0f} min at {s.speed_m_s:g} m/s\n"
        f"next: add your targets to {out / 'scene.toml'}, then shadowsurvey sim {out} --out runs/{name}\n")
    return 0
