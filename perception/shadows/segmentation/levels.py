"""Image levels for segmentation: decibel levels, box smoothing and row seabed levels.

Part of :mod:`perception.shadows.segmentation.segment` (which re-exports these names). Images are
(n_samples, n_beams) = (range rows, beam columns). uint8 images are ARIS-style display
levels (``uint8_db_range`` dB over 0-255), other dtypes linear echo power.
"""

from __future__ import annotations

import functools

import cv2
import numpy as np
from numpy.typing import NDArray
from scipy.ndimage import median_filter

#: Blocks of rows in the running median of the row background.
BACKGROUND_MEDIAN_BLOCKS = 63

#: Image levels proportional to dB: the uint8 display image or float32 dB.
Levels = NDArray[np.uint8] | NDArray[np.float32]


@functools.lru_cache(maxsize=8)
def power_table(db_per_level: float) -> NDArray[np.float64]:
    """Linear power of the 256 uint8 levels (read-only)."""
    table = np.power(10.0, np.arange(256) * (db_per_level / 10.0))
    table.flags.writeable = False
    return table


def as_levels(
    image: NDArray[np.generic], *, uint8_db_range: float | None = 80.0
) -> tuple[Levels, float]:
    """The image as levels proportional to dB, and the dB per level.

    uint8 with ``uint8_db_range``: the image itself (no copy), ``uint8_db_range / 255``
    dB per level. Otherwise the image is linear power and becomes
    ``10 log10(max(x, 1e-12))`` dB as float32 (a new array), 1 dB per level.

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
    power = np.ascontiguousarray(array, dtype=np.float32)
    if array.dtype.kind == "f" and not np.all(np.isfinite(power)):
        raise ValueError("image must be finite everywhere")
    if np.any(power < 0):
        raise ValueError("a linear image must be >= 0 everywhere")
    db = np.asarray(cv2.log(np.maximum(power, np.float32(1e-12))), dtype=np.float32)
    db *= np.float32(10.0 / np.log(10.0))
    return db, 1.0


def box_smooth(image: Levels, *, samples: int, beams: int) -> NDArray[np.float32]:
    """Box mean over ``samples`` rows x ``beams`` columns (edges replicated), float32, new array."""
    out = cv2.boxFilter(
        image, cv2.CV_32F, (beams, samples), normalize=True, borderType=cv2.BORDER_REPLICATE
    )
    return np.asarray(out, dtype=np.float32)


def grid_smooth(
    image: Levels, rows: NDArray[np.intp], *, samples: int, beams: int
) -> NDArray[np.float32]:
    """:func:`box_smooth` at the given rows only (edges replicated), float32, new array.

    Parameters
    ----------
    image : ndarray, shape (n_samples, n_beams), uint8 or float32
    rows : ndarray, shape (n,), int
        Rows to smooth, each in ``[0, n_samples)``.

    Returns
    -------
    ndarray, shape (n, n_beams), float32
    """
    n_rows, n_cols = image.shape
    half = samples // 2
    wide = image.dtype == np.uint8 and samples <= 257
    step = int(rows[1] - rows[0]) if rows.size > 1 else 0
    if (
        wide and step > 0 and rows.size * step == n_rows and int(rows[0]) == step // 2
        and step // 2 - half >= 0 and step // 2 + half < step and (2 * half + 1) * beams * 255 < 2**24
    ):
        # The detection grid's rows (the middle row of every block of ``step`` rows): the
        # sum over the rows around each is a sum of rows of a reshaped view, then a sum of
        # neighbouring columns (edges replicated). OpenCV adds the strided rows and columns
        # into float32 faster than numpy's adds or its box filter; every sum is exact
        # (whole numbers below 2**24), so they equal the integer sums of the other branch.
        blocks = image.reshape(rows.size, step, n_cols)[:, step // 2 - half : step // 2 + half + 1]
        side = beams // 2
        padded = np.zeros((rows.size, n_cols + 2 * side), dtype=np.float32)
        acc = padded[:, side : side + n_cols]
        for k in range(blocks.shape[1]):
            cv2.accumulate(blocks[:, k], acc)
        if side == 0:
            out = acc
        else:
            padded[:, :side] = acc[:, :1]
            padded[:, side + n_cols :] = acc[:, -1:]
            out = np.asarray(cv2.add(padded[:, :n_cols], padded[:, 1 : 1 + n_cols]), dtype=np.float32)
            for k in range(2, beams):
                cv2.accumulate(padded[:, k : k + n_cols], out)
    else:
        acc = np.zeros((rows.size, n_cols), dtype=np.uint16 if wide else np.float32)
        for offset in range(-half, half + 1):
            np.add(acc, image[np.minimum(np.maximum(rows + offset, 0), n_rows - 1)], out=acc)
        out = np.asarray(
            cv2.boxFilter(acc, cv2.CV_32F, (beams, 1), normalize=False, borderType=cv2.BORDER_REPLICATE),
            dtype=np.float32,
        )
    out *= np.float32(1.0 / (samples * beams))
    return out


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
    smoothed: NDArray[np.float32], *, block_samples: int
) -> NDArray[np.float32]:
    """Seabed level of each range row: upper quartile over beams of blocks of rows.

    Parameters
    ----------
    smoothed : ndarray, shape (n_samples, n_beams), float32
    block_samples : int
        Rows averaged per block before the median (speed and robustness).

    Returns
    -------
    ndarray, shape (n_samples,), float32
    """
    return row_background_of(smoothed, block_samples=block_samples, non_negative=None)


def row_background_of(
    smoothed: NDArray[np.float32], *, block_samples: int, non_negative: bool | None
) -> NDArray[np.float32]:
    """:func:`row_background`, told whether ``smoothed`` is known to be >= 0 (None: find out).

    Box means of uint8 levels are never negative, which saves a pass over them.
    """
    n_rows, n_cols = smoothed.shape
    block = max(1, min(block_samples, n_rows))
    n_blocks = n_rows // block
    if block > 1:
        small = smoothed[0 : n_blocks * block : block].copy()
        for k in range(1, block):
            small += smoothed[k : n_blocks * block : block]
        small *= np.float32(1.0 / block)
    else:
        small = smoothed
    # The upper quartile, not the median: a row can be more than half shadow when large
    # targets stand in it, but highlights are never a quarter of a row.
    k = (3 * small.shape[1]) // 4
    # Non-negative float32 values order as their int32 bit patterns, which numpy sorts
    # (SIMD) markedly faster than it partitions or sorts floats; the elements are the same.
    as_int = small.dtype == np.float32 and (bool(small.min() >= 0) if non_negative is None else non_negative)
    if as_int:
        # (A copy sorted in place: ``np.sort`` without its Python wrapper.)
        ordered = small.view(np.int32).copy()
        ordered.sort(axis=1)
        level = ordered[:, k].view(np.float32)
    else:
        level = np.partition(small, k, axis=1)[:, k].astype(np.float32)
    # Bright targets filling a quarter of a row raise its quartile; a wide running
    # median over blocks (which keeps the band's edges sharp) caps such rises.
    wide = _running_median_int(level) if as_int else median_filter(level, size=BACKGROUND_MEDIAN_BLOCKS, mode="nearest")
    level = np.minimum(level, wide)
    if block == 1:
        return level
    centres = (np.arange(n_blocks) + 0.5) * block - 0.5
    return np.interp(np.arange(n_rows), centres, level).astype(np.float32)


def _running_median_int(level: NDArray[np.float32]) -> NDArray[np.float32]:
    """``median_filter(level, size=BACKGROUND_MEDIAN_BLOCKS, mode="nearest")`` of non-negative float32.

    The windows (edges replicated) as a strided view, sorted by their int32 bit patterns
    (the same order for non-negative floats): the same medians as scipy's, at a fraction
    of its call overhead.
    """
    half = BACKGROUND_MEDIAN_BLOCKS // 2
    n = level.size
    padded = np.empty(n + 2 * half, dtype=np.float32)
    padded[:half] = level[0]
    padded[half : half + n] = level
    padded[half + n :] = level[-1]
    # Window i starts at element i: a strided view, no copy (``np.ndarray`` over the buffer
    # costs far less than ``as_strided``).
    windows = np.ndarray(
        (n, BACKGROUND_MEDIAN_BLOCKS), dtype=np.int32, buffer=padded, strides=(padded.itemsize, padded.itemsize)
    )
    ordered = windows.copy()
    ordered.sort(axis=1)
    return ordered[:, half].view(np.float32)


@functools.lru_cache(maxsize=8)
def _row_kernel(size: int) -> NDArray[np.uint8]:
    """A 1 x ``size`` structuring element (read-only)."""
    kernel = np.ones((1, size), dtype=np.uint8)
    kernel.flags.writeable = False
    return kernel


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
    low = cv2.erode(row, kernel, borderType=cv2.BORDER_REPLICATE)
    high = cv2.dilate(row, kernel, borderType=cv2.BORDER_REPLICATE)
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
