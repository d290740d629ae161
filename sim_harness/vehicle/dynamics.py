"""Dynamics of a small ROV (BlueROV2-like): surge, sway, heave and yaw.

Conventions (used by every module of sim_harness):

- Local NED frame: x north, y east, z down, metres; ``depth_m`` positive down.
- Body frame: x forward, y starboard, z down. Heading ``yaw_rad`` clockwise from north.
- Attitude, ArduPilot convention: pitch positive nose up, roll positive starboard down.
- Mount tilt ``tilt_rad`` positive = sonar pointing down (depression below the body
  x axis). MAVLink mount/gimbal pitch is the opposite sign (positive up).

State vector ``x`` (8,) = (north_m, east_m, down_m, yaw_rad, u_m_s, v_m_s, w_m_s, r_rad_s),
with (u, v, w) the body-frame velocity over ground and r the yaw rate.
Thrust ``tau`` (4,) = (surge_n, sway_n, heave_n, yaw_nm), body frame, heave positive down.
Water current ``current`` (3,) = (north, east, down) m/s, NED.

The model: rigid body with added mass, linear + quadratic drag on the velocity relative to
the water, a small net buoyancy, and Coriolis coupling between surge/sway and yaw rate.
Pitch and roll are not states: they are disturbances (see :class:`AttitudeDisturbance`).

:func:`rate_terms` is written with ``sin``/``cos``/``fabs`` passed in, so the same
equations serve numpy (:func:`derivative`) and plain floats (:func:`step_rk4`, fast in
the simulator loop). The controller does not share this model: the pitch loop predicts
with its own kinematic one (:mod:`planner.pitch.prediction`), and
``tests/planner/pitch/test_prediction_vs_simulator.py`` checks that prediction against
this model's trajectories.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from perception.geometry.mount import slew_toward
from sim_harness.errors import SimConfigError

STATE_SIZE = 8
THRUST_SIZE = 4
N_IDX, E_IDX, D_IDX, YAW_IDX, U_IDX, V_IDX, W_IDX, R_IDX = range(8)


@dataclass(frozen=True)
class RovParams:
    """Physical parameters; defaults roughly a BlueROV2 (heavy configuration)."""

    mass_surge_kg: float = 17.0  # rigid mass + added mass along x
    mass_sway_kg: float = 24.0
    mass_heave_kg: float = 27.0
    inertia_yaw_kg_m2: float = 0.8
    drag_lin_surge: float = 4.0  # N / (m/s)
    drag_lin_sway: float = 6.0
    drag_lin_heave: float = 6.0
    drag_lin_yaw: float = 0.6  # N m / (rad/s)
    drag_quad_surge: float = 18.0  # N / (m/s)^2
    drag_quad_sway: float = 21.0
    drag_quad_heave: float = 37.0
    drag_quad_yaw: float = 1.5  # N m / (rad/s)^2
    net_buoyancy_n: float = 1.0  # positive = floats up
    max_surge_n: float = 40.0
    max_sway_n: float = 35.0
    max_heave_n: float = 50.0
    max_yaw_nm: float = 8.0

    def __post_init__(self) -> None:
        for name, value in vars(self).items():
            if name != "net_buoyancy_n" and not value > 0.0:
                raise SimConfigError(f"must be positive, got {value}", key=name)

    @property
    def thrust_limits(self) -> tuple[float, float, float, float]:
        """(surge_n, sway_n, heave_n, yaw_nm) magnitude limits."""
        return (self.max_surge_n, self.max_sway_n, self.max_heave_n, self.max_yaw_nm)


def rate_terms(
    x: Any,
    tau: Any,
    current: Any,
    p: RovParams,
    sin: Callable[[Any], Any],
    cos: Callable[[Any], Any],
    fabs: Callable[[Any], Any],
) -> list[Any]:
    """The eight state derivatives as a list, for any scalar algebra (float, casadi).

    Parameters
    ----------
    x : sequence (8,)
        State, see the module docstring.
    tau : sequence (4,)
        Thrust (surge N, sway N, heave N down, yaw N m), already saturated.
    current : sequence (3,)
        Water velocity, NED, m/s.
    p : RovParams
    sin, cos, fabs
        Scalar functions of the algebra in use.
    """
    yaw, u, v, w, r = x[3], x[4], x[5], x[6], x[7]
    c, s = cos(yaw), sin(yaw)
    # Water velocity in the body frame, then velocity relative to the water.
    u_c = c * current[0] + s * current[1]
    v_c = -s * current[0] + c * current[1]
    u_r = u - u_c
    v_r = v - v_c
    w_r = w - current[2]
    du = (
        tau[0] - (p.drag_lin_surge + p.drag_quad_surge * fabs(u_r)) * u_r + p.mass_sway_kg * v * r
    ) / p.mass_surge_kg
    dv = (
        tau[1] - (p.drag_lin_sway + p.drag_quad_sway * fabs(v_r)) * v_r - p.mass_surge_kg * u * r
    ) / p.mass_sway_kg
    dw = (
        tau[2] - (p.drag_lin_heave + p.drag_quad_heave * fabs(w_r)) * w_r - p.net_buoyancy_n
    ) / p.mass_heave_kg
    dr = (tau[3] - (p.drag_lin_yaw + p.drag_quad_yaw * fabs(r)) * r) / p.inertia_yaw_kg_m2
    return [c * u - s * v, s * u + c * v, w, r, du, dv, dw, dr]


def saturate_thrust(tau: Sequence[float] | np.ndarray, p: RovParams) -> tuple[float, float, float, float]:
    """Clip each thrust component to its limit; returns (surge, sway, heave, yaw)."""
    lim = p.thrust_limits
    return (
        min(max(float(tau[0]), -lim[0]), lim[0]),
        min(max(float(tau[1]), -lim[1]), lim[1]),
        min(max(float(tau[2]), -lim[2]), lim[2]),
        min(max(float(tau[3]), -lim[3]), lim[3]),
    )


def derivative(
    state: np.ndarray, thrust: np.ndarray, current: np.ndarray, params: RovParams | None = None
) -> np.ndarray:
    """State derivative with numpy.

    Parameters
    ----------
    state : ndarray (8,)
        See module docstring; metres, radians, m/s, rad/s.
    thrust : ndarray (4,)
        Body thrust (N, N, N, N m); saturated here to the thrust limits.
    current : ndarray (3,)
        Water velocity NED, m/s.
    params : RovParams, optional

    Returns
    -------
    ndarray (8,)
        d(state)/dt.
    """
    p = params or RovParams()
    x = np.asarray(state, dtype=float)
    if x.shape != (STATE_SIZE,):
        raise ValueError(f"state must have shape (8,), got {x.shape}")
    t = np.asarray(thrust, dtype=float)
    if t.shape != (THRUST_SIZE,):
        raise ValueError(f"thrust must have shape (4,), got {t.shape}")
    cur = np.asarray(current, dtype=float)
    if cur.shape != (3,):
        raise ValueError(f"current must have shape (3,), got {cur.shape}")
    tau = saturate_thrust(t, p)
    return np.array(rate_terms(x, tau, cur, p, np.sin, np.cos, np.abs), dtype=float)


def step_rk4(
    state: Sequence[float],
    thrust: Sequence[float],
    current: Sequence[float],
    dt_s: float,
    params: RovParams,
) -> tuple[float, ...]:
    """One classical Runge-Kutta step on plain floats (thrust saturated, held over dt).

    Returns the new state as a tuple (8,); the yaw is wrapped to [-pi, pi).
    """
    tau = saturate_thrust(thrust, params)
    sin, cos, fabs = math.sin, math.cos, abs
    x0 = tuple(float(v) for v in state)
    k1 = rate_terms(x0, tau, current, params, sin, cos, fabs)
    x1 = tuple(a + 0.5 * dt_s * b for a, b in zip(x0, k1, strict=True))
    k2 = rate_terms(x1, tau, current, params, sin, cos, fabs)
    x2 = tuple(a + 0.5 * dt_s * b for a, b in zip(x0, k2, strict=True))
    k3 = rate_terms(x2, tau, current, params, sin, cos, fabs)
    x3 = tuple(a + dt_s * b for a, b in zip(x0, k3, strict=True))
    k4 = rate_terms(x3, tau, current, params, sin, cos, fabs)
    out = [
        a + dt_s / 6.0 * (b1 + 2.0 * b2 + 2.0 * b3 + b4)
        for a, b1, b2, b3, b4 in zip(x0, k1, k2, k3, k4, strict=True)
    ]
    out[YAW_IDX] = wrap_pi(out[YAW_IDX])
    return tuple(out)


def wrap_pi(angle_rad: float) -> float:
    """Wrap an angle to [-pi, pi)."""
    return (angle_rad + math.pi) % (2.0 * math.pi) - math.pi


@dataclass(frozen=True)
class UniformCurrent:
    """A water current, the same everywhere and at all times (NED, m/s)."""

    north_m_s: float = 0.0
    east_m_s: float = 0.0
    down_m_s: float = 0.0

    def velocity_ned_m_s(
        self, north_m: float, east_m: float, depth_m: float, t_s: float
    ) -> tuple[float, float, float]:
        """Water velocity at a point and time, NED m/s."""
        return (self.north_m_s, self.east_m_s, self.down_m_s)


@dataclass(frozen=True)
class ShearCurrent:
    """A current that fades with depth and swings slowly (tidal), NED m/s.

    ``surface`` speed at depth 0, decaying as exp(-depth/decay_depth_m); direction turns
    by ``swing_rad`` over ``period_s``.
    """

    surface_speed_m_s: float = 0.3
    direction_rad: float = 0.0  # direction the water flows towards, clockwise from north
    decay_depth_m: float = 15.0
    swing_rad: float = 0.3
    period_s: float = 600.0

    def velocity_ned_m_s(
        self, north_m: float, east_m: float, depth_m: float, t_s: float
    ) -> tuple[float, float, float]:
        """Water velocity at a point and time, NED m/s."""
        speed = self.surface_speed_m_s * math.exp(-max(depth_m, 0.0) / self.decay_depth_m)
        heading = self.direction_rad + self.swing_rad * math.sin(2.0 * math.pi * t_s / self.period_s)
        return (speed * math.cos(heading), speed * math.sin(heading), 0.0)


@dataclass(frozen=True)
class AttitudeDisturbance:
    """Pitch and roll as disturbances: waves, tether and thrust reaction.

    pitch = bias + wave amplitude * sin(2 pi t / period + phase) + gain * surge thrust;
    roll likewise with its own amplitude and period. Radians.

    The surge thrust enters through a first-order lag of ``surge_pitch_lag_s`` (the
    vehicle's pitch inertia against its restoring moment; the caller filters the thrust,
    :meth:`lagged_surge_n`): a thruster's step change tips the nose over about a second,
    not within one physics step.
    """

    pitch_bias_rad: float = 0.0
    pitch_amplitude_rad: float = math.radians(1.5)
    pitch_period_s: float = 6.0
    roll_amplitude_rad: float = math.radians(1.0)
    roll_period_s: float = 4.5
    pitch_per_surge_rad_n: float = -math.radians(3.0) / 40.0  # nose dips at full thrust
    phase_pitch_rad: float = 0.0
    phase_roll_rad: float = 0.7
    surge_pitch_lag_s: float = 0.8

    def __post_init__(self) -> None:
        for key in ("pitch_period_s", "roll_period_s"):
            if not (math.isfinite(getattr(self, key)) and getattr(self, key) > 0.0):
                raise SimConfigError("must be finite and > 0", key=key)
        if not (math.isfinite(self.surge_pitch_lag_s) and self.surge_pitch_lag_s >= 0.0):
            raise SimConfigError("must be finite and >= 0 (0: no lag)", key="surge_pitch_lag_s")

    def lagged_surge_n(self, filtered_n: float, surge_n: float, dt_s: float) -> float:
        """One step of the surge thrust's lag: the filtered thrust after ``dt_s`` s, N."""
        if self.surge_pitch_lag_s <= 0.0:
            return surge_n
        return filtered_n + (surge_n - filtered_n) * (1.0 - math.exp(-dt_s / self.surge_pitch_lag_s))

    def attitude(self, t_s: float, surge_n: float, surge_rate_n_s: float = 0.0) -> tuple[float, float, float, float]:
        """(pitch_rad, roll_rad, pitch_rate_rad_s, roll_rate_rad_s) at time ``t_s``.

        ``surge_n`` is the (lagged) surge thrust, N, and ``surge_rate_n_s`` its rate, N/s.
        """
        wp = 2.0 * math.pi / self.pitch_period_s
        wr = 2.0 * math.pi / self.roll_period_s
        ap = wp * t_s + self.phase_pitch_rad
        ar = wr * t_s + self.phase_roll_rad
        pitch = (
            self.pitch_bias_rad
            + self.pitch_amplitude_rad * math.sin(ap)
            + self.pitch_per_surge_rad_n * surge_n
        )
        roll = self.roll_amplitude_rad * math.sin(ar)
        return (
            pitch,
            roll,
            self.pitch_amplitude_rad * wp * math.cos(ap) + self.pitch_per_surge_rad_n * surge_rate_n_s,
            self.roll_amplitude_rad * wr * math.cos(ar),
        )


