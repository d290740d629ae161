"""Settings of the pitch loop and the tilt mount it drives, validated on construction."""

from __future__ import annotations

import math
from dataclasses import dataclass

from numpy.typing import ArrayLike

from planner.errors import ConfigError
from planner.pitch.aperture import tracking_zone_start_m
from planner.pitch.types import FloatArray

#: casadi conic plugins offered (exact active-set or interior-point; qpoases prints a banner once).
SOLVERS = ("daqp", "qpoases", "highs")


def finite_value(value: float, key: str, *, lo: float | None = None, lo_open: bool = False) -> float:
    v = float(value)
    if not math.isfinite(v):
        raise ConfigError(f"must be finite, got {value!r}", key=key)
    if lo is not None and (v < lo or (lo_open and v == lo)):
        raise ConfigError(f"must be {'>' if lo_open else '>='} {lo:g}, got {value!r}", key=key)
    return v


@dataclass(frozen=True)
class MountLimits:
    """The tilt mount: angle limits (rad, positive down) and slew rate (rad/s)."""

    min_tilt_rad: float
    max_tilt_rad: float
    max_rate_rad_s: float

    def __post_init__(self) -> None:
        lo = finite_value(self.min_tilt_rad, "min_tilt_rad")
        hi = finite_value(self.max_tilt_rad, "max_tilt_rad")
        if not (-math.pi / 2 <= lo < hi <= math.pi / 2):
            raise ConfigError(f"need -pi/2 <= min < max <= pi/2, got [{lo!r}, {hi!r}]", key="max_tilt_rad")
        finite_value(self.max_rate_rad_s, "max_rate_rad_s", lo=0.0, lo_open=True)

    def clip(self, tilt_rad: float) -> float:
        """``tilt_rad`` limited to the mount's angle range, rad."""
        return min(max(float(tilt_rad), self.min_tilt_rad), self.max_tilt_rad)


