"""The image operations perception uses, the one module that imports OpenCV.

Every other perception module is numpy-only and calls these. Each is a thin wrapper: one
OpenCV call with the arguments the callers have always passed, so its results are OpenCV's
bit for bit; what it adds is the contract, checked on entry (a ``TypeError`` for a wrong
dtype, a ``ValueError`` for a wrong shape): 2-D single-channel images unless said, C order
as OpenCV wants, and the dtype of the result. Borders are zero (constant) unless the name
or a flag says replicate.
"""

from __future__ import annotations

from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

__all__ = [
    "adaptive_mean_threshold",
    "bounding_box",
    "box_mean",
    "box_sum_replicate",
    "column_cumsum",
    "draw_filled_contour",
    "encode_png",
    "erode",
    "dilate",
    "external_contours",
    "fill_disc",
    "fill_polygon",
    "fixed_point_maps",
    "gaussian_blur",
    "label_components",
    "log",
    "lookup",
    "morph_close",
    "morph_open",
    "optimal_dft_size",
    "pad_bottom_right",
    "remap",
    "remap_fixed_point",
    "rotate_clockwise",
    "transpose",
    "translate",
]

F32 = NDArray[np.float32]
U8 = NDArray[np.uint8]


def set_threads(n: int) -> None:
    """OpenCV's worker threads for this process (1: every call on the caller's thread)."""
    cv2.setNumThreads(int(n))


def threads() -> int:
    """OpenCV's worker threads for this process."""
    return int(cv2.getNumThreads())


def _check(image: np.ndarray, name: str, dtypes: tuple[type, ...], ndim: int = 2) -> None:
    if image.dtype.type not in dtypes:
        allowed = " or ".join(np.dtype(d).name for d in dtypes)
        raise TypeError(f"{name} must be {allowed}, got {image.dtype}")
    if image.ndim != ndim:
        raise ValueError(f"{name} must be {ndim}-D, got shape {image.shape}")


# ---------------------------------------------------------------------------- filters
def gaussian_blur(image: F32, sigma: float) -> F32:
    """Gaussian blur of a float32 image, ``sigma`` in cells (kernel size from sigma,
    OpenCV's default border: reflected without the edge cell). Same shape, float32."""
    _check(image, "image", (np.float32,))
    return np.asarray(cv2.GaussianBlur(image, (0, 0), sigma))


def box_mean(image: F32, width: int, height: int, *, replicate: bool = False) -> F32:
    """Mean over a ``width`` x ``height`` box centred on each cell of a float32 image;
    the border reflected without the edge cell, or ``replicate``-d. Same shape, float32."""
    _check(image, "image", (np.float32,))
    if replicate:
        return np.asarray(cv2.boxFilter(image, -1, (width, height), normalize=True,
                                        borderType=cv2.BORDER_REPLICATE))
    return np.asarray(cv2.blur(image, (width, height)))


def box_sum_replicate(image: NDArray[np.uint16], width: int, height: int) -> F32:
    """Sum over a ``width`` x ``height`` box centred on each cell of a uint16 image (odd
    sizes), the border replicated, as float32 (exact while the sums stay below 2**24: sums
    of integers). Same shape."""
    _check(image, "image", (np.uint16,))
    return np.asarray(cv2.boxFilter(image, cv2.CV_32F, (width, height), normalize=False,
                                    borderType=cv2.BORDER_REPLICATE))


#: Most channels the Python binding wraps (column_cumsum's beams per call).
_MAX_CHANNELS = 128


def column_cumsum(values: NDArray[np.float64]) -> NDArray[np.float64]:
    """Cumulative sums down each column of a float64 (M, n) array, after a zero row:
    shape (M + 1, n), float64, C-contiguous; ``out[i + 1] = out[i] + values[i]``, the very
    additions of ``numpy.cumsum(axis=0)`` in the same order (identical bits for values
    without -0.0, whose first sum is +0.0 here). OpenCV's integral of the array as one
    column of n channels: each channel's running sum on its own, several times faster than
    numpy's strided accumulation down the columns."""
    _check(values, "values", (np.float64,))
    m, n = values.shape
    out = np.zeros((m + 1, n)) if values.size == 0 else np.empty((m + 1, n))
    for c0 in range(0, n if m else 0, _MAX_CHANNELS):
        c1 = min(c0 + _MAX_CHANNELS, n)
        block = np.ascontiguousarray(values[:, c0:c1]).reshape(m, 1, c1 - c0)
        out[:, c0:c1] = np.asarray(cv2.integral(block, sdepth=cv2.CV_64F)).reshape(m + 1, 2, c1 - c0)[:, 1]
    return out


def erode(image: np.ndarray, kernel: U8, *, replicate: bool = False) -> np.ndarray:
    """Minimum over the nonzero cells of ``kernel`` (uint8, centred) of a uint8 or float32
    image; outside the image counts as +inf (OpenCV's default), or ``replicate``-d. Same
    shape and dtype."""
    _check(image, "image", (np.uint8, np.float32))
    if replicate:
        return np.asarray(cv2.erode(image, kernel, borderType=cv2.BORDER_REPLICATE))
    return np.asarray(cv2.erode(image, kernel))


