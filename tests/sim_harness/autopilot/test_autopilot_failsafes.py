"""ArduSub 4.5 failsafes (ArduSub/failsafe.cpp, fence.cpp) and who may fly the sub."""

from __future__ import annotations

import math

from sim_harness.autopilot.autopilot import Mode
from sim_harness.faults import FaultConfig, TimeWindow
from sim_harness.peers import BlueOsServices
from sim_harness.vehicle.sensors import FlatSeabed, SensorConfig
from tests.sim_harness.autopilot.gcs_peer import ORIGIN, M, running_vehicle, vehicle_config


def _cfg(**params: float):
    return vehicle_config(start_depth_m=3.0, params=params)


def _texts(gcs) -> list[str]:
    return [m.text for m in gcs.log if m.get_type() == "STATUSTEXT"]


def test_gcs_failsafe_disarms_2_5_s_after_the_last_heartbeat_by_default():
    """Sub::failsafe_gcs_check: FS_GCS_TIMEOUT_MS 2500 (fixed in 4.5), FS_GCS_ENABLE 2 = disarm;
    "MYGCS: 255, heartbeat lost"."""
    with running_vehicle(config=_cfg()) as (sim, gcs):
        assert gcs.arm().result == M.MAV_RESULT_ACCEPTED
        gcs.run_for(5.0)
        assert sim.truth().armed  # heartbeats (and MANUAL_CONTROL) keep it quiet
        gcs.auto_heartbeat = False  # the topside dies: no heartbeat, no MANUAL_CONTROL
        lost_s = gcs.clock.now_s()
        while sim.truth().armed:
            gcs.tick()
            assert gcs.clock.now_s() - lost_s < 4.0
        gcs.discard()
        assert 2.5 <= gcs.clock.now_s() - lost_s <= 2.5 + 0.31 + 0.05  # 3.3 Hz check
        assert "MYGCS: 255, heartbeat lost" in _texts(gcs)


def test_any_component_of_sysid_mygcs_counts_and_other_systems_do_not():
    """GCS_MAVLINK::handle_heartbeat: sysid == SYSID_MYGCS, any component and type. BlueOS's
    services heartbeat as system 1: with SYSID_MYGCS 1 the failsafe would never fire."""
    with running_vehicle(config=_cfg()) as (sim, gcs):
        assert gcs.arm().result == M.MAV_RESULT_ACCEPTED
        gcs.auto_heartbeat = False
        for _ in range(60):  # 6 s of heartbeats from system 255 component 1, type ONBOARD_CONTROLLER
            gcs.conn.mav.srcComponent = 1
            gcs.mav.heartbeat_send(M.MAV_TYPE_ONBOARD_CONTROLLER, M.MAV_AUTOPILOT_INVALID, 0, 0, 0)
            gcs.conn.mav.srcComponent = 190
            gcs.manual_control()
            gcs.run_for(0.1)
        assert sim.truth().armed
    # (MANUAL_CONTROL from 255 no longer counts either: the pilot failsafe is switched off here.)
    cfg = vehicle_config(start_depth_m=3.0, params={"SYSID_MYGCS": 1, "FS_PILOT_INPUT": 0}, peers=(BlueOsServices(),))
    with running_vehicle(config=cfg) as (sim, gcs):
        assert gcs.arm().result == M.MAV_RESULT_ACCEPTED
        gcs.auto_heartbeat = False
        gcs.run_for(10.0)
        assert sim.truth().armed  # mavlink2rest's heartbeats as system 1 keep the GCS failsafe quiet
        assert not sim.autopilot.failsafes.gcs


def test_no_gcs_failsafe_before_the_gcs_is_seen_and_warn_only_sets_critical():
    cfg = vehicle_config(start_depth_m=3.0, params={"SYSID_MYGCS": 200, "FS_PILOT_INPUT": 0})
    with running_vehicle(config=cfg) as (sim, gcs):
        assert gcs.arm().result == M.MAV_RESULT_ACCEPTED
        gcs.run_for(6.0)
        assert sim.truth().armed  # system 200 never heard: no failsafe
    with running_vehicle(config=_cfg(FS_GCS_ENABLE=1, FS_PILOT_INPUT=0)) as (sim, gcs):
        assert gcs.arm().result == M.MAV_RESULT_ACCEPTED
        gcs.auto_heartbeat = False
        gcs.run_for(3.5)
        assert sim.truth().armed and sim.autopilot.failsafes.gcs  # warn only: flag, no action
        hb = gcs.wait_for("HEARTBEAT", 1.5)
        assert hb.system_status == M.MAV_STATE_CRITICAL


