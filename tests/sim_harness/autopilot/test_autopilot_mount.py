"""The tilt mount as ArduSub 4.5 drives it (AP_Mount_Servo, AP_Mount_Backend, Sub::exit_mode)."""

from __future__ import annotations

import math

from sim_harness.autopilot.autopilot import Mode
from sim_harness.vehicle.dynamics import AttitudeDisturbance, MountMechanics
from tests.sim_harness.autopilot.gcs_peer import M, running_vehicle, vehicle_config

LIMITS = MountMechanics(min_tilt_rad=math.radians(-20), max_tilt_rad=math.radians(60),
                     max_rate_rad_s=math.radians(20), default_tilt_rad=math.radians(10))
#: No waves, no thrust pitch: a level vehicle (the body-frame servo angle is the target).
LEVEL = AttitudeDisturbance(pitch_amplitude_rad=0.0, roll_amplitude_rad=0.0, pitch_per_surge_rad_n=0.0)
#: A steady 5 deg nose-up trim, no waves.
TRIM = AttitudeDisturbance(pitch_bias_rad=math.radians(5.0), pitch_amplitude_rad=0.0, roll_amplitude_rad=0.0,
                           pitch_per_surge_rad_n=0.0)


def _status_pitch_deg(msg) -> float:
    w, x, y, z = msg.q
    return math.degrees(math.asin(max(-1.0, min(1.0, 2 * (w * y - z * x)))))


def test_stabilised_servo_mount_holds_an_earth_frame_angle_and_reports_its_target():
    """MNT1_TYPE 1: servo = earth-frame target - AHRS pitch (update_angle_outputs);
    GIMBAL_DEVICE_ATTITUDE_STATUS carries the target, ROLL_LOCK | PITCH_LOCK, device 1."""
    cfg = vehicle_config(mount=LIMITS, start_depth_m=2, disturbance=TRIM)
    with running_vehicle(config=cfg) as (sim, gcs):
        ack = gcs.command(M.MAV_CMD_DO_MOUNT_CONTROL, -40.0, 0, 0, 0, 0, 0, M.MAV_MOUNT_MODE_MAVLINK_TARGETING)
        assert ack.result == M.MAV_RESULT_ACCEPTED
        t0, tilt0 = sim.truth().time_s, sim.truth().tilt_rad
        gcs.run_for(0.5)
        t1, tilt1 = sim.truth().time_s, sim.truth().tilt_rad
        assert 0 < tilt1 - tilt0 <= math.radians(20) * (t1 - t0) + 1e-9  # the servo's slew rate
        gcs.run_for(4.0)
        truth = sim.truth()
        # earth-frame depression = body tilt - pitch: 40 deg, so the servo sits at 45 deg
        assert abs(math.degrees(truth.tilt_rad - truth.pitch_rad) - 40.0) < 0.3
        assert abs(math.degrees(truth.tilt_rad) - 45.0) < 0.3
        status = gcs.wait_for("GIMBAL_DEVICE_ATTITUDE_STATUS", 2.0)
        assert abs(_status_pitch_deg(status) + 40.0) < 1e-3  # the target, not the servo angle
        assert status.flags == M.GIMBAL_DEVICE_FLAGS_ROLL_LOCK | M.GIMBAL_DEVICE_FLAGS_PITCH_LOCK
        assert status.gimbal_device_id == 1 and math.isnan(status.angular_velocity_y)


def test_unstabilised_mount_type_outputs_the_target_as_a_body_angle():
    cfg = vehicle_config(mount=LIMITS, start_depth_m=2, disturbance=TRIM, params={"MNT1_TYPE": 7})
    with running_vehicle(config=cfg) as (sim, gcs):
        gcs.command(M.MAV_CMD_DO_MOUNT_CONTROL, -40.0, 0, 0, 0, 0, 0, M.MAV_MOUNT_MODE_MAVLINK_TARGETING)
        gcs.run_for(4.5)
        assert abs(math.degrees(sim.truth().tilt_rad) - 40.0) < 0.01


