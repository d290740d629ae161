"""Geometry of the vertical aperture: which beam depressions keep a point, a shadow, or the
tracking zone inside it (flat seabed; frames and signs of :mod:`planner.pitch.qp`)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from perception.errors import GeometryError
from perception.geometry.shadow import clamp_height_m, shadow_end_slant_m
from planner.pitch.types import FloatArray


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
        below = alt - clamp_height_m(height_m, alt)
        fit = np.where(steep >= math.pi / 2, 0.0, np.sqrt(np.maximum(0.0, slant**2 - below**2)))
    if not fit_aperture:
        fit = np.zeros_like(fit)
    return np.where(reach, np.maximum(min_over_altitude * alt, fit), np.inf)


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
    end = shadow_end_slant_m(r_top, alt, h)
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
    whole, shadow = shadow_and_whole_intervals_rad(geom, half_aperture_rad=half_aperture_rad, include_base=include_base)
    return whole if include_base else shadow


def shadow_and_whole_intervals_rad(
    geom: ShadowGeometry, *, half_aperture_rad: float, include_base: bool = True
) -> tuple[tuple[FloatArray, FloatArray], tuple[FloatArray, FloatArray]]:
    """:func:`depression_interval_rad` with and without the near foot, the shared rays
    computed once: ``((lo, hi), (lo_shadow, hi_shadow))`` (the first is the second if not
    ``include_base``)."""
    lo, hi = aperture_interval_rad(geom.top_along_m, geom.top_cross_m, geom.altitude_m - geom.height_m,
                                   half_aperture_rad=half_aperture_rad)
    for x, y in ((geom.top_along_m, geom.top_cross_m), (geom.start_along_m, geom.start_cross_m)):
        lo_p, hi_p = aperture_interval_rad(x, y, geom.altitude_m, half_aperture_rad=half_aperture_rad)
        lo, hi = np.maximum(lo, lo_p), np.minimum(hi, hi_p)
    if not include_base:
        return (lo, hi), (lo, hi)
    lo_b, hi_b = aperture_interval_rad(geom.base_along_m, geom.base_cross_m, geom.altitude_m,
                                       half_aperture_rad=half_aperture_rad)
    return (np.maximum(lo, lo_b), np.minimum(hi, hi_b)), (lo, hi)


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
