"""Image levels for segmentation: decibel levels, box smoothing and row seabed levels.

Part of :mod:`perception.shadows.segmentation.segment` (which re-exports these names). Images are
(n_samples, n_beams) = (range rows, beam columns). uint8 images are ARIS-style display
levels (``uint8_db_range`` dB over 0-255), other dtypes linear echo power.
"""

from __future__ import annotations

import functools
import math

import numpy as np
from numpy.typing import NDArray

from perception import imaging

#: Image levels proportional to dB: the uint8 display image or float32 dB.
Levels = NDArray[np.uint8] | NDArray[np.float32]


@functools.lru_cache(maxsize=8)
def power_table(db_per_level: float) -> NDArray[np.float64]:
    """Linear power of the 256 uint8 levels (read-only)."""
    table = np.power(10.0, np.arange(256) * (db_per_level / 10.0))
    table.flags.writeable = False
    return table


#: A linear image's values are floored at this far below the median of its positive values,
#: dB: zeros (quantised noise, blanked samples) would otherwise sit arbitrarily far down.
LINEAR_FLOOR_DB = 50.0


@functools.lru_cache(maxsize=4)
def _uint16_half_lsb_table(floor: float) -> NDArray[np.float32]:
    """dB of the 65536 uint16 values, each at least ``floor`` (linear), read-only."""
    values = np.maximum(np.arange(65536, dtype=np.float64), 0.5)
    table = (10.0 * np.log10(np.maximum(values, floor))).astype(np.float32)
    table.flags.writeable = False
    return table


def as_levels(
    image: NDArray[np.generic], *, uint8_db_range: float | None = 80.0
) -> tuple[Levels, float]:
    """The image as levels proportional to dB, and the dB per level.

    uint8 with ``uint8_db_range``: the image itself (no copy), ``uint8_db_range / 255``
    dB per level (ARIS display levels). Otherwise the image is linear echo (power, or
    amplitude: its dB are then half as large, which the segmentation's spread-relative
    thresholds absorb) and becomes ``10 log10(x)`` dB as float32 (a new array), 1 dB per
    level, each value floored at half an integer step (uint16) and at ``LINEAR_FLOOR_DB``
    below the median of the positive values.

    Raises
    ------
    ValueError
        When the image is not 2-D, not of an accepted dtype, or not finite.
    """
    array = np.asarray(image)
    if array.ndim != 2:
        raise ValueError(f"image must be 2-D (n_samples, n_beams), got shape {array.shape}")
    if array.dtype not in (np.uint8, np.uint16, np.float32, np.float64):
        raise ValueError(f"image dtype must be uint8, uint16, float32 or float64, got {array.dtype}")
    if array.dtype == np.uint8 and uint8_db_range is not None:
        return np.ascontiguousarray(array, dtype=np.uint8), float(uint8_db_range) / 255.0
    if array.dtype == np.uint16:
        sample = array[::7, ::3]
        positive = sample[sample > 0]
        floor = float(np.median(positive)) * 10.0 ** (-LINEAR_FLOOR_DB / 10.0) if positive.size else 0.5
        return np.take(_uint16_half_lsb_table(max(floor, 0.5)), array), 1.0  # take: 0.6 x the time of [array]
    power = np.ascontiguousarray(array, dtype=np.float32)
    if array.dtype.kind == "f" and not np.all(np.isfinite(power)):
        raise ValueError("image must be finite everywhere")
    if np.any(power < 0):
        raise ValueError("a linear image must be >= 0 everywhere")
    sample = power[::7, ::3]
    positive = sample[sample > 0]
    floor = float(np.median(positive)) * 10.0 ** (-LINEAR_FLOOR_DB / 10.0) if positive.size else 1e-12
    db = imaging.log(np.maximum(power, np.float32(max(floor, 1e-30))))
    db *= np.float32(10.0 / np.log(10.0))
    return db, 1.0


