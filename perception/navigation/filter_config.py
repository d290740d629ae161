"""The altitude filter's settings, validated on construction, and what it answers with
(:mod:`perception.navigation.altitude_filter`)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from perception.errors import MeasurementError
from perception.navigation.pressure import (
    FRESH_WATER_SPECIFIC_GRAVITY,
    STANDARD_GRAVITY_M_S2,
    pascals_per_metre,
)

FloatArray = NDArray[np.float64]


#: Sensor names, as used by the counters.
SENSORS = ("pressure", "depth", "altimeter", "sonar")


@dataclass(frozen=True)
class AltitudeFilterConfig:
    """Settings of :class:`AltitudeFilter` (validated on construction).

    Attributes
    ----------
    accel_psd_m2_s3 : float
        Power spectral density of the white vertical acceleration while holding depth,
        m^2/s^3. Small values let the smoother average long stretches of a hold (mm
        precision on ``dH``) but cannot follow a fast depth change; see
        ``maneuver_accel_psd_m2_s3``.
    maneuver_accel_psd_m2_s3 : float
        The same while :meth:`AltitudeFilter.set_maneuvering` says the vehicle is
        changing depth on purpose, m^2/s^3.
    seabed_walk_psd_m2_s : float
        Power spectral density of the seabed-depth random walk, m^2/s.
    seabed_rate_psd_m2_s3 : float or None
        With a value, a fourth state ``db/dt`` (the seabed slope times the ground speed,
        m/s) follows a random walk of this PSD, m^2/s^3: for a vehicle flying over
        sloping ground. ``None`` (default): three states, seabed depth a random walk.
    initial_depth_std_m, initial_speed_std_m_s, initial_seabed_std_m : float
        Prior standard deviations before any measurement (the prior mean is zero).
    initial_seabed_rate_std_m_s : float
        Prior standard deviation of ``db/dt`` (four-state model only).
    gate_probability : float
        Chi-square gate (1 degree of freedom), probability in (0, 1).
    reinit_after : int
        Consecutive gated rejections of one sensor after which it is believed (>= 1).
    gate_warmup : int
        Measurements of each sensor accepted without gating at the start (>= 0).
    reinit_std_m : float
        Process noise (standard deviation, m) added to the observed state at a reset.
    reinit_speed_std_m_s : float
        Process noise (standard deviation, m/s) added to the vertical speed at a depth
        reset.
    window_s : float
        Length of the retained window, s, back from the latest step.
    max_steps : int
        Hard cap on retained steps (bounded memory whatever the rates).
    max_extrapolation_s : float
        How far past the latest step a query may predict, s.
    surface_pressure_pa : float or None
        Absolute pressure at the surface, Pa; ``None`` to take the median of the first
        ``surface_samples`` pressure samples (which must then be taken at the surface).
    surface_samples : int
        Samples for the surface calibration when ``surface_pressure_pa`` is ``None``.
    specific_gravity : float
        Water specific gravity (ArduSub ``BARO_SPEC_GRAV``: fresh 1.0, sea 1.024).
    gravity_m_s2 : float
        Gravity for the pressure-to-depth conversion, m/s^2.
    min_signal_quality : int
        Altimeter readings with a known signal quality (2..100) below this are rejected
        as ``low_quality``; 1 (MAVLink "invalid") is always rejected, 0 means unknown.
    """

    accel_psd_m2_s3: float = 1e-5
    maneuver_accel_psd_m2_s3: float = 1e-2
    seabed_walk_psd_m2_s: float = 1e-6
    seabed_rate_psd_m2_s3: float | None = None
    initial_seabed_rate_std_m_s: float = 0.1
    initial_depth_std_m: float = 100.0
    initial_speed_std_m_s: float = 1.0
    initial_seabed_std_m: float = 100.0
    gate_probability: float = 0.997
    reinit_after: int = 5
    gate_warmup: int = 10
    reinit_std_m: float = 10.0
    reinit_speed_std_m_s: float = 1.0
    window_s: float = 120.0
    max_steps: int = 20_000
    max_extrapolation_s: float = 1.0
    surface_pressure_pa: float | None = None
    surface_samples: int = 10
    specific_gravity: float = FRESH_WATER_SPECIFIC_GRAVITY
    gravity_m_s2: float = STANDARD_GRAVITY_M_S2
    min_signal_quality: int = 0

    def __post_init__(self) -> None:
        positive = {
            "accel_psd_m2_s3": self.accel_psd_m2_s3,
            "maneuver_accel_psd_m2_s3": self.maneuver_accel_psd_m2_s3,
            "seabed_walk_psd_m2_s": self.seabed_walk_psd_m2_s,
            "initial_depth_std_m": self.initial_depth_std_m,
            "initial_speed_std_m_s": self.initial_speed_std_m_s,
            "initial_seabed_std_m": self.initial_seabed_std_m,
            "initial_seabed_rate_std_m_s": self.initial_seabed_rate_std_m_s,
            "reinit_std_m": self.reinit_std_m,
            "reinit_speed_std_m_s": self.reinit_speed_std_m_s,
            "window_s": self.window_s,
        }
        if self.seabed_rate_psd_m2_s3 is not None:
            positive["seabed_rate_psd_m2_s3"] = self.seabed_rate_psd_m2_s3
        for name, value in positive.items():
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"AltitudeFilterConfig.{name} must be finite and > 0, got {value!r}")
        if not (0.0 < self.gate_probability < 1.0):
            raise ValueError(f"gate_probability must be in (0, 1), got {self.gate_probability!r}")
        if self.reinit_after < 1 or self.max_steps < 3 or self.surface_samples < 1 or self.gate_warmup < 0:
            raise ValueError("reinit_after >= 1, max_steps >= 3, surface_samples >= 1, gate_warmup >= 0 required")
        if not (math.isfinite(self.max_extrapolation_s) and self.max_extrapolation_s >= 0):
            raise ValueError(f"max_extrapolation_s must be >= 0, got {self.max_extrapolation_s!r}")
        if not (0 <= self.min_signal_quality <= 100):
            raise ValueError(f"min_signal_quality must be in [0, 100], got {self.min_signal_quality!r}")
        if self.surface_pressure_pa is not None and not (
            math.isfinite(self.surface_pressure_pa) and self.surface_pressure_pa > 0
        ):
            raise ValueError(f"surface_pressure_pa must be > 0 Pa, got {self.surface_pressure_pa!r}")
        pascals_per_metre(specific_gravity=self.specific_gravity, gravity_m_s2=self.gravity_m_s2)


class Estimate(NamedTuple):
    """A scalar estimate: ``mean`` (m) and ``variance`` (m^2); unpacks as a pair."""

    mean: float
    variance: float

    @property
    def std(self) -> float:
        """Standard deviation, m."""
        return math.sqrt(max(self.variance, 0.0))


@dataclass(frozen=True)
class UpdateResult:
    """What one ``update_*`` call did.

    ``status`` is one of ``"accepted"``, ``"reinitialised"`` (accepted after a reset),
    ``"gated"``, ``"out_of_order"``, ``"low_quality"``, ``"out_of_range"`` or
    ``"calibration"`` (a surface-pressure sample). ``nis`` is the normalised innovation
    squared (NaN when no innovation was computed).
    """

    status: str
    nis: float = math.nan

    @property
    def accepted(self) -> bool:
        """True when the measurement changed the state."""
        return self.status in ("accepted", "reinitialised")


@dataclass
class SensorCounters:
    """Per-sensor counts of what happened to its measurements (a snapshot when read)."""

    accepted: int = 0
    reinitialised: int = 0
    gated: int = 0
    out_of_order: int = 0
    low_quality: int = 0
    out_of_range: int = 0
    calibration: int = 0

    @property
    def rejected(self) -> int:
        """All measurements that did not change the state (calibration excluded)."""
        return self.gated + self.out_of_order + self.low_quality + self.out_of_range


def finite_measurement(value: float, what: str, sensor: str) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError) as exc:
        raise MeasurementError(f"{what} must be a number, got {value!r}", sensor=sensor, value=value) from exc
    if not math.isfinite(v):
        raise MeasurementError(f"{what} must be finite, got {value!r}", sensor=sensor, value=value)
    return v


def positive_std(std_m: float, sensor: str) -> float:
    s = finite_measurement(std_m, "noise standard deviation", sensor)
    if s <= 0:
        raise MeasurementError(f"noise standard deviation must be > 0, got {std_m!r}", sensor=sensor, value=std_m)
    return s