def dilate(image: np.ndarray, kernel: U8, *, replicate: bool = False) -> np.ndarray:
    """Maximum over the nonzero cells of ``kernel`` (uint8, centred) of a uint8 or float32
    image; outside the image counts as -inf (OpenCV's default), or ``replicate``-d. Same
    shape and dtype."""
    _check(image, "image", (np.uint8, np.float32))
    if replicate:
        return np.asarray(cv2.dilate(image, kernel, borderType=cv2.BORDER_REPLICATE))
    return np.asarray(cv2.dilate(image, kernel))


def morph_open(mask: U8, size: int) -> U8:
    """Opening (erode, then dilate) of a uint8 mask by a ``size`` x ``size`` square. Same
    shape, uint8."""
    _check(mask, "mask", (np.uint8,))
    return np.asarray(cv2.morphologyEx(mask, cv2.MORPH_OPEN, np.ones((size, size), np.uint8)), dtype=np.uint8)


def morph_close(mask: U8, size: int) -> U8:
    """Closing (dilate, then erode) of a uint8 mask by a ``size`` x ``size`` square. Same
    shape, uint8."""
    _check(mask, "mask", (np.uint8,))
    return np.asarray(cv2.morphologyEx(mask, cv2.MORPH_CLOSE, np.ones((size, size), np.uint8)), dtype=np.uint8)


def adaptive_mean_threshold(grey: U8, block: int, offset: float, *, below: bool) -> U8:
    """1 where a uint8 image lies below (``below``) or above its ``block`` x ``block`` mean
    (odd ``block`` >= 3) minus ``offset``, else 0 (OpenCV's ``ADAPTIVE_THRESH_MEAN_C``:
    ``below`` is ``THRESH_BINARY_INV``, else ``THRESH_BINARY``). Same shape, uint8."""
    _check(grey, "grey", (np.uint8,))
    kind = cv2.THRESH_BINARY_INV if below else cv2.THRESH_BINARY
    return np.asarray(cv2.adaptiveThreshold(grey, 1, cv2.ADAPTIVE_THRESH_MEAN_C, kind, block, offset),
                      dtype=np.uint8)


# ---------------------------------------------------------------------------- per cell
def log(image: F32) -> F32:
    """Natural logarithm of a positive float32 image (OpenCV's, not numpy's: the results
    differ in the last bits). Same shape, float32."""
    _check(image, "image", (np.float32,))
    return np.asarray(cv2.log(image), dtype=np.float32)


def lookup(levels: U8, table: NDArray[np.float64]) -> NDArray[np.float64]:
    """``table[levels]`` for a 2-D uint8 image and a (1, 256) float64 table. Same shape,
    float64."""
    _check(levels, "levels", (np.uint8,))
    _check(table, "table", (np.float64,))
    if table.shape != (1, 256):
        raise ValueError(f"table must have shape (1, 256), got {table.shape}")
    return np.asarray(cv2.LUT(levels, table), dtype=np.float64)


def transpose(image: U8) -> U8:
    """The transpose of a uint8 image, C-contiguous (faster than numpy's copy)."""
    _check(image, "image", (np.uint8,))
    return np.asarray(cv2.transpose(image))


def rotate_clockwise(image: U8) -> U8:
    """A uint8 image turned 90 degrees clockwise (the transpose with its columns reversed),
    C-contiguous."""
    _check(image, "image", (np.uint8,))
    return np.asarray(cv2.rotate(image, cv2.ROTATE_90_CLOCKWISE))


# ---------------------------------------------------------------------------- resampling
def remap(image: np.ndarray, map_col: F32, map_row: F32, *, nearest: bool) -> np.ndarray:
    """``image`` (float32 or uint8) sampled at (``map_col``, ``map_row``), float32 maps of
    the output's shape, bilinear or ``nearest``; samples outside the image are 0. The
    output has the maps' shape and the image's dtype."""
    _check(image, "image", (np.float32, np.uint8))
    _check(map_col, "map_col", (np.float32,))
    _check(map_row, "map_row", (np.float32,))
    interpolation = cv2.INTER_NEAREST if nearest else cv2.INTER_LINEAR
    return np.asarray(cv2.remap(image, map_col, map_row, interpolation, borderMode=cv2.BORDER_CONSTANT,
                                borderValue=0))


def fixed_point_maps(map_x: F32, map_y: F32, *, nearest: bool) -> tuple[np.ndarray, np.ndarray | None]:
    """float32 sampling maps in OpenCV's fixed-point form, read-only: the integer cell
    (int16, shape (h, w, 2)) and, for bilinear sampling, the interpolation table index
    (uint16, (h, w)); None for ``nearest``. For :func:`remap_fixed_point`."""
    _check(map_x, "map_x", (np.float32,))
    _check(map_y, "map_y", (np.float32,))
    map1, map2 = cv2.convertMaps(map_x, map_y, cv2.CV_16SC2, nninterpolation=nearest)
    map1.flags.writeable = False
    if nearest or map2 is None or map2.size == 0:
        return map1, None
    map2.flags.writeable = False
    return map1, map2


