"""The autopilot's control laws: position, velocity, depth and heading loops.

Pure functions of estimates (never truth) plus a small integrator state. Output thrust is
body frame (surge N, sway N, heave N down, yaw N m), as :mod:`sim_harness.vehicle.dynamics`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from sim_harness.vehicle.dynamics import RovParams, wrap_pi

POS_GAIN_1_S = 0.6  # horizontal position error -> velocity
VEL_BANDWIDTH_RAD_S = 1.5
VEL_INTEGRAL_1_S = 0.4
DEPTH_GAIN_1_S = 1.0
HEAVE_BANDWIDTH_RAD_S = 2.0
HEAVE_INTEGRAL_1_S = 0.5
YAW_GAIN_1_S = 1.2
YAW_RATE_MAX_RAD_S = math.radians(45.0)
YAW_RATE_BANDWIDTH_RAD_S = 4.0
INTEGRAL_LIMIT_FRACTION = 0.4  # integrators limited to this fraction of the thrust limit


@dataclass
class Integrators:
    """Integrator state of the velocity and heave loops (N)."""

    north_n: float = 0.0
    east_n: float = 0.0
    down_n: float = 0.0

    def reset(self) -> None:
        """Zero every integrator."""
        self.north_n = self.east_n = self.down_n = 0.0


def _clip(value: float, limit: float) -> float:
    return min(max(value, -limit), limit)


def velocity_toward(
    north_m: float, east_m: float, target_north_m: float, target_east_m: float, speed_m_s: float
) -> tuple[float, float, float]:
    """Desired NED horizontal velocity toward a target; returns (vn, ve, distance_m)."""
    dn, de = target_north_m - north_m, target_east_m - east_m
    dist = math.hypot(dn, de)
    if dist < 1e-9:
        return 0.0, 0.0, 0.0
    speed = min(POS_GAIN_1_S * dist, speed_m_s)
    return speed * dn / dist, speed * de / dist, dist


def horizontal_force(
    vel_des: tuple[float, float],
    vel_est: tuple[float, float],
    yaw_rad: float,
    p: RovParams,
    integ: Integrators,
    dt_s: float,
) -> tuple[float, float]:
    """PI velocity loop in NED, rotated to body (surge N, sway N)."""
    k = p.mass_surge_kg * VEL_BANDWIDTH_RAD_S
    en = vel_des[0] - vel_est[0]
    ee = vel_des[1] - vel_est[1]
    lim = INTEGRAL_LIMIT_FRACTION * p.max_surge_n
    integ.north_n = _clip(integ.north_n + k * VEL_INTEGRAL_1_S * en * dt_s, lim)
    integ.east_n = _clip(integ.east_n + k * VEL_INTEGRAL_1_S * ee * dt_s, lim)
    # Feed-forward the drag at the desired speed so steady tracking needs little integral.
    ff_n = (p.drag_lin_surge + p.drag_quad_surge * abs(vel_des[0])) * vel_des[0]
    ff_e = (p.drag_lin_surge + p.drag_quad_surge * abs(vel_des[1])) * vel_des[1]
    fn = k * en + integ.north_n + ff_n
    fe = k * ee + integ.east_n + ff_e
    c, s = math.cos(yaw_rad), math.sin(yaw_rad)
    return c * fn + s * fe, -s * fn + c * fe


def heave_force(
    depth_target_m: float,
    depth_m: float,
    vel_down_m_s: float,
    p: RovParams,
    integ: Integrators,
    dt_s: float,
    *,
    max_down_m_s: float,
    max_up_m_s: float,
) -> float:
    """Depth loop: depth error -> climb rate (limited) -> heave force (N, positive down)."""
    w_des = min(max(DEPTH_GAIN_1_S * (depth_target_m - depth_m), -max_up_m_s), max_down_m_s)
    return heave_for_rate(w_des, vel_down_m_s, p, integ, dt_s)


def heave_for_rate(
    w_des_m_s: float, vel_down_m_s: float, p: RovParams, integ: Integrators, dt_s: float
) -> float:
    """Heave PI loop on vertical speed (positive down); compensates buoyancy by integral."""
    k = p.mass_heave_kg * HEAVE_BANDWIDTH_RAD_S
    err = w_des_m_s - vel_down_m_s
    lim = INTEGRAL_LIMIT_FRACTION * p.max_heave_n
    integ.down_n = _clip(integ.down_n + k * HEAVE_INTEGRAL_1_S * err * dt_s, lim)
    # Feed-forward the drag at the desired rate (as the horizontal loop does): the integral
    # is left with the buoyancy, and does not wind up through a descent and overshoot.
    ff = (p.drag_lin_heave + p.drag_quad_heave * abs(w_des_m_s)) * w_des_m_s
    return k * err + integ.down_n + ff


def yaw_moment(yaw_target_rad: float, yaw_rad: float, yaw_rate_rad_s: float, p: RovParams) -> float:
    """Heading loop: heading error -> yaw rate (limited) -> moment (N m)."""
    r_des = _clip(YAW_GAIN_1_S * wrap_pi(yaw_target_rad - yaw_rad), YAW_RATE_MAX_RAD_S)
    return yaw_moment_for_rate(r_des, yaw_rate_rad_s, p)


def yaw_moment_for_rate(r_des_rad_s: float, yaw_rate_rad_s: float, p: RovParams) -> float:
    """Yaw rate loop (N m)."""
    return p.inertia_yaw_kg_m2 * YAW_RATE_BANDWIDTH_RAD_S * (r_des_rad_s - yaw_rate_rad_s)
