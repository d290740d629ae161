"""Target height from cast shadows: the geometry, the paper's Eq. 2, one- and two-frame heights.

For a sonar ``H`` above a flat seabed and a target whose top edge is at slant range
``r_top``, the ray through that edge meets the seabed (the shadow end) at
``r_end = r_top * H / (H - h)``, whatever the sonar's tilt, pitch or roll: top edge and
shadow end lie on one ray. With ``rho = r_top / r_end`` and ``u = 1 - rho``:

- one frame, ``H`` known: ``h = H * u``;
- frames at altitudes ``H_i = H0 + dH_i``: ``h - H0 * u_i = dH_i * u_i``, linear in
  ``(h, H0)``; two frames give it in closed form, more frames by weighted least squares;
- a sloped seabed: the same relation with ``H`` and ``h`` measured perpendicular to the
  seabed plane (:func:`solve_height_sloped`).

Every range is a slant range from range ZERO (the sonar's acoustic centre), never from the
start of the range window or the bottom of a fan image; that mistake is the error the paper
reports for its fan-shaped images. Units: metres (``eq2_paper`` takes any one unit).
"""

from __future__ import annotations

import math
from typing import overload

import numpy as np
from numpy.typing import ArrayLike, NDArray

from perception.errors import SolverError
from perception.geometry.shadow import height_from_shadow_m

FloatArray = NDArray[np.float64]


def eq2_paper(R1: float, L1: float, R2: float, L2: float, delta_h: float) -> float:
    """The paper's Eq. 2 exactly as published.

    ``h = dH * L1 * L2 / ((L1 + R1) * L2 - (L2 + R2) * L1)``

    Parameters
    ----------
    R1, R2 : float
        Distance from the shadow's critical point (target top edge) to the "detection
        baseline" in images 1 and 2, any unit (the paper: pixels).
    L1, L2 : float
        Shadow lengths in the same unit.
    delta_h : float
        Altitude variation, in the unit wanted for ``h``.

    Returns
    -------
    float
        The height. With ``R`` measured from range zero and ``L = r_end - R`` it is the
        true height when ``delta_h = H1 - H2`` (first altitude minus second); the paper's
        Table III lists ``|h|`` for ``delta_h = 0.10 m`` with image 2 the higher one.

    Raises
    ------
    SolverError
        For non-finite input or a zero denominator (both shadows give one range ratio).
    """
    values = (R1, L1, R2, L2, delta_h)
    if not all(math.isfinite(float(v)) for v in values):
        raise SolverError(f"Eq. 2 needs finite R1, L1, R2, L2, delta_h, got {values!r}")
    denominator = (L1 + R1) * L2 - (L2 + R2) * L1
    if denominator == 0:
        raise SolverError(
            "Eq. 2 denominator is zero: both images give the same R/L ratio, so the "
            "altitude change left no trace in the shadows"
        )
    return float(delta_h * L1 * L2 / denominator)


def shadow_ranges(r_top_m: ArrayLike, r_end_m: ArrayLike) -> tuple[FloatArray, FloatArray]:
    top = np.asarray(r_top_m, dtype=np.float64)
    end = np.asarray(r_end_m, dtype=np.float64)
    if not (np.all(np.isfinite(top)) and np.all(np.isfinite(end))):
        raise SolverError("shadow ranges must be finite")
    if not np.all(top > 0):
        raise SolverError(f"shadow start range must be > 0 m, got {top!r}")
    if not np.all(end > top):
        raise SolverError(
            f"shadow end range must exceed the shadow start range (r_end > r_top), got r_top={top!r}, r_end={end!r}"
        )
    return top, end


@overload
def height_one_frame(r_top_m: float, r_shadow_end_m: float, altitude_m: float) -> float: ...
@overload
def height_one_frame(r_top_m: ArrayLike, r_shadow_end_m: ArrayLike, altitude_m: ArrayLike) -> float | FloatArray: ...
def height_one_frame(r_top_m: ArrayLike, r_shadow_end_m: ArrayLike, altitude_m: ArrayLike) -> float | FloatArray:
    """Target height from one frame with the sonar altitude known, flat seabed.

    ``h = H * (r_end - r_top) / r_end``

    Parameters
    ----------
    r_top_m : float or array_like
        Slant range of the shadow start (the target's far top edge) from range zero, m.
    r_shadow_end_m : float or array_like
        Slant range of the shadow end, m, > ``r_top_m``.
    altitude_m : float or array_like
        Sonar height above the seabed, m, > 0. All three broadcast together.

    Returns
    -------
    float or ndarray
        Height, m: a float for scalar input, else an array of the broadcast shape.

    Raises
    ------
    SolverError
        For non-finite input, ``r_end <= r_top``, ``r_top <= 0`` or altitude <= 0.
    """
    top, end = shadow_ranges(r_top_m, r_shadow_end_m)
    altitude = np.asarray(altitude_m, dtype=np.float64)
    if not np.all(np.isfinite(altitude) & (altitude > 0)):
        raise SolverError(f"altitude must be finite and > 0 m, got {altitude!r}")
    h = height_from_shadow_m(top, end, altitude)
    return float(h) if h.ndim == 0 else h


def height_two_frames(r_top1_m: float, r_end1_m: float, r_top2_m: float, r_end2_m: float, delta_h_m: float) -> float:
    """Target height from two frames whose altitudes differ by ``delta_h_m`` (flat seabed).

    With ``rho_i = r_top_i / r_end_i`` and ``H2 = H1 + dH``:
    ``h = dH (1 - rho1)(1 - rho2) / (rho2 - rho1)``, evaluated as
    ``dH (e1 - t1)(e2 - t2) / (t2 e1 - t1 e2)``. This is the paper's Eq. 2 with ranges
    from range zero and the sign of ``dH`` stated: ``dH`` is the second altitude minus
    the first.

    Parameters
    ----------
    r_top1_m, r_end1_m, r_top2_m, r_end2_m : float
        Shadow start and end slant ranges in frames 1 and 2, m, from range zero.
    delta_h_m : float
        Altitude of frame 2 minus altitude of frame 1, m.

    Raises
    ------
    SolverError
        For bad ranges, non-finite ``delta_h_m``, or equal range ratios (no altitude
        change visible).
    """
    (t1, t2), (e1, e2) = shadow_ranges([r_top1_m, r_top2_m], [r_end1_m, r_end2_m])
    if not math.isfinite(delta_h_m):
        raise SolverError(f"delta_h_m must be finite, got {delta_h_m!r}")
    denominator = t2 * e1 - t1 * e2
    if denominator == 0:
        raise SolverError(
            "both frames give the same range ratio r_top / r_end: the altitude change left "
            "no trace (equal altitudes or inconsistent ranges)"
        )
    return float(delta_h_m * (e1 - t1) * (e2 - t2) / denominator)
