"""ArduSub mode, arming and command semantics, over MAVLink from a plain mavutil GCS."""

from __future__ import annotations

import math

from sim_harness.autopilot.autopilot import AutopilotConfig, Mode
from sim_harness.faults import FaultConfig, TimeWindow
from sim_harness.simulator import VehicleConfig
from sim_harness.vehicle.sensors import FlatSeabed, SensorConfig
from tests.sim_harness.autopilot.gcs_peer import M, running_vehicle

NO_DVL = VehicleConfig(sensors=SensorConfig(has_position_estimate=False), start_depth_m=2.0)


def _texts(msgs) -> list[str]:
    return [m.text for m in msgs if m.get_type() == "STATUSTEXT"]


def test_position_modes_refused_without_a_position_estimate():
    with running_vehicle(config=NO_DVL) as (_sim, gcs):
        for mode in (Mode.GUIDED, Mode.AUTO, Mode.POSHOLD):
            ack = gcs.set_mode(int(mode))
            assert ack.result == M.MAV_RESULT_FAILED, mode
        texts = _texts(gcs.log)
        assert "Mode change failed: GUIDED requires position" in texts
        assert "Mode change failed: POSHOLD requires position" in texts
        # Modes that need only depth are fine.
        assert gcs.set_mode(int(Mode.ALT_HOLD)).result == M.MAV_RESULT_ACCEPTED
        assert gcs.set_mode(int(Mode.SURFTRAK)).result == M.MAV_RESULT_ACCEPTED


def test_position_lost_mid_dive_refuses_guided_then_accepts_again():
    faults = FaultConfig(position_loss=(TimeWindow(0.0, 3.0),))
    with running_vehicle(faults=faults) as (_sim, gcs):
        assert gcs.set_mode(int(Mode.GUIDED)).result == M.MAV_RESULT_FAILED
        gcs.run_for(3.5)
        assert gcs.set_mode(int(Mode.GUIDED)).result == M.MAV_RESULT_ACCEPTED


def test_auto_refused_with_no_mission_and_unknown_mode_refused():
    with running_vehicle() as (_sim, gcs):
        assert gcs.set_mode(int(Mode.AUTO)).result == M.MAV_RESULT_FAILED
        assert gcs.set_mode(42).result == M.MAV_RESULT_FAILED
        hb = gcs.wait_for("HEARTBEAT", 2.0)
        assert hb.custom_mode == Mode.MANUAL


def test_arming_check_failure_is_refused_with_a_prearm_text_and_force_arms():
    cfg = VehicleConfig(autopilot=AutopilotConfig(arming_fail_reason="Leak Detected"))
    with running_vehicle(config=cfg) as (sim, gcs):
        ack = gcs.arm()
        assert ack.result == M.MAV_RESULT_FAILED
        assert "PreArm: Leak Detected" in _texts(gcs.log)
        assert not sim.truth().armed
        assert gcs.arm(force=True).result == M.MAV_RESULT_ACCEPTED
        hb = gcs.wait_for("HEARTBEAT", 2.0)
        assert hb.base_mode & M.MAV_MODE_FLAG_SAFETY_ARMED
        assert hb.system_status == M.MAV_STATE_ACTIVE


def test_arming_in_guided_needs_position():
    faults = FaultConfig(position_loss=(TimeWindow(2.0, 100.0),))
    with running_vehicle(faults=faults) as (_sim, gcs):
        assert gcs.set_mode(int(Mode.GUIDED)).result == M.MAV_RESULT_ACCEPTED
        gcs.run_for(2.5)
        assert gcs.arm().result == M.MAV_RESULT_FAILED
        assert "PreArm: Mode requires position" in _texts(gcs.log)


def test_unknown_command_unsupported_and_configured_refusal_denied():
    faults = FaultConfig(refuse_commands=frozenset({M.MAV_CMD_COMPONENT_ARM_DISARM}))
    with running_vehicle(faults=faults) as (sim, gcs):
        assert gcs.command(M.MAV_CMD_NAV_TAKEOFF).result == M.MAV_RESULT_UNSUPPORTED
        assert gcs.arm().result == M.MAV_RESULT_DENIED
        assert not sim.truth().armed


def test_alt_hold_takes_a_depth_target_as_negative_altitude():
    with running_vehicle(FlatSeabed(30.0), config=VehicleConfig(start_depth_m=1.0)) as (sim, gcs):
        assert gcs.set_mode(int(Mode.ALT_HOLD)).result == M.MAV_RESULT_ACCEPTED
        assert gcs.arm().result == M.MAV_RESULT_ACCEPTED
        ignore_all_but_z = 0b110111111000 | 0b011  # use z only
        gcs.mav.set_position_target_global_int_send(
            0, 1, 1, M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, ignore_all_but_z, 0, 0, -6.0,
            0, 0, 0, 0, 0, 0, 0, 0)
        gcs.run_for(30.0)
        truth = sim.truth()
        assert abs(truth.depth_m - 6.0) < 0.2
        assert math.hypot(truth.north_m, truth.east_m) < 1.0  # ALT_HOLD does not move it


def test_guided_goes_to_a_local_position_and_heading():
    with running_vehicle(FlatSeabed(30.0), config=VehicleConfig(start_depth_m=2.0)) as (sim, gcs):
        assert gcs.set_mode(int(Mode.GUIDED)).result == M.MAV_RESULT_ACCEPTED
        assert gcs.arm().result == M.MAV_RESULT_ACCEPTED
        pos_and_yaw = 0b100111111000
        gcs.mav.set_position_target_local_ned_send(
            0, 1, 1, M.MAV_FRAME_LOCAL_NED, pos_and_yaw, 12.0, -5.0, 8.0, 0, 0, 0, 0, 0, 0,
            math.radians(90.0), 0)
        gcs.run_for(60.0)
        t = sim.truth()
        assert math.hypot(t.north_m - 12.0, t.east_m + 5.0) < 0.6  # DVL drift is small
        assert abs(t.depth_m - 8.0) < 0.2
        assert abs(math.remainder(t.yaw_rad - math.radians(90.0), 2 * math.pi)) < 0.05


def test_surftrak_holds_the_height_over_a_sloping_seabed():
    from sim_harness.vehicle.sensors import SlopedSeabed

    world = SlopedSeabed(depth_m=12.0, slope_north=0.1)  # deeper to the north
    with running_vehicle(world, config=VehicleConfig(start_depth_m=8.0)) as (sim, gcs):
        assert gcs.set_mode(int(Mode.SURFTRAK)).result == M.MAV_RESULT_ACCEPTED
        assert gcs.arm().result == M.MAV_RESULT_ACCEPTED
        gcs.run_for(2.0)
        start_alt = sim.truth().altitude_m
        for _ in range(20 * 50):  # 20 s of full-forward stick
            gcs.mav.manual_control_send(1, 600, 0, 500, 0, 0)
            gcs.tick()
        t = sim.truth()
        assert t.north_m > 8.0  # it moved into deeper water ...
        assert t.depth_m > 8.5  # ... and followed the seabed down
        assert abs(t.altitude_m - start_alt) < 0.5
