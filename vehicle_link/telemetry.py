"""Typed, timestamped telemetry records decoded from MAVLink messages.

``decode(msg, time_s)`` is pure: it reads the fields of a pymavlink message (any object
with ``get_type()`` and the MAVLink field names) and returns a frozen record in SI units,
stamped with ``time_s`` (the injected clock's time at reception), or ``None`` for a message
type that is not telemetry. All unit conversions come from :mod:`vehicle_link.units`.
Frames and signs follow architecture.md: NED, depth down positive, tilt down positive.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from vehicle_link import units
from vehicle_link.modes import mode_name
from vehicle_link.records import (
    MAV_SENSOR_ROTATION_PITCH_270,
    Attitude,
    EkfStatus,
    GlobalOrigin,
    GlobalPosition,
    Heartbeat,
    HomePosition,
    LocalPositionNed,
    MissionCurrent,
    MissionItemReached,
    MountStatus,
    ParamValue,
    PeerSeen,
    Pressure,
    Rangefinder,
    StatusText,
    SysStatus,
    TelemetryRecord,
)

__all__ = [
    "Attitude", "EkfStatus", "GlobalOrigin", "GlobalPosition", "Heartbeat", "HomePosition", "LocalPositionNed",
    "MissionCurrent", "MissionItemReached", "MountStatus", "ParamValue", "PeerSeen", "Pressure", "Rangefinder",
    "StatusText", "SysStatus", "TelemetryRecord", "TELEMETRY_MESSAGE_TYPES", "decode", "store_key",
]

MAV_MODE_FLAG_SAFETY_ARMED = 128
MAV_TYPE_SUBMARINE = 12
_UINT16_MAX = 65535
_INT16_MAX = 32767


def _text(value: Any) -> str:
    if isinstance(value, bytes | bytearray):
        return bytes(value).split(b"\x00", 1)[0].decode("utf-8", errors="replace")
    return str(value).split("\x00", 1)[0]


def _heartbeat(msg: Any, time_s: float) -> Heartbeat:
    return Heartbeat(
        time_s=time_s,
        system_id=int(msg.get_srcSystem()),
        component_id=int(msg.get_srcComponent()),
        mav_type=int(msg.type),
        autopilot=int(msg.autopilot),
        base_mode=int(msg.base_mode),
        custom_mode=int(msg.custom_mode),
        system_status=int(msg.system_status),
        armed=bool(msg.base_mode & MAV_MODE_FLAG_SAFETY_ARMED),
        mode_name=mode_name(int(msg.custom_mode)),
    )


def _attitude(msg: Any, time_s: float) -> Attitude:
    return Attitude(
        time_s=time_s,
        time_boot_s=units.ms_to_s(msg.time_boot_ms),
        roll_rad=float(msg.roll),
        pitch_rad=float(msg.pitch),
        yaw_rad=float(msg.yaw),
        roll_rate_rad_s=float(msg.rollspeed),
        pitch_rate_rad_s=float(msg.pitchspeed),
        yaw_rate_rad_s=float(msg.yawspeed),
    )


def _global_position(msg: Any, time_s: float) -> GlobalPosition:
    heading = None if msg.hdg == _UINT16_MAX else units.cdeg_to_rad(msg.hdg)
    return GlobalPosition(
        time_s=time_s,
        time_boot_s=units.ms_to_s(msg.time_boot_ms),
        latitude_deg=units.dege7_to_deg(msg.lat),
        longitude_deg=units.dege7_to_deg(msg.lon),
        altitude_msl_m=units.mm_to_m(msg.alt),
        depth_m=units.depth_m_from_relative_alt_mm(msg.relative_alt),
        velocity_north_m_s=units.cm_s_to_m_s(msg.vx),
        velocity_east_m_s=units.cm_s_to_m_s(msg.vy),
        velocity_down_m_s=units.cm_s_to_m_s(msg.vz),
        heading_rad=heading,
    )


def _local_position(msg: Any, time_s: float) -> LocalPositionNed:
    return LocalPositionNed(
        time_s=time_s,
        time_boot_s=units.ms_to_s(msg.time_boot_ms),
        north_m=float(msg.x),
        east_m=float(msg.y),
        down_m=float(msg.z),
        velocity_north_m_s=float(msg.vx),
        velocity_east_m_s=float(msg.vy),
        velocity_down_m_s=float(msg.vz),
    )


def _pressure(instance: int) -> Callable[[Any, float], Pressure]:
    def build(msg: Any, time_s: float) -> Pressure:
        return Pressure(
            time_s=time_s,
            time_boot_s=units.ms_to_s(msg.time_boot_ms),
            instance=instance,
            press_abs_pa=units.hpa_to_pa(msg.press_abs),
            press_diff_pa=units.hpa_to_pa(msg.press_diff),
            temperature_degc=units.cdegc_to_degc(msg.temperature),
        )

    return build


def _distance_sensor(msg: Any, time_s: float) -> Rangefinder:
    distance_m = units.cm_to_m(msg.current_distance)
    min_m = units.cm_to_m(msg.min_distance)
    max_m = units.cm_to_m(msg.max_distance)
    quality = int(getattr(msg, "signal_quality", 0))
    return Rangefinder(
        time_s=time_s,
        source="DISTANCE_SENSOR",
        sensor_id=int(msg.id),
        distance_m=distance_m,
        min_distance_m=min_m,
        max_distance_m=max_m,
        orientation=int(msg.orientation),
        signal_quality_pct=None if quality == 0 else quality,
        in_range=min_m <= distance_m <= max_m,
    )


def _rangefinder(msg: Any, time_s: float) -> Rangefinder:
    distance_m = float(msg.distance)
    return Rangefinder(
        time_s=time_s,
        source="RANGEFINDER",
        sensor_id=0,
        distance_m=distance_m,
        min_distance_m=0.0,
        max_distance_m=math.inf,
        orientation=MAV_SENSOR_ROTATION_PITCH_270,
        signal_quality_pct=None,
        in_range=math.isfinite(distance_m) and distance_m >= 0.0,
    )


def _gimbal_status(msg: Any, time_s: float) -> MountStatus | None:
    q = tuple(float(v) for v in msg.q)
    if not all(math.isfinite(v) for v in q) or not any(q):
        return None  # attitude unknown (NaN or zero quaternion)
    roll, pitch, yaw = units.quaternion_wxyz_to_euler_rad((q[0], q[1], q[2], q[3]))
    return MountStatus(
        time_s=time_s,
        source="GIMBAL_DEVICE_ATTITUDE_STATUS",
        roll_rad=roll,
        pitch_rad=pitch,
        yaw_rad=yaw,
        tilt_rad=units.tilt_rad_from_mount_pitch_rad(pitch),
    )


def _mount_status(msg: Any, time_s: float) -> MountStatus:
    # ArduPilot fills pointing_a = pitch, pointing_b = roll, pointing_c = yaw, centidegrees.
    pitch = units.cdeg_to_rad(msg.pointing_a)
    return MountStatus(
        time_s=time_s,
        source="MOUNT_STATUS",
        roll_rad=units.cdeg_to_rad(msg.pointing_b),
        pitch_rad=pitch,
        yaw_rad=units.cdeg_to_rad(msg.pointing_c),
        tilt_rad=units.tilt_rad_from_mount_pitch_rad(pitch),
    )


def _mission_current(msg: Any, time_s: float) -> MissionCurrent:
    return MissionCurrent(
        time_s=time_s,
        seq=int(msg.seq),
        total=int(getattr(msg, "total", 0)),
        mission_state=int(getattr(msg, "mission_state", 0)),
        mission_mode=int(getattr(msg, "mission_mode", 0)),
    )


def _mission_item_reached(msg: Any, time_s: float) -> MissionItemReached:
    return MissionItemReached(time_s=time_s, seq=int(msg.seq))


def _statustext(msg: Any, time_s: float) -> StatusText:
    return StatusText(
        time_s=time_s,
        severity=int(msg.severity),
        text=_text(msg.text),
        text_id=int(getattr(msg, "id", 0)),
        chunk_seq=int(getattr(msg, "chunk_seq", 0)),
    )


def _sys_status(msg: Any, time_s: float) -> SysStatus:
    return SysStatus(
        time_s=time_s,
        voltage_battery_v=None
        if msg.voltage_battery == _UINT16_MAX
        else units.mv_to_v(msg.voltage_battery),
        current_battery_a=None if msg.current_battery == -1 else units.ca_to_a(msg.current_battery),
        battery_remaining_pct=None if msg.battery_remaining == -1 else int(msg.battery_remaining),
        sensors_present=int(msg.onboard_control_sensors_present),
        sensors_enabled=int(msg.onboard_control_sensors_enabled),
        sensors_health=int(msg.onboard_control_sensors_health),
        load_pct=msg.load / 10.0,
        drop_rate_comm_pct=msg.drop_rate_comm / 100.0,
    )


def _param_value(msg: Any, time_s: float) -> ParamValue:
    return ParamValue(time_s, _text(msg.param_id), float(msg.param_value), int(msg.param_index),
                      int(msg.param_count), int(msg.param_type))


def _ekf_status(msg: Any, time_s: float) -> EkfStatus:
    return EkfStatus(time_s, int(msg.flags))


def _global_origin(msg: Any, time_s: float) -> GlobalOrigin:
    return GlobalOrigin(time_s, units.dege7_to_deg(msg.latitude), units.dege7_to_deg(msg.longitude),
                        units.mm_to_m(msg.altitude))


def _home_position(msg: Any, time_s: float) -> HomePosition:
    return HomePosition(time_s, units.dege7_to_deg(msg.latitude), units.dege7_to_deg(msg.longitude),
                        units.mm_to_m(msg.altitude))


_DECODERS: dict[str, Callable[[Any, float], TelemetryRecord | None]] = {
    "HEARTBEAT": _heartbeat,
    "ATTITUDE": _attitude,
    "GLOBAL_POSITION_INT": _global_position,
    "LOCAL_POSITION_NED": _local_position,
    "SCALED_PRESSURE": _pressure(1),
    "SCALED_PRESSURE2": _pressure(2),
    "DISTANCE_SENSOR": _distance_sensor,
    "RANGEFINDER": _rangefinder,
    "GIMBAL_DEVICE_ATTITUDE_STATUS": _gimbal_status,
    "MOUNT_STATUS": _mount_status,
    "MISSION_CURRENT": _mission_current,
    "MISSION_ITEM_REACHED": _mission_item_reached,
    "STATUSTEXT": _statustext,
    "SYS_STATUS": _sys_status,
    "PARAM_VALUE": _param_value,
    "EKF_STATUS_REPORT": _ekf_status,
    "GPS_GLOBAL_ORIGIN": _global_origin,
    "HOME_POSITION": _home_position,
}

TELEMETRY_MESSAGE_TYPES: tuple[str, ...] = tuple(_DECODERS)


def decode(msg: Any, time_s: float) -> TelemetryRecord | None:
    """Decode one MAVLink message into a telemetry record, or None if it is not telemetry
    (or carries no usable value, like a gimbal status with a NaN quaternion).

    Parameters
    ----------
    msg : pymavlink message
        Any object with ``get_type()`` and the MAVLink fields of its type.
    time_s : float
        Reception time on the injected clock, seconds.
    """
    decoder = _DECODERS.get(msg.get_type())
    if decoder is None:
        return None
    return decoder(msg, time_s)


def store_key(record: TelemetryRecord) -> str:
    """Key under which the latest record of its kind is stored.

    Pressure is keyed per instance (``"Pressure1"``, ``"Pressure2"``), rangefinders per
    source and id (``"Rangefinder:DISTANCE_SENSOR:0"``), parameters by name
    (``"ParamValue:WPNAV_SPEED"``), every other record by class name.
    """
    if isinstance(record, Pressure):
        return f"Pressure{record.instance}"
    if isinstance(record, Rangefinder):
        return f"Rangefinder:{record.source}:{record.sensor_id}"
    if isinstance(record, ParamValue):
        return f"ParamValue:{record.name}"
    if isinstance(record, PeerSeen):
        return f"PeerSeen:{record.kind}:{record.system_id}:{record.component_id}"
    return type(record).__name__