def test_gcs_failsafe_surface_without_position_disarms_and_depth_hold_holds():
    """FS_GCS_ENABLE 4 calls set_mode(SURFACE), which 4.5 refuses without a position: then
    it disarms (GCS_FAILSAFE_SURFACEFAILED). 3 = ALT_HOLD works without one."""
    no_dvl = SensorConfig(has_position_estimate=False)
    cfg = vehicle_config(start_depth_m=3.0, sensors=no_dvl, params={"FS_GCS_ENABLE": 4, "FS_PILOT_INPUT": 0})
    with running_vehicle(FlatSeabed(30.0), config=cfg) as (sim, gcs):
        assert gcs.set_mode(int(Mode.ALT_HOLD)).result == M.MAV_RESULT_ACCEPTED
        assert gcs.arm().result == M.MAV_RESULT_ACCEPTED
        gcs.auto_heartbeat = False
        gcs.run_for(3.5)
        assert not sim.truth().armed
        assert "Mode change failed: SURFACE requires position" in _texts(gcs)
    cfg = vehicle_config(start_depth_m=3.0, sensors=no_dvl, params={"FS_GCS_ENABLE": 3, "FS_PILOT_INPUT": 0})
    with running_vehicle(FlatSeabed(30.0), config=cfg) as (sim, gcs):
        assert gcs.set_mode(int(Mode.MANUAL)).result == M.MAV_RESULT_ACCEPTED
        assert gcs.arm().result == M.MAV_RESULT_ACCEPTED
        gcs.auto_heartbeat = False
        hb = gcs.wait_for("HEARTBEAT", 4.0, lambda m: m.custom_mode == Mode.ALT_HOLD)
        assert hb is not None and hb.base_mode & 128 and hb.system_status == M.MAV_STATE_CRITICAL
        gcs.auto_heartbeat = True
        hb = gcs.wait_for("HEARTBEAT", 3.0, lambda m: m.system_status == M.MAV_STATE_ACTIVE)
        assert hb is not None and hb.custom_mode == Mode.ALT_HOLD  # cleared; the mode is not restored


def test_gcs_failsafe_surface_with_position_surfaces():
    with running_vehicle(FlatSeabed(30.0), config=_cfg(FS_GCS_ENABLE=4, FS_PILOT_INPUT=0)) as (sim, gcs):
        assert gcs.set_mode(int(Mode.ALT_HOLD)).result == M.MAV_RESULT_ACCEPTED
        assert gcs.arm().result == M.MAV_RESULT_ACCEPTED
        gcs.auto_heartbeat = False
        assert gcs.wait_for("HEARTBEAT", 4.0, lambda m: m.custom_mode == Mode.SURFACE)
        gcs.run_for(15.0)
        assert sim.truth().depth_m < 0.3 and sim.truth().armed


def test_pilot_input_failsafe_disarms_3_s_after_the_joystick_stops():
    """Sub::failsafe_pilot_input_check: FS_PILOT_INPUT 2, FS_PILOT_TIMEOUT 3 s; "Lost manual
    control"; the heartbeats alone do not feed it."""
    cfg = vehicle_config(start_depth_m=3.0, params={"FS_GCS_ENABLE": 0})
    with running_vehicle(config=cfg) as (sim, gcs):
        assert gcs.arm().result == M.MAV_RESULT_ACCEPTED
        gcs.run_for(4.0)
        assert sim.truth().armed
        gcs.auto_manual_control = False  # heartbeats go on
        stop_s = gcs.clock.now_s()
        while sim.truth().armed:
            gcs.tick()
            assert gcs.clock.now_s() - stop_s < 4.0
        assert 2.9 <= gcs.clock.now_s() - stop_s <= 3.1
        assert "Lost manual control" in _texts(gcs)
        gcs.discard()
        assert gcs.wait_for("HEARTBEAT", 1.5).system_status == M.MAV_STATE_CRITICAL


def test_pilot_input_failsafe_latches_at_boot_without_a_joystick_and_is_compiled_out_in_sitl():
    """On hardware the failsafe fires 3 s after boot with no MANUAL_CONTROL, not gated on
    arming, and acts once: arming later does not disarm. ArduPilot's SITL build has
    ``#if CONFIG_HAL_BOARD != HAL_BOARD_SITL`` around it."""
    with running_vehicle(config=_cfg()) as (sim, gcs):
        gcs.auto_manual_control = False
        gcs.run_for(4.0)
        hb = gcs.wait_for("HEARTBEAT", 1.5)
        assert hb.system_status == M.MAV_STATE_CRITICAL and "Lost manual control" in _texts(gcs)
        assert gcs.arm().result == M.MAV_RESULT_ACCEPTED
        gcs.run_for(5.0)
        assert sim.truth().armed  # latched: it already acted
    cfg = vehicle_config(start_depth_m=3.0, autopilot={"sitl_build": True})
    with running_vehicle(config=cfg) as (sim, gcs):
        gcs.auto_manual_control = False
        assert gcs.arm().result == M.MAV_RESULT_ACCEPTED
        gcs.run_for(5.0)
        assert sim.truth().armed and "Lost manual control" not in _texts(gcs)


