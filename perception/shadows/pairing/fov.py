"""Which edges of the field of view a highlight-shadow pair touches (:class:`perception.shadows.pairing.pair.Pair`).

The fan's edges (first and last beam), the range window's (first and last row) and the
insonified band's (its near and far edge, per beam). Split from :mod:`perception.shadows.pairing.pair`,
which re-exports :func:`fov_flags` and :func:`column_extents`.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence

import numpy as np

from perception.shadows.segmentation.segment import Extents, Region, Segmentation


def column_extents(segmentation: Segmentation, region: Region) -> Extents:
    """First and last row of ``region`` in each column of its box, and which columns hold it.

    See :meth:`perception.shadows.segmentation.segment.Segmentation.column_extents` (full-resolution rows,
    to the detection grid's row step).
    """
    return segmentation.column_extents(region)


def fov_flags(
    segmentation: Segmentation,
    *regions: Region,
    extents: dict[int, Extents] | None = None,
    columns: tuple[int, ...] | None = None,
) -> tuple[str, ...]:
    """Which edges of the field of view the regions touch (see :class:`Pair`).

    With ``columns`` (a pair's beams) only what concerns those beams counts: the fan's
    edge when they reach it, and the band's edges in them. The band's edges are checked
    per beam, for shadows: ``band_near`` when a shadow starts at the first insonified row
    of any beam, ``band_far`` when it reaches the last insonified row in most of the
    beams (a shadow cut by the far edge is cut across its width; the measurement checks
    each beam it uses). ``extents`` may hold the shadows' :func:`column_extents` by label.
    """
    n_rows, n_cols = segmentation.levels.shape
    d = segmentation.row_step
    lo_col = 0 if columns is None else min(columns)
    hi_col = n_cols - 1 if columns is None else max(columns)
    in_pair = None if columns is None else (list(columns), BandEdges(segmentation))
    flags: list[str] = []
    for region in regions:
        flags.extend(edge_flags(region, lo_col, hi_col, n_rows=n_rows, n_cols=n_cols))
        if region.kind != "shadow":
            continue
        if in_pair is not None:
            cols, band = in_pair
            first = segmentation.shadow_rows[0][region.label, cols].tolist()
            last = segmentation.shadow_rows[1][region.label, cols].tolist()
            flags.extend(band_flags(cols, first, last, band))
            continue
        known = None if extents is None else extents.get(region.label)
        first_a, last_a, present = known if known is not None else column_extents(segmentation, region)
        box = slice(region.col_start, region.col_stop)
        start = segmentation.band_start_rows[box]
        stop = segmentation.band_stop_rows[box]
        # On a grid of step d a region's rows are its cells' ([d i, d i + d - 1]); the
        # band's edge rows lie inside their cells.
        if np.any(present & (first_a <= start) & (start > 0)):
            flags.append("band_near")
        at_far = present & (last_a - (d - 1) >= stop - stop % d) & (stop < n_rows - 1)
        if 2 * np.count_nonzero(at_far) > np.count_nonzero(present):
            flags.append("band_far")
    return tuple(dict.fromkeys(flags))


def touches_edge(region: Region, n_rows: int, n_cols: int) -> bool:
    """Whether ``region`` reaches the edge of the image (else :func:`edge_flags` has none)."""
    return region.col_start == 0 or region.col_stop == n_cols or region.row_start == 0 or region.row_stop == n_rows


def edge_flags(region: Region, lo_col: int, hi_col: int, *, n_rows: int, n_cols: int) -> list[str]:
    """The fan's and the range window's edges that ``region`` touches, its beams reaching
    from ``lo_col`` to ``hi_col`` (see :func:`fov_flags`)."""
    flags = []
    if region.col_start == 0 and lo_col <= 1:
        flags.append("first_beam")
    if region.col_stop == n_cols and hi_col >= n_cols - 2:
        flags.append("last_beam")
    if region.row_start == 0:
        flags.append("window_start")
    if region.row_stop == n_rows:
        flags.append("window_end")
    return flags


class BandEdges:
    """The band's edge rows per beam, for the checks on a pair's few dozen beams: bounds
    that settle most shadows at once, and per-beam Python lists (plain Python on lists
    beats numpy's call overhead there) made when a shadow comes near an edge."""

    def __init__(self, segmentation: Segmentation) -> None:
        self._segmentation = segmentation
        #: No shadow starting below this row touches the band's near edge...
        self.max_start = int(np.maximum.reduce(segmentation.band_start_rows))
        #: ... nor one ending above this row its far edge (far_row >= stop in every beam).
        self.min_stop = int(np.minimum.reduce(segmentation.band_stop_rows))

    @functools.cached_property
    def start(self) -> list[int]:
        """The band's first row in each beam."""
        return self._segmentation.band_start_rows.tolist()

    @functools.cached_property
    def far_row(self) -> list[int]:
        """Per beam, the last row from which a shadow reaches the band's far edge."""
        seg = self._segmentation
        n_rows, d = seg.levels.shape[0], seg.row_step
        stop = seg.band_stop_rows
        # On a grid of step d a region's rows are its cells' ([d i, d i + d - 1]); the
        # band's edge rows lie inside their cells. Never in a beam whose band ends on the
        # last row.
        far_row = np.where(stop < n_rows - 1, stop - stop % d + (d - 1), np.iinfo(np.int64).max)
        return far_row.tolist()


def band_flags(cols: Sequence[int], first: Sequence[int], last: Sequence[int], band: BandEdges) -> list[str]:
    """``band_near``/``band_far`` of a shadow in a pair's beams ``cols`` (its first and last
    row there, -1 where absent; see :func:`fov_flags`)."""
    flags = []
    # Most shadows lie well inside the band: the bounds settle it without a look per beam.
    if min(first) <= band.max_start:
        start = band.start
        if any(b >= 0 and a <= start[c] and start[c] > 0 for c, a, b in zip(cols, first, last, strict=True)):
            flags.append("band_near")
    if max(last) >= band.min_stop:
        far_row = band.far_row
        n_present = sum(1 for b in last if b >= 0)
        n_far = sum(1 for c, b in zip(cols, last, strict=True) if b >= 0 and b >= far_row[c])
        if 2 * n_far > n_present:
            flags.append("band_far")
    return flags