@dataclass(frozen=True)
class PitchLoopConfig:
    """Settings of the pitch loop (validated on construction).

    Attributes
    ----------
    nominal_tilt_rad : float
        The planner's tilt for this altitude (seabed coverage), rad.
    elevation_aperture_rad, fan_width_rad : float
        Full vertical and horizontal openings of the sonar, rad.
    window_m : (float, float)
        Range window (first, last slant range), m.
    horizon_steps, dt_s : int, float
        Prediction horizon: number of steps and step length (the control period), s.
    margin_rad : float
        Elevation margin kept between the shadow and the aperture edges, rad.
    zone_lead_m : float
        A target is served while its shadow lies within the range window and the
        tracking zone *widened* by this much (slant / ground metres): they cannot be
        fixed by tilting, so serving a little early and late costs only beam freedom and
        covers the errors of predicted positions and heights. Inside this lead band
        only (not within the window and zone proper with the tall height prior) a
        target's slack weighs ``lead_weight_factor`` times less, so it never pulls the
        beam off a target that is properly within range.
    min_ground_range_over_altitude : float
        Tracking zone (:meth:`zone_start_m`): it never starts nearer than this many
        altitudes along the heading; targets whose far top edge is nearer than the zone's
        start are dropped (``"too_close"``): there the shadow sweeps faster than a mount
        follows, or it no longer fits one tilt with the farthest shadows in the window,
        and the target has been seen whole already.
    zone_fits_aperture : bool
        True (the default): the tracking zone starts where one tilt holds every shadow
        from there to the window's end (:func:`tracking_zone_start_m`), so targets in
        the zone never conflict. False: ``min_ground_range_over_altitude`` altitudes
        only, the plain zone (for comparison; there, targets in range can conflict).
    near_weight_factor : float
        The *near band*, between ``min_ground_range_over_altitude`` altitudes and the
        fitted zone's start (only with ``zone_fits_aperture``): targets there are served
        too, with their slack weighed this many times less (at least
        ``lead_weight_factor``), and where no tilt shows them together with the
        farther targets (in the zone or its lead band) they yield (``lead_weight_factor
        * near_weight_factor``, below any farther target), as they do where following
        them would take the window's far end out of the bare aperture while the search
        band (``search_weight_factor``) is on. So the loop keeps
        following a target in toward 2 altitudes whenever that costs no shadow in the
        zone: what a fixed tilt cannot do. 0 turns the band off (such targets are
        dropped as ``"too_close"``).
    height_prior_m, height_min_m : float
        Heights assumed for targets without an estimate, m: the tall prior for the
        aperture constraints (it puts the shadow end farther: safe), the short one for
        the range window check (the shadow may already be within range).
    pitch_accel_max_rad_s2 : float
        Bound on the vehicle's pitch acceleration; sets the envelope
        ``0.5 a dt^2`` of the pitch prediction over one step.
    pitch_rate_time_s : float
        Time constant over which the measured pitch rate is extrapolated, s.
    coverage_depression_rad : (float, float) or None
        Soft band on the beam-axis depression kept for the mosaic's coverage, rad.
    weight_slack_l1, weight_slack_l2 : float
        Cost per rad (and rad^2) of shadow-constraint violation.
    weight_nominal, weight_increment, weight_coverage : float
        Cost per rad^2 of distance to the nominal tilt, of tilt increments and (L1 and
        L2 alike, per rad) of leaving the coverage band.
    search_weight_factor : float
        Slack weight factor (relative to the shadow constraints') of a soft band on the
        depression that keeps the far end of the range window in view: the seabed at
        ``window_m[1]`` inside the shallow edge and the start of the shadow of a
        ``height_prior_m`` target ending there inside the steep edge (both less
        ``margin_rad``). A target entering the window is then seen whole at once, before
        any tracker knows it. Between ``lead_weight_factor`` and 1: tracked targets in
        range win over it, targets in the lead band yield to it. 0 turns it off.
    hold_start_s : float
        Each step's tilt must suit the geometry from this long after the step's start
        (the first frame it can act on: the mount's transit, the next ping) to its end, s;
        0 holds it from the start (the most cautious).
    max_targets : int
        Number of target slots in the QP; the nearest served targets fill them.
    solver : str
        casadi conic plugin, one of :data:`SOLVERS`.
    """

    nominal_tilt_rad: float
    elevation_aperture_rad: float = math.radians(14.0)
    fan_width_rad: float = math.radians(30.0)
    window_m: tuple[float, float] = (0.7, 12.0)
    horizon_steps: int = 10
    dt_s: float = 0.5
    margin_rad: float = math.radians(0.75)
    zone_lead_m: float = 0.3
    lead_weight_factor: float = 0.02
    min_ground_range_over_altitude: float = 2.0
    zone_fits_aperture: bool = True
    near_weight_factor: float = 0.25
    height_prior_m: float = 0.4
    height_min_m: float = 0.02
    pitch_accel_max_rad_s2: float = math.radians(12.0)
    pitch_rate_time_s: float = 1.0
    coverage_depression_rad: tuple[float, float] | None = None
    weight_slack_l1: float = 1000.0
    weight_slack_l2: float = 1.0e5
    weight_nominal: float = 1.0
    weight_increment: float = 20.0
    weight_coverage: float = 10.0
    search_weight_factor: float = 0.0
    hold_start_s: float = 0.0
    max_targets: int = 4
    solver: str = "daqp"

    def __post_init__(self) -> None:
        finite_value(self.nominal_tilt_rad, "nominal_tilt_rad")
        a = finite_value(self.elevation_aperture_rad, "elevation_aperture_rad", lo=0.0, lo_open=True)
        if a >= math.pi:
            raise ConfigError(f"must be < pi, got {a!r}", key="elevation_aperture_rad")
        f = finite_value(self.fan_width_rad, "fan_width_rad", lo=0.0, lo_open=True)
        if f >= math.pi:
            raise ConfigError(f"must be < pi, got {f!r}", key="fan_width_rad")
        w0, w1 = (float(v) for v in self.window_m)
        if not (math.isfinite(w1) and 0.0 <= w0 < w1):
            raise ConfigError(f"must satisfy 0 <= start < end, got {self.window_m!r}", key="window_m")
        if not (isinstance(self.horizon_steps, int) and 1 <= self.horizon_steps <= 100):
            raise ConfigError(f"must be a whole number in [1, 100], got {self.horizon_steps!r}",
                              key="horizon_steps")
        finite_value(self.dt_s, "dt_s", lo=0.0, lo_open=True)
        m = finite_value(self.margin_rad, "margin_rad", lo=0.0)
        if m >= a / 2:
            raise ConfigError(f"must be below half the aperture ({a / 2!r}), got {m!r}", key="margin_rad")
        finite_value(self.zone_lead_m, "zone_lead_m", lo=0.0)
        if not 0.0 < finite_value(self.lead_weight_factor, "lead_weight_factor", lo=0.0, lo_open=True) <= 1.0:
            raise ConfigError(f"must be in (0, 1], got {self.lead_weight_factor!r}", key="lead_weight_factor")
        finite_value(self.min_ground_range_over_altitude, "min_ground_range_over_altitude", lo=0.0)
        if not isinstance(self.zone_fits_aperture, bool):
            raise ConfigError(f"must be True or False, got {self.zone_fits_aperture!r}", key="zone_fits_aperture")
        if not finite_value(self.near_weight_factor, "near_weight_factor", lo=0.0) <= 1.0:
            raise ConfigError(f"must be in [0, 1], got {self.near_weight_factor!r}", key="near_weight_factor")
        finite_value(self.height_prior_m, "height_prior_m", lo=0.0)
        if not 0.0 <= finite_value(self.height_min_m, "height_min_m", lo=0.0) <= self.height_prior_m:
            raise ConfigError(f"must be <= height_prior_m, got {self.height_min_m!r}", key="height_min_m")
        finite_value(self.pitch_accel_max_rad_s2, "pitch_accel_max_rad_s2", lo=0.0)
        if 2.0 * (m + 0.5 * self.pitch_accel_max_rad_s2 * self.dt_s**2) >= a:
            raise ConfigError(f"the margin plus the pitch envelope over one step must be below half the aperture "
                              f"({a / 2!r}), got {m!r} + 0.5 * {self.pitch_accel_max_rad_s2!r} * {self.dt_s!r}^2",
                              key="pitch_accel_max_rad_s2")
        finite_value(self.pitch_rate_time_s, "pitch_rate_time_s", lo=0.0, lo_open=True)
        if self.coverage_depression_rad is not None:
            c0, c1 = (float(v) for v in self.coverage_depression_rad)
            if not (math.isfinite(c0) and math.isfinite(c1) and c0 <= c1):
                raise ConfigError(f"must be finite with lo <= hi, got {self.coverage_depression_rad!r}",
                                  key="coverage_depression_rad")
        if not 0.0 <= finite_value(self.hold_start_s, "hold_start_s", lo=0.0) <= self.dt_s:
            raise ConfigError(f"must be in [0, dt_s], got {self.hold_start_s!r}", key="hold_start_s")
        if not 0.0 <= finite_value(self.search_weight_factor, "search_weight_factor", lo=0.0) <= 1.0:
            raise ConfigError(f"must be in [0, 1], got {self.search_weight_factor!r}", key="search_weight_factor")
        for key in ("weight_slack_l1", "weight_coverage", "weight_nominal"):
            finite_value(getattr(self, key), key, lo=0.0)
        finite_value(self.weight_slack_l2, "weight_slack_l2", lo=0.0, lo_open=True)
        finite_value(self.weight_increment, "weight_increment", lo=0.0, lo_open=True)
        if not (isinstance(self.max_targets, int) and 1 <= self.max_targets <= 64):
            raise ConfigError(f"must be a whole number in [1, 64], got {self.max_targets!r}", key="max_targets")
        if self.solver not in SOLVERS:
            raise ConfigError(f"must be one of {SOLVERS}, got {self.solver!r}", key="solver")

    @property
    def pitch_envelope_rad(self) -> float:
        """Pitch-prediction envelope over one step, ``0.5 a_max dt^2``, rad."""
        return 0.5 * self.pitch_accel_max_rad_s2 * self.dt_s**2

    @property
    def zone_margin_rad(self) -> float:
        """The loop's margin at each aperture edge: ``margin_rad`` plus the pitch envelope, rad."""
        return self.margin_rad + self.pitch_envelope_rad

    def zone_start_m(self, altitude_m: ArrayLike) -> FloatArray:
        """Start of the tracking zone at ``altitude_m`` (m, any shape): :func:`tracking_zone_start_m`
        with this window's end, aperture, :attr:`zone_margin_rad`, ``min_ground_range_over_altitude``
        and the tall height prior, m."""
        return tracking_zone_start_m(altitude_m, window_end_m=float(self.window_m[1]),
                                     elevation_aperture_rad=self.elevation_aperture_rad,
                                     margin_rad=self.zone_margin_rad,
                                     min_over_altitude=self.min_ground_range_over_altitude,
                                     height_m=self.height_prior_m, fit_aperture=self.zone_fits_aperture)

    def near_start_m(self, altitude_m: ArrayLike) -> FloatArray:
        """Start of the near band (``near_weight_factor``) at ``altitude_m`` (m, any shape):
        ``min_ground_range_over_altitude`` altitudes, or the zone's start where the band
        is off, m."""
        if self.near_weight_factor <= 0.0 or not self.zone_fits_aperture:
            return self.zone_start_m(altitude_m)
        return tracking_zone_start_m(altitude_m, window_end_m=float(self.window_m[1]),
                                     elevation_aperture_rad=self.elevation_aperture_rad,
                                     margin_rad=self.zone_margin_rad,
                                     min_over_altitude=self.min_ground_range_over_altitude,
                                     height_m=self.height_prior_m, fit_aperture=False)
