"""GUIDED and ALT_HOLD targets as ArduSub 4.5 takes them (GCS_Mavlink.cpp, mode_guided.cpp, AC_WPNav)."""

from __future__ import annotations

import math

from sim_harness.autopilot.autopilot import Mode
from sim_harness.autopilot.wpnav import Leg, LegLimits
from sim_harness.vehicle.sensors import FlatSeabed
from tests.sim_harness.autopilot.gcs_peer import ORIGIN, M, running_vehicle, vehicle_config

POS = 0b110111111000  # position only (velocity, accel, yaw, yaw rate ignored)
POS_YAW = 0b100111111000
POSVEL = 0b110111000000
VEL = 0b110111000111
ACCEL_USED = 0b110000111000  # position with the accel bits clear: acted on by nobody


def _guided(gcs) -> None:
    assert gcs.set_mode(int(Mode.GUIDED)).result == M.MAV_RESULT_ACCEPTED
    assert gcs.arm().result == M.MAV_RESULT_ACCEPTED


def _local(gcs, mask: int, n: float, e: float, d: float, vn=0.0, ve=0.0, vd=0.0, yaw=0.0,
           frame=M.MAV_FRAME_LOCAL_NED) -> None:
    gcs.mav.set_position_target_local_ned_send(0, 1, 1, frame, mask, n, e, d, vn, ve, vd, 0, 0, 0, yaw, 0)


def test_guided_goes_to_a_local_position_and_heading():
    with running_vehicle(FlatSeabed(30.0), config=vehicle_config(start_depth_m=2.0)) as (sim, gcs):
        _guided(gcs)
        _local(gcs, POS_YAW, 12.0, -5.0, 8.0, yaw=math.radians(90.0))
        gcs.run_for(45.0)
        t = sim.truth()
        assert math.hypot(t.north_m - 12.0, t.east_m + 5.0) < 0.6
        assert abs(t.depth_m - 8.0) < 0.2
        assert abs(math.remainder(t.yaw_rad - math.radians(90.0), 2 * math.pi)) < 0.05


def test_local_ned_is_dropped_outside_guided_and_the_accel_bits_must_be_set():
    """SET_POSITION_TARGET_LOCAL_NED only in GUIDED; "send request" only with acc_ignore."""
    with running_vehicle(FlatSeabed(30.0), config=vehicle_config(start_depth_m=2.0)) as (sim, gcs):
        assert gcs.set_mode(int(Mode.ALT_HOLD)).result == M.MAV_RESULT_ACCEPTED
        assert gcs.arm().result == M.MAV_RESULT_ACCEPTED
        _local(gcs, POS, 0.0, 0.0, 6.0)
        gcs.run_for(8.0)
        assert abs(sim.truth().depth_m - 2.0) < 0.3  # ALT_HOLD ignores LOCAL_NED
        assert gcs.set_mode(int(Mode.GUIDED)).result == M.MAV_RESULT_ACCEPTED
        _local(gcs, ACCEL_USED, 10.0, 0.0, 2.0)
        _local(gcs, POS | 0b001, 10.0, 0.0, 2.0)  # one position bit set: position ignored
        gcs.run_for(8.0)
        assert abs(sim.truth().north_m) < 0.3


def test_global_int_in_guided_needs_origin_and_drops_terrain_frames():
    """mavlink_coordinate_frame_to_location_alt_frame + get_vector_from_origin_NEU: terrain
    needs the terrain database (none on a sub); relative frames need home."""
    lat = int(round((ORIGIN[0] + math.degrees(8.0 / 6378137.0)) * 1e7))
    lon = int(round(ORIGIN[1] * 1e7))
    with running_vehicle(FlatSeabed(30.0), config=vehicle_config(start_depth_m=2.0)) as (sim, gcs):
        _guided(gcs)
        gcs.mav.set_position_target_global_int_send(0, 1, 1, M.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT, POS, lat, lon, 5.0,
                                                    0, 0, 0, 0, 0, 0, 0, 0)
        gcs.run_for(8.0)
        assert abs(sim.truth().north_m) < 0.3  # dropped
        gcs.mav.set_position_target_global_int_send(0, 1, 1, M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, POS, lat, lon,
                                                    -4.0, 0, 0, 0, 0, 0, 0, 0, 0)
        gcs.run_for(30.0)
        t = sim.truth()
        assert abs(t.north_m - 8.0) < 0.5 and abs(t.depth_m - 4.0) < 0.2


def test_a_position_target_resent_before_it_is_reached_restarts_from_rest():
    """AC_WPNav::set_wp_destination calls wp_and_spline_init() when the destination has not
    been reached: re-sending every 0.5 s keeps the vehicle creeping."""
    def distance_after(resend_s: float | None) -> float:
        with running_vehicle(FlatSeabed(30.0), config=vehicle_config(start_depth_m=2.0)) as (sim, gcs):
            _guided(gcs)
            gcs.run_for(1.0)
            _local(gcs, POS, 30.0, 0.0, 2.0)
            for _ in range(int(10.0 / (resend_s or 10.0))):
                gcs.run_for(resend_s or 10.0)
                if resend_s is not None:
                    _local(gcs, POS, 30.0, 0.0, 2.0)
            return sim.truth().north_m

    once, resent = distance_after(None), distance_after(0.5)
    assert once > 6.0  # WPNAV_SPEED 1 m/s, less the start
    assert resent < 0.35 * once


