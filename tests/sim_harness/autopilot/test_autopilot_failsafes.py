"""Failsafes: GCS heartbeat loss, depth limit, terrain (rangefinder) loss."""

from __future__ import annotations

import math

from sim_harness.autopilot.autopilot import AutopilotConfig, Mode
from sim_harness.faults import FaultConfig, TimeWindow
from sim_harness.simulator import VehicleConfig
from sim_harness.vehicle.sensors import FlatSeabed
from tests.sim_harness.autopilot.gcs_peer import M, running_vehicle


def _cfg(**params: float) -> VehicleConfig:
    return VehicleConfig(start_depth_m=3.0, autopilot=AutopilotConfig(params=dict(params)))


def test_gcs_heartbeat_loss_disarms_by_default():
    with running_vehicle(config=_cfg()) as (sim, gcs):
        assert gcs.arm().result == M.MAV_RESULT_ACCEPTED
        gcs.run_for(8.0)
        assert sim.truth().armed  # heartbeats keep it quiet
        gcs.auto_heartbeat = False
        gcs.run_for(4.0)
        assert sim.truth().armed  # FS_GCS_TIMEOUT is 5 s
        gcs.run_for(3.0)
        assert not sim.truth().armed
        assert any("Lost GCS heartbeat" in m.text for m in gcs.log if m.get_type() == "STATUSTEXT")


def test_gcs_heartbeat_loss_surfaces_when_configured():
    with running_vehicle(config=_cfg(FS_GCS_ENABLE=4)) as (sim, gcs):
        assert gcs.set_mode(int(Mode.ALT_HOLD)).result == M.MAV_RESULT_ACCEPTED
        assert gcs.arm().result == M.MAV_RESULT_ACCEPTED
        gcs.auto_heartbeat = False
        hb = gcs.wait_for("HEARTBEAT", 10.0, lambda m: m.custom_mode == Mode.SURFACE)
        assert hb is not None and hb.system_status == M.MAV_STATE_CRITICAL
        gcs.run_for(40.0)
        assert sim.truth().depth_m < 0.3  # it went to the surface
        gcs.auto_heartbeat = True
        hb = gcs.wait_for("HEARTBEAT", 3.0, lambda m: m.system_status == M.MAV_STATE_ACTIVE)
        assert hb is not None  # failsafe clears when heartbeats return


def test_heartbeats_from_another_system_do_not_count():
    with running_vehicle(config=_cfg(SYSID_MYGCS=200)) as (sim, gcs):
        assert gcs.arm().result == M.MAV_RESULT_ACCEPTED
        gcs.run_for(10.0)  # our heartbeats come from system 255, not 200
        assert sim.truth().armed  # no heartbeat from 200 ever: failsafe not engaged


def test_depth_limit_sends_the_sub_up():
    cfg = _cfg(FENCE_ENABLE=1, FENCE_ALT_MIN=-6.0)
    with running_vehicle(FlatSeabed(30.0), config=cfg) as (sim, gcs):
        assert gcs.set_mode(int(Mode.ALT_HOLD)).result == M.MAV_RESULT_ACCEPTED
        assert gcs.arm().result == M.MAV_RESULT_ACCEPTED
        deepest = 0.0
        hb = None
        for _ in range(30 * 50):  # pilot pushes down hard
            gcs.mav.manual_control_send(1, 0, 0, 0, 0, 0)
            for m in gcs.tick():
                if m.get_type() == "HEARTBEAT" and m.custom_mode == Mode.SURFACE:
                    hb = m
            deepest = max(deepest, sim.truth().depth_m)
            if hb is not None:
                break
        assert hb is not None
        assert 6.0 < deepest < 7.0
        gcs.run_for(30.0)
        assert sim.truth().depth_m < 1.0


def test_terrain_failsafe_when_the_rangefinder_drops_out_in_auto():
    faults = FaultConfig(altimeter_dropouts=(TimeWindow(15.0, 60.0),))
    cfg = _cfg(FS_TERRAIN_ENAB=2)
    with running_vehicle(FlatSeabed(12.0), config=cfg, faults=faults) as (sim, gcs):
        lat = 47.0 + math.degrees(40.0 / 6378137.0)
        items = [
            M.MAVLink_mission_item_int_message(
                1, 1, seq, frame, M.MAV_CMD_NAV_WAYPOINT, 0, 1, 0, 0, 0, 0,
                int(round(la * 1e7)), 80000000, z, 0)
            for seq, frame, la, z in [
                (0, M.MAV_FRAME_GLOBAL, 47.0, 0.0),
                (1, M.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT, lat, 4.0),
            ]
        ]
        gcs.mav.mission_count_send(1, 1, 2, 0)
        for _ in range(2):
            req = gcs.wait_for("MISSION_REQUEST", 2.0)
            gcs.mav.send(items[req.seq])
        assert gcs.wait_for("MISSION_ACK", 2.0).type == M.MAV_MISSION_ACCEPTED
        assert gcs.arm().result == M.MAV_RESULT_ACCEPTED
        assert gcs.set_mode(int(Mode.AUTO)).result == M.MAV_RESULT_ACCEPTED
        gcs.run_for(14.0)
        assert abs(sim.truth().altitude_m - 4.0) < 1.0  # tracking the terrain target
        hb = gcs.wait_for("HEARTBEAT", 5.0, lambda m: m.custom_mode == Mode.SURFACE)
        assert hb is not None
        assert any("Terrain data lost" in m.text for m in gcs.log if m.get_type() == "STATUSTEXT")
