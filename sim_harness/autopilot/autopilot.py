"""The simulated ArduSub 4.5 flight controller: message dispatch, modes, arming, the loop.

No sockets here: :meth:`Autopilot.handle` takes a decoded MAVLink message and returns the
replies; :meth:`Autopilot.update` runs one control step on sensor readings (estimates,
never truth) and returns thrust, the mount's servo angle and messages to send. Each
behaviour lives in the module of its idea and cites its ArduSub 4.5 source there:
commands and their ACK codes (:mod:`~sim_harness.autopilot.commands`), modes and guidance
(:mod:`~sim_harness.autopilot.guidance`, :mod:`~sim_harness.autopilot.wpnav`), position
targets (:mod:`~sim_harness.autopilot.position_targets`), the pilot's input
(:mod:`~sim_harness.autopilot.pilot`), failsafes (:mod:`~sim_harness.autopilot.failsafes`),
the mount (:mod:`~sim_harness.autopilot.mount`), EKF origin and home
(:mod:`~sim_harness.autopilot.navigation`), the mission (``mission*``), parameters,
SYS_STATUS bits, telemetry and MAVFTP. Sources: Sub-4.5 @30257f0118 (ArduSub 4.5.7).

Here: ``Sub::set_mode`` (ArduSub/mode.cpp: same mode is a success; "No such mode N";
"Mode change failed: X requires position"; a failed ``init`` "Flight mode change failed
X"; on success a HEARTBEAT at once and the mount back to its default mode), arming
(``AP_Arming_Sub``: a mode may always be armed in; disarming resets the mission), the
rangefinder (``Sub::init_rangefinder``: enabled at boot when RNGFND1_TYPE is set and
RNGFND1_ORIENT is down; ``read_rangefinder``: healthy after 3 good readings within
RNGFND1_MIN_CM..MAX_CM), SURFACE ending in ALT_HOLD at the surface (``ModeSurface::run``,
SURFACE_DEPTH). What the telemetry reports (HEARTBEAT base_mode and system_status among
it) is :mod:`~sim_harness.autopilot.status`.
"""

from __future__ import annotations

import math

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sim_harness.autopilot.commands import handle_command
from sim_harness.autopilot.config import AutopilotConfig
from sim_harness.autopilot.failsafes import FailsafeActions, Failsafes
from sim_harness.autopilot.guidance import (
    INIT_NEEDS_POSITION,
    MODE_NAMES,
    REQUIRES_POSITION,
    SIMULATED_MODES,
    Guidance,
    Mode,
    Targets,
)
from sim_harness.autopilot.guided_request import do_guided
from sim_harness.autopilot.inbox import Inbox
from sim_harness.autopilot.mission import MissionProtocol
from sim_harness.autopilot.mission_runner import MissionHooks, MissionRunner
from sim_harness.autopilot.mission_storage import StoredItem
from sim_harness.autopilot.mount import Mount
from sim_harness.autopilot.navigation import GeoPoint, Navigation
from sim_harness.autopilot.params import ParamTable
from sim_harness.autopilot.pilot import PilotInput
from sim_harness.autopilot.rangefinder import Rangefinder
from sim_harness.autopilot.status import snapshot
from sim_harness.autopilot.telemetry import (
    BUILDABLE_IDS,
    STREAMS,
    TelemetryScheduler,
    TelemetrySnapshot,
    build_message,
)
from sim_harness.faults import FaultConfig
from sim_harness.vehicle.dynamics import MountMechanics, RovParams
from sim_harness.vehicle.sensors import SensorReadings

__all__ = ["Autopilot", "AutopilotConfig", "Mode"]

M = mavlink


