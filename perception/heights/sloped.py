"""Target height on a sloped (planar) seabed, through perpendicular distances to the plane."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import replace

import numpy as np
from numpy.typing import ArrayLike

from perception.errors import SolverError
from perception.geometry import SeabedPlane
from perception.heights.least_squares import HeightEstimate, ShadowObservation, check_positive_finite, solve_height


def solve_height_sloped(
    observations: Sequence[ShadowObservation],
    sonar_position_ned_m: ArrayLike,
    plane: SeabedPlane,
    *,
    position_std_m: float | None = None,
) -> HeightEstimate:
    """Target height on a sloped (planar) seabed through perpendicular distances.

    The flat-seabed relation holds with ``H`` the sonar's perpendicular distance to the
    seabed plane and ``h`` the target top's perpendicular height above it, because the
    shadow end is where the ray through the top edge meets the plane. Each frame's
    perpendicular distance comes from the sonar position:

    - plane with a known point (``plane.point_ned_m``, e.g. fitted from the sonar's own
      seabed returns with :meth:`SeabedPlane.fit`): ``P_i = plane.height_above_m(p_i)``,
      then as :func:`solve_height` with altitudes known;
    - orientation only: ``dP_i = n . (p_i - p_0)`` and ``(h, P0)`` by least squares, as
      :func:`solve_height` with altitudes unknown (needs >= 2 frames whose perpendicular
      distances differ). An error common to all positions only shifts ``P0``.

    Parameters
    ----------
    observations : sequence of ShadowObservation
        One per frame; their ``delta_h_m`` and ``altitude_m`` are ignored (replaced by the
        perpendicular distances).
    sonar_position_ned_m : array_like, shape (N, 3)
        Sonar acoustic centre of each frame in local NED, m.
    plane : SeabedPlane
        The seabed plane (local NED).
    position_std_m : float, optional
        1-sigma of each position coordinate, m, independent between frames.

    Returns
    -------
    HeightEstimate
        ``height_m`` perpendicular to the plane; ``ref_altitude_m`` is the perpendicular
        distance of the first frame (or the mean reference when the point is known).

    Raises
    ------
    SolverError
        For a position array of the wrong shape or non-finite, and everything
        :func:`solve_height` raises.
    """
    n = len(observations)
    positions = np.asarray(sonar_position_ned_m, dtype=np.float64)
    if positions.shape != (n, 3):
        raise SolverError(f"sonar_position_ned_m must have shape ({n}, 3) for {n} observations, got {positions.shape}")
    if not np.all(np.isfinite(positions)):
        raise SolverError("sonar_position_ned_m must be finite")
    normal = np.asarray(plane.normal_ned, dtype=np.float64)
    sigma = 0.0 if position_std_m is None else float(position_std_m)
    check_positive_finite(sigma, "position_std_m", allow_zero=True)
    if plane.point_ned_m is not None:
        distance = plane.height_above_m(positions)
        if not np.all(distance > 0):
            raise SolverError(f"every sonar position must lie above the seabed plane, distances {distance!r}")
        obs = [
            replace(o, delta_h_m=float(d - distance[0]), altitude_m=float(d))
            for o, d in zip(observations, distance, strict=True)
        ]
        return solve_height(obs, altitude_std_m=sigma)
    along = (positions - positions[0]) @ normal
    obs = [replace(o, delta_h_m=float(d), altitude_m=math.nan) for o, d in zip(observations, along, strict=True)]
    cov = None if sigma == 0 else np.full(n, sigma**2)
    return solve_height(obs, delta_h_cov_m2=cov)
