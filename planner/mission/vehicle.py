"""What the executor needs of a vehicle: the :class:`Vehicle` protocol.

:class:`vehicle_link.client.ArduSubClient` is the implementation (a real sub over MAVLink,
or the software sub behind the same client in a dry run); tests may pass anything that
has these members. The executor never reaches past them.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Protocol, TypeVar

from vehicle_link.config import LinkConfig
from vehicle_link.link import LinkHealth
from vehicle_link.mission import MissionItem
from vehicle_link.modes import SubMode
from vehicle_link.telemetry import GlobalOrigin, Heartbeat, ParamValue, PeerSeen, TelemetryRecord

T = TypeVar("T")


class Vehicle(Protocol):
    """The members of :class:`vehicle_link.client.ArduSubClient` the executor uses."""

    @property
    def config(self) -> LinkConfig:
        """The link's settings (the executor reads our own system id)."""
        ...

    @property
    def mode(self) -> int | None:
        """The flight mode of the newest heartbeat (``HEARTBEAT.custom_mode``), None before one."""
        ...

    @property
    def armed(self) -> bool | None:
        """Armed according to the newest heartbeat, None before one."""
        ...

    def connect(self) -> Heartbeat:
        """Wait for the vehicle's heartbeat and request its telemetry."""
        ...

    def latest(self, kind: type[T], key: str | None = None) -> T | None:
        """The newest telemetry record of a kind, None before one."""
        ...

    def add_listener(self, callback: Callable[[TelemetryRecord], None]) -> None:
        """Call ``callback(record)`` for every telemetry record (on the link's I/O thread)."""
        ...

    def link_health(self) -> LinkHealth:
        """Whether the link is up and how long the vehicle has been silent."""
        ...

    def set_mode(self, mode: SubMode | int | str, *, confirm: bool = True) -> SubMode:
        """Change the flight mode (raises when refused)."""
        ...

    def arm(self, *, force: bool = False, confirm: bool = True) -> None:
        """Arm the motors (raises when refused)."""
        ...

    def disarm(self, *, force: bool = False, confirm: bool = True) -> None:
        """Disarm the motors."""
        ...

    def get_parameter(self, name: str, *, timeout_s: float | None = None,
                      attempts: int | None = None) -> ParamValue:
        """Read one parameter (with the type the vehicle stores it as). The executor
        reads parameters; it never sets any."""
        ...

    def mount_frame(self) -> str | None:
        """"earth" (a stabilised mount) or "body", from MNT1_TYPE; None if unknown."""
        ...

    def ekf_origin(self, *, timeout_s: float | None = None) -> GlobalOrigin | None:
        """The vehicle's EKF origin, None if it has none."""
        ...

    def set_ekf_origin(self, latitude_deg: float, longitude_deg: float, altitude_m: float = 0.0, *,
                       timeout_s: float | None = None) -> GlobalOrigin:
        """Give the vehicle its EKF origin (ignored if it has one); returns the vehicle's."""
        ...

    def peers(self, kind: str, max_age_s: float) -> list[PeerSeen]:
        """Other systems heard lately: "HEARTBEAT" or "MANUAL_CONTROL" (a pilot's joystick)."""
        ...

    def upload_mission(self, items: Sequence[MissionItem], *, verify: bool = True,
                       home_slot: bool = True) -> list[MissionItem]:
        """Upload (and verify by download) a mission."""
        ...

    def goto_posvel(self, north_m: float, east_m: float, depth_m: float, vel_north_m_s: float,
                    vel_east_m_s: float, vel_down_m_s: float = 0.0, *, yaw_rad: float | None = None) -> None:
        """A GUIDED position + velocity target about the EKF origin (ArduSub stops on its
        own 3 s after the last one)."""
        ...

    def set_depth_target(self, depth_m: float) -> None:
        """A depth target (ALT_HOLD: SET_POSITION_TARGET_GLOBAL_INT with z only)."""
        ...

    def set_mount_tilt(self, tilt_rad: float, *, wait_ack: bool = True) -> None:
        """Point the sonar mount (tilt positive down)."""
        ...
