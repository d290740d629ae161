"""Mission files: QGroundControl's loader rules, Mission Planner's format via pymavlink."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import pytest
import shapely
from pymavlink import mavwp

from planner.config import default_settings
from planner.survey.altitudes import choose_altitudes
from planner.survey.area import SurveyArea, area_from_geojson
from planner.survey.lawnmower import plan_survey
from planner.survey.mission_files import (
    MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW,
    MAV_CMD_NAV_WAYPOINT,
    mission_items,
    plan_geojson,
    qgc_plan,
    waypoints_text,
    write_outputs,
)
from planner.survey.plan import SurveyPlan

SETTINGS = default_settings()


def qgc_loader_errors(doc: Any) -> list[str]:
    """The checks QGroundControl's loader makes on a .plan (PlanMasterController::loadFromJson,
    JsonHelper::validateQGCJsonFile, MissionController::_loadJsonMissionFileV2,
    SimpleMissionItem::load / MissionItem::load), for simple items."""
    errs: list[str] = []

    def need(obj: Any, key: str, kind: type | tuple[type, ...], where: str) -> bool:
        if not isinstance(obj, dict) or key not in obj:
            errs.append(f"{where}: missing key {key!r}")
            return False
        value = obj[key]
        ok = isinstance(value, kind) and not (kind in (int, float, (int, float)) and isinstance(value, bool))
        if not ok:
            errs.append(f"{where}.{key}: wrong type {type(value).__name__}")
        return ok

    if need(doc, "fileType", str, "root") and doc["fileType"] != "Plan":
        errs.append("root.fileType must be 'Plan'")
    if need(doc, "version", (int, float), "root") and doc["version"] != 1:
        errs.append("root.version must be 1")
    need(doc, "groundStation", str, "root")
    for key in ("mission", "geoFence", "rallyPoints"):
        need(doc, key, dict, "root")
    mission = doc.get("mission", {})
    if need(mission, "version", (int, float), "mission") and mission["version"] != 2:
        errs.append("mission.version must be 2")
    need(mission, "firmwareType", (int, float), "mission")
    for key in ("vehicleType", "cruiseSpeed", "hoverSpeed"):
        if key in mission:
            need(mission, key, (int, float), "mission")
    if need(mission, "plannedHomePosition", list, "mission"):
        home = mission["plannedHomePosition"]
        if len(home) != 3 or not all(isinstance(v, int | float) for v in home):
            errs.append("mission.plannedHomePosition must be [lat, lon, alt]")
    if need(mission, "items", list, "mission"):
        for i, item in enumerate(mission["items"]):
            where = f"items[{i}]"
            if need(item, "type", str, where) and item["type"] != "SimpleItem":
                errs.append(f"{where}.type must be SimpleItem")
            need(item, "autoContinue", bool, where)
            need(item, "command", (int, float), where)
            need(item, "frame", (int, float), where)
            if "doJumpId" in item:
                need(item, "doJumpId", (int, float), where)
            if need(item, "params", list, where):
                if len(item["params"]) != 7:
                    errs.append(f"{where}.params must hold 7 values")
                elif not all(v is None or isinstance(v, int | float) for v in item["params"]):
                    errs.append(f"{where}.params must be numbers or null")
    for key in ("geoFence", "rallyPoints"):
        sub = doc.get(key, {})
        need(sub, "version", (int, float), key)
    if isinstance(doc.get("geoFence"), dict):
        need(doc["geoFence"], "circles", list, "geoFence")
        need(doc["geoFence"], "polygons", list, "geoFence")
    if isinstance(doc.get("rallyPoints"), dict):
        need(doc["rallyPoints"], "points", list, "rallyPoints")
    return errs


@pytest.fixture(scope="module")
def plan_and_area() -> tuple[SurveyPlan, SurveyArea]:
    area = SurveyArea(43.2951, 5.3612, shapely.Polygon(
        [(0, 0), (60, 0), (60, 30), (30, 30), (30, 45), (0, 45)],
        [[(10, 10), (18, 10), (18, 16), (10, 16)]]))
    return plan_survey(area, SETTINGS, choice=choose_altitudes(SETTINGS), heading_rad=0.3), area


def test_validator_catches_what_qgc_rejects() -> None:
    good = {"fileType": "Plan", "version": 1, "groundStation": "x",
            "mission": {"version": 2, "firmwareType": 3, "plannedHomePosition": [1.0, 2.0, 0.0],
                        "items": [{"type": "SimpleItem", "autoContinue": True, "command": 16,
                                   "frame": 10, "params": [0, 1, 0, None, 1.0, 2.0, 3.0]}]},
            "geoFence": {"version": 2, "circles": [], "polygons": []},
            "rallyPoints": {"version": 2, "points": []}}
    assert qgc_loader_errors(good) == []
    bad = json.loads(json.dumps(good))
    bad["mission"]["items"][0]["params"] = [0, 0, 0, 0]
    bad["mission"]["items"][0]["autoContinue"] = 1
    del bad["rallyPoints"]
    bad["version"] = 2
    errs = qgc_loader_errors(bad)
    assert any("params must hold 7" in e for e in errs)
    assert any("autoContinue" in e for e in errs)
    assert any("rallyPoints" in e for e in errs)
    assert any("root.version" in e for e in errs)


@pytest.mark.parametrize("reference", ["seabed", "depth"])
def test_qgc_plan_passes_the_loader_rules(plan_and_area, reference: str) -> None:
    plan, _ = plan_and_area
    items = mission_items(plan, altitude_reference=reference)
    doc = json.loads(json.dumps(qgc_plan(plan, items)))
    assert qgc_loader_errors(doc) == []
    assert doc["mission"]["firmwareType"] == 3 and doc["mission"]["vehicleType"] == 12
    wps = [it for it in doc["mission"]["items"] if it["command"] == MAV_CMD_NAV_WAYPOINT]
    assert len(wps) == sum(len(p.waypoints) for p in plan.passes)
    if reference == "seabed":
        assert {it["frame"] for it in wps} == {10}
        alts = sorted({it["params"][6] for it in wps})  # whole centimetres, as ArduSub keeps them
        assert alts == sorted(round(p.altitude_m * 100) / 100 for p in plan.passes)
    else:
        assert {it["frame"] for it in wps} == {3}
        assert all(it["params"][6] < 0 for it in wps)
        assert sorted({-it["params"][6] for it in wps}) == sorted(
            round(p.depth_m * 100) / 100 for p in plan.passes)
    assert [it["doJumpId"] for it in doc["mission"]["items"]] == list(
        range(1, len(doc["mission"]["items"]) + 1))


def test_mount_tilt_precedes_each_pass_in_a_command_sub_4_5_runs(plan_and_area) -> None:
    """DO_GIMBAL_MANAGER_PITCHYAW (AP_Mission runs it itself; int8 whole degrees, yaw given);
    no DO_MOUNT_CONTROL or DO_CHANGE_SPEED, which Sub::start_command refuses ("Bad alt frame")."""
    plan, _ = plan_and_area
    items = mission_items(plan)
    assert {it.command for it in items} == {MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW, MAV_CMD_NAV_WAYPOINT}
    mounts = [i for i, it in enumerate(items) if it.command == MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW]
    assert len(mounts) == len(plan.passes)
    for idx, p in zip(mounts, plan.passes, strict=True):
        it = items[idx]
        assert it.params[0] == round(-math.degrees(p.tilt_rad))  # negative = down, whole degrees
        assert it.params[1] == 0.0 and not any(math.isnan(v) for v in it.params)
        nxt = items[idx + 1]
        assert nxt.command == MAV_CMD_NAV_WAYPOINT
        assert (nxt.params[4], nxt.params[5]) == pytest.approx((p.waypoints[0].lat_deg, p.waypoints[0].lon_deg),
                                                               abs=0.51e-7)  # whole 1e-7 degrees
        assert round(nxt.params[4] * 1e7) / 1e7 == nxt.params[4]


def test_waypoints_load_in_pymavlink_and_round_trip(plan_and_area, tmp_path: Path) -> None:
    plan, _ = plan_and_area
    items = mission_items(plan)
    text = waypoints_text(plan, items)
    lines = text.splitlines()
    assert lines[0] == "QGC WPL 110"
    assert all(len(line.split("\t")) == 12 for line in lines[1:])
    assert lines[2].split("\t")[8].split(".")[1].__len__() == 8
    path = tmp_path / "m.waypoints"
    path.write_text(text, encoding="utf-8")
    loader = mavwp.MAVWPLoader()
    assert loader.load(str(path)) == len(items) + 1
    home = loader.wp(0)
    assert (home.seq, home.current, home.x, home.y) == (0, 1, pytest.approx(plan.origin_lat_deg),
                                                        pytest.approx(plan.origin_lon_deg))
    for i, it in enumerate(items, start=1):
        w = loader.wp(i)
        assert (w.seq, w.frame, w.command, w.autocontinue) == (i, it.frame, it.command, 1)
        got = (w.param1, w.param2, w.param3, w.param4, w.x, w.y, w.z)
        assert got == pytest.approx(it.params, abs=1e-8)
    again = tmp_path / "again.waypoints"
    loader.save(str(again))
    loader2 = mavwp.MAVWPLoader()
    assert loader2.load(str(again)) == loader.count()
    for i in range(loader.count()):
        a, b = loader.wp(i), loader2.wp(i)
        assert (a.seq, a.frame, a.command) == (b.seq, b.frame, b.command)
        assert (a.x, a.y, a.z) == pytest.approx((b.x, b.y, b.z), abs=1e-6)


def test_outputs_are_written_and_reload(plan_and_area, tmp_path: Path) -> None:
    plan, area = plan_and_area
    paths = write_outputs(plan, area, tmp_path / "out")
    assert SurveyPlan.from_json(paths["plan_json"].read_text()) == plan
    assert qgc_loader_errors(json.loads(paths["qgc_plan"].read_text())) == []
    geo = json.loads(paths["geojson"].read_text())
    roles = [f["properties"]["role"] for f in geo["features"]]
    assert roles.count("boundary") == 1
    assert roles.count("path") == len(plan.passes)
    assert roles.count("lane") == sum(len(p.runs) for p in plan.passes)
    assert roles.count("footprint") > 0
    # The area inside the GeoJSON reads back as the same polygon.
    back = area_from_geojson(geo, origin=(area.origin_lat_deg, area.origin_lon_deg))
    assert shapely.hausdorff_distance(back.boundary, area.boundary) < 1e-3  # metres
    assert "height resolution" in paths["summary"].read_text()
    assert not list((tmp_path / "out").glob(".*.tmp"))
    assert plan_geojson(plan, area)["type"] == "FeatureCollection"
