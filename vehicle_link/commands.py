"""Pure builders of the MAVLink messages vehicle_link sends (no I/O here).

A command is first a :class:`CommandSpec` (MAV_CMD number and seven parameters), then a
COMMAND_LONG message for a given target; the client sends it and waits for COMMAND_ACK.
Position targets are fire-and-forget messages (ArduSub does not acknowledge them).

Sign and unit conventions: see :mod:`vehicle_link.units`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from vehicle_link import units
from vehicle_link.dialect import mavlink2
from vehicle_link.modes import SubMode

# POSITION_TARGET_TYPEMASK bits (a set bit means "ignore this field").
TYPE_MASK_X_IGNORE = 1
TYPE_MASK_Y_IGNORE = 2
TYPE_MASK_Z_IGNORE = 4
TYPE_MASK_VX_IGNORE = 8
TYPE_MASK_VY_IGNORE = 16
TYPE_MASK_VZ_IGNORE = 32
TYPE_MASK_AX_IGNORE = 64
TYPE_MASK_AY_IGNORE = 128
TYPE_MASK_AZ_IGNORE = 256
TYPE_MASK_FORCE_SET = 512
TYPE_MASK_YAW_IGNORE = 1024
TYPE_MASK_YAW_RATE_IGNORE = 2048

_VEL_IGNORE = TYPE_MASK_VX_IGNORE | TYPE_MASK_VY_IGNORE | TYPE_MASK_VZ_IGNORE
_ACC_IGNORE = TYPE_MASK_AX_IGNORE | TYPE_MASK_AY_IGNORE | TYPE_MASK_AZ_IGNORE
_YAW_IGNORE = TYPE_MASK_YAW_IGNORE | TYPE_MASK_YAW_RATE_IGNORE

#: Only z (depth) is used: ArduSub's ALT_HOLD reads ``alt`` and nothing else.
TYPE_MASK_DEPTH_ONLY = (
    TYPE_MASK_X_IGNORE | TYPE_MASK_Y_IGNORE | _VEL_IGNORE | _ACC_IGNORE | _YAW_IGNORE
)
#: Position only (x, y, z), yaw free.
TYPE_MASK_POSITION = _VEL_IGNORE | _ACC_IGNORE | _YAW_IGNORE
#: Position and yaw.
TYPE_MASK_POSITION_YAW = _VEL_IGNORE | _ACC_IGNORE | TYPE_MASK_YAW_RATE_IGNORE
#: Position and velocity (GUIDED's Guided_PosVel): the position target advances with the
#: velocity, and 3 s without a new one the velocity is zeroed and the position held
#: (ArduSub 4.5 mode_guided.cpp GUIDED_POSVEL_TIMEOUT_MS).
TYPE_MASK_POSITION_VELOCITY = _ACC_IGNORE | _YAW_IGNORE
#: Position, velocity and yaw.
TYPE_MASK_POSITION_VELOCITY_YAW = _ACC_IGNORE | TYPE_MASK_YAW_RATE_IGNORE

#: param2 of COMPONENT_ARM_DISARM that skips the pre-arm checks when arming (GCS.h
#: ``magic_force_arm_value``) and forces a disarm (``magic_force_disarm_value``).
ARM_FORCE_MAGIC = 2989
DISARM_FORCE_MAGIC = 21196
MAV_COMP_ID_ONBOARD_COMPUTER = 191
MAV_COMP_ID_AUTOPILOT1 = 1


@dataclass(frozen=True)
class CommandSpec:
    """A MAV_CMD and its seven parameters, as sent in COMMAND_LONG."""

    command: int
    params: tuple[float, float, float, float, float, float, float]

    @property
    def name(self) -> str:
        """The MAV_CMD name (or ``MAV_CMD(n)``)."""
        entry = mavlink2.enums["MAV_CMD"].get(self.command)
        return entry.name if entry is not None else f"MAV_CMD({self.command})"


def _spec(command: int, *params: float) -> CommandSpec:
    padded = tuple(float(p) for p in params) + (0.0,) * (7 - len(params))
    return CommandSpec(command, padded)  # type: ignore[arg-type]


def arm_disarm(arm: bool, *, force: bool = False) -> CommandSpec:
    """MAV_CMD_COMPONENT_ARM_DISARM; ``force`` skips the pre-arm checks (2989) or forces a
    disarm (21196) - use with care."""
    magic = ARM_FORCE_MAGIC if arm else DISARM_FORCE_MAGIC
    return _spec(mavlink2.MAV_CMD_COMPONENT_ARM_DISARM, 1.0 if arm else 0.0, float(magic) if force else 0.0)


def set_mode(mode: SubMode | int) -> CommandSpec:
    """MAV_CMD_DO_SET_MODE with MAV_MODE_FLAG_CUSTOM_MODE_ENABLED and ArduSub's mode number."""
    return _spec(
        mavlink2.MAV_CMD_DO_SET_MODE,
        float(mavlink2.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED),
        float(int(mode)),
    )


