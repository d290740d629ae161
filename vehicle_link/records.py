"""Typed, timestamped telemetry records (frozen, SI units) that :mod:`vehicle_link.telemetry`
decodes from MAVLink. Frames and signs follow architecture.md: NED, depth down positive,
tilt down positive.
"""

from __future__ import annotations

from dataclasses import dataclass

MAV_SENSOR_ROTATION_PITCH_270 = 25  # pointing down


@dataclass(frozen=True)
class LinkHealth:
    """Link state on the injected clock. ``up`` is None before the first heartbeat."""

    up: bool | None
    last_heartbeat_s: float | None
    silence_s: float | None
    losses: int
    restorations: int


@dataclass(frozen=True)
class LinkStats:
    """Counters of the session."""

    messages_received: int
    messages_sent: int
    bad_data: int
    signature_rejects: int
    unknown_messages: int


@dataclass(frozen=True)
class Heartbeat:
    """HEARTBEAT of the vehicle: mode and armed state."""

    time_s: float
    system_id: int
    component_id: int
    mav_type: int
    autopilot: int
    base_mode: int
    custom_mode: int
    system_status: int
    armed: bool
    mode_name: str


@dataclass(frozen=True)
class Attitude:
    """ATTITUDE: body attitude relative to NED, radians; rates rad/s."""

    time_s: float
    time_boot_s: float
    roll_rad: float
    pitch_rad: float
    yaw_rad: float
    roll_rate_rad_s: float
    pitch_rate_rad_s: float
    yaw_rate_rad_s: float


@dataclass(frozen=True)
class GlobalPosition:
    """GLOBAL_POSITION_INT: WGS84 position, depth below the surface, NED velocity.

    ``heading_rad`` is None when the vehicle reports it as unknown (UINT16_MAX).
    """

    time_s: float
    time_boot_s: float
    latitude_deg: float
    longitude_deg: float
    altitude_msl_m: float
    depth_m: float
    velocity_north_m_s: float
    velocity_east_m_s: float
    velocity_down_m_s: float
    heading_rad: float | None


@dataclass(frozen=True)
class LocalPositionNed:
    """LOCAL_POSITION_NED: position about the EKF origin (at the surface for ArduSub)."""

    time_s: float
    time_boot_s: float
    north_m: float
    east_m: float
    down_m: float
    velocity_north_m_s: float
    velocity_east_m_s: float
    velocity_down_m_s: float


@dataclass(frozen=True)
class Pressure:
    """SCALED_PRESSURE (instance 1) or SCALED_PRESSURE2 (instance 2; ArduSub's external
    depth sensor, e.g. a Bar30, is usually here)."""

    time_s: float
    time_boot_s: float
    instance: int
    press_abs_pa: float
    press_diff_pa: float
    temperature_degc: float


@dataclass(frozen=True)
class Rangefinder:
    """DISTANCE_SENSOR or ArduPilot's RANGEFINDER: a measured distance.

    ``orientation`` is a MAV_SENSOR_ORIENTATION (25 = pointing down); RANGEFINDER carries
    none and is ArduPilot's primary (downward) rangefinder, so it is reported as 25.
    ``signal_quality_pct`` is None when unknown. ``in_range`` is False when the reading
    lies outside the sensor's declared limits.
    """

    time_s: float
    source: str
    sensor_id: int
    distance_m: float
    min_distance_m: float
    max_distance_m: float
    orientation: int
    signal_quality_pct: int | None
    in_range: bool

    @property
    def is_downward(self) -> bool:
        """True for a sensor pointing down (an altimeter)."""
        return self.orientation == MAV_SENSOR_ROTATION_PITCH_270


@dataclass(frozen=True)
class MountStatus:
    """Mount attitude from GIMBAL_DEVICE_ATTITUDE_STATUS (4.3+) or MOUNT_STATUS (older).

    ``tilt_rad`` is the sonar tilt, positive down (= -pitch).
    """

    time_s: float
    source: str
    roll_rad: float
    pitch_rad: float
    yaw_rad: float
    tilt_rad: float


@dataclass(frozen=True)
class MissionCurrent:
    """MISSION_CURRENT: the active mission item."""

    time_s: float
    seq: int
    total: int
    mission_state: int
    mission_mode: int


@dataclass(frozen=True)
class MissionItemReached:
    """MISSION_ITEM_REACHED."""

    time_s: float
    seq: int


@dataclass(frozen=True)
class StatusText:
    """STATUSTEXT: a text message with its MAV_SEVERITY (0 emergency .. 7 debug)."""

    time_s: float
    severity: int
    text: str
    text_id: int
    chunk_seq: int


@dataclass(frozen=True)
class SysStatus:
    """SYS_STATUS: battery and sensor health. None marks values the vehicle reports as unknown."""

    time_s: float
    voltage_battery_v: float | None
    current_battery_a: float | None
    battery_remaining_pct: int | None
    sensors_present: int
    sensors_enabled: int
    sensors_health: int
    load_pct: float
    drop_rate_comm_pct: float


@dataclass(frozen=True)
class ParamValue:
    """PARAM_VALUE: one autopilot parameter as the vehicle holds it; ``param_type`` is the
    MAV_PARAM_TYPE ArduSub stores it as (INT8 2, INT16 4, INT32 6, REAL32 9)."""

    time_s: float
    name: str
    value: float
    index: int
    count: int
    param_type: int = 9


@dataclass(frozen=True)
class EkfStatus:
    """EKF_STATUS_REPORT flags (EKF_STATUS_FLAGS); ``horizontal_position_ok`` is what
    ArduSub's ``position_ok`` needs while armed: a horizontal position (relative or
    absolute) and not the constant-position fallback."""

    time_s: float
    flags: int

    @property
    def horizontal_position_ok(self) -> bool:
        """Relative or absolute horizontal position, not in constant-position mode."""
        return bool(self.flags & (8 | 16)) and not self.flags & 128


@dataclass(frozen=True)
class GlobalOrigin:
    """GPS_GLOBAL_ORIGIN: the EKF origin (the local NED frame's zero)."""

    time_s: float
    latitude_deg: float
    longitude_deg: float
    altitude_m: float


@dataclass(frozen=True)
class HomePosition:
    """HOME_POSITION: ArduSub's home (at the water surface), AMSL altitude."""

    time_s: float
    latitude_deg: float
    longitude_deg: float
    altitude_m: float


@dataclass(frozen=True)
class PeerSeen:
    """Another system on the network: its last HEARTBEAT (``kind`` "HEARTBEAT", with its
    MAV_TYPE) or MANUAL_CONTROL (``kind`` "MANUAL_CONTROL": a pilot's joystick)."""

    time_s: float
    system_id: int
    component_id: int
    kind: str
    mav_type: int | None = None


TelemetryRecord = (
    EkfStatus
    | GlobalOrigin
    | HomePosition
    | PeerSeen
    | Heartbeat
    | Attitude
    | GlobalPosition
    | LocalPositionNed
    | Pressure
    | Rangefinder
    | MountStatus
    | MissionCurrent
    | MissionItemReached
    | StatusText
    | SysStatus
    | ParamValue
)


