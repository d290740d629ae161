"""The helm: what goes to the vehicle each control period - the GUIDED setpoint and the tilt.

The setpoint is a position + velocity moving along the current leg
(:mod:`planner.mission.setpoints`), its depth ramped toward the safe depth for the
wanted altitude (:func:`planner.mission.safety.safe_depth_for_altitude` on the altitude
filter's seabed estimate; over a rising seabed on where it will be ``slope_lead_s`` ahead,
:mod:`planner.mission.seabed_slope`), in the vehicle's EKF frame (the plan's waypoints shifted by
the plan origin's offset in it). The tilt goes out when it changes (at most once a
control period) and every 2 s, without waiting for its acknowledgement; it is in the
mount's own frame (the tilt source knows which).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from planner.errors import MissionAborted, SafetyViolation
from planner.mission.executor_config import DiveResult, ExecutorConfig
from planner.mission.onboard import OnboardPerception
from planner.mission.run_folder import RunFolder
from planner.mission.safety import safe_depth_for_altitude
from planner.mission.seabed_slope import SeabedSlope
from planner.mission.setpoints import DepthRamp, LegSetpoint, Setpoint
from planner.mission.vehicle import Vehicle
from planner.survey.plan import PlanWaypoint
from vehicle_link.errors import CommandRejected, CommandTimeout


class Helm:
    """Setpoint and tilt state; ``abort`` builds the MissionAborted to raise."""

    def __init__(self, client: Vehicle, clock: Any, onboard: OnboardPerception, config: ExecutorConfig,
                 run: RunFolder, result: DiveResult, *, abort: Callable[[str, str], MissionAborted],
                 link_lost: Callable[[], bool]) -> None:
        self.client, self.clock, self.onboard, self.config = client, clock, onboard, config
        self.run, self.result = run, result
        self._abort, self._link_lost = abort, link_lost
        self.offset = (0.0, 0.0)  # the plan's origin in the vehicle's EKF frame, m
        self.leg: LegSetpoint | None = None
        self.yaw_rad = math.nan
        self.tilt_cmd_rad = math.nan
        self._depth_ramp: DepthRamp | None = None
        self._tilt_sent_s = -math.inf
        self.slope = SeabedSlope()

    def here(self) -> tuple[float, float] | None:
        """The vehicle's position in the plan's frame, m (None before any)."""
        nav = self.onboard.nav
        if nav is None or not math.isfinite(nav.north_m):
            return None
        return nav.north_m - self.offset[0], nav.east_m - self.offset[1]

    def go(self, start: tuple[float, float], wp: PlanWaypoint) -> LegSetpoint:
        """A new leg from ``start`` to ``wp`` at the survey speed."""
        cfg = self.config
        self.leg = LegSetpoint(start, (wp.north_m, wp.east_m), speed_m_s=cfg.speed_m_s, accel_m_s2=cfg.accel_m_s2,
                               lead_limit_m=cfg.lead_limit_m)
        self.onboard.ground_track_changed()
        return self.leg

    def hold_at(self, wp: PlanWaypoint) -> None:
        """A setpoint resting at ``wp``."""
        self.leg = LegSetpoint((wp.north_m, wp.east_m), (wp.north_m, wp.east_m), speed_m_s=0.0,
                               accel_m_s2=self.config.accel_m_s2, lead_limit_m=self.config.lead_limit_m)
        self.onboard.ground_track_changed()

    def send_setpoint(self, now: float, altitude_m: float) -> None:
        """The leg's moving setpoint with its safe depth, as GUIDED posvel."""
        cfg = self.config
        if self.leg is None:
            return
        sp: Setpoint = self.leg.advance(cfg.control_period_s, self.here())
        seabed, seabed_std = self.onboard.seabed_depth(now)
        depth_now, _ = self.onboard.depth(now)
        if self._depth_ramp is None:
            self._depth_ramp = DepthRamp(max(depth_now, 0.0) if math.isfinite(depth_now) else 0.0,
                                         vertical_speed_m_s=cfg.vertical_speed_m_s,
                                         accel_m_s2=cfg.vertical_accel_m_s2)
        if math.isfinite(seabed) and math.isfinite(seabed_std) and seabed_std <= cfg.max_seabed_std_m:
            here = self.here()
            if here is not None:
                self.slope.add(here[0], here[1], seabed, seabed_std)
            # A seabed rising ahead is met in time (shallower only: one falling away is
            # followed late, which errs high).
            rise = self.slope.rise_ahead_m(sp.vel_north_m_s, sp.vel_east_m_s, cfg.slope_lead_s)
            try:
                cmd = safe_depth_for_altitude(altitude_m, seabed_depth_m=seabed - rise, seabed_std_m=seabed_std,
                                              limits=cfg.safety)
            except SafetyViolation as exc:
                raise self._abort(exc.reason, str(exc)) from exc
            self.result.commands_clamped += cmd.clamped_by is not None
            wanted = cmd.depth_m
        else:
            wanted = self._depth_ramp.depth_m  # no usable estimate now: keep the last depth
        depth, vz = self._depth_ramp.advance(cfg.control_period_s, wanted)
        yaw = None if math.isnan(self.yaw_rad) else self.yaw_rad
        try:
            self.client.goto_posvel(sp.north_m + self.offset[0], sp.east_m + self.offset[1], depth,
                                    sp.vel_north_m_s, sp.vel_east_m_s, vz, yaw_rad=yaw)
        except ValueError as exc:  # the link's own limits refused it
            raise self._abort("safety_refused", f"target refused by the link's limits: {exc}") from exc

    def send_tilt(self, tilt_rad: float, *, force: bool = False) -> None:
        """The mount's tilt when it changed, every 2 s, or now (``force``, waiting for the ack)."""
        now = self.clock.now_s()
        changed = not math.isfinite(self.tilt_cmd_rad) or abs(tilt_rad - self.tilt_cmd_rad) > math.radians(0.2)
        # At most one tilt per control period (with slack for float sums), and every 2 s.
        if force or (changed and now - self._tilt_sent_s >= 0.5 * self.config.control_period_s) \
                or now - self._tilt_sent_s > 2.0:
            self._tilt_sent_s = now
            try:
                self.client.set_mount_tilt(tilt_rad, wait_ack=force)  # the loop never waits for an ack
            except (CommandTimeout, CommandRejected) as exc:
                self.run.event(now, "warning", f"mount tilt not acknowledged: {exc}")
                if self._link_lost():
                    raise self._abort("link_lost", "lost the vehicle's heartbeat") from exc
                return
            self.tilt_cmd_rad = tilt_rad
