"""Settings of a vehicle link, validated once here and then passed down (frozen)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from vehicle_link.errors import ConfigError
from vehicle_link.signing import check_key

MOUNT_PROTOCOLS = ("mount_control", "gimbal_manager", "mount_control_centidegrees")

#: Streams requested after connecting: (message name, period in seconds).
DEFAULT_MESSAGE_INTERVALS_S: tuple[tuple[str, float], ...] = (
    ("ATTITUDE", 0.1),
    ("GLOBAL_POSITION_INT", 0.2),
    ("LOCAL_POSITION_NED", 0.2),
    ("SCALED_PRESSURE2", 0.2),
    ("DISTANCE_SENSOR", 0.2),
    ("RANGEFINDER", 0.2),
    ("GIMBAL_DEVICE_ATTITUDE_STATUS", 0.1),
    ("MISSION_CURRENT", 1.0),
    ("SYS_STATUS", 1.0),
    ("EKF_STATUS_REPORT", 0.5),
)


@dataclass(frozen=True)
class AltimeterFeed:
    """Our own altimeter, fed to the autopilot as a downward DISTANCE_SENSOR.

    ArduSub must have a rangefinder of type MAVLink (``RNGFND1_TYPE = 10``) with
    ``RNGFND1_ORIENT = 25`` (down) and matching min/max.
    """

    min_range_m: float = 0.3
    max_range_m: float = 50.0
    sensor_id: int = 0

    def __post_init__(self) -> None:
        if not (0.0 <= self.min_range_m < self.max_range_m and math.isfinite(self.max_range_m)):
            raise ConfigError(
                "altimeter range limits must satisfy 0 <= min < max < inf, "
                f"got {self.min_range_m}, {self.max_range_m}"
            )
        if not 0 <= self.sensor_id <= 255:
            raise ConfigError(f"altimeter sensor_id must be 0..255, got {self.sensor_id}")


@dataclass(frozen=True)
class LinkConfig:
    """Everything a :class:`~vehicle_link.client.ArduSubClient` needs.

    Parameters
    ----------
    connection : str
        pymavlink connection string: ``udpin:0.0.0.0:14770``, ``udpout:host:port``,
        ``tcp:host:port``, or a serial device ``/dev/ttyACM0`` (baud from ``baud``).
    source_system, source_component : int
        Our ids. On BlueOS use the vehicle's system (1) and a component of 191-193
        (MAV_COMP_ID_ONBOARD_COMPUTER..3): 194 is mavlink2rest's, 100-105 the camera
        manager's. Never SYSID_MYGCS's system id: the vehicle would take our heartbeats
        for the topside's.
    target_system : int or None
        The vehicle's system id; None locks onto the first submarine heartbeat.
    target_component : int
        The autopilot component (1).
    heartbeat_period_s : float
        Period of our own heartbeat, clock seconds.
    link_timeout_s : float
        Vehicle heartbeat silence after which the link is declared lost.
    connect_timeout_s : float
        Wait for the first vehicle heartbeat in ``connect()``.
    command_timeout_s, command_attempts : float, int
        Wait for each COMMAND_ACK, and how many times a command is sent in all.
    state_confirm_timeout_s : float
        Wait for a heartbeat confirming a mode change or arming.
    mission_item_timeout_s, mission_retries : float, int
        Mission protocol: silence that triggers a resend, and resends allowed in a row.
    max_depth_m : float or None
        Depth limit: a depth target deeper than this is refused before sending.
    min_clearance_m : float or None
        Minimum altitude above the seabed: a lower altitude target is refused.
    telemetry_max_age_s : float
        Oldest telemetry usable for derived targets (depth from altimeter).
    signing_key : bytes or None
        32-byte MAVLink 2 signing key; signing is on when set.
    signing_link_id : int
        Link id in our signatures.
    tlog_path : str or None
        Write a .tlog of the session there (both directions).
    altimeter : AltimeterFeed or None
        Feed our altimeter to the autopilot when set.
    mount_protocol : str
        ``"mount_control"`` (MAV_CMD_DO_MOUNT_CONTROL, degrees, ArduSub 4.3+) or
        ``"gimbal_manager"`` (MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW), or
        ``"mount_control_centidegrees"`` (DO_MOUNT_CONTROL for firmware before 4.3).
    message_intervals_s : tuple of (str, float)
        Streams requested with MAV_CMD_SET_MESSAGE_INTERVAL after connecting.
    io_poll_s : float
        Real-time period at which the I/O thread re-reads the clock (keep small when the
        injected clock runs faster than real time).
    water_density_kg_m3, surface_pressure_pa : float
        For depth from SCALED_PRESSURE2 when no position is streamed.
    """

    connection: str
    source_system: int = 1
    source_component: int = 191
    target_system: int | None = None
    target_component: int = 1
    baud: int = 115200
    heartbeat_period_s: float = 1.0
    link_timeout_s: float = 3.0
    connect_timeout_s: float = 30.0
    command_timeout_s: float = 1.5
    command_attempts: int = 3
    state_confirm_timeout_s: float = 3.0
    mission_item_timeout_s: float = 1.5
    mission_retries: int = 5
    max_depth_m: float | None = None
    min_clearance_m: float | None = None
    telemetry_max_age_s: float = 2.0
    signing_key: bytes | None = field(default=None, repr=False)
    signing_link_id: int = 0
    tlog_path: str | None = None
    altimeter: AltimeterFeed | None = None
    mount_protocol: str = "mount_control"
    message_intervals_s: tuple[tuple[str, float], ...] = DEFAULT_MESSAGE_INTERVALS_S
    io_poll_s: float = 0.01
    water_density_kg_m3: float = 1025.0
    surface_pressure_pa: float = 101325.0

    def __post_init__(self) -> None:
        if not isinstance(self.connection, str) or not self.connection.strip():
            raise ConfigError("connection string is empty")
        for name in ("source_system", "target_component", "source_component"):
            value = getattr(self, name)
            if not 0 <= value <= 255:
                raise ConfigError(f"{name} must be 0..255, got {value}")
        if self.source_system == 0:
            raise ConfigError("source_system 0 is the broadcast id; use 1..255")
        if self.target_system is not None and not 1 <= self.target_system <= 255:
            raise ConfigError(f"target_system must be 1..255 or None, got {self.target_system}")
        for name in (
            "heartbeat_period_s",
            "link_timeout_s",
            "connect_timeout_s",
            "command_timeout_s",
            "state_confirm_timeout_s",
            "mission_item_timeout_s",
            "telemetry_max_age_s",
            "io_poll_s",
            "water_density_kg_m3",
        ):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
                raise ConfigError(f"{name} must be a finite number > 0, got {value!r}")
        if self.link_timeout_s <= self.heartbeat_period_s:
            raise ConfigError(
                f"link_timeout_s ({self.link_timeout_s}) must exceed "
                f"heartbeat_period_s ({self.heartbeat_period_s})"
            )
        if self.command_attempts < 1:
            raise ConfigError(f"command_attempts must be >= 1, got {self.command_attempts}")
        if self.mission_retries < 0:
            raise ConfigError(f"mission_retries must be >= 0, got {self.mission_retries}")
        if self.max_depth_m is not None and not self.max_depth_m > 0:
            raise ConfigError(f"max_depth_m must be > 0, got {self.max_depth_m}")
        if self.min_clearance_m is not None and not self.min_clearance_m >= 0:
            raise ConfigError(f"min_clearance_m must be >= 0, got {self.min_clearance_m}")
        if self.signing_key is not None:
            check_key(self.signing_key)
        if self.mount_protocol not in MOUNT_PROTOCOLS:
            raise ConfigError(
                f"mount_protocol must be one of {MOUNT_PROTOCOLS}, got {self.mount_protocol!r}"
            )
        for entry in self.message_intervals_s:
            if len(entry) != 2 or not isinstance(entry[0], str) or not entry[1] > 0:
                raise ConfigError(
                    f"message_intervals_s entries are (name, period_s > 0), got {entry!r}"
                )
