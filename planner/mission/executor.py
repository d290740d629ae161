"""The mission executor: flies the dual-altitude survey and measures heights on board.

States, in order, each logged with its time (``events.jsonl``, kind ``state``)::

    CONNECT -> PREFLIGHT -> ARM -> DESCEND -> PASS_1 -> ALTITUDE_CHANGE -> PASS_2
            -> FINISH -> COMPLETED

and from any of them ``ABORTED`` with the reason, after the configured safe action.

How it drives the vehicle (design note): GUIDED position targets
(``SET_POSITION_TARGET_LOCAL_NED``: north, east, depth), re-sent every
``target_resend_s``. The depth of every target is computed here from the wanted altitude
and the altitude filter's seabed estimate and clamped by :mod:`planner.mission.safety` before it
is sent, so the clearance and the depth limit hold whatever the plan asks. ArduSub 4.5
has no terrain-frame AUTO or GUIDED item, so an AUTO mission could not hold an altitude
above the seabed without trusting the rangefinder blindly; GUIDED also lets the pitch
loop and the altitude change run between waypoints. The plan is still uploaded as an AUTO
mission in PREFLIGHT and verified by download, so the vehicle holds the survey and the
link is proven before arming.

Everything time-based reads the injected clock (the simulator's, or the wall clock on a
real vehicle); ``clock.sleep_s`` is the only wait.
"""

from __future__ import annotations

import math
import threading
import traceback
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Literal, Protocol

from planner.errors import MissionAborted, SafetyViolation
from planner.mission.onboard import OnboardPerception
from planner.mission.run_folder import RunFolder
from planner.mission.safety import SafetyLimits, clamp_depth, safe_depth_for_altitude
from planner.mission.vehicle import Vehicle
from planner.survey.plan import PlanWaypoint, SurveyPass, SurveyPlan
from vehicle_link.errors import (
    CommandRejected,
    CommandTimeout,
    MissionTimeout,
    StateChangeTimeout,
    VehicleLinkError,
)
from vehicle_link.mission import waypoint
from vehicle_link.modes import SubMode
from vehicle_link.telemetry import SysStatus

SafeAction = Literal["hold", "surface"]


class Clock(Protocol):
    """Time source: the simulator's clock or the wall clock."""

    def now_s(self) -> float: ...

    def sleep_s(self, duration_s: float) -> None: ...


class SonarSource(Protocol):
    """What a sonar driver gives: the frames pinged by ``now_s`` not yet returned."""

    def poll(self, now_s: float) -> list[Any]: ...


class TiltSource(Protocol):
    """Chooses the mount tilt each control step (the pitch loop, or a fixed tilt)."""

    def tilt_command(self, *, now_s: float, pass_: SurveyPass, onboard: OnboardPerception,
                     current_tilt_rad: float, speed_m_s: float) -> tuple[float, float]:
        """(tilt to command, smallest shadow margin in rad or NaN)."""
        ...

    def tracking_zone(self, pass_: SurveyPass) -> dict[str, float] | None:
        """The pass's tracking zone for the log (``planner.pitch.control.describe_zone``), or None."""
        ...


class PlanTilt:
    """Holds the plan's tilt for the pass (the baseline the pitch loop is compared with)."""

    def tracking_zone(self, pass_: SurveyPass) -> dict[str, float] | None:
        """No tracking zone: nothing is tracked."""
        del pass_
        return None

    def tilt_command(self, *, now_s: float, pass_: SurveyPass, onboard: OnboardPerception,
                     current_tilt_rad: float, speed_m_s: float) -> tuple[float, float]:
        del now_s, onboard, current_tilt_rad, speed_m_s
        return pass_.tilt_rad, math.nan


