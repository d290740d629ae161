"""The pitch loop: a short-horizon QP (casadi) that moves the sonar tilt mount so that the
whole cast shadow of every tracked target stays inside the vertical field of view.

Frames and signs are those of :mod:`perception.geometry`. Here the *level frame* is the
vehicle's heading frame: ``along_m`` forward along the heading (horizontal), ``cross_m``
to starboard, ``depth_m`` down, origin at the sonar's acoustic centre. Roll is ignored.

Geometry (flat seabed, sonar at altitude ``H``). The beam axis has depression
``d = tilt - pitch`` (tilt positive down, pitch positive nose up). A point at level
position ``(x, y, z)`` has, in the sonar frame, elevation ``e`` with
``sin e = k sin(delta' - d)``, where ``delta' = atan2(z, x)`` is the depression of its
projection on the vertical plane of the heading and ``k = hypot(x, z) / |p|``. So the
point is inside the vertical aperture ``a`` with elevation margin ``m`` exactly when

    delta' - w <= d <= delta' + w,   w = asin(min(1, sin(a/2 - m) / k))

which is *linear in d* (for a point on the axis, ``k = 1`` and ``w = a/2 - m``).

A target of height ``h`` with its far top edge at ``(x, y)`` and a footprint ``f``
(horizontal extent from its near foot to its far top edge, 0 for a post): the ray through
the top edge meets the seabed at the shadow end ``(x, y) H / (H - h)`` (slant
``r_end = r_top H / (H - h)``); top edge and shadow end share one ray and so one
elevation. The whole shadow is seen when the top/end ray, the far foot ``(x, y, H)``
and the near foot are all inside the aperture (the seabed between them lies between
these rays), and the slant ranges of the near foot and the shadow end lie inside the
range window. Each such target gives one interval ``[lo, hi]`` of ``d`` per step; the
range window cannot be fixed by tilting and only decides whether a target is served.

The QP over ``N`` steps of ``dt`` (decision ``tilt_1..tilt_N``, the mount angle held
through step ``k``, so it must suit the geometry at both of the step's ends):
``lo_ik + pitch_k + e <= tilt_k <= hi_ik + pitch_k - e`` softened by a
slack ``s_ik >= 0`` (L1 + L2 cost with a large weight, so it is met whenever it can
be), ``e`` the pitch-prediction envelope over one step, ``|tilt_k - tilt_{k-1}| <=
rate dt``, tilt limits as bounds, a small pull toward the nominal tilt (the planner's
tilt for this altitude: seabed coverage for the mosaic), an optional soft band on the
depression for coverage, and a weight on tilt increments (smoothness, no limit cycles).
The problem's structure is built once (a casadi ``conic``, default plugin daqp); every
step re-solves it with new bounds, linear terms and slack weights.

Targets that no tilt can serve (behind, outside the fan, outside the range window,
nearer than 2 altitudes, a shadow spanning more than the aperture, beyond the mount
limits) are dropped with a reason instead of dragging the beam. The window and zone
checks are widened by a lead (serve a little early and late, against prediction errors);
a target only within the lead band has its slack weighed far less, so it never pulls the
beam off a target properly within range. The *tracking zone* (one tilt holds every
shadow in it) is served in full; the *near band* between 2 altitudes and the zone's start
is served with a lower weight and yields in any conflict with the zone, so the beam
follows a target in as far as it costs no shadow in the zone.

Everything here is pure: no sockets, clocks, threads or files; the caller times solves.
:func:`simulate_pass` is a small closed-loop kinematic simulation used by the tests and
the benchmark.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

import casadi as ca
import numpy as np
from numpy.typing import ArrayLike, NDArray

from perception.errors import GeometryError, MeasurementError
from perception.geometry import ray_angles_sonar, sonar_to_ned
from planner.errors import ConfigError

FloatArray = NDArray[np.float64]

#: Reasons a target is not served (``DroppedShadow.reason``).
BEHIND = "behind"
OUTSIDE_FAN = "outside_fan"
BEYOND_WINDOW_END = "beyond_window_end"
BEFORE_WINDOW_START = "before_window_start"
TOO_CLOSE = "too_close"
EXTENT_EXCEEDS_APERTURE = "extent_exceeds_aperture"
BEYOND_MOUNT_LIMITS = "beyond_mount_limits"
TOO_MANY_TARGETS = "too_many_targets"

#: casadi conic plugins offered (exact active-set or interior-point; qpoases prints a banner once).
SOLVERS = ("daqp", "qpoases", "highs")


# --------------------------------------------------------------------------- data types


def _finite(value: float, key: str, *, lo: float | None = None, lo_open: bool = False) -> float:
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
        lo = _finite(self.min_tilt_rad, "min_tilt_rad")
        hi = _finite(self.max_tilt_rad, "max_tilt_rad")
        if not (-math.pi / 2 <= lo < hi <= math.pi / 2):
            raise ConfigError(f"need -pi/2 <= min < max <= pi/2, got [{lo!r}, {hi!r}]", key="max_tilt_rad")
        _finite(self.max_rate_rad_s, "max_rate_rad_s", lo=0.0, lo_open=True)

    def clip(self, tilt_rad: float) -> float:
        """``tilt_rad`` limited to the mount's angle range, rad."""
        return min(max(float(tilt_rad), self.min_tilt_rad), self.max_tilt_rad)


