"""Connected regions of segmentation masks: labelling, per-column extents, clean-up.

Part of :mod:`perception.segmentation` (which re-exports these names). Masks are
(rows, beams) 0/1 uint8 arrays, at full resolution or on a detection grid whose row
``i`` stands for the full-resolution rows ``[d i, d i + d)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray

#: More outer contours than this (a speckled mask) switch to a labelling pass.
MAX_CONTOURS = 200

#: Per column of a region's box: first row, last row, whether the region is there.
Extents = tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.bool_]]

#: Per label and column: first and last full-resolution row (-1 where absent).
ColumnRows = tuple[NDArray[np.int64], NDArray[np.int64]]


@dataclass(frozen=True)
class Region:
    """One connected highlight or shadow component.

    Rows are range samples of the full image, columns beams; ``*_stop`` is exclusive.
    On a detection grid of step ``d`` the rows are those of the grid rows' cells
    (multiples of ``d``), and the area counts ``d`` pixels per grid pixel.
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


def clean_mask(mask: NDArray[np.uint8], *, open_size: int, close_size: int) -> NDArray[np.uint8]:
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

    Components come from their outer contours (OpenCV's border following); each is
    filled, so holes inside a shadow belong to it. Used at full resolution (the
    classical method).

    Returns
    -------
    labels : ndarray, shape of ``mask``, int32
        0 = none, 1.. = kept regions.
    regions : tuple of Region
    """
    contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    if len(contours) > MAX_CONTOURS:
        labels_by_pass, regions_by_pass, _ = grid_components(mask, kind=kind, min_area_px=min_area_px)
        return labels_by_pass, regions_by_pass
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


def grid_components(
    mask: NDArray[np.uint8],
    *,
    kind: str,
    min_area_px: int,
    row_step: int = 1,
    n_rows: int | None = None,
    second: tuple[str, int, int] | None = None,
) -> tuple[NDArray[np.int32], tuple[Region, ...], ColumnRows]:
    """Connected components (8-connected) of a 0/1 uint8 mask: one labelling pass.

    Holes are not filled. With ``row_step`` d > 1 the mask is a detection grid (row i
    stands for the full rows ``[d i, d i + d)``): the regions' rows, areas and centroids
    are given in full-resolution rows (``n_rows`` caps them), and ``min_area_px`` counts
    full-resolution pixels. The statistics and each label's first and last row per
    column come from the labelled pixels in one vectorised pass. ``second`` = (kind,
    first column, min_area_px): the mask holds a second mask side by side from that column
    on (a blank column before it); its regions are of that kind, their columns counted
    from there.

    Returns
    -------
    labels : ndarray, shape of ``mask``, int32
        0 = none, 1.. = components; dropped (small) ones keep their label but have no
        Region.
    regions : tuple of Region
    rows : tuple of two ndarray, shape (n_labels, n_cols), int64
        First and last full-resolution row of each label per column (-1: absent).
    """
    d = row_step
    full_rows = mask.shape[0] * d if n_rows is None else n_rows
    n_cols = mask.shape[1]
    labels = np.zeros(mask.shape, dtype=np.int32)
    occupied = np.flatnonzero(mask.any(axis=1))
    if occupied.size == 0:
        none = np.full((1, n_cols), -1, dtype=np.int64)
        return labels, (), (none, none.copy())
    r0, r1 = int(occupied[0]), int(occupied[-1]) + 1
    n, sub = cv2.connectedComponents(mask[r0:r1], connectivity=8, ltype=cv2.CV_32S)
    labels[r0:r1] = sub
    points = cv2.findNonZero(mask[r0:r1]).reshape(-1, 2)
    cols = points[:, 0].astype(np.int64)
    rows = points[:, 1].astype(np.int64)
    label = sub[rows, cols]
    rows += r0
    key = label * n_cols + cols
    first = np.full(n * n_cols, np.iinfo(np.int64).max, dtype=np.int64)
    last = np.full(n * n_cols, -1, dtype=np.int64)
    np.minimum.at(first, key, rows)
    np.maximum.at(last, key, rows)
    first, last = first.reshape(n, n_cols), last.reshape(n, n_cols)
    area = np.bincount(label, minlength=n)
    keep = np.flatnonzero(area[1:] * d >= min(min_area_px, min_area_px if second is None else second[2])) + 1
    present = last[keep] >= 0
    col_start = np.argmax(present, axis=1)
    col_stop = n_cols - np.argmax(present[:, ::-1], axis=1)
    row_start = np.where(present, first[keep], np.iinfo(np.int64).max).min(axis=1)
    row_stop = last[keep].max(axis=1) + 1
    weight = np.maximum(area[keep], 1)
    centroid_row = np.bincount(label, weights=rows, minlength=n)[keep] / weight
    centroid_col = np.bincount(label, weights=cols, minlength=n)[keep] / weight
    kinds = [(kind, 0, min_area_px)]
    split = n_cols + 1
    if second is not None:
        kinds.append(second)
        split = second[1]
    regions = []
    for lab, r_a, r_b, c_a, c_b, a, cy, cx in zip(
        keep.tolist(), row_start.tolist(), row_stop.tolist(), col_start.tolist(),
        col_stop.tolist(), area[keep].tolist(), centroid_row.tolist(), centroid_col.tolist(),
        strict=True,
    ):
        this_kind, offset, least = kinds[c_a >= split]
        if a * d < least:
            continue
        regions.append(
            Region(
                label=lab,
                kind=this_kind,
                row_start=r_a * d,
                row_stop=min(full_rows, r_b * d),
                col_start=c_a - offset,
                col_stop=c_b - offset,
                area_px=a * d,
                centroid_row=cy * d + (d - 1) / 2.0,
                centroid_col=cx - offset,
            )
        )
    absent = last < 0
    first_full = np.where(absent, -1, first * d)
    last_full = np.where(absent, -1, np.minimum(last * d + (d - 1), full_rows - 1))
    return labels, tuple(regions), (first_full, last_full)


def with_core(
    regions: tuple[Region, ...],
    labels: NDArray[np.int32],
    core: NDArray[np.bool_],
    *,
    min_core_px: int,
    row_step: int,
) -> tuple[Region, ...]:
    """The regions with at least ``min_core_px`` pixels in ``core``.

    Parameters
    ----------
    regions : tuple of Region
        Regions labelled in ``labels``.
    labels : ndarray, shape (n_grid_rows, n_beams), int32
        Their labels on the detection grid.
    core : ndarray, shape of ``labels``, bool
        Grid pixels far enough from their row's seabed level (the region's core).
    min_core_px : int
        Fewest full-resolution pixels (``row_step`` per grid pixel) in the core; 0 keeps all.
    """
    if min_core_px <= 0 or not regions:
        return regions
    count = np.bincount(labels[core], minlength=max(r.label for r in regions) + 1) * row_step
    return tuple(r for r in regions if count[r.label] >= min_core_px)


def label_rows(labels: NDArray[np.int32]) -> ColumnRows:
    """First and last row of each label in each column (-1: absent), shape (n_labels, n_cols)."""
    n_cols = labels.shape[1]
    n = int(labels.max()) + 1
    flat = labels.ravel()
    pixels = np.flatnonzero(flat)
    rows, cols = np.divmod(pixels, n_cols)
    key = flat[pixels] * n_cols + cols
    first = np.full(n * n_cols, np.iinfo(np.int64).max, dtype=np.int64)
    last = np.full(n * n_cols, -1, dtype=np.int64)
    np.minimum.at(first, key, rows)
    np.maximum.at(last, key, rows)
    last = last.reshape(n, n_cols)
    return np.where(last < 0, -1, first.reshape(n, n_cols)), last
