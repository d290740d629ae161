"""Full-resolution shadow rows and the gathers and running sums the edge search reads
(:mod:`perception.shadows.measurement.edges`).

On a detection grid of step ``d`` a shadow's first and last rows in a beam are known to
``d`` rows; :func:`refine_shadow_rows` follows them to full resolution in the measured
beams only. :func:`neighbour_power` gathers the edge search's block of beam-averaged
linear power. The helpers here keep the arithmetic of a plain numpy formulation exactly
(the same sums in the same order), only faster.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import cast

import cv2
import numpy as np
from numpy.typing import NDArray

from perception.shadows.segmentation.segment import Segmentation


def clamp(values: NDArray[np.intp], low: int, high: int) -> NDArray[np.intp]:
    """``values`` clamped to [low, high] (two ufunc calls, cheaper than ``np.clip``)."""
    return np.minimum(np.maximum(values, low), high)


#: Most channels of an OpenCV image (the columns :func:`cumsum0` hands to OpenCV at once).
CV_MAX_CHANNELS = 128


def cumsum0(values: NDArray[np.float64]) -> NDArray[np.float64]:
    """Cumulative sums down the rows with a row of zeros first, shape (n + 1, m).

    OpenCV's integral image of the values taken as one column of m-channel pixels holds
    these sums in its second column: per channel, each row's sum is the previous one
    plus (zero plus) the value, the additions of ``np.cumsum`` in the same order, so the
    same sums (the values summed here are never -0.0), in about half numpy's time.
    Wider arrays than OpenCV's channels allow take ``np.cumsum``.
    """
    n, m = values.shape
    if m <= CV_MAX_CHANNELS:
        image = np.ascontiguousarray(values).reshape(n, 1, m)
        # (a string cast: subscripting NDArray at run time costs microseconds per call)
        return cast("NDArray[np.float64]", cv2.integral(image, sdepth=cv2.CV_64F).reshape(n + 1, 2, m)[:, 1])
    out = np.empty((n + 1, m))
    out[0] = 0.0
    np.cumsum(values, axis=0, out=out[1:])
    return out


def take_neighbours(
    levels: NDArray[np.generic],
    first: NDArray[np.intp],
    beams: NDArray[np.intp],
    half_beams: int,
    *,
    beam_range: tuple[int, int],
) -> NDArray[np.generic]:
    """The levels of each beam's 2 half_beams + 1 neighbours, one plane per neighbour.

    ``first`` holds the flat indices ``row * n_beams + beam - half_beams`` (``beams``
    broadcast on its last axis, rows inside the image); returns
    ``out[j, ...] = levels[row, beam - half_beams + j]``, beams past the image's edge
    clamped to it. ``beam_range`` holds the smallest and the largest beam (or bounds
    of them). Where no neighbour lies past the edge, plane j is read through the
    flattened image shifted by j, with the one index array.
    """
    n_cols = levels.shape[1]
    inside = beam_range[0] >= half_beams and beam_range[1] < n_cols - half_beams
    flat = levels.ravel()
    out = np.empty((2 * half_beams + 1,) + first.shape, dtype=levels.dtype)
    for j in range(2 * half_beams + 1):
        # (every index is valid: "clip" only spares numpy the buffering it does for "raise")
        if inside:
            flat[j:].take(first, out=out[j], mode="clip")
        else:
            shift = clamp(beams - half_beams + j, 0, n_cols - 1) - (beams - half_beams)
            flat.take(first + shift, out=out[j], mode="clip")
    return out


@functools.lru_cache(maxsize=16)
def _row_starts(length: int, n_cols: int) -> NDArray[np.intp]:
    """Flat offsets ``i * n_cols`` of rows 0 .. length - 1, shape (length, 1) (read-only)."""
    out = np.arange(0, length * n_cols, n_cols).reshape(length, 1)
    out.flags.writeable = False
    return out


def neighbour_power(
    segmentation: Segmentation,
    lo: NDArray[np.intp],
    beams: NDArray[np.intp],
    length: int,
    k_beams: int,
    *,
    beam_range: tuple[int, int],
) -> NDArray[np.float64]:
    """Linear power of each beam averaged with its neighbours, in a window of rows per beam.

    Returns shape (length, beams.size): ``out[i, c]`` is the mean linear power of row
    ``lo[c] + i`` (rows past the image repeat its last row) over the ``k_beams`` beams
    centred on ``beams[c]`` (beams past the image's edge repeat it), the beams' powers
    added in turn (``((p0 + p1) + p2) * (1 / 3)`` for three: numpy's reduction over the
    first axis adds plane after plane). ``beam_range`` holds the smallest and the
    largest beam (or bounds of them).
    """
    levels = segmentation.levels
    n_rows, n_cols = levels.shape
    m = beams.size
    half = k_beams // 2
    first_beams = beams - half
    first = (lo * n_cols + first_beams) + _row_starts(length, n_cols)
    if int(np.maximum.reduce(lo)) + length > n_rows:
        # (rows past the image repeat its last row)
        first = np.minimum(first, (n_rows - 1) * n_cols + first_beams)
    taken = take_neighbours(levels, first, beams, half, beam_range=beam_range)
    planes = segmentation.power_of(taken.reshape(k_beams, length * m)).reshape(k_beams, length, m)
    power = np.add.reduce(planes, axis=0)
    power *= 1.0 / k_beams
    return cast("NDArray[np.float64]", power)


@functools.lru_cache(maxsize=16)
def window_sums(length: int, samples: int, beams: int) -> NDArray[np.float64]:
    """0/1 weights that sum ``samples`` rows of ``beams`` planes per output row (read-only).

    Shape (length, beams * (length + samples - 1)): column ``b * (length + samples - 1) + r``
    is row ``r`` of plane ``b``; output row ``i`` sums rows ``i .. i + samples - 1``.
    """
    span = length + samples - 1
    r = np.arange(span)[None, :]
    i = np.arange(length)[:, None]
    weights = np.tile(((r >= i) & (r < i + samples)).astype(np.float64), beams)
    weights.flags.writeable = False
    return weights


@dataclass(frozen=True)
class _RefineLayout:
    """Where :func:`refine_shadow_rows` reads, on a grid of step d (arrays read-only).

    Per beam two columns of ``n_before + 1`` rows (``n_before = d + d // 2``): column 0
    runs backwards from the row before the first cell's sampled row (``d i + d // 2``),
    column 1 forwards from the row after the last cell's sampled row. ``rows`` holds
    their offsets from the shadow's first and last grid rows (shape (n_before + 1, 2, 1),
    float), NaN at column 0's row n_before and column 1's row n_after (``2 d - d // 2 -
    1``): there the searches stop (a NaN row is never shadow). A search that stops
    after k shadow rows gives the shadow's first or last row ``grid row + to_row +
    sign * k``. ``padded`` holds the offsets with the smoothing's h = half length more
    on each side (shape (n_before + 1 + 2 h, 2, 1)), ``padded_index`` them times the
    image's width, ``low`` and ``high`` their least and greatest. ``window`` holds the
    offsets of the rows that numpy's smoothing of float levels reads (its running sums
    start there), ``in_window`` where each searched row lies in them.
    """

    rows: NDArray[np.float64]
    padded: NDArray[np.intp]
    padded_index: NDArray[np.intp]
    low: int
    high: int
    to_row: NDArray[np.intp]
    sign: NDArray[np.intp]
    window: NDArray[np.intp]
    in_window: NDArray[np.intp]


@functools.lru_cache(maxsize=8)
def _refine_layout(d: int, half_samples: int, n_cols: int) -> _RefineLayout:
    """The :class:`_RefineLayout` of grid step d, smoothing half length ``half_samples`` and image width ``n_cols``."""
    h = half_samples
    n_before = d + d // 2
    n_after = 2 * d - d // 2 - 1
    i = np.arange(n_before + 1 + 2 * h)
    padded = np.stack(((d // 2 - 1 + h) - i, (d // 2 - d + 2 - h) + i), axis=1)[:, :, None]
    rows = padded[h : h + n_before + 1].astype(np.float64)
    rows[n_before, 0] = rows[n_after, 1] = np.nan
    # Float levels: windows of 2 d + 1 rows from d rows before the first cell and d - 1
    # rows before the last one; searched row i of column 0 is row n_before - 1 - i there,
    # of column 1 row d // 2 + 1 + i (rows past the searches read any row).
    w = np.arange(2 * d + 1 + 2 * h)
    window = np.stack((w - d - h, w + 1 - d - h), axis=1)[:, :, None]
    k = np.arange(n_before + 1)
    in_window = np.stack((np.maximum(n_before - 1 - k, 0), np.minimum(d // 2 + 1 + k, 2 * d)), axis=1)[:, :, None]
    arrays = (
        rows, padded, padded * n_cols, np.array([[d // 2], [d // 2 - d + 1]]), np.array([[-1], [1]]), window,
        in_window,
    )
    for a in arrays:
        a.flags.writeable = False
    return _RefineLayout(*arrays[:3], int(padded[-1, 0, 0]), int(padded[-1, 1, 0]), *arrays[3:])


def refine_shadow_rows(
    segmentation: Segmentation,
    beams: NDArray[np.intp],
    s_first: NDArray[np.intp],
    s_last: NDArray[np.intp],
    *,
    beam_range: tuple[int, int],
) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """A shadow's first and last full-resolution row in each beam, from its grid cells.

    On a detection grid of step d the shadow's first and last cells in a beam are known;
    the grid row's sample (``d i + d // 2``) is shadow, and the run of full-resolution
    shadow rows (``smoothed < shadow_limit``, inside the band) through it is followed to
    its ends, which lie within the neighbouring cells (searched in the rows of
    :class:`_RefineLayout`). ``beam_range`` holds the smallest and the largest beam (or
    bounds of them).
    """
    d = segmentation.row_step
    levels = segmentation.levels
    n_rows, n_cols = levels.shape
    k_s, k_b = segmentation.smooth_samples, segmentation.smooth_beams
    h_s = k_s // 2
    n = beams.size
    layout = _refine_layout(d, h_s, n_cols)
    ends = np.array((s_first, s_last))
    rows = ends + layout.rows
    # Rows past the image repeat its edge row in the smoothing (as Segmentation.smoothed),
    # and are not shadow.
    low_row = int(np.minimum.reduce(s_first)) + layout.low
    high_row = int(np.maximum.reduce(s_last)) + layout.high
    outside = low_row < 0 or high_row >= n_rows
    first_beams = beams - k_b // 2
    if levels.dtype == np.uint8:
        if outside:
            first = clamp(ends + layout.padded, 0, n_rows - 1) * n_cols + first_beams
        else:
            first = (ends * n_cols + first_beams) + layout.padded_index
        taken = take_neighbours(levels, first, beams, k_b // 2, beam_range=beam_range)
        # Every row's box sum in one product with a 0/1 matrix: sums of small integers
        # are exact in float64 whatever their order.
        weights = window_sums(rows.shape[0], k_s, k_b)
        box = (weights @ cast("NDArray[np.float64]", taken.reshape(weights.shape[1], 2 * n))).reshape(rows.shape)
    else:
        # The beams added one by one, then running sums down the rows from the start of
        # numpy's windows.
        window = clamp(ends + layout.window, 0, n_rows - 1)
        taken = take_neighbours(levels, window * n_cols + first_beams, beams, k_b // 2, beam_range=beam_range)
        cum = cumsum0(np.add.reduce(taken, axis=0, dtype=np.float64).reshape(window.shape[0], 2 * n))
        box = (cum[k_s:] - cum[:-k_s]).reshape(2 * d + 1, 2, n)[layout.in_window, np.arange(2)[:, None], np.arange(n)]
    limit = np.interp(rows, segmentation.level_rows, segmentation.grid_shadow_limit)
    shadow = box / (k_s * k_b) < limit
    # Shadow rows lie inside the image and inside the band (tested row by row only
    # where the band of the beams' range may not hold every row read).
    band_start = segmentation.band_start_rows[beam_range[0] : beam_range[1] + 1]
    band_stop = segmentation.band_stop_rows[beam_range[0] : beam_range[1] + 1]
    if outside or np.maximum.reduce(band_start) > low_row or np.minimum.reduce(band_stop) < high_row:
        band_start = np.maximum(segmentation.band_start_rows[beams], 0)
        band_stop = np.minimum(segmentation.band_stop_rows[beams], n_rows - 1)
        shadow &= (rows >= band_start) & (rows <= band_stop)
    # The first row that is not shadow, counted from each search's start.
    refined = (ends + layout.to_row) + layout.sign * shadow.argmin(axis=0)
    return refined[0], refined[1]
