"""COMMAND_LONG / COMMAND_INT as ArduSub 4.5 answers them (the MAV_RESULT codes).

Dispatch: ``GCS_MAVLINK_Sub::handle_command_int_packet`` (ArduSub/GCS_Mavlink.cpp) for
Sub's own commands, then ``GCS_MAVLINK::handle_command_int_packet``
(libraries/GCS_MAVLink/GCS_Common.cpp); COMMAND_LONG goes through
``try_command_long_as_command_int`` to the same handlers. Sub-4.5 @30257f0118.

- COMPONENT_ARM_DISARM (``handle_command_component_arm_disarm``): param1 1 arms (with the
  pre-arm checks unless param2 is 2989), 0 disarms (21196 forces it); ACCEPTED when
  already in that state, FAILED when refused, UNSUPPORTED for any other param1.
- DO_SET_MODE: needs MAV_MODE_FLAG_CUSTOM_MODE_ENABLED; ACCEPTED or FAILED.
- MISSION_START: armed and the switch to AUTO, else FAILED (params ignored in 4.5).
- DO_SET_MISSION_CURRENT: a valid item, else FAILED.
- DO_CHANGE_SPEED: param2 > 0 sets the leg speed, else FAILED. CONDITION_YAW: 0..360 and
  param4 0/1, else DENIED; relative angles counter-clockwise for param3 < 0.
  NAV_LOITER_UNLIM -> POSHOLD, NAV_LAND -> SURFACE.
- GET_HOME_POSITION: FAILED without a home, else HOME_POSITION and GPS_GLOBAL_ORIGIN.
- REQUEST_MESSAGE: FAILED for an id without an ``ap_message``, else ACCEPTED (even when
  nothing can be sent). SET_MESSAGE_INTERVAL: DENIED and "No ap_message for mavlink id
  (N)" for an unmapped id. REQUEST_AUTOPILOT_CAPABILITIES: param1 must be 1.
- DO_MOUNT_CONTROL, DO_MOUNT_CONFIGURE, DO_GIMBAL_MANAGER_PITCHYAW and _CONFIGURE:
  ``handle_command_mount`` -> ``AP_Mount::handle_command`` (:meth:`~sim_harness.autopilot.
  mount.Mount.command`: FAILED without a mount, a gimbal device id other than 0 or 1).
- DO_FLIGHTTERMINATION (``GCS_MAVLINK_Sub::handle_flight_termination``): param1 > 0.5
  disarms at once, ACCEPTED; otherwise FAILED.
- DO_REPOSITION: UNSUPPORTED (added in 4.6), as is every command not listed; so are
  DO_SET_ROI* and DO_SET_ROI_SYSID here, which ArduSub 4.5 accepts (they aim the vehicle's
  yaw or the mount at a place or another vehicle, not simulated).
"""

from __future__ import annotations

import math
from typing import Protocol

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sim_harness.autopilot.telemetry import MAPPED_IDS

M = mavlink
FORCE_ARM_MAGIC = 2989.0  # GCS.h magic_force_arm_value
FORCE_DISARM_MAGIC = 21196.0  # GCS.h magic_force_disarm_value


class CommandTarget(Protocol):
    """What the command handlers act on (the autopilot)."""

    armed: bool

    def arm(self, *, force: bool) -> bool: ...

    def disarm(self, reason: str = "GCS", *, force: bool = False) -> bool: ...

    def set_mode(self, mode: int, *, reason: str = "GCS") -> bool: ...

    def start_mission(self) -> bool: ...

    def set_mission_current(self, seq: int) -> bool: ...

    def set_leg_speed(self, speed_m_s: float) -> None: ...

    def set_yaw_target(self, yaw_deg: float, relative: bool, direction: int = 1) -> None: ...

    def mount_command(self, command: int, p: tuple[float, ...]) -> int: ...

    def has_home(self) -> bool: ...

    def queue_message(self, msg_id: int) -> None: ...

    def set_message_interval(self, msg_id: int, interval_us: float, now_s: float) -> None: ...

    def text(self, severity: int, text: str) -> None: ...


