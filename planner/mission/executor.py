"""The mission executor: flies the dual-altitude survey and measures heights on board.

States, in order, each logged with its time (``events.jsonl``, kind ``state``)::

    CONNECT -> PREFLIGHT -> ARM -> DESCEND -> PASS_1 -> ALTITUDE_CHANGE -> PASS_2
            -> FINISH -> COMPLETED

and from any of them ``ABORTED`` with the reason and a message that says why, after the
safe action that fits it (:mod:`planner.mission.safe_actions`).

How it drives the vehicle: every control period a GUIDED position + velocity setpoint
moving along the leg (:mod:`planner.mission.setpoints`, which says why), its depth from
the wanted altitude and the altitude filter's seabed estimate, clamped by
:mod:`planner.mission.safety`, so the clearance and the depth limit hold whatever the
plan asks. If this computer stops, ArduSub stops the vehicle and holds within 3 s on its
own. The plan is also uploaded as an AUTO mission in ArduSub 4.5's frames and verified
by download, so the vehicle holds the survey and the link is proven before arming.

Safety (docs/flying-a-real-sub.md): the executor changes no vehicle parameter, never
sends MANUAL_CONTROL, and refuses to arm where a failsafe caused by this computer would
follow (:mod:`planner.mission.preflight`). A mode change it did not make is the pilot's
(or the vehicle's failsafe, :mod:`planner.mission.watch`): it stops commanding at once,
aborts with ``pilot_took_over`` (or ``vehicle_failsafe``) and never switches back.

Everything time-based reads the injected clock (the simulator's, or the wall clock on a
real vehicle); ``clock.sleep_s`` is the only wait.
"""

from __future__ import annotations

import math
import threading
import traceback
from collections.abc import Callable
from typing import Any, Protocol

from perception.geodesy import LocalOrigin
from planner.errors import MissionAborted, SafetyViolation
from planner.mission.dive_log import DiveLog
from planner.mission.executor_config import DiveResult, ExecutorConfig, SafeAction
from planner.mission.health import HealthCheck
from planner.mission.helm import Helm
from planner.mission.onboard import OnboardPerception
from planner.mission.preflight import PreflightReport
from planner.mission.preflight_steps import PreflightSteps
from planner.mission.run_folder import RunFolder
from planner.mission.safe_actions import SafeActions
from planner.mission.tilt import PlanTilt, TiltSource
from planner.mission.vehicle import Vehicle
from planner.mission.watch import VehicleWatch
from planner.survey.plan import PlanWaypoint, SurveyPass, SurveyPlan
from vehicle_link.errors import CommandRejected, CommandTimeout, MissionTimeout, StateChangeTimeout, VehicleLinkError
from vehicle_link.modes import SubMode

__all__ = ["DiveResult", "ExecutorConfig", "MissionExecutor", "PlanTilt", "SafeAction", "TiltSource"]


class Clock(Protocol):
    """Time source: the simulator's clock or the wall clock."""

    def now_s(self) -> float: ...

    def sleep_s(self, duration_s: float) -> None: ...


class SonarSource(Protocol):
    """What a sonar driver gives: the frames pinged by ``now_s`` not yet returned."""

    def poll(self, now_s: float) -> list[Any]: ...


