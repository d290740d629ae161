"""The forward-looking sonar's footprint on a flat seabed and the strip it sweeps.

Vehicle frame in this module: ``forward_m`` along the heading, ``starboard_m`` to the
right (the body x and y of :mod:`perception.geometry`). Plane coordinates are the
planner's local ``(east_m, north_m)`` (shapely's x, y); heading is clockwise from north.

The sonar insonifies, at altitude ``H`` and depression ``tilt`` with the vehicle level,
seabed ground ranges ``[g_near, g_far]`` (:func:`perception.geometry.insonified_band`,
range window included) within the fan ``|azimuth| <= fan / 2``. The planner uses a
conservative convex part of that annular sector, a trapezoid:

- sides: the bearings ``+-fan/2`` from the vehicle;
- near edge: the line ``forward = g_near``, far edge: the line ``forward = g_far``,
  where ``g_near``/``g_far`` are found by sampling the insonified seabed so that the
  whole trapezoid is seen (:func:`footprint`; a test checks random points of it by
  inverting the sonar geometry).

Tilting the sonar down only widens the real fan on the seabed, so the sides hold; the
beam-limited near edge bows forward off axis, which ``g_near`` accounts for.
The swath used for lane spacing is the trapezoid's near-edge width
``2 g_near tan(fan/2)``: swept along a lane, the trapezoid covers at least that width
on every point of the lane once the near edge has passed it, so a lane run must begin
``g_near`` before the first ground it has to cover (the lead-in).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import shapely
from numpy.typing import NDArray

from perception.geometry import (
    insonified_band,
    ray_direction_sonar,
    seabed_hit_slant_m,
    sonar_to_ned,
)
from planner.config import SonarSettings
from planner.errors import InfeasibleError

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class Footprint:
    """The planning footprint of the sonar at one altitude and tilt.

    Attributes
    ----------
    altitude_m, tilt_rad : float
        Sonar altitude above the seabed (m) and depression of the beam axis (rad).
    near_ground_m, far_ground_m : float
        Forward distances of the trapezoid's near and far edges, m.
    half_fan_rad : float
        Half the azimuth opening, rad.
    """

    altitude_m: float
    tilt_rad: float
    near_ground_m: float
    far_ground_m: float
    half_fan_rad: float

    @property
    def swath_m(self) -> float:
        """Cross-track width at the near edge, m: the conservative swath."""
        return 2.0 * self.near_ground_m * math.tan(self.half_fan_rad)

    @property
    def lead_in_m(self) -> float:
        """Along-track distance from the vehicle to the near edge, m."""
        return self.near_ground_m

    def corners_body(self) -> FloatArray:
        """Trapezoid corners ``(forward_m, starboard_m)``, shape (4, 2), counter-clockwise
        as seen with forward up and starboard right: near port, near starboard, far
        starboard, far port."""
        g_n, g_f, t = self.near_ground_m, self.far_ground_m, math.tan(self.half_fan_rad)
        return np.array([[g_n, -g_n * t], [g_n, g_n * t], [g_f, g_f * t], [g_f, -g_f * t]])

    def corners_plane(self, position_en_m: tuple[float, float], heading_rad: float) -> FloatArray:
        """Trapezoid corners in the plane ``(east_m, north_m)``, shape (4, 2), for the
        vehicle at ``position_en_m`` with compass heading ``heading_rad``."""
        body = self.corners_body()
        fwd = np.array([math.sin(heading_rad), math.cos(heading_rad)])
        stb = np.array([math.cos(heading_rad), -math.sin(heading_rad)])
        return np.asarray(position_en_m, dtype=float) + body[:, :1] * fwd + body[:, 1:] * stb


#: Bearings and ranges sampled when finding the footprint's edges.
_N_BEARINGS = 31
_N_RANGES = 1000


def seen_mask(
    forward_m: FloatArray, starboard_m: FloatArray, altitude_m: float, tilt_rad: float,
    sonar: SonarSettings,
) -> NDArray[np.bool_]:
    """Which seabed points (vehicle frame, level vehicle) the sonar insonifies: inside the
    fan, the vertical aperture and the range window. Arrays broadcast together."""
    x, y = np.broadcast_arrays(np.asarray(forward_m, float), np.asarray(starboard_m, float))
    slant = np.sqrt(x * x + y * y + altitude_m * altitude_m)
    ned = np.stack([x, y, np.full_like(x, altitude_m)], axis=-1) / slant[..., None]
    son = ned @ sonar_to_ned(tilt_rad=tilt_rad)  # rows: NED -> sonar (R^T v)
    azimuth = np.arctan2(son[..., 1], son[..., 0])
    elevation = np.arcsin(np.clip(son[..., 2], -1.0, 1.0))
    return np.asarray(
        (np.abs(azimuth) <= sonar.fan_width_rad / 2)
        & (np.abs(elevation) <= sonar.elevation_aperture_rad / 2)
        & (slant >= sonar.window_start_m)
        & (slant <= sonar.window_end_m)
    )


def footprint(altitude_m: float, tilt_rad: float, sonar: SonarSettings) -> Footprint:
    """The planning footprint for a level vehicle at ``altitude_m`` with mount ``tilt_rad``.

    The insonified seabed is sampled along bearings ``|theta| <= fan/2``: at each bearing
    the seen ground ranges form ``[rho_near, rho_far]``. The near edge of the trapezoid is
    the farthest ``rho_near cos(theta)`` (off-axis rays are shallower, so a beam-limited
    near edge bows forward at the sides), the far edge the nearest ``rho_far cos(theta)``.

    Raises
    ------
    InfeasibleError
        When the band holds no seabed inside the range window.
    """
    band = insonified_band(
        altitude_m,
        depression_rad=tilt_rad,
        elevation_aperture_rad=sonar.elevation_aperture_rad,
        window_m=(sonar.window_start_m, sonar.window_end_m),
    )
    max_ground = math.sqrt(max(sonar.window_end_m**2 - altitude_m**2, 0.0))
    half = sonar.fan_width_rad / 2 * (1 - 1e-6)
    if band.empty or max_ground <= 0:
        raise _nothing_seen(altitude_m, tilt_rad, band.near_slant_m, band.far_slant_m)
    bearings = np.linspace(-half, half, _N_BEARINGS)
    rho = np.linspace(0.0, max_ground, _N_RANGES)
    rr, bb = np.meshgrid(rho, bearings)
    seen = seen_mask(rr * np.cos(bb), rr * np.sin(bb), altitude_m, tilt_rad, sonar)
    if not seen.any(axis=1).all():
        raise _nothing_seen(altitude_m, tilt_rad, band.near_slant_m, band.far_slant_m)
    first = np.argmax(seen, axis=1)
    last = _N_RANGES - 1 - np.argmax(seen[:, ::-1], axis=1)
    step = float(rho[1] - rho[0])
    near = float(np.max(rho[first] * np.cos(bearings))) + step
    far = float(np.min(rho[last] * np.cos(bearings))) - step
    if far <= near:
        raise _nothing_seen(altitude_m, tilt_rad, band.near_slant_m, band.far_slant_m)
    return Footprint(
        altitude_m=float(altitude_m),
        tilt_rad=float(tilt_rad),
        near_ground_m=near,
        far_ground_m=far,
        half_fan_rad=half,
    )


def _nothing_seen(altitude_m: float, tilt_rad: float, near: float, far: float) -> InfeasibleError:
    return InfeasibleError(
        f"no usable seabed band inside the range window at altitude {altitude_m:.2f} m, tilt "
        f"{math.degrees(tilt_rad):.1f} deg (on-axis band {near:.2f}-{far:.2f} m slant)"
    )


def swept_polygon(
    fp: Footprint, start_en_m: tuple[float, float], end_en_m: tuple[float, float]
) -> shapely.Polygon:
    """Seabed seen while the vehicle runs straight from ``start_en_m`` to ``end_en_m``.

    The trapezoid is convex, so the swept region is the convex hull of the trapezoid at
    both ends. Plane coordinates ``(east_m, north_m)``.
    """
    return swept_polygons(fp, np.asarray([start_en_m], dtype=float), np.asarray([end_en_m], dtype=float))[0]


def swept_polygons(fp: Footprint, starts_en_m: FloatArray, ends_en_m: FloatArray) -> NDArray[np.object_]:
    """:func:`swept_polygon` of many runs at once: ``starts_en_m``, ``ends_en_m`` shape (n, 2)."""
    start = np.asarray(starts_en_m, dtype=float).reshape(-1, 2)
    end = np.asarray(ends_en_m, dtype=float).reshape(-1, 2)
    d = end - start
    heading = np.where(np.hypot(d[:, 0], d[:, 1]) > 1e-9, np.arctan2(d[:, 0], d[:, 1]), 0.0)
    fwd = np.stack([np.sin(heading), np.cos(heading)], axis=-1)[:, None, :]
    stb = np.stack([np.cos(heading), -np.sin(heading)], axis=-1)[:, None, :]
    body = fp.corners_body()[None]
    pts = np.concatenate([p[:, None, :] + body[..., :1] * fwd + body[..., 1:] * stb for p in (start, end)], axis=1)
    hulls = shapely.convex_hull(shapely.multipoints(shapely.points(pts.reshape(-1, 2)),
                                                    indices=np.repeat(np.arange(len(pts)), pts.shape[1])))
    return np.asarray(hulls, dtype=object)


def exact_footprint_body(
    altitude_m: float,
    tilt_rad: float,
    sonar: SonarSettings,
    *,
    n_azimuth: int = 41,
    n_elevation: int = 81,
) -> FloatArray:
    """Seabed points the sonar actually insonifies, by ray casting (flat seabed).

    Rays at the centres of an ``n_azimuth`` x ``n_elevation`` grid over the fan and the
    vertical aperture that meet the seabed inside the range window. Returns ``(forward_m, starboard_m)``, shape (n, 2).
    """
    az = (np.arange(n_azimuth) + 0.5) / n_azimuth * sonar.fan_width_rad - sonar.fan_width_rad / 2
    el = (np.arange(n_elevation) + 0.5) / n_elevation * sonar.elevation_aperture_rad - (
        sonar.elevation_aperture_rad / 2
    )
    aa, ee = np.meshgrid(az, el, indexing="ij")
    slant = seabed_hit_slant_m(aa, ee, altitude_m=altitude_m, tilt_rad=tilt_rad)
    ok = np.isfinite(slant) & (slant >= sonar.window_start_m) & (slant <= sonar.window_end_m)
    # Level vehicle heading north: NED x = forward, y = starboard.
    rays = ray_direction_sonar(aa[ok], ee[ok]) @ sonar_to_ned(tilt_rad=tilt_rad).T
    return rays[:, :2] * slant[ok][:, None]
