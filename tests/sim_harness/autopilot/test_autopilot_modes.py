"""ArduSub 4.5 modes: what needs a position, HEARTBEAT flags, arming, ALT_HOLD, SURFTRAK."""

from __future__ import annotations

import math

from sim_harness.autopilot.autopilot import Mode
from sim_harness.faults import FaultConfig, TimeWindow
from sim_harness.vehicle.sensors import FlatSeabed, SensorConfig, SlopedSeabed
from tests.sim_harness.autopilot.gcs_peer import M, running_vehicle, vehicle_config

NO_DVL = vehicle_config(sensors=SensorConfig(has_position_estimate=False), start_depth_m=2.0)


def _texts(msgs) -> list[str]:
    return [m.text for m in msgs if m.get_type() == "STATUSTEXT"]


def test_position_modes_and_surface_refused_without_a_position_estimate():
    """mode.h requires_GPS(): GUIDED, AUTO, CIRCLE and SURFACE in 4.5 ("Mode change failed:
    SURFACE requires position", mode.cpp Sub::set_mode); POSHOLD's init fails instead."""
    with running_vehicle(config=NO_DVL) as (_sim, gcs):
        for mode in (Mode.GUIDED, Mode.AUTO, Mode.POSHOLD, Mode.SURFACE):
            assert gcs.set_mode(int(mode)).result == M.MAV_RESULT_FAILED, mode
        texts = _texts(gcs.log)
        assert "Mode change failed: GUIDED requires position" in texts
        assert "Mode change failed: SURFACE requires position" in texts
        assert "Flight mode change failed POSHOLD" in texts
        # Depth alone is enough for these.
        assert gcs.set_mode(int(Mode.ALT_HOLD)).result == M.MAV_RESULT_ACCEPTED
        assert gcs.set_mode(int(Mode.SURFTRAK)).result == M.MAV_RESULT_ACCEPTED


def test_position_lost_mid_dive_refuses_guided_then_accepts_again():
    faults = FaultConfig(position_loss=(TimeWindow(0.0, 3.0),))
    with running_vehicle(faults=faults) as (_sim, gcs):
        assert gcs.set_mode(int(Mode.GUIDED)).result == M.MAV_RESULT_FAILED
        gcs.run_for(3.5)
        assert gcs.set_mode(int(Mode.GUIDED)).result == M.MAV_RESULT_ACCEPTED


def test_auto_refused_without_mission_and_unknown_mode_refused():
    with running_vehicle() as (_sim, gcs):
        assert gcs.set_mode(int(Mode.AUTO)).result == M.MAV_RESULT_FAILED
        assert "Flight mode change failed AUTO" in _texts(gcs.log)  # ModeAuto::init: < 2 items
        assert gcs.set_mode(42).result == M.MAV_RESULT_FAILED
        assert "No such mode 42" in _texts(gcs.log)
        assert gcs.wait_for("HEARTBEAT", 2.0).custom_mode == Mode.MANUAL


def test_heartbeat_base_mode_and_status_as_ardusub_sends_them():
    """GCS_MAVLINK_Sub::base_mode: 81 disarmed in MANUAL, 209 armed, +8 (GUIDED_ENABLED) in
    GUIDED/AUTO/POSHOLD/CIRCLE; STANDBY / ACTIVE; a HEARTBEAT at once on a mode change."""
    with running_vehicle(config=vehicle_config(start_depth_m=2.0)) as (_sim, gcs):
        hb = gcs.wait_for("HEARTBEAT", 2.0)
        assert (hb.base_mode, hb.system_status) == (81, M.MAV_STATE_STANDBY)
        assert gcs.arm().result == M.MAV_RESULT_ACCEPTED
        hb = gcs.wait_for("HEARTBEAT", 2.0, lambda m: m.base_mode & 128)
        assert (hb.base_mode, hb.system_status) == (209, M.MAV_STATE_ACTIVE)
        t0 = gcs.clock.now_s()
        gcs.conn.mav.command_long_send(1, 1, M.MAV_CMD_DO_SET_MODE, 0, 1, int(Mode.GUIDED), 0, 0, 0, 0, 0)
        hb = gcs.wait_for("HEARTBEAT", 2.0, lambda m: m.custom_mode == Mode.GUIDED)
        assert hb.base_mode == 217 and gcs.clock.now_s() - t0 < 0.2  # sent with the change, not at 1 Hz
        assert gcs.set_mode(int(Mode.ALT_HOLD)).result == M.MAV_RESULT_ACCEPTED
        assert gcs.wait_for("HEARTBEAT", 2.0, lambda m: m.custom_mode == Mode.ALT_HOLD).base_mode == 209


