"""The insonified seabed band of a polar sonar image: its rows and per-beam edges.

Part of :mod:`perception.shadows.segmentation.segment` (which re-exports these names). The band's edges
are curved across the beams of a polar image (outer beams meet the seabed farther away);
shadows are only sought between them.
"""

from __future__ import annotations

import functools

import numpy as np
from numpy.typing import NDArray

from perception import imaging

#: Beams whose band edge is this far (rows) from the fitted curve count as moved by a shadow.
BAND_EDGE_TOLERANCE_ROWS = 6.0

#: Row step of the per-beam band-edge search.
BAND_EDGE_STRIDE = 1


def longest_run(above: NDArray[np.bool_]) -> NDArray[np.bool_]:
    """The longest run of True in ``above`` (the first of equal ones), shape of ``above``."""
    true_at = above.nonzero()[0]
    if true_at.size == 0 or int(true_at[-1]) - int(true_at[0]) + 1 == true_at.size:
        # No True, or one run (the usual band): it is ``above`` itself.
        return above.copy()
    padded = np.zeros(above.size + 2, dtype=bool)
    padded[1:-1] = above
    edges = (padded[1:] != padded[:-1]).nonzero()[0]
    out = np.zeros(above.shape, dtype=bool)
    if edges.size == 0:
        return out
    starts, stops = edges[0::2], edges[1::2]
    best = int((stops - starts).argmax())
    out[starts[best] : stops[best]] = True
    return out


def _robust_edge(
    values: NDArray[np.intp],
    valid: NDArray[np.bool_],
    *,
    later_is_outlier: bool,
    tolerance: float,
    out: NDArray[np.intp],
    target: NDArray[np.float64] | None = None,
    n_valid: int | None = None,
) -> None:
    """A parabola over beams through band-edge rows, ignoring edges moved by shadows.

    A shadow at the band's near edge moves that beam's first seabed row later; at the
    far edge it moves the last seabed row earlier. Those beams (more than ``tolerance``
    rows off the fit) are dropped and the parabola refitted (two passes). With fewer
    than 3 usable beams (or a singular fit) the rows are kept as they are. Written into
    ``out`` (shape of ``values``), which may be ``values``. ``target`` (``values`` as
    float64) and ``n_valid`` (True in ``valid``) are taken when given.
    """
    powers = _beam_powers(values.size)
    x = powers[1]
    if target is None:
        target = values.astype(np.float64)
    use = valid
    n_use = int(np.count_nonzero(use)) if n_valid is None else n_valid
    fitted = target
    for refit in (False, True):
        coeffs = _fit_parabola(powers, target, use, n_use)
        if coeffs is None:
            out[...] = values
            return
        # c0 + c1 x + c2 x x, in place (the same operations: + and * commute exactly).
        fitted = x * coeffs[1]
        fitted += coeffs[0]
        square = x * coeffs[2]
        square *= x
        fitted += square
        if refit:
            break
        residual = target - fitted
        if n_use == values.size and (
            np.maximum.reduce(residual) <= tolerance if later_is_outlier else np.minimum.reduce(residual) >= -tolerance
        ):
            # Every beam used and none off the fit: the refit would be this fit (one
            # reduction decides it without building ``kept``).
            break
        kept = valid & ((residual <= tolerance) if later_is_outlier else (residual >= -tolerance))
        n_kept = np.count_nonzero(kept)
        if n_kept == n_use:
            # No beam dropped (``kept`` is a subset of ``use``): the refit would be this fit.
            break
        use, n_use = kept, int(n_kept)
    # Assignment casts as ``astype(np.intp)`` does (the values are whole numbers).
    out[...] = np.rint(fitted)


def _fit_parabola(
    powers: NDArray[np.float64], target: NDArray[np.float64], use: NDArray[np.bool_], n_use: int
) -> tuple[float, float, float] | None:
    """Least-squares parabola through ``target`` at the ``use`` beams (None: under 3 beams or singular)."""
    if n_use < 3:
        return None
    if n_use == target.size:
        # Every beam: the same sums over the whole arrays (no copies; the power sums kept).
        s0, s1, s2, s3, s4 = _power_sums(target.size)
        t0, t1, t2 = (powers[:3] @ target).tolist()
    else:
        # ``compress`` picks the used beams faster than boolean indexing (same arrays).
        picked = powers.compress(use, axis=1)
        s0, s1, s2, s3, s4 = np.add.reduce(picked, axis=1).tolist()
        t0, t1, t2 = (picked[:3] @ target.compress(use)).tolist()
    return _solve3(((s0, s1, s2), (s1, s2, s3), (s2, s3, s4)), (t0, t1, t2))


@functools.lru_cache(maxsize=8)
def _beam_powers(n: int) -> NDArray[np.float64]:
    """x^0 .. x^4 of n points over [-1, 1], shape (5, n), read-only."""
    x = np.linspace(-1.0, 1.0, n)
    out = np.stack([np.ones_like(x), x, x * x, x**3, x**4])
    out.flags.writeable = False
    return out


