"""AUTO mode's mission execution, as AP_Mission runs it on ArduSub.

Items run in order from 1 (0 is home). A navigation item sets the position and the depth
(relative or global frame: ``z`` = -depth) or height above the seabed (terrain frame:
``z`` = altitude from the rangefinder) target; it is reached within WPNAV_RADIUS and
``REACHED_VERTICAL_TOLERANCE_M``, announced with MISSION_ITEM_REACHED, then held for its
``param1`` seconds (NAV_WAYPOINT, NAV_LOITER_TIME). DO items run at once when the runner
passes them. Latitude and longitude 0 mean "here". After the last item the vehicle holds
its position and MISSION_CURRENT reports MISSION_STATE_COMPLETE.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sim_harness.autopilot.guidance import NavStatus, Targets
from sim_harness.autopilot.location import latlon_to_ned
from sim_harness.autopilot.mission import NAV_COMMANDS, MissionItem, MissionProtocol
from sim_harness.vehicle.sensors import SensorReadings

M = mavlink
REACHED_VERTICAL_TOLERANCE_M = 0.5
HOLD_COMMANDS = frozenset({M.MAV_CMD_NAV_WAYPOINT, M.MAV_CMD_NAV_LOITER_TIME})


@dataclass(frozen=True)
class MissionHooks:
    """What the runner needs from the autopilot."""

    origin: Callable[[], tuple[float, float]]  # (lat_deg, lon_deg) of the local origin
    do_command: Callable[[MissionItem], None]  # run a DO item (speed, mount)
    announce_current: Callable[[], None]  # send MISSION_CURRENT
    emit: Callable[[mavlink.MAVLink_message], None]  # send a message
    text: Callable[[int, str], None]  # send a STATUSTEXT


class MissionRunner:
    """Current item, mission state and the reached/hold logic."""

    def __init__(self, protocol: MissionProtocol, targets: Targets, hooks: MissionHooks) -> None:
        self._protocol = protocol
        self._targets = targets
        self._hooks = hooks
        self.index = 0
        self.state = M.MISSION_STATE_NO_MISSION
        self._reached_at_s: float | None = None

    @property
    def has_items(self) -> bool:
        """True if there is at least one item besides home."""
        return len(self._protocol.items) > 1

    def reset(self) -> None:
        """A new (or cleared) mission: back to item 1, not started."""
        self.index = 1 if self.has_items else 0
        self.state = M.MISSION_STATE_NOT_STARTED if self.has_items else M.MISSION_STATE_NO_MISSION

    def begin(self, r: SensorReadings | None) -> None:
        """AUTO entered: resume the current item (restart if complete)."""
        if self.state == M.MISSION_STATE_COMPLETE or self.index < 1:
            self.index = 1
        self.state = M.MISSION_STATE_ACTIVE
        self.start(self.index, r)

    def pause(self) -> None:
        """AUTO left while running."""
        if self.state == M.MISSION_STATE_ACTIVE:
            self.state = M.MISSION_STATE_PAUSED

    def start(self, index: int, r: SensorReadings | None) -> None:
        """Make item ``index`` current, running DO items until a NAV item (or the end)."""
        items = self._protocol.items
        tg = self._targets
        while 1 <= index < len(items):
            item = items[index]
            self.index = index
            self._hooks.announce_current()
            if item.command in NAV_COMMANDS:
                self._reached_at_s = None
                if item.command == M.MAV_CMD_NAV_DELAY:
                    return
                if item.lat_e7 == 0 and item.lon_e7 == 0:
                    if r is not None:
                        tg.hold_ne = (r.north_m, r.east_m)
                else:
                    tg.hold_ne = latlon_to_ned(item.lat_e7 * 1e-7, item.lon_e7 * 1e-7,
                                               *self._hooks.origin())
                tg.vel = None
                if item.is_terrain:
                    tg.alt_m = item.z
                else:
                    tg.alt_m = None
                    tg.depth_m = -item.z
                return
            self._hooks.do_command(item)
            index += 1
        self.index = len(items) - 1
        self.state = M.MISSION_STATE_COMPLETE
        tg.alt_m = None
        self._hooks.text(M.MAV_SEVERITY_INFO, "Mission complete")

    def update(self, r: SensorReadings, nav: NavStatus, now_s: float, radius_m: float) -> None:
        """Advance when the current item is reached and its hold time is over."""
        if self.state != M.MISSION_STATE_ACTIVE:
            return
        items = self._protocol.items
        if not 1 <= self.index < len(items):
            return
        item = items[self.index]
        if item.command == M.MAV_CMD_NAV_LOITER_UNLIM:
            return
        if item.command == M.MAV_CMD_NAV_DELAY:
            hold_s, reached = item.param1, True
        else:
            hold_s = item.param1 if item.command in HOLD_COMMANDS else 0.0
            reached = (nav.distance_m <= radius_m
                       and abs(nav.vertical_error_m) <= REACHED_VERTICAL_TOLERANCE_M)
        if self._reached_at_s is None:
            if not reached:
                return
            self._reached_at_s = now_s
            self._hooks.emit(M.MAVLink_mission_item_reached_message(self.index))
            self._hooks.text(M.MAV_SEVERITY_INFO, f"Reached command #{self.index}")
        if now_s - self._reached_at_s >= max(hold_s, 0.0):
            self.start(self.index + 1, r)
