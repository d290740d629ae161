"""What the executor needs of a vehicle: the :class:`Vehicle` protocol.

:class:`vehicle_link.client.ArduSubClient` is the implementation (a real sub over MAVLink,
or the software sub behind the same client in a dry run); tests may pass anything that
has these members. The executor never reaches past them.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol, TypeVar

from vehicle_link.config import LinkConfig
from vehicle_link.link import LinkHealth
from vehicle_link.mission import MissionItem
from vehicle_link.modes import SubMode
from vehicle_link.telemetry import Heartbeat

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

    def link_health(self) -> LinkHealth:
        """Whether the link is up and how long the vehicle has been silent."""
        ...

    def set_mode(self, mode: SubMode | int | str, *, confirm: bool = True) -> SubMode:
        """Change the flight mode (raises when refused)."""
        ...

    def arm(self, *, force: bool = False, confirm: bool = True) -> None:
        """Arm the motors (raises when refused)."""
        ...

    def set_parameter(self, name: str, value: float, *, timeout_s: float | None = None,
                      attempts: int | None = None) -> float:
        """Set a parameter, confirmed by its echo; returns the value the vehicle holds."""
        ...

    def upload_mission(self, items: Sequence[MissionItem], *, verify: bool = True,
                       home_slot: bool = True) -> list[MissionItem]:
        """Upload (and verify by download) a mission."""
        ...

    def goto_local_ned(self, north_m: float, east_m: float, depth_m: float, *,
                       yaw_rad: float | None = None) -> None:
        """A GUIDED position target about the EKF origin."""
        ...

    def set_mount_tilt(self, tilt_rad: float, *, wait_ack: bool = True) -> None:
        """Point the sonar mount (tilt positive down)."""
        ...