def tracking_zone_start_m(
    altitude_m: ArrayLike,
    *,
    window_end_m: float,
    elevation_aperture_rad: float,
    margin_rad: float,
    min_over_altitude: float = 2.0,
    height_m: float = 0.0,
    fit_aperture: bool = True,
) -> FloatArray:
    """Where the tracking zone starts: ground range ahead (along the heading, m) of a
    target's far top edge from which the loop keeps its shadow whole (and the scorer
    counts it *within range*). The zone runs from there to the far end of the range window.

    Two limits, the larger wins. ``min_over_altitude`` altitudes: nearer, the shadow
    sweeps through the aperture faster than a mount follows. And one tilt must hold every
    shadow in the zone with ``margin_rad`` at both aperture edges, so that targets in the
    zone never conflict: the steepest ray is the start of the shadow of a target of height
    ``height_m`` at the zone's start (the seabed at its top edge's slant range
    ``hypot(x0, H - h)``), the shallowest the seabed at the window's end ``w1``; so

        asin(H / hypot(x0, H - h)) - asin(H / w1) <= a - 2 m,

    i.e. ``hypot(x0, H - h) >= H / sin(D)``, ``D = asin(H / w1) + a - 2 m`` (no limit
    where ``D >= pi/2``). Flat seabed, point on the beam axis (off-axis points fit more
    easily), ``height_m`` the tallest target to expect (0: the seabed alone).

    Parameters
    ----------
    altitude_m : array_like
        Sonar altitude(s) over the seabed ``H``, m (> 0), any shape.
    window_end_m : float
        Last slant range of the range window ``w1``, m.
    elevation_aperture_rad, margin_rad : float
        Full vertical aperture ``a`` and the margin ``m`` kept at each of its edges, rad
        (``2 m < a``).
    min_over_altitude : float
        The zone never starts nearer than this many altitudes.
    height_m : float
        Tallest target height ``h``, m (``0 <= h``; clamped below ``H``).
    fit_aperture : bool
        False: the plain zone, ``min_over_altitude`` altitudes only (for comparison).

    Returns
    -------
    ndarray of float, shape of ``altitude_m``
        Zone start ``x0``, m; ``inf`` where the window does not reach the seabed
        (``w1 <= H``).
    """
    alt = np.asarray(altitude_m, dtype=np.float64)
    if np.any(~np.isfinite(alt)) or np.any(alt <= 0.0):
        raise GeometryError(f"altitude_m must be finite and > 0, got {altitude_m!r}")
    for key, value in (("window_end_m", window_end_m), ("elevation_aperture_rad", elevation_aperture_rad),
                       ("margin_rad", margin_rad), ("min_over_altitude", min_over_altitude),
                       ("height_m", height_m)):
        if not (math.isfinite(value) and value >= 0.0):
            raise GeometryError(f"{key} must be finite and >= 0, got {value!r}")
    if not 0.0 < elevation_aperture_rad - 2.0 * margin_rad < math.pi:
        raise GeometryError(f"need 0 < elevation_aperture_rad - 2 margin_rad < pi, got "
                            f"{elevation_aperture_rad!r} and {margin_rad!r}")
    reach = window_end_m > alt
    with np.errstate(divide="ignore", invalid="ignore"):
        shallow = np.arcsin(np.minimum(1.0, alt / window_end_m))
        steep = shallow + elevation_aperture_rad - 2.0 * margin_rad
        slant = alt / np.sin(np.minimum(steep, math.pi / 2))
        below = alt - np.minimum(height_m, 0.95 * alt)
        fit = np.where(steep >= math.pi / 2, 0.0, np.sqrt(np.maximum(0.0, slant**2 - below**2)))
    if not fit_aperture:
        fit = np.zeros_like(fit)
    return np.where(reach, np.maximum(min_over_altitude * alt, fit), np.inf)


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
        _finite(self.nominal_tilt_rad, "nominal_tilt_rad")
        a = _finite(self.elevation_aperture_rad, "elevation_aperture_rad", lo=0.0, lo_open=True)
        if a >= math.pi:
            raise ConfigError(f"must be < pi, got {a!r}", key="elevation_aperture_rad")
        f = _finite(self.fan_width_rad, "fan_width_rad", lo=0.0, lo_open=True)
        if f >= math.pi:
            raise ConfigError(f"must be < pi, got {f!r}", key="fan_width_rad")
        w0, w1 = (float(v) for v in self.window_m)
        if not (math.isfinite(w1) and 0.0 <= w0 < w1):
            raise ConfigError(f"must satisfy 0 <= start < end, got {self.window_m!r}", key="window_m")
        if not (isinstance(self.horizon_steps, int) and 1 <= self.horizon_steps <= 100):
            raise ConfigError(f"must be a whole number in [1, 100], got {self.horizon_steps!r}",
                              key="horizon_steps")
        _finite(self.dt_s, "dt_s", lo=0.0, lo_open=True)
        m = _finite(self.margin_rad, "margin_rad", lo=0.0)
        if m >= a / 2:
            raise ConfigError(f"must be below half the aperture ({a / 2!r}), got {m!r}", key="margin_rad")
        _finite(self.zone_lead_m, "zone_lead_m", lo=0.0)
        if not 0.0 < _finite(self.lead_weight_factor, "lead_weight_factor", lo=0.0, lo_open=True) <= 1.0:
            raise ConfigError(f"must be in (0, 1], got {self.lead_weight_factor!r}", key="lead_weight_factor")
        _finite(self.min_ground_range_over_altitude, "min_ground_range_over_altitude", lo=0.0)
        if not isinstance(self.zone_fits_aperture, bool):
            raise ConfigError(f"must be True or False, got {self.zone_fits_aperture!r}", key="zone_fits_aperture")
        if not _finite(self.near_weight_factor, "near_weight_factor", lo=0.0) <= 1.0:
            raise ConfigError(f"must be in [0, 1], got {self.near_weight_factor!r}", key="near_weight_factor")
        _finite(self.height_prior_m, "height_prior_m", lo=0.0)
        if not 0.0 <= _finite(self.height_min_m, "height_min_m", lo=0.0) <= self.height_prior_m:
            raise ConfigError(f"must be <= height_prior_m, got {self.height_min_m!r}", key="height_min_m")
        _finite(self.pitch_accel_max_rad_s2, "pitch_accel_max_rad_s2", lo=0.0)
        if 2.0 * (m + 0.5 * self.pitch_accel_max_rad_s2 * self.dt_s**2) >= a:
            raise ConfigError(f"the margin plus the pitch envelope over one step must be below half the aperture "
                              f"({a / 2!r}), got {m!r} + 0.5 * {self.pitch_accel_max_rad_s2!r} * {self.dt_s!r}^2",
                              key="pitch_accel_max_rad_s2")
        _finite(self.pitch_rate_time_s, "pitch_rate_time_s", lo=0.0, lo_open=True)
        if self.coverage_depression_rad is not None:
            c0, c1 = (float(v) for v in self.coverage_depression_rad)
            if not (math.isfinite(c0) and math.isfinite(c1) and c0 <= c1):
                raise ConfigError(f"must be finite with lo <= hi, got {self.coverage_depression_rad!r}",
                                  key="coverage_depression_rad")
        if not 0.0 <= _finite(self.hold_start_s, "hold_start_s", lo=0.0) <= self.dt_s:
            raise ConfigError(f"must be in [0, dt_s], got {self.hold_start_s!r}", key="hold_start_s")
        if not 0.0 <= _finite(self.search_weight_factor, "search_weight_factor", lo=0.0) <= 1.0:
            raise ConfigError(f"must be in [0, 1], got {self.search_weight_factor!r}", key="search_weight_factor")
        for key in ("weight_slack_l1", "weight_coverage", "weight_nominal"):
            _finite(getattr(self, key), key, lo=0.0)
        _finite(self.weight_slack_l2, "weight_slack_l2", lo=0.0, lo_open=True)
        _finite(self.weight_increment, "weight_increment", lo=0.0, lo_open=True)
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


@dataclass(frozen=True)
class TrackedShadow:
    """A target the loop serves, in the level frame at the time of the state.

    Attributes
    ----------
    target_id : int or str
        The tracker's id.
    along_m, cross_m : float
        Horizontal position of the target's far top edge from the sonar, m (forward
        along the heading, starboard).
    height_m : float or None
        Height estimate, m; None uses ``PitchLoopConfig.height_prior_m``.
    footprint_m : float
        Horizontal extent from the near foot to the far top edge along the line of
        sight, m (0 for a post).
    measured : bool
        True when this comes from the current sonar frame, False for a prediction
        (a previous pass's map, dead reckoning).
    """

    target_id: int | str
    along_m: float
    cross_m: float
    height_m: float | None = None
    footprint_m: float = 0.0
    measured: bool = False

    def __post_init__(self) -> None:
        for key in ("along_m", "cross_m", "footprint_m"):
            if not math.isfinite(float(getattr(self, key))):
                raise GeometryError(f"target {self.target_id!r}: {key} must be finite, got {getattr(self, key)!r}")
        if self.footprint_m < 0:
            raise GeometryError(f"target {self.target_id!r}: footprint_m must be >= 0, got {self.footprint_m!r}")
        if self.height_m is not None and not (math.isfinite(self.height_m) and self.height_m >= 0):
            raise GeometryError(f"target {self.target_id!r}: height_m must be finite and >= 0, got {self.height_m!r}")


@dataclass(frozen=True)
class PitchState:
    """What telemetry shows at the time of a control step.

    Attributes
    ----------
    altitude_m : float
        Sonar altitude above the seabed, m (> 0).
    vehicle_pitch_rad, pitch_rate_rad_s : float
        Vehicle pitch (nose up positive), rad, and its rate, rad/s.
    speed_m_s : float
        Horizontal speed along the heading, m/s (>= 0).
    current_tilt_rad : float
        The mount's present tilt, rad (positive down).
    climb_rate_m_s : float
        Rate of change of the altitude, m/s (positive up).
    predicted_pitch_rad : tuple of float or None
        The pitch at the ends of the next ``horizon_steps`` steps when the caller has
        a better prediction than the loop's extrapolation, rad.
    """

    altitude_m: float
    vehicle_pitch_rad: float
    speed_m_s: float
    current_tilt_rad: float
    pitch_rate_rad_s: float = 0.0
    climb_rate_m_s: float = 0.0
    predicted_pitch_rad: tuple[float, ...] | None = None

    def __post_init__(self) -> None:
        if not (math.isfinite(self.altitude_m) and self.altitude_m > 0):
            raise GeometryError(f"altitude_m must be finite and > 0, got {self.altitude_m!r}")
        if not (math.isfinite(self.speed_m_s) and self.speed_m_s >= 0):
            raise GeometryError(f"speed_m_s must be finite and >= 0, got {self.speed_m_s!r}")
        for key in ("vehicle_pitch_rad", "current_tilt_rad", "pitch_rate_rad_s", "climb_rate_m_s"):
            if not math.isfinite(float(getattr(self, key))):
                raise GeometryError(f"{key} must be finite, got {getattr(self, key)!r}")
        if self.predicted_pitch_rad is not None and not all(math.isfinite(p) for p in self.predicted_pitch_rad):
            raise GeometryError("predicted_pitch_rad must hold finite values")


@dataclass(frozen=True)
class ShadowMargin:
    """Predicted margins of one served target's shadow at the end of the first step.

    Elevation margins are angles (rad) in the sonar frame, positive inside:
    ``far_margin_rad`` from the shadow end's ray to the shallow aperture edge,
    ``near_margin_rad`` from the near foot's ray to the steep edge. Window margins are
    slant distances (m), positive inside the range window.
    """

    target_id: int | str
    far_margin_rad: float
    near_margin_rad: float
    window_far_margin_m: float
    window_near_margin_m: float
    constrained: bool

    @property
    def inside(self) -> bool:
        """True when the whole shadow is predicted inside the field of view."""
        return min(self.far_margin_rad, self.near_margin_rad, self.window_far_margin_m,
                   self.window_near_margin_m) >= 0.0


@dataclass(frozen=True)
class DroppedShadow:
    """A target the loop does not serve and why (one of the module's reason constants)."""

    target_id: int | str
    reason: str


