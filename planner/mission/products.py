"""The products of a dive, written into the run folder: targets, mosaic, summary.

Called during the dive (every few simulated minutes, so a crash leaves recent complete
files) and once at the end. Nothing here knows whether the vehicle was simulated.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from perception.geodesy import LocalOrigin
from perception.mapping.heights_layer import MappedTarget
from perception.mapping.products import (
    MapRaster,
    write_geotiff,
    write_png_with_world_file,
    write_targets_geojson,
)
from perception.mapping.survey_map import SAME_TARGET_RADIUS_M, Drift
from planner.mission.executor_config import DiveResult
from planner.mission.onboard import OnboardPerception
from planner.mission.run_folder import RunFolder
from planner.report.figure_worker import FigureWorker

TARGET_COLUMNS = ("id", "lat_deg", "lon_deg", "north_m", "east_m", "height_m", "height_std_m", "frames_used",
                  "frames_seen", "reason")


@dataclass(frozen=True)
class Products:
    """What :func:`write_products` wrote."""

    targets: tuple[MappedTarget, ...]
    raster: MapRaster | None
    map_pending: bool = False  # mosaic_heights.png is being drawn by the figure process


def write_products(
    run: RunFolder,
    onboard: OnboardPerception,
    origin: LocalOrigin,
    *,
    truth_points: tuple[tuple[float, float, float], ...] = (),
    final: bool = False,
    figures: FigureWorker | None = None,
) -> Products:
    """Write ``targets.geojson``, ``targets.csv`` and the mosaic files (atomically).

    ``truth_points`` (north, east, height) are drawn on the map picture in simulation.
    The picture is rendered only when ``final`` (it is the slowest product); with
    ``figures`` it is drawn there, meanwhile: take its result (:meth:`FigureWorker.result`,
    :attr:`Products.map_pending`) before the run folder is complete.
    """
    targets = tuple(onboard.mapped_targets())
    write_targets_geojson(run.path("targets.geojson"), targets, origin)
    rows = []
    for t in targets:
        lat, lon = origin.to_lat_lon(t.north_m, t.east_m)
        rows.append([
            t.target_id, f"{float(lat):.8f}", f"{float(lon):.8f}", f"{t.north_m:.3f}", f"{t.east_m:.3f}",
            "" if math.isnan(t.height_m) else f"{t.height_m:.4f}",
            "" if math.isnan(t.height_std_m) else f"{t.height_std_m:.4f}",
            t.frames_used, t.properties.get("frames_seen", ""), t.properties.get("reason") or "",
        ])
    run.write_csv("targets.csv", TARGET_COLUMNS, rows)
    raster = onboard.map_raster(list(targets))
    if raster is not None:
        write_geotiff(run.path("mosaic.tif"), raster, origin)
        write_png_with_world_file(run.path("mosaic.png"), raster, origin)
        if final and figures is not None:
            figures.submit("map", run.path("mosaic_heights.png"), raster, targets, truth=truth_points)
            return Products(targets, raster, map_pending=True)
        if final:
            from planner.report.map_plot import render_map_png  # matplotlib: only when a map is drawn

            render_map_png(run.path("mosaic_heights.png"), raster, targets, truth=truth_points)
    return Products(targets, raster)


#: What ``n_targets`` counts, in summary.json: the same targets targets.csv, targets.geojson,
#: the map and the report show.
TARGET_COUNT_DEFINITION = (
    "targets on the map (targets.csv, targets.geojson, mosaic_heights.png, report.md): the height pipeline's "
    f"tracks, a track whose centre lies within {SAME_TARGET_RADIUS_M:g} m of a track solved from more frames "
    "folded into it as a fragment of the same target; n_tracks_raw counts the tracks before folding (a diagnostic "
    "of the tracker)")


def drift_document(drift: Drift | None) -> dict[str, Any] | None:
    """``summary.json``'s ``navigation_drift``: the registration's correction and what it means."""
    if drift is None:
        return None
    size = math.hypot(drift.north_m, drift.east_m)
    return {
        "correction_north_m": drift.north_m,
        "correction_east_m": drift.east_m,
        "correction_m": size,
        "correction_std_m": drift.std_m,
        "navigation_drift_north_m": -drift.north_m,
        "navigation_drift_east_m": -drift.east_m,
        "registrations_accepted": drift.accepted,
        "registrations_refused": drift.refused,
        "track_m": drift.travelled_m,
        "plausible_drift_max_m": drift.plausible_m,
        "meaning": (
            "registration matched later sonar frames against the seabed mosaic already built and found them "
            f"{size:.2f} m off: the vehicle's dead-reckoned navigation (DVL) is believed to have drifted by "
            f"({-drift.north_m:+.2f}, {-drift.east_m:+.2f}) m north, east (1-sigma {drift.std_m:.2f} m per axis) "
            "since it first mapped that seabed. The correction is added to the position of every later frame and "
            "of the targets placed from them, so a second pass lines up with the first. It is relative: the map as "
            "a whole keeps the drift of the first pass over each place. "
            + ("No registration was accepted, so nothing was corrected." if drift.accepted == 0 else
               f"It rests on {drift.accepted} accepted registrations ({drift.refused} refused) over "
               f"{drift.travelled_m:.0f} m of track; the navigation prior allows up to {drift.plausible_m:.2f} m "
               "after that track.")),
    }


def summary_document(result: DiveResult, onboard: OnboardPerception, *, wall_s: float,
                     abort_message: str | None = None, extra: dict[str, Any] | None = None) -> dict[str, Any]:
    """The fields of ``summary.json`` the controller itself knows (simulation adds truth).

    ``n_targets`` counts the mapped targets, the same ones every other product shows
    (:data:`TARGET_COUNT_DEFINITION`). ``abort_message`` (the failsafe event's text) goes
    into ``reason_detail`` of an aborted dive.
    """
    mapped = onboard.mapped_targets()
    status = onboard.status()
    doc: dict[str, Any] = {
        "status": result.status,
        "reason": result.reason,
        "message": result.message,
        "reason_detail": abort_message if result.status == "aborted" else None,
        "final_state": result.state,
        "states": [{"t_s": round(t, 2), "state": s} for t, s in result.states],
        "sim_duration_s": result.end_s - result.start_s,
        "wall_duration_s": wall_s,
        "min_altitude_estimated_m": result.min_clearance_seen_m if math.isfinite(result.min_clearance_seen_m) else None,
        "depth_limit_violations_estimated": result.depth_limit_violations,
        "depth_commands_clamped": result.commands_clamped,
        "safe_action": result.safe_action,
        "waypoints_reached": result.waypoints_reached,
        "preflight": result.preflight,
        "mount_frame": result.mount_frame,
        "ekf_origin_offset_m": list(result.origin_offset_m),
        "frames_processed": status.frames_used,
        "frames_skipped": status.frames_skipped,
        "frames_mapped": status.frames_mapped,
        "n_targets": len(mapped),
        "n_targets_with_height": sum(1 for t in mapped if math.isfinite(t.height_m)),
        "n_tracks_raw": len(onboard.targets()),
        "target_count_definition": TARGET_COUNT_DEFINITION,
        "filter_counters": status.filter_counters,
        "navigation_drift": drift_document(status.drift),
    }
    if extra:
        doc.update(extra)
    return doc
