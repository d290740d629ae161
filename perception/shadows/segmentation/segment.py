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
    beam meets the seabed, beyond its far edge and beyond the range window. A region
    is kept only with a *core*: a shadow must hold pixels ``shadow_core_db`` below the
    seabed (a cast shadow holds only the noise floor, tens of dB down) and a highlight
    pixels ``highlight_core_db`` above it (a target's echo), so the dark and bright
    patches of a textured seabed, a few dB from its mean, are neither. Optional
    opening and closing clean the masks.

    Regions are found on a *detection grid*: every ``d``-th row of the smoothed image,
    ``d = max(1, n_samples // detection_rows)`` (a 2000-sample frame is searched on 250
    rows). Shadows and highlights of targets span many samples, so nothing is lost, and
    the labelling is one OpenCV pass over an eighth of the pixels. Region boxes and
    :meth:`Segmentation.column_extents` are in full-resolution rows (to ``d`` rows);
    :mod:`perception.shadows.measurement.measure` refines the edges it needs at full resolution, only in the
    beams of paired targets, and the full-resolution label images are built on demand.
``"classical"``
    The paper's baseline: OpenCV's adaptive mean threshold on the raw image (dark
    below the local mean minus ``classical_offset`` is shadow, bright above the local
    mean plus it is highlight), without normalisation or band awareness, at full
    resolution, components with their holes filled. Kept so that the improvement can be
    shown side by side.

The pieces live in :mod:`perception.shadows.segmentation.levels` (dB levels, smoothing, row
seabed levels), :mod:`perception.shadows.segmentation.band` (the insonified band) and
:mod:`perception.shadows.segmentation.grid` (regions and their extents); this module re-exports
their public names.

Images are (n_samples, n_beams) = (range rows, beam columns), see
:mod:`perception.sonar_io.frame`. Functions take the image first, options keyword-only, and
never modify their input. Accepted dtypes: uint8, uint16, float32 (float64 is
accepted and converted). uint8 images are taken as ARIS-style display levels,
``uint8_db_range`` dB over 0-255 (the ARIS SDK maps 0-80 dB to 0-255); uint16 and float
images as linear echo power (converted to dB here).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from perception.shadows.segmentation.band import (
    BAND_EDGE_STRIDE,
    BAND_EDGE_TOLERANCE_ROWS,
    band_edges,
    column_band,
    insonified_rows,
    longest_run,
    shadow_in_band,
    shadow_in_edges,
)
from perception.shadows.segmentation.classical import classical_regions
from perception.shadows.segmentation.config import METHODS, SegmentationConfig
from perception.shadows.segmentation.grid import (
    MAX_CONTOURS,
    ColumnRows,
    Extents,
    LabelledMask,
    Region,
    clean_mask,
    components,
    grid_components,
    label_mask,
    label_rows,
    labelled_regions,
    with_core,
)
from perception.shadows.segmentation.levels import (
    BACKGROUND_MEDIAN_BLOCKS,
    Levels,
    as_levels,
    box_smooth,
    grid_smooth,
    percentile90,
    row_background,
    row_background_of,
    running_min_max,
)
from perception.shadows.segmentation.result import LABEL_HIGHLIGHT, LABEL_OTHER, LABEL_SHADOW, Segmentation

__all__ = [
    "BACKGROUND_MEDIAN_BLOCKS",
    "BAND_EDGE_STRIDE",
    "BAND_EDGE_TOLERANCE_ROWS",
    "LABEL_HIGHLIGHT",
    "LABEL_OTHER",
    "LABEL_SHADOW",
    "MAX_CONTOURS",
    "METHODS",
    "ColumnRows",
    "Extents",
    "Levels",
    "Region",
    "Segmentation",
    "SegmentationConfig",
    "as_levels",
    "box_smooth",
    "column_band",
    "components",
    "grid_components",
    "grid_smooth",
    "insonified_rows",
    "label_mask",
    "labelled_regions",
    "longest_run",
    "mask_iou",
    "row_background",
    "running_min_max",
    "segment",
    "shadow_in_band",
    "with_core",
]


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
        Components (on the detection grid, boxes in full-resolution rows), smoothed
        levels, per-row thresholds and the insonified band.
    """
    cfg = config or SegmentationConfig()
    levels, db_per_level = as_levels(image, uint8_db_range=cfg.uint8_db_range)
    n_rows, n_cols = levels.shape
    # The band and the row levels come from every d-th row, whatever the method; the
    # speckle method also finds its regions there (the detection grid).
    d = max(1, n_rows // cfg.detection_rows) if cfg.detection_rows else 1
    centres = np.arange(d // 2, n_rows + d // 2, d)
    if centres.size and centres[-1] >= n_rows:
        # (Only when the last block is short.)
        centres = np.minimum(centres, n_rows - 1)
    grid = grid_smooth(levels, centres, samples=cfg.smooth_samples, beams=cfg.smooth_beams)
    block = max(1, cfg.background_block_samples // d)
    background = row_background_of(grid, block_samples=block, non_negative=levels.dtype == np.uint8)
    drop = cfg.band_drop_db / db_per_level
    seabed_floor = percentile90(background) - drop
    # insonified_rows(background, drop=drop) without taking the percentile again.
    band = longest_run(background >= seabed_floor)
    # Row 0: each beam's first band row (of the grid), row 1: its last (column_band as one array).
    edges = band_edges(
        grid, band, level=seabed_floor, stride=max(1, BAND_EDGE_STRIDE // d),
        tolerance_rows=BAND_EDGE_TOLERANCE_ROWS / d,
    )
    if cfg.method == "speckle":
        # Where the row level changes fast (the band's edges) a block straddles both
        # sides: shadows are tested against the lowest nearby level, highlights against
        # the highest, so neither edge of the band turns into shadow or highlight.
        low, high = running_min_max(background, size=2 * block + 1)
        shadow_limit = low - np.float32(cfg.shadow_db / db_per_level)
        highlight_limit = np.maximum(high, np.float32(seabed_floor)) + np.float32(
            cfg.highlight_db / db_per_level
        )
        # Both masks side by side (a blank column between): one labelling pass. Each mask
        # is written whole below.
        both = np.empty((grid.shape[0], 2 * n_cols + 1), dtype=np.uint8)
        both[:, n_cols] = 0
        shadow_in_edges(grid, shadow_limit, edges, out=both[:, :n_cols].view(bool))
        np.greater(grid, highlight_limit[:, None], out=both[:, n_cols + 1 :].view(bool))
        if cfg.open_size > 1 or cfg.close_size > 1:
            for part in (both[:, :n_cols], both[:, n_cols + 1 :]):
                part[...] = clean_mask(np.ascontiguousarray(part), open_size=cfg.open_size, close_size=cfg.close_size)
        labelled = label_mask(both.view(bool))
        # A shadow holds only the noise floor, a target's echo stands well above the
        # seabed: dark and bright patches of a textured seabed have neither core.
        shadow_core = low - np.float32(cfg.shadow_core_db / db_per_level)
        highlight_core = highlight_limit + np.float32((cfg.highlight_core_db - cfg.highlight_db) / db_per_level)
        core_px = _core_pixels(labelled, grid, shadow_core, highlight_core) * d
        regions, (first, last) = labelled_regions(
            labelled, kind="shadow", min_area_px=cfg.min_shadow_area_px, row_step=d, n_rows=n_rows,
            second=("highlight", n_cols + 1, cfg.min_highlight_area_px),
            core_px=core_px, min_core_px=(cfg.min_shadow_core_px, cfg.min_highlight_core_px),
        )
        labels = labelled.labels
        shadow_labels, highlight_labels = labels[:, :n_cols], labels[:, n_cols + 1 :]
        # (List comprehensions: cheaper than generators into tuple.)
        shadows = tuple([r for r in regions if r.kind == "shadow"])
        highlights = tuple([r for r in regions if r.kind == "highlight"])
        shadow_rows = (first[:, :n_cols], last[:, :n_cols])
        highlight_rows = (first[:, n_cols + 1 :], last[:, n_cols + 1 :])
        step = d
    else:
        shadow_labels, shadows, highlight_labels, highlights = classical_regions(levels, cfg)
        shadow_rows = label_rows(shadow_labels)
        highlight_rows = label_rows(highlight_labels)
        shadow_limit = np.full(centres.size, np.nan, dtype=np.float32)
        highlight_limit = shadow_limit
        step = 1
    band_rows = centres.take(edges)
    return _new_segmentation(
        grid_highlight_labels=highlight_labels,
        grid_shadow_labels=shadow_labels,
        row_step=step,
        highlight_rows=highlight_rows,
        shadow_rows=shadow_rows,
        highlights=highlights,
        shadows=shadows,
        levels=levels,
        db_per_level=db_per_level,
        smooth_samples=cfg.smooth_samples,
        smooth_beams=cfg.smooth_beams,
        level_rows=centres,
        grid_background=background,
        grid_shadow_limit=shadow_limit,
        grid_highlight_limit=highlight_limit,
        seabed_floor=seabed_floor,
        insonified_rows=np.repeat(band, d)[:n_rows],
        band_start_rows=band_rows[0],
        band_stop_rows=band_rows[1],
        method=cfg.method,
    )


def _new_segmentation(**fields: object) -> Segmentation:
    """``Segmentation(**fields)`` (every field by name) without the frozen ``__init__``'s per-field setattr.

    Filling the new instance's ``__dict__`` gives the same object (same attributes; the
    cached properties live in that ``__dict__`` too), in a fraction of the time.
    """
    result = object.__new__(Segmentation)
    result.__dict__.update(fields)
    return result


def _core_pixels(
    labelled: LabelledMask,
    grid: NDArray[np.float32],
    shadow_core: NDArray[np.float32],
    highlight_core: NDArray[np.float32],
) -> NDArray[np.int64]:
    """Per label of the side-by-side masks, its grid pixels in the core, shape (n_labels,).

    Shadow pixels (left of the blank column) below their row's ``shadow_core``, highlight
    pixels (right of it) above ``highlight_core``: the counts :func:`with_core` takes from
    whole-grid core masks, read at the labelled pixels only.
    """
    n_rows, n_cols = grid.shape
    pixels = labelled.pixels
    if pixels is None or pixels.size == 0:
        return np.zeros(labelled.n_labels, dtype=np.int64)
    # Both core masks side by side like the labelled masks, over the rows holding labelled
    # pixels (the only ones read): each labelled pixel's flat index reads its own test.
    # The blank column is never read.
    lo, hi = int(labelled.rows[0]), int(labelled.rows[-1]) + 1
    core = np.empty((n_rows, 2 * n_cols + 1), dtype=bool)
    np.less(grid[lo:hi], shadow_core[lo:hi, None], out=core[lo:hi, :n_cols])
    np.greater(grid[lo:hi], highlight_core[lo:hi, None], out=core[lo:hi, n_cols + 1 :])
    return np.bincount(labelled.pixel_labels[core.ravel().take(pixels)], minlength=labelled.n_labels)


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
