"""Mount control as ArduSub 4.5 and the mission protocol's re-requests and timeouts."""

from __future__ import annotations

import math

from sim_harness.autopilot.autopilot import Mode
from sim_harness.autopilot.mission import REREQUEST_INTERVAL_S, UPLOAD_TIMEOUT_S
from sim_harness.simulator import VehicleConfig
from sim_harness.vehicle.dynamics import MountMechanics
from tests.sim_harness.autopilot.gcs_peer import M, running_vehicle

LIMITS = MountMechanics(min_tilt_rad=math.radians(-20), max_tilt_rad=math.radians(60),
                     max_rate_rad_s=math.radians(20), default_tilt_rad=math.radians(10))


def _gimbal_pitch_deg(msg) -> float:
    w, x, y, z = msg.q
    return math.degrees(math.asin(max(-1.0, min(1.0, 2 * (w * y - z * x)))))


def test_do_mount_control_in_degrees_with_rate_and_angle_limits():
    with running_vehicle(config=VehicleConfig(mount=LIMITS, start_depth_m=2)) as (sim, gcs):
        assert abs(sim.truth().tilt_rad - math.radians(10)) < 1e-9
        ack = gcs.command(M.MAV_CMD_DO_MOUNT_CONTROL, -40.0, 0, 0, 0, 0, 0,
                          M.MAV_MOUNT_MODE_MAVLINK_TARGETING)
        assert ack.result == M.MAV_RESULT_ACCEPTED
        t0, tilt0 = sim.truth().time_s, sim.truth().tilt_rad
        gcs.run_for(0.5)
        t1, tilt1 = sim.truth().time_s, sim.truth().tilt_rad
        assert 0 < tilt1 - tilt0 <= math.radians(20) * (t1 - t0) + 1e-9  # rate limit
        gcs.run_for(3.0)
        assert abs(math.degrees(sim.truth().tilt_rad) - 40.0) < 0.01
        status = gcs.wait_for("GIMBAL_DEVICE_ATTITUDE_STATUS", 2.0)
        assert abs(_gimbal_pitch_deg(status) + 40.0) < 0.1  # MAVLink pitch is up-positive
        gcs.command(M.MAV_CMD_DO_MOUNT_CONTROL, -89.0, 0, 0, 0, 0, 0,
                    M.MAV_MOUNT_MODE_MAVLINK_TARGETING)
        gcs.run_for(5.0)
        assert abs(math.degrees(sim.truth().tilt_rad) - 60.0) < 0.01  # clamped at the limit


def test_gimbal_manager_pitchyaw_and_reset_to_default_on_mode_change():
    with running_vehicle(config=VehicleConfig(mount=LIMITS, start_depth_m=2)) as (sim, gcs):
        ack = gcs.command(M.MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW, -25.0, 0.0, math.nan, math.nan,
                          0, 0, 0)
        assert ack.result == M.MAV_RESULT_ACCEPTED
        gcs.run_for(3.0)
        assert abs(math.degrees(sim.truth().tilt_rad) - 25.0) < 0.01
        gcs.mav.gimbal_manager_set_pitchyaw_send(1, 1, 0, 0, math.radians(-35.0), math.nan,
                                                 math.nan, math.nan)
        gcs.run_for(3.0)
        assert abs(math.degrees(sim.truth().tilt_rad) - 35.0) < 0.01
        assert gcs.set_mode(int(Mode.STABILIZE)).result == M.MAV_RESULT_ACCEPTED
        gcs.run_for(3.0)
        assert abs(math.degrees(sim.truth().tilt_rad) - 10.0) < 0.01  # back to default


def _item(seq: int, frame: int = M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, command=None):
    return M.MAVLink_mission_item_int_message(
        1, 1, seq, frame, command or M.MAV_CMD_NAV_WAYPOINT, 0, 1, 0, 0, 0, 0,
        470000100 + seq, 80000000, -3.0, 0)


