"""The executor's safe actions: surface by a controlled ascent, or hold.

- **surface**: ALT_HOLD, then a depth target (SET_POSITION_TARGET_GLOBAL_INT, z only)
  stepped toward the surface at ``ascent_speed_m_s`` every control period until the
  vehicle is there. ArduSub 4.5 takes a GLOBAL_INT depth in ALT_HOLD whatever its
  navigation (GCS_Mavlink.cpp: ``set_pos_target_z_cm``); its SURFACE mode needs a
  position (``requires_GPS()`` in 4.5), so it would be refused exactly when navigation
  is lost. If this computer stops mid-ascent, the vehicle holds the last depth it was
  given, in ALT_HOLD, for the pilot.
- **hold**: with a position, GUIDED position + velocity at the vehicle's position and
  zero velocity (held with no timeout); without one, ALT_HOLD at the current depth.

Both stop at once when the vehicle is disarmed or changes mode by itself or by the
pilot: a safe action never fights the pilot or switches the mode back.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from planner.mission.executor_config import DiveResult, ExecutorConfig, SafeAction
from planner.mission.onboard import OnboardPerception
from planner.mission.run_folder import RunFolder
from planner.mission.safety import clamp_depth
from planner.mission.vehicle import Vehicle
from vehicle_link.errors import CommandTimeout, StateChangeTimeout
from vehicle_link.modes import SubMode
from vehicle_link.telemetry import EkfStatus

#: The ascent is done when the vehicle is this shallow, m.
SURFACED_DEPTH_M = 0.3


class SafeActions:
    """Commands a safe action through the vehicle and logs what it did and why."""

    def __init__(self, client: Vehicle, clock: Any, onboard: OnboardPerception, config: ExecutorConfig,
                 run: RunFolder, result: DiveResult, *, wait_cycle: Callable[[], None]) -> None:
        self._client = client
        self._clock = clock
        self._onboard = onboard
        self._cfg = config
        self._run = run
        self._result = result
        self._wait_cycle = wait_cycle

    def do(self, action: SafeAction, why: str) -> None:
        """Run ``action`` ("hold" or "surface") for ``why``."""
        self._result.safe_action = action
        if not self._client.armed:
            self._run.event(self._clock.now_s(), "info", f"{action} ({why}): the vehicle is disarmed, nothing to do")
            return
        if action == "surface":
            self.surface(why)
        else:
            self.hold(why)

    def _set_mode(self, mode: SubMode) -> None:
        """The mode change with the executor's retries (a lossy tether loses commands)."""
        for attempt in range(1, self._cfg.command_retries + 1):
            try:
                self._client.set_mode(mode)
                return
            except (CommandTimeout, StateChangeTimeout):
                if attempt == self._cfg.command_retries:
                    raise
                self._run.event(self._clock.now_s(), "warning", f"mode {mode.name}: attempt {attempt} unanswered, "
                                "again")

    def _position_ok(self) -> bool:
        ekf = self._client.latest(EkfStatus)
        return ekf is not None and ekf.horizontal_position_ok

    def surface(self, why: str) -> None:
        """ALT_HOLD and depth targets stepped up to the surface (see the module docstring)."""
        client, cfg, clock = self._client, self._cfg, self._clock
        if client.mode != SubMode.ALT_HOLD:
            self._set_mode(SubMode.ALT_HOLD)
        self._onboard.drain()
        depth, _ = self._onboard.depth(clock.now_s())
        target = depth if math.isfinite(depth) else 0.0
        self._run.event(clock.now_s(), "command", f"surface ({why}): ALT_HOLD, ascent at {cfg.ascent_speed_m_s:g} m/s "
                        f"from {target:.2f} m")
        deadline = clock.now_s() + target / cfg.ascent_speed_m_s + 30.0
        while True:
            target = max(0.0, target - cfg.ascent_speed_m_s * cfg.control_period_s)
            client.set_depth_target(target)
            self._wait_cycle()
            self._onboard.drain()
            depth, _ = self._onboard.depth(clock.now_s())
            if not client.armed or client.mode != SubMode.ALT_HOLD:
                self._run.event(clock.now_s(), "info", "ascent stopped: the vehicle is disarmed or its mode changed "
                                "(not commanded further)")
                return
            if math.isfinite(depth) and depth <= SURFACED_DEPTH_M and target == 0.0:
                self._run.event(clock.now_s(), "info", f"surfaced (depth {depth:.2f} m); holding depth in ALT_HOLD")
                return
            if clock.now_s() > deadline:
                self._run.event(clock.now_s(), "warning", f"ascent not finished in time (depth {depth:.2f} m); "
                                "the last depth target (the surface) stands")
                return

    def hold(self, why: str) -> None:
        """Hold the position (GUIDED posvel, zero velocity), or the depth without a position."""
        client, clock = self._client, self._clock
        now = clock.now_s()
        self._onboard.drain()
        depth, _ = self._onboard.depth(now)
        seabed, seabed_std = self._onboard.seabed_depth(now)
        nav = self._onboard.nav
        if not math.isfinite(depth):
            self.surface(f"{why}; no depth to hold")
            return
        safe = clamp_depth(depth, seabed_depth_m=seabed if math.isfinite(seabed) else None,
                           seabed_std_m=seabed_std if math.isfinite(seabed_std) else 0.0, limits=self._cfg.safety)
        if self._position_ok() and nav is not None and math.isfinite(nav.north_m):
            if client.mode != SubMode.GUIDED:
                self._set_mode(SubMode.GUIDED)
            client.goto_posvel(nav.north_m, nav.east_m, safe.depth_m, 0.0, 0.0)
            self._run.event(now, "command", f"hold at ({nav.north_m:.1f}, {nav.east_m:.1f}) depth {safe.depth_m:.2f} m "
                            f"in GUIDED ({why})")
            return
        if client.mode != SubMode.ALT_HOLD:
            self._set_mode(SubMode.ALT_HOLD)
        client.set_depth_target(safe.depth_m)
        self._run.event(now, "command", f"hold depth {safe.depth_m:.2f} m in ALT_HOLD ({why}; no position)")
