"""AUTO's mission execution as AP_Mission and ``Sub::start_command`` run it on ArduSub 4.5.

Sources: ``libraries/AP_Mission/AP_Mission.cpp`` (``update``, ``advance_current_nav_cmd``,
``advance_current_do_cmd``, ``get_next_cmd``, ``get_next_do_cmd``, ``start_command``,
``increment_jump_times_run``, ``get_index_of_jump_tag``), ``ArduSub/commands_logic.cpp``
(``Sub::start_command``, ``verify_command``, ``do_nav_wp``, ``verify_nav_wp``,
``do_surface``, ``verify_surface``, ``exit_mission``), Sub-4.5 @30257f0118 (the
AP_Mission logic read again at the branch point 3926e06508: the same).

- Items run from 1 (0 is home). Every command started sends "Mission: N <type>"
  (``AP_Mission::start_command``). AP_Mission runs DO_GIMBAL_MANAGER_PITCHYAW, the
  servo, relay, camera, gripper and aux-function commands and JUMP_TAG itself (here they
  have nothing to move, DO_GIMBAL_MANAGER_PITCHYAW aside), and they complete at once;
  every other command goes to ``Sub::start_command``, which first reads the command's
  ``content.location`` and refuses anything but ABOVE_HOME with alt <= 0 ("Alt above home
  must be negative") or ABOVE_TERRAIN with alt >= 0 ("Alt above terrain must be
  positive"); anything else is "Bad alt frame". For payload commands (DO_CHANGE_SPEED,
  DO_MOUNT_CONTROL, CONDITION_*, NAV_DELAY) that "location" is their packed payload (a
  union), so with ordinary values they fail that check and have no effect; so does
  NAV_RETURN_TO_LAUNCH, whose location is not stored (all zero: the absolute frame). A
  refused nav item is skipped.
- When the search for the next nav item passes DO items, the first of them starts with
  it; the others follow one at a time, each once the one before completes
  (``advance_current_do_cmd``: CONDITION_DISTANCE refused with its stale distance of 0
  never completes and holds back the rest), and those not yet run are dropped when the
  nav item completes. So the DO items after nav item N take effect on the way to N + 1.
- DO_JUMP and DO_JUMP_TAG are never started: the search itself jumps (``get_next_cmd``),
  counting the jumps per DO_JUMP ("Mission: N Jump i/n"; -1 jumps forever, at most 64
  jumps per search); a target of 0 or beyond the mission (or a tag not found) ends the
  mission. The counts start again with the mission (a new mission, a disarm, a restart).
- NAV_WAYPOINT: lat = lon = 0 is here, alt 0 the current altitude in its frame; the leg
  (:mod:`sim_harness.autopilot.wpnav`) must finish and the vehicle be within WPNAV_RADIUS
  (3D), then param1 seconds pass; then "Reached command #N" and MISSION_ITEM_REACHED.
  A terrain-frame item follows the seabed by the rangefinder (``WPNAV_RFND_USE`` and a
  downward rangefinder); without one, "Terrain data (rangefinder) not available" and the
  terrain failsafe (``ModeAuto::auto_wp_start``).
- NAV_LAND (``do_surface``): to the item's place at the current depth (lat = lon = 0: where
  the vehicle is), then up to the surface there; done when the surface is reached.
- NAV_TAKEOFF and NAV_SPLINE_WAYPOINT pass the check and are skipped (Sub 4.5 has no case
  for them). Not simulated: NAV_LOITER_TURNS (``do_circle``), NAV_GUIDED_ENABLE,
  DO_SET_HOME and DO_SET_ROI in a mission ("sim: command N not simulated"), and the
  stale-heading turn a refused CONDITION_YAW's ``verify_yaw`` makes (north after a boot).
  After the last item
  the vehicle holds its stopping point in AUTO (``auto_loiter_start``), or goes to
  ALT_HOLD without a position.
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
#: Nav commands simulated as ``Sub::start_command`` runs them (after the alt-frame check).
SUB_NAV_SIMULATED = frozenset({M.MAV_CMD_NAV_WAYPOINT, M.MAV_CMD_NAV_LOITER_UNLIM, M.MAV_CMD_NAV_LOITER_TIME,
                               M.MAV_CMD_NAV_LAND})
#: Nav commands Sub 4.5's start_command has no case for: skipped without a word.
SUB_NAV_SKIPPED = frozenset({M.MAV_CMD_NAV_TAKEOFF, M.MAV_CMD_NAV_SPLINE_WAYPOINT})
#: Commands ``AP_Mission::start_command`` runs itself (verify: done at once).
MISSION_OWN = frozenset({
    M.MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW, M.MAV_CMD_DO_SET_SERVO, M.MAV_CMD_DO_SET_RELAY, M.MAV_CMD_DO_REPEAT_SERVO,
    M.MAV_CMD_DO_REPEAT_RELAY, M.MAV_CMD_DO_DIGICAM_CONFIGURE, M.MAV_CMD_DO_DIGICAM_CONTROL,
    M.MAV_CMD_DO_SET_CAM_TRIGG_DIST, M.MAV_CMD_IMAGE_START_CAPTURE, M.MAV_CMD_IMAGE_STOP_CAPTURE,
    M.MAV_CMD_VIDEO_START_CAPTURE, M.MAV_CMD_VIDEO_STOP_CAPTURE, M.MAV_CMD_DO_GRIPPER, M.MAV_CMD_DO_AUX_FUNCTION,
    M.MAV_CMD_DO_SET_RESUME_REPEAT_DIST,
})
JUMPS = frozenset({M.MAV_CMD_DO_JUMP, M.MAV_CMD_DO_JUMP_TAG})
#: DO and condition commands ``Sub::verify_command`` knows (the rest: "Skipping invalid cmd").
SUB_VERIFIED = frozenset({
    M.MAV_CMD_CONDITION_DELAY, M.MAV_CMD_CONDITION_DISTANCE, M.MAV_CMD_CONDITION_YAW, M.MAV_CMD_DO_CHANGE_SPEED,
    M.MAV_CMD_DO_SET_HOME, M.MAV_CMD_DO_SET_ROI, M.MAV_CMD_DO_MOUNT_CONTROL, M.MAV_CMD_DO_CONTROL_VIDEO,
    M.MAV_CMD_DO_SET_CAM_TRIGG_DIST, M.MAV_CMD_DO_GUIDED_LIMITS,
})
#: ``Mission_Command::type()`` of the commands stored.
TYPE_NAMES = {
    M.MAV_CMD_NAV_WAYPOINT: "WP", M.MAV_CMD_NAV_SPLINE_WAYPOINT: "SplineWP", M.MAV_CMD_NAV_RETURN_TO_LAUNCH: "RTL",
    M.MAV_CMD_NAV_LOITER_UNLIM: "LoitUnlim", M.MAV_CMD_NAV_LOITER_TIME: "LoitTime",
    M.MAV_CMD_NAV_GUIDED_ENABLE: "GuidedEnable", M.MAV_CMD_NAV_LOITER_TURNS: "LoitTurns",
    M.MAV_CMD_CONDITION_DELAY: "CondDelay", M.MAV_CMD_CONDITION_DISTANCE: "CondDist",
    M.MAV_CMD_DO_CHANGE_SPEED: "ChangeSpeed", M.MAV_CMD_DO_SET_HOME: "SetHome", M.MAV_CMD_DO_SET_SERVO: "SetServo",
    M.MAV_CMD_DO_SET_RELAY: "SetRelay", M.MAV_CMD_DO_REPEAT_SERVO: "RepeatServo",
    M.MAV_CMD_DO_REPEAT_RELAY: "RepeatRelay", M.MAV_CMD_DO_DIGICAM_CONFIGURE: "DigiCamCfg",
    M.MAV_CMD_DO_DIGICAM_CONTROL: "DigiCamCtrl", M.MAV_CMD_DO_SET_CAM_TRIGG_DIST: "SetCamTrigDst",
    M.MAV_CMD_DO_SET_ROI: "SetROI", M.MAV_CMD_DO_SET_RESUME_REPEAT_DIST: "SetRepeatDist",
    M.MAV_CMD_NAV_TAKEOFF: "Takeoff", M.MAV_CMD_NAV_LAND: "Land", M.MAV_CMD_CONDITION_YAW: "CondYaw",
    M.MAV_CMD_DO_LAND_START: "LandStart", M.MAV_CMD_NAV_DELAY: "Delay", M.MAV_CMD_DO_GRIPPER: "Gripper",
    M.MAV_CMD_DO_AUX_FUNCTION: "AuxFunction", M.MAV_CMD_DO_MOUNT_CONTROL: "MountControl",
    M.MAV_CMD_JUMP_TAG: "Tag", M.MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW: "GimbalPitchYaw",
    M.MAV_CMD_IMAGE_START_CAPTURE: "ImageStartCapture", M.MAV_CMD_IMAGE_STOP_CAPTURE: "ImageStopCapture",
    M.MAV_CMD_VIDEO_START_CAPTURE: "VideoStartCapture", M.MAV_CMD_VIDEO_STOP_CAPTURE: "VideoStopCapture",
}
INDEX_NONE = 65535  # AP_MISSION_CMD_INDEX_NONE
MAX_JUMPS_PER_SEARCH = 64
MAX_SEARCH_LOOPS = 255  # advance_current_nav_cmd's guard against endless loops


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
    """The running nav and DO items, the jump counts and the reached/hold logic."""

    def __init__(self, protocol: MissionProtocol, targets: Targets, hooks: MissionHooks) -> None:
        self._protocol = protocol
        self._targets = targets
        self._hooks = hooks
        self.index = 0
        self.state = M.MISSION_STATE_NO_MISSION
        self._reached_at_s: float | None = None
        self._do_index: int | None = None  # the last DO item started (``_do_cmd.index``)
        self._do_loaded = False  # it has not completed yet
        self._do_all_done = False
        self._jumps: dict[int, int] = {}  # DO_JUMP index -> times run (``_jump_tracking``)
        self._surfacing: tuple[float, float] | None = None  # NAV_LAND's place once ascending

    @property
    def has_items(self) -> bool:
        """True if there is at least one item besides home (``num_commands() >= 2``)."""
        return len(self._protocol.items) > 1

    @property
    def nav_index(self) -> int:
        """The running nav command's index, or 65535 (none)."""
        return self.index if self.state == M.MISSION_STATE_ACTIVE else INDEX_NONE

    def reset(self) -> None:
        """A new (or cleared) mission, or a disarm (``mission.reset()``): back to item 1,
        the jump counts cleared."""
        self.index = 1 if self.has_items else 0
        self.state = M.MISSION_STATE_NOT_STARTED if self.has_items else M.MISSION_STATE_NO_MISSION
        self._do_index, self._do_loaded = None, False
        self._jumps.clear()

    def begin(self, r: SensorReadings | None) -> None:
        """AUTO entered: ``start_or_resume`` (restart if complete; a resume restarts the
        running DO item, or else the nav item: ``set_current_cmd``)."""
        if self.state == M.MISSION_STATE_COMPLETE or self.index < 1:
            self.index = 1
            self._jumps.clear()
        self.state = M.MISSION_STATE_ACTIVE
        self.start(self._do_index if self._do_loaded and self._do_index is not None else self.index, r)

    def pause(self) -> None:
        """AUTO left while running."""
        if self.state == M.MISSION_STATE_ACTIVE:
            self.state = M.MISSION_STATE_PAUSED

    # ------------------------------------------------------------------ the search
    def _next_cmd(self, start: int, *, counting: bool) -> int | None:
        """``get_next_cmd``: the first item at or after ``start`` that is not a jump,
        following the jumps (counted when ``counting``); None: the mission ends."""
        items = self._protocol.items
        index, first_jump, loops = start, None, MAX_JUMPS_PER_SEARCH
        while index < len(items):
            item = items[index]
            if item.command not in JUMPS:
                return index
            target, times = int(item.payload[0]), int(item.payload[1])
            if item.command == M.MAV_CMD_DO_JUMP_TAG:
                target = self._tag_index(target)
            if loops == 0 or target == 0 or target >= len(items):
                return None
            loops -= 1
            if not counting and first_jump == index:
                return None  # the same jump twice in one search: an endless loop
            first_jump = index if first_jump is None else first_jump
            if times == -1:
                index = target
            elif self._jumps.get(index, 0) < times:
                if counting and item.command == M.MAV_CMD_DO_JUMP:  # increment_jump_times_run
                    run = self._jumps.get(index, 0) + 1
                    self._jumps[index] = run
                    if run > 1:  # the first run is recorded without a message
                        self._hooks.text(M.MAV_SEVERITY_INFO, f"Mission: {index} Jump {run}/{times}")
                index = target
            else:
                index += 1
        return None

    def _tag_index(self, tag: int) -> int:
        """``get_index_of_jump_tag``: the first JUMP_TAG item with this tag, 0 if none."""
        for index, item in enumerate(self._protocol.items[1:], start=1):
            if item.command == M.MAV_CMD_JUMP_TAG and int(item.payload[0]) == tag:
                return index
        return 0

    def start(self, index: int, r: SensorReadings | None) -> None:
        """``advance_current_nav_cmd(index)``: search from ``index`` for the next nav item that
        starts and make it current; the first DO item passed on the way starts with it."""
        self._do_index, self._do_loaded, self._do_all_done = None, False, False
        self._reached_at_s, self._surfacing = None, None
        items = self._protocol.items
        search = max(index, 1)
        for _ in range(MAX_SEARCH_LOOPS):
            found = self._next_cmd(search, counting=True)
            if found is None:
                break
            item = items[found]
            if item.command in NAV_COMMANDS:
                self.index = found
                self._hooks.announce_current()
                if self._start_command(found, r):
                    if not self._do_loaded:
                        self._do_all_done = True
                    return
            elif not self._do_loaded:
                self._do_index, self._do_loaded = found, True
                self._start_command(found, r)
            search = found + 1
        self._end()  # no nav item started (or 255 tries: a loop of refused items): complete

    def _end(self) -> None:
        self.index = len(self._protocol.items) - 1
        self.state = M.MISSION_STATE_COMPLETE
        self._hooks.announce_current()
        self._hooks.mission_end()

    def _start_command(self, index: int, r: SensorReadings | None) -> bool:
        """``AP_Mission::start_command``: its message, then AP_Mission's own commands or Sub's."""
        item = self._protocol.items[index]
        self._hooks.text(M.MAV_SEVERITY_INFO, f"Mission: {index} {TYPE_NAMES.get(item.command, '?')}")
        if item.command == M.MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW:
            self._hooks.gimbal_pitchyaw(item)
            return True
        if item.command in MISSION_OWN:
            return True  # nothing here to move (servos, relays, cameras, grippers)
        return self._sub_start_command(item, r)  # JUMP_TAG too (its tag recorded, it falls through)

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
        if item.command == M.MAV_CMD_NAV_LAND:
            return self._do_surface(item, r)
        if item.command in SUB_NAV_SIMULATED:
            return self._do_nav_wp(item, r)
        if item.command in SUB_NAV_SKIPPED:
            return False
        if item.command in NAV_COMMANDS or item.command in (M.MAV_CMD_DO_SET_HOME, M.MAV_CMD_DO_SET_ROI):
            self._hooks.text(M.MAV_SEVERITY_WARNING, f"sim: command {item.command} not simulated")
            return item.command not in NAV_COMMANDS
        self._hooks.do_command(item)
        return True

    def _place(self, item: StoredItem, r: SensorReadings | None) -> tuple[float, float] | None:
        if item.lat_e7 == 0 and item.lon_e7 == 0:
            return (r.north_m, r.east_m) if r is not None else None
        return self._hooks.ned_of(item.lat_e7, item.lon_e7)

    def _do_nav_wp(self, item: StoredItem, r: SensorReadings | None) -> bool:
        """``Sub::do_nav_wp`` -> ``ModeAuto::auto_wp_start(Location)``."""
        ne = self._place(item, r)
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
        return True

    def _do_surface(self, item: StoredItem, r: SensorReadings | None) -> bool:
        """``Sub::do_surface``: to the place at the current depth (no terrain database on a
        sub: the current altitude above home), or straight up when the item has none."""
        if r is None:
            return False
        if item.lat_e7 == 0 and item.lon_e7 == 0:
            self._surfacing = (r.north_m, r.east_m)
            self._hooks.start_leg(r.north_m, r.east_m, 0.0, None)
            return True
        ne = self._place(item, r)
        if ne is None:
            return False
        self._hooks.start_leg(ne[0], ne[1], r.depth_m, None)
        return True

    # ------------------------------------------------------------------ each step
    def update(self, r: SensorReadings, nav: NavStatus, now_s: float, radius_m: float) -> None:
        """``AP_Mission::update``: verify the nav item (and advance), then the DO item."""
        if self.state != M.MISSION_STATE_ACTIVE:
            return
        items = self._protocol.items
        if not 1 <= self.index < len(items):
            return
        if self._verify_nav(items[self.index], r, nav, now_s, radius_m):
            self._hooks.emit(M.MAVLink_mission_item_reached_message(self.index))
            self.start(self.index + 1, r)
            if self.state != M.MISSION_STATE_ACTIVE:
                return
        if not self._do_loaded:
            self._advance_do(r)
        elif self._do_index is not None and self._verify_do(self._do_index):
            self._do_loaded = False

    def _verify_nav(self, item: StoredItem, r: SensorReadings, nav: NavStatus, now_s: float,
                    radius_m: float) -> bool:
        """``verify_nav_wp`` (reached within WPNAV_RADIUS, then held param1 s) and
        ``verify_surface``."""
        if item.command == M.MAV_CMD_NAV_LOITER_UNLIM:
            return False
        reached = nav.leg_reached and math.hypot(nav.distance_m, nav.vertical_error_m) <= radius_m
        if item.command == M.MAV_CMD_NAV_LAND:
            if reached and self._surfacing is None:  # there: up to the surface (at the item's place)
                self._surfacing = self._place(item, r)
                if self._surfacing is not None:
                    self._hooks.start_leg(self._surfacing[0], self._surfacing[1], 0.0, None)
                return False
            return reached and self._surfacing is not None
        hold_s = float(item.p1) if item.command in HOLD_COMMANDS else 0.0
        if self._reached_at_s is None:
            if not reached:
                return False
            self._reached_at_s = now_s
        if math.floor(now_s - self._reached_at_s) < hold_s:
            return False
        if item.command == M.MAV_CMD_NAV_WAYPOINT:  # verify_nav_wp's text alone
            self._hooks.text(M.MAV_SEVERITY_INFO, f"Reached command #{self.index}")
        return True

    def _verify_do(self, index: int) -> bool:
        """``verify_command`` of the running DO item: AP_Mission's own are done at once; Sub's
        (``verify_command_callback``: MISSION_ITEM_REACHED when done) too, except
        CONDITION_DISTANCE (refused by the alt-frame check, so its distance stays 0: never);
        a command Sub does not know is "Skipping invalid cmd #id", done."""
        item = self._protocol.items[index]
        if item.command in MISSION_OWN or item.command == M.MAV_CMD_JUMP_TAG:
            return True
        if item.command == M.MAV_CMD_CONDITION_DISTANCE:
            return False
        if item.command not in SUB_VERIFIED:
            self._hooks.text(M.MAV_SEVERITY_WARNING, f"Skipping invalid cmd #{item.command}")
        self._hooks.emit(M.MAVLink_mission_item_reached_message(index))
        return True

    def _advance_do(self, r: SensorReadings) -> None:
        """``advance_current_do_cmd``: the next DO item before the next nav item, if any."""
        if self._do_all_done:
            return
        start = self._do_index + 1 if self._do_index is not None else 1
        found = self._next_cmd(start, counting=False) if start < len(self._protocol.items) else None
        if found is None or self._protocol.items[found].command in NAV_COMMANDS:
            self._do_all_done = True
            return
        self._do_index, self._do_loaded = found, True
        self._start_command(found, r)
