"""While flying: is the vehicle still ours to command? (checked every control cycle)

In this order, each with the abort reason it gives:

- ``vehicle_disarmed``: the heartbeat shows it disarmed (a failsafe, or the pilot's
  disarm button); the STATUSTEXTs of the last seconds go into the message.
- ``vehicle_failsafe`` / ``pilot_took_over``: a mode other than GUIDED that this computer
  did not ask for: the vehicle's (a failsafe STATUSTEXT just before, see
  :mod:`planner.mission.watch`) or the pilot's. The executor then stops commanding.
- ``navigation_lost``: EKF_STATUS_REPORT without a horizontal position for
  ``navigation_lost_s`` (the DVL lost bottom lock).
- ``link_lost`` / ``stale_telemetry``: no depth, or no navigation, for ``telemetry_stale_s``.
- ``altimeter_failure``: no accepted altimeter reading for ``altimeter_timeout_s``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from planner.mission.executor_config import ExecutorConfig
from planner.mission.onboard import OnboardPerception
from planner.mission.vehicle import Vehicle
from planner.mission.watch import VehicleWatch
from vehicle_link.modes import SubMode, mode_name
from vehicle_link.telemetry import EkfStatus


@dataclass(frozen=True)
class Trouble:
    """Why the dive must end: an abort reason code and a message that says why."""

    reason: str
    message: str


class HealthCheck:
    """The checks of the module docstring; keeps when the navigation was lost."""

    def __init__(self, config: ExecutorConfig, watch: VehicleWatch, *, link_down: Callable[[], bool]) -> None:
        self._cfg = config
        self._watch = watch
        self._link_down = link_down
        self._nav_lost_since = math.nan

    def check(self, now: float, client: Vehicle, onboard: OnboardPerception) -> Trouble | None:
        """The first trouble found at ``now``, or None."""
        cfg = self._cfg
        if client.armed is False:
            texts = "; ".join(self._watch.texts_since(now - 5.0)) or "no message from the vehicle"
            return Trouble("vehicle_disarmed", f"the vehicle disarmed ({texts})")
        mode = client.mode
        if mode is not None and mode != SubMode.GUIDED:
            failsafe = self._watch.failsafe_text(now)
            if failsafe is not None:
                return Trouble("vehicle_failsafe", f"the vehicle's failsafe switched it to {mode_name(mode)} "
                               f"({failsafe}); not commanded further")
            return Trouble("pilot_took_over", f"pilot took over: the vehicle is in {mode_name(mode)}, a mode change "
                           "this computer did not make; not commanded further")
        ekf = client.latest(EkfStatus)
        if ekf is not None and not ekf.horizontal_position_ok:
            self._nav_lost_since = now if math.isnan(self._nav_lost_since) else self._nav_lost_since
            if now - self._nav_lost_since >= cfg.navigation_lost_s:
                return Trouble("navigation_lost", f"the vehicle has had no horizontal position for "
                               f"{now - self._nav_lost_since:.1f} s (DVL bottom lock lost?)")
        else:
            self._nav_lost_since = math.nan
        status = onboard.status()
        if now - status.last_depth_s > cfg.telemetry_stale_s:
            if self._link_down():
                return Trouble("link_lost", f"no heartbeat and no depth for {now - status.last_depth_s:.1f} s")
            return Trouble("stale_telemetry", f"no depth for {now - status.last_depth_s:.1f} s")
        if status.nav is None or now - status.nav.time_s > cfg.telemetry_stale_s:
            return Trouble("stale_telemetry", "no navigation telemetry")
        if now - status.last_altimeter_s > cfg.altimeter_timeout_s:
            return Trouble("altimeter_failure",
                           f"no valid altimeter reading for {now - status.last_altimeter_s:.1f} s")
        return None