def test_arming_in_guided_needs_no_check_of_position():
    """No mode refuses arming (allows_arming true for all, AP_Arming_Sub)."""
    faults = FaultConfig(position_loss=(TimeWindow(2.0, 100.0),))
    with running_vehicle(faults=faults) as (sim, gcs):
        assert gcs.set_mode(int(Mode.GUIDED)).result == M.MAV_RESULT_ACCEPTED
        gcs.run_for(2.5)
        assert gcs.arm().result == M.MAV_RESULT_ACCEPTED
        assert sim.truth().armed


def test_surface_climbs_then_holds_depth_at_the_surface():
    """ModeSurface::run: climb; at SURFACE_DEPTH switch to ALT_HOLD (it does not disarm)."""
    with running_vehicle(FlatSeabed(30.0), config=vehicle_config(start_depth_m=4.0)) as (sim, gcs):
        assert gcs.arm().result == M.MAV_RESULT_ACCEPTED
        assert gcs.set_mode(int(Mode.SURFACE)).result == M.MAV_RESULT_ACCEPTED
        hb = gcs.wait_for("HEARTBEAT", 30.0, lambda m: m.custom_mode == Mode.ALT_HOLD)
        assert hb is not None and hb.base_mode & 128
        assert sim.truth().depth_m < 0.3


def test_alt_hold_takes_a_depth_target_as_negative_altitude():
    """GLOBAL_INT in ALT_HOLD: set_pos_target_z_cm(alt * 100), frame and lat/lon ignored."""
    with running_vehicle(FlatSeabed(30.0), config=vehicle_config(start_depth_m=1.0)) as (sim, gcs):
        assert gcs.set_mode(int(Mode.ALT_HOLD)).result == M.MAV_RESULT_ACCEPTED
        assert gcs.arm().result == M.MAV_RESULT_ACCEPTED
        use_z_only = 0b110111111011
        gcs.mav.set_position_target_global_int_send(0, 1, 1, M.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT, use_z_only,
                                                    0, 0, -6.0, 0, 0, 0, 0, 0, 0, 0, 0)
        gcs.run_for(20.0)
        truth = sim.truth()
        assert abs(truth.depth_m - 6.0) < 0.2
        assert math.hypot(truth.north_m, truth.east_m) < 1.0  # ALT_HOLD does not move it


def test_surftrak_holds_the_height_over_a_sloping_seabed():
    world = SlopedSeabed(depth_m=12.0, slope_north=0.1)  # deeper to the north
    with running_vehicle(world, config=vehicle_config(start_depth_m=8.0)) as (sim, gcs):
        assert gcs.set_mode(int(Mode.SURFTRAK)).result == M.MAV_RESULT_ACCEPTED
        assert gcs.arm().result == M.MAV_RESULT_ACCEPTED
        gcs.run_for(2.0)
        start_alt = sim.truth().altitude_m
        gcs.auto_manual_control = False
        for _ in range(20 * 10):  # 20 s of full-forward stick (half thrust at JS_GAIN_DEFAULT 0.5)
            gcs.manual_control(x=1000)
            gcs.run_for(0.1)
        t = sim.truth()
        assert t.north_m > 8.0  # it moved into deeper water ...
        assert t.depth_m > 8.5  # ... and followed the seabed down
        assert abs(t.altitude_m - start_alt) < 0.5