def message_interval(message_id: int, interval_s: float | None) -> CommandSpec:
    """MAV_CMD_SET_MESSAGE_INTERVAL.

    Parameters
    ----------
    message_id : int
        MAVLink message id.
    interval_s : float or None
        Period in seconds (> 0); ``None`` restores the default rate; ``0`` or negative
        stops the stream (sent as -1).
    """
    if interval_s is None:
        interval_us = 0.0
    elif interval_s <= 0.0:
        interval_us = -1.0
    else:
        interval_us = float(units.s_to_us(interval_s))
    return _spec(mavlink2.MAV_CMD_SET_MESSAGE_INTERVAL, float(message_id), interval_us)


def mount_control(tilt_rad: float, *, centidegrees: bool = False) -> CommandSpec:
    """MAV_CMD_DO_MOUNT_CONTROL, MAVLink targeting mode.

    param1 = pitch (up positive = -tilt), param2 = roll, param3 = yaw, param7 = mode.
    ArduSub 4.3+ reads the angles in degrees; older firmware (4.1) passed them through
    an int32 centidegree path, so ``centidegrees=True`` sends pitch * 100 for it.
    """
    pitch_deg = units.mount_pitch_deg_from_tilt_rad(tilt_rad)
    pitch = float(round(pitch_deg * 100.0)) if centidegrees else pitch_deg
    return _spec(
        mavlink2.MAV_CMD_DO_MOUNT_CONTROL,
        pitch,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        float(mavlink2.MAV_MOUNT_MODE_MAVLINK_TARGETING),
    )


def gimbal_manager_pitchyaw(tilt_rad: float, *, gimbal_device_id: int = 0) -> CommandSpec:
    """MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW: pitch (deg, = -tilt), yaw 0 in body frame, rates NaN."""
    return _spec(
        mavlink2.MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW,
        units.mount_pitch_deg_from_tilt_rad(tilt_rad),
        0.0,
        math.nan,
        math.nan,
        0.0,
        0.0,
        float(gimbal_device_id),
    )


def mission_start() -> CommandSpec:
    """MAV_CMD_MISSION_START from the first item (ArduSub refuses other first/last items)."""
    return _spec(mavlink2.MAV_CMD_MISSION_START, 0.0, 0.0)


def set_mission_current(seq: int) -> CommandSpec:
    """MAV_CMD_DO_SET_MISSION_CURRENT (param1 = item number)."""
    if seq < 0:
        raise ValueError(f"mission item number must be >= 0, got {seq}")
    return _spec(mavlink2.MAV_CMD_DO_SET_MISSION_CURRENT, float(seq))


