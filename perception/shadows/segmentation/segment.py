"""Highlight and cast-shadow segmentation of polar sonar images.

Two methods, selectable in :class:`SegmentationConfig`:

``"speckle"`` (default)
    In levels proportional to dB (:func:`as_levels`: the uint8 display image of an ARIS,
    or the log of a linear image, whatever its gain, TVG or power law), on a *detection
    grid* whose rows are the mean levels of blocks of range samples a fixed distance long
    (``grid_step_m``, so frames of any sample spacing are searched alike) and a few beams
    wide. Each grid row has a seabed level (upper quartile over beams); the frame's
    *spread* ``sigma`` is the robust standard deviation of the grid's seabed pixels about
    their row's level, and every threshold is a multiple of it, so speckle statistics
    (looks, K-distributed tails), gain and dtype move the thresholds with the levels:

    - the *band* (rows with insonified seabed) is the longest run of rows standing
      ``band_sigmas`` spreads above the darkest rows (the noise floor); its edges are
      followed per beam (they are curved in a polar image) by a robust parabola;
    - a grid pixel inside the band is *shadow* ``shadow_sigmas`` below its row's level,
      *highlight* ``highlight_sigmas`` above it;
    - a region is kept with a *core*: a cast shadow reaches the noise floor, far below the
      seabed, a target's echo stands far above it, while the dark and bright patches of a
      textured seabed only just pass the first test: ``min_shadow_core_m`` of its range
      (summed over its beams) must lie ``shadow_core_sigmas`` below (highlights likewise);
    - regions are connected components of the grid (one OpenCV pass for both masks).

    Region rows and :meth:`Segmentation.column_extents` are full-resolution rows of the
    grid cells (to a grid step); :mod:`perception.shadows.measurement` finds the edges at
    full resolution in the beams it measures.
``"classical"``
    The paper's baseline: OpenCV's adaptive mean threshold on the 8-bit image (dark below
    the local mean minus ``classical_offset`` is shadow, bright above it plus the offset
    highlight), without normalisation or band awareness, at full resolution, components
    with their holes filled. Kept as the named baseline of the benchmark.

Images are (n_samples, n_beams) = (range rows, beam columns), see
:mod:`perception.sonar_io.frame`. Functions take the image first, options keyword-only, and
never modify their input. Accepted dtypes: uint8, uint16, float32 (float64 is accepted
and converted). uint8 is taken as ARIS-style display levels (``uint8_db_range`` dB over
0-255); uint16 and float as linear echo (power or amplitude: only the scale of the dB
differs, which the spread-relative thresholds absorb).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from perception import imaging
from perception.shadows.segmentation.band import band_edges, longest_run, shadow_in_edges
from perception.shadows.segmentation.classical import classical_regions
from perception.shadows.segmentation.config import METHODS, SegmentationConfig
from perception.shadows.segmentation.grid import (
    ColumnRows,
    Extents,
    LabelledMask,
    Region,
    label_mask,
    label_rows,
    labelled_regions,
)
from perception.shadows.segmentation.levels import (
    Levels,
    as_levels,
    block_levels,
    level_spread,
    row_background,
    row_spread,
    running_min_max,
)
from perception.shadows.segmentation.result import LABEL_HIGHLIGHT, LABEL_OTHER, LABEL_SHADOW, Segmentation

__all__ = [
    "LABEL_HIGHLIGHT",
    "LABEL_OTHER",
    "LABEL_SHADOW",
    "METHODS",
    "ColumnRows",
    "Extents",
    "Levels",
    "Region",
    "Segmentation",
    "SegmentationConfig",
    "as_levels",
    "mask_iou",
    "sample_spacing_m",
    "segment",
]

#: Range of the running median that caps a row's seabed level where bright targets raise it, m.
BACKGROUND_MEDIAN_M = 0.25
#: Beams whose band edge lies this far (m of range) from the fitted curve count as moved by a shadow.
BAND_EDGE_TOLERANCE_M = 0.015
#: Rows hold seabed this fraction of the way or more from the noise floor to the seabed's
#: brightest rows (95th percentile of the row levels).
BAND_FRACTION = 0.2
#: Below this many spreads between the darkest rows and the brightest, the window holds no
#: noise floor: the seabed fills it.
BAND_CONTRAST_SIGMAS = 6.0
#: A row's own spread replaces the frame's where it is this many times wider.
WIDE_SPREAD = 1.5
#: Percentile of the row levels taken as the noise floor.
NOISE_PERCENTILE = 2.0
#: Least spread (dB) of a frame: an image without speckle (smooth, or quantised to few levels) would
#: otherwise have every small systematic change of level taken for a shadow or a highlight.
MIN_SIGMA_DB = 0.5


def sorted_percentile(ordered: NDArray[np.float32], q: float) -> float:
    """``np.percentile(values, q)`` (linear interpolation) of values already sorted (at least one)."""
    pos = q / 100.0 * (ordered.size - 1)
    k = int(pos)
    if k + 1 >= ordered.size:
        return float(ordered[-1])
    lo, hi = float(ordered[k]), float(ordered[k + 1])
    return lo + (pos - k) * (hi - lo)


def sample_spacing_m(range_m: NDArray[np.float64] | None, n_samples: int) -> float:
    """Mean spacing of ``range_m`` (m), or 1 mm when no range axis is given."""
    if range_m is None:
        return 1e-3
    r = np.asarray(range_m, dtype=np.float64)
    if r.ndim != 1 or r.size != n_samples:
        raise ValueError(f"range_m must have shape ({n_samples},), got {r.shape}")
    if n_samples < 2:
        return 1e-3
    return float(r[-1] - r[0]) / (n_samples - 1)


def segment(
    image: NDArray[np.generic],
    *,
    range_m: NDArray[np.float64] | None = None,
    config: SegmentationConfig | None = None,
) -> Segmentation:
    """Segment highlights and cast shadows in one polar sonar image.

    Parameters
    ----------
    image : ndarray, shape (n_samples, n_beams), uint8, uint16, float32 or float64
        Echo intensity; rows are range samples (nearest first), columns beams.
    range_m : ndarray, shape (n_samples,), optional
        Slant range of each row, m; sets the physical scales (default: 1 mm samples).
    config : SegmentationConfig, optional
        Settings; the default is the speckle-aware method.

    Returns
    -------
    Segmentation
    """
    cfg = config or SegmentationConfig()
    levels, db_per_level = as_levels(image, uint8_db_range=cfg.uint8_db_range)
    n_rows, n_cols = levels.shape
    sample_m = sample_spacing_m(range_m, n_rows)
    if cfg.method == "classical":
        return _classical(levels, db_per_level, sample_m, cfg)
    d = cfg.row_step(n_rows, sample_m)
    grid = block_levels(levels, d, beams=cfg.smooth_beams)
    n_grid = grid.shape[0]
    cell_m = d * sample_m
    block = max(1, int(round(cfg.background_block_m / cell_m)))
    median_blocks = max(1, int(round(BACKGROUND_MEDIAN_M / (block * cell_m)))) | 1
    non_negative = levels.dtype == np.uint8
    background = row_background(grid, block_rows=block, median_blocks=median_blocks, non_negative=non_negative)
    # The noise floor: the darkest rows, blanked ones (all at the floor of the levels) aside.
    ordered = background.copy()
    ordered.sort()
    lowest = float(ordered[0])
    unblanked = ordered[int(ordered.searchsorted(lowest + 1e-3, side="right")):]
    noise = sorted_percentile(unblanked if unblanked.size >= 4 else ordered, NOISE_PERCENTILE)
    top = sorted_percentile(ordered, 95.0)
    # The spread, first over the rows half-way or more from the noise floor to the brightest
    # (surely seabed when there is any), then over the band it finds.
    upper = background >= 0.5 * (noise + top)
    sigma0 = max(level_spread(grid, background, upper), MIN_SIGMA_DB / db_per_level)
    lit_level = noise + cfg.band_sigmas * sigma0
    band = longest_run(background >= lit_level)
    if not band.any() or top - noise < BAND_CONTRAST_SIGMAS * sigma0:
        band = np.ones_like(band)
    sigma = max(level_spread(grid, background, band), MIN_SIGMA_DB / db_per_level) if band.any() else sigma0
    # A row holds seabed where its level stands clear of the noise floor: by band_sigmas
    # spreads, and by a fifth of the way from the floor to the seabed's brightest rows
    # (noise of one look spreads wider than a many-look seabed's speckle).
    if top - noise < BAND_CONTRAST_SIGMAS * sigma:
        # No row stands clear of the darkest: the seabed fills the whole window (its
        # dimmest rows are no noise floor).
        lit_level = float(background.min())
    else:
        lit_level = noise + max(cfg.band_sigmas * sigma, BAND_FRACTION * (top - noise))
    band = longest_run(background >= lit_level)
    # Thresholds per row: the frame's spread, or the row's own where it is clearly wider
    # (one-look noise where the seabed has many looks; a target's shadow and highlight in a
    # row widen the row's own spread by less than that).
    own = row_spread(grid, background, block_rows=block)
    spread = np.where(own > np.float32(WIDE_SPREAD * sigma), own, np.float32(sigma)).astype(np.float32, copy=False)
    tolerance = max(1.0, BAND_EDGE_TOLERANCE_M / cell_m)
    edges = band_edges(grid, band, level=lit_level, stride=1, tolerance_rows=tolerance)
    # Near the band's edges a block straddles both sides: shadows are tested against the
    # lowest nearby level, highlights against the highest.
    low, high = running_min_max(background, size=2 * block + 1)
    shadow_offset = cfg.shadow_sigmas * sigma
    highlight_offset = cfg.highlight_sigmas * sigma
    shadow_limit = low - np.float32(cfg.shadow_sigmas) * spread
    highlight_limit = np.maximum(high, np.float32(lit_level)) + np.float32(cfg.highlight_sigmas) * spread
    # Both masks side by side (a blank column between): one labelling pass.
    both = np.zeros((n_grid, 2 * n_cols + 1), dtype=np.uint8)
    # The grid cell at each beam's band edge straddles the edge (half dark): not shadow.
    inner = edges + np.array([[1], [-1]])
    shadow_in_edges(grid, shadow_limit, inner, out=both[:, :n_cols].view(bool))
    # Along each beam a shadow runs on through pixels only weakly darker than the seabed
    # (hysteresis): a bright target's side-lobe streak across another's shadow, at the
    # ranges of its echo, would cut the shadow in two.
    weak = np.empty((n_grid, n_cols), dtype=bool)  # (every row written)
    shadow_in_edges(grid, background - np.float32(cfg.shadow_weak_sigmas) * spread, inner, out=weak)
    grown = _hysteresis_block(both[:, :n_cols].view(bool), weak)
    if grown is not None:  # (elsewhere the strong mask is the result: no strong row there)
        r0, r1, cols, grown_rows = grown
        both[r0:r1, cols] = grown_rows
    # Highlights inside the band: its rows are one run (longest_run's), the others stay 0.
    band_at = band.nonzero()[0]
    if band_at.size:
        b0, b1 = int(band_at[0]), int(band_at[-1]) + 1
        np.greater(grid[b0:b1], highlight_limit[b0:b1, None], out=both[b0:b1, n_cols + 1 :].view(bool))
    labelled = label_mask(both.view(bool))
    shadow_core = low - np.float32(cfg.shadow_core_sigmas) * spread
    highlight_core = highlight_limit + np.float32(cfg.highlight_core_sigmas - cfg.highlight_sigmas) * spread
    core_px = _core_pixels(labelled, grid, shadow_core, highlight_core) * d
    min_core = (int(math.ceil(cfg.min_shadow_core_m / sample_m)), int(math.ceil(cfg.min_highlight_core_m / sample_m)))
    regions, (first, last) = labelled_regions(
        labelled, kind="shadow", min_area_px=1, row_step=d, n_rows=n_rows,
        second=("highlight", n_cols + 1, 1), core_px=core_px, min_core_px=min_core,
    )
    min_shadow_rows = cfg.min_shadow_length_m / sample_m
    min_highlight_rows = cfg.min_highlight_length_m / sample_m
    shadows = tuple(r for r in regions if r.kind == "shadow" and r.row_stop - r.row_start >= min_shadow_rows
                    and r.n_cols >= cfg.min_shadow_beams)
    highlights = tuple(r for r in regions if r.kind == "highlight" and r.row_stop - r.row_start >= min_highlight_rows)
    labels = labelled.labels
    band_rows = np.minimum(edges * d + np.array([[0], [d - 1]]), n_rows - 1)
    return Segmentation(
        levels=levels,
        db_per_level=db_per_level,
        sample_m=sample_m,
        row_step=d,
        grid=grid,
        grid_background=background,
        sigma=float(sigma),
        noise_level=noise,
        shadow_offset=float(shadow_offset),
        highlight_offset=float(highlight_offset),
        grid_highlight_labels=labels[:, n_cols + 1 :],
        grid_shadow_labels=labels[:, :n_cols],
        highlight_rows=(first[:, n_cols + 1 :], last[:, n_cols + 1 :]),
        shadow_rows=(first[:, :n_cols], last[:, :n_cols]),
        highlights=highlights,
        shadows=shadows,
        band_grid_rows=band,
        band_start_rows=band_rows[0],
        band_stop_rows=band_rows[1],
        method=cfg.method,
    )


def _classical(levels: Levels, db_per_level: float, sample_m: float, cfg: SegmentationConfig) -> Segmentation:
    """The paper's adaptive threshold (:mod:`perception.shadows.segmentation.classical`) at full resolution."""
    n_rows, n_cols = levels.shape
    shadow_labels, shadows, highlight_labels, highlights = classical_regions(levels, cfg)
    grid = np.asarray(levels, dtype=np.float32)
    background = np.median(grid, axis=1).astype(np.float32)
    # The spread of the full-resolution levels: the measurement's contrast tests use it.
    sigma = max(level_spread(grid, background, np.ones(n_rows, dtype=bool)), MIN_SIGMA_DB / db_per_level)
    return Segmentation(
        levels=levels,
        db_per_level=db_per_level,
        sample_m=sample_m,
        row_step=1,
        grid=grid,
        grid_background=background,
        sigma=float(sigma),
        noise_level=math.nan,
        shadow_offset=math.nan,
        highlight_offset=math.nan,
        grid_highlight_labels=highlight_labels,
        grid_shadow_labels=shadow_labels,
        highlight_rows=label_rows(highlight_labels),
        shadow_rows=label_rows(shadow_labels),
        highlights=highlights,
        shadows=shadows,
        band_grid_rows=np.ones(n_rows, dtype=bool),
        band_start_rows=np.zeros(n_cols, dtype=np.intp),
        band_stop_rows=np.full(n_cols, n_rows - 1, dtype=np.intp),
        method=cfg.method,
    )


