"""ArduSub 4.5's failsafes that the simulator models (ArduSub/failsafe.cpp, fence.cpp).

- **GCS** (``Sub::failsafe_gcs_check``, 3.3 Hz): the GCS counts as seen on any HEARTBEAT
  whose *system* id is SYSID_MYGCS, whatever its component or type
  (``GCS_MAVLINK::handle_heartbeat``), and on accepted MANUAL_CONTROL / RC override. Never
  seen -> no failsafe. Timeout fixed at 2.5 s (``FS_GCS_TIMEOUT_MS``, ArduSub/defines.h; the
  FS_GCS_TIMEOUT parameter is 4.6). "MYGCS: N, heartbeat lost" every 30 s, armed or not;
  the action only when armed and only once: FS_GCS_ENABLE 1 warn, 2 disarm (default),
  3 ALT_HOLD and 4 SURFACE, each disarming if the mode change fails. Cleared silently
  when the GCS is seen again; the mode is not restored.
- **Pilot input** (``Sub::failsafe_pilot_input_check``, 50 Hz; real hardware: ArduPilot's
  SITL build compiles it out, ``AutopilotConfig.sitl_build``): FS_PILOT_TIMEOUT (3 s)
  after the last accepted pilot input, *armed or not*, once: "Lost manual control",
  sticks to neutral, disarm if FS_PILOT_INPUT is 2 (default). Latched until pilot input
  returns. The clock starts at boot, so a sub with no joystick is in this failsafe from
  3 s after boot.
- **Fence** (``Sub::fence_check``, 1 Hz, armed): a breach of the depth limit
  (FENCE_TYPE bit ALT_MIN, FENCE_ALT_MIN) or the circle is only *recorded*: the response
  code is commented out in 4.5; SYS_STATUS shows it.
- **Terrain** (``failsafe_terrain_check``): rangefinder-following in AUTO or GUIDED
  failing for more than 1 s (``FS_TERRAIN_TIMEOUT_MS``): "Failsafe terrain triggered",
  FS_TERRAIN_ENAB 0 disarm (default), 1 POSHOLD else ALT_HOLD, 2 SURFACE.
  (``Auto_TerrainRecover`` needs a rangefinder reporting out of range, not a dropout; not
  modelled.)
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass

from pymavlink.dialects.v20 import ardupilotmega as mavlink

M = mavlink
GCS_TIMEOUT_S = 2.5  # ArduSub/defines.h FS_GCS_TIMEOUT_MS
GCS_CHECK_PERIOD_S = 1.0 / 3.3  # three_hz_loop
GCS_WARN_PERIOD_S = 30.0
TERRAIN_TIMEOUT_S = 1.0  # FS_TERRAIN_TIMEOUT_MS
FENCE_CHECK_PERIOD_S = 1.0
FENCE_TYPE_ALT_MIN = 8
FENCE_TYPE_CIRCLE = 2


@dataclass(frozen=True)
class FailsafeActions:
    """What the failsafes may do to the vehicle."""

    armed: Callable[[], bool]
    disarm: Callable[[str], None]
    set_mode: Callable[[int, str], bool]
    text: Callable[[int, str], None]
    neutral_controls: Callable[[], None]


class Failsafes:
    """The failsafe state machines; :meth:`update` runs them on the simulated clock."""

    def __init__(self, params: Mapping[str, float], actions: FailsafeActions, *, sitl_build: bool) -> None:
        self._params = params
        self._act = actions
        self._sitl_build = sitl_build
        self.gcs_last_seen_s: float | None = None
        self.gcs = False
        self.pilot_input = False
        self.terrain = False
        self.fence_breaches = 0
        self._next_gcs_check_s = 0.0
        self._next_fence_check_s = 0.0
        self._last_gcs_warn_s = -math.inf
        self._terrain_first_failure_s: float | None = None
        self._terrain_last_failure_s: float | None = None

    @property
    def any_triggered(self) -> bool:
        """``Sub::any_failsafe_triggered`` in 4.5: pilot input, GCS, terrain (battery and EKF
        are not simulated)."""
        return self.pilot_input or self.gcs or self.terrain

    def gcs_seen(self, now_s: float) -> None:
        """``gcs().sysid_myggcs_seen``."""
        self.gcs_last_seen_s = now_s

    def terrain_status(self, now_s: float, data_ok: bool) -> None:
        """``failsafe_terrain_set_status``: record a rangefinder-following failure or success."""
        if not data_ok:
            self._terrain_last_failure_s = now_s
            if self._terrain_first_failure_s is None:
                self._terrain_first_failure_s = now_s
        elif self._terrain_last_failure_s is not None and now_s - self._terrain_last_failure_s > 0.1:
            self._terrain_first_failure_s = self._terrain_last_failure_s = None

    def terrain_event(self) -> None:
        """``failsafe_terrain_on_event`` -> ``failsafe_terrain_act`` (no recovery modelled)."""
        self.terrain = True
        act = int(self._params["FS_TERRAIN_ENAB"])
        if act == 1:
            if not self._act.set_mode(16, "terrain failsafe"):  # POSHOLD
                self._act.set_mode(2, "terrain failsafe")  # ALT_HOLD
        elif act == 2:
            self._act.set_mode(9, "terrain failsafe")  # SURFACE
        else:
            self._act.disarm("terrain failsafe")

    def update(self, now_s: float, *, last_pilot_input_s: float | None, terrain_mode: bool,
               depth_m: float, distance_from_home_m: float | None) -> None:
        """Run the checks due at ``now_s``."""
        self._pilot_input_check(now_s, last_pilot_input_s)
        if now_s + 1e-9 >= self._next_gcs_check_s:
            self._next_gcs_check_s = now_s + GCS_CHECK_PERIOD_S
            self._gcs_check(now_s)
            self._terrain_check(terrain_mode)
        if now_s + 1e-9 >= self._next_fence_check_s:
            self._next_fence_check_s = now_s + FENCE_CHECK_PERIOD_S
            self._fence_check(depth_m, distance_from_home_m)

    def _pilot_input_check(self, now_s: float, last_s: float | None) -> None:
        p = self._params
        if self._sitl_build:
            return  # #if CONFIG_HAL_BOARD != HAL_BOARD_SITL
        if int(p["FS_PILOT_INPUT"]) == 0:
            self.pilot_input = False
            return
        if now_s < (last_s if last_s is not None else 0.0) + p["FS_PILOT_TIMEOUT"]:
            self.pilot_input = False
            return
        if self.pilot_input:
            return  # only act once
        self.pilot_input = True
        self._act.text(M.MAV_SEVERITY_CRITICAL, "Lost manual control")
        self._act.neutral_controls()
        if int(p["FS_PILOT_INPUT"]) == 2:
            self._act.disarm("pilot input failsafe")

    def _gcs_check(self, now_s: float) -> None:
        p = self._params
        action = int(p["FS_GCS_ENABLE"])
        if action == 0 or self.gcs_last_seen_s is None:
            return
        if now_s - self.gcs_last_seen_s < GCS_TIMEOUT_S:
            self.gcs = False
            return
        if now_s - self._last_gcs_warn_s > GCS_WARN_PERIOD_S:
            self._last_gcs_warn_s = now_s
            self._act.text(M.MAV_SEVERITY_WARNING, f"MYGCS: {int(p['SYSID_MYGCS'])}, heartbeat lost")
        if self.gcs or not self._act.armed():
            return
        self.gcs = True
        if action == 2:
            self._act.disarm("GCS failsafe")
        elif action == 3:
            if not self._act.set_mode(2, "GCS failsafe"):  # ALT_HOLD
                self._act.disarm("GCS failsafe, depth hold failed")
        elif action == 4:
            if not self._act.set_mode(9, "GCS failsafe"):  # SURFACE
                self._act.disarm("GCS failsafe, surface failed")

    def _terrain_check(self, terrain_mode: bool) -> None:
        first, last = self._terrain_first_failure_s, self._terrain_last_failure_s
        timeout = first is not None and last is not None and last - first > TERRAIN_TIMEOUT_S
        trigger = terrain_mode and timeout
        if trigger != self.terrain:
            if trigger:
                self._act.text(M.MAV_SEVERITY_CRITICAL, "Failsafe terrain triggered")
                self.terrain_event()
            else:
                self.terrain = False

    def _fence_check(self, depth_m: float, distance_from_home_m: float | None) -> None:
        p = self._params
        if not int(p["FENCE_ENABLE"]) or not self._act.armed():
            return
        types = int(p["FENCE_TYPE"])
        breaches = 0
        if types & FENCE_TYPE_ALT_MIN and -depth_m < p["FENCE_ALT_MIN"]:
            breaches |= FENCE_TYPE_ALT_MIN
        if types & FENCE_TYPE_CIRCLE and distance_from_home_m is not None and \
                distance_from_home_m > p["FENCE_RADIUS"]:
            breaches |= FENCE_TYPE_CIRCLE
        self.fence_breaches = breaches  # recorded only (the 4.5 response code is commented out)