def command_long(
    spec: CommandSpec, target_system: int, target_component: int, confirmation: int = 0
) -> mavlink2.MAVLink_command_long_message:
    """COMMAND_LONG for ``spec``; ``confirmation`` counts retransmissions (0 the first time)."""
    return mavlink2.MAVLink_command_long_message(
        target_system, target_component, spec.command, min(confirmation, 255), *spec.params
    )


def param_set(
    name: str, value: float, target_system: int, target_component: int
) -> mavlink2.MAVLink_param_set_message:
    """PARAM_SET of a float parameter (ArduPilot stores every parameter as a float).

    Raises
    ------
    ValueError
        For a name longer than MAVLink's 16 characters, or a value that is not finite.
    """
    if not name or len(name) > 16:
        raise ValueError(f"parameter name must be 1-16 characters, got {name!r}")
    if not math.isfinite(value):
        raise ValueError(f"parameter {name} value must be finite, got {value!r}")
    return mavlink2.MAVLink_param_set_message(
        target_system, target_component, name.encode("ascii"), float(value), mavlink2.MAV_PARAM_TYPE_REAL32
    )


def heartbeat_onboard_computer() -> mavlink2.MAVLink_heartbeat_message:
    """Our heartbeat: MAV_TYPE_ONBOARD_CONTROLLER, no autopilot, state ACTIVE."""
    return mavlink2.MAVLink_heartbeat_message(
        mavlink2.MAV_TYPE_ONBOARD_CONTROLLER,
        mavlink2.MAV_AUTOPILOT_INVALID,
        0,
        0,
        mavlink2.MAV_STATE_ACTIVE,
        3,
    )


def depth_target_global_int(
    depth_m: float, target_system: int, target_component: int, time_boot_ms: int
) -> mavlink2.MAVLink_set_position_target_global_int_message:
    """Depth target for ALT_HOLD: SET_POSITION_TARGET_GLOBAL_INT with only z used.

    ArduSub (4.0+) in ALT_HOLD sets its depth target to ``alt`` (metres above the origin,
    so ``-depth_m``) and ignores the frame and every other field.
    """
    return mavlink2.MAVLink_set_position_target_global_int_message(
        time_boot_ms & 0xFFFFFFFF,
        target_system,
        target_component,
        mavlink2.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
        TYPE_MASK_DEPTH_ONLY,
        0,
        0,
        units.depth_m_to_alt_m(depth_m),
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
    )


def position_target_local_ned(
    north_m: float,
    east_m: float,
    depth_m: float,
    target_system: int,
    target_component: int,
    time_boot_ms: int,
    *,
    yaw_rad: float | None = None,
) -> mavlink2.MAVLink_set_position_target_local_ned_message:
    """GUIDED position target about the EKF origin: SET_POSITION_TARGET_LOCAL_NED.

    ``z`` is down positive, equal to depth because ArduSub's origin is at the surface.
    """
    mask = TYPE_MASK_POSITION if yaw_rad is None else TYPE_MASK_POSITION_YAW
    return mavlink2.MAVLink_set_position_target_local_ned_message(
        time_boot_ms & 0xFFFFFFFF,
        target_system,
        target_component,
        mavlink2.MAV_FRAME_LOCAL_NED,
        mask,
        north_m,
        east_m,
        depth_m,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0 if yaw_rad is None else yaw_rad,
        0.0,
    )


def position_velocity_target_local_ned(
    north_m: float,
    east_m: float,
    depth_m: float,
    vel_north_m_s: float,
    vel_east_m_s: float,
    vel_down_m_s: float,
    target_system: int,
    target_component: int,
    time_boot_ms: int,
    *,
    yaw_rad: float | None = None,
) -> mavlink2.MAVLink_set_position_target_local_ned_message:
    """GUIDED position + velocity target (Guided_PosVel) about the EKF origin, NED.

    ArduSub 4.5 integrates the position by the velocity and zeroes the velocity 3 s after
    the last such message, holding the position it got to: a stream of these moving
    along a lane never restarts an S-curve, and stops the vehicle on its own when the
    stream stops.
    """
    mask = TYPE_MASK_POSITION_VELOCITY if yaw_rad is None else TYPE_MASK_POSITION_VELOCITY_YAW
    return mavlink2.MAVLink_set_position_target_local_ned_message(
        time_boot_ms & 0xFFFFFFFF,
        target_system,
        target_component,
        mavlink2.MAV_FRAME_LOCAL_NED,
        mask,
        north_m,
        east_m,
        depth_m,
        vel_north_m_s,
        vel_east_m_s,
        vel_down_m_s,
        0.0,
        0.0,
        0.0,
        0.0 if yaw_rad is None else yaw_rad,
        0.0,
    )


