"""Vehicle sensors from the simulated world: depth, altimeter, attitude, DVL position.

Each sensor is a small stateful object with a seeded generator; ``sample`` takes the true
state and returns what the real sensor would report (noise, drift, dropouts, spikes).
Conventions as in :mod:`sim_harness.vehicle.dynamics`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from sim_harness.errors import SimConfigError
from sim_harness.faults import FaultConfig


class SeabedWorld(Protocol):
    """What the vehicle needs from the world (``sim_harness.world.world.World`` provides it)."""

    def seabed_depth_m(self, north_m: float, east_m: float) -> float:
        """Depth of the seabed below the surface at a point, metres, positive down."""
        ...


@dataclass(frozen=True)
class FlatSeabed:
    """A flat seabed at a fixed depth (a stand-in world for tests)."""

    depth_m: float = 20.0

    def seabed_depth_m(self, north_m: float, east_m: float) -> float:
        """Depth of the seabed, metres, positive down."""
        return self.depth_m


@dataclass(frozen=True)
class SlopedSeabed:
    """A planar seabed: depth = depth_m + slope_north * north + slope_east * east."""

    depth_m: float = 20.0
    slope_north: float = 0.0
    slope_east: float = 0.0

    def seabed_depth_m(self, north_m: float, east_m: float) -> float:
        """Depth of the seabed, metres, positive down."""
        return self.depth_m + self.slope_north * north_m + self.slope_east * east_m


@dataclass(frozen=True)
class SensorConfig:
    """Noise and limits of the sensors."""

    depth_noise_m: float = 0.01
    altimeter_noise_m: float = 0.02
    altimeter_noise_frac: float = 0.005  # extra noise per metre of range
    altimeter_min_range_m: float = 0.3
    altimeter_max_range_m: float = 50.0
    altimeter_dropout_prob: float = 0.0  # random dropouts per sample
    altimeter_offset_m: float = 0.0  # altimeter below the sonar / vehicle reference, metres
    heading_noise_rad: float = math.radians(0.2)
    attitude_noise_rad: float = math.radians(0.05)
    dvl_velocity_noise_m_s: float = 0.005
    dvl_bias_walk_m_s: float = 0.0005  # random walk of the velocity bias per sqrt(s)
    dvl_max_altitude_m: float = 60.0  # no bottom lock higher than this
    has_position_estimate: bool = True

    def __post_init__(self) -> None:
        for name, value in vars(self).items():
            if isinstance(value, float) and value < 0.0 and name != "altimeter_offset_m":
                raise SimConfigError(f"must be >= 0, got {value}", key=name)
        if not self.altimeter_min_range_m < self.altimeter_max_range_m:
            raise SimConfigError("must be below altimeter_max_range_m", key="altimeter_min_range_m")
        if not 0.0 <= self.altimeter_dropout_prob <= 1.0:
            raise SimConfigError("must be a probability", key="altimeter_dropout_prob")


@dataclass(frozen=True)
class SensorReadings:
    """What the autopilot sees at one instant (estimates, never truth)."""

    time_s: float
    depth_m: float
    altitude_m: float | None  # None: no valid rangefinder reading
    roll_rad: float
    pitch_rad: float
    yaw_rad: float
    roll_rate_rad_s: float
    pitch_rate_rad_s: float
    yaw_rate_rad_s: float
    position_ok: bool
    north_m: float  # estimated position (DVL dead reckoning), NED
    east_m: float
    vel_north_m_s: float
    vel_east_m_s: float
    vel_down_m_s: float


class _Draws:
    """Standard normals and uniforms drawn from a seeded generator in blocks (fast scalars)."""

    BLOCK = 4096

    def __init__(self, rng: np.random.Generator) -> None:
        self._rng = rng
        self._normals: list[float] = []
        self._uniforms: list[float] = []

    def normal(self) -> float:
        """One standard normal draw."""
        if not self._normals:
            self._normals = self._rng.standard_normal(self.BLOCK).tolist()
        return self._normals.pop()

    def uniform(self) -> float:
        """One draw from U[0, 1)."""
        if not self._uniforms:
            self._uniforms = self._rng.random(self.BLOCK).tolist()
        return self._uniforms.pop()


class SensorSuite:
    """All vehicle sensors, seeded; ``sample`` is called once per simulator step."""

    def __init__(
        self,
        world: SeabedWorld,
        config: SensorConfig,
        faults: FaultConfig,
        rng: np.random.Generator,
        *,
        start_north_m: float,
        start_east_m: float,
    ) -> None:
        self._world = world
        self._cfg = config
        self._faults = faults
        self._rng = _Draws(rng)
        self._est_north_m = start_north_m
        self._est_east_m = start_east_m
        self._bias_n = 0.0
        self._bias_e = 0.0
        self._last_t: float | None = None

    def true_altitude_m(self, north_m: float, east_m: float, depth_m: float) -> float:
        """True height of the vehicle reference above the seabed, metres."""
        return self._world.seabed_depth_m(north_m, east_m) - depth_m

    def sample(
        self,
        t_s: float,
        state: tuple[float, ...],
        attitude: tuple[float, float, float, float],
    ) -> SensorReadings:
        """Readings at ``t_s`` from the true ``state`` (8,) and (pitch, roll, rates)."""
        cfg = self._cfg
        rng = self._rng
        north, east, down, yaw, u, v, w, r = state
        pitch, roll, pitch_rate, roll_rate = attitude
        dt = 0.0 if self._last_t is None else max(t_s - self._last_t, 0.0)
        self._last_t = t_s

        depth = down + cfg.depth_noise_m * rng.normal()
        if self._faults.depth_spike_prob > 0.0 and rng.uniform() < self._faults.depth_spike_prob:
            depth += self._faults.depth_spike_m * (1.0 if rng.uniform() < 0.5 else -1.0)

        true_alt = self.true_altitude_m(north, east, down) - cfg.altimeter_offset_m
        altitude: float | None = None
        if cfg.altimeter_min_range_m <= true_alt <= cfg.altimeter_max_range_m:
            dropped = rng.uniform() < cfg.altimeter_dropout_prob or self._faults.altimeter_out(t_s)
            if not dropped:
                sigma = cfg.altimeter_noise_m + cfg.altimeter_noise_frac * true_alt
                altitude = max(true_alt + sigma * rng.normal(), 0.0)

        c, s = math.cos(yaw), math.sin(yaw)
        vn = c * u - s * v
        ve = s * u + c * v
        lock = cfg.has_position_estimate and true_alt <= cfg.dvl_max_altitude_m
        lock = lock and not self._faults.position_out(t_s)
        if dt > 0.0:
            walk = cfg.dvl_bias_walk_m_s * math.sqrt(dt)
            self._bias_n += walk * rng.normal()
            self._bias_e += walk * rng.normal()
            noise = cfg.dvl_velocity_noise_m_s
            vn_meas = vn + self._bias_n + noise * rng.normal()
            ve_meas = ve + self._bias_e + noise * rng.normal()
            # Without bottom lock the estimate coasts on the last velocity (and drifts).
            self._est_north_m += vn_meas * dt
            self._est_east_m += ve_meas * dt
        else:
            vn_meas, ve_meas = vn, ve
        an = cfg.attitude_noise_rad
        return SensorReadings(
            time_s=t_s,
            depth_m=depth,
            altitude_m=altitude,
            roll_rad=roll + an * rng.normal(),
            pitch_rad=pitch + an * rng.normal(),
            yaw_rad=yaw + cfg.heading_noise_rad * rng.normal(),
            roll_rate_rad_s=roll_rate,
            pitch_rate_rad_s=pitch_rate,
            yaw_rate_rad_s=r,
            position_ok=lock,
            north_m=self._est_north_m,
            east_m=self._est_east_m,
            vel_north_m_s=vn_meas,
            vel_east_m_s=ve_meas,
            vel_down_m_s=w,
        )
