"""The one place that picks the pymavlink dialect: ArduPilot's, MAVLink 2 wire format.

pymavlink's ``mavutil`` chooses MAVLink 1 or 2 from the MAVLINK20 environment variable at
import time and can flip it process-wide. vehicle_link never relies on that: it imports the
MAVLink 2 generated module directly and gives each connection its own ``MAVLink`` object
(see :mod:`vehicle_link.transport`), so the bytes it sends start with 0xFD whatever the
environment says.
"""

from __future__ import annotations

from pymavlink.dialects.v20 import ardupilotmega as mavlink2

MAVLINK2_MAGIC = 0xFD

__all__ = ["mavlink2", "MAVLINK2_MAGIC"]
