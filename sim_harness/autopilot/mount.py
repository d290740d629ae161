"""The camera mount as ArduSub 4.5 drives it (AP_Mount_Backend, AP_Mount_Servo).

Angles here are MAVLink's: mount *pitch* in radians, positive up (the sonar's tilt is
``-pitch``). Sources: Sub-4.5 @30257f0118, ``libraries/AP_Mount``.

- **Type and frame.** ``MNT1_TYPE`` 1 (servo, Sub's default) is *stabilised*: the target
  pitch is earth-frame and the servo output is the target less the AHRS pitch
  (``AP_Mount_Servo::update_angle_outputs``, ``requires_stabilization``); type 7
  (brushless PWM) outputs the target as it is. Read once, at boot (the parameter needs a
  reboot).
- **Modes.** ``set_angle_target`` clamps to MNT1_PITCH_MIN/MAX and switches to
  MAVLINK_TARGETING (``AP_Mount_Backend::set_angle_target``). RC_TARGETING (the default,
  ``MNT1_DEFLT_MODE`` 3) integrates the pilot's tilt input at ``MNT1_RC_RATE`` deg/s from
  the angle it holds (``get_rc_target``, ``update_angle_target_from_rate``), so a neutral
  stick holds the last angle. A change of the pilot's tilt input by more than 10 us
  switches back to RC_TARGETING (``set_rctargeting_on_rcinput_change``), as does every
  flight-mode change (``Sub::exit_mode`` -> ``camera_mount.set_mode_to_default()``).
- **Commands.** MAV_CMD_DO_MOUNT_CONTROL takes its mode from param7 and, for MAVLink
  targeting, refuses |pitch| > 90 deg with FAILED and "invalid angle targets"
  (``handle_command_do_mount_control``). MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW needs pitch
  *and* yaw (or both rates) non-NaN, else FAILED (``AP_Mount::
  handle_command_do_gimbal_manager_pitchyaw``). MOUNT_CONTROL acts only in MAVLink
  targeting (``handle_mount_control``). DO_MOUNT_CONFIGURE sets the mode; without a mount
  (``MNT1_TYPE`` 0) every mount command is FAILED (:meth:`Mount.command`). Not simulated:
  GPS_POINT and SYSID targets and the HOME_LOCATION mode's aiming (the mount holds its angle
  in those modes here; ArduSub 4.5 aims it at the place), so DO_MOUNT_CONTROL in GPS_POINT
  is FAILED here where ArduSub accepts it.
- **Status.** GIMBAL_DEVICE_ATTITUDE_STATUS carries the *target* (the servo has no
  feedback, ``AP_Mount_Servo::get_attitude_quaternion``) with ROLL_LOCK | PITCH_LOCK set
  whatever the type (``get_gimbal_device_flags``), gimbal_device_id = instance + 1.
"""

from __future__ import annotations

import math

from pymavlink.dialects.v20 import ardupilotmega as mavlink

M = mavlink
RC_INPUT_DEADZONE_US = 10  # max(dead zone, 10) in set_rctargeting_on_rcinput_change
RC_NEUTRAL_US = 1500
RC_HALF_RANGE_US = 400.0  # 1100..1900 (ArduSub joystick.cpp clamps overrides there)


