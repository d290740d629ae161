"""Targets from cast shadows and the highlights before them (the paper's Algorithm 1, steps 2-5).

A cast shadow is what every target leaves, bright or not: the seabed hidden behind it. A
target's echo (highlight) is often there too, but not always (a low-contrast target
echoes no brighter than the seabed; a top seen at grazing incidence is dim). So targets
are found from the shadows:

1. the beams of each shadow region are split into *runs* of neighbouring beams along which
   the shadow's first and last rows change smoothly (:mod:`perception.shadows.pairing.runs`):
   neighbouring targets whose shadows merged into one region fall apart at the jump (unless
   one highlight precedes the runs on both sides and its near edge runs on smoothly across
   the jump: then the jump is one target's shape);
2. in each beam of a run, the highlight that ends nearest before the shadow starts (at
   most ``max_gap_m`` before: the gap holds the target's dim top, or the seabed in front
   of a tall target at the same slant range as its top; not after it) precedes the
   shadow; where that highlight changes along the run, neighbouring targets' shadows have
   merged smoothly and the run is split there (blocks of at least ``min_run_beams``);
   each block is one target with its highlight, and Algorithm 1's ratio
   ``|T ∩ S| / |T|`` (over beams) is reported as the pair's ``overlap``. A block without
   one is a target too (``PairingConfig.shadow_only``), with no highlight.

Algorithm 1 also requires both regions inside the field of view; here a pair is kept
either way and :class:`Pair` says which edge cuts it (``fov_flags``), so the measurement
can report a truncated shadow with its reason instead of silently losing the target.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from perception.shadows.pairing.fov import BandEdges, band_flags, column_extents, edge_flags, fov_flags, touches_edge
from perception.shadows.pairing.runs import JUMP_FRACTION, JUMP_MIN_M, MAX_BEAM_STEP, MIN_RUN_BEAMS, split_runs
from perception.shadows.segmentation.segment import Extents, Region, Segmentation
from perception.stored_init import check_init_takes_fields

__all__ = [
    "JUMP_FRACTION",
    "JUMP_MIN_M",
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
    max_gap_m : float
        Largest gap, m of range, between a highlight's far end and its shadow's near end
        in one beam (see the module docstring); generous, a large target's dim top can be
        a few decimetres long.
    shadow_only : bool
        Runs of shadow that no highlight precedes make targets too (Algorithm 1 needs both).
    min_run_beams : int
        Fewest beams of a run when its shadow region splits in several (a region of one
        run keeps all its beams).
    """

    max_gap_m: float = 0.45
    shadow_only: bool = True
    min_run_beams: int = MIN_RUN_BEAMS

    def __post_init__(self) -> None:
        if not (math.isfinite(self.max_gap_m) and self.max_gap_m >= 0):
            raise ValueError(f"max_gap_m must be finite and >= 0, got {self.max_gap_m}")
        if self.min_run_beams < 1:
            raise ValueError(f"min_run_beams must be >= 1, got {self.min_run_beams}")


@dataclass(frozen=True)
class Pair:
    """A shadow run and the highlight before it (if any).

    Attributes
    ----------
    highlight : Region or None
        None when no highlight precedes the run.
    shadow : Region
    overlap : float
        Algorithm 1's ``|T ∩ S| / |T|`` over beams (0 without a highlight).
    columns : tuple of int
        The run's beams (increasing).
    fov_flags : tuple of str
        Edges that cut the pair: ``"first_beam"``/``"last_beam"`` (the azimuth edge of
        the fan), ``"window_start"``/``"window_end"`` (range window), ``"band_near"``/
        ``"band_far"`` (the insonified seabed band). Empty when wholly inside.
    highlight_extents, shadow_extents : tuple of ndarray
        :func:`column_extents` of the two regions (first row, last row, present; one
        entry per column of the region's box); ``highlight_extents`` None without one.
    """

    highlight: Region | None
    shadow: Region
    overlap: float
    columns: tuple[int, ...]
    fov_flags: tuple[str, ...]
    highlight_extents: Extents | None = field(compare=False, repr=False)
    shadow_extents: Extents = field(compare=False, repr=False)

    # A frame builds one per target: the fields stored in ``__dict__`` at once (what the
    # generated frozen ``__init__`` does one ``object.__setattr__`` at a time), as
    # :class:`perception.shadows.segmentation.grid.Region` does; its parameters are the
    # fields, in order (checked when the module loads).
    def __init__(self, highlight: Region | None, shadow: Region, overlap: float, columns: tuple[int, ...],
                 fov_flags: tuple[str, ...], highlight_extents: Extents | None, shadow_extents: Extents) -> None:
        self.__dict__.update(highlight=highlight, shadow=shadow, overlap=overlap, columns=columns,
                             fov_flags=fov_flags, highlight_extents=highlight_extents, shadow_extents=shadow_extents)

    @property
    def inside_fov(self) -> bool:
        """True when no edge cuts the pair (Algorithm 1's condition)."""
        return not self.fov_flags


