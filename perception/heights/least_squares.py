"""The N-frame height solver: weighted least squares for ``(h, H0)`` from the shadows of frames
at altitudes ``H0 + dH_i`` (or known altitudes), with first-order uncertainty.

``h - H0 * u_i = dH_i * u_i`` with ``u_i = 1 - r_top_i / r_end_i`` (see
:mod:`perception.heights.eq2` for the geometry). Each range has standard deviation
``sigma_r`` (independent), so ``var(u) = sigma_r**2 * (r_end**2 + r_top**2) / r_end**4``; the
altitude differences have a joint covariance (e.g. from the altitude filter). The
least-squares residual of frame i is ``u_i * H_i - h``, with covariance
``diag(H_i**2 var(u_i)) + diag(u) C_dH diag(u)``; its inverse weights the fit, iterated
because ``H_i`` depends on the solved ``H0`` (effective-variance method).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from perception.errors import SolverError
from perception.heights.eq2 import shadow_ranges

FloatArray = NDArray[np.float64]


#: Most re-weighting passes of the N-frame least squares (weights depend on the solved
#: H0); it stops earlier once H0 changes by less than 1e-9 relative.
WLS_ITERATIONS = 6

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


def check_positive_finite(value: ArrayLike, name: str, *, allow_zero: bool = False) -> FloatArray:
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
        c = np.diag(check_positive_finite(c, "delta_h_cov_m2 (variances)", allow_zero=True))
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
    top, end = shadow_ranges(r_top_m, r_end_m)
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
    sigma_r = np.broadcast_to(check_positive_finite(sigma_r_m, "sigma_r_m"), top.shape)
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
    top, end = shadow_ranges([o.r_top_m for o in observations], [o.r_end_m for o in observations])
    sigma_r = check_positive_finite([o.sigma_r_m for o in observations], "sigma_r_m")
    dh = np.array([o.delta_h_m for o in observations], dtype=np.float64)
    if not np.all(np.isfinite(dh)):
        raise SolverError(f"delta_h_m must be finite, got {dh!r}")
    if all(math.isfinite(o.altitude_m) for o in observations):
        std = 0.0 if altitude_std_m is None else float(altitude_std_m)
        check_positive_finite(std, "altitude_std_m", allow_zero=True)
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
