"""Telemetry streams as ArduSub 4.5 sends them: SRn_* stream rates, SET_MESSAGE_INTERVAL.

:class:`TelemetryScheduler` decides which message ids are due; :func:`build_message` turns a
:class:`TelemetrySnapshot` (what the autopilot knows, never truth) into MAVLink messages.
Sources (Sub-4.5 @30257f0118): ``ArduSub/GCS_Mavlink.cpp`` (stream groups, HEARTBEAT,
capabilities), ``libraries/GCS_MAVLink/GCS_Common.cpp`` (``mavlink_id_to_ap_message_id``,
``send_global_position_int``, ``send_home_position``, ``send_gps_global_origin``,
``send_extended_sys_state``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sim_harness.autopilot.location import latlon_to_ned, ned_to_latlon
from sim_harness.autopilot.sensor_status import SensorFlags
from sim_harness.vehicle.sensors import SensorReadings

#: ArduSub stream groups (``STREAM_*_msgs``): parameter name -> the simulated message ids.
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
        mavlink.MAVLINK_MSG_ID_EKF_STATUS_REPORT,
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
#: EKF_STATUS_REPORT flags (EKF_STATUS_FLAGS)
EKF_ATTITUDE, EKF_VELOCITY_HORIZ, EKF_VELOCITY_VERT = 1, 2, 4
EKF_POS_HORIZ_REL, EKF_POS_HORIZ_ABS, EKF_POS_VERT_ABS = 8, 16, 32
EKF_CONST_POS_MODE, EKF_PRED_POS_HORIZ_REL, EKF_PRED_POS_HORIZ_ABS = 128, 256, 512


@dataclass(frozen=True)
class TelemetrySnapshot:
    """What the autopilot reports at one instant (estimates only).

    ``origin``/``home`` are (lat_deg, lon_deg, alt_m AMSL) or None while unset.
    """

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
    servo_tilt_rad: float  # the tilt servo's body-frame angle, down positive
    origin: tuple[float, float, float] | None
    home: tuple[float, float, float] | None
    nav_bearing_deg: float
    nav_distance_m: float
    nav_alt_error_m: float
    target_yaw_rad: float
    rangefinder_min_m: float
    rangefinder_max_m: float
    rangefinder_enabled: bool
    sensors: SensorFlags
    position_ok: bool
    mount_status: mavlink.MAVLink_message | None


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


def _global_position(s: TelemetrySnapshot, boot_ms: int) -> mavlink.MAVLink_message:
    """GLOBAL_POSITION_INT: lat/lon from the EKF origin (0 while there is none: ArduPilot
    sends its last known location), alt AMSL, relative_alt above home (the surface)."""
    r = s.readings
    if s.origin is not None:
        lat, lon = ned_to_latlon(r.north_m, r.east_m, s.origin[0], s.origin[1])
        lat_e7, lon_e7 = int(round(lat * 1e7)), int(round(lon * 1e7))
        alt_mm = int(round((s.origin[2] - r.depth_m) * 1000.0))
    else:
        lat_e7 = lon_e7 = 0
        alt_mm = int(round(-r.depth_m * 1000.0))
    home_alt = s.home[2] if s.home is not None else (s.origin[2] if s.origin is not None else 0.0)
    origin_alt = s.origin[2] if s.origin is not None else 0.0
    rel_mm = int(round((origin_alt - r.depth_m - home_alt) * 1000.0))
    heading_cdeg = int(round(math.degrees(r.yaw_rad) * 100.0)) % 36000
    return mavlink.MAVLink_global_position_int_message(
        boot_ms, lat_e7, lon_e7, alt_mm, rel_mm, int(round(r.vel_north_m_s * 100)),
        int(round(r.vel_east_m_s * 100)), int(round(r.vel_down_m_s * 100)), heading_cdeg)


def _ekf_flags(s: TelemetrySnapshot) -> int:
    """EKF_STATUS_REPORT flags: DVL aiding gives velocity and relative position (absolute
    with an origin); without it EKF3 falls back to a constant position."""
    flags = EKF_ATTITUDE | EKF_VELOCITY_VERT | EKF_POS_VERT_ABS
    if s.readings.position_ok:
        flags |= EKF_VELOCITY_HORIZ | EKF_POS_HORIZ_REL | EKF_PRED_POS_HORIZ_REL
        if s.origin is not None:
            flags |= EKF_POS_HORIZ_ABS | EKF_PRED_POS_HORIZ_ABS
    else:
        flags |= EKF_CONST_POS_MODE
    return flags


def build_message(msg_id: int, s: TelemetrySnapshot) -> mavlink.MAVLink_message | None:
    """Build one telemetry message from a snapshot; None if nothing to report now."""
    r = s.readings
    boot_ms = int(s.time_s * 1000.0) & 0xFFFFFFFF
    m = mavlink
    if msg_id == m.MAVLINK_MSG_ID_HEARTBEAT:
        # GCS_MAVLINK::send_heartbeat: MAV_TYPE_SUBMARINE (GCS_Sub::frame_type), ArduPilot
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
        return _global_position(s, boot_ms)
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
        f = s.sensors
        return m.MAVLink_sys_status_message(f.present, f.enabled, f.health, 250, 16000, 1000, 80, 0, 0, 0, 0, 0, 0)
    if msg_id == m.MAVLINK_MSG_ID_MISSION_CURRENT:
        return m.MAVLink_mission_current_message(s.mission_seq, s.mission_total, s.mission_state, 0)
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
        if not s.rangefinder_enabled or r.altitude_m is None:
            return None
        return m.MAVLink_rangefinder_message(r.altitude_m, 0.0)
    if msg_id == m.MAVLINK_MSG_ID_DISTANCE_SENSOR:
        if not s.rangefinder_enabled or r.altitude_m is None:
            return None
        # GCS_MAVLINK::send_distance_sensor: the vehicle re-emits its rangefinder (sysid 1 compid 1)
        return m.MAVLink_distance_sensor_message(
            boot_ms, int(s.rangefinder_min_m * 100), int(s.rangefinder_max_m * 100),
            int(round(r.altitude_m * 100)), m.MAV_DISTANCE_SENSOR_UNKNOWN, 0,
            m.MAV_SENSOR_ROTATION_PITCH_270, 0,
        )
    if msg_id == m.MAVLINK_MSG_ID_GIMBAL_DEVICE_ATTITUDE_STATUS:
        return s.mount_status
    if msg_id == m.MAVLINK_MSG_ID_EKF_STATUS_REPORT:
        return m.MAVLink_ekf_status_report_message(_ekf_flags(s), 0.1, 0.1, 0.1, 0.1, 0.0, 0.0)
    if msg_id == m.MAVLINK_MSG_ID_EXTENDED_SYS_STATE:
        # send_extended_sys_state: Sub overrides neither vtol_state nor landed_state
        return m.MAVLink_extended_sys_state_message(m.MAV_VTOL_STATE_UNDEFINED, m.MAV_LANDED_STATE_UNDEFINED)
    if msg_id == m.MAVLINK_MSG_ID_HOME_POSITION:
        if s.home is None or s.origin is None:
            return None  # send_home_position: nothing without a home
        lat, lon, alt = s.home
        north, east = latlon_to_ned(lat, lon, s.origin[0], s.origin[1])
        nan = float("nan")
        return m.MAVLink_home_position_message(
            int(round(lat * 1e7)), int(round(lon * 1e7)), int(round(alt * 1000)), north, east,
            s.origin[2] - alt, [nan, nan, nan, nan], 0.0, 0.0, 0.0, int(s.time_s * 1e6))
    if msg_id == m.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN:
        if s.origin is None:
            return None
        lat, lon, alt = s.origin
        return m.MAVLink_gps_global_origin_message(int(round(lat * 1e7)), int(round(lon * 1e7)),
                                                   int(round(alt * 1000)), int(s.time_s * 1e6))
    if msg_id == m.MAVLINK_MSG_ID_AUTOPILOT_VERSION:
        # GCS_MAVLINK_Sub::capabilities, less FTP: the simulator has no file server
        # (ftp.py answers every request with a NAK).
        caps = (
            m.MAV_PROTOCOL_CAPABILITY_MAVLINK2 | m.MAV_PROTOCOL_CAPABILITY_MISSION_INT
            | m.MAV_PROTOCOL_CAPABILITY_MISSION_FLOAT | m.MAV_PROTOCOL_CAPABILITY_PARAM_FLOAT
            | m.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_LOCAL_NED
            | m.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_GLOBAL_INT
            | m.MAV_PROTOCOL_CAPABILITY_FLIGHT_TERMINATION | m.MAV_PROTOCOL_CAPABILITY_SET_ATTITUDE_TARGET
            | m.MAV_PROTOCOL_CAPABILITY_MISSION_FENCE | m.MAV_PROTOCOL_CAPABILITY_MISSION_RALLY
        )
        return m.MAVLink_autopilot_version_message(
            caps, (4 << 24) | (5 << 16) | (7 << 8) | 255, 0, 0, 0, [0] * 8, [0] * 8, [0] * 8,
            0, 0, 0, [0] * 18,
        )
    if msg_id == m.MAVLINK_MSG_ID_GIMBAL_MANAGER_INFORMATION:
        return m.MAVLink_gimbal_manager_information_message(
            boot_ms, m.GIMBAL_MANAGER_CAP_FLAGS_HAS_PITCH_AXIS, 1, 0.0, 0.0,
            -math.radians(90.0), math.radians(90.0), 0.0, 0.0,
        )
    return None


#: Messages the simulator can build (streams, REQUEST_MESSAGE).
BUILDABLE_IDS = frozenset(
    [mid for ids in STREAMS.values() for mid in ids]
    + [
        mavlink.MAVLINK_MSG_ID_HEARTBEAT,
        mavlink.MAVLINK_MSG_ID_HOME_POSITION,
        mavlink.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN,
        mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION,
        mavlink.MAVLINK_MSG_ID_GIMBAL_MANAGER_INFORMATION,
        mavlink.MAVLINK_MSG_ID_EXTENDED_SYS_STATE,
    ]
)
#: Message ids that have an ArduPilot ``ap_message`` (``mavlink_id_to_ap_message_id``):
#: SET_MESSAGE_INTERVAL and REQUEST_MESSAGE accept them even where the simulator (or, for
#: the POSITION_TARGET_* and ATTITUDE_TARGET, Sub itself) never sends anything.
MAPPED_IDS = BUILDABLE_IDS | frozenset(
    getattr(mavlink, f"MAVLINK_MSG_ID_{name}") for name in (
        "ATTITUDE_QUATERNION", "POWER_STATUS", "MEMINFO", "RC_CHANNELS", "RC_CHANNELS_RAW", "RAW_IMU",
        "SCALED_IMU", "SCALED_IMU2", "SCALED_IMU3", "SCALED_PRESSURE3", "GPS_RTK", "GPS2_RAW", "GPS2_RTK",
        "RC_CHANNELS_SCALED", "PARAM_VALUE", "FENCE_STATUS", "AHRS", "AHRS2", "HWSTATUS", "WIND",
        "BATTERY2", "CAMERA_FEEDBACK", "GIMBAL_MANAGER_STATUS", "AUTOPILOT_STATE_FOR_GIMBAL_DEVICE",
        "OPTICAL_FLOW", "MAG_CAL_PROGRESS", "MAG_CAL_REPORT", "PID_TUNING", "VIBRATION",
        "MISSION_ITEM_REACHED", "ATTITUDE_TARGET", "POSITION_TARGET_GLOBAL_INT", "POSITION_TARGET_LOCAL_NED",
        "ADSB_VEHICLE", "BATTERY_STATUS", "ESC_TELEMETRY_1_TO_4",
    )
)