def test_mount_control_takes_its_mode_from_param7_and_refuses_centidegrees():
    """handle_command_do_mount_control: the mode is param7 (0 = RETRACT); |pitch| > 90 ->
    FAILED "invalid angle targets"; angle limits from MNT1_PITCH_MIN/MAX."""
    with running_vehicle(config=vehicle_config(mount=LIMITS, start_depth_m=2, disturbance=LEVEL)) as (sim, gcs):
        assert gcs.command(M.MAV_CMD_DO_MOUNT_CONTROL, -4000.0, 0, 0, 0, 0, 0, 2).result == M.MAV_RESULT_FAILED
        assert any("invalid angle targets" in m.text for m in gcs.log if m.get_type() == "STATUSTEXT")
        gcs.command(M.MAV_CMD_DO_MOUNT_CONTROL, -89.0, 0, 0, 0, 0, 0, 2)
        gcs.run_for(5.0)
        assert abs(math.degrees(sim.truth().tilt_rad) - 60.0) < 0.5  # clamped at the limit
        assert gcs.command(M.MAV_CMD_DO_MOUNT_CONTROL, -30.0).result == M.MAV_RESULT_ACCEPTED  # param7 0: RETRACT
        gcs.run_for(4.0)
        assert abs(math.degrees(sim.truth().tilt_rad)) < 0.5


def test_gimbal_manager_needs_pitch_and_yaw_and_a_mode_change_returns_to_rc_targeting():
    """DO_GIMBAL_MANAGER_PITCHYAW: pitch-only (yaw NaN) FAILED. Any mode change:
    set_mode_to_default (RC_TARGETING), which holds the last angle with the stick neutral;
    a tilt button then moves it at MNT1_RC_RATE."""
    with running_vehicle(config=vehicle_config(mount=LIMITS, start_depth_m=2, disturbance=LEVEL)) as (sim, gcs):
        nan = math.nan
        assert gcs.command(M.MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW, -25.0, nan, nan, nan).result == M.MAV_RESULT_FAILED
        assert gcs.command(M.MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW, -25.0, 0.0, nan, nan).result == M.MAV_RESULT_ACCEPTED
        gcs.run_for(3.0)
        assert abs(math.degrees(sim.truth().tilt_rad) - 25.0) < 0.3
        assert gcs.set_mode(int(Mode.STABILIZE)).result == M.MAV_RESULT_ACCEPTED
        gcs.run_for(2.0)
        assert sim.autopilot.mount.mode == M.MAV_MOUNT_MODE_RC_TARGETING
        assert abs(math.degrees(sim.truth().tilt_rad) - 25.0) < 0.3  # held
        gcs.auto_manual_control = False
        for _ in range(10):  # tilt-down button held 1 s: 30 deg/s at the stick's full throw
            gcs.manual_control(buttons=1 << 9)
            gcs.run_for(0.1)
        gcs.auto_manual_control = True
        gcs.run_for(1.0)
        assert 50.0 < math.degrees(sim.truth().tilt_rad) < 58.0


def test_without_a_mount_every_mount_command_fails_and_messages_are_dropped():
    """MNT1_TYPE 0: AP_Mount has no backend, ``get_primary()`` is null, so DO_MOUNT_CONTROL,
    DO_MOUNT_CONFIGURE and the gimbal-manager commands are FAILED (AP_Mount::handle_command_*)."""
    cfg = vehicle_config(mount=LIMITS, start_depth_m=2, disturbance=LEVEL, params={"MNT1_TYPE": 0})
    with running_vehicle(config=cfg) as (sim, gcs):
        tilt0 = sim.truth().tilt_rad
        for command, params in ((M.MAV_CMD_DO_MOUNT_CONTROL, (-30.0, 0, 0, 0, 0, 0, 2)),
                                (M.MAV_CMD_DO_MOUNT_CONFIGURE, (2, 0, 0, 0, 0, 0, 0)),
                                (M.MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW, (-30.0, 0.0, math.nan, math.nan, 0, 0, 0)),
                                (M.MAV_CMD_DO_GIMBAL_MANAGER_CONFIGURE, (-2, -2, -1, -1, 0, 0, 0))):
            assert gcs.command(command, *params).result == M.MAV_RESULT_FAILED, command
        gcs.conn.mav.gimbal_manager_set_pitchyaw_send(1, 1, 0, 0, math.radians(-30.0), 0.0, math.nan, math.nan)
        gcs.run_for(2.0)
        assert sim.truth().tilt_rad == tilt0