@dataclass(frozen=True)
class PitchCommand:
    """The loop's answer for one control step.

    Attributes
    ----------
    tilt_rad : float
        Mount tilt to command now, rad (positive down); within the angle limits and
        reachable within one step at the rate limit.
    planned_tilt_rad : tuple of float
        The planned tilts at the ends of the ``horizon_steps`` steps, rad.
    margins : tuple of ShadowMargin
        Every served target's predicted margins with the commanded tilt.
    dropped : tuple of DroppedShadow
        Targets not served, with reasons.
    slack_rad : float
        Total violation of the shadow constraints at the first step (0 when all served
        shadows are kept inside with margin), rad.
    solver_ok : bool
        False when the QP solver failed; then the tilt holds the current one.
    """

    tilt_rad: float
    planned_tilt_rad: tuple[float, ...]
    margins: tuple[ShadowMargin, ...]
    dropped: tuple[DroppedShadow, ...]
    slack_rad: float = 0.0
    solver_ok: bool = True

    @property
    def tilt_deg(self) -> float:
        """The tilt in degrees, for MAV_CMD_DO_MOUNT_CONTROL."""
        return math.degrees(self.tilt_rad)


class TiltController(Protocol):
    """Anything that turns a state and the tracked shadows into a tilt command."""

    def step(self, state: PitchState, shadows: Sequence[TrackedShadow]) -> PitchCommand: ...


# --------------------------------------------------------------------------- geometry


def aperture_interval_rad(
    along_m: ArrayLike, cross_m: ArrayLike, depth_m: ArrayLike, *, half_aperture_rad: float
) -> tuple[FloatArray, FloatArray]:
    """Beam-axis depressions for which a point lies inside the vertical aperture.

    Parameters
    ----------
    along_m, cross_m, depth_m : array_like
        Point in the level frame relative to the sonar (forward, starboard, down), m;
        broadcast together.
    half_aperture_rad : float
        Half the vertical aperture less the wanted margin, rad (in (0, pi/2)).

    Returns
    -------
    lo_rad, hi_rad : ndarray
        The point's elevation in the sonar frame is within ``+-half_aperture_rad``
        exactly when the beam-axis depression ``d`` is in ``[lo, hi]`` (with ``d`` within
        ``+-pi/2`` of the point's in-plane depression).
    """
    x, y, z = np.broadcast_arrays(*(np.asarray(v, dtype=np.float64) for v in (along_m, cross_m, depth_m)))
    rho = np.hypot(x, z)
    k = rho / np.hypot(rho, y)
    with np.errstate(divide="ignore", invalid="ignore"):
        half = np.arcsin(np.minimum(1.0, math.sin(half_aperture_rad) / k))
    dep = np.arctan2(z, x)
    return dep - half, dep + half


def point_elevation_rad(
    along_m: ArrayLike, cross_m: ArrayLike, depth_m: ArrayLike, *, depression_rad: ArrayLike
) -> FloatArray:
    """Elevation (positive down) in the sonar frame of level-frame points, rad.

    ``sin e = k sin(delta' - d)`` (module docstring), the closed form the QP rests on.
    """
    x, y, z, d = np.broadcast_arrays(
        *(np.asarray(v, dtype=np.float64) for v in (along_m, cross_m, depth_m, depression_rad))
    )
    rho = np.hypot(x, z)
    k = rho / np.hypot(rho, y)
    return np.arcsin(np.clip(k * np.sin(np.arctan2(z, x) - d), -1.0, 1.0))


@dataclass(frozen=True)
class ShadowGeometry:
    """Level-frame points of targets' shadows at one or more times (arrays broadcast).

    ``top_*``: the far top edge (depth ``H - h``); the far foot is below it (depth
    ``H``); ``end_*``: the shadow end on the seabed; ``base_*``: the near foot;
    ``start_*``: the seabed point at the top edge's slant range on the top edge's
    bearing (depth ``H``): the image shows the shadow from that slant range on, so it
    too must be insonified (it is nearer than the far foot, by ``~ H h / g``). Slant
    ranges in m, bearing from the heading in rad.
    """

    altitude_m: FloatArray
    height_m: FloatArray
    top_along_m: FloatArray
    top_cross_m: FloatArray
    base_along_m: FloatArray
    base_cross_m: FloatArray
    end_slant_m: FloatArray
    near_slant_m: FloatArray
    base_ground_m: FloatArray
    bearing_rad: FloatArray
    start_along_m: FloatArray
    start_cross_m: FloatArray


def shadow_geometry(
    along_m: ArrayLike, cross_m: ArrayLike, height_m: ArrayLike, footprint_m: ArrayLike, altitude_m: ArrayLike
) -> ShadowGeometry:
    """Shadow points of targets (far top edge at ``(along, cross)``), arrays broadcast.

    Raises
    ------
    GeometryError
        Where a target is as tall as the sonar's altitude or taller (no shadow end).
    """
    x, y, h, f, alt = np.broadcast_arrays(
        *(np.asarray(v, dtype=np.float64) for v in (along_m, cross_m, height_m, footprint_m, altitude_m))
    )
    if np.any(h >= alt):
        raise GeometryError("a target is as tall as the sonar's altitude or taller: its shadow never ends")
    g = np.hypot(x, y)
    with np.errstate(divide="ignore", invalid="ignore"):
        shrink = np.where(g > 0, np.maximum(g - f, 0.0) / np.where(g > 0, g, 1.0), 0.0)
    bx, by = x * shrink, y * shrink
    r_top = np.sqrt(g**2 + (alt - h) ** 2)
    end = r_top * alt / (alt - h)
    near = np.minimum(np.minimum(r_top, np.sqrt(g**2 + alt**2)), np.sqrt(bx**2 + by**2 + alt**2))
    # The seabed at the top edge's slant range: ground sqrt(r_top^2 - H^2) on the same bearing.
    with np.errstate(divide="ignore", invalid="ignore"):
        start_scale = np.where(g > 0, np.sqrt(np.maximum(r_top**2 - alt**2, 0.0)) / np.where(g > 0, g, 1.0), 0.0)
    return ShadowGeometry(alt, h, x, y, bx, by, end, near, g * shrink, np.arctan2(y, x),
                          x * start_scale, y * start_scale)


def depression_interval_rad(geom: ShadowGeometry, *, half_aperture_rad: float,
                            include_base: bool = True) -> tuple[FloatArray, FloatArray]:
    """Beam-axis depressions that keep the whole shadow inside the aperture, rad.

    The intersection of the intervals of the top/end ray, the far foot, the near foot
    and the seabed at the shadow's start range (:func:`aperture_interval_rad`);
    ``lo > hi`` where the shadow spans more than ``2 half_aperture_rad``. Without
    ``include_base`` the near foot is left out: the shadow alone (for a target with a
    footprint, its near part is nearer than the shadow's start on the middle beams).
    """
    lo, hi = aperture_interval_rad(geom.top_along_m, geom.top_cross_m, geom.altitude_m - geom.height_m,
                                   half_aperture_rad=half_aperture_rad)
    points = [(geom.top_along_m, geom.top_cross_m), (geom.start_along_m, geom.start_cross_m)]
    if include_base:
        points.append((geom.base_along_m, geom.base_cross_m))
    for x, y in points:
        lo_p, hi_p = aperture_interval_rad(x, y, geom.altitude_m, half_aperture_rad=half_aperture_rad)
        lo, hi = np.maximum(lo, lo_p), np.minimum(hi, hi_p)
    return lo, hi


def shadow_margins_rad(geom: ShadowGeometry, *, depression_rad: ArrayLike,
                       elevation_aperture_rad: float) -> tuple[FloatArray, FloatArray]:
    """Elevation margins (rad, positive inside) of a shadow to the aperture's edges.

    Returns ``(far, near)``: the shallowest of the shadow's rays (top/end ray, far foot,
    near foot, seabed at the start range) to the shallow edge ``-a/2``, and the steepest
    to the steep edge ``+a/2``.
    """
    half = elevation_aperture_rad / 2.0
    e = [point_elevation_rad(geom.top_along_m, geom.top_cross_m, geom.altitude_m - geom.height_m,
                             depression_rad=depression_rad)]
    e += [point_elevation_rad(x, y, geom.altitude_m, depression_rad=depression_rad)
          for x, y in ((geom.top_along_m, geom.top_cross_m), (geom.base_along_m, geom.base_cross_m),
                       (geom.start_along_m, geom.start_cross_m))]
    return np.minimum.reduce(e) + half, half - np.maximum.reduce(e)


# --------------------------------------------------------------------------- measurements