def test_upload_rerequests_a_missing_item_then_times_out():
    with running_vehicle() as (_sim, gcs):
        gcs.mav.mission_count_send(1, 1, 3, 0)
        first = gcs.wait_for("MISSION_REQUEST", 1.0)
        assert first is not None and first.seq == 0
        again = gcs.wait_for("MISSION_REQUEST", REREQUEST_INTERVAL_S + 0.5)
        assert again is not None and again.seq == 0  # re-request after silence
        gcs.mav.send(_item(0))
        nxt = gcs.wait_for("MISSION_REQUEST", 1.0)
        assert nxt.seq == 1
        ack = gcs.wait_for("MISSION_ACK", UPLOAD_TIMEOUT_S + 1.0)
        assert ack is not None and ack.type == M.MAV_MISSION_OPERATION_CANCELLED
        gcs.mav.mission_request_list_send(1, 1, 0)
        assert gcs.wait_for("MISSION_COUNT", 1.0).count == 1  # old mission (home) kept


def test_upload_rejects_unsupported_frames_and_commands():
    with running_vehicle() as (_sim, gcs):
        for bad, expected in ((_item(1, frame=M.MAV_FRAME_LOCAL_NED),
                               M.MAV_MISSION_UNSUPPORTED_FRAME),
                              (_item(1, command=M.MAV_CMD_NAV_TAKEOFF),
                               M.MAV_MISSION_UNSUPPORTED)):
            gcs.mav.mission_count_send(1, 1, 2, 0)
            assert gcs.wait_for("MISSION_REQUEST", 1.0).seq == 0
            gcs.mav.send(_item(0))
            assert gcs.wait_for("MISSION_REQUEST", 1.0).seq == 1
            gcs.mav.send(bad)
            assert gcs.wait_for("MISSION_ACK", 1.0).type == expected
        gcs.mav.mission_count_send(1, 1, 1, M.MAV_MISSION_TYPE_FENCE)
        assert gcs.wait_for("MISSION_ACK", 1.0).type == M.MAV_MISSION_UNSUPPORTED


def test_clear_all_and_auto_with_a_delay_and_mount_item():
    with running_vehicle(config=VehicleConfig(start_depth_m=2.0)) as (sim, gcs):
        items = [
            _item(0),
            M.MAVLink_mission_item_int_message(1, 1, 1, M.MAV_FRAME_MISSION,
                                               M.MAV_CMD_DO_MOUNT_CONTROL, 0, 1, -30, 0, 0, 0,
                                               0, 0, M.MAV_MOUNT_MODE_MAVLINK_TARGETING, 0),
            M.MAVLink_mission_item_int_message(1, 1, 2, M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
                                               M.MAV_CMD_NAV_WAYPOINT, 0, 1, 4.0, 0, 0, 0,
                                               0, 0, -2.0, 0),
        ]
        gcs.mav.mission_count_send(1, 1, len(items), 0)
        for _ in items:
            gcs.mav.send(items[gcs.wait_for("MISSION_REQUEST", 1.0).seq])
        assert gcs.wait_for("MISSION_ACK", 1.0).type == M.MAV_MISSION_ACCEPTED
        assert gcs.arm().result == M.MAV_RESULT_ACCEPTED
        assert gcs.set_mode(int(Mode.AUTO)).result == M.MAV_RESULT_ACCEPTED
        reached = gcs.wait_for("MISSION_ITEM_REACHED", 10.0)
        assert reached.seq == 2  # the DO item runs at once; lat/lon 0 = here
        t_reached = sim.truth().time_s
        gcs.run_for(3.0)
        assert abs(math.degrees(sim.truth().tilt_rad) - 30.0) < 0.01
        done = gcs.wait_for("STATUSTEXT", 5.0, lambda m: m.text == "Mission complete")
        assert done is not None and sim.truth().time_s - t_reached > 3.9  # 4 s hold (+- a step)
        gcs.mav.mission_clear_all_send(1, 1, 0)
        assert gcs.wait_for("MISSION_ACK", 1.0).type == M.MAV_MISSION_ACCEPTED
        # Clearing the mission in AUTO drops to depth hold, as there is nothing to fly.
        assert gcs.wait_for("HEARTBEAT", 2.0, lambda m: m.custom_mode == Mode.ALT_HOLD)