@dataclass(frozen=True)
class MountMechanics:
    """Tilt mount: angle limits and slew rate (tilt positive down, radians)."""

    min_tilt_rad: float = math.radians(-30.0)
    max_tilt_rad: float = math.radians(90.0)
    max_rate_rad_s: float = math.radians(30.0)
    default_tilt_rad: float = math.radians(0.0)

    def __post_init__(self) -> None:
        if not self.min_tilt_rad < self.max_tilt_rad:
            raise SimConfigError("min_tilt_rad must be below max_tilt_rad", key="min_tilt_rad")
        if not self.max_rate_rad_s > 0.0:
            raise SimConfigError("must be positive", key="max_rate_rad_s")
        if not self.min_tilt_rad <= self.default_tilt_rad <= self.max_tilt_rad:
            raise SimConfigError("must lie within the limits", key="default_tilt_rad")

    def clamp(self, tilt_rad: float) -> float:
        """Clip a tilt to the angle limits."""
        return min(max(tilt_rad, self.min_tilt_rad), self.max_tilt_rad)


def slew_tilt(current_rad: float, target_rad: float, dt_s: float, limits: MountMechanics) -> float:
    """Move the mount from ``current_rad`` towards the clamped target at most at the rate limit."""
    return slew_toward(current_rad, limits.clamp(target_rad), max_rate_rad_s=limits.max_rate_rad_s, dt_s=dt_s)