def shadow_from_measurement(
    target_id: int | str,
    *,
    top_slant_m: float,
    end_slant_m: float,
    azimuth_rad: float,
    altitude_m: float,
    tilt_rad: float,
    pitch_rad: float,
    footprint_m: float = 0.0,
) -> TrackedShadow:
    """A measured shadow (slant ranges from range ZERO) as the loop's target model.

    ``h = H (r_end - r_top) / r_end``; the shadow end's ray has depression
    ``asin(H / r_end)``; with the beam azimuth and the pose of the frame that fixes its
    elevation (the root inside the aperture), hence the ray's level-frame direction, and
    the top edge lies on it at ``r_top`` (so ``g_top = sqrt(r_top^2 - (H - h)^2)``).

    Parameters
    ----------
    top_slant_m, end_slant_m : float
        Slant ranges of the target's top edge and of the shadow end, m.
    azimuth_rad : float
        Beam azimuth of the shadow in the sonar frame, rad (positive to starboard).
    altitude_m, tilt_rad, pitch_rad : float
        Sonar altitude (m), mount tilt and vehicle pitch (rad) when the frame was taken.

    Raises
    ------
    MeasurementError
        For ranges that are not finite, an end not beyond the top or nearer than the
        altitude, or a pose for which no ray of that beam meets the seabed there.
    """
    r_top, r_end, alt = float(top_slant_m), float(end_slant_m), float(altitude_m)
    if not all(math.isfinite(v) for v in (r_top, r_end, alt, azimuth_rad, tilt_rad, pitch_rad)):
        raise MeasurementError("non-finite shadow measurement or pose", sensor="sonar")
    if not (alt > 0 and 0 < r_top < r_end and r_end >= alt):
        raise MeasurementError(
            f"need 0 < top ({r_top!r} m) < end ({r_end!r} m) and end >= altitude ({alt!r} m)", sensor="sonar")
    h = alt * (r_end - r_top) / r_end
    d = tilt_rad - pitch_rad
    a_coef, b_coef = math.sin(d) * math.cos(azimuth_rad), math.cos(d)
    amp = math.hypot(a_coef, b_coef)
    ratio = (alt / r_end) / amp
    if ratio > 1.0 + 1e-12:
        raise MeasurementError(
            f"no ray of beam azimuth {azimuth_rad!r} rad reaches the seabed at {r_end!r} m with this pose",
            sensor="sonar")
    phi = math.atan2(b_coef, a_coef)
    spread = math.acos(min(1.0, ratio))
    roots = [phi - spread, phi + spread]
    roots = [math.atan2(math.sin(r), math.cos(r)) for r in roots]
    e = min(roots, key=abs)
    u = sonar_to_ned(tilt_rad=tilt_rad, pitch_rad=pitch_rad) @ np.array(
        [math.cos(e) * math.cos(azimuth_rad), math.cos(e) * math.sin(azimuth_rad), math.sin(e)])
    return TrackedShadow(target_id, float(r_top * u[0]), float(r_top * u[1]), h, footprint_m, True)


def shadow_measurement(
    shadow: TrackedShadow, *, altitude_m: float, tilt_rad: float, pitch_rad: float
) -> tuple[float, float, float]:
    """Forward model: what the sonar measures of a target, ``(r_top_m, r_end_m, azimuth_rad)``.

    A direct ray computation with :func:`perception.geometry.sonar_to_ned`
    (the inverse of :func:`shadow_from_measurement`; ``height_m`` must be set).
    """
    if shadow.height_m is None:
        raise GeometryError(f"target {shadow.target_id!r}: height_m is needed for a measurement")
    depth = altitude_m - shadow.height_m
    if depth <= 0:
        raise GeometryError(f"target {shadow.target_id!r} is as tall as the altitude or taller")
    p = np.array([shadow.along_m, shadow.cross_m, depth])
    r_top = float(np.linalg.norm(p))
    p_sonar = sonar_to_ned(tilt_rad=tilt_rad, pitch_rad=pitch_rad).T @ p
    az, _ = ray_angles_sonar(p_sonar)
    return r_top, r_top * altitude_m / depth, float(az)


def shadow_from_ned(
    target_id: int | str,
    *,
    target_ned_m: tuple[float, float],
    sonar_ned_m: tuple[float, float],
    heading_rad: float,
    height_m: float | None = None,
    footprint_m: float = 0.0,
) -> TrackedShadow:
    """A mapped target (far top edge at north/east ``target_ned_m``) in the level frame.

    For targets known from a previous pass but not in the current frame
    (``measured=False``).
    """
    dn, de = target_ned_m[0] - sonar_ned_m[0], target_ned_m[1] - sonar_ned_m[1]
    c, s = math.cos(heading_rad), math.sin(heading_rad)
    return TrackedShadow(target_id, dn * c + de * s, -dn * s + de * c, height_m, footprint_m, False)


# --------------------------------------------------------------------------- prediction


@dataclass(frozen=True)
class HorizonPrediction:
    """Predicted pitch, altitude and target geometry at the ends of the horizon's steps.

    ``pitch_rad`` and ``altitude_m`` have shape ``(N + 1,)`` (index 0 = now); the
    geometry arrays have shape ``(n_targets, N + 1)``. ``geometry`` uses the height
    estimates or the tall prior (aperture constraints), ``range_geometry`` the
    estimates or the short prior (range window check).
    """

    time_s: FloatArray
    pitch_rad: FloatArray
    altitude_m: FloatArray
    geometry: ShadowGeometry
    range_geometry: ShadowGeometry


def predict_pitch_rad(state: PitchState, config: PitchLoopConfig) -> FloatArray:
    """Pitch at ``t_k = k dt``, ``k = 0..N``: the caller's prediction, or the measured rate
    extrapolated with time constant ``pitch_rate_time_s`` (rad, shape ``(N + 1,)``)."""
    n = config.horizon_steps
    if state.predicted_pitch_rad is not None:
        if len(state.predicted_pitch_rad) != n:
            raise GeometryError(f"predicted_pitch_rad must hold {n} values, got {len(state.predicted_pitch_rad)}")
        return np.concatenate([[state.vehicle_pitch_rad], np.asarray(state.predicted_pitch_rad, dtype=np.float64)])
    t = np.arange(n + 1) * config.dt_s
    tau = config.pitch_rate_time_s
    return state.vehicle_pitch_rad + state.pitch_rate_rad_s * tau * (1.0 - np.exp(-t / tau))


def predict_horizon(state: PitchState, shadows: Sequence[TrackedShadow], config: PitchLoopConfig) -> HorizonPrediction:
    """The kinematic model: the vehicle advances along its heading at ``speed_m_s`` and
    climbs at ``climb_rate_m_s``; targets stay put on the seabed."""
    n = config.horizon_steps
    t = np.arange(n + 1) * config.dt_s
    alt = state.altitude_m + state.climb_rate_m_s * t
    if np.any(alt <= 0):
        raise GeometryError("the predicted altitude reaches the seabed within the horizon")
    along = np.array([[s.along_m] for s in shadows]).reshape(-1, 1) - state.speed_m_s * t
    cross = np.array([[s.cross_m] for s in shadows]).reshape(-1, 1)
    foot = np.array([[s.footprint_m] for s in shadows]).reshape(-1, 1)
    geoms = []
    for prior in (config.height_prior_m, config.height_min_m):
        height = np.array([[prior if s.height_m is None else s.height_m] for s in shadows]).reshape(-1, 1)
        height = np.minimum(height, 0.95 * alt.min())  # a height up to the altitude: clamp
        geoms.append(shadow_geometry(along, cross, height, foot, alt))
    return HorizonPrediction(np.asarray(t, dtype=np.float64), predict_pitch_rad(state, config),
                             np.asarray(alt, dtype=np.float64), geoms[0], geoms[1])


def _serviceability(pred: HorizonPrediction, config: PitchLoopConfig, limits: MountLimits,
                    envelope_rad: float) -> tuple[FloatArray, FloatArray, NDArray[np.object_], NDArray[np.bool_],
                                                  FloatArray, NDArray[np.bool_]]:
    """Tilt bounds ``(L, U)`` per (target, step), the reason each is not served ('' if
    served), whether it is within the window and zone proper (not only the lead band), ``L``
    for the shadow alone (without the target's footprint), and whether it is within the
    window and the near band (``PitchLoopConfig.near_weight_factor``).

    ``L > U`` where the margins and the envelope leave no room but the bare aperture
    does: such a target is still served and the QP centres it. It is dropped only when
    no tilt within the mount's limits fits it even without margins (short height prior).
    """
    g, gr = pred.geometry, pred.range_geometry
    lead = config.zone_lead_m
    lo, hi = depression_interval_rad(g, half_aperture_rad=config.elevation_aperture_rad / 2 - config.margin_rad)
    low_t = lo + pred.pitch_rad + envelope_rad
    up_t = hi + pred.pitch_rad - envelope_rad
    lo_s, _ = depression_interval_rad(g, half_aperture_rad=config.elevation_aperture_rad / 2 - config.margin_rad,
                                      include_base=False)
    low_shadow = lo_s + pred.pitch_rad + envelope_rad
    lo0, hi0 = depression_interval_rad(gr, half_aperture_rad=config.elevation_aperture_rad / 2)
    w0, w1 = config.window_m
    zone_start = config.zone_start_m(pred.altitude_m)
    near_start = config.near_start_m(pred.altitude_m)
    reason = np.full(lo.shape, "", dtype=object)
    checks = [
        (hi0 < lo0, EXTENT_EXCEEDS_APERTURE),
        ((lo0 + pred.pitch_rad > limits.max_tilt_rad) | (hi0 + pred.pitch_rad < limits.min_tilt_rad),
         BEYOND_MOUNT_LIMITS),
        (g.top_along_m < near_start - lead, TOO_CLOSE),
        (g.near_slant_m < w0 - lead, BEFORE_WINDOW_START),
        (gr.end_slant_m > w1 + lead, BEYOND_WINDOW_END),
        (np.abs(g.bearing_rad) > config.fan_width_rad / 2, OUTSIDE_FAN),
        (g.top_along_m <= 0, BEHIND),
    ]
    for bad, why in checks:  # the last one that applies wins: the most basic reason
        reason[bad] = why
    window = (g.near_slant_m >= w0) & (g.end_slant_m <= w1)
    core = (g.top_along_m >= zone_start) & window
    near = (g.top_along_m >= near_start) & (g.top_along_m < zone_start) & window
    return low_t, up_t, reason, core, low_shadow, near