@dataclass(frozen=True)
class ExecutorConfig:
    """How the executor flies and when it gives up.

    Attributes
    ----------
    safety : SafetyLimits
        Clearance and depth limit, applied to every depth target.
    control_period_s : float
        Period of the control loop (telemetry, frames, pitch loop, targets), s.
    target_resend_s : float
        GUIDED targets are re-sent this often (ArduSub does not acknowledge them), s.
    acceptance_radius_m : float
        A waypoint counts as reached within this horizontal distance, m.
    settle_tolerance_m, settle_time_s, settle_timeout_s : float
        The altitude counts as settled when the filter's altitude stays within the
        tolerance of the target for ``settle_time_s``; past the timeout the dive aborts.
    waypoint_timeout_margin : float
        A leg may take this many times its length at ``speed_m_s`` (plus 30 s).
    speed_m_s : float
        Expected ground speed (for timeouts and the pitch loop's prediction), m/s.
    link_lost_action, finish_action, abort_action : "hold" or "surface"
        What to do when the link is lost (once it is back, or by the vehicle's own
        failsafe while it is down), at the end of the survey, and on any other abort.
    telemetry_stale_s : float
        Depth or navigation older than this aborts the dive, s.
    altimeter_timeout_s : float
        No accepted altimeter reading for this long aborts the dive, s.
    link_restore_wait_s : float
        After a link loss, how long to wait for the link before giving up commanding, s.
    preflight_timeout_s : float
        Time allowed for the sensors to report healthy before arming, s.
    upload_mission : bool
        Upload and verify the plan as an AUTO mission in PREFLIGHT.
    max_seabed_std_m : float
        No new depth target is derived from a seabed estimate less certain than this (m,
        1-sigma); the vehicle keeps its last one meanwhile.
    heading_tolerance_rad, turn_timeout_s : float
        At each lane start the vehicle turns in place until its heading is this close to
        the lane's (a forward-looking sonar must face along the lane), or the time is up.
    command_retries : int
        How many times a command (mode, arming, parameter, mission upload) that got no
        answer is sent again, each time with the link's own bounded retries; a refusal
        is never retried.
    arm_vehicle_failsafe : bool
        In PREFLIGHT, point ArduSub's GCS failsafe at this controller (``SYSID_MYGCS`` =
        our system id) and set its action (``FS_GCS_ENABLE``: 3 depth hold for "hold",
        4 surface) from ``link_lost_action``, so the vehicle acts on its own when the link
        to the companion computer drops.
    """

    safety: SafetyLimits
    control_period_s: float = 0.2
    target_resend_s: float = 0.5
    acceptance_radius_m: float = 0.25
    settle_tolerance_m: float = 0.03
    settle_time_s: float = 3.0
    settle_timeout_s: float = 90.0
    waypoint_timeout_margin: float = 3.0
    speed_m_s: float = 0.25
    link_lost_action: SafeAction = "surface"
    finish_action: SafeAction = "surface"
    abort_action: SafeAction = "hold"
    telemetry_stale_s: float = 3.0
    altimeter_timeout_s: float = 6.0
    link_restore_wait_s: float = 30.0
    preflight_timeout_s: float = 30.0
    upload_mission: bool = True
    command_retries: int = 3
    heading_tolerance_rad: float = math.radians(5.0)
    max_seabed_std_m: float = 0.3
    turn_timeout_s: float = 30.0
    arm_vehicle_failsafe: bool = True

    def __post_init__(self) -> None:
        for name in ("control_period_s", "target_resend_s", "acceptance_radius_m", "settle_tolerance_m",
                     "speed_m_s", "telemetry_stale_s", "altimeter_timeout_s"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"ExecutorConfig.{name} must be > 0, got {value!r}")
        for name in ("link_lost_action", "finish_action", "abort_action"):
            if getattr(self, name) not in ("hold", "surface"):
                raise ValueError(f"ExecutorConfig.{name} must be 'hold' or 'surface', got {getattr(self, name)!r}")


@dataclass
class DiveResult:
    """What the dive did (the summary's raw material)."""

    status: str = "running"
    reason: str = ""
    state: str = "CONNECT"
    states: list[tuple[float, str]] = field(default_factory=list)
    start_s: float = math.nan
    end_s: float = math.nan
    min_clearance_seen_m: float = math.inf
    depth_limit_violations: int = 0
    commands_clamped: int = 0
    safe_action: str | None = None
    waypoints_reached: int = 0