def test_manual_control_only_from_sysid_mygcs_aimed_at_us():
    """GCS_MAVLINK_Sub::handle_message: msg.sysid == SYSID_MYGCS and target == SYSID_THISMAV
    (target 0 refused); a default joystick button 2 switches to ALT_HOLD (joystick.cpp)."""
    cfg = vehicle_config(start_depth_m=3.0, params={"FS_GCS_ENABLE": 0})
    with running_vehicle(FlatSeabed(30.0), config=cfg) as (sim, gcs):
        assert gcs.arm().result == M.MAV_RESULT_ACCEPTED
        gcs.auto_manual_control = False
        start = sim.truth()
        for _ in range(30):
            gcs.manual_control(x=1000, target=0)  # not aimed at system 1
            gcs.run_for(0.1)
        assert abs(sim.truth().north_m - start.north_m) < 0.05
        assert not sim.truth().armed  # and no pilot input either: disarmed after 3 s
    with running_vehicle(FlatSeabed(30.0), config=cfg) as (sim, gcs):
        assert gcs.arm().result == M.MAV_RESULT_ACCEPTED
        gcs.auto_manual_control = False
        gcs.conn.mav.srcSystem = 42  # another system's joystick
        for _ in range(20):
            gcs.manual_control(x=1000)
            gcs.run_for(0.1)
        gcs.conn.mav.srcSystem = 255
        assert abs(sim.truth().north_m) < 0.05
        gcs.manual_control(buttons=1 << 2)
        assert gcs.wait_for("HEARTBEAT", 1.0, lambda m: m.custom_mode == Mode.ALT_HOLD)
        for _ in range(30):
            gcs.manual_control(x=1000)
            gcs.run_for(0.1)
        assert sim.truth().north_m > 0.3  # the pilot drives it


def test_fence_breach_is_only_recorded():
    """ArduSub/fence.cpp (4.5): the breach response is commented out; SYS_STATUS health shows it."""
    cfg = vehicle_config(params={"FENCE_ENABLE": 1, "FENCE_TYPE": 8, "FENCE_ALT_MIN": -6.0})
    with running_vehicle(FlatSeabed(30.0), config=cfg) as (sim, gcs):
        assert gcs.set_mode(int(Mode.ALT_HOLD)).result == M.MAV_RESULT_ACCEPTED
        assert gcs.arm().result == M.MAV_RESULT_ACCEPTED
        use_z_only = 0b110111111011
        gcs.mav.set_position_target_global_int_send(0, 1, 1, M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, use_z_only,
                                                    0, 0, -8.0, 0, 0, 0, 0, 0, 0, 0, 0)
        gcs.run_for(20.0)
        assert sim.truth().depth_m > 7.5 and sim.truth().mode == Mode.ALT_HOLD  # nothing done
        status = gcs.wait_for("SYS_STATUS", 1.0)
        assert status.onboard_control_sensors_present & M.MAV_SYS_STATUS_GEOFENCE
        assert status.onboard_control_sensors_enabled & M.MAV_SYS_STATUS_GEOFENCE
        assert not status.onboard_control_sensors_health & M.MAV_SYS_STATUS_GEOFENCE


def test_terrain_failsafe_when_the_rangefinder_drops_out_in_auto():
    """failsafe_terrain_check: > 1 s of failed rangefinder following in AUTO -> "Failsafe
    terrain triggered", FS_TERRAIN_ENAB 2 surface."""
    faults = FaultConfig(altimeter_dropouts=(TimeWindow(10.0, 60.0),))
    cfg = _cfg(FS_TERRAIN_ENAB=2)
    with running_vehicle(FlatSeabed(12.0), config=cfg, faults=faults) as (sim, gcs):
        lat = ORIGIN[0] + math.degrees(40.0 / 6378137.0)
        items = [M.MAVLink_mission_item_int_message(1, 1, seq, frame, M.MAV_CMD_NAV_WAYPOINT, 0, 1, 0, 0, 0, 0,
                                                    int(lat * 1e7) if seq else 0, int(ORIGIN[1] * 1e7), z, 0)
                 for seq, frame, z in ((0, 0, 0.0), (1, M.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT, 4.0))]
        gcs.mav.mission_count_send(1, 1, 2, 0)
        for _ in items:
            gcs.mav.send(items[gcs.wait_for("MISSION_REQUEST", 1.0).seq])
        assert gcs.wait_for("MISSION_ACK", 1.0).type == M.MAV_MISSION_ACCEPTED
        assert gcs.arm().result == M.MAV_RESULT_ACCEPTED
        assert gcs.set_mode(int(Mode.AUTO)).result == M.MAV_RESULT_ACCEPTED
        assert gcs.wait_for("HEARTBEAT", 15.0, lambda m: m.custom_mode == Mode.SURFACE) is not None
        assert "Failsafe terrain triggered" in _texts(gcs)