# --------------------------------------------------------------------------- the loop


def search_band_rad(pred: HorizonPrediction, config: PitchLoopConfig) -> tuple[FloatArray, FloatArray] | None:
    """Depressions that keep the far end of the range window in view, rad, shape ``(N + 1,)``
    each (see ``PitchLoopConfig.search_weight_factor``); None when turned off.

    ``hi = asin(H / w1) + a/2 - m`` puts the seabed at the window's last slant range
    ``w1`` on the shallow edge less the margin; ``lo = asin(H / r) - (a/2 - m)`` with
    ``r = w1 (H - h) / H`` (``h`` the tall prior) puts the start of the shadow of a target
    whose shadow ends at ``w1`` on the steep edge; ``lo`` is capped at ``hi``. Where the
    window ends above the seabed (``w1 <= H``) the band is unbounded.
    """
    if config.search_weight_factor <= 0.0:
        return None
    alt = pred.altitude_m
    w1 = config.window_m[1]
    half = config.elevation_aperture_rad / 2 - config.margin_rad
    h = np.minimum(config.height_prior_m, 0.95 * alt)
    reach = w1 > alt
    with np.errstate(divide="ignore", invalid="ignore"):
        hi = np.where(reach, np.arcsin(np.minimum(1.0, alt / w1)) + half, np.inf)
        r_start = w1 * (alt - h) / alt
        lo = np.where(reach, np.arcsin(np.minimum(1.0, alt / r_start)) - half, -np.inf)
    return np.minimum(lo, hi), hi


class PitchLoop:
    """The MPC pitch loop. Build once per configuration; call :meth:`step` each control step.

    The only state it keeps is the solver (built once); every step is a function of its
    arguments.
    """

    def __init__(self, config: PitchLoopConfig, limits: MountLimits):
        self.config = config
        self.limits = limits
        n, m = config.horizon_steps, config.max_targets
        self._n, self._m = n, m
        nx = n + n * m + n + n  # tilts, target slacks (step-major), coverage slacks, search slacks
        self._nx = nx
        s0, c0, q0 = n, n + n * m, n + n * m + n
        hess = np.zeros((nx, nx))
        wi, wn = config.weight_increment, config.weight_nominal
        for k in range(n):
            hess[k, k] += 2.0 * (wi + wn) + (2.0 * wi if k < n - 1 else 0.0)
            if k < n - 1:
                hess[k, k + 1] = hess[k + 1, k] = -2.0 * wi
        hess[s0:c0, s0:c0] = np.eye(n * m) * 2.0 * config.weight_slack_l2
        hess[c0:q0, c0:q0] = np.eye(n) * 2.0 * config.weight_coverage
        hess[q0:, q0:] = np.eye(n) * 2.0 * config.weight_slack_l2 * max(config.search_weight_factor, 1e-3)
        rows = 2 * n * m + 2 * n + (n - 1) + 2 * n
        a = np.zeros((rows, nx))
        r = 0
        for k in range(n):
            for i in range(m):
                a[r, k], a[r, s0 + k * m + i] = 1.0, 1.0
                a[r + 1, k], a[r + 1, s0 + k * m + i] = 1.0, -1.0
                r += 2
        for k in range(n):
            a[r, k], a[r, c0 + k] = 1.0, 1.0
            a[r + 1, k], a[r + 1, c0 + k] = 1.0, -1.0
            r += 2
        for k in range(1, n):
            a[r, k], a[r, k - 1] = 1.0, -1.0
            r += 1
        for k in range(n):
            a[r, k], a[r, q0 + k] = 1.0, 1.0
            a[r + 1, k], a[r + 1, q0 + k] = 1.0, -1.0
            r += 2
        self._a = a
        self._s0, self._c0, self._q0 = s0, c0, q0
        self._hess_dm, self._a_dm = ca.sparsify(ca.DM(hess)), ca.sparsify(ca.DM(a))
        opts: dict[str, Any] = {"error_on_fail": False}
        if config.solver == "qpoases":
            opts["printLevel"] = "none"
        elif config.solver == "highs":
            opts["highs"] = {"output_flag": False}
        self._hess_sp = self._hess_dm.sparsity()
        self._hess_nz = np.asarray(self._hess_dm.nonzeros(), dtype=np.float64)
        nz_rows = np.asarray(self._hess_sp.row())
        nz_cols = np.asarray(self._hess_sp.get_col())
        diag = {int(r): j for j, (r, c) in enumerate(zip(nz_rows, nz_cols, strict=True)) if r == c}
        self._slack_nz = np.array([diag[s0 + j] for j in range(n * m)])  # slack j = k * m + slot
        self._solver = ca.conic("pitch_loop_qp", config.solver,
                                {"h": self._hess_dm.sparsity(), "a": self._a_dm.sparsity()}, opts)

    @property
    def envelope_rad(self) -> float:
        """Pitch-prediction envelope over one step, ``0.5 a_max dt^2``, rad."""
        return self.config.pitch_envelope_rad

    def step(self, state: PitchState, shadows: Sequence[TrackedShadow]) -> PitchCommand:
        """One control step: the tilt to command now.

        Parameters
        ----------
        state : PitchState
            Telemetry at the step.
        shadows : sequence of TrackedShadow
            The tracked targets ahead (measured this frame or predicted), level frame.

        Returns
        -------
        PitchCommand
        """
        cfg, lim = self.config, self.limits
        n, m = self._n, self._m
        t0 = lim.clip(state.current_tilt_rad)
        served, dropped, low, up, factor, pred = _select(state, shadows, cfg, lim, self.envelope_rad)
        weight = np.ones((n, m))  # slack weight factors, (step, slot)
        lba = np.full(self._a.shape[0], -np.inf)
        uba = np.full(self._a.shape[0], np.inf)
        for slot, (i, _) in enumerate(served):
            for k in range(n):
                if np.isfinite(low[i, k + 1]):
                    r = 2 * (k * m + slot)
                    lba[r], uba[r + 1] = low[i, k + 1], up[i, k + 1]
                    weight[k, slot] = factor[i, k + 1]
        if cfg.coverage_depression_rad is not None:
            base = 2 * n * m
            for k in range(n):
                lba[base + 2 * k] = cfg.coverage_depression_rad[0] + pred.pitch_rad[k + 1]
                uba[base + 2 * k + 1] = cfg.coverage_depression_rad[1] + pred.pitch_rad[k + 1]
        step_max = lim.max_rate_rad_s * cfg.dt_s
        inc0 = 2 * n * m + 2 * n
        lba[inc0:inc0 + n - 1] = -step_max
        uba[inc0:inc0 + n - 1] = step_max
        lbx = np.zeros(self._nx)
        ubx = np.full(self._nx, np.inf)
        search = search_band_rad(pred, cfg)
        if search is None:
            ubx[self._q0:] = 0.0
        else:
            lba[inc0 + n - 1::2] = search[0][1:] + pred.pitch_rad[1:]
            uba[inc0 + n::2] = search[1][1:] + pred.pitch_rad[1:]
        lbx[:n], ubx[:n] = lim.min_tilt_rad, lim.max_tilt_rad
        first_lo, first_hi = max(lim.min_tilt_rad, t0 - step_max), min(lim.max_tilt_rad, t0 + step_max)
        lbx[0], ubx[0] = first_lo, first_hi
        g = np.zeros(self._nx)
        g[:n] = -2.0 * cfg.weight_nominal * cfg.nominal_tilt_rad
        g[0] += -2.0 * cfg.weight_increment * t0
        g[self._s0:self._c0] = cfg.weight_slack_l1 * weight.ravel()
        g[self._c0:self._q0] = cfg.weight_coverage
        g[self._q0:] = cfg.weight_slack_l1 * cfg.search_weight_factor
        hess_nz = self._hess_nz.copy()
        hess_nz[self._slack_nz] = 2.0 * cfg.weight_slack_l2 * weight.ravel()
        hess = ca.DM(self._hess_sp, hess_nz)
        sol = self._solver(h=hess, g=g, a=self._a_dm, lba=lba, uba=uba, lbx=lbx, ubx=ubx)
        ok = bool(self._solver.stats().get("success", False))
        x = np.asarray(sol["x"]).ravel()
        if ok and np.all(np.isfinite(x)):
            plan = np.clip(x[:n], lim.min_tilt_rad, lim.max_tilt_rad)
            tilt = float(min(max(plan[0], first_lo), first_hi))
        else:
            ok, plan, tilt = False, np.full(n, t0), t0
        idx = [i for i, _ in served]  # NaN bounds (not served at step 1) count as no violation
        slack = float(np.sum(np.fmax(0.0, low[idx, 1] - tilt)) + np.sum(np.fmax(0.0, tilt - up[idx, 1])))
        return PitchCommand(tilt, tuple(float(v) for v in plan),
                            _margins(pred, shadows, served, tilt, cfg), tuple(dropped), slack, ok)


