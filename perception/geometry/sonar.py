"""Sonar-to-seabed geometry: slant and ground range, ray depression, the insonified band.

Frames and signs (the one place they are written down; see also
:mod:`perception.sonar_io.frame`):

- Local NED: x north, y east, z down. Depth positive down, altitude positive up from the
  seabed.
- Vehicle body: x forward, y starboard, z down; attitude by ZYX Euler angles
  (heading psi clockwise from north, pitch theta positive nose up, roll phi positive
  starboard down), ``R_body_to_ned = Rz(psi) @ Ry(theta) @ Rx(phi)``.
- Sonar: x along the boresight, y starboard, z down; mounted with depression ``tilt``
  (positive down) about the body y axis: ``R_sonar_to_body = Ry(-tilt)``.
- A ray of the sonar at beam azimuth ``a`` (positive to starboard) and elevation ``e``
  within the vertical aperture (positive down, 0 on the beam axis) points along
  ``(cos e cos a, cos e sin a, sin e)`` in the sonar frame.

For a flat seabed a ray's *depression* (angle below the horizontal) fixes where it
meets the seabed: ``slant = H / sin(depression)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from perception.errors import GeometryError

FloatArray = NDArray[np.float64]


def _check_altitude(altitude_m: float) -> float:
    h = float(altitude_m)
    if not (math.isfinite(h) and h > 0):
        raise GeometryError(f"altitude must be finite and > 0 m, got {altitude_m!r}")
    return h


def slant_to_ground(slant_m: ArrayLike, altitude_m: float) -> FloatArray:
    """Horizontal distance to the seabed point at a slant range, flat seabed.

    Parameters
    ----------
    slant_m : array_like
        Slant ranges from the sonar, m. Ranges shorter than the altitude never reach
        the seabed and give NaN.
    altitude_m : float
        Sonar height above the seabed, m (> 0).

    Returns
    -------
    ndarray
        Ground ranges, m, same shape as ``slant_m``.
    """
    h = _check_altitude(altitude_m)
    r = np.asarray(slant_m, dtype=np.float64)
    sq = (r - h) * (r + h)  # fewer rounding errors than r*r - h*h near the nadir
    with np.errstate(invalid="ignore"):
        return np.where(sq >= 0, np.sqrt(np.maximum(sq, 0.0)), np.nan)


def ground_to_slant(ground_m: ArrayLike, altitude_m: float) -> FloatArray:
    """Slant range to a seabed point at a horizontal distance, flat seabed, m."""
    h = _check_altitude(altitude_m)
    g = np.asarray(ground_m, dtype=np.float64)
    return np.hypot(g, h)


def ray_depression_rad(slant_m: ArrayLike, altitude_m: float) -> FloatArray:
    """Depression below the horizontal of the ray that meets a flat seabed at ``slant_m``.

    NaN where the slant range is shorter than the altitude.
    """
    h = _check_altitude(altitude_m)
    r = np.asarray(slant_m, dtype=np.float64)
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = h / r
    return np.where((ratio <= 1.0) & (ratio > 0), np.arcsin(np.clip(ratio, 0.0, 1.0)), np.nan)


def slant_for_depression(depression_rad: ArrayLike, altitude_m: float) -> FloatArray:
    """Slant range at which a ray of the given depression meets a flat seabed, m.

    ``inf`` for rays at or above the horizontal (they never meet the seabed).
    """
    h = _check_altitude(altitude_m)
    d = np.asarray(depression_rad, dtype=np.float64)
    with np.errstate(divide="ignore"):
        return np.where(d > 0, h / np.sin(np.clip(d, 1e-300, math.pi / 2)), np.inf)


def altitude_from_band_start(near_slant_m: float, *, depression_rad: float, elevation_aperture_rad: float) -> float:
    """Sonar altitude from where the insonified seabed starts in range (flat seabed).

    The steepest ray of the vertical aperture has depression
    ``min(depression + aperture / 2, pi / 2)`` and first meets the seabed at
    ``near_slant_m``.
    """
    steepest = min(depression_rad + elevation_aperture_rad / 2.0, math.pi / 2)
    if steepest <= 0:
        raise GeometryError("the steepest ray points at or above the horizontal; no seabed seen")
    if not (math.isfinite(near_slant_m) and near_slant_m > 0):
        raise GeometryError(f"near slant range must be finite and > 0, got {near_slant_m!r}")
    return float(near_slant_m * math.sin(steepest))


@dataclass(frozen=True)
class SeabedBand:
    """The part of a flat seabed the sonar insonifies along its beam axis.

    Slant ranges are from the acoustic centre, ground ranges horizontal, all in m.
    ``far_*`` is ``inf`` when the shallowest ray does not meet the seabed and no range
    window limits it. ``*_limited_by`` says which limit sets each edge: ``"beam"`` (the
    vertical aperture) or ``"window"`` (the range window).
    """

    near_slant_m: float
    far_slant_m: float
    near_ground_m: float
    far_ground_m: float
    near_limited_by: str
    far_limited_by: str

    @property
    def empty(self) -> bool:
        """True when the band holds no seabed."""
        return not self.far_slant_m > self.near_slant_m

    def contains_slant(self, slant_m: float, *, margin_m: float = 0.0) -> bool:
        """True when ``slant_m`` lies inside the band with ``margin_m`` to spare at both ends."""
        return self.near_slant_m + margin_m <= slant_m <= self.far_slant_m - margin_m


def insonified_band(
    altitude_m: float,
    *,
    depression_rad: float,
    elevation_aperture_rad: float,
    window_m: tuple[float, float] | None = None,
) -> SeabedBand:
    """The insonified seabed band on a flat seabed along the beam axis.

    Parameters
    ----------
    altitude_m : float
        Sonar height above the seabed, m (> 0).
    depression_rad : float
        Depression of the beam axis below the horizontal, rad: the mount tilt minus the
        vehicle pitch (pitch positive nose up) for a forward-looking sonar.
    elevation_aperture_rad : float
        Full vertical opening, rad.
    window_m : (float, float), optional
        Range window (first, last slant range), m.

    Raises
    ------
    GeometryError
        For a non-positive altitude or aperture, or a beam that points entirely above
        the horizontal.
    """
    h = _check_altitude(altitude_m)
    if not (0 < elevation_aperture_rad < math.pi):
        raise GeometryError(f"elevation aperture must be in (0, pi) rad, got {elevation_aperture_rad!r}")
    steep = min(depression_rad + elevation_aperture_rad / 2.0, math.pi / 2)
    shallow = depression_rad - elevation_aperture_rad / 2.0
    if steep <= 0:
        raise GeometryError(
            f"beam points above the horizontal (depression {math.degrees(depression_rad):.1f} deg, "
            f"aperture {math.degrees(elevation_aperture_rad):.1f} deg): it never sees the seabed"
        )
    near = h / math.sin(steep)
    far = h / math.sin(shallow) if shallow > 0 else math.inf
    near_by, far_by = "beam", "beam"
    if window_m is not None:
        lo, hi = float(window_m[0]), float(window_m[1])
        if not (0 <= lo < hi):
            raise GeometryError(f"range window must satisfy 0 <= start < end, got {window_m!r}")
        if lo > near:
            near, near_by = lo, "window"
        if hi < far:
            far, far_by = hi, "window"
    near_ground = float(slant_to_ground(near, h)) if near >= h else 0.0
    far_ground = math.inf if math.isinf(far) else float(slant_to_ground(max(far, h), h))
    return SeabedBand(near, far, near_ground, far_ground, near_by, far_by)


def rot_x(angle_rad: float) -> FloatArray:
    """Rotation matrix about x (roll), active, right-handed."""
    c, s = math.cos(angle_rad), math.sin(angle_rad)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def rot_y(angle_rad: float) -> FloatArray:
    """Rotation matrix about y (pitch), active, right-handed."""
    c, s = math.cos(angle_rad), math.sin(angle_rad)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def rot_z(angle_rad: float) -> FloatArray:
    """Rotation matrix about z (heading), active, right-handed."""
    c, s = math.cos(angle_rad), math.sin(angle_rad)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def sonar_to_ned(
    *, tilt_rad: float, pitch_rad: float = 0.0, roll_rad: float = 0.0, heading_rad: float = 0.0
) -> FloatArray:
    """Rotation taking sonar-frame vectors to local NED (see the module docstring)."""
    return rot_z(heading_rad) @ rot_y(pitch_rad) @ rot_x(roll_rad) @ rot_y(-tilt_rad)


def ray_direction_sonar(azimuth_rad: ArrayLike, elevation_rad: ArrayLike) -> FloatArray:
    """Unit ray directions in the sonar frame, shape ``broadcast(az, el).shape + (3,)``."""
    a = np.asarray(azimuth_rad, dtype=np.float64)
    e = np.asarray(elevation_rad, dtype=np.float64)
    a, e = np.broadcast_arrays(a, e)
    return np.stack([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)], axis=-1)


def seabed_hit_slant_m(
    azimuth_rad: ArrayLike,
    elevation_rad: ArrayLike,
    *,
    altitude_m: float,
    tilt_rad: float,
    pitch_rad: float = 0.0,
    roll_rad: float = 0.0,
) -> FloatArray:
    """Slant range at which sonar rays meet a flat seabed ``altitude_m`` below, m.

    ``inf`` for rays that point at or above the horizontal. Heading does not matter for
    a flat seabed.
    """
    h = _check_altitude(altitude_m)
    rot = sonar_to_ned(tilt_rad=tilt_rad, pitch_rad=pitch_rad, roll_rad=roll_rad)
    down = ray_direction_sonar(azimuth_rad, elevation_rad) @ rot[2]
    with np.errstate(divide="ignore"):
        return np.where(down > 0, h / np.where(down > 0, down, 1.0), np.inf)


def ray_angles_sonar(direction_sonar: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """Azimuth and elevation of directions given in the sonar frame (inverse of
    :func:`ray_direction_sonar`).

    Parameters
    ----------
    direction_sonar : array_like, shape (..., 3)
        Directions in the sonar frame (x boresight, y starboard, z down); need not be
        unit length but must not be zero.

    Returns
    -------
    azimuth_rad, elevation_rad : ndarray, shape (...)
        Azimuth (positive to starboard) and elevation (positive down), rad.

    Raises
    ------
    GeometryError
        For a zero-length or non-finite direction, or a last axis that is not 3 long.
    """
    d = np.asarray(direction_sonar, dtype=np.float64)
    if d.shape[-1:] != (3,):
        raise GeometryError(f"directions must have a last axis of length 3, got shape {d.shape}")
    norm = np.linalg.norm(d, axis=-1)
    if not np.all(np.isfinite(norm) & (norm > 0)):
        raise GeometryError("directions must be finite and non-zero")
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    return np.arctan2(y, x), np.arctan2(z, np.hypot(x, y))


def ray_depression_of_angles_rad(
    azimuth_rad: ArrayLike,
    elevation_rad: ArrayLike,
    *,
    tilt_rad: float,
    pitch_rad: float = 0.0,
    roll_rad: float = 0.0,
) -> FloatArray:
    """Depression below the local horizontal of sonar rays, rad (negative: upward).

    Parameters
    ----------
    azimuth_rad, elevation_rad : array_like
        Ray angles in the sonar frame (module docstring), broadcast together.
    tilt_rad, pitch_rad, roll_rad : float
        Mount depression, vehicle pitch (nose up) and roll (starboard down), rad.

    Returns
    -------
    ndarray
        ``arcsin`` of the ray's down component in NED; for a flat seabed ``altitude``
        below, the ray meets it at ``altitude / sin(depression)``
        (:func:`seabed_hit_slant_m`).
    """
    rot = sonar_to_ned(tilt_rad=tilt_rad, pitch_rad=pitch_rad, roll_rad=roll_rad)
    down = ray_direction_sonar(azimuth_rad, elevation_rad) @ rot[2]
    return np.arcsin(np.clip(down, -1.0, 1.0))


@dataclass(frozen=True)
class SeabedPlane:
    """A planar (possibly sloped) seabed in local NED.

    Attributes
    ----------
    normal_ned : tuple of 3 float
        Unit normal pointing from the seabed into the water (its down component is
        negative). Normalised on construction.
    point_ned_m : tuple of 3 float or None
        A point on the plane, m, when the plane's position is known; None when only its
        orientation is (then only differences of distance to it can be formed).

    Raises
    ------
    GeometryError
        For a zero, non-finite or horizontal-pointing normal (a seabed steeper than or
        equal to 90 deg), or a non-finite point.
    """

    normal_ned: tuple[float, float, float]
    point_ned_m: tuple[float, float, float] | None = None

    def __post_init__(self) -> None:
        n = np.asarray(self.normal_ned, dtype=np.float64)
        if n.shape != (3,) or not np.all(np.isfinite(n)) or not np.linalg.norm(n) > 0:
            raise GeometryError(f"seabed normal must be a finite non-zero 3-vector, got {n!r}")
        n = n / np.linalg.norm(n)
        if not n[2] < 0:
            raise GeometryError(f"seabed normal must point up into the water (negative down component), got {n!r}")
        object.__setattr__(self, "normal_ned", (float(n[0]), float(n[1]), float(n[2])))
        if self.point_ned_m is not None:
            q = np.asarray(self.point_ned_m, dtype=np.float64)
            if q.shape != (3,) or not np.all(np.isfinite(q)):
                raise GeometryError(f"seabed point must be a finite 3-vector, got {q!r}")
            object.__setattr__(self, "point_ned_m", (float(q[0]), float(q[1]), float(q[2])))

    @classmethod
    def horizontal(cls, depth_m: float) -> SeabedPlane:
        """A flat seabed at ``depth_m`` (NED down)."""
        return cls((0.0, 0.0, -1.0), (0.0, 0.0, float(depth_m)))

    @classmethod
    def fit(cls, points_ned_m: ArrayLike) -> SeabedPlane:
        """Least-squares plane (orthogonal distances) through seabed points.

        Parameters
        ----------
        points_ned_m : array_like, shape (K, 3)
            Seabed points in local NED, m (e.g. the sonar's own seabed returns), K >= 3
            and not all on one line.

        Raises
        ------
        GeometryError
            For fewer than 3 points, non-finite points or collinear points.
        """
        p = np.asarray(points_ned_m, dtype=np.float64)
        if p.ndim != 2 or p.shape[1] != 3 or p.shape[0] < 3:
            raise GeometryError(f"plane fit needs points of shape (K >= 3, 3), got {p.shape}")
        if not np.all(np.isfinite(p)):
            raise GeometryError("plane fit needs finite points")
        centre = p.mean(axis=0)
        _, s, vt = np.linalg.svd(p - centre)
        if s[1] <= 1e-12 * max(s[0], 1e-300):
            raise GeometryError("plane fit points are collinear (or coincide)")
        n = vt[2] if vt[2][2] < 0 else -vt[2]
        return cls(
            (float(n[0]), float(n[1]), float(n[2])),
            (float(centre[0]), float(centre[1]), float(centre[2])),
        )

    @property
    def slope_rad(self) -> float:
        """Angle between the seabed and the horizontal, rad."""
        return float(math.acos(min(1.0, -self.normal_ned[2])))

    def height_above_m(self, points_ned_m: ArrayLike) -> FloatArray:
        """Perpendicular distance of points above the plane, m (negative below it).

        Parameters
        ----------
        points_ned_m : array_like, shape (..., 3)
            Points in local NED, m.

        Raises
        ------
        GeometryError
            When the plane's point is unknown (``point_ned_m`` is None).
        """
        if self.point_ned_m is None:
            raise GeometryError("the seabed plane's position is unknown (point_ned_m is None)")
        p = np.asarray(points_ned_m, dtype=np.float64)
        return (p - np.asarray(self.point_ned_m)) @ np.asarray(self.normal_ned)
