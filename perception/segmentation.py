"""Highlight and cast-shadow segmentation of polar sonar images.

Two methods, selectable in :class:`SegmentationConfig`:

``"speckle"`` (default)
    Speckle-aware, in the decibel domain where speckle is additive and of one spread
    everywhere: the image's levels (dB) are smoothed over a few range samples and beams,
    and each pixel is compared with the seabed level of its range row (the upper quartile
    over the beams, taken on a decimated image so it stays cheap). A fixed difference is a
    cell-averaging CFAR test against the row: highlights are ``highlight_db`` above
    their row's seabed, shadows ``shadow_db`` below it. Shadows are only sought in rows
    where seabed is insonified (the row's seabed level within ``band_drop_db`` of the
    frame's seabed level), which tells them apart from the darkness before the vertical
    beam meets the seabed, beyond its far edge and beyond the range window. Optional
    opening and closing clean the masks; components have their holes filled.
``"classical"``
    The paper's baseline: OpenCV's adaptive mean threshold on the raw image (dark
    below the local mean minus ``classical_offset`` is shadow, bright above the local
    mean plus it is highlight), without normalisation or band awareness. Kept so that
    the improvement can be shown side by side.

Images are (n_samples, n_beams) = (range rows, beam columns), see
:mod:`perception.frame`. Functions take the image first, options keyword-only, and
never modify their input. Accepted dtypes: uint8, uint16, float32 (float64 is
accepted and converted). uint8 images are taken as ARIS-style display levels,
``uint8_db_range`` dB over 0-255 (the ARIS SDK maps 0-80 dB to 0-255); uint16 and float
images as linear echo power (converted to dB here).
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray
from scipy.ndimage import maximum_filter1d, median_filter, minimum_filter1d

METHODS = ("speckle", "classical")

#: Blocks of rows in the running median of the row background.
BACKGROUND_MEDIAN_BLOCKS = 63

#: Beams whose band edge is this far (rows) from the fitted curve count as moved by a shadow.
BAND_EDGE_TOLERANCE_ROWS = 6.0

#: Row step of the per-beam band-edge search.
BAND_EDGE_STRIDE = 4

#: More outer contours than this (a speckled mask) switch to a labelling pass.
MAX_CONTOURS = 200

#: Image levels proportional to dB: the uint8 display image or float32 dB.
Levels = NDArray[np.uint8] | NDArray[np.float32]

#: Label codes of :func:`label_image` (kept equal to the simulator's where they overlap).
LABEL_OTHER = 0
LABEL_HIGHLIGHT = 1
LABEL_SHADOW = 2


@dataclass(frozen=True)
class SegmentationConfig:
    """Settings of :func:`segment`.

    Attributes
    ----------
    method : str
        ``"speckle"`` (default) or ``"classical"`` (the paper's adaptive threshold).
    smooth_samples, smooth_beams : int
        Box smoothing size along range (samples) and azimuth (beams), odd, >= 1.
    background_block_samples : int
        Rows averaged per block before the per-row median over beams.
    shadow_db : float
        A pixel is shadow when its smoothed level is this far below its row's seabed, dB.
    highlight_db : float
        A pixel is highlight when its smoothed level is this far above its row's seabed, dB.
    band_drop_db : float
        A row is insonified seabed when its seabed level is within this of the frame's
        seabed level (90th percentile of the row levels), dB.
    uint8_db_range : float or None
        dB spanned by uint8 levels 0-255 (80 for ARIS); None: uint8 is linear power.
    open_size, close_size : int
        Sizes (pixels) of the square structuring elements of the clean-up; 0 disables.
    min_shadow_area_px, min_highlight_area_px : int
        Smaller components are dropped.
    classical_block_size : int
        Neighbourhood (odd) of the classical adaptive threshold.
    classical_offset : float
        Offset of the classical threshold in grey levels of the 8-bit image.
    """

    method: str = "speckle"
    smooth_samples: int = 5
    smooth_beams: int = 3
    background_block_samples: int = 8
    shadow_db: float = 6.0
    highlight_db: float = 6.0
    band_drop_db: float = 10.0
    uint8_db_range: float | None = 80.0
    open_size: int = 0
    close_size: int = 0
    min_shadow_area_px: int = 12
    min_highlight_area_px: int = 6
    classical_block_size: int = 51
    classical_offset: float = 12.0

    def __post_init__(self) -> None:
        if self.method not in METHODS:
            raise ValueError(f"method must be one of {METHODS}, got {self.method!r}")
        for name in ("smooth_samples", "smooth_beams", "classical_block_size"):
            value = getattr(self, name)
            if value < 1 or value % 2 == 0:
                raise ValueError(f"{name} must be an odd integer >= 1, got {value}")
        if self.background_block_samples < 1:
            raise ValueError("background_block_samples must be >= 1")
        for name in ("shadow_db", "highlight_db", "band_drop_db"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0 dB, got {getattr(self, name)}")
        if self.uint8_db_range is not None and not self.uint8_db_range > 0:
            raise ValueError(f"uint8_db_range must be > 0 dB or None, got {self.uint8_db_range}")
        if self.open_size < 0 or self.close_size < 0:
            raise ValueError("open_size and close_size must be >= 0")


@dataclass(frozen=True)
class Region:
    """One connected highlight or shadow component.

    Rows are range samples, columns beams; ``*_stop`` is exclusive.
    """

    label: int
    kind: str
    row_start: int
    row_stop: int
    col_start: int
    col_stop: int
    area_px: int
    centroid_row: float
    centroid_col: float

    @property
    def n_cols(self) -> int:
        """Number of beams the bounding box spans."""
        return self.col_stop - self.col_start


@dataclass(frozen=True, eq=False)
class Segmentation:
    """The result of :func:`segment`.

    Attributes
    ----------
    highlight_labels, shadow_labels : ndarray, shape (n_samples, n_beams), int32
        Component labels, 0 = none; ``Region.label`` indexes them.
    highlights, shadows : tuple of Region
        The components.
    levels : ndarray, shape (n_samples, n_beams), uint8 or float32
        The image's unsmoothed levels: the uint8 image itself (display levels) or the
        dB of a linear image; ``levels * db_per_level`` is dB.
    db_per_level : float
        dB per unit of ``levels``.
    smoothed : ndarray, shape (n_samples, n_beams), float32
        Box-smoothed ``levels``.
    background : ndarray, shape (n_samples,), float32
        Seabed level of each row (upper quartile over beams of ``smoothed``), level units.
    insonified_rows : ndarray, shape (n_samples,), bool
        Rows where seabed is insonified (the band, as one run of rows).
    band_start_rows, band_stop_rows : ndarray, shape (n_beams,), int
        Per beam, the first and last insonified row (the band's edges are curved in
        a polar image: outer beams meet the seabed farther away); start > stop for a
        beam with no seabed.
    method : str
        The method used.
    """

    highlight_labels: NDArray[np.int32]
    shadow_labels: NDArray[np.int32]
    highlights: tuple[Region, ...]
    shadows: tuple[Region, ...]
    levels: Levels
    db_per_level: float
    smoothed: NDArray[np.float32]
    background: NDArray[np.float32]
    insonified_rows: NDArray[np.bool_]
    band_start_rows: NDArray[np.intp]
    band_stop_rows: NDArray[np.intp]
    method: str = "speckle"

    def power(self, rows: slice, cols: slice | NDArray[np.intp]) -> NDArray[np.float64]:
        """Linear echo power (relative) of a block of the image (rows, then columns)."""
        block = self.levels[rows][:, cols]
        if block.dtype == np.uint8:
            table = np.power(10.0, np.arange(256) * (self.db_per_level / 10.0))
            return np.asarray(table[block], dtype=np.float64)
        return np.power(10.0, np.asarray(block, dtype=np.float64) * (self.db_per_level / 10.0))

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
        out = np.zeros(self.highlight_labels.shape, dtype=np.uint8)
        out[self.shadow_labels > 0] = LABEL_SHADOW
        out[self.highlight_labels > 0] = LABEL_HIGHLIGHT
        return out

    def band_edges(self) -> tuple[int, int] | None:
        """(first, last) insonified row, or None when no row is insonified."""
        rows = np.flatnonzero(self.insonified_rows)
        if rows.size == 0:
            return None
        return int(rows[0]), int(rows[-1])


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
    n_rows, n_cols = smoothed.shape
    n_blocks = max(1, n_rows // block_samples)
    if n_blocks < n_rows:
        small = cv2.resize(smoothed, (n_cols, n_blocks), interpolation=cv2.INTER_AREA)
    else:
        small = smoothed
    # The upper quartile, not the median: a row can be more than half shadow when large
    # targets stand in it, but highlights are never a quarter of a row.
    k = (3 * small.shape[1]) // 4
    level = np.partition(small, k, axis=1)[:, k].astype(np.float32)
    # Bright targets filling a quarter of a row raise its quartile; a wide running
    # median over blocks (which keeps the band's edges sharp) caps such rises.
    wide = np.asarray(median_filter(level, size=BACKGROUND_MEDIAN_BLOCKS, mode="nearest"))
    level = np.minimum(level, wide)
    if n_blocks == n_rows:
        return level
    centres = (np.arange(n_blocks) + 0.5) * (n_rows / n_blocks) - 0.5
    return np.interp(np.arange(n_rows), centres, level).astype(np.float32)


def _clean(mask: NDArray[np.uint8], *, open_size: int, close_size: int) -> NDArray[np.uint8]:
    if open_size > 1:
        kernel = np.ones((open_size, open_size), np.uint8)
        mask = np.asarray(cv2.morphologyEx(mask, cv2.MORPH_OPEN, kernel), dtype=np.uint8)
    if close_size > 1:
        kernel = np.ones((close_size, close_size), np.uint8)
        mask = np.asarray(cv2.morphologyEx(mask, cv2.MORPH_CLOSE, kernel), dtype=np.uint8)
    return mask


def components(
    mask: NDArray[np.uint8], *, kind: str, min_area_px: int
) -> tuple[NDArray[np.int32], tuple[Region, ...]]:
    """Connected components (8-connected) of a 0/1 uint8 mask, holes filled, small ones dropped.

    Components come from their outer contours (OpenCV's border following, much cheaper
    than a labelling pass with statistics on sparse masks); each is filled, so holes
    inside a shadow belong to it.

    Returns
    -------
    labels : ndarray, shape of ``mask``, int32
        0 = none, 1.. = kept regions.
    regions : tuple of Region
    """
    contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    if len(contours) > MAX_CONTOURS:
        return _components_by_labelling(mask, kind=kind, min_area_px=min_area_px)
    labels = np.zeros(mask.shape, dtype=np.int32)
    regions: list[Region] = []
    for i, contour in enumerate(contours):
        x, y, w, h = cv2.boundingRect(contour)
        if w * h < min_area_px:
            continue
        new = len(regions) + 1
        cv2.drawContours(labels, contours, i, new, thickness=-1)
        rows, cols = np.nonzero(labels[y : y + h, x : x + w] == new)
        if rows.size < min_area_px:
            cv2.drawContours(labels, contours, i, 0, thickness=-1)
            continue
        regions.append(
            Region(
                label=new,
                kind=kind,
                row_start=y,
                row_stop=y + h,
                col_start=x,
                col_stop=x + w,
                area_px=int(rows.size),
                centroid_row=y + float(rows.mean()),
                centroid_col=x + float(cols.mean()),
            )
        )
    return labels, tuple(regions)


def _components_by_labelling(
    mask: NDArray[np.uint8], *, kind: str, min_area_px: int
) -> tuple[NDArray[np.int32], tuple[Region, ...]]:
    """:func:`components` for speckled masks with many pieces (holes are not filled)."""
    n, raw, stats, centroids = cv2.connectedComponentsWithStats(mask, connectivity=8)
    keep = np.flatnonzero(stats[1:, cv2.CC_STAT_AREA] >= min_area_px) + 1
    lut = np.zeros(n, dtype=np.int32)
    lut[keep] = np.arange(1, keep.size + 1, dtype=np.int32)
    regions = tuple(
        Region(
            label=new,
            kind=kind,
            row_start=int(stats[old, cv2.CC_STAT_TOP]),
            row_stop=int(stats[old, cv2.CC_STAT_TOP] + stats[old, cv2.CC_STAT_HEIGHT]),
            col_start=int(stats[old, cv2.CC_STAT_LEFT]),
            col_stop=int(stats[old, cv2.CC_STAT_LEFT] + stats[old, cv2.CC_STAT_WIDTH]),
            area_px=int(stats[old, cv2.CC_STAT_AREA]),
            centroid_row=float(centroids[old, 1]),
            centroid_col=float(centroids[old, 0]),
        )
        for new, old in enumerate(keep, start=1)
    )
    return np.asarray(lut[raw], dtype=np.int32), regions


def insonified_rows(background: NDArray[np.float32], *, drop: float) -> NDArray[np.bool_]:
    """Rows whose seabed level is within ``drop`` (level units) of the frame's seabed level.

    The frame's seabed level is the 90th percentile of the row levels; the kept rows
    form the longest contiguous run (the insonified band), so isolated bright rows in
    the dark are not taken for seabed.
    """
    reference = float(np.percentile(background, 90))
    above = background >= reference - drop
    padded = np.concatenate(([0], above.astype(np.int8), [0]))
    edges = np.flatnonzero(np.diff(padded))
    starts, stops = edges[0::2], edges[1::2]
    best = int(np.argmax(stops - starts))
    out = np.zeros(background.shape, dtype=bool)
    out[starts[best] : stops[best]] = True
    return out


def _robust_edge(values: NDArray[np.intp], valid: NDArray[np.bool_], *, later_is_outlier: bool) -> NDArray[np.intp]:
    """A parabola over beams through band-edge rows, ignoring edges moved by shadows.

    A shadow at the band's near edge moves that beam's first seabed row later; at the
    far edge it moves the last seabed row earlier. Those beams are dropped and the
    parabola refitted (two passes).
    """
    x = np.linspace(-1.0, 1.0, values.size)
    design = np.stack([np.ones_like(x), x, x * x], axis=1)
    target = values.astype(np.float64)
    use = valid.copy()
    fitted = target
    for _ in range(2):
        if np.count_nonzero(use) < 3:
            return values
        a = design[use]
        coeffs = np.linalg.solve(a.T @ a, a.T @ target[use])
        fitted = design @ coeffs
        residual = target - fitted
        use = valid & ((residual <= BAND_EDGE_TOLERANCE_ROWS) if later_is_outlier
                       else (residual >= -BAND_EDGE_TOLERANCE_ROWS))
    return np.rint(fitted).astype(np.intp)


def column_band(
    smoothed: NDArray[np.float32], rows: NDArray[np.bool_], *, level: float
) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """Per beam, the first and last seabed row of the band ``rows`` (level >= ``level``).

    The band's edges are curved across the beams; beams where a shadow moves an edge are
    corrected by a robust parabola over the beams. Returns (start, stop), shape (n_beams,).
    """
    n_cols = smoothed.shape[1]
    band = np.flatnonzero(rows)
    if band.size == 0:
        return np.ones(n_cols, dtype=np.intp), np.zeros(n_cols, dtype=np.intp)
    r0, r1 = int(band[0]), int(band[-1]) + 1
    # Every BAND_EDGE_STRIDE-th row is enough for the edges (and four times cheaper).
    inside = smoothed[r0:r1:BAND_EDGE_STRIDE] >= level
    any_row = np.asarray(inside.any(axis=0), dtype=bool)
    start = r0 + BAND_EDGE_STRIDE * np.argmax(inside, axis=0)
    stop = r0 + BAND_EDGE_STRIDE * (inside.shape[0] - 1 - np.argmax(inside[::-1], axis=0))
    start = np.clip(_robust_edge(start, any_row, later_is_outlier=True), r0, r1 - 1)
    stop = np.clip(_robust_edge(stop, any_row, later_is_outlier=False), r0, r1 - 1)
    return start.astype(np.intp), stop.astype(np.intp)


def _shadow_in_band(
    smoothed: NDArray[np.float32],
    below: NDArray[np.float32],
    start: NDArray[np.intp],
    stop: NDArray[np.intp],
) -> NDArray[np.bool_]:
    """``smoothed < below`` per row, kept only between each beam's band rows.

    The per-beam test is only needed in the rows where the curved band edges lie.
    """
    n_rows = smoothed.shape[0]
    lo, hi = int(start.min()), int(stop.max()) + 1
    limit = below.copy()
    limit[: max(lo, 0)] = -np.inf
    limit[max(hi, 0) :] = -np.inf
    shadow = smoothed < limit[:, None]
    near_end = min(int(start.max()), n_rows)
    if near_end > lo:
        rows = np.arange(lo, near_end)[:, None]
        shadow[lo:near_end] &= rows >= start[None, :]
    far_start = max(int(stop.min()) + 1, 0)
    if hi > far_start:
        rows = np.arange(far_start, hi)[:, None]
        shadow[far_start:hi] &= rows <= stop[None, :]
    return shadow


def segment(image: NDArray[np.generic], *, config: SegmentationConfig | None = None) -> Segmentation:
    """Segment highlights and cast shadows in one polar sonar image.

    Parameters
    ----------
    image : ndarray, shape (n_samples, n_beams), uint8, uint16, float32 or float64
        Echo intensity; rows are range samples (nearest first), columns beams. uint8 is
        taken as display levels over ``config.uint8_db_range`` dB, other dtypes as
        linear power.
    config : SegmentationConfig, optional
        Settings; the default is the speckle-aware method.

    Returns
    -------
    Segmentation
        Masks, components, smoothed levels and the insonified rows.
    """
    cfg = config or SegmentationConfig()
    levels, db_per_level = as_levels(image, uint8_db_range=cfg.uint8_db_range)
    smoothed = box_smooth(levels, samples=cfg.smooth_samples, beams=cfg.smooth_beams)
    background = row_background(smoothed, block_samples=cfg.background_block_samples)
    rows = insonified_rows(background, drop=cfg.band_drop_db / db_per_level)
    seabed_floor = float(np.percentile(background, 90)) - cfg.band_drop_db / db_per_level
    band_start, band_stop = column_band(smoothed, rows, level=seabed_floor)
    if cfg.method == "speckle":
        # Where the row level changes fast (the band's edges) a block straddles both
        # sides: shadows are tested against the lowest nearby level, highlights against
        # the highest, so neither edge of the band turns into shadow or highlight.
        size = 2 * cfg.background_block_samples + 1
        low = minimum_filter1d(background, size, mode="nearest")
        high = maximum_filter1d(background, size, mode="nearest")
        shadow_below = low - np.float32(cfg.shadow_db / db_per_level)
        highlight_above = np.maximum(high, np.float32(seabed_floor)) + np.float32(
            cfg.highlight_db / db_per_level
        )
        shadow = _shadow_in_band(smoothed, shadow_below, band_start, band_stop)
        shadow_u8 = shadow.view(np.uint8)
        highlight_u8 = (smoothed > highlight_above[:, None]).view(np.uint8)
    else:
        grey: NDArray[np.uint8] = (
            np.asarray(levels, dtype=np.uint8)
            if levels.dtype == np.uint8
            else _to_uint8(np.asarray(levels, np.float32))
        )
        block = min(cfg.classical_block_size, (min(grey.shape) // 2) * 2 - 1)
        block = max(block, 3)
        shadow_u8 = np.asarray(
            cv2.adaptiveThreshold(
                grey, 1, cv2.ADAPTIVE_THRESH_MEAN_C, cv2.THRESH_BINARY_INV, block,
                cfg.classical_offset,
            ),
            dtype=np.uint8,
        )
        highlight_u8 = np.asarray(
            cv2.adaptiveThreshold(
                grey, 1, cv2.ADAPTIVE_THRESH_MEAN_C, cv2.THRESH_BINARY, block,
                -cfg.classical_offset,
            ),
            dtype=np.uint8,
        )
    shadow_u8 = _clean(shadow_u8, open_size=cfg.open_size, close_size=cfg.close_size)
    highlight_u8 = _clean(highlight_u8, open_size=cfg.open_size, close_size=cfg.close_size)
    shadow_labels, shadows = components(shadow_u8, kind="shadow", min_area_px=cfg.min_shadow_area_px)
    highlight_labels, highlights = components(
        highlight_u8, kind="highlight", min_area_px=cfg.min_highlight_area_px
    )
    return Segmentation(
        highlight_labels=highlight_labels,
        shadow_labels=shadow_labels,
        highlights=highlights,
        shadows=shadows,
        levels=levels,
        db_per_level=db_per_level,
        smoothed=smoothed,
        background=background,
        insonified_rows=rows,
        band_start_rows=band_start,
        band_stop_rows=band_stop,
        method=cfg.method,
    )


def _to_uint8(db: NDArray[np.float32]) -> NDArray[np.uint8]:
    """dB levels to 0..255 over the 80 dB below their 99.5th percentile (classical input)."""
    top = float(np.percentile(db, 99.5))
    return np.clip((db - (top - 80.0)) * (255.0 / 80.0), 0, 255).astype(np.uint8)


def mask_iou(predicted: NDArray[np.bool_], truth: NDArray[np.bool_]) -> float:
    """Intersection over union of two boolean masks of one shape (1.0 when both are empty)."""
    p = np.asarray(predicted, dtype=bool)
    t = np.asarray(truth, dtype=bool)
    if p.shape != t.shape:
        raise ValueError(f"mask shapes differ: {p.shape} vs {t.shape}")
    union = int(np.count_nonzero(p | t))
    if union == 0:
        return 1.0
    return int(np.count_nonzero(p & t)) / union