def remap_fixed_point(image: np.ndarray, map1: np.ndarray, map2: np.ndarray | None, *, nearest: bool,
                      fill: float, out: np.ndarray) -> np.ndarray:
    """``image`` sampled through maps from :func:`fixed_point_maps` into ``out`` (the maps'
    shape, the image's dtype), bilinear or ``nearest``; samples outside are ``fill``.
    Returns ``out``."""
    if out.shape[:2] != map1.shape[:2] or out.dtype != image.dtype:
        raise ValueError(f"out must be {image.dtype} of shape {map1.shape[:2]}, got {out.dtype} {out.shape}")
    interpolation_table: Any = map2  # None for nearest: OpenCV accepts it, its stubs do not
    cv2.remap(image, map1, interpolation_table, cv2.INTER_NEAREST if nearest else cv2.INTER_LINEAR, dst=out,
              borderMode=cv2.BORDER_CONSTANT, borderValue=fill)
    return out


def translate(image: F32, dx: float, dy: float) -> F32:
    """A float32 image moved by (``dx`` columns, ``dy`` rows), bilinear, 0 where nothing
    arrives. Same shape, float32."""
    _check(image, "image", (np.float32,))
    rows, cols = image.shape
    return np.asarray(cv2.warpAffine(image, np.array([[1.0, 0.0, dx], [0.0, 1.0, dy]], dtype=np.float64),
                                     (cols, rows), flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT,
                                     borderValue=0))


def optimal_dft_size(n: int) -> int:
    """The smallest size >= ``n`` whose DFT is fast (a product of 2, 3 and 5)."""
    return int(cv2.getOptimalDFTSize(n))


def pad_bottom_right(image: F32, rows: int, cols: int) -> F32:
    """A float32 image padded with zeros below and to the right to ``rows`` x ``cols``."""
    _check(image, "image", (np.float32,))
    n_rows, n_cols = image.shape
    return np.asarray(cv2.copyMakeBorder(image, 0, rows - n_rows, 0, cols - n_cols, cv2.BORDER_CONSTANT, value=0))


# ---------------------------------------------------------------------------- regions
def label_components(mask: U8, labels: NDArray[np.int32]) -> int:
    """Label the 8-connected components of a 0/1 uint8 mask into ``labels`` (int32, the
    mask's shape, written in place: 0 = background, 1.. = components); returns the number
    of labels, background included."""
    _check(mask, "mask", (np.uint8,))
    _check(labels, "labels", (np.int32,))
    n, _ = cv2.connectedComponents(mask, labels=labels, connectivity=8, ltype=cv2.CV_32S)
    return int(n)


def external_contours(mask: U8) -> tuple[np.ndarray, ...]:
    """The outer contours of a uint8 mask's components (border following, corner points
    only), each an int32 array of shape (n, 1, 2) of (column, row) points."""
    _check(mask, "mask", (np.uint8,))
    contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    return tuple(contours)


def bounding_box(contour: np.ndarray) -> tuple[int, int, int, int]:
    """(column, row, width, height) of the cells a contour covers."""
    x, y, w, h = cv2.boundingRect(contour)
    return int(x), int(y), int(w), int(h)


def draw_filled_contour(labels: NDArray[np.int32], contours: tuple[np.ndarray, ...], index: int, value: int) -> None:
    """Fill contour ``index`` of ``contours`` (with its inside) with ``value`` in the int32
    image ``labels``, in place."""
    _check(labels, "labels", (np.int32,))
    cv2.drawContours(labels, contours, index, value, thickness=-1)


def fill_polygon(mask: U8, points_px: NDArray[np.float64], value: int) -> None:
    """Fill a polygon, vertices (n, 2) as (column, row) in cells (1/16 cell precision,
    8-connected edges), with ``value`` in the uint8 ``mask``, in place."""
    _check(mask, "mask", (np.uint8,))
    cv2.fillPoly(mask, [np.round(points_px * 16).astype(np.int32)], value, lineType=cv2.LINE_8, shift=4)


def fill_disc(mask: U8, centre: tuple[int, int], radius: int, value: int) -> None:
    """Fill a disc of ``radius`` cells about ``centre`` (column, row) with ``value`` in the
    uint8 ``mask``, in place."""
    _check(mask, "mask", (np.uint8,))
    cv2.circle(mask, centre, radius, value, -1)


# ---------------------------------------------------------------------------- files
def encode_png(image: U8) -> bytes:
    """PNG bytes of a uint8 image: (h, w) grey, (h, w, 3) BGR or (h, w, 4) BGRA; an
    ``OSError`` if OpenCV cannot encode it."""
    if image.dtype != np.uint8:
        raise TypeError(f"image must be uint8, got {image.dtype}")
    if image.ndim not in (2, 3):
        raise ValueError(f"image must be 2-D or 3-D, got shape {image.shape}")
    ok, encoded = cv2.imencode(".png", image)
    if not ok:
        raise OSError("PNG encoding failed")
    return encoded.tobytes()
