"""Target height from cast shadows: the paper's Eq. 2 and the solvers built on its geometry.

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

Uncertainty is propagated to first order: each range has standard deviation ``sigma_r``
(independent), so ``var(u) = sigma_r**2 * (r_end**2 + r_top**2) / r_end**4``; the
altitude differences have a joint covariance (e.g. from the altitude filter). The
least-squares residual of frame i is ``u_i * H_i - h``, with covariance
``diag(H_i**2 var(u_i)) + diag(u) C_dH diag(u)``; its inverse weights the fit, iterated
because ``H_i`` depends on the solved ``H0`` (effective-variance method).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import overload

import numpy as np
from numpy.typing import ArrayLike, NDArray

from perception.errors import SolverError
from perception.geometry import SeabedPlane
from perception.geometry.shadow import height_from_shadow_m

FloatArray = NDArray[np.float64]

#: Most re-weighting passes of the N-frame least squares (weights depend on the solved
#: H0); it stops earlier once H0 changes by less than 1e-9 relative.
WLS_ITERATIONS = 6


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


def _ranges(r_top_m: ArrayLike, r_end_m: ArrayLike) -> tuple[FloatArray, FloatArray]:
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
    top, end = _ranges(r_top_m, r_shadow_end_m)
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
    (t1, t2), (e1, e2) = _ranges([r_top1_m, r_top2_m], [r_end1_m, r_end2_m])
    if not math.isfinite(delta_h_m):
        raise SolverError(f"delta_h_m must be finite, got {delta_h_m!r}")
    denominator = t2 * e1 - t1 * e2
    if denominator == 0:
        raise SolverError(
            "both frames give the same range ratio r_top / r_end: the altitude change left "
            "no trace (equal altitudes or inconsistent ranges)"
        )
    return float(delta_h_m * (e1 - t1) * (e2 - t2) / denominator)


@dataclass(frozen=True)
class ShadowObservation:
    """One frame's shadow of one target.

    Attributes
    ----------
    r_top_m : float
        Slant range of the shadow start (the target's far top edge), from range ZERO, m.
    r_end_m : float
        Slant range of the shadow end, m.
    sigma_r_m : float
        1-sigma of each range measurement, m (e.g. from the range resolution), > 0.
    delta_h_m : float
        This frame's altitude minus the reference altitude ``H0``, m.
    altitude_m : float
        This frame's absolute altitude when known, m; NaN when not.
    """

    r_top_m: float
    r_end_m: float
    sigma_r_m: float
    delta_h_m: float = 0.0
    altitude_m: float = math.nan


@dataclass(frozen=True)
class HeightEstimate:
    """A target height with its propagated uncertainty.

    Attributes
    ----------
    height_m, height_std_m : float
        Target height above the seabed (perpendicular to it for a sloped seabed) and its
        1-sigma, m.
    ref_altitude_m, ref_altitude_std_m : float
        The reference altitude ``H0`` (solved, or from the given altitudes) and its 1-sigma.
    frames_used : int
        Number of observations used.
    residual_rms_m : float
        RMS of the per-frame residuals ``u_i H_i - h``, m (0 for an exactly determined fit).
    """

    height_m: float
    height_std_m: float
    ref_altitude_m: float
    ref_altitude_std_m: float
    frames_used: int
    residual_rms_m: float


@dataclass(frozen=True)
class BatchHeightEstimate:
    """:class:`HeightEstimate` for many independent problems, arrays of shape (...)."""

    height_m: FloatArray
    height_std_m: FloatArray
    ref_altitude_m: FloatArray
    ref_altitude_std_m: FloatArray
    residual_rms_m: FloatArray


def _check_positive_finite(value: ArrayLike, name: str, *, allow_zero: bool = False) -> FloatArray:
    array = np.asarray(value, dtype=np.float64)
    ok = np.isfinite(array) & ((array >= 0) if allow_zero else (array > 0))
    if not np.all(ok):
        bound = ">= 0" if allow_zero else "> 0"
        raise SolverError(f"{name} must be finite and {bound}, got {array!r}")
    return array


def _dh_covariance(cov: ArrayLike | None, n: int) -> FloatArray:
    if cov is None:
        return np.zeros((n, n))
    c = np.asarray(cov, dtype=np.float64)
    if c.shape == (n,):
        c = np.diag(_check_positive_finite(c, "delta_h_cov_m2 (variances)", allow_zero=True))
    if c.shape != (n, n):
        raise SolverError(f"delta_h_cov_m2 must have shape ({n},) or ({n}, {n}) for {n} frames, got {c.shape}")
    if not np.all(np.isfinite(c)):
        raise SolverError("delta_h_cov_m2 must be finite")
    if not np.allclose(c, c.T, rtol=1e-9, atol=1e-15) or np.any(np.diag(c) < 0):
        raise SolverError("delta_h_cov_m2 must be symmetric with non-negative variances")
    return c


def _u_and_variance(top: FloatArray, end: FloatArray, sigma_r: FloatArray) -> tuple[FloatArray, FloatArray]:
    u = (end - top) / end
    var_u = sigma_r**2 * (end**2 + top**2) / end**4
    return u, var_u


def solve_height_batch(
    r_top_m: ArrayLike,
    r_end_m: ArrayLike,
    delta_h_m: ArrayLike,
    *,
    sigma_r_m: ArrayLike,
    delta_h_cov_m2: ArrayLike | None = None,
) -> BatchHeightEstimate:
    """Weighted least squares for ``(h, H0)`` over many independent problems at once.

    Each problem is a set of N frames at altitudes ``H0 + dH_i`` (flat seabed), solved from
    ``h - H0 u_i = dH_i u_i`` as described in the module docstring. :func:`solve_height`
    uses this for its unknown-altitude case.

    Parameters
    ----------
    r_top_m, r_end_m : array_like, shape (..., N)
        Shadow start and end slant ranges from range zero, m.
    delta_h_m : array_like, shape (..., N) or (N,)
        Each frame's altitude minus ``H0``, m; at least two distinct values per problem.
    sigma_r_m : array_like, broadcastable to (..., N)
        1-sigma of each range, m, > 0.
    delta_h_cov_m2 : array_like, shape (N,) or (N, N), optional
        Variances or joint covariance of the ``dH_i``, m^2 (shared by all problems).

    Returns
    -------
    BatchHeightEstimate
        Arrays of shape (...).

    Raises
    ------
    SolverError
        For bad ranges, fewer than 2 frames, all ``dH`` equal, or a singular system.
    """
    top, end = _ranges(r_top_m, r_end_m)
    if top.shape != end.shape or top.ndim < 1:
        raise SolverError(f"r_top_m and r_end_m need one shape (..., N), got {top.shape} and {end.shape}")
    n = top.shape[-1]
    if n < 2:
        raise SolverError(f"solving for height without absolute altitude needs >= 2 frames, got {n}")
    dh = np.asarray(delta_h_m, dtype=np.float64)
    if not np.all(np.isfinite(dh)):
        raise SolverError("delta_h_m must be finite")
    try:
        dh = np.broadcast_to(dh, top.shape)
    except ValueError as exc:
        raise SolverError(f"delta_h_m shape {dh.shape} does not fit ranges {top.shape}") from exc
    if np.any(np.ptp(dh, axis=-1) == 0):
        raise SolverError("all frames have the same delta_h_m: the altitude must change between frames")
    sigma_r = np.broadcast_to(_check_positive_finite(sigma_r_m, "sigma_r_m"), top.shape)
    cov_dh = _dh_covariance(delta_h_cov_m2, n)

    u, var_u = _u_and_variance(top, end, sigma_r)
    target = dh * u  # y_i = dH_i u_i = h - H0 u_i, (..., N)
    # Uncorrelated dH errors (the usual case) keep the weight matrix diagonal: store only
    # its diagonal and skip the matrix inverses.
    full = bool(np.any(cov_dh != np.diag(np.diag(cov_dh))))
    cov_from_dh = u[..., :, None] * cov_dh * u[..., None, :] if full else None
    var_from_dh = u**2 * np.diag(cov_dh)

    # Centred form: with u_bar the W-weighted mean of u and d = u - u_bar,
    # y = a - H0 d with a = h - H0 u_bar, and the normal equations are diagonal
    # (1' W d = 0). This avoids the ill-conditioning of [1, -u] when the u_i are close.
    # Weights: the diagonal (..., N), or the full matrix (..., N, N) when dH errors correlate.
    weights = np.broadcast_to(np.eye(n), (*u.shape, n)) if full else np.ones_like(u)

    def weighted(x: FloatArray) -> FloatArray:
        return (weights @ x[..., None])[..., 0] if full else weights * x

    previous = np.full(u.shape[:-1], np.nan)
    for iteration in range(WLS_ITERATIONS + 1):
        w_one = weighted(np.ones_like(u))  # W @ 1, (..., N)
        sum_w = w_one.sum(axis=-1)  # 1' W 1
        u_bar = np.sum(w_one * u, axis=-1) / sum_w
        d = u - u_bar[..., None]
        w_d = weighted(d)
        d_w_d = np.sum(d * w_d, axis=-1)
        if not np.all(np.isfinite(d_w_d) & (d_w_d > 0) & np.isfinite(sum_w) & (sum_w > 0)):
            raise SolverError("height least squares is singular: the shadows do not change with altitude")
        a = np.sum(w_one * target, axis=-1) / sum_w
        ref_altitude = -np.sum(w_d * target, axis=-1) / d_w_d
        if iteration == WLS_ITERATIONS or (
            iteration > 0 and np.all(np.abs(ref_altitude - previous) <= 1e-9 * (1.0 + np.abs(ref_altitude)))
        ):
            break
        previous = ref_altitude
        altitude = ref_altitude[..., None] + dh  # H_i = H0 + dH_i, (..., N)
        if cov_from_dh is not None:
            cov_res = cov_from_dh + np.eye(n) * (altitude**2 * var_u)[..., None, :]
            weights = np.asarray(np.linalg.inv(cov_res), dtype=np.float64)
        else:
            weights = 1.0 / (altitude**2 * var_u + var_from_dh)
    height = a + ref_altitude * u_bar
    var_ref = 1.0 / d_w_d
    residual = u * (ref_altitude[..., None] + dh) - height[..., None]
    return BatchHeightEstimate(
        height_m=height,
        height_std_m=np.sqrt(1.0 / sum_w + u_bar**2 * var_ref),
        ref_altitude_m=ref_altitude,
        ref_altitude_std_m=np.sqrt(var_ref),
        residual_rms_m=np.sqrt(np.mean(residual**2, axis=-1)),
    )


def _solve_known_altitude(
    observations: Sequence[ShadowObservation],
    top: FloatArray,
    end: FloatArray,
    sigma_r: FloatArray,
    altitude_std_m: float,
) -> HeightEstimate:
    altitude = np.array([o.altitude_m for o in observations])
    if not np.all(np.isfinite(altitude) & (altitude > 0)):
        raise SolverError(f"altitude_m must be finite and > 0 m, got {altitude!r}")
    u, var_u = _u_and_variance(top, end, sigma_r)
    h_each = altitude * u
    var_each = altitude**2 * var_u + u**2 * altitude_std_m**2
    w = 1.0 / var_each
    h = float(np.sum(w * h_each) / np.sum(w))
    ref = altitude - np.array([o.delta_h_m for o in observations])
    n = len(observations)
    return HeightEstimate(
        height_m=h,
        height_std_m=float(1.0 / math.sqrt(float(np.sum(w)))),
        ref_altitude_m=float(np.mean(ref)),
        ref_altitude_std_m=altitude_std_m / math.sqrt(n),
        frames_used=n,
        residual_rms_m=float(np.sqrt(np.mean((h_each - h) ** 2))),
    )


def solve_height(
    observations: Sequence[ShadowObservation],
    *,
    delta_h_cov_m2: ArrayLike | None = None,
    altitude_std_m: float | None = None,
) -> HeightEstimate:
    """Target height from the shadows of one target in one or more frames (flat seabed).

    If every observation carries ``altitude_m``, each frame gives ``h_i = H_i u_i`` and
    the result is their inverse-variance weighted mean (variance from ``sigma_r_m`` and
    ``altitude_std_m``, altitude errors taken independent between frames); ``H0`` is
    reported as the mean of ``altitude_m - delta_h_m``.
    Otherwise ``altitude_m`` is ignored and ``(h, H0)`` are solved by weighted least
    squares from ``delta_h_m`` (:func:`solve_height_batch`), which needs >= 2 frames with
    distinct ``delta_h_m``.

    Parameters
    ----------
    observations : sequence of ShadowObservation
        One per frame.
    delta_h_cov_m2 : array_like, shape (N,) or (N, N), optional
        Variances or joint covariance of the observations' ``delta_h_m``, m^2 (e.g. from
        the altitude filter). Only used when altitudes are unknown.
    altitude_std_m : float, optional
        1-sigma of each given ``altitude_m``, m. Only used when all altitudes are known.

    Returns
    -------
    HeightEstimate

    Raises
    ------
    SolverError
        Naming the problem: no observations, non-finite input, ``r_end <= r_top``, a
        non-positive ``sigma_r_m``, fewer than 2 frames without altitude, all ``delta_h_m``
        equal, or a malformed covariance.
    """
    n = len(observations)
    if n == 0:
        raise SolverError("no shadow observations given")
    top, end = _ranges([o.r_top_m for o in observations], [o.r_end_m for o in observations])
    sigma_r = _check_positive_finite([o.sigma_r_m for o in observations], "sigma_r_m")
    dh = np.array([o.delta_h_m for o in observations], dtype=np.float64)
    if not np.all(np.isfinite(dh)):
        raise SolverError(f"delta_h_m must be finite, got {dh!r}")
    if all(math.isfinite(o.altitude_m) for o in observations):
        std = 0.0 if altitude_std_m is None else float(altitude_std_m)
        _check_positive_finite(std, "altitude_std_m", allow_zero=True)
        return _solve_known_altitude(observations, top, end, sigma_r, std)
    if n < 2:
        raise SolverError(
            "one frame without altitude_m cannot give a height: need >= 2 frames at "
            "different altitudes (distinct delta_h_m) or the absolute altitude"
        )
    batch = solve_height_batch(top, end, dh, sigma_r_m=sigma_r, delta_h_cov_m2=delta_h_cov_m2)
    return HeightEstimate(
        height_m=float(batch.height_m),
        height_std_m=float(batch.height_std_m),
        ref_altitude_m=float(batch.ref_altitude_m),
        ref_altitude_std_m=float(batch.ref_altitude_std_m),
        frames_used=n,
        residual_rms_m=float(batch.residual_rms_m),
    )


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
    _check_positive_finite(sigma, "position_std_m", allow_zero=True)
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
    altitude = _check_positive_finite(altitude_m, "altitude_m")
    end = _check_positive_finite(r_end_m, "r_end_m")
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
    z = _check_positive_finite(grazing_height_m, "grazing_height_m")
    sz = _check_positive_finite(grazing_std_m, "grazing_std_m")
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
