"""A rounded (half-ellipsoid) target's summit from the heights of its grazing points."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from perception.errors import SolverError
from perception.heights.least_squares import check_positive_finite

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class RoundedTopFit:
    """A rounded (half-ellipsoid) target's summit height from its grazing points.

    Attributes
    ----------
    height_m, height_std_m : float
        Summit height ``c`` above the seabed and its 1-sigma, m.
    curvature_per_m2, curvature_std_per_m2 : float
        ``k = a^2 / c^4`` (``a``: the half-length along the ray), 1/m^2, and its 1-sigma:
        0 for a sharp far top edge (a box), > 0 for a rounded top.
    """

    height_m: float
    height_std_m: float
    curvature_per_m2: float
    curvature_std_per_m2: float


def grazing_tan2(altitude_m: ArrayLike, r_end_m: ArrayLike) -> FloatArray:
    """``tan^2`` of the depression of the ray from the sonar to the shadow end (flat seabed).

    ``sin(theta) = H / r_end``, so ``tan^2(theta) = H^2 / (r_end^2 - H^2)``.

    Parameters
    ----------
    altitude_m, r_end_m : array_like, broadcast together
        Sonar altitude and shadow-end slant range, m (``r_end > H > 0``).
    """
    altitude = check_positive_finite(altitude_m, "altitude_m")
    end = check_positive_finite(r_end_m, "r_end_m")
    if not np.all(end > altitude):
        raise SolverError(f"shadow end slant range must exceed the altitude, got {end!r} vs {altitude!r}")
    return np.asarray(altitude**2 / (end**2 - altitude**2), dtype=np.float64)


def fit_rounded_top(grazing_height_m: ArrayLike, grazing_std_m: ArrayLike, tan2_depression: ArrayLike) -> RoundedTopFit:
    """Summit height of a half-ellipsoid from the heights of its grazing points.

    A ray at depression ``theta`` grazes a half-ellipse of half-length ``a`` (along the
    ray) and height ``c`` at the height ``z = c / sqrt(1 + (a/c)^2 tan^2 theta)``: the
    shadow's far top edge is that grazing point, so each frame's one-frame height
    ``H u`` is ``z``, lower than the summit and lower the steeper the ray. Exactly,
    ``1 / z^2 = 1 / c^2 + k tan^2 theta`` with ``k = a^2 / c^4``: a straight line in
    ``tan^2 theta`` whose intercept gives ``c``. Fitted by weighted least squares
    (``sigma(1/z^2) = 2 sigma_z / z^3``); a sharp edge (box) gives ``k = 0``.

    Parameters
    ----------
    grazing_height_m, grazing_std_m : array_like, shape (N,)
        Grazing-point heights ``z_i`` (> 0) and their 1-sigma, m (independent).
    tan2_depression : array_like, shape (N,)
        ``tan^2`` of each frame's shadow-ray depression (:func:`grazing_tan2`), at least
        two distinct values.

    Returns
    -------
    RoundedTopFit

    Raises
    ------
    SolverError
        For fewer than two points, one viewing angle only, non-positive heights or a fit
        whose intercept is not positive (no summit).
    """
    z = check_positive_finite(grazing_height_m, "grazing_height_m")
    sz = check_positive_finite(grazing_std_m, "grazing_std_m")
    t = np.asarray(tan2_depression, dtype=np.float64)
    if z.ndim != 1 or z.shape != sz.shape or z.shape != t.shape:
        raise SolverError(
            f"grazing heights, sigmas and tan^2 need one shape (N,), got {z.shape}, {sz.shape}, {t.shape}"
        )
    if z.size < 2 or not np.all(np.isfinite(t)) or np.ptp(t) <= 0:
        raise SolverError("a rounded top needs grazing heights seen at two or more depression angles")
    y = 1.0 / z**2
    w = 1.0 / (2.0 * sz / z**3) ** 2
    sw = float(np.sum(w))
    t_bar = float(np.sum(w * t)) / sw
    d = t - t_bar
    dwd = float(np.sum(w * d * d))
    if not dwd > 0:
        raise SolverError("rounded-top fit is singular: the depression angles do not differ")
    k = float(np.sum(w * d * y)) / dwd
    y_bar = float(np.sum(w * y)) / sw
    intercept = y_bar - k * t_bar
    var_intercept = 1.0 / sw + t_bar**2 / dwd
    if not intercept > 0:
        raise SolverError("rounded-top fit has no summit (non-positive intercept of 1/z^2)")
    c = intercept**-0.5
    return RoundedTopFit(
        height_m=float(c),
        height_std_m=float(0.5 * math.sqrt(var_intercept) * intercept**-1.5),
        curvature_per_m2=k,
        curvature_std_per_m2=float(math.sqrt(1.0 / dwd)),
    )


#: Aspects ``a / c`` (half-length along the ray over height) searched by
#: :func:`summit_from_near_echo`, and the points of each half-ellipse's front quarter (at
#: the nearest point the range is stationary: 1.4 deg steps move it by well under 0.1 mm).
_ASPECTS = np.geomspace(1e-3, 8.0, 160)
_FRONT = np.linspace(0.0, 0.5 * math.pi, 65)
_COS_FRONT, _SIN_FRONT = np.cos(_FRONT), np.sin(_FRONT)


class NearEchoSummit(NamedTuple):
    """:func:`summit_from_near_echo`'s half-ellipsoid: its height ``c`` (the summit) and
    half-length ``a`` along the ray, m (NaN when not determined)."""

    height_m: float
    half_length_m: float


def summit_from_near_echo(altitude_m: float, r_near_m: float, r_top_m: float, r_end_m: float) -> NearEchoSummit:
    """The half-ellipsoid on a flat seabed that casts the shadow seen (its summit and length).

    In the vertical plane of the beam (sonar at height ``H``, the seabed flat), the shadow
    is cast by the ray to its end (depression ``theta``, ``sin(theta) = H / r_end``), which
    grazes the target at the far top edge, at slant range ``r_top``: a rounded top's
    grazing point, below its summit. Of the half-ellipses of height ``c`` and half-length
    ``a`` resting on the seabed that the ray grazes there, the aspect ``a / c`` is fixed
    by where the target's echo starts, ``r_near``: its point nearest the sonar. With the
    grazing point at height ``z`` and ``t = tan(theta)``,

        c = z sqrt(1 + (a/c)^2 t^2),  centre  x_T - z (a/c)^2 t  along the seabed,

    and the nearest point's range falls from ``r_top`` (a vertical edge, ``a -> 0``) as
    the aspect grows: it is searched over aspects from 0.001 to 8 whose front foot is
    ahead of the sonar, and interpolated between the two that bracket ``r_near``.

    The height is ``z`` (half-length 0) when the echo starts at the grazing point (no
    target in front of it); NaN when the ranges give no grazing point above the seabed (``r_top`` not between
    ``H`` and ``r_end``) or no aspect reaches back to ``r_near``.
    """
    none = NearEchoSummit(math.nan, math.nan)
    h, near, top, end = (float(v) for v in (altitude_m, r_near_m, r_top_m, r_end_m))
    if not all(math.isfinite(v) for v in (h, near, top, end)) or not 0.0 < h < top < end:
        return none
    sin_t = h / end
    cos_t = math.sqrt(1.0 - sin_t * sin_t)
    tan_t = sin_t / cos_t
    x_top, z_top = top * cos_t, h - top * sin_t
    if not z_top > 0.0:
        return none
    if near >= top:
        return NearEchoSummit(z_top, 0.0)
    rho = _ASPECTS
    c = z_top * np.sqrt(1.0 + (rho * tan_t) ** 2)
    a = rho * c
    centre = x_top - z_top * rho * rho * tan_t
    ahead = centre - a > 0.0
    # Each aspect's nearest front point to the sonar at (0, h).
    x = centre[:, None] - a[:, None] * _COS_FRONT[None, :]
    z = c[:, None] * _SIN_FRONT[None, :]
    nearest = np.sqrt(np.min(x * x + (z - h) ** 2, axis=1))
    nearest = np.where(ahead, nearest, np.inf)
    below = np.nonzero(nearest <= near)[0]
    if below.size == 0 or below[0] == 0:
        return none
    k = int(below[0])
    r0, r1 = float(nearest[k - 1]), float(nearest[k])
    f = (r0 - near) / (r0 - r1) if r0 > r1 else 1.0
    return NearEchoSummit(float(c[k - 1] + f * (c[k] - c[k - 1])), float(a[k - 1] + f * (a[k] - a[k - 1])))
