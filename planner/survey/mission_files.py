"""Mission files from a :class:`SurveyPlan`: QGroundControl ``.plan``, Mission Planner
``.waypoints`` and GeoJSON.

One list of :class:`MissionItem` (built by :func:`mission_items`, pure) feeds both
mission formats, in what ArduSub 4.5 runs in AUTO (``Sub::start_command``,
ArduSub/commands_logic.cpp):

- per pass: ``MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW`` (1000) with param1 = the mount pitch
  in whole degrees (ArduPilot's convention, negative = down, so ``-tilt``; AP_Mission
  stores it as an int8, so it is rounded here rather than truncated there) and param2 =
  yaw 0; for ArduSub's default stabilised mount (MNT1_TYPE 1) that is an earth-frame
  angle, which is what the plan's tilt is. AP_Mission runs this command itself.
  ``DO_MOUNT_CONTROL`` and ``DO_CHANGE_SPEED`` are *not* used: Sub 4.5 reads their
  packed parameters as a location and refuses them ("Bad alt frame"), so in a Sub
  mission they have no effect. The AUTO speed is the vehicle's ``WPNAV_SPEED``.
- then one ``MAV_CMD_NAV_WAYPOINT`` (16) per waypoint of the pass, param1 (hold) 0 and
  param2 0: a sub keeps no per-waypoint acceptance radius (WPNAV_RADIUS for all).

Altitude of the waypoints (``[mission] altitude_reference``):

- ``"seabed"`` (default): the altitude above the seabed in ``MAV_FRAME_GLOBAL_TERRAIN_ALT``
  (10), alt >= 0. ArduSub 4.5 flies these in AUTO by its downward rangefinder
  (``AC_WPNav`` with WPNAV_RFND_USE 1 and RNGFND1_TYPE/ORIENT set; the Sub-4.5 branch
  has "support ABOVE_TERRAIN frame in auto"), so the vehicle holds the survey altitude
  over a seabed that slopes. This is what a survey that must keep its altitude needs.
  Without a rangefinder the item gives "Terrain data (rangefinder) not available" and
  the terrain failsafe (FS_TERRAIN_ENAB, default 0 = disarm).
- ``"depth"``: ``-depth`` in ``MAV_FRAME_GLOBAL_RELATIVE_ALT`` (3), alt <= 0 below home
  (the surface): a fixed depth, for a vehicle without a rangefinder on flat ground.

Absolute-frame (0) waypoints are refused by Sub at run time ("Bad alt frame").

The values are those ArduSub keeps (AP_Mission ``mavlink_int_to_mission_cmd``): latitude
and longitude in whole 1e-7 degrees, the altitude in whole centimetres (rounded here:
AP_Mission truncates ``z * 100.0f``, which would turn 0.99999 m into 99 cm; whole
centimetres below 163 m survive that float32 product exactly). A mission read back from
the vehicle is then the file itself, home aside.

The ``.plan`` carries what QGroundControl's loader requires (PlanMasterController /
MissionController::_loadJsonMissionFileV2 / SimpleMissionItem): ``fileType`` "Plan",
``version`` 1, ``groundStation`` (string), ``mission`` {``version`` 2, ``firmwareType``
3 (MAV_AUTOPILOT_ARDUPILOTMEGA), ``vehicleType`` 12 (MAV_TYPE_SUBMARINE),
``cruiseSpeed``, ``hoverSpeed``, ``plannedHomePosition`` [lat, lon, alt], ``items``},
``geoFence`` and ``rallyPoints`` (version 2, empty). Each item: ``type`` "SimpleItem",
``autoContinue``, ``command``, ``doJumpId`` (1-based), ``frame``, ``params`` (7 values).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from perception.atomic_file import atomic_write_text
from planner.survey.area import SurveyArea, area_to_geojson
from planner.survey.footprint import Footprint, swept_polygon
from planner.survey.plan import SurveyPlan

MAV_CMD_NAV_WAYPOINT = 16
MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW = 1000
MAV_FRAME_GLOBAL = 0
MAV_FRAME_MISSION = 2
MAV_FRAME_GLOBAL_RELATIVE_ALT = 3
MAV_FRAME_GLOBAL_TERRAIN_ALT = 10
MAV_AUTOPILOT_ARDUPILOTMEGA = 3
MAV_TYPE_SUBMARINE = 12


@dataclass(frozen=True)
class MissionItem:
    """One MAVLink mission item (params 1-7 as MAVLink orders them; lat/lon in degrees)."""

    command: int
    frame: int
    params: tuple[float, float, float, float, float, float, float]
    autocontinue: bool = True


def mission_items(plan: SurveyPlan, *, altitude_reference: str = "seabed") -> tuple[MissionItem, ...]:
    """The mission (without the home item) for a plan; see the module docstring.

    Raises
    ------
    ValueError
        For an unknown ``altitude_reference``.
    """
    if altitude_reference not in ("seabed", "depth"):
        raise ValueError(f"altitude_reference must be 'seabed' or 'depth', got {altitude_reference!r}")
    items: list[MissionItem] = []
    for p in plan.passes:
        pitch_deg = float(round(-math.degrees(p.tilt_rad)))
        items.append(MissionItem(MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW, MAV_FRAME_MISSION,
                                 (pitch_deg, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)))
        if altitude_reference == "seabed":
            frame, alt = MAV_FRAME_GLOBAL_TERRAIN_ALT, p.altitude_m
        else:
            frame, alt = MAV_FRAME_GLOBAL_RELATIVE_ALT, -p.depth_m
        alt = round(alt * 100.0) / 100.0
        for w in p.waypoints:
            lat, lon = round(w.lat_deg * 1e7) / 1e7, round(w.lon_deg * 1e7) / 1e7
            items.append(MissionItem(MAV_CMD_NAV_WAYPOINT, frame, (0.0, 0.0, 0.0, 0.0, lat, lon, alt)))
    return tuple(items)


def qgc_plan(plan: SurveyPlan, items: tuple[MissionItem, ...]) -> dict[str, Any]:
    """The QGroundControl ``.plan`` document (a dict ready for ``json.dump``)."""
    speed = plan.summary.speed_m_s
    return {
        "fileType": "Plan",
        "version": 1,
        "groundStation": "shadowsurvey",
        "mission": {
            "version": 2,
            "firmwareType": MAV_AUTOPILOT_ARDUPILOTMEGA,
            "vehicleType": MAV_TYPE_SUBMARINE,
            "cruiseSpeed": speed,
            "hoverSpeed": speed,
            "plannedHomePosition": [plan.origin_lat_deg, plan.origin_lon_deg, 0.0],
            "items": [
                {
                    "type": "SimpleItem",
                    "autoContinue": it.autocontinue,
                    "command": it.command,
                    "doJumpId": i,
                    "frame": it.frame,
                    "params": [None if math.isnan(v) else v for v in it.params],
                }
                for i, it in enumerate(items, start=1)
            ],
        },
        "geoFence": {"version": 2, "circles": [], "polygons": []},
        "rallyPoints": {"version": 2, "points": []},
    }


def waypoints_text(plan: SurveyPlan, items: tuple[MissionItem, ...]) -> str:
    """Mission Planner ``.waypoints`` text: ``QGC WPL 110``, then the home line (seq 0),
    then one tab-separated line per item: seq, current, frame, command, p1..p4, lat,
    lon, alt, autocontinue (8 decimals)."""

    def line(seq: int, current: int, it: MissionItem) -> str:
        nums = "\t".join(f"{v:.8f}" for v in it.params)
        return f"{seq}\t{current}\t{it.frame}\t{it.command}\t{nums}\t{int(it.autocontinue)}"

    home = MissionItem(MAV_CMD_NAV_WAYPOINT, MAV_FRAME_GLOBAL,
                       (0.0, 0.0, 0.0, 0.0, plan.origin_lat_deg, plan.origin_lon_deg, 0.0))
    lines = ["QGC WPL 110", line(0, 1, home)]
    lines += [line(i, 0, it) for i, it in enumerate(items, start=1)]
    return "\n".join(lines) + "\n"


def plan_geojson(plan: SurveyPlan, area: SurveyArea, *, footprint_every: int = 1) -> dict[str, Any]:
    """GeoJSON (WGS84) of the area, each pass's path and lane runs, and the sonar
    footprint swept by each run (``footprint_every``: keep every n-th)."""
    doc = area_to_geojson(area)
    shapes: list[tuple[dict[str, Any], str, np.ndarray]] = []
    for p in plan.passes:
        path = np.array([[w.east_m, w.north_m] for w in p.waypoints])
        shapes.append(({"role": "path", "pass": p.name, "altitude_m": p.altitude_m,
                        "tilt_deg": math.degrees(p.tilt_rad)}, "LineString", path))
        fp = Footprint(p.altitude_m, p.tilt_rad, p.near_ground_m, p.far_ground_m,
                       math.atan(p.swath_m / (2 * p.near_ground_m)))
        for i, r in enumerate(p.runs):
            seg = np.array([[r.start_east_m, r.start_north_m], [r.end_east_m, r.end_north_m]])
            shapes.append(({"role": "lane", "pass": p.name, "lane": r.lane}, "LineString", seg))
            if i % footprint_every or r.length_m <= 0:
                continue
            ring = np.asarray(swept_polygon(fp, tuple(seg[0]), tuple(seg[1])).exterior.coords)
            shapes.append(({"role": "footprint", "pass": p.name, "lane": r.lane}, "Polygon", ring))
    # One geodetic conversion for every vertex, then split back per feature.
    allxy = np.vstack([xy for _, _, xy in shapes])
    lat, lon = area.origin.to_lat_lon(allxy[:, 1], allxy[:, 0])
    lonlat = np.round(np.column_stack([lon, lat]), 9).tolist()
    feats = list(doc["features"])
    at = 0
    for props, kind, xy in shapes:
        coords = lonlat[at:at + len(xy)]
        at += len(xy)
        feats.append({"type": "Feature", "properties": props,
                      "geometry": {"type": kind,
                                   "coordinates": [coords] if kind == "Polygon" else coords}})
    return {"type": "FeatureCollection", "features": feats}


def _area_text(area_m2: float) -> str:
    """An area with its figures kept: 12,309 m^2, 14.2 m^2 (never "0 m^2" for a small one)."""
    return f"{area_m2:,.0f} m^2" if area_m2 >= 100 else f"{area_m2:.3g} m^2"


def summary_text(plan: SurveyPlan) -> str:
    """A short human-readable summary of the plan."""
    s = plan.summary
    lines = [
        f"origin               {plan.origin_lat_deg:.7f}, {plan.origin_lon_deg:.7f}",
        f"area to cover        {_area_text(s.area_m2)} (water depth {plan.water_depth_m:g} m)",
        f"lanes                {s.n_lanes} at heading {math.degrees(s.lane_heading_rad):.1f} deg, "
        f"spacing {s.lane_spacing_m:.2f} m ({s.n_runs} runs over both passes)",
    ]
    for p in plan.passes:
        lines.append(
            f"{p.name:<20} altitude {p.altitude_m:.2f} m (depth {p.depth_m:.2f} m), tilt "
            f"{math.degrees(p.tilt_rad):.1f} deg, band {p.near_ground_m:.2f}-{p.far_ground_m:.2f} m "
            f"ahead, swath {p.swath_m:.2f} m; {p.length_m / 1000:.3f} km, "
            f"{p.duration_s / 60:.1f} min, coverage {100 * p.coverage_fraction:.2f} % "
            f"({p.uncovered_area_m2:.1f} m^2 missed)"
        )
        lines.append(
            f"{'':<20} lead-in {p.lead_in_m:.2f} m; path stays within {p.excursion_limit_m:.2f} m "
            f"of the boundary (max {p.max_excursion_m:.2f} m)"
        )
    lines += [
        f"total                {s.total_length_m / 1000:.3f} km, {s.total_duration_s / 3600:.2f} h "
        f"at {s.speed_m_s:g} m/s" + (" (stay inside)" if s.stay_inside else ""),
        f"height resolution    {1000 * s.height_resolution_m:.2f} mm per range sample of shadow "
        f"change ({s.samples_per_cm:.2f} samples/cm); dH error adds "
        f"{1000 * s.height_std_from_dh_m:.2f} mm (tallest target)",
        f"binding constraints  {', '.join(s.binding_constraints) or 'none'}",
    ]
    return "\n".join(lines) + "\n"


def write_outputs(plan: SurveyPlan, area: SurveyArea, out_dir: str | Path, *,
                  altitude_reference: str = "seabed", stem: str = "survey") -> dict[str, Path]:
    """Write plan.json, STEM.plan, STEM.waypoints, STEM.geojson and summary.txt to
    ``out_dir`` (created if needed); each file is written atomically (:mod:`perception.atomic_file`).
    Returns the paths by kind."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    items = mission_items(plan, altitude_reference=altitude_reference)
    n_fp = max(1, sum(len(p.runs) for p in plan.passes) // 2000)
    texts = {
        "plan_json": ("plan.json", plan.to_json()),
        "qgc_plan": (f"{stem}.plan", json.dumps(qgc_plan(plan, items), indent=2)),
        "waypoints": (f"{stem}.waypoints", waypoints_text(plan, items)),
        "geojson": (f"{stem}.geojson", json.dumps(plan_geojson(plan, area, footprint_every=n_fp))),
        "summary": ("summary.txt", summary_text(plan)),
    }
    return {kind: atomic_write_text(out / name, text) for kind, (name, text) in texts.items()}