def hysteresis_along_beams(strong: NDArray[np.bool_], weak: NDArray[np.bool_]) -> NDArray[np.bool_]:
    """Per beam (column), every run of ``weak`` rows that holds a ``strong`` row (``strong``
    is added to ``weak``), shape of the masks.

    Only the rows from the first to the last of the masks are worked on
    (:func:`_hysteresis_block`).
    """
    out = np.zeros(strong.shape, dtype=bool)
    grown = _hysteresis_block(strong, weak)
    if grown is not None:
        r0, r1, cols, block = grown
        out[r0:r1, cols] = block
    return out


def _hysteresis_block(
    strong: NDArray[np.bool_], weak: NDArray[np.bool_]
) -> tuple[int, int, slice, NDArray[np.bool_]] | None:
    """:func:`hysteresis_along_beams` where it can differ from ``strong``: rows ``r0:r1``
    (every beam: ``cols`` is ``slice(0, n_beams)``) and the result there; None when no beam has a
    ``strong`` row (the result is then ``strong``, all False). Outside those rows the mask,
    and so ``strong``, is all False. Segmentation writes the block into its mask in place.

    Every beam is worked on, not only those with a ``strong`` row: a beam without one keeps
    none of its runs (False, as ``strong`` there), and the column gathers and the scatter
    of the result cost more than the extra columns."""
    if not strong.any():
        return None
    mask = weak | strong
    occupied = np.logical_or.reduce(mask, axis=1).nonzero()[0]
    r0, r1 = int(occupied[0]), int(occupied[-1]) + 1
    mask = mask[r0:r1]
    n_rows, n_cols = mask.shape
    starts = np.empty(mask.shape, dtype=bool)  # a run's first row: set, the row before not
    starts[0] = mask[0]
    np.greater(mask[1:], mask[:-1], out=starts[1:])
    # 1.. per run within a column (0 before its first; after a run, that run's id until the
    # next: those rows are outside the mask, which the result is cut to).
    # (Summed along the rows of the transpose, a view of it returned: integers, exact in any
    # order, and several times faster than numpy's cumulative sum down the columns.)
    run_id = imaging.transpose(starts.view(np.uint8)).astype(np.int32)
    np.add.accumulate(run_id, axis=1, out=run_id)
    run_id = run_id.T
    run_id += (np.arange(n_cols, dtype=np.int32) * (n_rows + 1))[None, :]
    has = np.zeros(n_cols * (n_rows + 1), dtype=bool)
    has[run_id[strong[r0:r1]]] = True
    has[::n_rows + 1] = False  # id 0 of each column: before any run
    return r0, r1, slice(0, n_cols), np.logical_and(has.take(run_id), mask)


def _core_pixels(
    labelled: LabelledMask,
    grid: NDArray[np.float32],
    shadow_core: NDArray[np.float32],
    highlight_core: NDArray[np.float32],
) -> NDArray[np.int64]:
    """Per label of the side-by-side masks, its grid pixels in the core, shape (n_labels,).

    Shadow pixels (left of the blank column) below their row's ``shadow_core``, highlight
    pixels (right of it) above ``highlight_core``.
    """
    n_cols = grid.shape[1]
    rows, cols = labelled.rows, labelled.cols
    if rows.size == 0:
        return np.zeros(labelled.n_labels, dtype=np.int64)
    # Tested at the labelled pixels only (a few percent of the grid): each one's grid value
    # (a highlight pixel's column counted from the second mask's first) against its row's level.
    highlight = cols > n_cols
    values = grid.ravel().take(rows * n_cols + cols - highlight * (n_cols + 1))
    core = np.where(highlight, values > highlight_core.take(rows), values < shadow_core.take(rows))
    return np.bincount(labelled.pixel_labels[core], minlength=labelled.n_labels)


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
