"""The ArduSub 4.5-like autopilot: modes, guidance, mission, parameters, telemetry, MAVLink socket."""

from sim_harness.autopilot.autopilot import Autopilot, AutopilotConfig
from sim_harness.autopilot.guidance import Mode
from sim_harness.autopilot.location import latlon_to_ned, ned_to_latlon
from sim_harness.autopilot.mavlink_endpoint import LinkAddress, MavlinkPort, open_transport
from sim_harness.autopilot.mission import REREQUEST_INTERVAL_S, UPLOAD_TIMEOUT_S

__all__ = [
    "Autopilot",
    "AutopilotConfig",
    "LinkAddress",
    "MavlinkPort",
    "Mode",
    "REREQUEST_INTERVAL_S",
    "UPLOAD_TIMEOUT_S",
    "latlon_to_ned",
    "ned_to_latlon",
    "open_transport",
]
