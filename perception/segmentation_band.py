"""The insonified seabed band of a polar sonar image: its rows and per-beam edges.

Part of :mod:`perception.segmentation` (which re-exports these names). The band's edges
are curved across the beams of a polar image (outer beams meet the seabed farther away);
shadows are only sought between them.
"""

from __future__ import annotations

import functools

import numpy as np
from numpy.typing import NDArray

from perception.segmentation_levels import percentile90

#: Beams whose band edge is this far (rows) from the fitted curve count as moved by a shadow.
BAND_EDGE_TOLERANCE_ROWS = 6.0

#: Row step (full-resolution rows) of the per-beam band-edge search.
BAND_EDGE_STRIDE = 4


def insonified_rows(background: NDArray[np.float32], *, drop: float) -> NDArray[np.bool_]:
    """Rows whose seabed level is within ``drop`` (level units) of the frame's seabed level.

    The frame's seabed level is the 90th percentile of the row levels; the kept rows
    form the longest contiguous run (the insonified band), so isolated bright rows in
    the dark are not taken for seabed.
    """
    reference = percentile90(background)
    above = background >= reference - drop
    padded = np.concatenate(([0], above.astype(np.int8), [0]))
    edges = np.flatnonzero(np.diff(padded))
    starts, stops = edges[0::2], edges[1::2]
    out = np.zeros(background.shape, dtype=bool)
    if starts.size == 0:
        return out
    best = int(np.argmax(stops - starts))
    out[starts[best] : stops[best]] = True
    return out


def _robust_edge(
    values: NDArray[np.intp], valid: NDArray[np.bool_], *, later_is_outlier: bool, tolerance: float
) -> NDArray[np.intp]:
    """A parabola over beams through band-edge rows, ignoring edges moved by shadows.

    A shadow at the band's near edge moves that beam's first seabed row later; at the
    far edge it moves the last seabed row earlier. Those beams (more than ``tolerance``
    rows off the fit) are dropped and the parabola refitted (two passes).
    """
    powers = _beam_powers(values.size)
    x = powers[1]
    target = values.astype(np.float64)
    use = valid.copy()
    fitted = target
    for _ in range(2):
        if np.count_nonzero(use) < 3:
            return values
        # ``compress`` picks the used beams faster than boolean indexing (same arrays).
        picked = powers.compress(use, axis=1)
        s0, s1, s2, s3, s4 = np.add.reduce(picked, axis=1).tolist()
        t0, t1, t2 = (picked[:3] @ target.compress(use)).tolist()
        coeffs = _solve3(((s0, s1, s2), (s1, s2, s3), (s2, s3, s4)), (t0, t1, t2))
        if coeffs is None:
            return values
        fitted = coeffs[0] + coeffs[1] * x + coeffs[2] * x * x
        residual = target - fitted
        use = valid & ((residual <= tolerance) if later_is_outlier else (residual >= -tolerance))
    return np.rint(fitted).astype(np.intp)


@functools.lru_cache(maxsize=8)
def _beam_powers(n: int) -> NDArray[np.float64]:
    """x^0 .. x^4 of n points over [-1, 1], shape (5, n), read-only."""
    x = np.linspace(-1.0, 1.0, n)
    out = np.stack([np.ones_like(x), x, x * x, x**3, x**4])
    out.flags.writeable = False
    return out


def _solve3(
    a: tuple[tuple[float, float, float], ...], b: tuple[float, float, float]
) -> tuple[float, float, float] | None:
    """Solve a 3 x 3 linear system by Cramer's rule (None when singular)."""
    (a00, a01, a02), (a10, a11, a12), (a20, a21, a22) = a
    c0 = a11 * a22 - a12 * a21
    c1 = a10 * a22 - a12 * a20
    c2 = a10 * a21 - a11 * a20
    det = a00 * c0 - a01 * c1 + a02 * c2
    if abs(det) < 1e-12 * max(1.0, abs(a00 * a11 * a22)):
        return None
    b0, b1, b2 = b
    x0 = (b0 * c0 - a01 * (b1 * a22 - a12 * b2) + a02 * (b1 * a21 - a11 * b2)) / det
    x1 = (a00 * (b1 * a22 - a12 * b2) - b0 * c1 + a02 * (a10 * b2 - b1 * a20)) / det
    x2 = (a00 * (a11 * b2 - b1 * a21) - a01 * (a10 * b2 - b1 * a20) + b0 * c2) / det
    return x0, x1, x2


def column_band(
    smoothed: NDArray[np.float32], rows: NDArray[np.bool_], *, level: float, stride: int = BAND_EDGE_STRIDE,
    tolerance_rows: float = BAND_EDGE_TOLERANCE_ROWS,
) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """Per beam, the first and last seabed row of the band ``rows`` (level >= ``level``).

    The band's edges are curved across the beams; beams where a shadow moves an edge
    (more than ``tolerance_rows`` off) are corrected by a robust parabola over the beams.
    Every ``stride``-th row is searched. Returns (start, stop), shape (n_beams,), rows of
    ``smoothed``.
    """
    n_cols = smoothed.shape[1]
    band = np.flatnonzero(rows)
    if band.size == 0:
        return np.ones(n_cols, dtype=np.intp), np.zeros(n_cols, dtype=np.intp)
    r0, r1 = int(band[0]), int(band[-1]) + 1
    inside = smoothed[r0:r1:stride] >= level
    any_row = np.asarray(inside.any(axis=0), dtype=bool)
    start = r0 + stride * np.argmax(inside, axis=0)
    stop = r0 + stride * (inside.shape[0] - 1 - np.argmax(inside[::-1], axis=0))
    start = np.minimum(np.maximum(
        _robust_edge(start, any_row, later_is_outlier=True, tolerance=tolerance_rows), r0), r1 - 1)
    stop = np.minimum(np.maximum(
        _robust_edge(stop, any_row, later_is_outlier=False, tolerance=tolerance_rows), r0), r1 - 1)
    return start.astype(np.intp), stop.astype(np.intp)


def shadow_in_band(
    smoothed: NDArray[np.float32],
    below: NDArray[np.float32],
    start: NDArray[np.intp],
    stop: NDArray[np.intp],
    *,
    out: NDArray[np.bool_] | None = None,
) -> NDArray[np.bool_]:
    """``smoothed < below`` per row, kept only between each beam's band rows.

    The per-beam test is only needed in the rows where the curved band edges lie.
    Written into ``out`` (shape of ``smoothed``) when given.
    """
    n_rows = smoothed.shape[0]
    lo, hi = int(start.min()), int(stop.max()) + 1
    limit = below.copy()
    limit[: max(lo, 0)] = -np.inf
    limit[max(hi, 0) :] = -np.inf
    shadow = np.less(smoothed, limit[:, None], out=out)
    near_end = min(int(start.max()), n_rows)
    if near_end > lo:
        rows = np.arange(lo, near_end)[:, None]
        shadow[lo:near_end] &= rows >= start[None, :]
    far_start = max(int(stop.min()) + 1, 0)
    if hi > far_start:
        rows = np.arange(far_start, hi)[:, None]
        shadow[far_start:hi] &= rows <= stop[None, :]
    return shadow
