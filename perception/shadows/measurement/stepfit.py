"""Sub-sample edge of a blurred step, fitted in many profiles at once.

A shadow's edges in one beam are steps of linear echo power between two levels, blurred
by the pulse (range), the beam pattern (azimuth: an edge oblique to the beams smears in
range by its slope across a beam width) and any smoothing. For any blur that is symmetric
about the edge, the edge is where the blurred step crosses half-way between its two
levels in LINEAR power. Estimating those levels from windows beside the edge is biased
when the blur is wider than expected (the window then samples the ramp and moves the
half-way level); fitting the whole step instead is not:

    y(x) = a + b * Phi(sign * (x0 - x) / s)

with ``Phi`` the standard normal CDF, levels ``a`` (far side) and ``a + b`` (near side),
edge ``x0`` and blur ``s`` free, by damped Gauss-Newton (Levenberg-Marquardt), all
profiles together (arrays of shape (n_profiles, n_samples); each profile has its own
window as 0/1 weights). ``sign`` +1 fits a fall (bright before the edge, dark after: the
far top edge), -1 a rise (the shadow's end, a highlight's start).

Units: ``x`` in samples (any origin), the levels in the profiles' units.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.special import ndtr

FloatArray = NDArray[np.float64]

#: Gauss-Newton iterations, the first ones unweighted.
ITERATIONS = 10
UNWEIGHTED_ITERATIONS = 3
#: Weights use means floored at this fraction of the bright level.
FLOOR_FRACTION = 0.02
#: Narrowest and widest blur fitted, samples.
MIN_BLUR_SAMPLES = 0.3
_SQRT_2PI = float(np.sqrt(2.0 * np.pi))


@dataclass(frozen=True)
class StepFit:
    """Fitted steps, arrays of shape (n_profiles,).

    Attributes
    ----------
    edge : ndarray
        ``x0``, samples (in the profiles' x).
    edge_std : ndarray
        1-sigma of ``x0`` from the fit's residuals, samples.
    low, high : ndarray
        The dark and the bright level (``a`` and ``a + b`` for a positive ``b``).
    blur : ndarray
        ``s``, samples.
    ok : ndarray, bool
        Converged to a step of positive contrast inside its window.
    """

    edge: FloatArray
    edge_std: FloatArray
    low: FloatArray
    high: FloatArray
    blur: FloatArray
    ok: NDArray[np.bool_]


def _levels(phi: FloatArray, y: FloatArray, w: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Weighted least-squares ``a, b`` of ``y = a + b phi`` per profile."""
    sw = w.sum(axis=1)
    sp = (w * phi).sum(axis=1)
    spp = (w * phi * phi).sum(axis=1)
    sy = (w * y).sum(axis=1)
    spy = (w * phi * y).sum(axis=1)
    det = sw * spp - sp * sp
    safe = np.where(np.abs(det) > 1e-12 * np.maximum(sw * spp, 1e-300), det, np.nan)
    b = (sw * spy - sp * sy) / safe
    a = (sy - b * sp) / np.maximum(sw, 1e-300)
    return a, b


def fit_steps(
    y: FloatArray,
    weights: FloatArray,
    *,
    edge0: FloatArray,
    blur0: float | FloatArray,
    sign: float = 1.0,
) -> StepFit:
    """Fit ``y = a + b Phi(sign (x0 - x) / s)`` to each row of ``y`` (x = 0, 1, 2, ...).

    Parameters
    ----------
    y : ndarray, shape (n, m)
        Profiles (linear power).
    weights : ndarray, shape (n, m)
        1 inside each profile's window, 0 outside (or any non-negative weights).
    edge0 : ndarray, shape (n,)
        Starting edges, samples.
    blur0 : float or ndarray
        Starting blur, samples.
    sign : float
        +1: bright before the edge (a fall); -1: a rise.

    Returns
    -------
    StepFit
    """
    y = np.asarray(y, dtype=np.float64)
    w = np.asarray(weights, dtype=np.float64)
    n, m = y.shape
    x = np.arange(m, dtype=np.float64)[None, :]
    inside = w > 0
    first = np.where(inside.any(axis=1), inside.argmax(axis=1), 0).astype(np.float64)
    last = np.where(inside.any(axis=1), m - 1 - inside[:, ::-1].argmax(axis=1), m - 1).astype(np.float64)
    x0 = np.clip(np.asarray(edge0, dtype=np.float64), first, last)
    span = np.maximum(last - first, 1.0)
    s = np.clip(np.broadcast_to(np.asarray(blur0, dtype=np.float64), (n,)).copy(), MIN_BLUR_SAMPLES, span / 2)
    lam = np.full(n, 1e-2)

    def model(x0: FloatArray, s: FloatArray, wt: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray,
                                                                       FloatArray, FloatArray]:
        z = sign * (x0[:, None] - x) / s[:, None]
        phi = ndtr(z)
        a, b = _levels(phi, y, wt)
        r = y - (a[:, None] + b[:, None] * phi)
        return z, phi, a, b, r

    z, phi, a, b, r = model(x0, s, w)
    wt = w
    for it in range(ITERATIONS):
        if it >= UNWEIGHTED_ITERATIONS:
            # Speckle is multiplicative: a sample's variance grows as its mean squared, so
            # each sample is weighted by 1 / mean^2 (the gamma likelihood's score equations);
            # unweighted, the bright side's noise pulls the edge towards it. The mean is
            # floored at a small fraction of the bright level (a dark level near zero would
            # take every weight).
            floor = np.maximum(FLOOR_FRACTION * np.abs(a + b), 1e-300)[:, None]
            mean = np.maximum(a[:, None] + b[:, None] * phi, floor)
            wt = w / (mean * mean)
            z, phi, a, b, r = model(x0, s, wt)
        cost = (wt * r * r).sum(axis=1)
        dens = np.exp(-0.5 * z * z) / _SQRT_2PI
        # d model / d x0 and d model / d log s (a, b at their least squares; variable projection
        # to first order: their own derivatives are orthogonal to the residual)
        j0 = (b / s)[:, None] * dens * sign
        j1 = -b[:, None] * dens * z
        g0 = (wt * j0 * r).sum(axis=1)
        g1 = (wt * j1 * r).sum(axis=1)
        h00 = (wt * j0 * j0).sum(axis=1)
        h01 = (wt * j0 * j1).sum(axis=1)
        h11 = (wt * j1 * j1).sum(axis=1)
        h00d, h11d = h00 * (1 + lam), h11 * (1 + lam)
        det = h00d * h11d - h01 * h01
        det = np.where(np.abs(det) > 1e-300, det, np.inf)
        d0 = (h11d * g0 - h01 * g1) / det
        d1 = (h00d * g1 - h01 * g0) / det
        d1 = np.clip(d1, -0.7, 0.7)
        d0 = np.clip(d0, -0.5 * span, 0.5 * span)
        x_new = np.clip(x0 + d0, first, last)
        s_new = np.clip(s * np.exp(d1), MIN_BLUR_SAMPLES, span / 2)
        z_n, phi_n, a_n, b_n, r_n = model(x_new, s_new, wt)
        cost_n = (wt * r_n * r_n).sum(axis=1)
        better = np.isfinite(cost_n) & (cost_n <= cost)
        keep = better[:, None]
        x0, s = np.where(better, x_new, x0), np.where(better, s_new, s)
        z, phi, r = np.where(keep, z_n, z), np.where(keep, phi_n, phi), np.where(keep, r_n, r)
        a, b, cost = np.where(better, a_n, a), np.where(better, b_n, b), np.where(better, cost_n, cost)
        lam = np.where(better, lam * 0.3, lam * 10.0)
    dens = np.exp(-0.5 * z * z) / _SQRT_2PI
    j0 = (b / s)[:, None] * dens * sign
    floor = np.maximum(FLOOR_FRACTION * np.abs(a + b), 1e-300)[:, None]
    mean = np.maximum(a[:, None] + b[:, None] * phi, floor)
    wt = w / (mean * mean)
    dof = np.maximum(w.sum(axis=1) - 4.0, 1.0)
    var_res = (wt * r * r).sum(axis=1) / dof
    h00 = (wt * j0 * j0).sum(axis=1)
    edge_std = np.sqrt(var_res / np.maximum(h00, 1e-300))
    ok = np.isfinite(x0) & np.isfinite(b) & (b > 0) & (x0 > first) & (x0 < last) & np.isfinite(edge_std)
    return StepFit(edge=x0, edge_std=edge_std, low=a, high=a + b, blur=s, ok=ok)
