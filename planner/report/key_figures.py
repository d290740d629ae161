"""The report's key-figures table: each figure with its value and what it counts.

Every row says where its value comes from and what it means, so the report never shows
a bare number (the rule of the dive report: it explains every figure it shows). Fields
of ``summary.json`` the report does not know are not shown; the table ends with a line
that says how many there are (``summary.json`` itself, and ``docs/run-folder.md``, hold
them).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from planner.report.data import RunData
from planner.report.height_score import HeightScore
from planner.report.md import cell, fmt, table

#: summary.json fields that appear elsewhere in the report (its status line, its sections).
SHOWN_ELSEWHERE = frozenset({
    "status", "reason", "reason_detail", "final_state", "states", "scenario", "heights_vs_truth",
    "shadow_in_fov_definition", "shadow_time_by_target", "tracking_zone", "shadow_frames_within_range",
    "shadow_in_fov_ratio_2alt", "shadow_frames_within_range_2alt", "shadow_frames_in_conflict_2alt",
    "shadow_in_fov_ratio_all", "shadow_frames_unshowable", "shadow_fov_model_agreement", "navigation_drift",
    "altitude_excursions", "altitude_excursions_true", "target_count_definition", "n_tracks_raw", "partial",
    "summary_before_stop", "n_matched", "n_truth_targets", "height_mean_abs_error_m", "height_max_abs_error_m",
    "filter_counters",
})


def track_length_m(run: RunData) -> float:
    """Distance flown along the telemetry track, m (NaN without positions)."""
    if run.nav is None or not run.nav.has("north_m"):
        return math.nan
    ne = np.column_stack([run.nav.col("north_m"), run.nav.col("east_m")])
    ne = ne[np.isfinite(ne).all(axis=1)]
    return float(np.hypot(*np.diff(ne, axis=0).T).sum()) if len(ne) > 1 else 0.0


def nan_stat(fn: Any, values: np.ndarray) -> float:
    """``fn`` of the finite values (NaN when there are none)."""
    finite = values[np.isfinite(values)]
    return float(fn(finite)) if len(finite) else math.nan


def _targets_row(run: RunData, summary: Mapping[str, Any]) -> list[str] | None:
    if run.targets is None and "n_targets" not in summary:
        return None
    listed = None if run.targets is None else len(run.targets)
    solved = None if run.targets is None else sum(math.isfinite(t.height_m) for t in run.targets)
    if listed is not None:
        value = f"{listed} ({solved} with a height)"
    else:
        value = f"{summary['n_targets']} ({summary.get('n_targets_with_height', '–')} with a height)"
    what = ("targets on the map: targets.csv, targets.geojson, mosaic_heights.png and this report show the same "
            "ones (track fragments within 0.1 m of a stronger track folded in")
    raw = summary.get("n_tracks_raw")
    what += f"; the tracker held {raw} tracks before folding)" if raw is not None else ")"
    if listed is not None and "n_targets" in summary and summary["n_targets"] != listed:
        what += f". summary.json says {summary['n_targets']}: it was written by an older version that counted tracks"
    return ["targets (on the map)", value, what]


def key_figures(run: RunData, score: HeightScore | None) -> list[str]:
    """The key-figures table (Markdown lines)."""
    s = dict(run.summary or {})
    sim = run.simulated
    floor = s.get("min_altitude_allowed_m")
    floor_text = f" (the survey allows no lower than {fmt(floor, 'm')})" if floor is not None else ""
    rows: list[list[str]] = []

    def add(key: str, label: str, unit: str, what: str) -> None:
        if key in s:
            rows.append([label, fmt(s[key], unit), what])

    add("sim_duration_s", "dive duration" + (" (simulated clock)" if sim else ""), "duration",
        "from the first state (CONNECT) to the end state, on the dive's clock")
    add("wall_duration_s", "wall-clock duration", "duration", "real time the run took")
    add("min_clearance_m", "lowest altitude above the seabed (simulator truth)", "m",
        f"the vehicle's lowest true altitude while armed{floor_text}")
    add("min_altitude_estimated_m", "lowest altitude (filter estimate)", "m",
        "the lowest altitude the controller's altitude filter estimated while flying: what the safety envelope "
        "acts on")
    add("min_altitude_allowed_m", "lowest allowed altitude", "m",
        "survey.toml: min_clearance_m kept above the tallest expected target (target_height_max_m); no depth "
        "target is sent below it (plus 3 sigma of the seabed estimate)")
    excursions = list(s.get("altitude_excursions") or ()) + list(s.get("altitude_excursions_true") or ())
    if "altitude_excursions" in s:
        rows.append(["altitude warnings", str(len(excursions)),
                     "stretches below the pass altitude by more than 3 sigma of the filter, or below the lowest "
                     "allowed altitude (filter estimate" + (" and simulator truth" if sim else "") + "); see "
                     "Altitude warnings"])
    add("depth_commands_clamped", "depth targets clamped", "count",
        "depth targets the safety envelope changed: made shallower to keep the lowest allowed altitude plus 3 "
        "sigma of the seabed estimate, or kept within the depth limit")
    add("depth_limit_violations", "depth-limit violations (simulator truth)", "count",
        "samples of the true track deeper than vehicle.max_depth_m")
    add("depth_limit_violations_estimated", "depth-limit violations (estimated)", "count",
        "control cycles whose estimated depth was beyond vehicle.max_depth_m")
    add("shadow_in_fov_ratio", "target shadows inside the vertical FOV", "percent",
        "share of the counted target-frames (simulator truth) whose whole shadow was in the field of view; "
        "which frames count, and the seconds outside them: Shadows in view")
    coverage = s.get("coverage_by_truth")
    if isinstance(coverage, dict) and coverage.get("every_pass") is not None:
        per_pass = ", ".join(f"{k.replace('_', ' ')} {fmt(v, 'percent')}" for k, v in coverage.items()
                             if k.startswith("pass_") and v is not None)
        rows.append(["survey area seen by the sonar (simulator truth)",
                     f"{per_pass}; by every pass {fmt(coverage['every_pass'], 'percent')}",
                     f"share of the area to cover ({coverage.get('region_m2', 0):.0f} m^2, less holes and keep-outs) "
                     "inside some frame's insonified seabed, per pass and by every pass (a height needs the "
                     "shadow at two altitudes): the frames' true poses, the range window and the vertical aperture"])
    targets = _targets_row(run, s)
    if targets is not None:
        rows.append(targets)
    if score is not None:
        rows.append(["height error against truth", f"mean \\|e\\| {fmt(score.mean_abs_error_m, 'cm')}, max "
                     f"{fmt(score.max_abs_error_m, 'cm')} ({len(score.errors)} of {len(run.truth or ())} "
                     "true targets scored)",
                     f"estimated minus true height of the targets matched one to one within {score.radius_m:g} m"])
    drift = s.get("navigation_drift")
    if isinstance(drift, dict) and "correction_m" in drift:
        rows.append(["navigation drift corrected", fmt(drift.get("correction_m"), "m"),
                     "the registration's shift of later frames onto the map already built; see Navigation drift"])
    add("frames_processed", "sonar frames measured", "count", "frames the on-board height pipeline took")
    add("frames_skipped", "sonar frames skipped", "count",
        "frames without navigation or altitude at their timestamp yet, or unusable")
    add("frames_mapped", "sonar frames blended into the mosaic", "count",
        "frames on the lanes whose footprint had moved on enough (about 40 per seabed cell; each stands for the "
        "frames since the last)")
    add("waypoints_reached", "waypoints reached", "count", "plan waypoints the vehicle reached")
    nav = run.nav
    if nav is not None and nav.n_rows:
        rows.append(["distance flown (telemetry)", fmt(track_length_m(run), "m"),
                     "length of the telemetry track (nav.csv)"])
        rows.append(["deepest (telemetry)", fmt(nan_stat(np.max, nav.col("depth_m")), "m"),
                     "deepest depth the vehicle reported"])
        rows.append(["lowest altitude (telemetry)", fmt(nan_stat(np.min, nav.col("altitude_m")), "m"),
                     "lowest altimeter reading the vehicle reported (readings the filter rejected included)"])
    events = run.events or ()
    rows.append(["warnings / failsafes", f"{sum(e.kind == 'warning' for e in events)} / "
                 f"{sum(e.kind == 'failsafe' for e in events)}",
                 "warning and failsafe events in events.jsonl (listed under States and events)"])
    known = SHOWN_ELSEWHERE | {"sim_duration_s", "wall_duration_s", "min_clearance_m", "min_altitude_estimated_m",
                               "min_altitude_allowed_m", "depth_commands_clamped", "depth_limit_violations",
                               "depth_limit_violations_estimated", "shadow_in_fov_ratio", "n_targets",
                               "n_targets_with_height", "frames_processed", "frames_skipped", "frames_mapped",
                               "waypoints_reached",
                               "safe_action", "coverage_by_truth"}
    if "safe_action" in s:
        rows.append(["safe action taken", fmt(s["safe_action"]), "what the executor did at the end or on an abort: "
                     "hold (depth hold where it was) or surface"])
    lines = table(["key figure", "value", "what it is"], [[cell(a), b, cell(c)] for a, b, c in rows])
    others = sorted(k for k in s if k not in known)
    if others:
        lines += [f"summary.json holds {len(others)} more field(s) this report does not explain "
                  f"({cell(', '.join(others[:8]))}{', ...' if len(others) > 8 else ''}); see the file.", ""]
    return lines