class Mount:
    """Mount mode and target; :meth:`servo_output_rad` gives the body-frame servo angle."""

    def __init__(self, *, mount_type: int, default_mode: int, pitch_min_deg: float,
                 pitch_max_deg: float, rc_rate_deg_s: float) -> None:
        self.stabilised = mount_type == 1  # AP_Mount::init: Servo(requires_stab=true)
        self.present = mount_type != 0
        self.default_mode = default_mode
        self.pitch_min_rad = math.radians(pitch_min_deg)
        self.pitch_max_rad = math.radians(pitch_max_deg)
        self.rc_rate_rad_s = math.radians(rc_rate_deg_s)
        self.mode = default_mode
        self.pitch_rad = 0.0  # the target (earth-frame when stabilised)
        self._rate_rad_s: float | None = None  # a MAVLink rate target
        self._last_rc_us = RC_NEUTRAL_US

    def _clamp(self, pitch_rad: float) -> float:
        return min(max(pitch_rad, self.pitch_min_rad), self.pitch_max_rad)

    # ------------------------------------------------------------------ targets
    def set_angle_target(self, pitch_deg: float) -> None:
        """``AP_Mount_Backend::set_angle_target``: clamp, angle target, MAVLink targeting."""
        self.pitch_rad = self._clamp(math.radians(pitch_deg))
        self._rate_rad_s = None
        self.mode = M.MAV_MOUNT_MODE_MAVLINK_TARGETING

    def set_rate_target(self, pitch_rate_deg_s: float) -> None:
        """``AP_Mount_Backend::set_rate_target``: rate target, MAVLink targeting."""
        self._rate_rad_s = math.radians(pitch_rate_deg_s)
        self.mode = M.MAV_MOUNT_MODE_MAVLINK_TARGETING

    def set_mode_to_default(self) -> None:
        """``AP_Mount::set_mode_to_default`` (every flight-mode change in Sub 4.5)."""
        self.mode = self.default_mode
        self._rate_rad_s = None

    def centre(self) -> None:
        """The joystick's mount-centre button (ArduSub joystick.cpp): angles 0, RC targeting."""
        self.pitch_rad = 0.0
        self._rate_rad_s = None
        self.mode = M.MAV_MOUNT_MODE_RC_TARGETING

    # ------------------------------------------------------------------ commands
    def do_mount_control(self, pitch_deg: float, roll_deg: float, yaw_deg: float,
                         mode: int) -> tuple[int, str | None]:
        """MAV_CMD_DO_MOUNT_CONTROL: (MAV_RESULT, warning text or None)."""
        if mode in (M.MAV_MOUNT_MODE_RETRACT, M.MAV_MOUNT_MODE_NEUTRAL,
                    M.MAV_MOUNT_MODE_RC_TARGETING, M.MAV_MOUNT_MODE_HOME_LOCATION):
            self.mode = mode
            self._rate_rad_s = None
            return M.MAV_RESULT_ACCEPTED, None
        if mode == M.MAV_MOUNT_MODE_MAVLINK_TARGETING:
            if abs(pitch_deg) > 90 or abs(roll_deg) > 180 or abs(yaw_deg) > 360:
                return M.MAV_RESULT_FAILED, "Mount: invalid angle targets"
            self.set_angle_target(pitch_deg)
            return M.MAV_RESULT_ACCEPTED, None
        return M.MAV_RESULT_FAILED, None  # GPS_POINT / SYSID targets are not simulated

    def gimbal_manager_pitchyaw(self, pitch_deg: float, yaw_deg: float, pitch_rate_deg_s: float,
                                yaw_rate_deg_s: float, flags: int) -> int:
        """MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW (also GIMBAL_MANAGER_SET_PITCHYAW): MAV_RESULT."""
        if flags & M.GIMBAL_MANAGER_FLAGS_RETRACT:
            self.mode = M.MAV_MOUNT_MODE_RETRACT
            return M.MAV_RESULT_ACCEPTED
        if flags & M.GIMBAL_MANAGER_FLAGS_NEUTRAL:
            self.mode = M.MAV_MOUNT_MODE_NEUTRAL
            return M.MAV_RESULT_ACCEPTED
        if not (math.isnan(pitch_deg) or math.isnan(yaw_deg)):
            self.set_angle_target(pitch_deg)
            return M.MAV_RESULT_ACCEPTED
        if not (math.isnan(pitch_rate_deg_s) or math.isnan(yaw_rate_deg_s)):
            self.set_rate_target(pitch_rate_deg_s)
            return M.MAV_RESULT_ACCEPTED
        return M.MAV_RESULT_FAILED

    def mount_control_message(self, pitch_cdeg: float) -> None:
        """MOUNT_CONTROL (deprecated message): only in MAVLink targeting, centidegrees
        (``AP_Mount::handle_mount_control``: dropped without a mount)."""
        if self.present and self.mode == M.MAV_MOUNT_MODE_MAVLINK_TARGETING:
            self.set_angle_target(pitch_cdeg * 0.01)

    def command(self, command: int, p: tuple[float, ...]) -> tuple[int, str | None]:
        """The mount's commands as ``AP_Mount::handle_command`` takes them: (MAV_RESULT,
        warning text or None).

        - No mount (``MNT1_TYPE`` 0): ``get_primary()`` is null, so every one is FAILED.
        - DO_MOUNT_CONFIGURE: ``backend->set_mode(param1)`` (modes RETRACT..HOME_LOCATION;
          another is ignored), ACCEPTED (``handle_command_do_mount_configure``).
        - DO_MOUNT_CONTROL: the mode from param7 (:meth:`do_mount_control`).
        - DO_GIMBAL_MANAGER_PITCHYAW and _CONFIGURE: gimbal device id in param7, 0 the
          primary and N instance N - 1: one mount here, so only 0 and 1 reach it, another
          is FAILED (``handle_command_do_gimbal_manager_pitchyaw`` / ``_configure``).
          CONFIGURE is FAILED when param1 or param2 lies outside -3..255, else ACCEPTED
          (``AP_Mount_Backend::handle_command_do_gimbal_manager_configure``); the control
          id it records feeds only GIMBAL_MANAGER_STATUS, which this vehicle does not send.
        """
        if not self.present:
            return M.MAV_RESULT_FAILED, None
        if command == M.MAV_CMD_DO_MOUNT_CONTROL:
            return self.do_mount_control(p[0], p[1], p[2], int(p[6]))
        if command == M.MAV_CMD_DO_MOUNT_CONFIGURE:
            mode = int(p[0])
            if M.MAV_MOUNT_MODE_RETRACT <= mode <= M.MAV_MOUNT_MODE_HOME_LOCATION:  # valid_mode
                self.mode = mode
                self._rate_rad_s = None
            return M.MAV_RESULT_ACCEPTED, None
        if not self.reaches(int(p[6])):
            return M.MAV_RESULT_FAILED, None
        if command == M.MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW:
            return self.gimbal_manager_pitchyaw(p[0], p[1], p[2], p[3], int(p[4])), None
        if command == M.MAV_CMD_DO_GIMBAL_MANAGER_CONFIGURE:
            ok = all(-3 <= v <= 255 for v in (p[0], p[1]))
            return (M.MAV_RESULT_ACCEPTED if ok else M.MAV_RESULT_FAILED), None
        return M.MAV_RESULT_UNSUPPORTED, None

    def reaches(self, gimbal_device_id: int) -> bool:
        """Whether a gimbal-manager command or message for ``gimbal_device_id`` reaches this
        mount (0: the primary, N: instance N - 1; one instance here)."""
        return self.present and gimbal_device_id in (0, 1)

    def mission_pitchyaw(self, pitch_deg: float, yaw_deg: float, pitch_rate_deg_s: float,
                         yaw_rate_deg_s: float, flags: int) -> None:
        """A mission's DO_GIMBAL_MANAGER_PITCHYAW (``AP_Mission::
        start_command_do_gimbal_manager_pitchyaw``): stored as whole degrees, so the angle
        is valid whenever |pitch| <= 90 and |yaw| <= 360."""
        if flags & (M.GIMBAL_MANAGER_FLAGS_RETRACT | M.GIMBAL_MANAGER_FLAGS_NEUTRAL):
            self.gimbal_manager_pitchyaw(math.nan, math.nan, math.nan, math.nan, int(flags))
        elif abs(pitch_deg) <= 90 and abs(yaw_deg) <= 360:
            self.set_angle_target(float(pitch_deg))
        else:
            self.set_rate_target(float(pitch_rate_deg_s))
        del yaw_rate_deg_s

    # ------------------------------------------------------------------ update
    def update(self, dt_s: float, rc8_us: int | None) -> None:
        """One mount update (``AP_Mount_Servo::update``): RC change detection, RC or rate
        targets integrated. ``rc8_us`` is the pilot's tilt channel (None: no RC input)."""
        if rc8_us is not None:
            if self.mode not in (M.MAV_MOUNT_MODE_RC_TARGETING, M.MAV_MOUNT_MODE_RETRACT) and \
                    abs(self._last_rc_us - rc8_us) > RC_INPUT_DEADZONE_US:
                self.mode = M.MAV_MOUNT_MODE_RC_TARGETING
                self._rate_rad_s = None
            if self.mode in (M.MAV_MOUNT_MODE_RC_TARGETING, M.MAV_MOUNT_MODE_RETRACT):
                self._last_rc_us = rc8_us
        if self.mode in (M.MAV_MOUNT_MODE_RETRACT, M.MAV_MOUNT_MODE_NEUTRAL):
            self.pitch_rad = 0.0  # the target becomes the retract/neutral angle (0 by default)
        elif self.mode == M.MAV_MOUNT_MODE_RC_TARGETING and self.rc_rate_rad_s > 0:
            stick = 0.0 if rc8_us is None else max(-1.0, min(1.0, (rc8_us - RC_NEUTRAL_US) / RC_HALF_RANGE_US))
            self.pitch_rad = self._clamp(self.pitch_rad + stick * self.rc_rate_rad_s * dt_s)
        elif self.mode == M.MAV_MOUNT_MODE_MAVLINK_TARGETING and self._rate_rad_s is not None:
            self.pitch_rad = self._clamp(self.pitch_rad + self._rate_rad_s * dt_s)

    def servo_output_rad(self, vehicle_pitch_rad: float) -> float:
        """Body-frame servo pitch (``update_angle_outputs``): earth-frame target less the
        AHRS pitch when stabilised, the target itself otherwise; RETRACT/NEUTRAL at 0
        (MNT1_RETRACT_Y / MNT1_NEUTRAL_Y default 0). Clamped to the servo's range."""
        if self.mode in (M.MAV_MOUNT_MODE_RETRACT, M.MAV_MOUNT_MODE_NEUTRAL):
            return 0.0
        out = self.pitch_rad - (vehicle_pitch_rad if self.stabilised else 0.0)
        return self._clamp(out)

    def status_message(self, boot_ms: int) -> mavlink.MAVLink_message:
        """GIMBAL_DEVICE_ATTITUDE_STATUS as ``send_gimbal_device_attitude_status`` sends it."""
        flags = M.GIMBAL_DEVICE_FLAGS_ROLL_LOCK | M.GIMBAL_DEVICE_FLAGS_PITCH_LOCK
        if self.mode == M.MAV_MOUNT_MODE_RETRACT:
            flags |= M.GIMBAL_DEVICE_FLAGS_RETRACT
        elif self.mode == M.MAV_MOUNT_MODE_NEUTRAL:
            flags |= M.GIMBAL_DEVICE_FLAGS_NEUTRAL
        pitch = self.pitch_rad
        q = [math.cos(pitch / 2), 0.0, math.sin(pitch / 2), 0.0]  # from_euler(0, pitch, 0)
        nan = float("nan")
        return M.MAVLink_gimbal_device_attitude_status_message(
            0, 0, boot_ms, flags, q, nan, nan, nan, 0, nan, nan, 1)
