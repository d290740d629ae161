"""The result of :func:`perception.shadows.segmentation.segment.segment`: regions, levels and the band.

Rows are range samples of the full image, columns beams. On a detection grid of step ``d``
grid row ``i`` is the mean of the full rows ``[d i, d i + d)``; the regions' rows are those
of their grid cells, and full-resolution label images are built on demand.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from perception import imaging
from perception.shadows.segmentation.grid import ColumnRows, Extents, Region
from perception.shadows.segmentation.levels import Levels, block_axes, power_table
from perception.stored_init import check_init_takes_fields

#: Label codes of :meth:`Segmentation.label_image` (kept equal to the simulator's where they overlap).
LABEL_OTHER = 0
LABEL_HIGHLIGHT = 1
LABEL_SHADOW = 2


@dataclass(frozen=True, eq=False)
class Segmentation:
    """The result of :func:`segment`.

    Attributes
    ----------
    levels : ndarray, shape (n_samples, n_beams), uint8 or float32
        The image's levels: the uint8 image itself (display levels) or the dB of a linear
        image; ``levels * db_per_level`` is dB (of power when a linear image holds power).
    db_per_level : float
        dB per unit of ``levels``.
    sample_m : float
        Range spacing of the samples, m.
    row_step : int
        Full-resolution rows per grid row (1: the grid is the image).
    grid : ndarray, shape (n_grid_rows, n_beams), float32
        Mean level of each grid cell (``row_step`` rows x ``smooth_beams`` beams centred).
    grid_background : ndarray, shape (n_grid_rows,), float32
        Seabed level of each grid row (upper quartile over beams, capped where bright
        targets raise it), level units.
    sigma : float
        The frame's seabed spread: robust standard deviation of ``grid - background`` over
        the band, level units (> 0). Thresholds are multiples of it.
    noise_level : float
        Level of the darkest grid rows (2nd percentile of the row levels): the noise floor
        when the window holds water column or the dark beyond the aperture.
    shadow_offset, highlight_offset : float
        Grid pixels below ``background - shadow_offset`` (inside the band) are shadow, above
        ``background + highlight_offset`` highlight, level units.
    grid_highlight_labels, grid_shadow_labels : ndarray, shape (n_grid_rows, n_beams), int32
        Component labels on the grid, 0 = none; ``Region.label`` indexes them.
    highlight_rows, shadow_rows : tuple of two ndarray, each shape (n_labels, n_beams), int64
        First and last full-resolution row of each label in each beam (-1 where absent).
    highlights, shadows : tuple of Region
        The kept components (rows in full-resolution rows).
    band_grid_rows : ndarray, shape (n_grid_rows,), bool
        Grid rows holding insonified seabed (one run).
    band_start_rows, band_stop_rows : ndarray, shape (n_beams,), int
        Per beam, the first and last insonified full-resolution row (curved across the
        beams of a polar image); start > stop for a beam without seabed.
    method : str
    """

    levels: Levels
    db_per_level: float
    sample_m: float
    row_step: int
    grid: NDArray[np.float32]
    grid_background: NDArray[np.float32]
    sigma: float
    noise_level: float
    shadow_offset: float
    highlight_offset: float
    grid_highlight_labels: NDArray[np.int32]
    grid_shadow_labels: NDArray[np.int32]
    highlight_rows: ColumnRows
    shadow_rows: ColumnRows
    highlights: tuple[Region, ...]
    shadows: tuple[Region, ...]
    band_grid_rows: NDArray[np.bool_]
    band_start_rows: NDArray[np.intp]
    band_stop_rows: NDArray[np.intp]
    method: str = "speckle"

    # One per frame, with many fields: stored in ``__dict__`` at once (what the generated
    # frozen ``__init__`` does one ``object.__setattr__`` at a time), as
    # :class:`perception.shadows.segmentation.grid.Region` does; its parameters are the
    # fields, in order (checked when the module loads).
    def __init__(
        self, levels: Levels, db_per_level: float, sample_m: float, row_step: int, grid: NDArray[np.float32],
        grid_background: NDArray[np.float32], sigma: float, noise_level: float, shadow_offset: float,
        highlight_offset: float, grid_highlight_labels: NDArray[np.int32], grid_shadow_labels: NDArray[np.int32],
        highlight_rows: ColumnRows, shadow_rows: ColumnRows, highlights: tuple[Region, ...],
        shadows: tuple[Region, ...], band_grid_rows: NDArray[np.bool_], band_start_rows: NDArray[np.intp],
        band_stop_rows: NDArray[np.intp], method: str = "speckle",
    ) -> None:
        self.__dict__.update(
            levels=levels, db_per_level=db_per_level, sample_m=sample_m, row_step=row_step, grid=grid,
            grid_background=grid_background, sigma=sigma, noise_level=noise_level, shadow_offset=shadow_offset,
            highlight_offset=highlight_offset, grid_highlight_labels=grid_highlight_labels,
            grid_shadow_labels=grid_shadow_labels, highlight_rows=highlight_rows, shadow_rows=shadow_rows,
            highlights=highlights, shadows=shadows, band_grid_rows=band_grid_rows, band_start_rows=band_start_rows,
            band_stop_rows=band_stop_rows, method=method,
        )

    @property
    def n_rows(self) -> int:
        """Rows of the full image."""
        return int(self.levels.shape[0])

    @property
    def sigma_db(self) -> float:
        """:attr:`sigma` in dB."""
        return self.sigma * self.db_per_level

    def power_of(self, block: NDArray[np.generic]) -> NDArray[np.float64]:
        """Linear echo power (relative) of levels taken from ``levels`` (any shape)."""
        if block.dtype == np.uint8:
            if block.ndim == 2 and block.size:
                lut = power_table(self.db_per_level)[None, :]
                return imaging.lookup(np.asarray(block, dtype=np.uint8), lut)
            return np.asarray(power_table(self.db_per_level)[block], dtype=np.float64)
        return np.power(10.0, np.asarray(block, dtype=np.float64) * (self.db_per_level / 10.0))

    def column_extents(self, region: Region) -> Extents:
        """First and last full-resolution row of ``region`` in each column of its box, and
        which columns hold it; each of shape (region.n_cols,)."""
        first_all, last_all = self.shadow_rows if region.kind == "shadow" else self.highlight_rows
        cols = slice(region.col_start, region.col_stop)
        last = last_all[region.label, cols]
        return first_all[region.label, cols], last, last >= 0

    def _full(self, grid: NDArray[np.int32]) -> NDArray[np.int32]:
        d = self.row_step
        if d == 1 and grid.shape[0] == self.n_rows:
            return grid
        full = np.zeros((self.n_rows, grid.shape[1]), dtype=np.int32)
        rows = min(grid.shape[0] * d, self.n_rows)
        full[:rows] = np.repeat(grid, d, axis=0)[:rows]
        return full

    def _kept(self, grid: NDArray[np.int32], regions: tuple[Region, ...]) -> NDArray[np.int32]:
        lut = np.zeros(int(grid.max(initial=0)) + 1, dtype=np.int32)
        for region in regions:
            lut[region.label] = region.label
        return lut[grid]

    @functools.cached_property
    def shadow_labels(self) -> NDArray[np.int32]:
        """Shadow labels of the kept regions at full resolution, shape (n_samples, n_beams)."""
        return self._full(self._kept(self.grid_shadow_labels, self.shadows))

    @functools.cached_property
    def highlight_labels(self) -> NDArray[np.int32]:
        """Highlight labels of the kept regions at full resolution, shape (n_samples, n_beams)."""
        return self._full(self._kept(self.grid_highlight_labels, self.highlights))

    @property
    def shadow_mask(self) -> NDArray[np.bool_]:
        """Boolean shadow mask, shape (n_samples, n_beams)."""
        return self.shadow_labels > 0

    @property
    def highlight_mask(self) -> NDArray[np.bool_]:
        """Boolean highlight mask, shape (n_samples, n_beams)."""
        return self.highlight_labels > 0

    def label_image(self) -> NDArray[np.uint8]:
        """Codes per pixel: 0 other, 1 highlight, 2 shadow; shape (n_samples, n_beams)."""
        out = np.zeros(self.levels.shape, dtype=np.uint8)
        out[self.shadow_labels > 0] = LABEL_SHADOW
        out[self.highlight_labels > 0] = LABEL_HIGHLIGHT
        return out

    @functools.cached_property
    def background(self) -> NDArray[np.float32]:
        """Seabed level of each full-resolution row, shape (n_samples,), float32, level units."""
        return self._background_at(0, self.n_rows)

    def background_rows(self, start: int, stop: int) -> NDArray[np.float32]:
        """``background[start:stop]`` (0 <= start <= stop <= n_samples), interpolated at those
        rows only unless the whole is known (the measurement reads a few hundred rows of a
        frame's thousands): the same values, each row's interpolation on its own."""
        known = self.__dict__.get("background")
        if known is not None:
            return known[start:stop]
        return self._background_at(start, stop)

    def _background_at(self, start: int, stop: int) -> NDArray[np.float32]:
        # The rows as float64 and the grid rows' centres ((i + 0.5) d - 0.5, the same
        # operations), cached per geometry.
        rows, centres = block_axes(self.n_rows, self.grid_background.size, self.row_step)
        return np.interp(rows[start:stop], centres, self.grid_background).astype(np.float32)

    @functools.cached_property
    def insonified_rows(self) -> NDArray[np.bool_]:
        """Full-resolution rows of the band, shape (n_samples,), bool."""
        out = np.zeros(self.n_rows, dtype=bool)
        rows = min(self.band_grid_rows.size * self.row_step, self.n_rows)
        out[:rows] = np.repeat(self.band_grid_rows, self.row_step)[:rows]
        return out

    def band_edges(self) -> tuple[int, int] | None:
        """(first, last) insonified full-resolution row, or None when no row is insonified."""
        rows = np.flatnonzero(self.insonified_rows)
        if rows.size == 0:
            return None
        return int(rows[0]), int(rows[-1])


check_init_takes_fields(Segmentation)
