"""Scoring a dry-run dive against the simulator's truth: clearance, depth limit, heights,
shadows in view."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from planner.config import Settings
from planner.dryrun.shadow_view import holdable_tilts, shadow_visible_at_tilts, visible_tilts
from planner.mission.altitude_watch import AltitudeLimits, AltitudeWatch, replay
from planner.mission.executor_config import DiveResult
from planner.mission.run_folder import RunFolder
from planner.report.height_score import score_heights
from planner.survey.plan import SurveyPlan
from sim_harness.simulator import VehicleSimulator

#: Shadow-in-view scoring (see :func:`score_against_truth`). The judge's own rules, set
#: here and nowhere else: a target counts from this many altitudes ahead ...
FOV_MIN_AHEAD_ALTITUDES = 2.0
#: ... once it has been countable for this long (the loop settling on it), s ...
FOV_SETTLE_S = 1.0
#: ... and only where one tilt within the mount's limits shows both its whole shadow and the
#: seabed at the window's end, with this much to spare at each aperture edge: then one
#: tilt can hold every such target at once (the loop keeps 0.75 deg and up to 1.5 deg of
#: pitch prediction envelope; the judge asks the same 2.25 deg of the truth geometry).
FOV_EDGE_MARGIN_RAD = math.radians(2.25)
#: Tilts tried, rad, when asking whether some tilt within the mount's limits shows a shadow.
FOV_TILT_STEP_RAD = math.radians(0.1)


def height_summary(estimated: Any, truth_targets: Any, *, radius_m: float = 0.25) -> dict[str, Any]:
    """Heights against truth for summary.json (one-to-one matching by seabed position:
    each estimate sits at the target's estimated centre, within ``radius_m`` of the true one)."""
    score = score_heights(list(estimated), list(truth_targets), radius_m=radius_m)
    per_target = []
    for k, t in enumerate(truth_targets):
        e = next((x for x in score.errors if x.truth == k), None)
        entry: dict[str, Any] = {"id": t.target_id, "true_height_m": t.height_m, "matched": e is not None}
        if e is not None:
            est = list(estimated)[e.estimated]
            entry.update(estimate_id=est.target_id, height_m=e.height_m, height_std_m=e.height_std_m,
                         frames_used=est.frames_used, error_m=e.error_m, distance_m=e.distance_m)
        per_target.append(entry)
    n = len(score.errors)
    return {
        "n_matched": n,
        "n_truth_targets": len(per_target),
        "height_mean_abs_error_m": score.mean_abs_error_m if n else None,
        "height_max_abs_error_m": score.max_abs_error_m if n else None,
        "heights_vs_truth": per_target,
    }


def score_against_truth(run: RunFolder, sim: VehicleSimulator, settings: Settings, result: DiveResult,
                        estimated: Any, *, n_beams: int, truth_targets: Any,
                        beam_azimuth_rad: Any = None, mount: Any = None,
                        plan: SurveyPlan | None = None) -> dict[str, Any]:
    """Simulation-only figures from the truth: clearance, depth limit, heights, shadows in view.

    The judge works from the simulator's truth of every rendered frame (true pose and
    attitude, per-beam slant ranges of each target's shadow) with its own geometry
    (:mod:`planner.dryrun.shadow_view`), never with the controller's functions. Over the
    frames of the survey passes, a target is *within range* when

    - its whole shadow lies inside the range window and the fan (not on the first or
      last beam), its centre at least ``FOV_MIN_AHEAD_ALTITUDES`` altitudes ahead, and
    - it is *holdable*: some tilt within the mount's limits shows, at the frame's true
      attitude, both its whole shadow and the seabed at the window's end on its beams,
      each ``FOV_EDGE_MARGIN_RAD`` inside the aperture's edges (one tilt then holds every
      holdable target: they never conflict; targets nearer or taller than that are
      reported apart, as ``near_band``).

    Frames in the first ``FOV_SETTLE_S`` of a pass or of a target coming into range are
    left out (the loop settling). ``shadow_in_fov_ratio`` is the share of within-range
    target-frames whose whole shadow was inside the field of view (the simulator's own
    ``whole_shadow_in_band`` and ``whole_shadow_in_window``).

    Second figures: ``shadow_in_fov_ratio_2alt`` counts every target from
    ``FOV_MIN_AHEAD_ALTITUDES`` altitudes ahead that some tilt could show whole (holdable
    or not; where such targets conflict, only as many as the best single tilt could show
    count), and ``shadow_in_fov_ratio_all`` every within-range target-frame including the
    settling ones. ``shadow_time_by_target`` gives, per target, the seconds it was within
    range, in the near band, and out of view while within range.
    """
    from planner.pitch.control import DEFAULT_MOUNT, describe_zone, loop_config

    if mount is None:
        mount = DEFAULT_MOUNT  # the mount the executor commands
    tilt_grid = np.arange(mount.min_tilt_rad, mount.max_tilt_rad + 0.5 * FOV_TILT_STEP_RAD, FOV_TILT_STEP_RAD)
    azimuths = np.asarray(beam_azimuth_rad if beam_azimuth_rad is not None else
                          np.linspace(-settings.sonar.fan_width_rad / 2, settings.sonar.fan_width_rad / 2, n_beams))
    aperture = settings.sonar.elevation_aperture_rad
    window_end_m = settings.sonar.window_end_m
    track = _track_figures(run, sim, settings)
    frame_dt = _frame_period_s(sim)
    counts = {"zone_within": 0, "zone_inside": 0, "alt_within": 0, "alt_inside": 0, "alt_conflict": 0,
              "all_within": 0, "all_inside": 0, "unshowable": 0, "model_checked": 0, "model_agrees": 0}
    per_target: dict[str, dict[str, float]] = {}
    rows = []
    pass_starts = [t for t, state in result.states if state.startswith("PASS_")]
    entered: dict[str, dict[str, float]] = {"zone": {}, "2alt": {}}
    for t_s, truth in sim.sonar_truths():
        pose, altitude = truth.pose, truth.altitude_m
        in_pass = any(0.0 <= t_s - start for start in pass_starts) and all(
            not 0.0 <= t_s - start < FOV_SETTLE_S for start in pass_starts)
        alt_scored: list[tuple[bool, np.ndarray]] = []
        for tt in truth.targets:
            in_fov = bool(tt.whole_shadow_in_band) and bool(tt.whole_shadow_in_window)
            ahead = (tt.north_m - pose.north_m) * math.cos(pose.heading_rad) + \
                (tt.east_m - pose.east_m) * math.sin(pose.heading_rad)
            in_fan = len(tt.beams) > 0 and int(min(tt.beams)) > 0 and int(max(tt.beams)) < n_beams - 1
            base = bool(tt.whole_shadow_in_window) and in_fan and ahead >= FOV_MIN_AHEAD_ALTITUDES * altitude
            visible = holdable = np.zeros(tilt_grid.shape, dtype=bool)
            if base:
                beams_az = azimuths[np.asarray(tt.beams, dtype=int)]
                visible = visible_tilts(tt, azimuths, tilt_grid, altitude_m=altitude, pitch_rad=pose.pitch_rad,
                                        roll_rad=pose.roll_rad, aperture_rad=aperture)
                # The judge's geometry checked against the simulator's own flag at the true tilt.
                here = shadow_visible_at_tilts(
                    beams_az, np.asarray(tt.shadow_start_m), np.asarray(tt.shadow_end_m), altitude_m=altitude,
                    pitch_rad=pose.pitch_rad, roll_rad=pose.roll_rad, tilt_rad=np.array([pose.tilt_rad]),
                    elevation_aperture_rad=aperture)
                counts["model_checked"] += 1
                counts["model_agrees"] += int(bool(here[0]) == bool(tt.whole_shadow_in_band))
                holdable = holdable_tilts(
                    beams_az, np.asarray(tt.shadow_start_m), np.asarray(tt.shadow_end_m), altitude_m=altitude,
                    pitch_rad=pose.pitch_rad, roll_rad=pose.roll_rad, tilt_grid=tilt_grid,
                    aperture_rad=aperture - 2.0 * FOV_EDGE_MARGIN_RAD, window_end_m=window_end_m)
            in_range = {"zone": base and bool(holdable.any()), "2alt": base and bool(visible.any() or in_fov)}
            settled = {}
            for z in ("zone", "2alt"):
                if in_range[z]:
                    entered[z].setdefault(tt.target_id, t_s)
                else:
                    entered[z].pop(tt.target_id, None)
                settled[z] = in_range[z] and in_pass and t_s - entered[z].get(tt.target_id, t_s) >= FOV_SETTLE_S
            stats = per_target.setdefault(str(tt.target_id), {"within_range_s": 0.0, "out_of_view_s": 0.0,
                                                              "near_band_s": 0.0})
            if in_range["zone"]:
                counts["all_within"] += 1
                counts["all_inside"] += int(in_fov)
                stats["within_range_s"] += frame_dt
                stats["out_of_view_s"] += 0.0 if in_fov else frame_dt
            elif in_range["2alt"]:
                stats["near_band_s"] += frame_dt
            if settled["zone"]:
                counts["zone_within"] += 1
                counts["zone_inside"] += int(in_fov)
            if settled["2alt"]:
                alt_scored.append((in_fov, visible | in_fov))
            elif base and in_pass and not in_range["2alt"]:
                counts["unshowable"] += 1
            rows.append([f"{t_s:.2f}", tt.target_id, int(in_range["zone"]), int(in_range["2alt"]), int(in_fov),
                         int(settled["zone"]), int(bool(visible.any()) or in_fov)])
        if alt_scored:
            shown = sum(int(v) for v, _ in alt_scored)
            best = max(int(np.max(np.sum([m for _, m in alt_scored], axis=0))), shown)
            counts["alt_conflict"] += int(best < len(alt_scored))
            counts["alt_within"] += best
            counts["alt_inside"] += shown
    run.write_csv("shadows.csv", ("t_s", "target_id", "within_range", "within_2alt", "in_fov", "settled", "showable"),
                  rows)
    zone_config = loop_config(settings, nominal_tilt_rad=0.0)  # for the log only: the controller's own zone
    zone_doc = [{"pass": p.name, **describe_zone(zone_config, p.altitude_m)} for p in plan.passes] if plan else []

    def ratio(inside: int, within: int) -> float | None:
        return inside / within if within else None

    return {
        **height_summary(estimated, truth_targets),
        **track,
        "shadow_in_fov_ratio": ratio(counts["zone_inside"], counts["zone_within"]),
        "shadow_frames_within_range": counts["zone_within"],
        "shadow_in_fov_ratio_2alt": ratio(counts["alt_inside"], counts["alt_within"]),
        "shadow_frames_within_range_2alt": counts["alt_within"],
        "shadow_frames_in_conflict_2alt": counts["alt_conflict"],
        "shadow_in_fov_ratio_all": ratio(counts["all_inside"], counts["all_within"]),
        "shadow_frames_unshowable": counts["unshowable"],
        "shadow_fov_model_agreement": ratio(counts["model_agrees"], counts["model_checked"]),
        "shadow_time_by_target": {k: {n: round(v, 2) for n, v in d.items()} for k, d in sorted(per_target.items())},
        "tracking_zone": zone_doc,
        "shadow_in_fov_definition": (
            "a target counts (within range) in a survey frame when, in the simulator's truth, its whole shadow lies "
            f"in the range window and the fan, its centre at least {FOV_MIN_AHEAD_ALTITUDES:g} altitudes ahead, and "
            "one tilt within the mount's limits shows its whole shadow and the seabed at the window's end, "
            f"{math.degrees(FOV_EDGE_MARGIN_RAD):.2f} deg inside both aperture edges, at the frame's true attitude; "
            f"the first {FOV_SETTLE_S:g} s of a pass or of a target coming into range are left out; the ratio is "
            "the share of those target-frames whose whole shadow was in the field of view. "
            "shadow_in_fov_ratio_2alt: every target from "
            f"{FOV_MIN_AHEAD_ALTITUDES:g} altitudes ahead that some tilt could show whole, counted up to the most "
            "one tilt could show where they conflict"),
    }


def score_altitude(run: RunFolder, sim: VehicleSimulator, result: DiveResult, limits: AltitudeLimits,
                   std_at: Callable[[float], float]) -> dict[str, Any]:
    """The simulator's true altitude through the controller's altitude checks
    (:mod:`planner.mission.altitude_watch`: below the pass by more than the filter's 3 sigma at
    that moment, ``std_at(t_s)``, or below the clearance); each excursion is a warning in
    ``events.jsonl`` (``source`` ``"truth"``) and an entry of ``altitude_excursions_true``."""
    watch = AltitudeWatch(limits, source="truth")
    samples = [(h.time_s, h.altitude_m, std_at(h.time_s)) for h in sim.truth_history() if h.armed]
    for t_s, kind, message, fields in replay(watch, samples, result.states):
        run.event(t_s, kind, message, **fields)
    return {"altitude_excursions_true": [ex.to_dict() for ex in watch.excursions]}


def _track_figures(run: RunFolder, sim: VehicleSimulator, settings: Settings) -> dict[str, Any]:
    """Clearance and depth limit from the true track; writes ``truth_track.csv``."""
    history = sim.truth_history()
    run.write_csv("truth_track.csv", ("t_s", "north_m", "east_m", "depth_m", "altitude_m", "tilt_deg", "armed"),
                  [[f"{h.time_s:.2f}", f"{h.north_m:.3f}", f"{h.east_m:.3f}", f"{h.depth_m:.3f}", f"{h.altitude_m:.3f}",
                    f"{math.degrees(h.tilt_rad):.2f}", int(h.armed)] for h in history])
    armed = [h for h in history if h.armed]
    return {
        "min_clearance_m": min((h.altitude_m for h in armed), default=math.nan),
        "depth_limit_violations": sum(1 for h in history if h.depth_m > settings.vehicle.max_depth_m),
    }


def _frame_period_s(sim: VehicleSimulator) -> float:
    """The time between two rendered frames, s (for seconds per target)."""
    times = [t for t, _ in sim.sonar_truths()]
    return float(np.median(np.diff(times))) if len(times) > 1 else 0.0