def test_posvel_and_velocity_targets_time_out_after_3_s():
    """GUIDED_POSVEL_TIMEOUT_MS 3000: posvel then holds its integrated position; velocity
    zeroes the velocity."""
    with running_vehicle(FlatSeabed(30.0), config=vehicle_config(start_depth_m=3.0)) as (sim, gcs):
        _guided(gcs)
        for k in range(25):  # 5 s of a setpoint moving east at 0.3 m/s
            _local(gcs, POSVEL, 0.0, 0.3 * 0.2 * k, 3.0, ve=0.3)
            gcs.run_for(0.2)
        last_setpoint_e = 0.3 * 0.2 * 24
        gcs.run_for(12.0)
        stopped = sim.truth()
        gcs.run_for(5.0)
        held = sim.truth()
        # 3 s more of the setpoint moving on at 0.3 m/s, then it holds there
        assert abs(held.east_m - (last_setpoint_e + 0.3 * 3.0)) < 0.4
        assert abs(held.east_m - stopped.east_m) < 0.05
        for _ in range(5):  # velocity only: 0.5 m/s north, refreshed every second
            _local(gcs, VEL, 0, 0, 0, vn=0.5)
            gcs.run_for(1.0)
        moving = sim.truth()
        assert 1.5 < moving.north_m < 2.7
        gcs.run_for(8.0)
        assert abs(sim.truth().north_m - moving.north_m) < 2.0  # 3 s more at 0.5 m/s, then stopped
        assert math.hypot(sim.truth().surge_m_s, sim.truth().sway_m_s) < 0.05


def test_leg_profile_limits_and_restart():
    limits = LegLimits(speed_m_s=1.0, accel_m_s2=2.5, jerk_m_s3=1.0)
    leg = Leg((0.0, 0.0), (10.0, 0.0))
    speeds = []
    for _ in range(int(20 / 0.02)):
        leg.advance(0.02, limits)
        speeds.append(leg.speed_m_s)
    assert leg.reached and leg.point() == (10.0, 0.0)
    assert max(speeds) <= 1.0 + 1e-9
    assert all(b - a <= 2.5 * 0.02 + 1e-9 for a, b in zip(speeds, speeds[1:], strict=False))
    short = Leg((0.0, 0.0), (10.0, 0.0))
    for _ in range(25):  # 0.5 s from rest: jerk-limited, barely moving
        short.advance(0.02, limits)
    assert short.s_m < 0.05


def _top_speed_m_s(sim, gcs, seconds: float) -> float:
    speeds = []
    for _ in range(int(seconds / 0.5)):
        gcs.run_for(0.5)
        t = sim.truth()
        speeds.append(math.hypot(t.surge_m_s, t.sway_m_s))  # body frame: the same horizontal speed
    return max(speeds)


def test_change_speed_holds_until_the_controller_restarts_and_leaves_the_parameter():
    """MAV_CMD_DO_CHANGE_SPEED -> ``AC_WPNav::set_speed_xy``: the legs run at that speed, the
    WPNAV_SPEED parameter is untouched, and GUIDED's next ``guided_pos_control_start``
    (``wp_and_spline_init``) is back at WPNAV_SPEED."""
    with running_vehicle(FlatSeabed(30.0), config=vehicle_config(start_depth_m=2.0)) as (sim, gcs):
        _guided(gcs)
        wpnav_m_s = sim.autopilot.params["WPNAV_SPEED"] / 100.0
        assert gcs.command(M.MAV_CMD_DO_CHANGE_SPEED, 1, 0.3, -1, 0).result == M.MAV_RESULT_ACCEPTED
        assert gcs.command(M.MAV_CMD_DO_CHANGE_SPEED, 1, 0.0, -1, 0).result == M.MAV_RESULT_FAILED
        _local(gcs, POS, 12.0, 0.0, 2.0)
        assert abs(_top_speed_m_s(sim, gcs, 20.0) - 0.3) < 0.05
        assert gcs.param("WPNAV_SPEED").param_value == wpnav_m_s * 100.0
        assert gcs.set_mode(int(Mode.ALT_HOLD)).result == M.MAV_RESULT_ACCEPTED
        assert gcs.set_mode(int(Mode.GUIDED)).result == M.MAV_RESULT_ACCEPTED
        _local(gcs, POS, -12.0, 0.0, 2.0)
        assert abs(_top_speed_m_s(sim, gcs, 20.0) - wpnav_m_s) < 0.1


def test_condition_yaw_relative_turns_from_the_held_heading_and_its_direction_counts():
    """GCS_MAVLINK_Sub::handle_MAV_CMD_CONDITION_YAW -> ModeAuto::set_auto_yaw_look_at_heading:
    a relative angle is taken from the attitude target's yaw and negated for direction < 0
    (param3); an absolute one is the heading itself."""
    with running_vehicle(FlatSeabed(30.0), config=vehicle_config(start_depth_m=2.0)) as (sim, gcs):
        _guided(gcs)
        gcs.run_for(2.0)
        yaw0 = sim.truth().yaw_rad

        def heading_error_rad(expected_rad: float) -> float:
            return abs(math.remainder(sim.truth().yaw_rad - expected_rad, 2 * math.pi))

        assert gcs.command(M.MAV_CMD_CONDITION_YAW, 90.0, 0, -1, 1).result == M.MAV_RESULT_ACCEPTED
        gcs.run_for(15.0)
        assert heading_error_rad(yaw0 - math.radians(90.0)) < 0.05
        assert gcs.command(M.MAV_CMD_CONDITION_YAW, 30.0, 0, 1, 1).result == M.MAV_RESULT_ACCEPTED
        gcs.run_for(10.0)
        assert heading_error_rad(yaw0 - math.radians(60.0)) < 0.05
        assert gcs.command(M.MAV_CMD_CONDITION_YAW, 45.0, 0, -1, 0).result == M.MAV_RESULT_ACCEPTED  # absolute
        gcs.run_for(15.0)
        assert heading_error_rad(math.radians(45.0)) < 0.05