class Autopilot:
    """The simulated flight controller."""

    def __init__(self, config: AutopilotConfig, rov: RovParams, mount: MountMechanics, faults: FaultConfig) -> None:
        self.cfg = config
        self.rov = rov
        self.mount_limits = mount
        self.faults = faults
        overrides: dict[str, float] = {"MNT1_PITCH_MIN": -math.degrees(mount.max_tilt_rad),
                                       "MNT1_PITCH_MAX": -math.degrees(mount.min_tilt_rad)}
        overrides.update(config.setup)
        overrides.update(config.params)
        overrides.setdefault("SYSID_THISMAV", float(config.system_id))
        self.params = ParamTable(overrides)
        p = self.params
        self.telemetry = TelemetryScheduler({n: p[n] for n in STREAMS})
        self.mode = Mode.MANUAL  # init_joystick: the vehicle boots in MANUAL
        self.armed = False
        origin = config.origin
        self.navigation = Navigation(GeoPoint(*origin) if origin is not None else None)
        self._outbox: list[mavlink.MAVLink_message | None] = []
        self.targets = Targets()
        self.guidance = Guidance(rov, p, lambda text: self.text(M.MAV_SEVERITY_INFO, text))
        # AP_Mount::init and Sub::init_rangefinder read their type once, at boot.
        self.mount = Mount(mount_type=int(p["MNT1_TYPE"]), default_mode=int(p["MNT1_DEFLT_MODE"]),
                           pitch_min_deg=p["MNT1_PITCH_MIN"], pitch_max_deg=p["MNT1_PITCH_MAX"],
                           rc_rate_deg_s=p["MNT1_RC_RATE"])
        self.mount.pitch_rad = -mount.default_tilt_rad
        self.rangefinder = Rangefinder(p)
        self.pilot = PilotInput()
        self.failsafes = Failsafes(p, FailsafeActions(
            armed=lambda: self.armed, disarm=lambda why: self.disarm(why, force=True),
            set_mode=lambda mode, why: self.set_mode(mode, reason=why), text=self.text,
            neutral_controls=self.pilot.neutral), sitl_build=config.sitl_build)
        self.mission = MissionProtocol(self.home_tuple, self._on_new_mission, self.text,
                                       lambda: self.runner.nav_index, self.guided_request)
        self.runner = MissionRunner(self.mission, self.targets, MissionHooks(
            ned_of=lambda lat, lon: self.navigation.ned_of(lat * 1e-7, lon * 1e-7),
            terrain_available=self._terrain_available,
            on_terrain_unavailable=self.failsafes.terrain_event,
            do_command=self._do_command, gimbal_pitchyaw=lambda item: self.mount.mission_pitchyaw(*item.payload[:5]),
            start_leg=self._start_leg, announce_current=lambda: self.queue_message(M.MAVLINK_MSG_ID_MISSION_CURRENT),
            emit=lambda msg: self._outbox.append(msg), text=self.text, mission_end=self._mission_end,
        ))
        self.readings: SensorReadings | None = None
        self._inbox = Inbox(self)
        self.thrust = (0.0, 0.0, 0.0, 0.0)
        self.servo_tilt_rad = mount.default_tilt_rad

    # ------------------------------------------------------------------ helpers
    def text(self, severity: int, text: str) -> None:
        """Queue a STATUSTEXT (truncated to 50 characters, as MAVLink)."""
        self._outbox.append(mavlink.MAVLink_statustext_message(severity, text[:50].encode(), 0, 0))

    def home_tuple(self) -> tuple[float, float, float] | None:
        h = self.navigation.home
        return None if h is None else (h.lat_deg, h.lon_deg, h.alt_m)

    def position_ok(self) -> bool:
        """``Sub::position_ok``."""
        return self.navigation.position_ok(self.readings, self.params)

    def has_home(self) -> bool:
        """True once home is set."""
        return self.navigation.home is not None

    def queue_message(self, msg_id: int) -> None:
        """Send one telemetry message now (REQUEST_MESSAGE and friends); nothing if it cannot be built."""
        if self.readings is not None and msg_id in BUILDABLE_IDS:
            self._outbox.append(build_message(msg_id, self.snapshot(self.readings.time_s)))

    def set_message_interval(self, msg_id: int, interval_us: float, now_s: float) -> None:
        """SET_MESSAGE_INTERVAL for a mapped id (unbuildable ones are accepted and never sent)."""
        if msg_id in BUILDABLE_IDS:
            self.telemetry.set_interval(msg_id, interval_us, now_s=now_s)

    def _drain(self) -> list[mavlink.MAVLink_message]:
        out, self._outbox = self._outbox, []
        return [m for m in out if m is not None]

    # ------------------------------------------------------------------ modes
    def set_mode(self, mode: int, *, reason: str = "GCS") -> bool:
        """``Sub::set_mode``; False (with the firmware's STATUSTEXT) if refused."""
        if mode == self.mode:
            return True
        try:
            new = Mode(mode)
        except ValueError:
            self.text(M.MAV_SEVERITY_WARNING, f"No such mode {mode}")
            return False
        name = MODE_NAMES[new]
        if new not in SIMULATED_MODES:
            self.text(M.MAV_SEVERITY_WARNING, f"Flight mode change failed {name}")
            return False
        if new in REQUIRES_POSITION and not self.position_ok():
            self.text(M.MAV_SEVERITY_WARNING, f"Mode change failed: {name} requires position")
            return False
        init_ok = not (new in INIT_NEEDS_POSITION and not self.position_ok())
        init_ok = init_ok and not (new == Mode.AUTO and not self.runner.has_items)  # ModeAuto::init
        if not init_ok:
            self.text(M.MAV_SEVERITY_WARNING, f"Flight mode change failed {name}")
            return False
        if self.mode == Mode.AUTO:
            self.runner.pause()
        self.mode = new
        self.mount.set_mode_to_default()  # Sub::exit_mode(Mode*&, Mode*&)
        self._enter_mode(new)
        self.queue_message(M.MAVLINK_MSG_ID_HEARTBEAT)  # gcs().send_message(MSG_HEARTBEAT)
        del reason  # ModeReason: logged only
        return True

    def _enter_mode(self, mode: Mode) -> None:
        self.guidance.reset()
        r = self.readings
        if r is None:
            return
        self.targets.hold_here(r, position_ok=self.position_ok())
        if mode == Mode.GUIDED:
            self.targets.pos_control_start(r, self.params["WPNAV_ACCEL"] / 100.0)  # ModeGuided::init
        elif mode == Mode.AUTO:
            self.targets.speed_m_s = None  # ModeAuto::init: wp_nav.wp_and_spline_init()
            self.runner.begin(r)

    def _start_leg(self, north_m: float, east_m: float, depth_m: float | None, altitude_m: float | None) -> None:
        r = self.readings
        if r is None:
            return
        self.targets.set_destination(north_m, east_m, depth_m, r, self.params["WPNAV_ACCEL"] / 100.0)
        if altitude_m is not None:
            self.targets.alt_m = altitude_m

    def _mission_end(self) -> None:
        """``Sub::exit_mission``: loiter at the stopping point in AUTO, else ALT_HOLD."""
        r = self.readings
        if r is not None and self.position_ok():
            self.targets.hold_here(r, position_ok=True)
            self.targets.leg = None
        else:
            self.set_mode(Mode.ALT_HOLD, reason="mission end")

    def _on_new_mission(self) -> None:
        self.runner.reset()
        if self.mode == Mode.AUTO and not self.runner.has_items:
            self.set_mode(Mode.ALT_HOLD, reason="mission cleared")

    def start_mission(self) -> bool:
        """MAV_CMD_MISSION_START: switch to AUTO (armed checked by the caller)."""
        return self.set_mode(Mode.AUTO, reason="mission start")

    def set_mission_current(self, seq: int) -> bool:
        """Make item ``seq`` current (restart it when in AUTO)."""
        if not 1 <= seq < len(self.mission.items):
            return False
        self.runner.index = seq
        if self.mode == Mode.AUTO:
            self.runner.start(seq, self.readings)
        self.queue_message(M.MAVLINK_MSG_ID_MISSION_CURRENT)
        return True

    def set_leg_speed(self, speed_m_s: float) -> None:
        """DO_CHANGE_SPEED (``wp_nav.set_speed_xy``; below WPNAV_WP_SPEED_MIN 20 cm/s
        ignored): the controller's speed until its next ``wp_and_spline_init``, not the
        WPNAV_SPEED parameter (:attr:`~sim_harness.autopilot.guidance.Targets.speed_m_s`)."""
        if speed_m_s >= 0.2:
            self.targets.speed_m_s = speed_m_s

    def _terrain_available(self) -> bool:
        """Terrain altitudes from the rangefinder: fitted and used by the waypoint controller."""
        return self.rangefinder.enabled and int(self.params["WPNAV_RFND_USE"]) != 0

    def guided_request(self, item: StoredItem) -> bool:
        """A MISSION_ITEM with current 2: :func:`~sim_harness.autopilot.guided_request.do_guided`."""
        return self.readings is not None and do_guided(
            item, in_guided=self.mode == Mode.GUIDED, nav=self.navigation,
            terrain_available=self._terrain_available(),
            start_leg=self._start_leg,
            set_yaw_target=lambda deg, rel, way: self.set_yaw_target(deg, relative=rel, direction=way))

    def set_yaw_target(self, yaw_deg: float, relative: bool, direction: int = 1) -> None:
        """CONDITION_YAW (``ModeAuto::set_auto_yaw_look_at_heading``): an absolute heading, or
        an angle from the attitude target's yaw (the heading held, else the measured one),
        counter-clockwise when ``direction`` < 0; wrapped to 0..360 deg. Its turn rate is
        not simulated (the heading controller's own applies)."""
        if relative:
            r = self.readings
            held = self.targets.yaw_rad
            base = held if held is not None else (r.yaw_rad if r is not None else 0.0)
            yaw_rad = base + math.radians(-yaw_deg if direction < 0 else yaw_deg)
        else:
            yaw_rad = math.radians(yaw_deg)
        self.targets.yaw_rad = yaw_rad % (2.0 * math.pi)

    # ------------------------------------------------------------------ arming
    def arm(self, *, force: bool) -> bool:
        """``AP_Arming_Sub::arm``: pre-arm checks unless forced; False with a PreArm text.

        Home, if set and not locked, moves to the current location; without an EKF origin
        the backup ORIGIN_* is tried (``Sub::ensure_ekf_origin``), else "Compass performance
        degraded". "Arming motors" is a SITL-build text only.
        """
        if self.armed:
            return True
        if not force:
            reason = self.prearm_failure()
            if reason is not None:
                self.text(M.MAV_SEVERITY_CRITICAL, f"PreArm: {reason}")
                return False
        if self.cfg.sitl_build:
            self.text(M.MAV_SEVERITY_INFO, "Arming motors")
        self.armed = True
        r = self.readings
        if self.navigation.home is not None and r is not None:
            self.navigation.home = None  # set_home_to_current_location(false), on the next update
            self.navigation.update_home(r, self.params)
        if self.navigation.origin is None:
            backup = self.navigation.backup_origin(self.params)
            if backup is None:
                self.text(M.MAV_SEVERITY_WARNING, "Backup location parameters are missing or zero")
            elif self.navigation.set_origin(backup):
                self.text(M.MAV_SEVERITY_INFO, "Using backup location")
                self.queue_message(M.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN)
            if self.navigation.origin is None:
                self.text(M.MAV_SEVERITY_WARNING, "Compass performance degraded")
        self._enter_mode(self.mode)
        return True

    def prearm_failure(self) -> str | None:
        """The first failing pre-arm check, or None (the simulated ones)."""
        return self.cfg.arming_fail_reason

    def disarm(self, reason: str = "GCS", *, force: bool = False) -> bool:
        """Disarm (always allowed on a sub); the mission goes back to its first item."""
        del force, reason  # the reason is logged only
        if self.armed:
            self.armed = False
            self.runner.reset()  # AP_Arming_Sub::disarm -> mission.reset()
            if self.cfg.sitl_build:
                self.text(M.MAV_SEVERITY_INFO, "Disarming motors")
        return True

    def set_guided_target(self, north_m: float, east_m: float, depth_m: float, yaw_rad: float | None = None) -> bool:
        """A GUIDED position target given directly (unit tests and benchmarks only; a
        controller sends SET_POSITION_TARGET_*, which lands in the same state). False
        (ignored) unless in GUIDED with readings."""
        r = self.readings
        if self.mode != Mode.GUIDED or r is None:
            return False
        self.targets.set_destination(north_m, east_m, depth_m, r, self.params["WPNAV_ACCEL"] / 100.0)
        if yaw_rad is not None:
            self.targets.yaw_rad = yaw_rad
        return True

    # ------------------------------------------------------------------ mount
    def mount_command(self, command: int, p: tuple[float, ...]) -> int:
        """DO_MOUNT_CONTROL / DO_GIMBAL_MANAGER_PITCHYAW / DO_MOUNT_CONFIGURE."""
        result, warning = self.mount.command(command, p)
        if warning is not None:
            self.text(M.MAV_SEVERITY_WARNING, warning)
        return result

    def _do_command(self, item: StoredItem) -> None:
        """A DO item that passed Sub's alt-frame check (rare with real values, see mission_runner)."""
        if item.command == M.MAV_CMD_DO_CHANGE_SPEED and item.payload[1] > 0:
            self.set_leg_speed(float(item.payload[1]))
        elif item.command == M.MAV_CMD_DO_MOUNT_CONTROL:
            self.mount.set_angle_target(float(item.payload[0]))

    # ------------------------------------------------------------------ messages
    def handle(self, msg: mavlink.MAVLink_message, now_s: float) -> list[mavlink.MAVLink_message]:
        """Handle one received message; returns replies (and anything queued meanwhile)."""
        out = self._inbox.handle(msg, now_s)
        # Texts raised while handling go first, as ArduPilot sends them before the ACK.
        return self._drain() + out

    def command(self, command: int, p: tuple[float, ...], now_s: float) -> int:
        """One COMMAND_LONG/INT: its MAV_RESULT (refused with DENIED by fault injection)."""
        if command in self.faults.refuse_commands:
            return M.MAV_RESULT_DENIED
        return handle_command(self, command, p, now_s)

    # ------------------------------------------------------------------ control loop
    def update(self, now_s: float, dt_s: float, r: SensorReadings
               ) -> tuple[tuple[float, float, float, float], float, list[mavlink.MAVLink_message]]:
        """One control step: (thrust (4,), the tilt servo's body-frame angle (rad, down
        positive), messages to send)."""
        first = self.readings is None
        r = self.rangefinder.filter(r, self.params)
        self.readings = r
        if first:
            self._enter_mode(self.mode)
        if self.navigation.update_home(r, self.params):  # AP_AHRS::set_home sends both to all links
            self.queue_message(M.MAVLINK_MSG_ID_HOME_POSITION)
            self.queue_message(M.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN)
        uses_terrain = self.targets.alt_m is not None and self.mode in (Mode.AUTO, Mode.GUIDED)
        if uses_terrain and self.armed:
            self.failsafes.terrain_status(now_s, r.altitude_m is not None)
        home = self.navigation.home
        home_ne = None if home is None else self.navigation.ned_of(home.lat_deg, home.lon_deg)
        from_home = None if home_ne is None else math.dist(home_ne, (r.north_m, r.east_m))
        self.failsafes.update(now_s, last_pilot_input_s=self.pilot.last_input_s, terrain_mode=uses_terrain,
                              depth_m=r.depth_m, distance_from_home_m=from_home)
        self.mount.update(dt_s, self.pilot.rc8_us)
        if self.armed:
            sticks = self.pilot.sticks
            self.thrust = self.guidance.thrust(self.mode, self.targets, sticks, r, now_s, dt_s)
            if self.mode == Mode.AUTO:
                self.runner.update(r, self.guidance.nav, now_s, self.params["WPNAV_RADIUS"] / 100.0)
            if self.mode == Mode.SURFACE and r.depth_m < -self.params["SURFACE_DEPTH"] / 100.0:
                self.set_mode(Mode.ALT_HOLD, reason="surface complete")  # ModeSurface::run at the surface
        else:
            self.thrust = (0.0, 0.0, 0.0, 0.0)
            if self.mode in (Mode.AUTO, Mode.GUIDED):  # their run(), disarmed: wp_and_spline_init()
                self.targets.speed_m_s = None
        servo_pitch = self.mount.servo_output_rad(r.pitch_rad)
        self.servo_tilt_rad = self.mount_limits.clamp(-servo_pitch)
        out = self._drain()
        out.extend(self.mission.update(now_s))
        due = self.telemetry.due(now_s)
        if due:
            snap = self.snapshot(now_s)
            out.extend(m for m in (build_message(msg_id, snap) for msg_id in due) if m is not None)
        return self.thrust, self.servo_tilt_rad, out

    def snapshot(self, now_s: float) -> TelemetrySnapshot:
        """What telemetry reports now (:func:`~sim_harness.autopilot.status.snapshot`)."""
        return snapshot(self, now_s)
