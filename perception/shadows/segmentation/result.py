"""The result of :func:`perception.shadows.segmentation.segment.segment`: regions, levels and the band.

Part of :mod:`perception.shadows.segmentation.segment` (which re-exports these names). Rows are range
samples of the full image, columns beams; on a detection grid of step ``d`` the regions'
rows are those of the grid rows' cells, and the full-resolution label images are built
on demand.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray

from perception.shadows.segmentation.grid import ColumnRows, Extents, Region
from perception.shadows.segmentation.levels import Levels, box_smooth, power_table


@functools.lru_cache(maxsize=16)
def _window_weights(length: int, samples: int, beams: int) -> NDArray[np.float64]:
    """0/1 weights summing ``samples`` rows x ``beams`` beams per output row (read-only).

    Shape (length, (length + samples - 1) * beams): column ``r * beams + b`` is row ``r``
    of a window, beam ``b`` of the box; output row ``i`` sums rows ``i .. i + samples - 1``.
    """
    span = length + samples - 1
    rows = np.arange(span)
    inside = (rows[None, :] >= np.arange(length)[:, None]) & (rows[None, :] < np.arange(length)[:, None] + samples)
    weights = np.repeat(inside.astype(np.float64), beams, axis=1)
    weights.flags.writeable = False
    return weights


#: Label codes of :meth:`Segmentation.label_image` (kept equal to the simulator's where they overlap).
LABEL_OTHER = 0
LABEL_HIGHLIGHT = 1
LABEL_SHADOW = 2


@dataclass(frozen=True, eq=False)
class Segmentation:
    """The result of :func:`segment`.

    Attributes
    ----------
    grid_highlight_labels, grid_shadow_labels : ndarray, shape (n_grid_rows, n_beams), int32
        Component labels on the detection grid, 0 = none; ``Region.label`` indexes them.
        Grid row ``i`` stands for the full rows ``[i * row_step, (i + 1) * row_step)``
        and holds the smoothed level of row ``i * row_step + row_step // 2``.
    row_step : int
        Full-resolution rows per grid row (1: the grid is the image).
    highlight_rows, shadow_rows : tuple of two ndarray, each shape (n_labels, n_beams), int64
        First and last full-resolution row of each label in each beam (first: ``d i``
        and last: ``d i + d - 1`` of its first and last grid cells; -1 where absent),
        indexed by label; read them through :meth:`column_extents`.
    highlights, shadows : tuple of Region
        The components.
    levels : ndarray, shape (n_samples, n_beams), uint8 or float32
        The image's unsmoothed levels: the uint8 image itself (display levels) or the
        dB of a linear image; ``levels * db_per_level`` is dB.
    db_per_level : float
        dB per unit of ``levels``.
    smooth_samples, smooth_beams : int
        The box smoothing (range samples x beams) of the levels that were thresholded;
        :attr:`smoothed` and :meth:`smoothed_windows` give it.
    level_rows : ndarray, shape (n_levels,), int
        The rows (increasing) where the row levels below were taken (every ``d``-th row,
        whatever the method); :attr:`background`, :attr:`shadow_limit` and
        :attr:`highlight_limit` interpolate them to every row.
    grid_background : ndarray, shape (n_levels,), float32
        Seabed level of those rows (upper quartile over beams of the smoothed levels),
        level units.
    grid_shadow_limit, grid_highlight_limit : ndarray, shape (n_levels,), float32
        There, smoothed levels below ``shadow_limit`` (inside the band) are shadow and
        above ``highlight_limit`` highlight, level units (NaN for the classical method,
        whose threshold is local).
    seabed_floor : float
        Smoothed level (level units) above which a row's seabed counts as insonified
        (``band_drop_db`` below the frame's seabed level).
    insonified_rows : ndarray, shape (n_samples,), bool
        Rows where seabed is insonified (the band, as one run of rows).
    band_start_rows, band_stop_rows : ndarray, shape (n_beams,), int
        Per beam, the first and last insonified row (the band's edges are curved in
        a polar image: outer beams meet the seabed farther away); start > stop for a
        beam with no seabed.
    method : str
        The method used.
    """

    grid_highlight_labels: NDArray[np.int32]
    grid_shadow_labels: NDArray[np.int32]
    row_step: int
    highlight_rows: ColumnRows
    shadow_rows: ColumnRows
    highlights: tuple[Region, ...]
    shadows: tuple[Region, ...]
    levels: Levels
    db_per_level: float
    smooth_samples: int
    smooth_beams: int
    level_rows: NDArray[np.intp]
    grid_background: NDArray[np.float32]
    grid_shadow_limit: NDArray[np.float32]
    grid_highlight_limit: NDArray[np.float32]
    seabed_floor: float
    insonified_rows: NDArray[np.bool_]
    band_start_rows: NDArray[np.intp]
    band_stop_rows: NDArray[np.intp]
    method: str = "speckle"

    def power(self, rows: slice, cols: slice | NDArray[np.intp]) -> NDArray[np.float64]:
        """Linear echo power (relative) of a block of the image (rows, then columns)."""
        return self.power_of(self.levels[rows][:, cols])

    def power_of(self, block: NDArray[np.generic]) -> NDArray[np.float64]:
        """Linear echo power (relative) of levels taken from ``levels`` (any shape)."""
        if block.dtype == np.uint8:
            if block.ndim == 2 and block.size:
                # OpenCV's table look-up: the same values, several times faster.
                lut = power_table(self.db_per_level)[None, :]
                return np.asarray(cv2.LUT(np.asarray(block, dtype=np.uint8), lut), dtype=np.float64)
            return np.asarray(power_table(self.db_per_level)[block], dtype=np.float64)
        return np.power(10.0, np.asarray(block, dtype=np.float64) * (self.db_per_level / 10.0))

    def power_take(self, index: NDArray[np.intp]) -> NDArray[np.float64]:
        """Linear echo power at flat indices ``row * n_beams + beam`` of ``levels`` (any shape)."""
        return self.power_of(self.levels.ravel().take(index))

    def column_extents(self, region: Region) -> Extents:
        """First and last full-resolution row of ``region`` in each column of its box.

        On a detection grid of step ``d`` the rows are those of the grid cells (first:
        ``d * i``, last: ``d * i + d - 1``). Returns (first, last, present), each of shape
        (region.n_cols,); first and last are meaningless where present is False.
        """
        first_all, last_all = self.shadow_rows if region.kind == "shadow" else self.highlight_rows
        cols = slice(region.col_start, region.col_stop)
        last = last_all[region.label, cols]
        return first_all[region.label, cols], last, last >= 0

    def _per_row(self, values: NDArray[np.float32]) -> NDArray[np.float32]:
        rows = np.arange(self.levels.shape[0])
        return np.interp(rows, self.level_rows, values).astype(np.float32)

    @functools.cached_property
    def background(self) -> NDArray[np.float32]:
        """Seabed level of each row, shape (n_samples,), float32, level units."""
        return self._per_row(self.grid_background)

    @functools.cached_property
    def shadow_limit(self) -> NDArray[np.float32]:
        """Shadow threshold of each row, shape (n_samples,), float32, level units."""
        return self._per_row(self.grid_shadow_limit)

    @functools.cached_property
    def highlight_limit(self) -> NDArray[np.float32]:
        """Highlight threshold of each row, shape (n_samples,), float32, level units."""
        return self._per_row(self.grid_highlight_limit)

    @functools.cached_property
    def smoothed(self) -> NDArray[np.float32]:
        """Box-smoothed ``levels``, shape (n_samples, n_beams), float32 (built on demand)."""
        return box_smooth(self.levels, samples=self.smooth_samples, beams=self.smooth_beams)

    def smoothed_windows(
        self, start_rows: NDArray[np.intp], length: int, beams: NDArray[np.intp]
    ) -> NDArray[np.float64]:
        """:attr:`smoothed` in a window of rows per beam, without smoothing the whole image.

        Parameters
        ----------
        start_rows : ndarray, shape (n,), int
            First row of each window. Rows outside the image hold the box mean over the
            image's edge rows repeated (the same as :attr:`smoothed` inside the image).
        length : int
            Rows per window.
        beams : ndarray, shape (n,), int
            The beam of each window.

        Returns
        -------
        ndarray, shape (length, n), float64
            ``smoothed[start_rows[j] + i, beams[j]]`` at ``[i, j]``.
        """
        n_rows, n_cols = self.levels.shape
        h_s, h_b = self.smooth_samples // 2, self.smooth_beams // 2
        rows = np.minimum(np.maximum(start_rows[None, :] - h_s + np.arange(length + 2 * h_s)[:, None], 0), n_rows - 1)
        cols = np.minimum(np.maximum(beams[None, :] + np.arange(-h_b, h_b + 1)[:, None], 0), n_cols - 1)
        index = (rows * n_cols)[:, None, :] + cols[None, :, :]
        taken = self.levels.ravel().take(index)
        if taken.dtype == np.uint8:
            # Every window's sum of the box's levels in one product with a 0/1 matrix:
            # sums of small integers are exact in float64 whatever their order, so the
            # means are those of the running sums below.
            weights = _window_weights(length, self.smooth_samples, self.smooth_beams)
            flat = taken.reshape(weights.shape[1], beams.size).astype(np.float64)
            return (weights @ flat) / (self.smooth_samples * self.smooth_beams)
        # The beams added one by one (cheaper than a reduction over the middle axis).
        block = taken[:, 0].astype(np.float64)
        for k in range(1, taken.shape[1]):
            block += taken[:, k]
        cum = np.empty((block.shape[0] + 1, beams.size))
        cum[0] = 0.0
        np.cumsum(block, axis=0, out=cum[1:])
        return (cum[self.smooth_samples :] - cum[: -self.smooth_samples]) / (
            self.smooth_samples * self.smooth_beams
        )

    @functools.cached_property
    def highlight_labels(self) -> NDArray[np.int32]:
        """Highlight labels at full resolution, shape (n_samples, n_beams), int32 (built on demand)."""
        return self._full_labels(
            self.grid_highlight_labels, self.highlights, self.smoothed > self.highlight_limit[:, None]
        )

    @functools.cached_property
    def shadow_labels(self) -> NDArray[np.int32]:
        """Shadow labels at full resolution, shape (n_samples, n_beams), int32 (built on demand)."""
        return self._full_labels(
            self.grid_shadow_labels,
            self.shadows,
            (self.smoothed < self.shadow_limit[:, None]) & self._band_mask(),
        )

    def _band_mask(self) -> NDArray[np.bool_]:
        rows = np.arange(self.levels.shape[0])[:, None]
        return (rows >= self.band_start_rows[None, :]) & (rows <= self.band_stop_rows[None, :])

    def _full_labels(
        self, grid: NDArray[np.int32], regions: tuple[Region, ...], mask: NDArray[np.bool_]
    ) -> NDArray[np.int32]:
        """Grid labels of ``regions`` carried to full resolution: each region takes the pixels
        of the full-resolution threshold ``mask`` in and next to its grid cells, holes filled."""
        d = self.row_step
        lut = np.zeros(int(grid.max()) + 1, dtype=np.int32)
        for region in regions:
            lut[region.label] = region.label
        grid = lut[grid]
        if d == 1:
            return grid
        n_rows = self.levels.shape[0]
        near = np.asarray(cv2.dilate(grid.astype(np.uint16), np.ones((3, 3), np.uint8)), dtype=np.int32)
        near = np.repeat(near, d, axis=0)[:n_rows]
        kept = (mask & (near > 0)).astype(np.uint8)
        contours, _ = cv2.findContours(kept, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
        filled = np.zeros_like(kept)
        cv2.drawContours(filled, contours, -1, 1, thickness=-1)
        return np.where(filled > 0, near, 0).astype(np.int32)

    @property
    def highlight_mask(self) -> NDArray[np.bool_]:
        """Boolean highlight mask, shape (n_samples, n_beams)."""
        return self.highlight_labels > 0

    @property
    def shadow_mask(self) -> NDArray[np.bool_]:
        """Boolean shadow mask, shape (n_samples, n_beams)."""
        return self.shadow_labels > 0

    def label_image(self) -> NDArray[np.uint8]:
        """Codes per pixel: 0 other, 1 highlight, 2 shadow; shape (n_samples, n_beams)."""
        out = np.zeros(self.levels.shape, dtype=np.uint8)
        out[self.shadow_labels > 0] = LABEL_SHADOW
        out[self.highlight_labels > 0] = LABEL_HIGHLIGHT
        return out

    def band_edges(self) -> tuple[int, int] | None:
        """(first, last) insonified row, or None when no row is insonified."""
        rows = np.flatnonzero(self.insonified_rows)
        if rows.size == 0:
            return None
        return int(rows[0]), int(rows[-1])