def block_levels(image: Levels, row_step: int, *, beams: int) -> NDArray[np.float32]:
    """Mean level of each block of ``row_step`` rows, averaged over ``beams`` beams (centred,
    edges replicated): the detection grid.

    Parameters
    ----------
    image : ndarray, shape (n_samples, n_beams), uint8 or float32
        Levels (:func:`as_levels`).
    row_step : int
        Rows per block (>= 1); the ``n_samples % row_step`` last rows are left out.
    beams : int
        Beams averaged (odd, >= 1).

    Returns
    -------
    ndarray, shape (n_samples // row_step, n_beams), float32
    """
    n_rows, n_cols = image.shape
    d = max(1, min(int(row_step), n_rows))
    n_grid = n_rows // d
    blocks = image[: n_grid * d].reshape(n_grid, d, n_cols)
    if image.dtype == np.uint8 and d * beams <= 257:
        # Row by row into uint16 (cheaper than a reduction along the middle axis), then the
        # beams' sums (edges replicated) by OpenCV's box filter into float32: sums of
        # integers below 2**16, exact, then scaled.
        total = blocks[:, 0].astype(np.uint16)
        for i in range(1, d):
            total += blocks[:, i]
        if beams > 1 and n_cols > 1:
            out = imaging.box_sum_replicate(total, beams, 1)
            d *= beams
        else:
            out = total.astype(np.float32)
        out *= np.float32(1.0 / d)
        return out
    out = np.add.reduce(blocks, axis=1, dtype=np.float32)
    out *= np.float32(1.0 / d)
    if beams > 1:
        out = imaging.box_mean(out, beams, 1, replicate=True)
    return out


#: Most values :func:`level_spread` reads (a strided subsample of larger grids).
SPREAD_SAMPLE = 4096


def level_spread(grid: NDArray[np.float32], background: NDArray[np.float32], rows: NDArray[np.bool_]) -> float:
    """Robust standard deviation of the seabed's ``grid - background`` over the ``rows``.

    Shadows, the dark outer beams at the band's curved edges and targets' echoes lie in
    the tails of the residuals and can be a third of a row or more, so: a first estimate
    from the upper tail (``(q90 - q75) / 0.6071``, as for a normal; dark pixels are all
    below the median), then the interquartile range (``/ 1.349``) of the residuals within
    3 of those of it. At most :data:`SPREAD_SAMPLE` values are read, strided over rows and
    beams. Returns 0 when no row is given.
    """
    picked = rows.nonzero()[0]
    if picked.size == 0:
        return 0.0
    n_cols = grid.shape[1]
    step_rows = max(1, int(math.ceil(math.sqrt(picked.size * n_cols / SPREAD_SAMPLE))))
    step_cols = max(1, min(n_cols, step_rows))
    row_a, row_b = int(picked[0]), int(picked[-1])
    if row_b - row_a + 1 == picked.size:  # one run of rows (the usual case): slices, no gather
        at = slice(row_a, row_b + 1, step_rows)
        flat = (grid[at, ::step_cols] - background[at, None]).ravel()
    else:
        picked = picked[::step_rows]
        flat = (grid[picked, ::step_cols] - background[picked, None]).ravel()
    n = flat.size
    if n < 8:
        return float(np.std(flat))
    # (numpy's vectorised sort costs less than its partition for a few thousand values; in
    # place: ``flat`` is a new array, np.sort would copy it first.)
    ordered = flat
    ordered.sort()
    k75, k90 = int(0.75 * (n - 1)), int(0.90 * (n - 1))
    first = float(ordered[k90] - ordered[k75]) / 0.6071
    centre = float(ordered[k75]) - 0.6745 * first  # the seabed's median, from its upper quartile
    if first > 0:
        # The values within 3 first estimates of the centre: a run of the sorted values.
        i0 = int(ordered.searchsorted(centre - 3.0 * first, side="left"))
        i1 = int(ordered.searchsorted(centre + 3.0 * first, side="right"))
        kept = ordered[i0:i1]
    else:
        kept = ordered
    if kept.size < 8:
        return first
    k25, k75 = int(0.25 * (kept.size - 1)), int(0.75 * (kept.size - 1))
    return float(kept[k75] - kept[k25]) / 1.349


