"""Telemetry streams as ArduSub sends them: SRn_* stream rates, SET_MESSAGE_INTERVAL.

:class:`TelemetryScheduler` decides which message ids are due; :func:`build_message` turns a
:class:`TelemetrySnapshot` (what the autopilot knows, never truth) into MAVLink messages.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sim_harness.autopilot.location import ned_to_latlon
from sim_harness.vehicle.sensors import SensorReadings

#: ArduSub stream groups: parameter name -> message ids it drives.
STREAMS: dict[str, tuple[int, ...]] = {
    "SR0_RAW_SENS": (
        mavlink.MAVLINK_MSG_ID_SCALED_PRESSURE,
        mavlink.MAVLINK_MSG_ID_SCALED_PRESSURE2,
    ),
    "SR0_EXT_STAT": (
        mavlink.MAVLINK_MSG_ID_SYS_STATUS,
        mavlink.MAVLINK_MSG_ID_MISSION_CURRENT,
        mavlink.MAVLINK_MSG_ID_NAV_CONTROLLER_OUTPUT,
        mavlink.MAVLINK_MSG_ID_GPS_RAW_INT,
    ),
    "SR0_RC_CHAN": (mavlink.MAVLINK_MSG_ID_SERVO_OUTPUT_RAW,),
    "SR0_POSITION": (
        mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT,
        mavlink.MAVLINK_MSG_ID_LOCAL_POSITION_NED,
    ),
    "SR0_EXTRA1": (mavlink.MAVLINK_MSG_ID_ATTITUDE,),
    "SR0_EXTRA2": (mavlink.MAVLINK_MSG_ID_VFR_HUD,),
    "SR0_EXTRA3": (
        mavlink.MAVLINK_MSG_ID_SYSTEM_TIME,
        mavlink.MAVLINK_MSG_ID_RANGEFINDER,
        mavlink.MAVLINK_MSG_ID_DISTANCE_SENSOR,
        mavlink.MAVLINK_MSG_ID_GIMBAL_DEVICE_ATTITUDE_STATUS,
    ),
}

#: MAV_DATA_STREAM ids (REQUEST_DATA_STREAM) -> stream parameter.
DATA_STREAM_PARAMS: dict[int, str] = {
    mavlink.MAV_DATA_STREAM_RAW_SENSORS: "SR0_RAW_SENS",
    mavlink.MAV_DATA_STREAM_EXTENDED_STATUS: "SR0_EXT_STAT",
    mavlink.MAV_DATA_STREAM_RC_CHANNELS: "SR0_RC_CHAN",
    mavlink.MAV_DATA_STREAM_POSITION: "SR0_POSITION",
    mavlink.MAV_DATA_STREAM_EXTRA1: "SR0_EXTRA1",
    mavlink.MAV_DATA_STREAM_EXTRA2: "SR0_EXTRA2",
    mavlink.MAV_DATA_STREAM_EXTRA3: "SR0_EXTRA3",
}

HEARTBEAT_INTERVAL_S = 1.0


@dataclass(frozen=True)
class TelemetrySnapshot:
    """What the autopilot reports at one instant (estimates only)."""

    time_s: float
    readings: SensorReadings
    custom_mode: int
    armed: bool
    system_status: int
    base_mode: int
    mission_seq: int
    mission_total: int
    mission_state: int
    thrust_norm: tuple[float, float, float, float]  # -1..1 surge, sway, heave, yaw
    tilt_rad: float
    origin_lat_deg: float
    origin_lon_deg: float
    nav_bearing_deg: float
    nav_distance_m: float
    nav_alt_error_m: float
    target_yaw_rad: float
    rangefinder_min_m: float
    rangefinder_max_m: float
    failsafe: bool


class TelemetryScheduler:
    """Per-message intervals from the stream rates, overridden by SET_MESSAGE_INTERVAL."""

    def __init__(self, stream_rates_hz: Mapping[str, float]) -> None:
        self._interval_s: dict[int, float | None] = {}
        self._default_s: dict[int, float | None] = {}
        self._next_s: dict[int, float] = {}
        for param, ids in STREAMS.items():
            self.set_stream_rate(param, stream_rates_hz.get(param, 0.0), now_s=0.0, default=True)
            del ids
        self._interval_s[mavlink.MAVLINK_MSG_ID_HEARTBEAT] = HEARTBEAT_INTERVAL_S
        self._default_s[mavlink.MAVLINK_MSG_ID_HEARTBEAT] = HEARTBEAT_INTERVAL_S
        self._next_s[mavlink.MAVLINK_MSG_ID_HEARTBEAT] = 0.0

    def set_stream_rate(
        self, param: str, rate_hz: float, *, now_s: float, default: bool = False
    ) -> None:
        """Set every message of a stream group to ``rate_hz`` (0 = off)."""
        interval = 1.0 / rate_hz if rate_hz > 0.0 else None
        for msg_id in STREAMS[param]:
            self._interval_s[msg_id] = interval
            if default:
                self._default_s[msg_id] = interval
            self._next_s[msg_id] = now_s

    def set_interval(self, msg_id: int, interval_us: float, *, now_s: float) -> None:
        """SET_MESSAGE_INTERVAL semantics: -1 off, 0 default, > 0 interval in us."""
        if interval_us < 0:
            self._interval_s[msg_id] = None
        elif interval_us == 0:
            self._interval_s[msg_id] = self._default_s.get(msg_id)
        else:
            self._interval_s[msg_id] = interval_us * 1e-6
        self._next_s[msg_id] = now_s

    def interval_s(self, msg_id: int) -> float | None:
        """Current interval of a message, or None when it is not streamed."""
        return self._interval_s.get(msg_id)

    def due(self, now_s: float) -> list[int]:
        """Message ids due at ``now_s``; schedules their next time."""
        out = []
        for msg_id, interval in self._interval_s.items():
            if interval is None:
                continue
            nxt = self._next_s.get(msg_id, now_s)
            if now_s + 1e-9 >= nxt:
                out.append(msg_id)
                # Keep the long-run rate; do not burst after a stall.
                nxt += interval
                self._next_s[msg_id] = nxt if nxt > now_s else now_s + interval
        return out


def _euler_to_quaternion(roll: float, pitch: float, yaw: float) -> list[float]:
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return [
        cr * cp * cy + sr * sp * sy,
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
    ]


def build_message(msg_id: int, s: TelemetrySnapshot) -> mavlink.MAVLink_message | None:
    """Build one telemetry message from a snapshot; None if nothing to report now."""
    r = s.readings
    boot_ms = int(s.time_s * 1000.0) & 0xFFFFFFFF
    m = mavlink
    if msg_id == m.MAVLINK_MSG_ID_HEARTBEAT:
        return m.MAVLink_heartbeat_message(
            m.MAV_TYPE_SUBMARINE, m.MAV_AUTOPILOT_ARDUPILOTMEGA, s.base_mode, s.custom_mode,
            s.system_status, 3,
        )
    if msg_id == m.MAVLINK_MSG_ID_ATTITUDE:
        return m.MAVLink_attitude_message(
            boot_ms, r.roll_rad, r.pitch_rad, r.yaw_rad,
            r.roll_rate_rad_s, r.pitch_rate_rad_s, r.yaw_rate_rad_s,
        )
    if msg_id == m.MAVLINK_MSG_ID_GLOBAL_POSITION_INT:
        lat, lon = ned_to_latlon(r.north_m, r.east_m, s.origin_lat_deg, s.origin_lon_deg)
        heading_cdeg = int(round(math.degrees(r.yaw_rad) * 100.0)) % 36000
        return m.MAVLink_global_position_int_message(
            boot_ms, int(round(lat * 1e7)), int(round(lon * 1e7)),
            int(round(-r.depth_m * 1000.0)), int(round(-r.depth_m * 1000.0)),
            int(round(r.vel_north_m_s * 100)), int(round(r.vel_east_m_s * 100)),
            int(round(r.vel_down_m_s * 100)), heading_cdeg,
        )
    if msg_id == m.MAVLINK_MSG_ID_LOCAL_POSITION_NED:
        return m.MAVLink_local_position_ned_message(
            boot_ms, r.north_m, r.east_m, r.depth_m, r.vel_north_m_s, r.vel_east_m_s,
            r.vel_down_m_s,
        )
    if msg_id == m.MAVLINK_MSG_ID_VFR_HUD:
        speed = math.hypot(r.vel_north_m_s, r.vel_east_m_s)
        return m.MAVLink_vfr_hud_message(
            speed, speed, int(round(math.degrees(r.yaw_rad))) % 360,
            int(round(abs(s.thrust_norm[2]) * 100)), -r.depth_m, -r.vel_down_m_s,
        )
    if msg_id == m.MAVLINK_MSG_ID_SYS_STATUS:
        sensors = (
            m.MAV_SYS_STATUS_SENSOR_3D_GYRO | m.MAV_SYS_STATUS_SENSOR_3D_ACCEL
            | m.MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE | m.MAV_SYS_STATUS_SENSOR_LASER_POSITION
            | m.MAV_SYS_STATUS_AHRS
        )
        return m.MAVLink_sys_status_message(
            sensors, sensors, sensors, 250, 16000, 1000, 80, 0, 0, 0, 0, 0, 0,
        )
    if msg_id == m.MAVLINK_MSG_ID_MISSION_CURRENT:
        return m.MAVLink_mission_current_message(
            s.mission_seq, s.mission_total, s.mission_state, 0,
        )
    if msg_id == m.MAVLINK_MSG_ID_NAV_CONTROLLER_OUTPUT:
        return m.MAVLink_nav_controller_output_message(
            0.0, 0.0, int(round(math.degrees(s.target_yaw_rad))),
            int(round(s.nav_bearing_deg)), min(int(s.nav_distance_m), 65535), s.nav_alt_error_m,
            0.0, 0.0,
        )
    if msg_id == m.MAVLINK_MSG_ID_GPS_RAW_INT:
        return m.MAVLink_gps_raw_int_message(
            int(s.time_s * 1e6), m.GPS_FIX_TYPE_NO_GPS, 0, 0, 0, 65535, 65535, 65535, 65535, 0,
        )
    if msg_id == m.MAVLINK_MSG_ID_SERVO_OUTPUT_RAW:
        pwm = [int(1500 + 400 * v) for v in s.thrust_norm] + [1500] * 4
        return m.MAVLink_servo_output_raw_message(int(s.time_s * 1e6) & 0xFFFFFFFF, 0, *pwm)
    if msg_id == m.MAVLINK_MSG_ID_SCALED_PRESSURE:
        return m.MAVLink_scaled_pressure_message(boot_ms, 1013.25, 0.0, 2500)
    if msg_id == m.MAVLINK_MSG_ID_SCALED_PRESSURE2:
        press_hpa = 1013.25 + r.depth_m * 1025.0 * 9.80665 / 100.0
        return m.MAVLink_scaled_pressure2_message(boot_ms, press_hpa, 0.0, 1500)
    if msg_id == m.MAVLINK_MSG_ID_SYSTEM_TIME:
        return m.MAVLink_system_time_message(0, boot_ms)
    if msg_id == m.MAVLINK_MSG_ID_RANGEFINDER:
        if r.altitude_m is None:
            return None
        return m.MAVLink_rangefinder_message(r.altitude_m, 0.0)
    if msg_id == m.MAVLINK_MSG_ID_DISTANCE_SENSOR:
        if r.altitude_m is None:
            return None
        return m.MAVLink_distance_sensor_message(
            boot_ms, int(s.rangefinder_min_m * 100), int(s.rangefinder_max_m * 100),
            int(round(r.altitude_m * 100)), m.MAV_DISTANCE_SENSOR_ULTRASOUND, 0,
            m.MAV_SENSOR_ROTATION_PITCH_270, 0,
        )
    if msg_id == m.MAVLINK_MSG_ID_GIMBAL_DEVICE_ATTITUDE_STATUS:
        q = _euler_to_quaternion(0.0, -s.tilt_rad, 0.0)
        nan = float("nan")
        return m.MAVLink_gimbal_device_attitude_status_message(
            0, 0, boot_ms, m.GIMBAL_DEVICE_FLAGS_YAW_IN_VEHICLE_FRAME, q, nan, nan, nan, 0, 0.0,
            0.0, 1,
        )
    if msg_id == m.MAVLINK_MSG_ID_HOME_POSITION:
        lat, lon = s.origin_lat_deg, s.origin_lon_deg
        return m.MAVLink_home_position_message(
            int(round(lat * 1e7)), int(round(lon * 1e7)), 0, 0.0, 0.0, 0.0, [1.0, 0, 0, 0],
            0.0, 0.0, 0.0, int(s.time_s * 1e6),
        )
    if msg_id == m.MAVLINK_MSG_ID_AUTOPILOT_VERSION:
        caps = (
            m.MAV_PROTOCOL_CAPABILITY_MAVLINK2 | m.MAV_PROTOCOL_CAPABILITY_MISSION_INT
            | m.MAV_PROTOCOL_CAPABILITY_COMMAND_INT | m.MAV_PROTOCOL_CAPABILITY_PARAM_FLOAT
            | m.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_LOCAL_NED
            | m.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_GLOBAL_INT
        )
        return m.MAVLink_autopilot_version_message(
            caps, (4 << 24) | (5 << 16) | (0 << 8) | 255, 0, 0, 0, [0] * 8, [0] * 8, [0] * 8,
            0, 0, 0, [0] * 18,
        )
    if msg_id == m.MAVLINK_MSG_ID_GIMBAL_MANAGER_INFORMATION:
        return m.MAVLink_gimbal_manager_information_message(
            boot_ms, m.GIMBAL_MANAGER_CAP_FLAGS_HAS_PITCH_AXIS, 1, 0.0, 0.0,
            -math.radians(90.0), math.radians(90.0), 0.0, 0.0,
        )
    return None


#: Messages that REQUEST_MESSAGE and SET_MESSAGE_INTERVAL accept.
BUILDABLE_IDS = frozenset(
    [mid for ids in STREAMS.values() for mid in ids]
    + [
        mavlink.MAVLINK_MSG_ID_HEARTBEAT,
        mavlink.MAVLINK_MSG_ID_HOME_POSITION,
        mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION,
        mavlink.MAVLINK_MSG_ID_GIMBAL_MANAGER_INFORMATION,
    ]
)
