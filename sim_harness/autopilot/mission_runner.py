"""AUTO's mission execution as AP_Mission and ``Sub::start_command`` run it on ArduSub 4.5.

Sources: ``libraries/AP_Mission/AP_Mission.cpp`` (``advance_current_nav_cmd``,
``start_command``), ``ArduSub/commands_logic.cpp`` (``Sub::start_command``,
``do_nav_wp``, ``verify_nav_wp``, ``exit_mission``), Sub-4.5 @30257f0118.

- Items run from 1 (0 is home). AP_Mission handles DO_GIMBAL_MANAGER_PITCHYAW itself;
  every other command goes to ``Sub::start_command``, which first reads the command's
  ``content.location`` and refuses anything but ABOVE_HOME with alt <= 0 ("Alt above home
  must be negative") or ABOVE_TERRAIN with alt >= 0 ("Alt above terrain must be
  positive"); anything else is "Bad alt frame". For payload commands (DO_CHANGE_SPEED,
  DO_MOUNT_CONTROL, CONDITION_DELAY, CONDITION_YAW, NAV_DELAY) that "location" is their
  packed payload (a union), so with ordinary values they fail that check and have no
  effect; a refused nav item is skipped.
- NAV_WAYPOINT: lat = lon = 0 is here, alt 0 the current altitude in its frame; the leg
  (:mod:`sim_harness.autopilot.wpnav`) must finish and the vehicle be within WPNAV_RADIUS
  (3D), then param1 seconds pass; then "Reached command #N" and MISSION_ITEM_REACHED.
  A terrain-frame item follows the seabed by the rangefinder (``WPNAV_RFND_USE`` and a
  downward rangefinder); without one, "Terrain data (rangefinder) not available" and the
  terrain failsafe (``ModeAuto::auto_wp_start``).
- Unknown nav commands: "Ignoring command N". After the last item the vehicle holds its
  stopping point in AUTO (``auto_loiter_start``), or goes to ALT_HOLD without a position.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sim_harness.autopilot.guidance import NavStatus, Targets
from sim_harness.autopilot.mission import MissionProtocol
from sim_harness.autopilot.mission_storage import NAV_COMMANDS, StoredItem
from sim_harness.vehicle.sensors import SensorReadings

M = mavlink
HOLD_COMMANDS = frozenset({M.MAV_CMD_NAV_WAYPOINT, M.MAV_CMD_NAV_LOITER_TIME})
#: Commands Sub's start_command runs (after the alt-frame check); the rest are ignored.
SUB_NAV_SIMULATED = frozenset({M.MAV_CMD_NAV_WAYPOINT, M.MAV_CMD_NAV_LOITER_UNLIM, M.MAV_CMD_NAV_LOITER_TIME})
INDEX_NONE = 65535  # AP_MISSION_CMD_INDEX_NONE


@dataclass(frozen=True)
class MissionHooks:
    """What the runner needs from the autopilot."""

    ned_of: Callable[[int, int], tuple[float, float] | None]  # lat_e7, lon_e7 -> NED about the origin
    terrain_available: Callable[[], bool]  # a downward rangefinder AC_WPNav may use
    on_terrain_unavailable: Callable[[], None]  # failsafe_terrain_on_event
    do_command: Callable[[StoredItem], None]  # run a DO item that passed Sub's checks
    gimbal_pitchyaw: Callable[[StoredItem], None]  # AP_Mission's DO_GIMBAL_MANAGER_PITCHYAW
    start_leg: Callable[[float, float, float | None, float | None], None]  # north, east, depth, altitude
    announce_current: Callable[[], None]  # send MISSION_CURRENT
    emit: Callable[[mavlink.MAVLink_message], None]  # send a message
    text: Callable[[int, str], None]  # send a STATUSTEXT
    mission_end: Callable[[], None]  # Sub::exit_mission


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
        """True if there is at least one item besides home (``num_commands() >= 2``)."""
        return len(self._protocol.items) > 1

    @property
    def nav_index(self) -> int:
        """The running nav command's index, or 65535 (none)."""
        return self.index if self.state == M.MISSION_STATE_ACTIVE else INDEX_NONE

    def reset(self) -> None:
        """A new (or cleared) mission, or a disarm (``mission.reset()``): back to item 1."""
        self.index = 1 if self.has_items else 0
        self.state = M.MISSION_STATE_NOT_STARTED if self.has_items else M.MISSION_STATE_NO_MISSION

    def begin(self, r: SensorReadings | None) -> None:
        """AUTO entered: ``start_or_resume`` (restart if complete)."""
        if self.state == M.MISSION_STATE_COMPLETE or self.index < 1:
            self.index = 1
        self.state = M.MISSION_STATE_ACTIVE
        self.start(self.index, r)

    def pause(self) -> None:
        """AUTO left while running."""
        if self.state == M.MISSION_STATE_ACTIVE:
            self.state = M.MISSION_STATE_PAUSED

    def _sub_start_command(self, item: StoredItem, r: SensorReadings | None) -> bool:
        """``Sub::start_command``: the alt-frame check, then the command itself."""
        frame, alt_cm = item.alt_frame()
        if frame == "above_home":
            if alt_cm > 0:
                self._hooks.text(M.MAV_SEVERITY_WARNING, "Alt above home must be negative")
                return False
        elif frame == "above_terrain":
            if alt_cm < 0:
                self._hooks.text(M.MAV_SEVERITY_WARNING, "Alt above terrain must be positive")
                return False
        else:
            self._hooks.text(M.MAV_SEVERITY_WARNING, "Bad alt frame")
            return False
        if item.command in SUB_NAV_SIMULATED:
            return self._do_nav_wp(item, r)
        if item.command in NAV_COMMANDS:
            self._hooks.text(M.MAV_SEVERITY_WARNING, f"Ignoring command {item.command}")
            return False
        self._hooks.do_command(item)
        return True

    def _do_nav_wp(self, item: StoredItem, r: SensorReadings | None) -> bool:
        """``Sub::do_nav_wp`` -> ``ModeAuto::auto_wp_start(Location)``."""
        if item.lat_e7 == 0 and item.lon_e7 == 0:
            ne = (r.north_m, r.east_m) if r is not None else None
        else:
            ne = self._hooks.ned_of(item.lat_e7, item.lon_e7)
        if ne is None:
            self._hooks.text(M.MAV_SEVERITY_WARNING, "Mission item has no location (no EKF origin)")
            return False
        alt_m = item.alt_cm / 100.0
        if item.terrain_alt:
            if not self._hooks.terrain_available():
                self._hooks.text(M.MAV_SEVERITY_WARNING, "Terrain data (rangefinder) not available")
                self._hooks.on_terrain_unavailable()
                return True
            if item.alt_cm == 0:
                alt_m = r.altitude_m if r is not None and r.altitude_m is not None else 0.0
            self._hooks.start_leg(ne[0], ne[1], None, alt_m)
        else:
            depth = -alt_m if item.alt_cm != 0 or r is None else r.depth_m
            self._hooks.start_leg(ne[0], ne[1], depth, None)
        self._reached_at_s = None
        return True

    def start(self, index: int, r: SensorReadings | None) -> None:
        """Make the first nav item from ``index`` current (``advance_current_nav_cmd``),
        running the DO items before it and those that follow it up to the next nav item."""
        items = self._protocol.items
        while 1 <= index < len(items):
            item = items[index]
            if item.command not in NAV_COMMANDS:
                self._start_do(item, r)
                index += 1
                continue
            self.index = index
            self._hooks.announce_current()
            if self._sub_start_command(item, r):
                following = index + 1
                while following < len(items) and items[following].command not in NAV_COMMANDS:
                    self._start_do(items[following], r)
                    following += 1
                return
            index += 1
        self.index = len(items) - 1
        self.state = M.MISSION_STATE_COMPLETE
        self._hooks.announce_current()
        self._hooks.mission_end()

    def _start_do(self, item: StoredItem, r: SensorReadings | None) -> None:
        if item.command == M.MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW:
            self._hooks.gimbal_pitchyaw(item)  # AP_Mission::start_command handles it itself
        else:
            self._sub_start_command(item, r)

    def update(self, r: SensorReadings, nav: NavStatus, now_s: float, radius_m: float) -> None:
        """Advance when the current item is reached (``verify_nav_wp``) and held long enough."""
        if self.state != M.MISSION_STATE_ACTIVE:
            return
        items = self._protocol.items
        if not 1 <= self.index < len(items):
            return
        item = items[self.index]
        if item.command == M.MAV_CMD_NAV_LOITER_UNLIM:
            return
        hold_s = float(item.p1) if item.command in HOLD_COMMANDS else 0.0
        distance_3d = math.hypot(nav.distance_m, nav.vertical_error_m)
        if self._reached_at_s is None:
            if not (nav.leg_reached and distance_3d <= radius_m):
                return
            self._reached_at_s = now_s
        if math.floor(now_s - self._reached_at_s) >= hold_s:
            self._hooks.text(M.MAV_SEVERITY_INFO, f"Reached command #{self.index}")
            self._hooks.emit(M.MAVLink_mission_item_reached_message(self.index))
            following = self.index + 1
            while following < len(items) and items[following].command not in NAV_COMMANDS:
                following += 1  # their DO items ran when this nav item started
            self.start(following, r)
