"""``shadowsurvey sim [SCENARIO] [--out DIR]``: the dry-run dive, the product's main job.

Plans the scenario's dual-altitude survey, starts the software ArduSub vehicle on a UDP
socket, flies the survey through the same executor and MAVLink client that fly a real
sub, measures target heights on board, and writes the run folder: plan/, dive.tlog,
events.jsonl, time series, targets.geojson/csv, mosaic.tif/png, report.md, summary.json
and, because this is a simulation, truth.json.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path
from typing import Any

from tqdm import tqdm

from planner.mission.output_folder import check_output_folder


def register(subparsers: Any) -> None:
    """Add the ``sim`` subcommand."""
    parser = subparsers.add_parser(
        "sim",
        help="dry-run a whole dive against the simulated vehicle (the main job)",
        description=(
            "Plan, fly and process a dual-altitude survey against the software ArduSub "
            "vehicle over real MAVLink; write the run folder and print a summary."
        ),
    )
    parser.add_argument("scenario", nargs="?", default="paper-targets",
                        help="built-in scenario name, a scenario folder or scenario.toml (default: paper-targets)")
    parser.add_argument("--out", default="runs/sim",
                        help="run folder (default: runs/sim; an existing run needs --overwrite)")
    parser.add_argument("--overwrite", action="store_true",
                        help="replace an existing run folder at --out (replaced whole once the new run is complete)")
    parser.add_argument("--fixed-tilt", action="store_true",
                        help="hold the tilt that centres the tracking zone (no pitch loop)")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run the dry dive; exit 0 when completed, 1 when aborted (the run folder says why).

    The scenario, its scene, area and settings are checked (each, and against one another:
    :mod:`planner.dryrun.consistency`) and the survey planned before any folder is
    touched; the run is built in a staged folder and moved to ``--out`` when complete
    (:mod:`planner.mission.output_folder`).
    """
    from perception.child_process import started_early
    from planner.report.figure_worker import FigureWorker

    # The helper processes start first: they import numpy, OpenCV and matplotlib while this
    # process imports the rest and plans (those a refused input leaves unused are stopped).
    with started_early("sim_harness.render_worker", "perception.mapping.map_process"), FigureWorker() as figures:
        return _run(args, figures)


def _run(args: argparse.Namespace, figures: Any) -> int:
    from planner.dryrun.consistency import check_consistent
    from planner.dryrun.dive import dry_dive_into, prepare_dry_dive
    from planner.dryrun.scenario import load_scenario
    from planner.report.markdown import generate_report

    overrides = {"pitch_loop": False} if args.fixed_tilt else {}
    prepared = prepare_dry_dive(load_scenario(args.scenario, **overrides))
    check_consistent(prepared)
    out = Path(args.out)
    check_output_folder(out, kind="run", overwrite=args.overwrite)
    bar = None if args.no_progress else tqdm(total=100, unit="%", desc="dive", file=sys.stderr, mininterval=1.0,
                                              bar_format="{l_bar}{bar}| {n:.0f}% [{elapsed}<{remaining}] {postfix}")

    def progress(sim_s: float, planned_s: float, state: str) -> None:
        if bar is not None:
            bar.n = min(100.0, 100.0 * sim_s / planned_s)
            bar.set_postfix_str(state if sim_s >= planned_s else f"{state}, sim {sim_s:.0f} s", refresh=False)
            if sim_s >= planned_s:
                bar.refresh()  # the dive is over: shown at once
            else:
                bar.update(0)  # redraws at most once per mininterval

    try:
        dry = dry_dive_into(prepared, out, overwrite=args.overwrite, progress=progress, figures=figures)
    finally:
        if bar is not None:
            bar.close()
    report = generate_report(out, helper=figures)
    print(format_summary(dry.summary, out))
    print(f"report: {report}")
    return 0 if dry.summary.get("status") == "completed" else 1


def format_summary(summary: dict[str, Any], out: Path) -> str:
    """A short human-readable summary of ``summary.json``."""
    def num(key: str, fmt: str) -> str:
        value = summary.get(key)
        return "n/a" if value is None or (isinstance(value, float) and not math.isfinite(value)) else format(value, fmt)

    excursions = len(summary.get("altitude_excursions") or ()) + len(summary.get("altitude_excursions_true") or ())
    lines = [
        f"dive {summary.get('status')}: {summary.get('reason')} (final state {summary.get('final_state')})",
        f"simulated {num('sim_duration_s', '.0f')} s in {num('wall_duration_s', '.0f')} s wall",
        f"targets {summary.get('n_targets')} on the map, {summary.get('n_targets_with_height')} with a height "
        "(as in targets.csv, targets.geojson and the map)",
        f"lowest true altitude {num('min_clearance_m', '.2f')} m (allowed {num('min_altitude_allowed_m', '.2f')} m), "
        f"altitude warnings {excursions}, depth-limit violations {summary.get('depth_limit_violations')}",
        f"shadows in view {num('shadow_in_fov_ratio', '.3f')} of {summary.get('shadow_frames_within_range')} "
        "counted target-frames (report.md: Shadows in view)",
    ]
    if summary.get("height_mean_abs_error_m") is not None:
        lines.append(f"heights vs truth: mean |error| {100 * summary['height_mean_abs_error_m']:.2f} cm, "
                     f"max {100 * summary['height_max_abs_error_m']:.2f} cm over {summary.get('n_matched')} targets")
    elif "n_truth_targets" in summary:
        lines.append(f"heights vs truth: none of the {summary['n_truth_targets']} true targets has an estimate "
                     "within the matching radius (report.md)")
    coverage = summary.get("coverage_by_truth") or {}
    if coverage.get("every_pass") is not None:
        per_pass = ", ".join(f"{k.replace('_', ' ')} {100 * v:.1f} %" for k, v in coverage.items()
                             if k.startswith("pass_") and v is not None)
        lines.append(f"area seen by the sonar: {per_pass}, by every pass {100 * coverage['every_pass']:.1f} % "
                     f"of {coverage['region_m2']:.0f} m^2 (from the truth)")
    lines.append(f"run folder: {out} (summary.json, report.md, mosaic_heights.png, targets.geojson)")
    return "\n".join(lines) + "\n" + json.dumps({k: summary[k] for k in ("status", "reason")})
