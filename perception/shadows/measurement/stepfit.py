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
edge ``x0`` and blur ``s`` free. For given ``x0, s`` the levels are linear least squares,
so the fit searches ``x0, s`` over banks of templates ``Phi((x0 - x) / s)`` (all profiles
against all templates as three matrix products: the cost of every template follows in
closed form): a coarse bank about the expected edge, then a fine one about each profile's
best (the profiles shifted by whole samples so that one bank serves all), and ``x0``
between the fine bank's steps from a parabola through the costs.
Speckle is multiplicative (a sample's variance grows as its mean squared), so after the
first, unweighted search each sample is weighted by ``1 / mean^2`` of the model found
(the gamma likelihood's score equations; unweighted, the bright side's noise pulls the
edge towards it), the mean floored at a small fraction of the bright level.

A rise (``sign`` -1) is the same family of curves (``Phi(-z) = 1 - Phi(z)``) with the
level difference of the other sign: one bank serves both.

Units: ``x`` in samples (0 .. m - 1), the levels in the profiles' units.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.special import ndtr

FloatArray = NDArray[np.float64]

#: Weights use means floored at this fraction of the bright level.
FLOOR_FRACTION = 0.02
#: Narrowest and widest blur searched, samples (the widest also at most half the window).
MIN_BLUR_SAMPLES = 0.3
MAX_BLUR_SAMPLES = 16.0
#: Blurs of the coarse and of the fine bank (geometric steps between the two bounds).
COARSE_BLURS = 8
FINE_BLURS = 24
#: Edge step of the coarse bank and its reach either side of the expected edge, and of the
#: fine bank about the coarse best, samples.
COARSE_STEP_SAMPLES = 0.5
COARSE_REACH_SAMPLES = 3.0
FINE_STEP_SAMPLES = 0.1
FINE_REACH_SAMPLES = 0.8
FINE_REWEIGHTS = 1
#: Gauss-Newton steps after the banks, their damping (added to the diagonal, as a fraction)
#: and their largest steps.
GN_ITERATIONS = 2
DAMPING = 0.01
MAX_EDGE_STEP_SAMPLES = 0.5
MAX_LOG_BLUR_STEP = 0.35
_SQRT_2PI = math.sqrt(2.0 * math.pi)
#: The Gauss-Newton steps' bounds, (x0, log s) as a column.
_MAX_STEPS = np.array([[MAX_EDGE_STEP_SAMPLES], [MAX_LOG_BLUR_STEP]])
_MAX_STEPS.flags.writeable = False
#: One step either way and none, as a column (the 3 x 3 scores about a bank's best).
_STEPS3 = np.arange(-1, 2)[:, None]
_STEPS3.flags.writeable = False
#: The 4 x 4 identity, (1, 4, 4), read-only (the Fisher matrices' regularisation).
_EYE4 = np.eye(4)[None]
_EYE4.flags.writeable = False


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
        The dark and the bright level.
    blur : ndarray
        ``s``, samples.
    ok : ndarray, bool
        A step of the asked sign's contrast inside its window.
    """

    edge: FloatArray
    edge_std: FloatArray
    low: FloatArray
    high: FloatArray
    blur: FloatArray
    ok: NDArray[np.bool_]


@dataclass(frozen=True)
class _Bank:
    """Templates ``Phi((centre + offset - x) / blur)``, x = 0 .. m - 1: ``t`` (m, K), its
    transpose ``t_rows`` (K, m: a template per row, for picking templates) and
    ``t2 = t * t``, side by side in ``t_t2`` (m, 2 K: one product gives both sums);
    ``offsets`` and ``blurs`` (K,) each; ``n_blurs`` blurs per offset (offsets vary slowest)."""

    t: FloatArray
    t_rows: FloatArray
    t_t2: FloatArray
    offsets: FloatArray
    blurs: FloatArray
    n_blurs: int
    blur_ratio: float


@functools.lru_cache(maxsize=32)
def _bank(m: int, centre: float, reach: float, step: float, n_blurs: int, widest: float) -> _Bank:
    n_off = int(round(reach / step))
    offsets = np.arange(-n_off, n_off + 1) * step
    blurs = np.geomspace(MIN_BLUR_SAMPLES, max(widest, MIN_BLUR_SAMPLES * 1.01), n_blurs)
    off, blur = (v.ravel() for v in np.meshgrid(offsets, blurs, indexing="ij"))
    x = np.arange(m, dtype=np.float64)
    t = ndtr((centre + off[None, :] - x[:, None]) / blur[None, :])
    t_t2 = np.ascontiguousarray(np.hstack([t, t * t]))
    t_rows = np.ascontiguousarray(t.T)
    for array in (t, t_rows, t_t2, off, blur):
        array.flags.writeable = False
    ratio = float(blurs[1] / blurs[0]) if n_blurs > 1 else 1.0
    return _Bank(t=t, t_rows=t_rows, t_t2=t_t2, offsets=off, blurs=blur, n_blurs=n_blurs, blur_ratio=ratio)


@dataclass(frozen=True)
class _Search:
    """The best template of each profile (``best`` (n,) into the bank) with its levels
    ``a`` (after the edge) and ``b`` (before minus after), and every template's ``score``
    (n, K): the weighted sum of squares the template explains beyond a constant, negative
    for a level difference of the wrong sign (the cost is a constant per profile minus it)."""

    best: NDArray[np.intp]
    a: FloatArray
    b: FloatArray
    score: FloatArray


def _search(y: FloatArray, w: FloatArray, bank: _Bank, sign: FloatArray) -> _Search:
    """Weighted least squares of every profile against every template (one product).

    ``sign`` is +1 or -1 per profile."""
    n = y.shape[0]
    k = bank.t.shape[1]
    w_wy = np.empty((2 * n, y.shape[1]))  # rows: w then w y (their sums, and the product's rows)
    w_wy[:n] = w
    np.multiply(w, y, out=w_wy[n:])
    sw, sy = np.add.reduce(w_wy, axis=1).reshape(2, n, 1)
    sums = w_wy @ bank.t_t2  # rows: w then wy; columns: t then t2
    sp = sums[:n, :k]
    # Each first operation reads the product's blocks (strided) into a new contiguous array:
    # the later ones then run over contiguous memory, several times faster. The sign rides on
    # the (n, 1) factors: sign * (sw * spy - sp * sy) = (sign sw) spy - sp (sign sy) exactly
    # (a factor of +-1 only flips signs), so ``num`` holds sign times b det.
    s = sign[:, None]
    num = np.multiply(sums[n:, :k], sw * s)
    scratch = np.multiply(sp, sy * s)
    num -= scratch
    det = np.multiply(sums[:n, k:], sw)
    det -= np.multiply(sp, sp, out=scratch)  # sw * spp - sp^2 >= 0 (0 for a template flat over the window)
    det += 1e-12 * sw * sw
    score = np.abs(num, out=scratch)
    score *= num
    score /= det  # the explained sum of squares times sw, signed
    best = score.argmax(axis=1)
    # The best templates' values by flat index (one take each: cheaper than indexing by rows
    # and columns); b = num / det * sign, the sign's flip undone exactly.
    row_k, row_2k = _row_starts(n, k)
    at = row_k + best
    b = num.take(at) / det.take(at) * sign
    a = (sy[:, 0] - b * sums.take(row_2k + best)) / sw[:, 0]
    return _Search(best=best, a=a, b=b, score=score)


@functools.lru_cache(maxsize=16)
def _row_starts(n: int, k: int) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """Flat index of each of ``n`` rows' first element in rows of ``k`` and of ``2 k``, read-only."""
    out = (np.arange(n) * k, np.arange(n) * (2 * k))
    for array in out:
        array.flags.writeable = False
    return out


def _levels(phi: FloatArray, y: FloatArray, w: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Weighted least-squares ``a, b`` of ``y = a + b phi`` per profile (rows)."""
    # The five sums in one reduction (each row's sum as on its own).
    terms = np.empty((5, *w.shape))
    terms[0] = w
    wp = np.multiply(w, phi, out=terms[1])
    np.multiply(w, y, out=terms[2])
    np.multiply(wp, phi, out=terms[3])
    np.multiply(wp, y, out=terms[4])
    sums = np.add.reduce(terms, axis=2)  # sw, sp, sy, spp, spy
    sw, sp, sy = sums[0], sums[1], sums[2]
    # sw spp - sp sp (the determinant) and sw spy - sp sy (b times it), side by side.
    sw_times = sw * sums[3:5]
    det, b_det = sw_times - sp * sums[1:3]
    det = np.where(np.abs(det) > 1e-12 * np.maximum(sw_times[0], 1e-300), det, np.nan)
    b = b_det / det
    a = (sy - b * sp) / np.maximum(sw, 1e-300)
    return a, b


def _gamma_weights(w: FloatArray, a: FloatArray, b: FloatArray, phi: FloatArray,
                   model: FloatArray | None = None) -> FloatArray:
    """``w / mean^2`` of the model ``a + b phi`` (levels (n,), phi (n, m); ``model`` when
    already computed), the mean floored."""
    floor = FLOOR_FRACTION * np.maximum(np.abs(a), np.abs(a + b)) + 1e-300
    mean = np.maximum(a[:, None] + b[:, None] * phi if model is None else model, floor[:, None])
    return w / (mean * mean)


def _vertex_2d(cube: FloatArray, rows: NDArray[np.intp], j: NDArray[np.intp],
               k: NDArray[np.intp]) -> tuple[FloatArray, FloatArray]:
    """Vertex of the quadratic through each profile's 3 x 3 scores about its best ``(j, k)``
    (edge step, blur step) of ``cube`` (n, n_edges, n_blurs), in steps (within one; 0 along a
    direction at the bank's edge or where the scores do not curve down). Jointly, not one
    direction at a time: with a blur between the bank's, the weighted scores' ridge runs
    oblique, and the best edge at the nearest blur is off the vertex."""
    n_j, n_k = cube.shape[1], cube.shape[2]
    # The 3 x 3 scores about each best at once (indices clamped at the bank's edges), as
    # rows of profiles: c[3 a + b] is each profile's score at (j - 1 + a, k - 1 + b). (Flat
    # indices and contiguous rows: cheaper calls than fancy indexing and strided columns.)
    jj = np.minimum(np.maximum(j[None, :] + _STEPS3, 0), n_j - 1)  # np.clip: several times slower
    kk = np.minimum(np.maximum(k[None, :] + _STEPS3, 0), n_k - 1)
    flat = jj[:, None, :] * n_k + kk[None, :, :]
    flat += rows * (n_j * n_k)
    c = cube.take(flat).reshape(9, -1)
    # The two directions side by side, rows (edge, blur): the same operations on each
    # element as written out one direction at a time, half the calls.
    after, before = c.take((7, 5), axis=0), c.take((1, 3), axis=0)  # (j + 1, k), (j, k + 1); (j - 1, k), (j, k - 1)
    g = 0.5 * (after - before)  # gj, gk
    hd = after - 2.0 * c[4] + before  # hjj, hkk
    hjk = 0.25 * (c[8] - c[6] - c[2] + c[0])
    jk = np.array((j, k))
    inner = (jk > 0) & (jk < np.array(((n_j - 1,), (n_k - 1,))))
    both_inner = inner[0] & inner[1]
    hjk = np.where(both_inner, hjk, 0.0)
    hjj, hkk = hd
    det = hjj * hkk - hjk * hjk
    joint = both_inner & (hjj < 0) & (det > 0)
    safe = np.where(joint, det, 1.0)
    # du: -(hkk gj - hjk gk) / safe; dv: -(hjj gk - hjk gj) / safe.
    d_joint = -(hd[::-1] * g - hjk * g[::-1]) / safe
    # Alone where the other direction is at the bank's edge.
    curved = hd < 0
    d_alone = np.where(inner & curved, -g / np.where(curved, hd, -1.0), 0.0)
    d = np.minimum(np.maximum(np.where(joint, d_joint, d_alone), -1.0), 1.0)
    return d[0], d[1]


def fit_steps(
    y: FloatArray,
    weights: FloatArray,
    *,
    edge0: float,
    sign: float | FloatArray = 1.0,
) -> StepFit:
    """Fit ``y = a + b Phi(sign (x0 - x) / s)`` to each row of ``y`` (x = 0, 1, 2, ...).

    Parameters
    ----------
    y : ndarray, shape (n, m)
        Profiles (linear power, >= 0).
    weights : ndarray, shape (n, m)
        1 inside each profile's window, 0 outside (or any non-negative weights); each
        profile needs some weight.
    edge0 : float
        Where the edges are expected, samples (the same in every profile); the search
        covers ``COARSE_REACH_SAMPLES`` either side of it.
    sign : float or ndarray, shape (n,)
        Per profile: +1 bright before the edge (a fall); -1 a rise (exactly +-1).

    Returns
    -------
    StepFit
    """
    y = np.asarray(y, dtype=np.float64)
    w = np.asarray(weights, dtype=np.float64)
    n, m = y.shape
    sign = np.asarray(sign, dtype=np.float64) * np.ones(n)
    inside = w > 0
    # Each window's first and last sample, as floats (the edge is clamped to them).
    first = inside.argmax(axis=1).astype(np.float64)
    last = (m - 1 - inside[:, ::-1].argmax(axis=1)).astype(np.float64)
    # Each profile on its own scale (the closed forms then stay well conditioned).
    w_sum = np.add.reduce(w, axis=1)
    scale = np.add.reduce(w * y, axis=1) / w_sum + 1e-300
    y = y / scale[:, None]
    widest = min(MAX_BLUR_SAMPLES, max(m - 1, 1) / 2.0)
    rows = np.arange(n)
    coarse = _bank(m, float(edge0), min(COARSE_REACH_SAMPLES, edge0 - 1.0), COARSE_STEP_SAMPLES, COARSE_BLURS, widest)
    # Unweighted (weights from a model far off would pull the step anywhere), then the fine
    # bank weighted by the model found.
    found = _search(y, w, coarse, sign)
    # The fine bank about each profile's best, on profiles shifted by whole samples.
    shift = np.rint(coarse.offsets[found.best]).astype(np.intp)
    cols = np.arange(m)[None, :] + shift[:, None]
    valid = (cols >= 0) & (cols < m)
    cols = np.minimum(np.maximum(cols, 0), m - 1)
    cols += (rows * m)[:, None]  # flat indices (one take each)
    wt = _gamma_weights(w, found.a, found.b, coarse.t_rows[found.best])
    y_s = np.where(valid, y.take(cols), 0.0)
    wt_s = np.where(valid, wt.take(cols), 0.0)
    fine = _bank(m, float(edge0), FINE_REACH_SAMPLES, FINE_STEP_SAMPLES, FINE_BLURS, widest)
    found = _search(y_s, wt_s, fine, sign)
    w_s = np.where(valid, w.take(cols), 0.0)
    for _ in range(FINE_REWEIGHTS):
        wt_s = _gamma_weights(w_s, found.a, found.b, fine.t_rows[found.best])
        found = _search(y_s, wt_s, fine, sign)
    n_blurs = fine.n_blurs
    n_off = fine.offsets.size // n_blurs
    j, k = np.divmod(found.best, n_blurs)
    cube = found.score.reshape(n, n_off, n_blurs)
    du, dv = _vertex_2d(cube, rows, j, k)
    x0 = float(edge0) + shift + fine.offsets[found.best] + du * FINE_STEP_SAMPLES
    blur = fine.blurs[found.best] * fine.blur_ratio**dv
    a, b = found.a, found.b
    # Gauss-Newton in (x0, log s) from the bank's vertex, each step weighted by the model so
    # far and the levels at their least squares (variable projection: their own derivatives
    # are orthogonal to the residual to first order): the bank's steps (edge, blur) leave a
    # bias where the weighted cost's ridge runs oblique; a continuous step takes it out.
    x = np.arange(m, dtype=np.float64)[None, :]
    log_s = np.log(blur)
    phi = ndtr((x0[:, None] - x) / blur[:, None])
    model = a[:, None] + b[:, None] * phi
    # (x0, log s) side by side for the Gauss-Newton steps, and their bounds.
    params = np.array([x0, log_s])
    bounds = np.empty((2, 2, n))  # lowest, highest
    bounds[0, 0], bounds[0, 1] = first, math.log(MIN_BLUR_SAMPLES)
    bounds[1, 0], bounds[1, 1] = last, math.log(widest)
    lowest, highest = bounds
    # The last pass's Jacobian of all four parameters (levels, edge, blur), for the 1-sigma.
    jac = np.empty((n, 4, m))
    jac[:, 0] = 1.0
    # The gradient's and the Hessian's five sums, in one reduction (each row's sum as on its own).
    terms = np.empty((5, n, m))
    for it in range(GN_ITERATIONS + 1):
        wt = _gamma_weights(w, a, b, phi, model)
        s_now = np.exp(log_s)
        z = (x0[:, None] - x) / s_now[:, None]
        phi = ndtr(z)
        a, b = _levels(phi, y, wt)
        model = a[:, None] + b[:, None] * phi
        r = y - model
        dens = np.exp(-0.5 * z * z) * (1.0 / _SQRT_2PI)
        j0 = np.multiply((b / s_now)[:, None], dens, out=jac[:, 2])
        j1 = np.multiply(-b[:, None] * dens, z, out=jac[:, 3])
        if it == GN_ITERATIONS:
            break  # the last pass only gives the edge's 1-sigma
        wj0, wj1 = wt * j0, wt * j1
        np.multiply(wj0, r, out=terms[0])
        np.multiply(wj1, r, out=terms[1])
        np.multiply(wj1, j1, out=terms[2])
        np.multiply(wj0, j0, out=terms[3])
        np.multiply(wj0, j1, out=terms[4])
        sums = np.add.reduce(terms, axis=2)  # g0, g1, h11, h00, h01
        g, h_diag, h01 = sums[0:2], sums[2:4], sums[4]
        h_diag *= 1.0 + DAMPING  # h11, h00
        det = h_diag[1] * h_diag[0] - h01 * h01
        det = np.where(det > 0, det, np.inf)
        # The steps of (x0, log s) side by side: (h11 g0 - h01 g1, h00 g1 - h01 g0) / det, each
        # bounded, then the parameters bounded.
        step = h_diag * g
        step -= h01 * g[::-1]
        step /= det
        step = np.minimum(np.maximum(step, -_MAX_STEPS), _MAX_STEPS)
        params = np.minimum(np.maximum(params + step, lowest), highest)
        x0, log_s = params
    blur = np.exp(log_s)
    # The edge's 1-sigma from the weighted residuals and the Jacobian of all four parameters
    # (levels, edge, blur): the levels' errors move the fitted edge too.
    var_res = np.add.reduce(wt * r * r, axis=1) / np.maximum(w_sum - 4.0, 1.0)
    jac[:, 1] = phi
    fisher = np.einsum("nim,njm->nij", jac * wt[:, None, :], jac)
    fisher += _EYE4 * (1e-12 * fisher.trace(axis1=1, axis2=2)[:, None, None] + 1e-300)
    h00 = 1.0 / np.linalg.inv(fisher)[:, 2, 2]
    edge_std = np.sqrt(var_res / h00)
    ok = (sign * b > 0) & np.isfinite(x0) & np.isfinite(edge_std) & (x0 > first) & (x0 < last)
    low = np.minimum(a, a + b) * scale
    high = np.maximum(a, a + b) * scale
    return StepFit(edge=x0, edge_std=edge_std, low=low, high=high, blur=blur, ok=ok)