def handle_command(ap: CommandTarget, command: int, p: tuple[float, ...], now_s: float) -> int:
    """The MAV_RESULT of one command (params 1-7 as floats; x/y of COMMAND_INT as floats)."""
    if command == M.MAV_CMD_COMPONENT_ARM_DISARM:
        return _arm_disarm(ap, p)
    if command == M.MAV_CMD_DO_SET_MODE:
        if not int(p[0]) & M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
            return M.MAV_RESULT_FAILED
        return M.MAV_RESULT_ACCEPTED if ap.set_mode(int(p[1])) else M.MAV_RESULT_FAILED
    if command == M.MAV_CMD_MISSION_START:
        return M.MAV_RESULT_ACCEPTED if ap.armed and ap.start_mission() else M.MAV_RESULT_FAILED
    if command == M.MAV_CMD_DO_SET_MISSION_CURRENT:
        return M.MAV_RESULT_ACCEPTED if ap.set_mission_current(int(p[0])) else M.MAV_RESULT_FAILED
    if command == M.MAV_CMD_DO_CHANGE_SPEED:
        if p[1] > 0.0:
            ap.set_leg_speed(p[1])
            return M.MAV_RESULT_ACCEPTED
        return M.MAV_RESULT_FAILED
    if command == M.MAV_CMD_CONDITION_YAW:
        if 0.0 <= p[0] <= 360.0 and p[3] in (0.0, 1.0):
            ap.set_yaw_target(p[0], relative=p[3] == 1.0, direction=int(p[2]))  # param3 as int8_t
            return M.MAV_RESULT_ACCEPTED
        return M.MAV_RESULT_DENIED
    if command == M.MAV_CMD_NAV_LOITER_UNLIM:
        return M.MAV_RESULT_ACCEPTED if ap.set_mode(16) else M.MAV_RESULT_FAILED
    if command == M.MAV_CMD_NAV_LAND:
        return M.MAV_RESULT_ACCEPTED if ap.set_mode(9) else M.MAV_RESULT_FAILED
    if command in (M.MAV_CMD_DO_MOUNT_CONTROL, M.MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW, M.MAV_CMD_DO_MOUNT_CONFIGURE,
                   M.MAV_CMD_DO_GIMBAL_MANAGER_CONFIGURE):  # GCS_MAVLINK::handle_command_mount
        return ap.mount_command(command, p)
    if command == M.MAV_CMD_GET_HOME_POSITION:
        if not ap.has_home():
            return M.MAV_RESULT_FAILED
        ap.queue_message(M.MAVLINK_MSG_ID_HOME_POSITION)
        ap.queue_message(M.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN)
        return M.MAV_RESULT_ACCEPTED
    if command == M.MAV_CMD_REQUEST_MESSAGE:
        msg_id = int(p[0])
        if msg_id not in MAPPED_IDS:
            return M.MAV_RESULT_FAILED
        ap.queue_message(msg_id)
        return M.MAV_RESULT_ACCEPTED
    if command == M.MAV_CMD_SET_MESSAGE_INTERVAL:
        msg_id = int(p[0])
        if msg_id not in MAPPED_IDS:
            ap.text(M.MAV_SEVERITY_INFO, f"No ap_message for mavlink id ({msg_id})")
            return M.MAV_RESULT_DENIED
        ap.set_message_interval(msg_id, p[1], now_s)
        return M.MAV_RESULT_ACCEPTED
    if command == M.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES:
        if p[0] != 1.0:
            return M.MAV_RESULT_FAILED
        ap.queue_message(M.MAVLINK_MSG_ID_AUTOPILOT_VERSION)
        return M.MAV_RESULT_ACCEPTED
    if command == M.MAV_CMD_DO_FLIGHTTERMINATION:  # GCS_MAVLINK_Sub::handle_flight_termination
        if p[0] > 0.5:
            ap.disarm("flight termination", force=True)
            return M.MAV_RESULT_ACCEPTED
        return M.MAV_RESULT_FAILED
    return M.MAV_RESULT_UNSUPPORTED  # DO_REPOSITION (4.6+) included


def _arm_disarm(ap: CommandTarget, p: tuple[float, ...]) -> int:
    if p[0] == 1.0:
        if ap.armed:
            return M.MAV_RESULT_ACCEPTED
        return M.MAV_RESULT_ACCEPTED if ap.arm(force=math.isclose(p[1], FORCE_ARM_MAGIC)) else M.MAV_RESULT_FAILED
    if p[0] == 0.0:
        if not ap.armed:
            return M.MAV_RESULT_ACCEPTED
        forced = math.isclose(p[1], FORCE_DISARM_MAGIC)
        return M.MAV_RESULT_ACCEPTED if ap.disarm("GCS", force=forced) else M.MAV_RESULT_FAILED
    return M.MAV_RESULT_UNSUPPORTED
