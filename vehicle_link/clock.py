"""Injected clocks: everything time-based in vehicle_link reads one of these.

Timeouts, heartbeat periods and link-loss detection are measured on ``Clock.now_s()``;
waiting loops wake at least every ``POLL_S`` of *real* time to re-read the clock, so a
clock that runs faster than real time (the simulator's) shortens every wait.
"""

from __future__ import annotations

import time
from typing import Protocol

from vehicle_link.errors import ConfigError


class Clock(Protocol):
    """What vehicle_link needs of a clock."""

    def now_s(self) -> float:
        """Current time, seconds (monotonic, arbitrary origin)."""
        ...

    def sleep_s(self, dt_s: float) -> None:
        """Block for ``dt_s`` seconds of this clock's time."""
        ...


class WallClock:
    """Real time: ``time.monotonic`` and ``time.sleep``."""

    def now_s(self) -> float:
        return time.monotonic()

    def sleep_s(self, dt_s: float) -> None:
        if dt_s > 0.0:
            time.sleep(dt_s)


class ScaledClock:
    """Real time sped up by a constant factor (``speed=10`` runs ten times faster).

    Parameters
    ----------
    speed : float
        Clock seconds per real second, > 0.
    """

    def __init__(self, speed: float) -> None:
        if not speed > 0.0:
            raise ConfigError(f"ScaledClock speed must be > 0, got {speed!r}")
        self.speed = float(speed)
        self._t0_real_s = time.monotonic()

    def now_s(self) -> float:
        return (time.monotonic() - self._t0_real_s) * self.speed

    def sleep_s(self, dt_s: float) -> None:
        if dt_s > 0.0:
            time.sleep(dt_s / self.speed)