class FixedTilt:
    """The baseline: the same interface, always the nominal tilt (within the limits)."""

    def __init__(self, config: PitchLoopConfig, limits: MountLimits):
        self.config = config
        self.limits = limits

    def step(self, state: PitchState, shadows: Sequence[TrackedShadow]) -> PitchCommand:
        """Return the nominal tilt, with the margins and drops it implies."""
        cfg, lim = self.config, self.limits
        target = lim.clip(cfg.nominal_tilt_rad)
        step_max = lim.max_rate_rad_s * cfg.dt_s
        t0 = lim.clip(state.current_tilt_rad)
        tilt = min(max(target, t0 - step_max), t0 + step_max)
        served, dropped, low, up, _, pred = _select(state, shadows, cfg, lim, 0.0)
        idx = [i for i, _ in served]
        slack = float(np.sum(np.fmax(0.0, low[idx, 1] - tilt)) + np.sum(np.fmax(0.0, tilt - up[idx, 1])))
        return PitchCommand(tilt, (target,) * cfg.horizon_steps, _margins(pred, shadows, served, tilt, cfg),
                            tuple(dropped), slack, True)


def _select(state: PitchState, shadows: Sequence[TrackedShadow], cfg: PitchLoopConfig, lim: MountLimits,
            envelope_rad: float) -> tuple[list[tuple[int, bool]], list[DroppedShadow], FloatArray, FloatArray,
                                          FloatArray, HorizonPrediction]:
    """Targets to serve (index, served at step 1), those dropped, tilt bounds, slack weight
    factors (1 within range proper, ``near_weight_factor`` in the near band,
    ``lead_weight_factor`` in the lead band), prediction."""
    pred = predict_horizon(state, shadows, cfg)
    if not shadows:
        empty = np.zeros((0, cfg.horizon_steps + 1))
        return [], [], empty, empty, empty, pred
    low, up, reason, core, low_shadow, near = _serviceability(pred, cfg, lim, envelope_rad)
    ok = reason == ""
    core = core & ok
    near = near & ok
    low = np.where(ok, low, np.nan)
    low_shadow = np.where(ok, low_shadow, np.nan)
    up = np.where(ok, up, np.nan)
    # The mount reaches each command quickly and holds it through the step while the
    # target moves: tilt_k must suit the geometry at both ends of step k (at the ends
    # where the target is served: it may enter or leave during the step).
    ok[:, 1:] = ok[:, 1:] | ok[:, :-1]
    core[:, 1:] = core[:, 1:] | core[:, :-1]
    near[:, 1:] = (near[:, 1:] | near[:, :-1]) & ~core[:, 1:]
    near_factor = max(cfg.near_weight_factor, cfg.lead_weight_factor)
    factor = np.where(core, 1.0, np.where(near, near_factor, cfg.lead_weight_factor))
    w = min(max(cfg.hold_start_s / cfg.dt_s, 0.0), 1.0)
    low[:, 1:] = np.fmax(low[:, 1:], _held_from(low, w))
    low_shadow[:, 1:] = np.fmax(low_shadow[:, 1:], _held_from(low_shadow, w))
    up[:, 1:] = np.fmin(up[:, 1:], _held_from(up, w))
    dropped: list[DroppedShadow] = []
    candidates: list[tuple[float, int]] = []
    for i, s in enumerate(shadows):
        if ok[i, 1:].any():
            candidates.append((float(pred.geometry.top_along_m[i, 0]), i))
        else:
            dropped.append(DroppedShadow(s.target_id, str(reason[i, 1])))
    candidates.sort()
    served = [(i, bool(ok[i, 1])) for _, i in candidates[: cfg.max_targets]]
    dropped += [DroppedShadow(shadows[i].target_id, TOO_MANY_TARGETS) for _, i in candidates[cfg.max_targets:]]
    firm = np.array([s.measured or s.height_m is not None for s in shadows])
    sides = None
    watch = None
    if cfg.near_weight_factor > 0.0 and cfg.zone_fits_aperture:
        nearer = ok & (pred.geometry.top_along_m < cfg.zone_start_m(pred.altitude_m))
        sides = (ok & ~nearer, nearer)
        search = search_band_rad(pred, cfg)
        if search is not None:  # the window's far end in the bare aperture, as tilts
            watch = (search[0] - cfg.margin_rad + pred.pitch_rad, search[1] + cfg.margin_rad + pred.pitch_rad)
    _yield_in_conflicts(pred, [i for i, _ in served], core & ok, factor, cfg, firm, sides, watch)
    _footprints_yield(low, low_shadow, up, factor, [i for i, _ in served])
    return served, dropped, low, up, factor, pred


def _footprints_yield(low: FloatArray, low_shadow: FloatArray, up: FloatArray, factor: FloatArray,
                      idx: list[int]) -> None:
    """A target's footprint (its near part, nearer than its shadow) is kept in the beam
    only where that costs no other fully weighted target's shadow: where its bound with
    the footprint lies beyond another's opposite bound, its shadow's own bound is used
    (``low`` is changed in place; arrays of shape ``(n_targets, N + 1)``)."""
    if len(idx) < 2:
        return
    for k in range(1, low.shape[1]):
        active = [i for i in idx if factor[i, k] >= 1.0 and np.isfinite(low[i, k])]
        for i in active:
            others = [float(up[j, k]) for j in active if j != i]
            if others and low[i, k] > min(others):
                low[i, k] = low_shadow[i, k]


def _held_from(bound: FloatArray, fraction: float) -> FloatArray:
    """A bound at the first instant each step's tilt acts on a frame: ``fraction`` of the
    way from the step's start to its end (linear), shape ``(n, N)`` from ``(n, N + 1)``;
    NaN where the bound is NaN at the start (not served then)."""
    start, end = bound[:, :-1], bound[:, 1:]
    return np.where(np.isnan(start), np.nan, start + fraction * np.nan_to_num(end - start))


def _yield_in_conflicts(pred: HorizonPrediction, idx: list[int], core: NDArray[np.bool_], factor: FloatArray,
                        cfg: PitchLoopConfig, firm: NDArray[np.bool_],
                        sides: tuple[NDArray[np.bool_], NDArray[np.bool_]] | None = None,
                        watch: tuple[FloatArray, FloatArray] | None = None) -> None:
    """Where no tilt shows several targets in range whole at once, the nearer ones yield.

    Per step, the targets within range proper are taken from the farthest to the nearest;
    one whose bare shadow interval (no margin, no envelope, no footprint) misses the
    common interval of those taken before it, at both ends of the step, gets
    ``lead_weight_factor`` (``factor`` is changed in place, shape ``(n_targets, N + 1)``).
    Without this the QP would split the violation and lose both; and the nearer target is
    the one about to leave the tracking zone, seen whole on its way in, while the farther
    one stays in range longer (keeping the nearer would cost the farther one as many
    frames plus the slew back to it). Targets seen in this frame or with a height come
    before those known only from memory with no height (``firm``, shape ``(n_targets,)``):
    a guess with the tall height prior never displaces a shadow actually seen.

    With the near band on, ``sides = (farther, nearer)`` (served targets at or beyond the
    zone's start, and nearer than it; each ``(n_targets, N + 1)``): a second pass takes
    every farther target (in range proper or only in the lead band: its shadow may well
    be in range while the tall prior says otherwise) before the nearer ones, and a nearer
    one that misses them (here with the loop's margin, ``zone_margin_rad``, at both
    aperture edges) gets ``lead_weight_factor * near_weight_factor``, below any farther
    target's weight: the near band never takes the beam, or its margin, from the zone.
    With ``watch`` (tilt bounds per step, shape ``(N + 1,)`` each: the search band widened
    to the bare aperture) the farther side starts from it: a nearer target is also given
    up where following it would take the window's far end out of the aperture, so that a
    target entering the window, not tracked yet, is still seen (and then tracked).
    """
    if len(idx) < (1 if watch is not None else 2):
        return
    lo, hi = depression_interval_rad(pred.geometry, half_aperture_rad=cfg.elevation_aperture_rad / 2,
                                     include_base=False)
    lo = lo + pred.pitch_rad
    hi = hi + pred.pitch_rad
    w = min(max(cfg.hold_start_s / cfg.dt_s, 0.0), 1.0)
    bare = ((_held_from(lo, w), _held_from(hi, w), -1), (lo, hi, 0))
    along = pred.geometry.top_along_m

    def misfits(order: list[int], k: int, ends: tuple = bare, watched: bool = False) -> set[int]:
        """Targets of ``order`` (taken in turn) that miss the common interval of those
        before them (and of ``watch`` when ``watched``) at both ends of step ``k``: a
        conflict only when there is one at both."""
        yielding: set[int] | None = None
        for lo_j, hi_j, shift in ends:
            common_lo, common_hi = -math.inf, math.inf
            if watched and watch is not None:
                common_lo, common_hi = float(watch[0][k + shift]), float(watch[1][k + shift])
            here: set[int] = set()
            for i in order:
                new_lo, new_hi = max(common_lo, float(lo_j[i, k + shift])), min(common_hi, float(hi_j[i, k + shift]))
                if new_lo <= new_hi:
                    common_lo, common_hi = new_lo, new_hi
                else:
                    here.add(i)
            yielding = here if yielding is None else yielding & here
        return yielding or set()

    near_yield = cfg.lead_weight_factor * cfg.near_weight_factor
    if sides is not None:  # the near band must not cost a farther target even its margin
        lo_m, hi_m = depression_interval_rad(pred.geometry, half_aperture_rad=cfg.elevation_aperture_rad / 2
                                             - cfg.zone_margin_rad, include_base=False)
        lo_m, hi_m = lo_m + pred.pitch_rad, hi_m + pred.pitch_rad
        with_margin = ((_held_from(lo_m, w), _held_from(hi_m, w), -1), (lo_m, hi_m, 0))
    for k in range(1, lo.shape[1]):
        def key(i: int, k: int = k) -> tuple[bool, float]:
            return (not firm[i], -float(along[i, k]))

        for i in misfits(sorted((i for i in idx if core[i, k]), key=key), k):
            factor[i, k] = min(factor[i, k], cfg.lead_weight_factor)
        if sides is not None:
            nearer = sorted((i for i in idx if sides[1][i, k]), key=key)
            if nearer:
                farther = sorted((i for i in idx if sides[0][i, k]), key=key)
                for i in misfits(farther + nearer, k, with_margin, watched=True) & set(nearer):
                    factor[i, k] = min(factor[i, k], near_yield)


