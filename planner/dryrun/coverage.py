"""The judge's coverage: how much of the survey area each pass's sonar really saw.

From the simulator's truth of the rendered frames (true position, heading, attitude, tilt
and altitude), each frame's insonified seabed: on each beam, the slant ranges of the range
window whose seabed point lies inside the vertical aperture (the geometry of
:mod:`planner.dryrun.shadow_view`, a level seabed at the frame's true altitude), placed
on the ground along the beam's bearing. The union of those footprints over a pass, cut to
the area's coverage region (the boundary less holes and keep-outs), over the region's
area is that pass's coverage; the share seen by both passes is what the method needs (a
target's height comes from its shadow at two altitudes). Nothing here comes from the
planner's footprint model or the controller.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np
import shapely

from perception.geometry import rot_x, rot_y

#: Beams and slant ranges sampled per footprint (the fan's edges and the window's ends included).
FOOTPRINT_BEAMS = 17
FOOTPRINT_SLANTS = 96
#: Frames are taken about this far apart along the track (their footprints overlap by metres).
FRAME_SPACING_M = 0.25


def insonified_ground(*, north_m: float, east_m: float, heading_rad: float, pitch_rad: float, roll_rad: float,
                      tilt_rad: float, altitude_m: float, beam_azimuth_rad: np.ndarray, window_start_m: float,
                      window_end_m: float, elevation_aperture_rad: float) -> shapely.Polygon | None:
    """The seabed one ping insonifies, as a polygon in local ``(east_m, north_m)``; None if none.

    A seabed point at slant ``r`` on a beam of azimuth ``az`` lies at the elevation ``e``
    (nearest the beam axis) with ``r (A cos e + B sin e) = H``, ``(A, B)`` from the third
    row of the sonar-to-level rotation; it is seen when ``|e|`` is within half the aperture.
    Its ground range is ``sqrt(r^2 - H^2)`` along the bearing ``heading + az``.
    """
    if not (math.isfinite(altitude_m) and altitude_m > 0.0):
        return None
    az = np.asarray(beam_azimuth_rad, dtype=np.float64)
    az = np.linspace(float(az.min()), float(az.max()), FOOTPRINT_BEAMS)
    slant = np.linspace(window_start_m, window_end_m, FOOTPRINT_SLANTS)
    row = (rot_y(pitch_rad) @ rot_x(roll_rad) @ rot_y(-tilt_rad))[2]
    a = row[0] * np.cos(az) + row[1] * np.sin(az)
    b = np.full_like(a, row[2])
    amp, phi = np.hypot(a, b), np.arctan2(b, a)
    ratio = altitude_m / (slant[:, None] * amp[None, :])
    spread = np.arccos(np.clip(ratio, -1.0, 1.0))
    e1 = np.mod(phi - spread + math.pi, 2 * math.pi) - math.pi
    e2 = np.mod(phi + spread + math.pi, 2 * math.pi) - math.pi
    e = np.where(np.abs(e1) <= np.abs(e2), e1, e2)
    seen = (ratio <= 1.0) & (np.abs(e) <= elevation_aperture_rad / 2.0)
    ground = np.sqrt(np.maximum(slant**2 - altitude_m**2, 0.0))
    near, far = [], []
    for j in range(az.size):
        hits = np.flatnonzero(seen[:, j])
        if hits.size == 0:
            continue
        bearing = heading_rad + az[j]
        for g, side in ((ground[hits[0]], near), (ground[hits[-1]], far)):
            side.append((east_m + g * math.sin(bearing), north_m + g * math.cos(bearing)))
    if len(near) < 2:
        return None
    polygon = shapely.Polygon(near + far[::-1])
    return polygon if polygon.is_valid else polygon.buffer(0)


def pass_intervals(states: Sequence[tuple[float, str]], end_s: float) -> dict[str, tuple[float, float]]:
    """``{"PASS_1": (start_s, end_s), ...}`` from the executor's state changes."""
    out: dict[str, tuple[float, float]] = {}
    for i, (t_s, state) in enumerate(states):
        if state.startswith("PASS_"):
            stop = states[i + 1][0] if i + 1 < len(states) else end_s
            out[state] = (t_s, stop)
    return out


def pass_coverage(frames: Iterable[tuple[float, Any]], passes: dict[str, tuple[float, float]],
                  region: shapely.Geometry, *, beam_azimuth_rad: np.ndarray, window_start_m: float,
                  window_end_m: float, elevation_aperture_rad: float) -> dict[str, Any]:
    """Shares of ``region`` (0-1) seen by each pass, by every pass and by any, from ``frames``
    ``(t_s, FrameTruth)``; with the region's area in m^2."""
    footprints: dict[str, list[shapely.Polygon]] = {name: [] for name in passes}
    last: dict[str, tuple[float, float]] = {}
    for t_s, truth in frames:
        name = next((n for n, (t0, t1) in passes.items() if t0 <= t_s < t1), None)
        if name is None:
            continue
        pose = truth.pose
        previous = last.get(name)
        if previous is not None and math.hypot(pose.north_m - previous[0], pose.east_m - previous[1]) \
                < FRAME_SPACING_M:
            continue
        last[name] = (pose.north_m, pose.east_m)
        polygon = insonified_ground(north_m=pose.north_m, east_m=pose.east_m, heading_rad=pose.heading_rad,
                                    pitch_rad=pose.pitch_rad, roll_rad=pose.roll_rad, tilt_rad=pose.tilt_rad,
                                    altitude_m=truth.altitude_m, beam_azimuth_rad=beam_azimuth_rad,
                                    window_start_m=window_start_m, window_end_m=window_end_m,
                                    elevation_aperture_rad=elevation_aperture_rad)
        if polygon is not None and not polygon.is_empty:
            footprints[name].append(polygon)
    area = float(region.area)
    seen = {name: shapely.union_all(polys).intersection(region) if polys else shapely.Polygon()
            for name, polys in footprints.items()}
    out: dict[str, Any] = {"region_m2": round(area, 2)}
    for name, geometry in seen.items():
        out[name.lower()] = round(float(geometry.area) / area, 4) if area > 0 else None
    if seen and area > 0:
        every = seen[next(iter(seen))]
        for geometry in list(seen.values())[1:]:
            every = every.intersection(geometry)
        out["every_pass"] = round(float(every.area) / area, 4)
        out["any_pass"] = round(float(shapely.union_all(list(seen.values())).area) / area, 4)
    return out