def set_gps_global_origin(
    latitude_deg: float, longitude_deg: float, altitude_m: float, target_system: int
) -> mavlink2.MAVLink_set_gps_global_origin_message:
    """SET_GPS_GLOBAL_ORIGIN: ArduSub sets its EKF origin once (later ones are ignored) and
    answers with GPS_GLOBAL_ORIGIN (``GCS_MAVLINK::set_ekf_origin``); altitude in mm."""
    return mavlink2.MAVLink_set_gps_global_origin_message(
        target_system, units.deg_to_dege7(latitude_deg), units.deg_to_dege7(longitude_deg),
        int(round(units.m_to_mm(altitude_m))), 0)


def request_message(message_id: int) -> CommandSpec:
    """MAV_CMD_REQUEST_MESSAGE (ArduSub: ACCEPTED even when it has nothing to send)."""
    return _spec(mavlink2.MAV_CMD_REQUEST_MESSAGE, float(message_id))


def get_home_position() -> CommandSpec:
    """MAV_CMD_GET_HOME_POSITION (ArduSub: FAILED without a home)."""
    return _spec(mavlink2.MAV_CMD_GET_HOME_POSITION)


def gimbal_manager_pitch_deg(tilt_rad: float) -> float:
    """The whole-degree pitch a DO_GIMBAL_MANAGER_PITCHYAW *mission item* carries (AP_Mission
    stores it as int8 degrees, truncated toward zero)."""
    return float(math.trunc(units.mount_pitch_deg_from_tilt_rad(tilt_rad)))


def distance_sensor(
    range_m: float,
    min_range_m: float,
    max_range_m: float,
    time_boot_ms: int,
    *,
    sensor_id: int = 0,
    signal_quality_pct: int | None = None,
) -> mavlink2.MAVLink_distance_sensor_message:
    """Our altimeter as DISTANCE_SENSOR pointing down (ArduSub: RNGFND1_TYPE = 10, MAVLink).

    Ranges in metres, sent in whole centimetres; a reading outside [min, max] is clamped to
    max + 1 cm, which ArduPilot treats as "out of range high".
    """
    if not (0.0 <= min_range_m < max_range_m):
        raise ValueError(
            f"altimeter limits must satisfy 0 <= min < max, got {min_range_m}, {max_range_m}"
        )
    if not math.isfinite(range_m):
        raise ValueError(f"altimeter range must be finite, got {range_m}")
    current_cm = int(round(units.m_to_cm(range_m)))
    max_cm = int(round(units.m_to_cm(max_range_m)))
    if range_m > max_range_m or range_m < 0.0:
        current_cm = max_cm + 1
    quality = 0 if signal_quality_pct is None else max(1, min(100, int(signal_quality_pct)))
    return mavlink2.MAVLink_distance_sensor_message(
        time_boot_ms & 0xFFFFFFFF,
        int(round(units.m_to_cm(min_range_m))),
        max_cm,
        min(current_cm, 65535),
        mavlink2.MAV_DISTANCE_SENSOR_ULTRASOUND,
        sensor_id,
        mavlink2.MAV_SENSOR_ROTATION_PITCH_270,
        255,
        0.0,
        0.0,
        (0.0, 0.0, 0.0, 0.0),
        quality,
    )