check_init_takes_fields(Pair)


def _beam_highlights(
    segmentation: Segmentation, columns: list[int], first: list[int], max_rise: int
) -> list[int]:
    """Per beam of a run, the label of the highlight that ends nearest before the shadow
    starts there (at most ``max_rise`` rows before it, not after); -1 where none does."""
    lo, hi = columns[0], columns[-1]
    last_all = segmentation.highlight_rows[1]
    best = [-1] * len(columns)
    best_rise = [max_rise + 1] * len(columns)
    for t in segmentation.highlights:
        if t.col_stop <= lo or t.col_start > hi:
            continue
        last = last_all[t.label, lo : hi + 1].tolist()  # (a list: cheaper to index than the array)
        for k, (c, s_first) in enumerate(zip(columns, first, strict=True)):
            t_last = last[c - lo]
            if t_last >= 0:
                rise = s_first - t_last
                if 0 <= rise < best_rise[k]:
                    best[k], best_rise[k] = t.label, rise
    return best


def _blocks(labels: list[int], min_beams: int) -> list[tuple[int, int, int]]:
    """Split a run where the highlight before it changes: (start, stop, label) blocks.

    Beams without a highlight (-1) join the block before them (the first block takes
    the ones before it); blocks of fewer than ``min_beams`` beams join a neighbour.
    """
    distinct = set(labels)
    distinct.discard(-1)
    if len(distinct) <= 1:  # one highlight or none (the usual case): one block
        return [(0, len(labels), distinct.pop() if distinct else -1)]
    filled = list(labels)
    known = next((v for v in filled if v >= 0), -1)
    for k, v in enumerate(filled):
        if v < 0:
            filled[k] = known
        else:
            known = v
    blocks: list[list[int]] = []
    for k, v in enumerate(filled):
        if blocks and blocks[-1][2] == v:
            blocks[-1][1] = k + 1
        else:
            blocks.append([k, k + 1, v])
    merged = True
    while merged and len(blocks) > 1:
        merged = False
        for i, (a, b, _) in enumerate(blocks):
            if b - a < min_beams:
                j = i - 1 if i > 0 and (i == len(blocks) - 1 or blocks[i - 1][1] - blocks[i - 1][0]
                                        >= blocks[i + 1][1] - blocks[i + 1][0]) else i + 1
                lo_i, hi_i = min(i, j), max(i, j)
                keep = blocks[j][2]
                blocks[lo_i:hi_i + 1] = [[blocks[lo_i][0], blocks[hi_i][1], keep]]
                merged = True
                break
    return [(a, b, v) for a, b, v in blocks]


#: A highlight's near edge stepping by this much more than its neighbouring steps (m of range)
#: between two beams starts another target's echo.
NEAR_EDGE_JUMP_M = 0.015


def _smooth_near_edge(segmentation: Segmentation, label: int, col_a: int, col_b: int) -> bool:
    """Whether highlight ``label``'s first row runs on smoothly from beam ``col_a`` to
    ``col_b``: its step there exceeds the median of the neighbouring steps (the slope of a
    face oblique to the beams) by at most :data:`NEAR_EDGE_JUMP_M` (False where absent)."""
    first = segmentation.highlight_rows[0][label]
    last = segmentation.highlight_rows[1][label]
    if last[col_a] < 0 or last[col_b] < 0:
        return False
    step = int(first[col_b]) - int(first[col_a])
    around = []
    for c0 in range(col_a - 3, col_b + 3):
        c1 = c0 + (col_b - col_a)
        if c0 == col_a or c0 < 0 or c1 >= first.size or last[c0] < 0 or last[c1] < 0:
            continue
        around.append(int(first[c1]) - int(first[c0]))
    trend = float(np.median(around)) if around else 0.0
    return abs(step - trend) * segmentation.sample_m <= NEAR_EDGE_JUMP_M


#: Shadows on the two sides of a jump behind one highlight whose lengths differ by more than
#: this factor belong to targets of different heights.
MERGE_LENGTH_RATIO = 1.5


#: Within one run (no jump), the shadows behind two highlights are one target's when their
#: lengths differ by at most this factor.
SAME_TARGET_LENGTH_RATIO = 1.25