def test_mount_configure_sets_the_mode_the_mount_control_message_needs():
    """DO_MOUNT_CONFIGURE calls ``backend->set_mode(param1)``; MOUNT_CONTROL then moves the
    mount, which it does only in MAVLink targeting (``handle_mount_control``)."""
    with running_vehicle(config=vehicle_config(mount=LIMITS, start_depth_m=2, disturbance=LEVEL)) as (sim, gcs):
        assert sim.autopilot.mount.mode == M.MAV_MOUNT_MODE_RC_TARGETING  # MNT1_DEFLT_MODE 3
        pitch0 = sim.autopilot.mount.pitch_rad
        gcs.conn.mav.mount_control_send(1, 1, -3000, 0, 0, 0)  # ignored in RC targeting
        gcs.run_for(1.0)
        assert sim.autopilot.mount.pitch_rad == pitch0
        ack = gcs.command(M.MAV_CMD_DO_MOUNT_CONFIGURE, M.MAV_MOUNT_MODE_MAVLINK_TARGETING, 0, 0, 0, 0, 0, 0)
        assert ack.result == M.MAV_RESULT_ACCEPTED
        gcs.conn.mav.mount_control_send(1, 1, -3000, 0, 0, 0)  # centidegrees: 30 deg down
        gcs.run_for(3.0)
        assert abs(math.degrees(sim.truth().tilt_rad) - 30.0) < 0.3


def test_gimbal_manager_configure_and_device_ids():
    """DO_GIMBAL_MANAGER_CONFIGURE: FAILED for param1 or param2 outside -3..255, else
    ACCEPTED (AP_Mount_Backend::handle_command_do_gimbal_manager_configure). The gimbal
    device id (param7 of the commands, ``gimbal_device_id`` of GIMBAL_MANAGER_SET_PITCHYAW):
    0 is the primary and N instance N - 1, so with one mount 2 finds none: FAILED, or the
    message dropped."""
    nan = math.nan
    with running_vehicle(config=vehicle_config(mount=LIMITS, start_depth_m=2, disturbance=LEVEL)) as (sim, gcs):
        configure = M.MAV_CMD_DO_GIMBAL_MANAGER_CONFIGURE
        assert gcs.command(configure, -2, -2, -1, -1, 0, 0, 0).result == M.MAV_RESULT_ACCEPTED
        assert gcs.command(configure, 300, 0, -1, -1, 0, 0, 0).result == M.MAV_RESULT_FAILED
        assert gcs.command(configure, -2, -4, -1, -1, 0, 0, 0).result == M.MAV_RESULT_FAILED
        assert gcs.command(configure, -2, -2, -1, -1, 0, 0, 2).result == M.MAV_RESULT_FAILED
        pitchyaw = M.MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW
        assert gcs.command(pitchyaw, -20.0, 0.0, nan, nan, 0, 0, 2).result == M.MAV_RESULT_FAILED
        assert gcs.command(pitchyaw, -20.0, 0.0, nan, nan, 0, 0, 1).result == M.MAV_RESULT_ACCEPTED
        gcs.run_for(3.0)
        assert abs(math.degrees(sim.truth().tilt_rad) - 20.0) < 0.3
        gcs.conn.mav.gimbal_manager_set_pitchyaw_send(1, 1, 0, 2, math.radians(-40.0), 0.0, nan, nan)  # device 2
        gcs.run_for(3.0)
        assert abs(math.degrees(sim.truth().tilt_rad) - 20.0) < 0.3
        gcs.conn.mav.gimbal_manager_set_pitchyaw_send(1, 1, 0, 0, math.radians(-40.0), 0.0, nan, nan)  # primary
        gcs.run_for(3.0)
        assert abs(math.degrees(sim.truth().tilt_rad) - 40.0) < 0.3
