"""The GUIDED setpoints the executor streams: a point moving along the leg, a depth ramp.

Design (why posvel, streamed): ArduSub 4.5 restarts its S-curve from the stopping point
at zero speed whenever a *position* target arrives before the previous one was reached
(``AC_WPNav::set_wp_destination``), so re-sent position targets make it creep, and one
target per waypoint stops the vehicle at every waypoint and leaves it flying on by
itself when the companion dies. A *position + velocity* target (Guided_PosVel,
``ModeGuided::guided_posvel_control_run``) is tracked as it is, every update, with the
velocity as feed-forward; and 3 s after the last update ArduSub zeroes the velocity and
holds the position the target had reached. So the executor streams, every control
period, a setpoint that moves along the leg at the survey speed: the vehicle flies the
lane without stops, the pitch loop and the depth follow as they go, and if this computer
dies or hangs the vehicle stops and holds on its own within 3 s, up to 3 s times the
speed past its last setpoint.

:class:`LegSetpoint` is pure arithmetic on NED metres: speed ramps by ``accel_m_s2`` from
rest at the leg's start down to rest at its end, and never gets more than
``lead_limit_m`` ahead of the vehicle along the leg (a vehicle held back by a current is
not left behind by its own setpoint). :class:`DepthRamp` moves the depth setpoint toward
its target at most at ``vertical_speed_m_s``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class Setpoint:
    """One GUIDED posvel setpoint (NED metres and m/s; depth down positive)."""

    north_m: float
    east_m: float
    vel_north_m_s: float
    vel_east_m_s: float


class LegSetpoint:
    """A setpoint moving from ``start`` to ``end`` (north, east metres)."""

    def __init__(self, start: tuple[float, float], end: tuple[float, float], *, speed_m_s: float,
                 accel_m_s2: float, lead_limit_m: float) -> None:
        self.start, self.end = start, end
        dn, de = end[0] - start[0], end[1] - start[1]
        self.length_m = math.hypot(dn, de)
        self._unit = (dn / self.length_m, de / self.length_m) if self.length_m > 1e-9 else (0.0, 0.0)
        self.speed_m_s = speed_m_s
        self.accel_m_s2 = accel_m_s2
        self.lead_limit_m = lead_limit_m
        self.s_m = 0.0
        self._v = 0.0

    def along_m(self, north_m: float, east_m: float) -> float:
        """A point's distance along the leg from its start, m."""
        return (north_m - self.start[0]) * self._unit[0] + (east_m - self.start[1]) * self._unit[1]

    def advance(self, dt_s: float, vehicle_ne: tuple[float, float] | None) -> Setpoint:
        """Move the setpoint on by ``dt_s`` s; ``vehicle_ne`` holds it within the lead limit."""
        remaining = self.length_m - self.s_m
        wanted = min(self.speed_m_s, math.sqrt(2.0 * self.accel_m_s2 * max(remaining, 0.0)))
        if vehicle_ne is not None and self.s_m - self.along_m(*vehicle_ne) >= self.lead_limit_m:
            wanted = 0.0  # wait for the vehicle
        step = self.accel_m_s2 * dt_s
        self._v = max(0.0, min(wanted, self._v + step)) if wanted >= self._v else max(wanted, self._v - step)
        self.s_m = min(self.length_m, self.s_m + self._v * dt_s)
        if self.s_m >= self.length_m:
            self._v = 0.0
        n = self.start[0] + self._unit[0] * self.s_m
        e = self.start[1] + self._unit[1] * self.s_m
        return Setpoint(n, e, self._unit[0] * self._v, self._unit[1] * self._v)

    @property
    def finished(self) -> bool:
        """True once the setpoint sits at the leg's end."""
        return self.s_m >= self.length_m


#: A depth setpoint this close to its target (m) has arrived (the exponential approach's tail).
ARRIVED_M = 0.002


class DepthRamp:
    """A depth setpoint that moves toward its target at most ``vertical_speed_m_s``, slowing
    at ``accel_m_s2`` as it arrives, and over the last stretch no faster than the gap over
    ``approach_time_s`` (an exponential approach).

    The approach is what keeps a descent from overshooting its target onto the floor: the
    vehicle's depth loop lags its setpoint, by about 0.3 s in the simulated sub (a real
    ArduSub's depth controller lags too), so a setpoint that brakes only at the last
    moment left the vehicle 13 cm below a 0.52 m pass; approaching at ``gap /
    approach_time_s`` the lag costs ``lag / approach_time_s`` of the last gap.
    """

    def __init__(self, depth_m: float, *, vertical_speed_m_s: float, accel_m_s2: float,
                 approach_time_s: float = 2.0) -> None:
        self.depth_m = depth_m
        self.vertical_speed_m_s = vertical_speed_m_s
        self.accel_m_s2 = accel_m_s2
        self.approach_time_s = approach_time_s
        self._rate = 0.0

    def advance(self, dt_s: float, target_m: float) -> tuple[float, float]:
        """(depth setpoint m, its rate m/s, down positive) after ``dt_s`` toward ``target_m``."""
        gap = target_m - self.depth_m
        if abs(gap) <= ARRIVED_M:  # the approach's tail: arrived
            self.depth_m, self._rate = target_m, 0.0
            return self.depth_m, 0.0
        speed = min(self.vertical_speed_m_s, math.sqrt(2.0 * self.accel_m_s2 * abs(gap)),
                    abs(gap) / self.approach_time_s if self.approach_time_s > 0 else math.inf)
        wanted = math.copysign(speed, gap)
        step = self.accel_m_s2 * dt_s
        self._rate = max(self._rate - step, min(self._rate + step, wanted))
        delta = self._rate * dt_s
        if abs(delta) >= abs(gap) or gap * delta < 0:
            delta, self._rate = gap, 0.0
        self.depth_m += delta
        return self.depth_m, self._rate