class MissionExecutor:
    """Flies a :class:`~planner.survey.plan.SurveyPlan` through an ArduSub client.

    ``confirm_arm(report)`` is asked after the pre-flight checks pass and before arming
    (``shadowsurvey run``'s ARM prompt); False aborts with ``arming_not_confirmed``.
    Other parameters as before: the vehicle, a sonar source, the plan, the settings, the
    run folder, the clock the client was given, on-board perception, the tilt source (a
    :class:`PlanTilt` by default) and an ``on_cycle`` hook.
    """

    def __init__(self, client: Vehicle, sonar: SonarSource | None, plan: SurveyPlan, config: ExecutorConfig,
                 run: RunFolder, clock: Clock, onboard: OnboardPerception, *, tilt: TiltSource | None = None,
                 on_cycle: Callable[[MissionExecutor], None] | None = None,
                 confirm_arm: Callable[[PreflightReport], bool] | None = None):
        self.client, self.sonar, self.plan, self.config = client, sonar, plan, config
        self.run, self.clock, self.onboard = run, clock, onboard
        self.tilt = tilt or PlanTilt()
        self.on_cycle = on_cycle
        self.confirm_arm = confirm_arm
        self.result = DiveResult()
        self.watch = VehicleWatch()
        self.safe = SafeActions(client, clock, onboard, config, run, self.result,
                                wait_cycle=lambda: clock.sleep_s(config.control_period_s))
        self.map_origin = LocalOrigin(plan.origin_lat_deg, plan.origin_lon_deg)
        self._link_lost = threading.Event()
        self.helm = Helm(client, clock, onboard, config, run, self.result, abort=self._abort,
                         link_lost=self._link_lost.is_set)
        self._margin_rad = math.nan
        self._pass: SurveyPass | None = None
        self._altitude_target_m = math.nan
        self._health = HealthCheck(config, self.watch, link_down=self._link_down)
        self._log = DiveLog(run)

    # ----------------------------------------------------------------- callbacks
    def on_link_lost(self, *_: Any) -> None:
        """Link callback (I/O thread): only raises a flag; the loop acts on it."""
        self._link_lost.set()

    def on_link_restored(self, *_: Any) -> None:
        """Link callback (I/O thread)."""
        self._link_lost.clear()

    # --------------------------------------------------------------------- run
    def run_dive(self) -> DiveResult:
        """Fly the whole survey; never raises for vehicle trouble or Ctrl-C (see ``result``)."""
        r = self.result
        r.start_s = self.clock.now_s()
        try:
            self._enter("CONNECT")
            self._connect()
            self._enter("PREFLIGHT")
            report = self._preflight()
            self._enter("ARM")
            self._arm(report)
            for k, pass_ in enumerate(self.plan.passes):
                self._enter("DESCEND" if k == 0 else "ALTITUDE_CHANGE")
                self._to_pass_start(pass_)
                self._enter(f"PASS_{k + 1}")
                self._fly_pass(pass_)
            self._enter("FINISH")
            self.safe.do(self.config.finish_action, "survey finished")
            r.status, r.reason, r.message = "completed", "survey flown", "survey flown"
            self._enter("COMPLETED")
        except MissionAborted as exc:
            self._aborted(exc)
        except KeyboardInterrupt:
            self._aborted(self._abort("operator_interrupt", "stopped by the operator (Ctrl-C)"))
        except VehicleLinkError as exc:
            self._aborted(self._abort("command_failed", f"vehicle command failed: {exc}"))
        except Exception as exc:  # a controller bug must still end in the safe action
            self.run.event(self.clock.now_s(), "error", "".join(traceback.format_exception(exc)))
            self._aborted(self._abort("internal_error", f"{type(exc).__name__}: {exc}"))
        r.end_s = self.clock.now_s()
        return r

    def _aborted(self, exc: MissionAborted) -> None:
        r = self.result
        r.status, r.reason, r.message = "aborted", exc.reason, str(exc)
        self.run.event(self.clock.now_s(), "failsafe", str(exc), reason=exc.reason, state=exc.state)
        try:
            self._after_abort(exc)
        except KeyboardInterrupt:
            r.safe_action = f"{r.safe_action} (interrupted)"
            self.run.event(self.clock.now_s(), "failsafe", "safe action interrupted by the operator")
        self._enter("ABORTED", reason=exc.reason)

    def _after_abort(self, exc: MissionAborted) -> None:
        """The safe action that fits the abort: none after the pilot or the vehicle took
        over, after a disarm, or before arming; the link-lost action once the link is back."""
        cfg = self.config
        if exc.reason in ("pilot_took_over", "vehicle_failsafe", "vehicle_disarmed", "no_vehicle",
                          "preflight_refused", "arming_not_confirmed") or not self.client.armed:
            self.result.safe_action = "none: " + ("the pilot or the vehicle has it" if self.client.armed
                                                   else "the vehicle is disarmed")
            self.run.event(self.clock.now_s(), "info", f"no safe action commanded ({self.result.safe_action})")
            return
        action = cfg.link_lost_action if exc.reason == "link_lost" else cfg.abort_action
        if exc.reason == "navigation_lost":
            action = "surface"  # a hold needs the position that was lost
        if self._link_down():
            self.run.event(self.clock.now_s(), "failsafe", "link lost: the vehicle stops within 3 s and holds on its "
                           f"own (GUIDED setpoint timeout); will command '{action}' if the link returns")
            deadline = self.clock.now_s() + cfg.link_restore_wait_s
            while self._link_down() and self.clock.now_s() < deadline:
                self.clock.sleep_s(cfg.control_period_s)
            if self._link_down():
                self.result.safe_action = f"{action} (not sent: link still down)"
                self.run.event(self.clock.now_s(), "failsafe", "link did not return; nothing more can be commanded")
                return
            self.run.event(self.clock.now_s(), "info", "link restored")
        try:
            self.safe.do(action, f"abort: {exc.reason}")
        except (MissionAborted, SafetyViolation, VehicleLinkError, ValueError) as again:
            self.result.safe_action = f"{action} (failed: {again})"
            self.run.event(self.clock.now_s(), "failsafe", f"safe action failed: {again}")

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
        self.client.add_listener(self.watch.listener)
        self.run.event(self.clock.now_s(), "info", "vehicle heartbeat", mode=getattr(heartbeat, "mode_name", None))

    def _preflight(self) -> PreflightReport:
        outcome = PreflightSteps(self.client, self.clock, self.onboard, self.config, self.run, self.plan,
                                 command=self._command, cycle=lambda: self._cycle(fly=False),
                                 abort=self._abort).run()
        r = self.result
        r.preflight, r.mount_frame, r.origin_offset_m = outcome.report.lines(), outcome.mount_frame, outcome.offset_m
        self.helm.offset, self.map_origin = outcome.offset_m, outcome.map_origin
        self.tilt.set_mount_frame(outcome.mount_frame)
        self.onboard.set_mount_frame(outcome.mount_frame)
        return outcome.report

    def _arm(self, report: PreflightReport) -> None:
        if self.confirm_arm is not None and not self.confirm_arm(report):
            raise self._abort("arming_not_confirmed", "arming not confirmed by the operator: nothing armed")
        self._command("mode GUIDED", lambda: self.client.set_mode(SubMode.GUIDED))
        self._command("arm", lambda: self.client.arm())

    # ------------------------------------------------------------------ flying
    def _to_pass_start(self, pass_: SurveyPass) -> None:
        """DESCEND and ALTITUDE_CHANGE: go to the pass's first waypoint at its altitude, settle."""
        self._pass = pass_
        self.onboard.set_mapping(False)
        self.helm.send_tilt(pass_.tilt_rad, force=True)
        start = pass_.waypoints[0]
        self.helm.yaw_rad = _bearing(start, pass_.waypoints[1]) if len(pass_.waypoints) > 1 else math.nan
        self.onboard.expect_vertical_motion(True)  # a commanded depth change: the filter expects motion
        self._go_to(start, pass_)
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
            if math.hypot(wp.north_m - prev.north_m, wp.east_m - prev.east_m) > 0.05:
                self.helm.yaw_rad = _bearing(prev, wp)  # the sonar looks ahead: face along each leg
            run = prev.kind == "lane_start"
            if run:
                self._turn_at(prev, pass_)  # turn in place, so the lead-in is flown looking ahead
            self.onboard.set_mapping(run)
            self._go_to(wp, pass_)
            self.onboard.set_mapping(False)
            self.result.waypoints_reached += 1
            self.run.event(self.clock.now_s(), "waypoint", f"{wp.kind} lane {wp.lane} reached", pass_=pass_.name,
                           north_m=wp.north_m, east_m=wp.east_m)

    def _turn_at(self, wp: PlanWaypoint, pass_: SurveyPass) -> None:
        """Hold ``wp`` until the heading is within ``heading_tolerance_rad`` of the leg's."""
        cfg = self.config
        deadline = self.clock.now_s() + cfg.turn_timeout_s
        self.helm.hold_at(wp)
        while True:
            nav = self.onboard.nav
            off = math.nan if nav is None else (nav.heading_rad - self.helm.yaw_rad + math.pi) % (2 * math.pi) - math.pi
            if math.isfinite(off) and abs(off) <= cfg.heading_tolerance_rad:
                return
            if self.clock.now_s() > deadline:
                self.run.event(self.clock.now_s(), "warning",
                               f"heading not reached in {cfg.turn_timeout_s:.0f} s at lane {wp.lane}; flying on")
                return
            self._cycle(fly=True, altitude_m=pass_.altitude_m)

    def _go_to(self, wp: PlanWaypoint, pass_: SurveyPass) -> None:
        cfg = self.config
        here = self.helm.here()
        start = here if here is not None else (wp.north_m, wp.east_m)
        leg = self.helm.go(start, wp)
        timeout_s = 30.0 + cfg.waypoint_timeout_margin * leg.length_m / cfg.speed_m_s
        deadline = self.clock.now_s() + timeout_s
        while True:
            self._cycle(fly=True, altitude_m=pass_.altitude_m, speed_m_s=cfg.speed_m_s)
            here = self.helm.here()
            if leg.finished and here is not None and \
                    math.hypot(wp.north_m - here[0], wp.east_m - here[1]) < cfg.acceptance_radius_m:
                return
            if self.clock.now_s() > deadline:
                raise self._abort("waypoint_timeout", f"waypoint ({wp.north_m:.1f}, {wp.east_m:.1f}) not reached "
                                  f"in {timeout_s:.0f} s")

    def _settle(self, altitude_m: float, hold: PlanWaypoint) -> None:
        cfg = self.config
        deadline = self.clock.now_s() + cfg.settle_timeout_s
        since = math.nan
        self.helm.hold_at(hold)
        while True:
            self._cycle(fly=True, altitude_m=altitude_m)
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
                raise self._abort("altitude_not_settled", f"altitude {alt:.2f} m did not settle at {altitude_m:.2f} m "
                                  f"in {cfg.settle_timeout_s:.0f} s")

    # ------------------------------------------------------------ control cycle
    def _cycle(self, *, fly: bool, altitude_m: float = math.nan, speed_m_s: float = 0.0) -> None:
        """One control period; ``speed_m_s`` is the speed the vehicle is asked to fly (the
        pitch loop's prediction)."""
        cfg = self.config
        self.clock.sleep_s(cfg.control_period_s)
        now = self.clock.now_s()
        if self._link_lost.is_set():
            raise self._abort("link_lost", "lost the vehicle's heartbeat")
        self.onboard.drain()
        if self.sonar is not None:
            self.onboard.process_frames(self.sonar.poll(now))
        if fly:
            trouble = self._health.check(now, self.client, self.onboard)
            if trouble is not None:
                raise self._abort(trouble.reason, trouble.message)
            self._track_limits(now)
            self._altitude_target_m = altitude_m
            self.helm.send_setpoint(now, altitude_m)
            if self._pass is not None:
                tilt, margin = self.tilt.tilt_command(now_s=now, pass_=self._pass, onboard=self.onboard,
                                                      current_tilt_rad=self.helm.tilt_cmd_rad, speed_m_s=speed_m_s)
                self._margin_rad = margin
                self.helm.send_tilt(tilt)
        self._log.record(now, self.onboard, mode=self.client.mode, armed=self.client.armed,
                         tilt_cmd_rad=self.helm.tilt_cmd_rad, margin_rad=self._margin_rad,
                         altitude_target_m=self._altitude_target_m)
        if self.on_cycle is not None:
            self.on_cycle(self)

    def _track_limits(self, now: float) -> None:
        """The smallest altitude and the depth-limit violations the estimates show."""
        alt, _ = self.onboard.altitude(now)
        depth, _ = self.onboard.depth(now)
        if math.isfinite(alt):
            self.result.min_clearance_seen_m = min(self.result.min_clearance_seen_m, alt)
        if math.isfinite(depth) and depth > self.config.safety.depth_limit_m:
            self.result.depth_limit_violations += 1

    def _link_down(self) -> bool:
        """True when the link says it is lost, or the vehicle's heartbeat has gone quiet."""
        if self._link_lost.is_set():
            return True
        health = self.client.link_health()
        return health.up is False or (health.silence_s is not None and health.silence_s > self.config.telemetry_stale_s)


def _bearing(a: PlanWaypoint, b: PlanWaypoint) -> float:
    """Compass bearing from ``a`` to ``b``, rad in [0, 2 pi)."""
    return math.atan2(b.east_m - a.east_m, b.north_m - a.north_m) % (2 * math.pi)