def _margins(pred: HorizonPrediction, shadows: Sequence[TrackedShadow], served: list[tuple[int, bool]],
             tilt_rad: float, cfg: PitchLoopConfig) -> tuple[ShadowMargin, ...]:
    if not served:
        return ()
    idx = [i for i, _ in served]
    g = pred.geometry
    sub = ShadowGeometry(*(np.asarray(getattr(g, f))[idx, 1] for f in ShadowGeometry.__dataclass_fields__))
    far, near = shadow_margins_rad(sub, depression_rad=tilt_rad - pred.pitch_rad[1],
                                   elevation_aperture_rad=cfg.elevation_aperture_rad)
    w0, w1 = cfg.window_m
    return tuple(
        ShadowMargin(shadows[i].target_id, float(far[j]), float(near[j]), float(w1 - sub.end_slant_m[j]),
                     float(sub.near_slant_m[j] - w0), now)
        for j, (i, now) in enumerate(served)
    )


# --------------------------------------------------------------------------- closed-loop simulation


@dataclass(frozen=True)
class SeabedTarget:
    """A target on a flat seabed: far top edge at lane position ``(along_m, cross_m)``, m."""

    target_id: int
    along_m: float
    cross_m: float
    height_m: float
    footprint_m: float = 0.0


@dataclass(frozen=True)
class PassScenario:
    """One straight pass at constant altitude and speed over a field of targets.

    The vehicle's sonar starts at lane position 0 and advances at ``speed_m_s``; the pitch
    disturbance is ``amplitude sin(2 pi f t + phase)``. Noise levels are standard
    deviations of what the controller is given; frames come every ``frame_period_s``,
    control steps every ``PitchLoopConfig.dt_s``. Frames before ``settle_s`` are not scored.
    """

    altitude_m: float
    speed_m_s: float
    pitch_amplitude_rad: float
    pitch_frequency_hz: float
    pitch_phase_rad: float
    targets: tuple[SeabedTarget, ...]
    duration_s: float
    frame_period_s: float = 0.1
    settle_s: float = 5.0
    range_noise_m: float = 0.01
    azimuth_noise_rad: float = math.radians(0.2)
    altitude_noise_m: float = 0.01
    pitch_noise_rad: float = math.radians(0.1)
    prior_position_noise_m: float = 0.1
    tracker_gain: float = 0.3
    lookahead_m: float = 16.0


@dataclass(frozen=True)
class PassResult:
    """Truth of a simulated pass. Frame arrays have shape ``(F,)`` or ``(F, T)`` for T targets.

    ``in_range``: the target's whole shadow lies in the range window and the fan, it is in
    the tracking zone, and some tilt within the mount's limits would show it whole
    (elevation margin 0, true pitch). ``visible``: the whole shadow is inside the field
    of view (direct ray computation). ``jointly_feasible``: one tilt could show all
    in-range targets at once.
    """

    time_s: FloatArray
    tilt_rad: FloatArray
    pitch_rad: FloatArray
    command_tilt_rad: FloatArray
    in_range: NDArray[np.bool_]
    visible: NDArray[np.bool_]
    jointly_feasible: NDArray[np.bool_]
    settled: NDArray[np.bool_]
    solver_failures: int
    command_time_s: FloatArray = field(default_factory=lambda: np.zeros(0))

    @property
    def scored_frames(self) -> int:
        """Number of (frame, target) pairs scored: settled and in range."""
        return int(np.sum(self.in_range & self.settled[:, None]))

    @property
    def visible_frames(self) -> int:
        """Scored (frame, target) pairs with the whole shadow in view."""
        return int(np.sum(self.in_range & self.visible & self.settled[:, None]))

    @property
    def feasible_scored_frames(self) -> int:
        """Scored pairs in frames where one tilt could show every in-range target."""
        return int(np.sum(self.in_range & (self.settled & self.jointly_feasible)[:, None]))

    @property
    def feasible_visible_frames(self) -> int:
        """Of those, the pairs with the whole shadow in view."""
        return int(np.sum(self.in_range & self.visible & (self.settled & self.jointly_feasible)[:, None]))

    def sign_changes_per_minute(self, deadband_rad: float = math.radians(0.1)) -> float:
        """Sign changes of the commanded tilt increments per minute (settled part)."""
        settled_t = self.command_time_s >= self.time_s[self.settled][0] if np.any(self.settled) else None
        if settled_t is None:
            return 0.0
        return tilt_sign_changes(self.command_tilt_rad[settled_t], deadband_rad=deadband_rad) / max(
            (self.time_s[-1] - self.time_s[self.settled][0]) / 60.0, 1e-9)


def tilt_sign_changes(tilt_rad: ArrayLike, *, deadband_rad: float) -> int:
    """Sign changes of the increments of a tilt series, increments within the deadband ignored."""
    inc = np.diff(np.asarray(tilt_rad, dtype=np.float64))
    signs = np.sign(inc[np.abs(inc) > deadband_rad])
    return int(np.count_nonzero(signs[1:] != signs[:-1]))


def whole_shadow_visible(
    geom: ShadowGeometry, *, tilt_rad: float, pitch_rad: float, config: PitchLoopConfig, samples: int = 8
) -> NDArray[np.bool_]:
    """Truth: is each target's whole shadow inside the field of view? (direct ray computation)

    The top edge, the near foot, the seabed at the top edge's slant range and ``samples``
    seabed points from the far foot to the shadow end are turned into the sonar frame
    with :func:`perception.geometry.sonar_to_ned`; all must be within the elevation
    aperture, the fan and the range window.

    Parameters
    ----------
    geom : ShadowGeometry
        Shapes ``(T,)``: one time, T targets.
    """
    alt, h = geom.altitude_m, geom.height_m
    s = np.linspace(0.0, 1.0, samples)[None, :]
    scale = 1.0 + s * (alt / (alt - h) - 1.0)[:, None]
    pts = [np.stack([geom.top_along_m, geom.top_cross_m, alt - h], axis=-1)[:, None, :],
           np.stack([geom.base_along_m, geom.base_cross_m, alt], axis=-1)[:, None, :],
           np.stack([geom.start_along_m, geom.start_cross_m, alt], axis=-1)[:, None, :],
           np.stack([geom.top_along_m[:, None] * scale, geom.top_cross_m[:, None] * scale,
                     np.broadcast_to(alt[:, None], scale.shape)], axis=-1)]
    p = np.concatenate(pts, axis=1)
    rot = sonar_to_ned(tilt_rad=tilt_rad, pitch_rad=pitch_rad)
    az, el = ray_angles_sonar(p @ rot)  # rows of p times rot = rot.T applied to each point
    rng_m = np.linalg.norm(p, axis=-1)
    w0, w1 = config.window_m
    ok = ((np.abs(el) <= config.elevation_aperture_rad / 2) & (np.abs(az) <= config.fan_width_rad / 2)
          & (rng_m >= w0) & (rng_m <= w1))
    return np.all(ok, axis=1) & (geom.top_along_m > 0)