@functools.lru_cache(maxsize=8)
def _power_sums(n: int) -> tuple[float, float, float, float, float]:
    """Sums over all n beams of x^0 .. x^4 (:func:`_beam_powers`)."""
    s0, s1, s2, s3, s4 = np.add.reduce(_beam_powers(n), axis=1).tolist()
    return s0, s1, s2, s3, s4


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


def band_edges(
    smoothed: NDArray[np.float32], rows: NDArray[np.bool_], *, level: float, stride: int = BAND_EDGE_STRIDE,
    tolerance_rows: float = BAND_EDGE_TOLERANCE_ROWS,
) -> NDArray[np.intp]:
    """:func:`column_band` as one array: shape (2, n_beams), the start rows then the stop rows."""
    n_cols = smoothed.shape[1]
    band = rows.nonzero()[0]
    if band.size == 0:
        return np.array([np.ones(n_cols, dtype=np.intp), np.zeros(n_cols, dtype=np.intp)])
    r0, r1 = int(band[0]), int(band[-1]) + 1
    inside = (smoothed[r0:r1:stride] >= level).view(np.uint8)
    # Each beam's first and last seabed row by argmax along contiguous memory: OpenCV
    # turns the rows into columns (transposed; rotated clockwise = transposed with the
    # rows reversed) far faster than numpy's argmax copies along the first axis.
    by_beam = imaging.transpose(inside).view(bool)
    by_beam_reversed = imaging.rotate_clockwise(inside).view(bool)
    ends = np.empty((2, n_cols), dtype=np.intp)
    by_beam.argmax(axis=1, out=ends[0])
    by_beam_reversed.argmax(axis=1, out=ends[1])
    # A beam with a seabed row: its first one is past row 0, or row 0 is one.
    any_row = (ends[0] > 0) | by_beam[:, 0]
    # Row 0 holds the first seabed rows (r0 + stride * first), row 1 the last ones
    # (r0 + stride * (last searched row - reversed argmax)); integers, exact in any order.
    np.subtract(inside.shape[0] - 1, ends[1], out=ends[1])
    if stride != 1:
        ends *= stride
    ends += r0
    # Each edge's fit is written over its rows (read first, as ``target``).
    target, n_valid = ends.astype(np.float64), int(np.count_nonzero(any_row))
    for e in (0, 1):
        _robust_edge(
            ends[e], any_row, later_is_outlier=e == 0, tolerance=tolerance_rows, out=ends[e], target=target[e],
            n_valid=n_valid,
        )
    # (np.clip costs several times more than the two calls.)
    return np.minimum(np.maximum(ends, r0, out=ends), r1 - 1, out=ends)


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
    shadow = np.empty(smoothed.shape, dtype=bool) if out is None else out
    bounds = (int(start.min()), int(start.max()), int(stop.min()), int(stop.max()))
    _shadow_in_band(smoothed, below, start, stop, bounds, shadow)
    return shadow


def shadow_in_edges(
    smoothed: NDArray[np.float32], below: NDArray[np.float32], edges: NDArray[np.intp], *, out: NDArray[np.bool_]
) -> None:
    """:func:`shadow_in_band` with the band's edges as :func:`band_edges` gives them, into ``out``."""
    # Both edges' least and greatest rows in two reductions (no Python wrappers).
    (start_min, stop_min), (start_max, stop_max) = (
        np.minimum.reduce(edges, axis=1).tolist(), np.maximum.reduce(edges, axis=1).tolist()
    )
    _shadow_in_band(smoothed, below, edges[0], edges[1], (start_min, start_max, stop_min, stop_max), out)


def _shadow_in_band(
    smoothed: NDArray[np.float32],
    below: NDArray[np.float32],
    start: NDArray[np.intp],
    stop: NDArray[np.intp],
    bounds: tuple[int, int, int, int],
    shadow: NDArray[np.bool_],
) -> None:
    """:func:`shadow_in_band` into ``shadow``, given (min, max) of ``start`` and of ``stop``."""
    n_rows = smoothed.shape[0]
    start_min, start_max, stop_min, stop_max = bounds
    lo, hi = start_min, stop_max + 1
    # Only the rows from the first band row to the last are compared; the others are not shadow.
    first, stop_row = max(lo, 0), max(hi, lo, 0)
    shadow[:first] = False
    shadow[stop_row:] = False
    np.less(smoothed[first:stop_row], below[first:stop_row, None], out=shadow[first:stop_row])
    near_end = min(start_max, n_rows)
    if near_end > lo:
        rows = np.arange(lo, near_end)[:, None]
        shadow[lo:near_end] &= rows >= start[None, :]
    far_start = max(stop_min + 1, 0)
    if hi > far_start:
        rows = np.arange(far_start, hi)[:, None]
        shadow[far_start:hi] &= rows <= stop[None, :]