def _similar_lengths(first: list[int], last: list[int], a: int, k: int, b: int,
                     ratio: float = MERGE_LENGTH_RATIO) -> bool:
    """Whether the shadow lengths (rows) just before position ``k`` (from ``a``) and just
    after it (to ``b``), medians over up to three beams, differ by at most ``ratio``."""
    before = sorted(last[i] - first[i] + 1 for i in range(max(a, k - 3), k))
    after = sorted(last[i] - first[i] + 1 for i in range(k, min(b, k + 3)))
    if not before or not after:
        return True
    x, y = before[len(before) // 2], after[len(after) // 2]
    return max(x, y) <= ratio * max(min(x, y), 1)


def pair_regions(segmentation: Segmentation, *, config: PairingConfig | None = None) -> list[Pair]:
    """Targets from the shadows of one frame, each with the highlight before it (module docstring).

    Parameters
    ----------
    segmentation : Segmentation
        The output of :func:`perception.shadows.segmentation.segment.segment`.
    config : PairingConfig, optional

    Returns
    -------
    list of Pair
        Ordered by the run's first beam.
    """
    cfg = config or PairingConfig()
    if not segmentation.shadows:
        return []
    n_rows, n_cols = segmentation.levels.shape
    sample_m = segmentation.sample_m
    max_rise = int(math.ceil(cfg.max_gap_m / sample_m)) + 1
    jump_rows = JUMP_MIN_M / sample_m
    band = BandEdges(segmentation)
    first_all, last_all = segmentation.shadow_rows
    highlights = {t.label: t for t in segmentation.highlights}
    # Algorithm 1's |T| (beams holding the highlight), of every label at once.
    # (np.count_nonzero's own sum, without its Python wrapper.)
    highlight_beams = np.add.reduce(segmentation.highlight_rows[1] >= 0, axis=1, dtype=np.intp).tolist()
    pairs: list[Pair] = []
    for s in segmentation.shadows:
        box = slice(s.col_start, s.col_stop)
        first_box, last_box = first_all[s.label, box], last_all[s.label, box]
        shadow_extents = (first_box, last_box, last_box >= 0)
        # The beams holding the shadow, and its rows there, as lists (a region's box is a few
        # dozen beams).
        first_l, last_l = first_box.tolist(), last_box.tolist()
        at = [k for k, row in enumerate(last_l) if row >= 0]
        if not at:
            continue
        if len(at) == len(last_l):  # every beam of the box (the usual case): the lists as they are
            cols, first, last = list(range(s.col_start, s.col_start + len(at))), first_l, last_l
        else:
            cols = [s.col_start + k for k in at]
            first = [first_l[k] for k in at]
            last = [last_l[k] for k in at]
        runs = split_runs(cols, first, last, jump_rows=jump_rows, min_beams=cfg.min_run_beams)
        blocks: list[tuple[int, int, int]] = []
        for p0, p1 in runs:
            labels = _beam_highlights(segmentation, cols[p0:p1], first[p0:p1], max_rise)
            for k_block, (a, b, v) in enumerate(_blocks(labels, cfg.min_run_beams)):
                u = blocks[-1][2] if blocks else -1
                if (k_block > 0 and u >= 0 and v >= 0 and u != v
                        and _similar_lengths(first, last, blocks[-1][0], p0 + a, p0 + b, SAME_TARGET_LENGTH_RATIO)):
                    # Two highlights in front of one smooth shadow (no jump: one run) as long
                    # on both sides: one target whose echo is broken (dim beams through its
                    # middle, its face's and its top's echoes apart), not two side by side.
                    blocks[-1] = (blocks[-1][0], p0 + b, u)
                    continue
                if (blocks and blocks[-1][2] == v >= 0 and blocks[-1][1] == p0 + a
                        and _smooth_near_edge(segmentation, v, cols[p0 + a - 1], cols[p0 + a])
                        and _similar_lengths(first, last, blocks[-1][0], p0 + a, p0 + b)):
                    # A jump of the shadow behind one highlight whose near edge runs on
                    # smoothly, with shadows about as long on both sides (as tall), is the
                    # target's own shape (a corner, a rounded side), not a second target
                    # (whose echo would start at another range, or whose height differs).
                    blocks[-1] = (blocks[-1][0], p0 + b, v)
                else:
                    blocks.append((p0 + a, p0 + b, v))
        for p0, p1, label in blocks:
            columns = cols[p0:p1]
            t = highlights.get(label)
            if t is None and not cfg.shadow_only:
                continue
            ratio = 0.0 if t is None else (p1 - p0) / max(highlight_beams[label], 1)  # |T ∩ S| / |T|
            flags = band_flags(columns, first[p0:p1], last[p0:p1], band)
            if touches_edge(s, n_rows, n_cols) or (t is not None and touches_edge(t, n_rows, n_cols)):
                flags = (
                    (edge_flags(t, columns[0], columns[-1], n_rows=n_rows, n_cols=n_cols) if t is not None else [])
                    + edge_flags(s, columns[0], columns[-1], n_rows=n_rows, n_cols=n_cols)
                    + flags
                )
            pairs.append(Pair(
                highlight=t,
                shadow=s,
                overlap=ratio,
                columns=tuple(columns),
                fov_flags=tuple(dict.fromkeys(flags)),
                highlight_extents=None if t is None else segmentation.column_extents(t),
                shadow_extents=shadow_extents,
            ))
    pairs.sort(key=lambda p: (p.columns[0], p.shadow.row_start))
    return pairs