class MissionExecutor:
    """Flies a :class:`~planner.survey.plan.SurveyPlan` through an ArduSub client.

    Parameters
    ----------
    client : Vehicle
        A connected-or-connectable vehicle (:class:`vehicle_link.client.ArduSubClient`).
    sonar : SonarSource
    plan : SurveyPlan
    config : ExecutorConfig
    run : RunFolder
        Where the event log and the time series go, as the dive goes.
    clock : Clock
        The same clock the client was given.
    onboard : OnboardPerception
    tilt : TiltSource, optional
        The pitch loop; a :class:`PlanTilt` by default.
    on_cycle : callable, optional
        Called at the end of every control cycle with the executor (progress bars,
        tests).
    """

    def __init__(self, client: Vehicle, sonar: SonarSource | None, plan: SurveyPlan, config: ExecutorConfig,
                 run: RunFolder, clock: Clock, onboard: OnboardPerception, *,
                 tilt: TiltSource | None = None,
                 on_cycle: Callable[[MissionExecutor], None] | None = None):
        self.client = client
        self.sonar = sonar
        self.plan = plan
        self.config = config
        self.run = run
        self.clock = clock
        self.onboard = onboard
        self.tilt = tilt or PlanTilt()
        self.on_cycle = on_cycle
        self.result = DiveResult()
        self._link_lost = threading.Event()
        self._last_target_s = -math.inf
        self._tilt_cmd_rad = math.nan
        self._tilt_sent_s = -math.inf
        self._margin_rad = math.nan
        self._pass: SurveyPass | None = None
        self._altitude_target_m = math.nan
        self._yaw_rad = math.nan
        self._nav_log = run.series("nav.csv", ("t_s", "north_m", "east_m", "depth_m", "altitude_m", "heading_deg",
                                               "pitch_deg", "roll_deg", "mode", "armed"))
        self._filter_log = run.series("filter.csv", ("t_s", "depth_est_m", "altitude_est_m", "altitude_std_m",
                                                     "seabed_depth_est_m", "altimeter_m", "rejected_total"))
        self._tilt_log = run.series("tilt.csv", ("t_s", "tilt_cmd_deg", "tilt_meas_deg", "pitch_deg",
                                                 "min_margin_deg", "n_tracked", "altitude_target_m"))

    # ----------------------------------------------------------------- callbacks
    def on_link_lost(self, *_: Any) -> None:
        """Link callback (I/O thread): only raises a flag; the loop acts on it."""
        self._link_lost.set()

    def on_link_restored(self, *_: Any) -> None:
        """Link callback (I/O thread)."""
        self._link_lost.clear()

    # --------------------------------------------------------------------- run
    def run_dive(self) -> DiveResult:
        """Fly the whole survey; never raises for vehicle trouble (see ``result``)."""
        r = self.result
        r.start_s = self.clock.now_s()
        passes = self.plan.passes
        try:
            self._enter("CONNECT")
            self._connect()
            self._enter("PREFLIGHT")
            self._preflight()
            self._enter("ARM")
            self._arm()
            for k, pass_ in enumerate(passes):
                self._enter("DESCEND" if k == 0 else "ALTITUDE_CHANGE")
                self._to_pass_start(pass_)
                self._enter(f"PASS_{k + 1}")
                self._fly_pass(pass_)
            self._enter("FINISH")
            self._safe_action(self.config.finish_action, "survey finished")
            r.status, r.reason = "completed", "survey flown"
            self._enter("COMPLETED")
        except MissionAborted as exc:
            self._aborted(exc)
        except VehicleLinkError as exc:
            self._aborted(self._abort("command_failed", f"vehicle command failed: {exc}"))
        except Exception as exc:  # a controller bug must still end in the safe action
            self.run.event(self.clock.now_s(), "error", "".join(traceback.format_exception(exc)))
            self._aborted(self._abort("internal_error", f"{type(exc).__name__}: {exc}"))
        r.end_s = self.clock.now_s()
        return r

    def _aborted(self, exc: MissionAborted) -> None:
        r = self.result
        r.status, r.reason = "aborted", exc.reason
        self.run.event(self.clock.now_s(), "failsafe", str(exc), reason=exc.reason, state=exc.state)
        action = self.config.link_lost_action if exc.reason == "link_lost" else self.config.abort_action
        self._abort_action(action, exc)
        self._enter("ABORTED", reason=exc.reason)

    # ------------------------------------------------------------------ states
    def _enter(self, state: str, **extra: Any) -> None:
        now = self.clock.now_s()
        self.result.state = state
        self.result.states.append((now, state))
        self.run.event(now, "state", f"enter {state}", state=state, **extra)

    def _abort(self, reason: str, message: str) -> MissionAborted:
        return MissionAborted(f"{self.result.state}: {message}", reason=reason, state=self.result.state)

    def _command(self, what: str, call: Callable[[], Any]) -> Any:
        """Run a vehicle command; a refusal or timeout aborts with the reason."""
        attempts = self.config.command_retries
        for attempt in range(1, attempts + 1):
            try:
                value = call()
                break
            except CommandRejected as exc:
                raise self._abort("command_refused", f"vehicle refused {what}: {exc}") from exc
            except (CommandTimeout, StateChangeTimeout, MissionTimeout) as exc:
                # Every command the executor sends is idempotent: on a lossy link, send again.
                if attempt == attempts or self._link_lost.is_set():
                    raise self._abort("command_timeout", f"no answer to {what}: {exc}") from exc
                self.run.event(self.clock.now_s(), "warning", f"{what}: attempt {attempt} unanswered, again")
            except VehicleLinkError as exc:
                raise self._abort("command_failed", f"{what} failed: {exc}") from exc
        self.run.event(self.clock.now_s(), "command", what)
        return value

    def _connect(self) -> None:
        try:
            heartbeat = self.client.connect()
        except (TimeoutError, OSError) as exc:
            raise self._abort("no_vehicle", f"no vehicle heartbeat: {exc}") from exc
        self.run.event(self.clock.now_s(), "info", "vehicle heartbeat", mode=getattr(heartbeat, "mode_name", None))

    def _preflight(self) -> None:
        cfg = self.config
        deadline = self.clock.now_s() + cfg.preflight_timeout_s
        while True:
            self._cycle(fly=False)
            now = self.clock.now_s()
            alt, _ = self.onboard.altitude(now)
            status = self.client.latest(SysStatus)
            healthy = status is None or _sensors_healthy(status)
            if now - self.onboard.status().last_altimeter_s < cfg.altimeter_timeout_s and math.isfinite(alt) \
                    and healthy:
                break
            if now > deadline:
                why = "altimeter not valid" if not math.isfinite(alt) else "sensors unhealthy"
                raise self._abort("preflight_failed", f"preflight: {why} after {cfg.preflight_timeout_s:.0f} s")
        seabed, seabed_std = self.onboard.seabed_depth(self.clock.now_s())
        self.run.event(self.clock.now_s(), "info", "preflight sensors healthy", seabed_depth_m=seabed,
                       seabed_std_m=seabed_std)
        if cfg.upload_mission:
            items = []
            for pass_ in self.plan.passes:
                for wp in pass_.waypoints:
                    depth = safe_depth_for_altitude(pass_.altitude_m, seabed_depth_m=seabed,
                                                    seabed_std_m=seabed_std, limits=cfg.safety).depth_m
                    items.append(waypoint(wp.lat_deg, wp.lon_deg, depth, acceptance_radius_m=cfg.acceptance_radius_m))
            self._command(f"mission upload ({len(items)} items, verified)", lambda: self.client.upload_mission(items))
        if cfg.arm_vehicle_failsafe:
            our_id = int(self.client.config.source_system)
            action = 3 if cfg.link_lost_action == "hold" else 4
            self._command(f"SYSID_MYGCS {our_id}", lambda: self.client.set_parameter("SYSID_MYGCS", our_id))
            self._command(f"FS_GCS_ENABLE {action}", lambda: self.client.set_parameter("FS_GCS_ENABLE", action))

    def _arm(self) -> None:
        speed_cm_s = round(100.0 * self.config.speed_m_s)
        self._command(f"WPNAV_SPEED {speed_cm_s} cm/s", lambda: self.client.set_parameter("WPNAV_SPEED", speed_cm_s))
        self._command("mode GUIDED", lambda: self.client.set_mode(SubMode.GUIDED))
        self._command("arm", lambda: self.client.arm())

    def _to_pass_start(self, pass_: SurveyPass) -> None:
        """DESCEND and ALTITUDE_CHANGE: go to the pass's first waypoint at its altitude, settle."""
        self._pass = pass_
        self.onboard.set_mapping(False)
        self._send_tilt(pass_.tilt_rad, force=True)
        start = pass_.waypoints[0]
        self._yaw_rad = _bearing(start, pass_.waypoints[1]) if len(pass_.waypoints) > 1 else math.nan
        # A commanded depth change: the altitude filter must expect the vehicle to move.
        self.onboard.expect_vertical_motion(True)
        self._go_to(start, pass_, state_timeout_s=self._leg_timeout(start))
        self._settle(pass_.altitude_m, start)
        self.onboard.expect_vertical_motion(False)

    def _fly_pass(self, pass_: SurveyPass) -> None:
        self._pass = pass_
        zone = self.tilt.tracking_zone(pass_)
        if zone is not None:
            self.run.event(self.clock.now_s(), "tracking_zone",
                           f"{pass_.name}: shadows kept whole from {zone['start_m']:.2f} m ahead "
                           f"({zone['start_over_altitude']:.2f} altitudes) to the window's end "
                           f"{zone['end_ground_m']:.2f} m: {zone['depression_span_deg']:.1f} deg of "
                           f"{zone['aperture_deg']:.1f} deg aperture, margin {zone['margin_deg']:.2f} deg",
                           pass_=pass_.name, **zone)
        for prev, wp in zip(pass_.waypoints[:-1], pass_.waypoints[1:], strict=True):
            # The sonar looks ahead: face along each leg (ArduSub keeps its heading otherwise).
            if math.hypot(wp.north_m - prev.north_m, wp.east_m - prev.east_m) > 0.05:
                self._yaw_rad = _bearing(prev, wp)
            run = prev.kind == "lane_start"
            if run:
                # Turn in place before the run, so that the lead-in is flown looking ahead.
                self._turn_at(prev, pass_)
            self.onboard.set_mapping(run)
            self._go_to(wp, pass_, state_timeout_s=self._leg_timeout(wp))
            self.onboard.set_mapping(False)
            self.result.waypoints_reached += 1
            self.run.event(self.clock.now_s(), "waypoint", f"{wp.kind} lane {wp.lane} reached", pass_=pass_.name,
                           north_m=wp.north_m, east_m=wp.east_m)

    def _turn_at(self, wp: PlanWaypoint, pass_: SurveyPass) -> None:
        """Hold ``wp`` until the heading is within ``heading_tolerance_rad`` of the leg's."""
        cfg = self.config
        deadline = self.clock.now_s() + cfg.turn_timeout_s
        self._last_target_s = -math.inf
        while True:
            nav = self.onboard.nav
            if nav is not None and math.isfinite(nav.heading_rad) and abs(
                    (nav.heading_rad - self._yaw_rad + math.pi) % (2 * math.pi) - math.pi) <= cfg.heading_tolerance_rad:
                return
            if self.clock.now_s() > deadline:
                self.run.event(self.clock.now_s(), "warning",
                               f"heading not reached in {cfg.turn_timeout_s:.0f} s at lane {wp.lane}; flying on")
                return
            self._cycle(fly=True, target=(wp.north_m, wp.east_m), altitude_m=pass_.altitude_m)

    def _leg_timeout(self, wp: PlanWaypoint) -> float:
        nav = self.onboard.nav
        dist = 50.0 if nav is None or not math.isfinite(nav.north_m) else math.hypot(
            wp.north_m - nav.north_m, wp.east_m - nav.east_m)
        return 30.0 + self.config.waypoint_timeout_margin * dist / self.config.speed_m_s

    def _go_to(self, wp: PlanWaypoint, pass_: SurveyPass, *, state_timeout_s: float) -> None:
        deadline = self.clock.now_s() + state_timeout_s
        self._last_target_s = -math.inf
        while True:
            self._cycle(fly=True, target=(wp.north_m, wp.east_m), altitude_m=pass_.altitude_m,
                        speed_m_s=self.config.speed_m_s)
            nav = self.onboard.nav
            if nav is not None and math.hypot(wp.north_m - nav.north_m, wp.east_m - nav.east_m) \
                    < self.config.acceptance_radius_m:
                return
            if self.clock.now_s() > deadline:
                raise self._abort("waypoint_timeout", f"waypoint ({wp.north_m:.1f}, {wp.east_m:.1f}) not reached "
                                  f"in {state_timeout_s:.0f} s")

    def _settle(self, altitude_m: float, hold: PlanWaypoint) -> None:
        cfg = self.config
        deadline = self.clock.now_s() + cfg.settle_timeout_s
        since = math.nan
        self._last_target_s = -math.inf
        while True:
            self._cycle(fly=True, target=(hold.north_m, hold.east_m), altitude_m=altitude_m)
            now = self.clock.now_s()
            alt, _ = self.onboard.altitude(now)
            if math.isfinite(alt) and abs(alt - altitude_m) <= cfg.settle_tolerance_m:
                since = now if math.isnan(since) else since
                if now - since >= cfg.settle_time_s:
                    self.run.event(now, "info", f"altitude settled at {alt:.3f} m", altitude_m=alt)
                    return
            else:
                since = math.nan
            if now > deadline:
                raise self._abort("altitude_not_settled",
                                  f"altitude {alt:.2f} m did not settle at {altitude_m:.2f} m in "
                                  f"{cfg.settle_timeout_s:.0f} s")

    # ------------------------------------------------------------ control cycle
    def _cycle(self, *, fly: bool, target: tuple[float, float] | None = None,
               altitude_m: float = math.nan, speed_m_s: float = 0.0) -> None:
        """One control period; ``speed_m_s`` is the speed the vehicle is asked to fly
        (the leg's speed while going to a waypoint, 0 while turning or holding), for the
        pitch loop's prediction."""
        cfg = self.config
        self.clock.sleep_s(cfg.control_period_s)
        now = self.clock.now_s()
        if self._link_lost.is_set():
            raise self._abort("link_lost", "lost the vehicle's heartbeat")
        self.onboard.drain()
        if self.sonar is not None:
            self.onboard.process_frames(self.sonar.poll(now))
        self._check_health(now, fly=fly)
        if fly and target is not None:
            self._altitude_target_m = altitude_m
            if now - self._last_target_s >= cfg.target_resend_s:
                self._send_target(now, target, altitude_m)
            if self._pass is not None:
                tilt, margin = self.tilt.tilt_command(now_s=now, pass_=self._pass, onboard=self.onboard,
                                                      current_tilt_rad=self._tilt_cmd_rad, speed_m_s=speed_m_s)
                self._margin_rad = margin
                self._send_tilt(tilt)
        self._log(now)
        if self.on_cycle is not None:
            self.on_cycle(self)

    def _check_health(self, now: float, *, fly: bool) -> None:
        cfg = self.config
        if not fly:
            return
        mode = self.client.mode
        if mode is not None and mode != SubMode.GUIDED:
            name = _mode_name(mode)
            raise self._abort("vehicle_mode_change", f"the vehicle switched to {name} on its own (its failsafe or "
                              "the pilot took over)")
        status = self.onboard.status()
        if now - status.last_depth_s > cfg.telemetry_stale_s:
            if self._link_down():
                raise self._abort("link_lost", f"no heartbeat and no depth for {now - status.last_depth_s:.1f} s")
            raise self._abort("stale_telemetry", f"no depth for {now - status.last_depth_s:.1f} s")
        nav = status.nav
        if nav is None or now - nav.time_s > cfg.telemetry_stale_s:
            raise self._abort("stale_telemetry", "no navigation telemetry")
        if now - status.last_altimeter_s > cfg.altimeter_timeout_s:
            raise self._abort("altimeter_failure",
                              f"no valid altimeter reading for {now - status.last_altimeter_s:.1f} s")
        alt, _ = self.onboard.altitude(now)
        depth, _ = self.onboard.depth(now)
        if math.isfinite(alt):
            self.result.min_clearance_seen_m = min(self.result.min_clearance_seen_m, alt)
        if math.isfinite(depth) and depth > cfg.safety.depth_limit_m:
            self.result.depth_limit_violations += 1

    def _send_target(self, now: float, target: tuple[float, float], altitude_m: float) -> None:
        seabed, seabed_std = self.onboard.seabed_depth(now)
        if not (math.isfinite(seabed) and math.isfinite(seabed_std)) or seabed_std > self.config.max_seabed_std_m:
            # No usable estimate right now (a gap in telemetry, or the filter just re-set
            # after a jump): the vehicle keeps its last target; the staleness and settle
            # checks abort if this lasts.
            return
        try:
            cmd = safe_depth_for_altitude(altitude_m, seabed_depth_m=seabed, seabed_std_m=seabed_std,
                                          limits=self.config.safety)
        except SafetyViolation as exc:
            raise self._abort(exc.reason, str(exc)) from exc
        if cmd.clamped_by is not None:
            self.result.commands_clamped += 1
        try:
            yaw = None if math.isnan(self._yaw_rad) else self._yaw_rad
            self.client.goto_local_ned(target[0], target[1], cmd.depth_m, yaw_rad=yaw)
        except ValueError as exc:  # the link's own limits refused it
            raise self._abort("safety_refused", f"target refused by the link's limits: {exc}") from exc
        self._last_target_s = now

    def _send_tilt(self, tilt_rad: float, *, force: bool = False) -> None:
        now = self.clock.now_s()
        changed = not math.isfinite(self._tilt_cmd_rad) or abs(tilt_rad - self._tilt_cmd_rad) > math.radians(0.2)
        # At most one tilt per control period, with slack: the clock's periods are sums of
        # floats, and a strict ">=" skipped every other period's tilt (the mount then lagged
        # the loop by a whole period).
        if force or (changed and now - self._tilt_sent_s >= 0.5 * self.config.control_period_s) \
                or now - self._tilt_sent_s > 2.0:
            self._tilt_sent_s = now
            try:
                # In the control loop the tilt is re-sent every cycle it changes (and every
                # 2 s): a lost ack must not hold the loop up. Pass starts wait for the ack.
                self.client.set_mount_tilt(tilt_rad, wait_ack=force)
            except (CommandTimeout, CommandRejected) as exc:
                # Not worth a dive: the next cycle sends the tilt again. A lost link is
                # caught by its own callback.
                self.run.event(now, "warning", f"mount tilt not acknowledged: {exc}")
                if self._link_lost.is_set():
                    raise self._abort("link_lost", "lost the vehicle's heartbeat") from exc
                return
            self._tilt_cmd_rad = tilt_rad

    def _log(self, now: float) -> None:
        status = self.onboard.status()
        nav = status.nav
        alt, alt_std = self.onboard.altitude(now)
        depth, _ = self.onboard.depth(now)
        seabed, _ = self.onboard.seabed_depth(now)
        mode = self.client.mode
        armed = self.client.armed
        if nav is not None:
            self._nav_log.append(t_s=now, north_m=nav.north_m, east_m=nav.east_m, depth_m=depth,
                                 altitude_m=status.last_altimeter_m, heading_deg=math.degrees(nav.heading_rad),
                                 pitch_deg=math.degrees(nav.pitch_rad), roll_deg=math.degrees(nav.roll_rad),
                                 mode=None if mode is None else int(mode), armed=None if armed is None else int(armed))
        self._filter_log.append(t_s=now, depth_est_m=depth, altitude_est_m=alt, altitude_std_m=alt_std,
                                seabed_depth_est_m=seabed, altimeter_m=status.last_altimeter_m,
                                rejected_total=status.filter_rejected)
        self._tilt_log.append(t_s=now, tilt_cmd_deg=math.degrees(self._tilt_cmd_rad),
                              tilt_meas_deg=math.degrees(nav.tilt_rad) if nav else None,
                              pitch_deg=math.degrees(nav.pitch_rad) if nav else None,
                              min_margin_deg=math.degrees(self._margin_rad),
                              n_tracked=status.measured_last_frame,
                              altitude_target_m=self._altitude_target_m)

    # ------------------------------------------------------------- safe actions
    def _safe_action(self, action: SafeAction, why: str) -> None:
        now = self.clock.now_s()
        self.result.safe_action = action
        if action == "surface":
            self._command(f"mode SURFACE ({why})", lambda: self.client.set_mode(SubMode.SURFACE))
        else:
            if not self.client.armed:
                self.run.event(now, "info", f"hold ({why}): the vehicle is disarmed, nothing to command")
                return
            if self.client.mode != SubMode.GUIDED:
                self._command("mode GUIDED (to hold)", lambda: self.client.set_mode(SubMode.GUIDED))
            nav = self.onboard.nav
            depth, _ = self.onboard.depth(now)
            seabed, seabed_std = self.onboard.seabed_depth(now)
            if nav is None or not math.isfinite(depth):
                self._command(f"mode SURFACE ({why}; no position to hold)",
                              lambda: self.client.set_mode(SubMode.SURFACE))
                return
            safe = clamp_depth(depth, seabed_depth_m=seabed if math.isfinite(seabed) else None,
                               seabed_std_m=seabed_std if math.isfinite(seabed_std) else 0.0,
                               limits=self.config.safety)
            self.client.goto_local_ned(nav.north_m, nav.east_m, safe.depth_m)
            self.run.event(now, "command", f"hold at ({nav.north_m:.1f}, {nav.east_m:.1f}) depth {safe.depth_m:.2f} m "
                           f"({why})")

    def _link_down(self) -> bool:
        """True when the link says it is lost, or the vehicle's heartbeat has gone quiet."""
        if self._link_lost.is_set():
            return True
        health = self.client.link_health()
        return health.up is False or (health.silence_s is not None and health.silence_s > self.config.telemetry_stale_s)

    def _abort_action(self, action: SafeAction, exc: MissionAborted) -> None:
        """The configured action after an abort; waits (bounded) for a lost link first."""
        cfg = self.config
        if exc.reason == "no_vehicle":
            return
        if self._link_down():
            self.run.event(self.clock.now_s(), "failsafe",
                           f"link lost: the vehicle's own failsafe acts; will command '{action}' when it returns")
            deadline = self.clock.now_s() + cfg.link_restore_wait_s
            while self._link_down() and self.clock.now_s() < deadline:
                self.clock.sleep_s(cfg.control_period_s)
            if self._link_down():
                self.result.safe_action = f"{action} (not sent: link still down)"
                self.run.event(self.clock.now_s(), "failsafe", "link did not return; nothing more can be commanded")
                return
            self.run.event(self.clock.now_s(), "info", "link restored")
        try:
            self.onboard.drain()
            self._safe_action(action, f"abort: {exc.reason}")
        except (MissionAborted, SafetyViolation, VehicleLinkError, ValueError) as again:
            self.result.safe_action = f"{action} (failed: {again})"
            self.run.event(self.clock.now_s(), "failsafe", f"safe action failed: {again}")


def _mode_name(mode: int) -> str:
    try:
        return SubMode(mode).name
    except ValueError:
        return f"mode {mode}"


def _bearing(a: PlanWaypoint, b: PlanWaypoint) -> float:
    """Compass bearing from ``a`` to ``b``, rad in [0, 2 pi)."""
    return math.atan2(b.east_m - a.east_m, b.north_m - a.north_m) % (2 * math.pi)


def _sensors_healthy(status: SysStatus) -> bool:
    present = getattr(status, "sensors_present", None)
    health = getattr(status, "sensors_health", None)
    enabled = getattr(status, "sensors_enabled", None)
    if present is None or health is None or enabled is None:
        return True
    return (present & enabled & ~health) == 0

