"""Pair target highlights with their cast shadows (the paper's Algorithm 1, steps 2-5).

Algorithm 1 keeps a highlight ``T_i`` and a shadow ``S_j`` as a pair when
``m <= |T_i ∩ S_j| / |T_i| <= n``. In a polar image a highlight and its shadow do not
overlap as pixel sets: the shadow lies directly behind the highlight in range, in the same
beams. So ``|T_i ∩ S_j|`` is counted here over beams: the beams of ``T_i`` in which
``S_j`` starts no more than ``max_gap_samples`` rows after the far end of ``T_i``
(and not before its near end); ``|T_i|`` is the number of beams of ``T_i``. Each beam
of a highlight and each beam of a shadow is used at most once (merged regions of
neighbouring targets are shared out by beam; a highlight paired already counts only its
beams left over), smallest gap first, then best overlap, so two targets in one beam each
get the shadow right behind them.

Neighbouring targets can merge into one highlight and one shadow region, and one target's
echo can break into several highlights. So the beams each shadow region received are then
regrouped into targets: runs of neighbouring beams along which the shadow's first and last
rows change smoothly. A jump in either (larger than ``JUMP_MIN_SAMPLES`` and than
``JUMP_FRACTION`` of the shorter shadow) starts a new target; each run becomes one pair,
with the highlight that holds most of its beams.

Algorithm 1 also requires both regions inside the field of view; here a pair is kept
either way and :class:`Pair` says which edge cuts it (``fov_flags``), so the measurement
can report a truncated shadow with its reason instead of silently losing the target.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from perception.shadows.pairing.fov import BandEdges, band_flags, column_extents, edge_flags, fov_flags, touches_edge
from perception.shadows.pairing.runs import JUMP_FRACTION, JUMP_MIN_SAMPLES, MAX_BEAM_STEP, MIN_RUN_BEAMS, split_runs
from perception.shadows.segmentation.segment import ColumnRows, Extents, Region, Segmentation

__all__ = [
    "JUMP_FRACTION",
    "JUMP_MIN_SAMPLES",
    "MAX_BEAM_STEP",
    "MIN_RUN_BEAMS",
    "Pair",
    "PairingConfig",
    "column_extents",
    "fov_flags",
    "pair_regions",
]

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


_Candidate = tuple[int, float, int, int, Region, Region, tuple[int, ...], int]


def _box_rows(rows: NDArray[np.int64], regions: Iterable[Region]) -> dict[int, list[int]]:
    """The row of each region in each column of its box (``rows`` by label, -1 where
    absent), as plain Python lists by label."""
    return {r.label: rows[r.label, r.col_start : r.col_stop].tolist() for r in regions}


def _candidates(
    segmentation: Segmentation, cfg: PairingConfig, shadow_first: dict[int, list[int]]
) -> list[_Candidate]:
    """Every (highlight, shadow) that may pair: (median gap, -ratio, the shadow's first row,
    the candidate's number, highlight, shadow, the beams where the shadow follows the
    highlight, the highlight's number of beams). The first four order the candidates for
    :func:`_share_beams` (the numbers, increasing, break the ties as found).
    ``shadow_first`` holds each shadow's first rows in its box (:func:`_box_rows`).
    """
    highlights, shadows = segmentation.highlights, segmentation.shadows
    highlight_last = _box_rows(segmentation.highlight_rows[1], highlights)
    # The shadow starts no more than max_gap_samples rows after the highlight's far end
    # (0 <= rise <= max_gap + 1, rise = the gap + 1), which also puts the shadow's start at
    # or after the highlight's near end. Plain Python over the regions' boxes: the boxes of
    # most (highlight, shadow) do not meet, and the few dozen beams where they do cost less
    # in a plain loop than numpy's calls over every (highlight, shadow, beam).
    max_rise = cfg.max_gap_samples + 1
    boxes = [(s, s.col_start, s.col_stop, shadow_first[s.label]) for s in shadows]
    n_s = len(shadows)
    candidates: list[_Candidate] = []
    for i, t in enumerate(highlights):
        t0, t1 = t.col_start, t.col_stop
        t_last = highlight_last[t.label]
        n_t = len(t_last) - t_last.count(-1)  # its beams
        for j, (s, s0, s1, s_first) in enumerate(boxes):
            lo = t0 if t0 > s0 else s0
            hi = t1 if t1 < s1 else s1
            if lo >= hi:  # the boxes do not meet
                continue
            beams = []
            rises = []
            for c in range(lo, hi):
                far = t_last[c - t0]
                # The highlight is in the beam; an absent shadow's first row (-1) makes the rise negative.
                if far >= 0:
                    rise = s_first[c - s0] - far
                    if 0 <= rise <= max_rise:
                        beams.append(c)
                        rises.append(rise)
            n = len(beams)
            if not n:
                continue
            ratio = n / n_t
            # A highlight merged from neighbours may fall short of overlap_min with each shadow
            # until its other beams are paired: enough common beams keep it a candidate.
            if ratio <= cfg.overlap_max and (ratio >= cfg.overlap_min or n >= MIN_RUN_BEAMS):
                rises.sort()
                # The median gap (rise - 1), truncated toward zero.
                median_gap = int((rises[(n - 1) // 2] + rises[n // 2] - 2) / 2)
                candidates.append((median_gap, -ratio, s.row_start, i * n_s + j, t, s, tuple(beams), n_t))
    return candidates


def _share_beams(
    candidates: list[_Candidate], cfg: PairingConfig
) -> tuple[dict[int, list[tuple[tuple[int, ...], int]]], list[tuple[Region, float]], dict[int, Region]]:
    """Share the beams out between the candidates, nearest shadow first.

    Returns, per shadow label, the beams it received, as (beams, index into the second
    item) for each accepted candidate in turn (its beams increasing; empty when none),
    the accepted (highlight, ratio), and the shadows by label. The first dict keeps the
    order in which the candidates reached the shadows (that orders the pairs on ties).
    """
    # Nearest shadow first (smallest median gap, then best ratio, then the nearer shadow):
    # two targets in one beam each take the shadow right behind them.
    candidates = sorted(candidates)
    paired_t: dict[int, list[tuple[int, ...]]] = {}  # highlight label -> the beams of its pairs
    owner: dict[int, list[tuple[tuple[int, ...], int]]] = {}  # shadow label -> (beams, index in accepted)
    accepted: list[tuple[Region, float]] = []  # (highlight, ratio)
    shadow_of: dict[int, Region] = {}
    for _, _, _, _, t, s, all_columns, n_t in candidates:
        # Neighbouring targets can merge into one shadow region and into one highlight
        # region: each highlight then takes the beams right behind itself, never beams
        # already taken, and a highlight paired already may take another shadow in its
        # other beams (the ratio is then over the beams it has left).
        received = owner.setdefault(s.label, [])
        t_paired = paired_t.setdefault(t.label, [])
        n_left = n_t
        columns = all_columns
        if received or t_paired:
            # (Sets of the beams taken only here: most shadows and highlights pair once.)
            taken = {c for beams, _ in received for c in beams}.union(*t_paired)
            columns = tuple(c for c in all_columns if c not in taken)
            if not columns:
                continue
            if t_paired:
                if len(columns) < MIN_RUN_BEAMS:
                    continue
                n_left -= sum(map(len, t_paired))  # its pairs' beams are disjoint
        ratio = len(columns) / n_left
        if not cfg.overlap_min <= ratio <= cfg.overlap_max:
            continue
        t_paired.append(columns)
        shadow_of[s.label] = s
        received.append((columns, len(accepted)))
        accepted.append((t, ratio))
    return owner, accepted, shadow_of


def _column_extents(
    rows: ColumnRows, present_all: NDArray[np.bool_], regions: Iterable[Region]
) -> dict[int, Extents]:
    """:meth:`Segmentation.column_extents` of ``regions`` by label: slices (views) of
    their kind's ``rows`` (first and last rows by label) and of ``present_all`` (last row
    >= 0, computed once for every label instead of once per region)."""
    first_all, last_all = rows
    extents = {}
    for r in regions:
        box = (r.label, slice(r.col_start, r.col_stop))  # one index for the three views
        extents[r.label] = (first_all[box], last_all[box], present_all[box])
    return extents


def _new_pair(**values: object) -> Pair:
    """``Pair(**values)`` (every field by name) at a fraction of the cost: the frozen
    dataclass's ``__init__`` sets each field through ``object.__setattr__``, filling the new
    instance's ``__dict__`` gives the same object (equal, same hash, repr and pickle)."""
    pair = object.__new__(Pair)
    pair.__dict__.update(values)
    return pair


