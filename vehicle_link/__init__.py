"""shadowsurvey: vehicle_link - the companion computer's MAVLink 2 client for ArduSub.

The only controller-side package that imports pymavlink. Start with
:class:`~vehicle_link.client.ArduSubClient` and :class:`~vehicle_link.config.LinkConfig`;
see ``vehicle_link/README.md``.
"""

from vehicle_link.client import AltitudeTargetResult, ArduSubClient, LinkHealth, LinkStats
from vehicle_link.clock import Clock, ScaledClock, WallClock
from vehicle_link.config import AltimeterFeed, LinkConfig
from vehicle_link.mission import MissionItem, waypoint
from vehicle_link.modes import SubMode

__all__ = [
    "AltimeterFeed",
    "AltitudeTargetResult",
    "ArduSubClient",
    "Clock",
    "LinkConfig",
    "LinkHealth",
    "LinkStats",
    "MissionItem",
    "ScaledClock",
    "SubMode",
    "WallClock",
    "waypoint",
]
