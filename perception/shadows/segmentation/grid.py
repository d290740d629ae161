"""Connected regions of segmentation masks: labelling, per-column extents, clean-up.

Part of :mod:`perception.shadows.segmentation.segment` (which re-exports these names). Masks are
(rows, beams) 0/1 uint8 arrays, at full resolution or on a detection grid whose row
``i`` stands for the full-resolution rows ``[d i, d i + d)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from perception import imaging
from perception.stored_init import check_init_takes_fields

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

    A frame builds tens of regions, so the class writes its own ``__init__``: it stores
    the fields in the instance's ``__dict__`` at once, which is what the generated frozen
    ``__init__`` does one ``object.__setattr__`` at a time, at about a quarter of the cost
    (same object: equal, same hash, repr and pickle). Its parameters are the fields, in
    order (checked when the module loads).
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

    def __init__(self, label: int, kind: str, row_start: int, row_stop: int, col_start: int, col_stop: int,
                 area_px: int, centroid_row: float, centroid_col: float) -> None:
        d = self.__dict__
        d["label"] = label
        d["kind"] = kind
        d["row_start"] = row_start
        d["row_stop"] = row_stop
        d["col_start"] = col_start
        d["col_stop"] = col_stop
        d["area_px"] = area_px
        d["centroid_row"] = centroid_row
        d["centroid_col"] = centroid_col

    @property
    def n_cols(self) -> int:
        """Number of beams the bounding box spans."""
        return self.col_stop - self.col_start


check_init_takes_fields(Region)


def clean_mask(mask: NDArray[np.uint8], *, open_size: int, close_size: int) -> NDArray[np.uint8]:
    if open_size > 1:
        mask = imaging.morph_open(mask, open_size)
    if close_size > 1:
        mask = imaging.morph_close(mask, close_size)
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
    contours = imaging.external_contours(mask)
    if len(contours) > MAX_CONTOURS:
        labels_by_pass, regions_by_pass, _ = grid_components(mask, kind=kind, min_area_px=min_area_px)
        return labels_by_pass, regions_by_pass
    labels = np.zeros(mask.shape, dtype=np.int32)
    regions: list[Region] = []
    for i, contour in enumerate(contours):
        x, y, w, h = imaging.bounding_box(contour)
        if w * h < min_area_px:
            continue
        new = len(regions) + 1
        imaging.draw_filled_contour(labels, contours, i, new)
        rows, cols = np.nonzero(labels[y : y + h, x : x + w] == new)
        if rows.size < min_area_px:
            imaging.draw_filled_contour(labels, contours, i, 0)
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


@dataclass(frozen=True)
class LabelledMask:
    """A mask's 8-connected components and its labelled pixels, in raster order.

    Attributes
    ----------
    labels : ndarray, shape of the mask, int32
        0 = none, 1.. = components (OpenCV's numbering).
    n_labels : int
        Number of labels, 0 included.
    rows, cols : ndarray, shape (n_pixels,), int64
        Row and column of each nonzero pixel of the mask (rows ascending, then columns).
    pixel_labels : ndarray, shape (n_pixels,), int32
        The label of each of those pixels.
    pixels : ndarray, shape (n_pixels,), int64, or None
        Their flat indices ``row * n_cols + col`` in the mask (None: not given).
    """

    labels: NDArray[np.int32]
    n_labels: int
    rows: NDArray[np.int64]
    cols: NDArray[np.int64]
    pixel_labels: NDArray[np.int32]
    pixels: NDArray[np.int64] | None = None


def label_mask(mask: NDArray[np.bool_]) -> LabelledMask:
    """Label the 8-connected components of a boolean mask (one OpenCV pass) and list its pixels.

    Only the rows from the first to the last occupied one are labelled (the same labels as
    labelling the whole mask).

    Parameters
    ----------
    mask : ndarray, shape (n_rows, n_cols), bool, C-contiguous
    """
    n_cols = mask.shape[1]
    # The nonzero of a bool array is many times faster than of uint8 (or OpenCV's findNonZero).
    pixels = mask.ravel().nonzero()[0]
    if pixels.size == 0:
        empty = np.zeros(0, dtype=np.int64)
        return LabelledMask(
            np.zeros(mask.shape, dtype=np.int32), 1, empty, empty.copy(), np.zeros(0, dtype=np.int32), pixels
        )
    r0, r1 = int(pixels[0]) // n_cols, int(pixels[-1]) // n_cols + 1
    # Labelled in place into the occupied rows of ``labels`` (every pixel there written);
    # the rows around them are none.
    labels = np.empty(mask.shape, dtype=np.int32)
    labels[:r0] = 0
    labels[r1:] = 0
    n = imaging.label_components(mask[r0:r1].view(np.uint8), labels[r0:r1])
    rows, cols = np.divmod(pixels, n_cols)
    return LabelledMask(labels, int(n), rows, cols, labels.ravel().take(pixels), pixels)


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
    labelled = label_mask(np.not_equal(mask, 0))
    regions, rows = labelled_regions(
        labelled, kind=kind, min_area_px=min_area_px, row_step=row_step, n_rows=n_rows, second=second
    )
    return labelled.labels, regions, rows


def labelled_regions(
    labelled: LabelledMask,
    *,
    kind: str,
    min_area_px: int,
    row_step: int = 1,
    n_rows: int | None = None,
    second: tuple[str, int, int] | None = None,
    core_px: NDArray[np.int64] | None = None,
    min_core_px: tuple[int, int] = (0, 0),
) -> tuple[tuple[Region, ...], ColumnRows]:
    """The regions and per-column rows of :func:`grid_components`, from a :func:`label_mask` result.

    The other parameters are those of :func:`grid_components`. With ``core_px``, shape
    (n_labels,) (per label, full-resolution pixels in the region's core), only the regions
    with at least ``min_core_px`` (first kind, second kind) of them are kept: the test of
    :func:`with_core`, made before the regions are built.

    Returns
    -------
    regions : tuple of Region
    rows : tuple of two ndarray, shape (n_labels, n_cols), int64
        First and last full-resolution row of each label per column (-1: absent).
    """
    d = row_step
    n_grid_rows, n_cols = labelled.labels.shape
    full_rows = n_grid_rows * d if n_rows is None else n_rows
    n = labelled.n_labels
    if labelled.rows.size == 0:
        none = np.full((1, n_cols), -1, dtype=np.int64)
        return (), (none, none.copy())
    rows, cols, label = labelled.rows, labelled.cols, labelled.pixel_labels
    key = label * n_cols + cols
    # Each pixel's grid cell in full-resolution rows: its first and last row (capped).
    top = rows * d
    bottom = top + (d - 1)
    if n_grid_rows * d > full_rows:
        np.minimum(bottom, full_rows - 1, out=bottom)
    # -1 where a label is absent from a column. The minimum starts from the maximum of the
    # same key (never smaller than its pixels' rows), so absent stays -1.
    last_full = np.empty(n * n_cols, dtype=np.int64)
    last_full.fill(-1)
    np.maximum.at(last_full, key, bottom)
    first_full = last_full.copy()
    np.minimum.at(first_full, key, top)
    first_full, last_full = first_full.reshape(n, n_cols), last_full.reshape(n, n_cols)
    area = np.bincount(label, minlength=n)
    # Labels 1.. have at least one pixel, label 0 none: area >= 1 and area * d >= the
    # smaller of the two minima.
    least_area = min(min_area_px, min_area_px if second is None else second[2])
    keep = (area >= max(1, -(-least_area // d))).nonzero()[0]
    # Per label (all of them: fewer calls than picking the kept ones first); the loop
    # below reads the kept ones from lists. (ufunc reductions and array methods skip
    # numpy's Python-level wrappers.)
    present = last_full >= 0
    # As unsigned, absent (-1) is the greatest value: the least is that of the present
    # columns (label 0, never kept, has none).
    row_start = np.minimum.reduce(first_full.view(np.uint64), axis=1)
    row_end = np.maximum.reduce(last_full, axis=1)
    col_start = present.argmax(axis=1)
    col_end_from_right = present[:, ::-1].argmax(axis=1)
    row_sum = np.bincount(label, weights=rows, minlength=n).tolist()
    col_sum = np.bincount(label, weights=cols, minlength=n).tolist()
    kinds = [(kind, 0, min_area_px, min_core_px[0])]
    split = n_cols + 1
    if second is not None:
        kinds.append((*second, min_core_px[1]))
        split = second[1]
    core = [0] * n if core_px is None else core_px.tolist()
    r_a, r_b, c_a, c_b, areas = (
        row_start.tolist(), row_end.tolist(), col_start.tolist(), col_end_from_right.tolist(), area.tolist()
    )
    regions = []
    for lab in keep.tolist():
        this_kind, offset, least, least_core = kinds[c_a[lab] >= split]
        a = areas[lab]
        if a * d < least or (least_core > 0 and core[lab] < least_core):
            continue
        regions.append(
            Region(  # by position: the keywords' dict would cost a third of the call
                lab,  # label
                this_kind,  # kind
                r_a[lab],  # row_start
                r_b[lab] + 1,  # row_stop
                c_a[lab] - offset,  # col_start
                n_cols - c_b[lab] - offset,  # col_stop
                a * d,  # area_px
                # The same float64 divisions as numpy's (sums of integers are exact).
                row_sum[lab] / a * d + (d - 1) / 2.0,  # centroid_row
                col_sum[lab] / a - offset,  # centroid_col
            )
        )
    return tuple(regions), (first_full, last_full)


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