def pair_regions(segmentation: Segmentation, *, config: PairingConfig | None = None) -> list[Pair]:
    """Pair each highlight with the shadow right behind it (Algorithm 1, step 5).

    Parameters
    ----------
    segmentation : Segmentation
        The output of :func:`perception.shadows.segmentation.segment.segment`.
    config : PairingConfig, optional
        Thresholds ``[m, n]`` and the largest highlight-to-shadow gap.

    Returns
    -------
    list of Pair
        Ordered by the shadow's first beam.
    """
    cfg = config or PairingConfig()
    if not segmentation.highlights or not segmentation.shadows:
        return []
    shadow_first = _box_rows(segmentation.shadow_rows[0], segmentation.shadows)
    owner, accepted, shadow_of = _share_beams(_candidates(segmentation, cfg, shadow_first), cfg)
    if not shadow_of:
        return []
    n_rows, n_cols = segmentation.levels.shape
    band = BandEdges(segmentation)
    shadow_extents_of = _column_extents(segmentation.shadow_rows, segmentation.shadow_rows[1] >= 0, shadow_of.values())
    highlight_extents = _column_extents(
        segmentation.highlight_rows, segmentation.highlight_rows[1] >= 0, (t for t, _ in accepted)
    )
    pairs: list[Pair] = []
    for label, received in owner.items():
        if not received:
            continue
        s = shadow_of[label]
        shadow_extents = shadow_extents_of[label]
        s_at_edge = touches_edge(s, n_rows, n_cols)
        # The shadow's box settles most shadows for band_flags' bounds: its rows lie in
        # [row_start, row_stop - 1] (the same answer, without a look at its beams).
        s_near_band = s.row_start <= band.max_start or s.row_stop - 1 >= band.min_stop
        if len(received) == 1:
            # Most shadows follow one highlight only: it holds every run.
            cols, sole = received[0]
            by_beam = None
        else:
            by_beam = {c: index for columns, index in received for c in columns}
            cols, sole = tuple(sorted(by_beam)), None
        # The shadow's rows in the beams of its box, for plain Python to pick from.
        first_box, last_box = shadow_first[label], shadow_extents[1].tolist()
        p, q = cols[0] - s.col_start, cols[-1] - s.col_start + 1
        if q - p == len(cols):  # beams side by side
            first, last = first_box[p:q], last_box[p:q]
        else:
            first = [first_box[c - s.col_start] for c in cols]
            last = [last_box[c - s.col_start] for c in cols]
        for p0, p1 in split_runs(cols, first, last):
            if by_beam is None:
                assert sole is not None  # one highlight holds every beam
                t, ratio = accepted[sole]
            else:
                # The highlight holding most of the run's beams (the first of them on a
                # tie: dict keeps the order of first appearance, max the first of equals).
                run_holders = [by_beam[c] for c in cols[p0:p1]]
                t, ratio = accepted[max(dict.fromkeys(run_holders), key=run_holders.count)]
            columns = cols[p0:p1]
            # fov_flags' order: the highlight's edges, the shadow's, then the band's.
            flags = band_flags(columns, first[p0:p1], last[p0:p1], band) if s_near_band else []
            if s_at_edge or touches_edge(t, n_rows, n_cols):
                flags = (
                    edge_flags(t, columns[0], columns[-1], n_rows=n_rows, n_cols=n_cols)
                    + edge_flags(s, columns[0], columns[-1], n_rows=n_rows, n_cols=n_cols)
                    + flags
                )
            pairs.append(
                _new_pair(
                    highlight=t,
                    shadow=s,
                    overlap=ratio,
                    columns=columns,
                    fov_flags=tuple(dict.fromkeys(flags)) if flags else (),
                    highlight_extents=highlight_extents[t.label],
                    shadow_extents=shadow_extents,
                )
            )
    pairs.sort(key=lambda p: (p.shadow.col_start, p.shadow.row_start))
    return pairs