def _truth_in_range(geom: ShadowGeometry, *, pitch_rad: float, config: PitchLoopConfig,
                    limits: MountLimits) -> tuple[NDArray[np.bool_], FloatArray, FloatArray]:
    lo, hi = depression_interval_rad(geom, half_aperture_rad=config.elevation_aperture_rad / 2)
    lo_t = np.maximum(lo + pitch_rad, limits.min_tilt_rad)
    hi_t = np.minimum(hi + pitch_rad, limits.max_tilt_rad)
    w0, w1 = config.window_m
    ok = ((geom.top_along_m > 0) & (geom.end_slant_m <= w1) & (geom.near_slant_m >= w0)
          & (np.abs(geom.bearing_rad) <= config.fan_width_rad / 2)
          & (geom.base_ground_m >= config.zone_start_m(geom.altitude_m)) & (lo_t <= hi_t))
    return ok, lo_t, hi_t


def simulate_pass(
    controller: TiltController,
    scenario: PassScenario,
    *,
    config: PitchLoopConfig,
    limits: MountLimits,
    rng: np.random.Generator,
    score_config: PitchLoopConfig | None = None,
) -> PassResult:
    """Fly one pass in closed loop and score it against truth (pure; seeded by ``rng``).

    ``score_config`` (default ``config``) gives the tracking zone the frames are scored
    over, e.g. the plain 2-altitude zone for a loop configured with the fitted one.

    Each frame: truth scoring; every ``config.dt_s`` the controller gets the measured
    altitude, pitch and rate, the mount's tilt and the targets within ``lookahead_m``
    ahead, as a simple tracker sees them: its estimate of each target starts at the
    mapped position (noisy, no height) and is blended (gain ``tracker_gain``) with each
    noisy slant measurement (:func:`shadow_from_measurement`) taken when the whole
    shadow is in the frame (then ``measured=True``). The mount slews toward the command
    at its rate limit.
    """
    sc = scenario
    every = round(config.dt_s / sc.frame_period_s)
    if every < 1 or not math.isclose(every * sc.frame_period_s, config.dt_s, rel_tol=1e-9):
        raise ConfigError(f"dt_s ({config.dt_s!r}) must be a whole number of frame periods ({sc.frame_period_s!r})",
                          key="dt_s")
    n_frames = int(round(sc.duration_s / sc.frame_period_s))
    tgt = sc.targets
    n_t = len(tgt)
    t_x = np.array([t.along_m for t in tgt], dtype=np.float64)
    t_y = np.array([t.cross_m for t in tgt], dtype=np.float64)
    t_h = np.array([t.height_m for t in tgt], dtype=np.float64)
    t_f = np.array([t.footprint_m for t in tgt], dtype=np.float64)
    est_x = t_x + rng.normal(0.0, sc.prior_position_noise_m, n_t)  # lane coordinates
    est_y = t_y + rng.normal(0.0, sc.prior_position_noise_m, n_t)
    est_h = np.full(n_t, np.nan)
    omega = 2 * math.pi * sc.pitch_frequency_hz
    tilt = limits.clip(config.nominal_tilt_rad)
    command = tilt
    times = np.arange(n_frames) * sc.frame_period_s
    tilts, pitches = np.zeros(n_frames), np.zeros(n_frames)
    in_range = np.zeros((n_frames, n_t), dtype=bool)
    visible = np.zeros((n_frames, n_t), dtype=bool)
    joint = np.zeros(n_frames, dtype=bool)
    cmd_t: list[float] = []
    cmd_v: list[float] = []
    failures = 0
    for j, t in enumerate(times):
        pitch = sc.pitch_amplitude_rad * math.sin(omega * t + sc.pitch_phase_rad)
        rate = sc.pitch_amplitude_rad * omega * math.cos(omega * t + sc.pitch_phase_rad)
        rel_x = t_x - sc.speed_m_s * t
        geom = shadow_geometry(rel_x, t_y, t_h, t_f, sc.altitude_m)
        vis = whole_shadow_visible(geom, tilt_rad=tilt, pitch_rad=pitch, config=config)
        rng_ok, lo_t, hi_t = _truth_in_range(geom, pitch_rad=pitch, config=score_config or config, limits=limits)
        tilts[j], pitches[j] = tilt, pitch
        visible[j], in_range[j] = vis, rng_ok
        joint[j] = (not rng_ok.any()) or bool(np.max(lo_t[rng_ok]) <= np.min(hi_t[rng_ok]))
        if j % every == 0:
            alt_meas = sc.altitude_m + rng.normal(0.0, sc.altitude_noise_m)
            pitch_meas = pitch + rng.normal(0.0, sc.pitch_noise_rad)
            shadows: list[TrackedShadow] = []
            for i in np.flatnonzero((rel_x > 0) & (rel_x <= sc.lookahead_m)):
                shadow: TrackedShadow | None = None
                measured = False
                if vis[i]:
                    truth = TrackedShadow(tgt[i].target_id, rel_x[i], t_y[i], t_h[i], t_f[i])
                    r_top, r_end, az = shadow_measurement(truth, altitude_m=sc.altitude_m, tilt_rad=tilt,
                                                          pitch_rad=pitch)
                    try:
                        shadow = shadow_from_measurement(
                            tgt[i].target_id, top_slant_m=r_top + rng.normal(0.0, sc.range_noise_m),
                            end_slant_m=r_end + rng.normal(0.0, sc.range_noise_m),
                            azimuth_rad=az + rng.normal(0.0, sc.azimuth_noise_rad), altitude_m=alt_meas,
                            tilt_rad=tilt, pitch_rad=pitch_meas, footprint_m=t_f[i])
                    except MeasurementError:
                        shadow = None
                    if shadow is not None and shadow.height_m is not None:
                        k = sc.tracker_gain
                        est_x[i] += k * (shadow.along_m + sc.speed_m_s * t - est_x[i])
                        est_y[i] += k * (shadow.cross_m - est_y[i])
                        est_h[i] = shadow.height_m if np.isnan(est_h[i]) else est_h[i] + k * (
                            shadow.height_m - est_h[i])
                        measured = True
                shadows.append(TrackedShadow(tgt[i].target_id, float(est_x[i] - sc.speed_m_s * t), float(est_y[i]),
                                             None if np.isnan(est_h[i]) else float(est_h[i]), t_f[i], measured))
            state = PitchState(altitude_m=alt_meas, vehicle_pitch_rad=pitch_meas,
                               pitch_rate_rad_s=rate + rng.normal(0.0, sc.pitch_noise_rad),
                               speed_m_s=sc.speed_m_s, current_tilt_rad=tilt)
            cmd = controller.step(state, shadows)
            failures += 0 if cmd.solver_ok else 1
            command = cmd.tilt_rad
            cmd_t.append(float(t))
            cmd_v.append(command)
        move = limits.max_rate_rad_s * sc.frame_period_s
        tilt = limits.clip(tilt + min(max(command - tilt, -move), move))
    return PassResult(np.asarray(times, dtype=np.float64), tilts, pitches, np.array(cmd_v), in_range, visible,
                      joint, times >= sc.settle_s, failures, np.array(cmd_t))


def nominal_tilt_for(altitude_m: float, config: PitchLoopConfig) -> float:
    """A fixed tilt for an altitude: the beam axis midway, in depression, across the
    tracking zone (from the far end of the range window to the zone's near edge,
    :meth:`PitchLoopConfig.zone_start_m`), rad."""
    far = math.sqrt(max(config.window_m[1] ** 2 - altitude_m**2, 1e-9))
    near = float(config.zone_start_m(altitude_m))
    return 0.5 * (math.atan2(altitude_m, far) + math.atan2(altitude_m, max(near, 1e-9)))


def random_scenario(
    rng: np.random.Generator,
    *,
    duration_s: float = 90.0,
    speed_m_s: float = 0.5,
    altitude_range_m: tuple[float, float] = (0.5, 2.5),
    height_range_m: tuple[float, float] = (0.02, 0.40),
    spacing_range_m: tuple[float, float] = (14.0, 24.0),
    cross_max_m: float = 0.5,
    pitch_amplitude_max_rad: float = math.radians(3.0),
    pitch_frequency_range_hz: tuple[float, float] = (0.1, 0.3),
) -> PassScenario:
    """A random pass: altitude, pitch disturbance and a line of targets with random
    spacing along the lane, cross-track offsets and heights (seeded by ``rng``)."""
    alt = float(rng.uniform(*altitude_range_m))
    targets: list[SeabedTarget] = []
    x = float(rng.uniform(4.0, 12.0))
    end = speed_m_s * duration_s + 14.0
    while x < end:
        h = float(min(rng.uniform(*height_range_m), 0.8 * alt))
        targets.append(SeabedTarget(len(targets), x, float(rng.uniform(-cross_max_m, cross_max_m)), h))
        x += float(rng.uniform(*spacing_range_m))
    return PassScenario(
        altitude_m=alt, speed_m_s=speed_m_s,
        pitch_amplitude_rad=float(rng.uniform(0.5, 1.0) * pitch_amplitude_max_rad),
        pitch_frequency_hz=float(rng.uniform(*pitch_frequency_range_hz)),
        pitch_phase_rad=float(rng.uniform(0.0, 2 * math.pi)), targets=tuple(targets), duration_s=duration_s)
