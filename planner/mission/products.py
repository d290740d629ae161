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
from planner.mission.executor_config import DiveResult
from planner.mission.onboard import OnboardPerception
from planner.mission.run_folder import RunFolder
from planner.report.map_plot import render_map_png

TARGET_COLUMNS = ("id", "lat_deg", "lon_deg", "north_m", "east_m", "height_m", "height_std_m", "frames_used",
                  "frames_seen", "reason")


@dataclass(frozen=True)
class Products:
    """What :func:`write_products` wrote."""

    targets: tuple[MappedTarget, ...]
    raster: MapRaster | None


def write_products(
    run: RunFolder,
    onboard: OnboardPerception,
    origin: LocalOrigin,
    *,
    truth_points: tuple[tuple[float, float, float], ...] = (),
    final: bool = False,
) -> Products:
    """Write ``targets.geojson``, ``targets.csv`` and the mosaic files (atomically).

    ``truth_points`` (north, east, height) are drawn on the map picture in simulation.
    The picture is rendered only when ``final`` (it is the slowest product).
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
        if final:
            render_map_png(run.path("mosaic_heights.png"), raster, targets, truth=truth_points)
    return Products(targets, raster)


def summary_document(result: DiveResult, onboard: OnboardPerception, *, wall_s: float,
                     extra: dict[str, Any] | None = None) -> dict[str, Any]:
    """The fields of ``summary.json`` the controller itself knows (simulation adds truth)."""
    targets = onboard.targets()
    status = onboard.status()
    doc: dict[str, Any] = {
        "status": result.status,
        "reason": result.reason,
        "message": result.message,
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
        "n_targets": len(targets),
        "n_targets_with_height": sum(1 for t in targets if t.height_m is not None),
        "filter_counters": status.filter_counters,
        "mosaic_drift_correction_m": [status.drift.north_m, status.drift.east_m]
        if status.drift is not None else None,
    }
    if extra:
        doc.update(extra)
    return doc
