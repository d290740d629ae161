"""Pair target highlights with their cast shadows (the paper's Algorithm 1, steps 2-5).

Algorithm 1 keeps a highlight ``T_i`` and a shadow ``S_j`` as a pair when
``m <= |T_i ∩ S_j| / |T_i| <= n``. In a polar image a highlight and its shadow do not
overlap as pixel sets: the shadow lies directly behind the highlight in range, in the same
beams. So ``|T_i ∩ S_j|`` is counted here over beams: the beams of ``T_i`` in which
``S_j`` starts no more than ``max_gap_samples`` rows after the far end of ``T_i``
(and not before its near end); ``|T_i|`` is the number of beams of ``T_i``. Each
highlight is used at most once and each beam of a shadow at most once (the merged
shadows of neighbouring targets are shared out by beam), smallest gap first, then best
overlap, so two targets in one beam each get the shadow right behind them.

Algorithm 1 also requires both regions inside the field of view; here a pair is kept
either way and :class:`Pair` says which edge cuts it (``fov_flags``), so the measurement
can report a truncated shadow with its reason instead of silently losing the target.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from perception.segmentation import Region, Segmentation


@dataclass(frozen=True)
class PairingConfig:
    """Settings of :func:`pair_regions`.

    Attributes
    ----------
    overlap_min, overlap_max : float
        Algorithm 1's thresholds ``[m, n]`` on ``|T ∩ S| / |T|`` (beam overlap ratio).
    max_gap_samples : int
        Largest gap, in range samples, between a highlight's far end and its shadow's
        near end in one beam. The gap holds the target's top when its echo is too weak
        to count as highlight (a top seen at grazing incidence), so it is generous.
    """

    overlap_min: float = 0.4
    overlap_max: float = 1.0
    max_gap_samples: int = 150

    def __post_init__(self) -> None:
        if not 0 <= self.overlap_min <= self.overlap_max:
            raise ValueError(
                f"need 0 <= overlap_min <= overlap_max, got [{self.overlap_min}, {self.overlap_max}]"
            )
        if self.max_gap_samples < 0:
            raise ValueError(f"max_gap_samples must be >= 0, got {self.max_gap_samples}")


#: Per column of a region's box: first row, last row, whether the region is there.
Extents = tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.bool_]]


@dataclass(frozen=True)
class Pair:
    """A highlight and the shadow it casts.

    Attributes
    ----------
    highlight, shadow : Region
    overlap : float
        ``|T ∩ S| / |T|`` over beams.
    columns : tuple of int
        The beams counted in ``|T ∩ S|`` (the shadow follows the highlight there).
    highlight_extents, shadow_extents : tuple of ndarray
        :func:`column_extents` of the two regions (first row, last row, present; one
        entry per column of the region's box).
    fov_flags : tuple of str
        Edges that cut the pair: ``"first_beam"``/``"last_beam"`` (the azimuth edge of
        the fan), ``"window_start"``/``"window_end"`` (range window), ``"band_near"``/
        ``"band_far"`` (the insonified seabed band). Empty when wholly inside.
    """

    highlight: Region
    shadow: Region
    overlap: float
    columns: tuple[int, ...]
    fov_flags: tuple[str, ...]
    highlight_extents: Extents = field(compare=False, repr=False)
    shadow_extents: Extents = field(compare=False, repr=False)

    @property
    def inside_fov(self) -> bool:
        """True when no edge cuts the pair (Algorithm 1's condition)."""
        return not self.fov_flags


def column_extents(
    labels: NDArray[np.int32], region: Region
) -> Extents:
    """First and last row of ``region`` in each column of its box, and which columns hold it."""
    box = labels[region.row_start : region.row_stop, region.col_start : region.col_stop] == region.label
    present = box.any(axis=0)
    first = np.argmax(box, axis=0) + region.row_start
    last = box.shape[0] - 1 - np.argmax(box[::-1], axis=0) + region.row_start
    return first, last, present


def fov_flags(segmentation: Segmentation, *regions: Region) -> tuple[str, ...]:
    """Which edges of the field of view the regions touch (see :class:`Pair`).

    The band's edges are checked per beam, for shadows (a shadow reaching the first or
    last insonified row of any of its beams is cut there).
    """
    n_rows, n_cols = segmentation.shadow_labels.shape
    flags: list[str] = []
    for region in regions:
        if region.col_start == 0:
            flags.append("first_beam")
        if region.col_stop == n_cols:
            flags.append("last_beam")
        if region.row_start == 0:
            flags.append("window_start")
        if region.row_stop == n_rows:
            flags.append("window_end")
        if region.kind == "shadow":
            first, last, present = column_extents(segmentation.shadow_labels, region)  # small box
            cols = slice(region.col_start, region.col_stop)
            start = segmentation.band_start_rows[cols]
            stop = segmentation.band_stop_rows[cols]
            if np.any(present & (first <= start) & (start > 0)):
                flags.append("band_near")
            if np.any(present & (last >= stop) & (stop < n_rows - 1)):
                flags.append("band_far")
    return tuple(dict.fromkeys(flags))


def pair_regions(segmentation: Segmentation, *, config: PairingConfig | None = None) -> list[Pair]:
    """Pair each highlight with the shadow right behind it (Algorithm 1, step 5).

    Parameters
    ----------
    segmentation : Segmentation
        The output of :func:`perception.segmentation.segment`.
    config : PairingConfig, optional
        Thresholds ``[m, n]`` and the largest highlight-to-shadow gap.

    Returns
    -------
    list of Pair
        Ordered by the shadow's first beam.
    """
    cfg = config or PairingConfig()
    shadow_ext = {
        s.label: column_extents(segmentation.shadow_labels, s) for s in segmentation.shadows
    }
    highlight_ext: dict[int, Extents] = {}
    candidates: list[tuple[float, int, Region, Region, tuple[int, ...], int]] = []
    for t in segmentation.highlights:
        highlight_ext[t.label] = column_extents(segmentation.highlight_labels, t)
        t_first, t_last, t_present = highlight_ext[t.label]
        n_t = int(np.count_nonzero(t_present))
        if n_t == 0:
            continue
        for s in segmentation.shadows:
            lo, hi = max(t.col_start, s.col_start), min(t.col_stop, s.col_stop)
            if (
                lo >= hi
                or s.row_stop <= t.row_start
                or s.row_start > t.row_stop + cfg.max_gap_samples
            ):
                continue
            s_first, _, s_present = shadow_ext[s.label]
            ti = slice(lo - t.col_start, hi - t.col_start)
            si = slice(lo - s.col_start, hi - s.col_start)
            gap = s_first[si] - t_last[ti] - 1
            follows = (
                t_present[ti]
                & s_present[si]
                & (s_first[si] >= t_first[ti])
                & (gap <= cfg.max_gap_samples)
                & (gap >= -1)
            )
            n_common = int(np.count_nonzero(follows))
            if n_common == 0:
                continue
            ratio = n_common / n_t
            if not cfg.overlap_min <= ratio <= cfg.overlap_max:
                continue
            columns = tuple(int(c) for c in np.flatnonzero(follows) + lo)
            median_gap = int(np.median(gap[follows]))
            candidates.append((ratio, median_gap, t, s, columns, n_t))
    # Nearest shadow first: two targets in one beam each take the shadow right behind them.
    candidates.sort(key=lambda c: (c[1], -c[0], c[3].row_start))
    used_t: set[int] = set()
    used_s: dict[int, set[int]] = {}
    pairs: list[Pair] = []
    for ratio, _, t, s, all_columns, n_t in candidates:
        # The shadows of neighbouring targets can merge into one region: each highlight
        # then takes the beams of it right behind itself, never beams already taken.
        taken = used_s.setdefault(s.label, set())
        columns = tuple(c for c in all_columns if c not in taken)
        if t.label in used_t or not columns:
            continue
        if len(columns) < len(all_columns):
            ratio = len(columns) / n_t
            if ratio < cfg.overlap_min:
                continue
        used_t.add(t.label)
        taken.update(columns)
        pairs.append(
            Pair(
                highlight=t,
                shadow=s,
                overlap=ratio,
                columns=columns,
                fov_flags=fov_flags(segmentation, t, s),
                highlight_extents=highlight_ext[t.label],
                shadow_extents=shadow_ext[s.label],
            )
        )
    pairs.sort(key=lambda p: (p.shadow.col_start, p.shadow.row_start))
    return pairs