def _block_count(grid: NDArray[np.float32], block_rows: int) -> tuple[int, int, int, int]:
    """``(n_rows, n_cols, block, n_blocks)`` of a grid cut in blocks of ``block_rows`` rows (at least 1)."""
    n_rows, n_cols = grid.shape
    block = max(1, min(int(block_rows), n_rows))
    return n_rows, n_cols, block, n_rows // block


@functools.lru_cache(maxsize=16)
def block_axes(n_rows: int, n_blocks: int, block: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The rows 0 .. n_rows - 1 and the centres of ``n_blocks`` blocks of ``block`` rows,
    read-only: where per-block values are interpolated to, and from (per geometry, not per frame)."""
    rows = np.arange(n_rows, dtype=np.float64)
    centres = np.arange(n_blocks, dtype=np.float64)  # (i + 0.5) block - 0.5
    centres += 0.5
    centres *= block
    centres -= 0.5
    rows.flags.writeable = False
    centres.flags.writeable = False
    return rows, centres


def row_spread(grid: NDArray[np.float32], background: NDArray[np.float32], *, block_rows: int) -> NDArray[np.float32]:
    """Each grid row's spread of levels about its seabed level, from blocks of rows.

    Per block of ``block_rows`` rows, the smaller of ``(q75 - q50) / 0.6745`` and
    ``(q90 - q75) / 0.6071`` of the residuals (as for a normal): targets' shadows, below, widen
    only the first, their highlights, above, only the second; then a running median over
    three blocks; interpolated to every row.
    Where noise dominates (one look, whatever the seabed's speckle) it is wider than the
    seabed's spread, which thresholds must respect there.

    Returns
    -------
    ndarray, shape (n_rows,), float32
    """
    n_rows, n_cols, block, n_blocks = _block_count(grid, block_rows)
    # Every other beam: neighbouring beams of the grid share a beam of smoothing.
    step = 2 if n_cols >= 16 else 1
    residual = (grid[: n_blocks * block, ::step] - background[: n_blocks * block, None]).reshape(n_blocks, -1)
    m = residual.shape[1]
    k50, k75, k90 = int(0.50 * (m - 1)), int(0.75 * (m - 1)), int(0.90 * (m - 1))
    part = residual  # a new array, sorted in place (vectorised: cheaper than a partition at three places)
    part.sort(axis=1)
    spread = np.minimum((part[:, k75] - part[:, k50]) / np.float32(0.6745),
                        (part[:, k90] - part[:, k75]) / np.float32(0.6071))
    if spread.size >= 3:
        # The median of each block's and its two neighbours' (the ends wrap around).
        before = np.concatenate([spread[-1:], spread[:-1]])
        after = np.concatenate([spread[1:], spread[:1]])
        spread = np.maximum(np.minimum(spread, np.maximum(before, after)), 0)
    rows, centres = block_axes(n_rows, n_blocks, block)
    return np.interp(rows, centres, spread).astype(np.float32)


def percentile90(values: NDArray[np.float32]) -> float:
    """``np.percentile(values, 90)`` (linear), by one partition (much cheaper on short arrays)."""
    n = values.size
    pos = 0.9 * (n - 1)
    k = int(pos)
    if k + 1 >= n:
        return float(np.max(values))
    part = values.copy()
    part.partition((k, k + 1))
    return float(part[k] + (pos - k) * (part[k + 1] - part[k]))


def row_background(
    grid: NDArray[np.float32], *, block_rows: int, median_blocks: int, non_negative: bool | None = None
) -> NDArray[np.float32]:
    """Seabed level of each grid row: upper quartile over beams of blocks of rows, capped by
    a running median over blocks.

    Parameters
    ----------
    grid : ndarray, shape (n_rows, n_beams), float32
        Smoothed levels (the detection grid).
    block_rows : int
        Rows averaged per block before the quartile (>= 1).
    median_blocks : int
        Blocks (odd) of the running median that caps rises by bright targets: a row can
        be a quarter bright targets, which raises its quartile, while the seabed's own level
        changes slowly along range (the band's edges stay sharp: the cap only lowers).
    non_negative : bool or None
        Whether ``grid`` is known to be >= 0 (None: find out); non-negative values sort
        faster as integers.

    Returns
    -------
    ndarray, shape (n_rows,), float32
    """
    n_rows, n_cols, block, n_blocks = _block_count(grid, block_rows)
    if block > 1:
        blocks = grid[: n_blocks * block].reshape(n_blocks, block, n_cols)
        small = blocks[:, 0].copy()
        for i in range(1, block):
            small += blocks[:, i]
        small *= np.float32(1.0 / block)
    else:
        small = grid
    # The upper quartile, not the median: a row can be more than half shadow when large
    # targets stand in it, but highlights are never a quarter of a row.
    k = (3 * n_cols) // 4
    as_int = small.dtype == np.float32 and (bool(small.min() >= 0) if non_negative is None else non_negative)
    if as_int:
        # Non-negative float32 values order as their int32 bit patterns, which numpy sorts faster.
        ordered = small.view(np.int32).copy()
        ordered.sort(axis=1)
        level = ordered[:, k].view(np.float32)
    else:
        level = np.partition(small, k, axis=1)[:, k].astype(np.float32)
    size = max(1, int(median_blocks) | 1)
    if size > 1 and level.size > 1:
        level = np.minimum(level, running_median(level, size=size))
    if block == 1:
        return np.asarray(level, dtype=np.float32)
    rows, centres = block_axes(n_rows, n_blocks, block)
    return np.interp(rows, centres, level).astype(np.float32)


@functools.lru_cache(maxsize=8)
def _row_kernel(size: int) -> NDArray[np.uint8]:
    """A 1 x ``size`` structuring element (read-only)."""
    kernel = np.ones((1, size), dtype=np.uint8)
    kernel.flags.writeable = False
    return kernel


def running_median(values: NDArray[np.float32], *, size: int) -> NDArray[np.float32]:
    """Running median over ``size`` (odd) neighbours, edges replicated (scipy's
    ``median_filter`` with ``mode="nearest"``, without its call overhead), shape of ``values``."""
    windows = values[_window_index(values.size, size)]
    windows.sort(axis=1)
    return windows[:, size // 2].astype(np.float32)


@functools.lru_cache(maxsize=16)
def _window_index(n: int, size: int) -> NDArray[np.intp]:
    """Indices of the ``size`` neighbours of each of ``n`` values, edges replicated, shape (n, size)."""
    half = size // 2
    index = np.clip(np.arange(n)[:, None] + np.arange(-half, half + 1)[None, :], 0, n - 1)
    index.flags.writeable = False
    return index


def running_min_max(
    values: NDArray[np.float32], *, size: int
) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
    """Running minimum and maximum over ``size`` (odd) neighbours, edges replicated.

    The same as scipy's ``minimum_filter1d`` and ``maximum_filter1d`` with
    ``mode="nearest"``, by OpenCV's erosion and dilation (far less call overhead), or
    for 3 neighbours by numpy's pairwise minima and maxima (less still).

    Parameters
    ----------
    values : ndarray, shape (n,), float32

    Returns
    -------
    low, high : ndarray, shape (n,), float32
    """
    if size == 3 and values.size >= 2:
        # Three neighbours (the detection grid's usual case): the minimum of neighbouring
        # pairs, then of neighbouring pairs of those, costs less than OpenCV's calls.
        return _min_max_of_three(np.asarray(values, dtype=np.float32))
    row = np.ascontiguousarray(values, dtype=np.float32).reshape(1, -1)
    kernel = _row_kernel(size)
    low = imaging.erode(row, kernel, replicate=True)
    high = imaging.dilate(row, kernel, replicate=True)
    return low[0], high[0]


def _min_max_of_three(values: NDArray[np.float32]) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
    """Running minimum and maximum over 3 neighbours, edges replicated, of at least 2 values."""
    out = []
    for pair in (np.minimum, np.maximum):
        # pairs[i] = pair(values[i], values[i + 1]); element i takes pairs i - 1 and i.
        pairs = pair(values[:-1], values[1:])
        result = np.empty_like(values)
        result[0] = pairs[0]
        result[-1] = pairs[-1]
        pair(pairs[:-1], pairs[1:], out=result[1:-1])
        out.append(result)
    return out[0], out[1]
