"""Horizontal targets as ArduSub 4.5 moves them: S-curve legs, position+velocity, velocity.

- **Legs** (GUIDED position targets and AUTO waypoints, ``AC_WPNav``): the target point
  runs along the leg from origin to destination with jerk- and acceleration-limited
  speed (WPNAV_SPEED, WPNAV_ACCEL, WPNAV_JERK), slowing so as to stop at the
  destination. ``AC_WPNav::set_wp_destination`` re-initialises from the *stopping point
  at zero speed* whenever the previous destination has not been reached
  (``if (!is_active() || !_flags.reached_destination) wp_and_spline_init()``): a target
  re-sent before it is reached restarts the leg, so re-sending every half second makes
  the vehicle creep. After the destination is reached a new one starts from it. The
  leg's speed profile is a kinematic stand-in for the S-curve (same limits, same
  restart), not ArduPilot's polynomial; the vertical part is not shaped.
- **Position + velocity** (``ModeGuided::guided_posvel_control_run``): the position
  target advances by the velocity every step; 3 s (``GUIDED_POSVEL_TIMEOUT_MS``) after
  the last message the velocity is zeroed and the position held.
- **Velocity** (``guided_vel_control_run``): 3 s without a message zeroes the velocity;
  the position is not held (``stop_pos_xy_stabilisation``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

GUIDED_POSVEL_TIMEOUT_S = 3.0  # ArduSub/mode_guided.cpp GUIDED_POSVEL_TIMEOUT_MS


@dataclass(frozen=True)
class LegLimits:
    """Along-track limits (m/s, m/s/s, m/s/s/s) from WPNAV_SPEED, WPNAV_ACCEL, WPNAV_JERK."""

    speed_m_s: float
    accel_m_s2: float
    jerk_m_s3: float


class Leg:
    """One S-curve-like leg from ``origin`` to ``destination`` (north, east metres)."""

    def __init__(self, origin: tuple[float, float], destination: tuple[float, float],
                 speed_m_s: float = 0.0) -> None:
        self.origin = origin
        self.destination = destination
        dn, de = destination[0] - origin[0], destination[1] - origin[1]
        self.length_m = math.hypot(dn, de)
        self.unit = (dn / self.length_m, de / self.length_m) if self.length_m > 1e-9 else (0.0, 0.0)
        self.s_m = 0.0
        self.speed_m_s = speed_m_s
        self.accel_m_s2 = 0.0
        self.reached = self.length_m <= 1e-9

    def advance(self, dt_s: float, limits: LegLimits) -> None:
        """Move the target point on by one step."""
        if self.reached:
            return
        remaining = self.length_m - self.s_m
        # Fastest speed from which the jerk and acceleration limits still stop at the end.
        stop_speed = min((remaining * remaining * limits.jerk_m_s3) ** (1.0 / 3.0),
                         math.sqrt(2.0 * limits.accel_m_s2 * remaining))
        wanted = min(limits.speed_m_s, stop_speed)
        accel_wanted = max(-limits.accel_m_s2, min(limits.accel_m_s2, (wanted - self.speed_m_s) / max(dt_s, 1e-3)))
        step = limits.jerk_m_s3 * dt_s
        if wanted < self.speed_m_s:
            self.accel_m_s2 = accel_wanted  # braking follows the stopping curve
        else:
            self.accel_m_s2 = max(min(accel_wanted, self.accel_m_s2 + step), self.accel_m_s2 - step)
        self.speed_m_s = max(0.0, min(limits.speed_m_s, self.speed_m_s + self.accel_m_s2 * dt_s))
        self.s_m += self.speed_m_s * dt_s
        if self.s_m >= self.length_m - 1e-4:
            self.s_m = self.length_m
            self.speed_m_s = self.accel_m_s2 = 0.0
            self.reached = True

    def point(self) -> tuple[float, float]:
        """The target point now (north, east)."""
        return (self.origin[0] + self.unit[0] * self.s_m, self.origin[1] + self.unit[1] * self.s_m)

    def velocity(self) -> tuple[float, float]:
        """The target point's velocity (north, east m/s)."""
        return (self.unit[0] * self.speed_m_s, self.unit[1] * self.speed_m_s)


def stopping_point(north_m: float, east_m: float, vel_north_m_s: float, vel_east_m_s: float,
                   accel_m_s2: float) -> tuple[float, float]:
    """Where the vehicle stops braking at ``accel_m_s2`` (``AC_PosControl::get_stopping_point_xy_cm``)."""
    speed = math.hypot(vel_north_m_s, vel_east_m_s)
    if speed < 1e-6:
        return (north_m, east_m)
    d = speed * speed / (2.0 * accel_m_s2)
    return (north_m + vel_north_m_s / speed * d, east_m + vel_east_m_s / speed * d)


@dataclass
class PosVel:
    """A GUIDED position+velocity target (NED, metres and m/s) and when it was last set."""

    north_m: float
    east_m: float
    depth_m: float
    vel_north_m_s: float
    vel_east_m_s: float
    vel_down_m_s: float
    set_s: float

    def advance(self, now_s: float, dt_s: float) -> None:
        """``guided_posvel_control_run``: zero the velocity after the timeout, integrate."""
        if now_s - self.set_s > GUIDED_POSVEL_TIMEOUT_S:
            self.vel_north_m_s = self.vel_east_m_s = self.vel_down_m_s = 0.0
        self.north_m += self.vel_north_m_s * dt_s
        self.east_m += self.vel_east_m_s * dt_s
        self.depth_m += self.vel_down_m_s * dt_s


@dataclass
class Velocity:
    """A GUIDED velocity target (NED m/s) and when it was last set."""

    north_m_s: float
    east_m_s: float
    down_m_s: float
    set_s: float

    def current(self, now_s: float) -> tuple[float, float, float]:
        """``guided_vel_control_run``: zero after the timeout."""
        if now_s - self.set_s > GUIDED_POSVEL_TIMEOUT_S:
            return (0.0, 0.0, 0.0)
        return (self.north_m_s, self.east_m_s, self.down_m_s)
