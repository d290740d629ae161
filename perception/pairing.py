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

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from perception.segmentation import Extents, Region, Segmentation

#: A shadow's first or last row jumping by more than this (and JUMP_FRACTION) between
#: neighbouring beams separates two targets, samples.
JUMP_MIN_SAMPLES = 24

#: ... and by more than this fraction of the shorter of the two shadow lengths.
JUMP_FRACTION = 0.2

#: Fewest beams of a regrouped target (when its shadow region holds more than one), and
#: of a second pairing of one highlight.
MIN_RUN_BEAMS = 5

#: Neighbouring beams of one target may be this far apart (beams without its highlight).
MAX_BEAM_STEP = 3


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


def column_extents(segmentation: Segmentation, region: Region) -> Extents:
    """First and last row of ``region`` in each column of its box, and which columns hold it.

    See :meth:`perception.segmentation.Segmentation.column_extents` (full-resolution rows,
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
    flags: list[str] = []
    for region in regions:
        if region.col_start == 0 and lo_col <= 1:
            flags.append("first_beam")
        if region.col_stop == n_cols and hi_col >= n_cols - 2:
            flags.append("last_beam")
        if region.row_start == 0:
            flags.append("window_start")
        if region.row_stop == n_rows:
            flags.append("window_end")
        if region.kind == "shadow":
            if columns is None:
                known = None if extents is None else extents.get(region.label)
                first, last, present = known if known is not None else column_extents(segmentation, region)
                cols: slice | NDArray[np.intp] = slice(region.col_start, region.col_stop)
            else:
                # A pair's few dozen beams: plain Python on lists beats numpy's call overhead.
                flags.extend(_band_flags(segmentation, region, columns, n_rows=n_rows, d=d))
                continue
            start = segmentation.band_start_rows[cols]
            stop = segmentation.band_stop_rows[cols]
            # On a grid of step d a region's rows are its cells' ([d i, d i + d - 1]); the
            # band's edge rows lie inside their cells.
            if np.any(present & (first <= start) & (start > 0)):
                flags.append("band_near")
            at_far = present & (last - (d - 1) >= stop - stop % d) & (stop < n_rows - 1)
            if 2 * np.count_nonzero(at_far) > np.count_nonzero(present):
                flags.append("band_far")
    return tuple(dict.fromkeys(flags))


def _band_flags(
    segmentation: Segmentation, region: Region, columns: tuple[int, ...], *, n_rows: int, d: int
) -> list[str]:
    """``band_near``/``band_far`` of a shadow in a pair's beams (see :func:`fov_flags`)."""
    cols = list(columns)
    first = segmentation.shadow_rows[0][region.label, cols].tolist()
    last = segmentation.shadow_rows[1][region.label, cols].tolist()
    start = segmentation.band_start_rows[cols].tolist()
    stop = segmentation.band_stop_rows[cols].tolist()
    flags = []
    # On a grid of step d a region's rows are its cells' ([d i, d i + d - 1]); the
    # band's edge rows lie inside their cells.
    if any(b >= 0 and a <= s0 and s0 > 0 for a, b, s0 in zip(first, last, start, strict=True)):
        flags.append("band_near")
    n_present = sum(1 for b in last if b >= 0)
    n_far = sum(
        1 for b, e in zip(last, stop, strict=True) if b >= 0 and b - (d - 1) >= e - e % d and e < n_rows - 1
    )
    if 2 * n_far > n_present:
        flags.append("band_far")
    return flags


def _median3(values: list[float]) -> list[float]:
    """Running median of three (the ends kept): a single odd beam is not a jump."""
    if len(values) < 3:
        return values
    inner = [
        b if a <= b <= c or c <= b <= a else (a if b <= a <= c or c <= a <= b else c)
        for a, b, c in zip(values, values[1:], values[2:], strict=False)
    ]
    return [values[0], *inner, values[-1]]


def _runs(
    segmentation: Segmentation, shadow: Region, columns: list[int]
) -> list[list[int]]:
    """The beams a shadow region received, split into targets (see the module docstring).

    Plain Python: a region holds a few dozen beams, fewer than numpy's call overhead pays for.
    """
    cols = sorted(columns)
    first = _median3(segmentation.shadow_rows[0][shadow.label, cols].tolist())
    last = _median3(segmentation.shadow_rows[1][shadow.label, cols].tolist())
    runs = [[cols[0]]]
    run = runs[0]
    c0, f0, l0 = cols[0], first[0], last[0]
    for c1, f1, l1 in zip(cols[1:], first[1:], last[1:], strict=True):
        # max(JUMP_MIN_SAMPLES, JUMP_FRACTION * min(lengths) + 1), without the calls
        a, b = l0 - f0, l1 - f1
        limit = JUMP_FRACTION * (a if a < b else b) + 1
        if limit < JUMP_MIN_SAMPLES:
            limit = JUMP_MIN_SAMPLES
        if c1 - c0 > MAX_BEAM_STEP or abs(f1 - f0) > limit or abs(l1 - l0) > limit:
            run = []
            runs.append(run)
        run.append(c1)
        c0, f0, l0 = c1, f1, l1
    if len(runs) > 1:
        runs = [r for r in runs if len(r) >= MIN_RUN_BEAMS]
    return runs


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
    highlights, shadows = segmentation.highlights, segmentation.shadows
    if not highlights or not shadows:
        return []
    # Every highlight against every shadow in every beam at once: (highlight, shadow, beam).
    h_labels = np.array([t.label for t in highlights])
    s_labels = np.array([s.label for s in shadows])
    t_first = segmentation.highlight_rows[0][h_labels][:, None, :]
    t_last = segmentation.highlight_rows[1][h_labels][:, None, :]
    s_first = segmentation.shadow_rows[0][s_labels][None, :, :]
    s_present = segmentation.shadow_rows[1][s_labels][None, :, :] >= 0
    t_present = t_last >= 0
    gap = s_first - t_last - 1
    follows = (
        t_present & s_present & (s_first >= t_first) & (gap <= cfg.max_gap_samples) & (gap >= -1)
    )
    n_common = np.count_nonzero(follows, axis=2)
    n_beams = np.count_nonzero(t_present[:, 0, :], axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        ratios = n_common / n_beams[:, None]
    # A highlight merged from neighbours may fall short of overlap_min with each shadow
    # until its other beams are paired: enough common beams keep it a candidate.
    keep = (n_common > 0) & (ratios <= cfg.overlap_max) & (
        (ratios >= cfg.overlap_min) | (n_common >= MIN_RUN_BEAMS)
    )
    candidates: list[tuple[float, int, Region, Region, tuple[int, ...], int]] = []
    for i, j in zip(*np.nonzero(keep), strict=True):
        beams = np.flatnonzero(follows[i, j])
        gaps = sorted(gap[i, j, beams].tolist())
        median_gap = int((gaps[(len(gaps) - 1) // 2] + gaps[len(gaps) // 2]) / 2)
        candidates.append(
            (float(ratios[i, j]), median_gap, highlights[i], shadows[j], tuple(beams.tolist()), int(n_beams[i]))
        )
    # Nearest shadow first: two targets in one beam each take the shadow right behind them.
    candidates.sort(key=lambda c: (c[1], -c[0], c[3].row_start))
    used_t: dict[int, set[int]] = {}  # highlight label -> its beams already paired
    owner: dict[int, dict[int, tuple[Region, float]]] = {}  # shadow label -> beam -> highlight
    shadow_of: dict[int, Region] = {}
    for ratio, _, t, s, all_columns, n_t in candidates:
        # Neighbouring targets can merge into one shadow region and into one highlight
        # region: each highlight then takes the beams right behind itself, never beams
        # already taken, and a highlight paired already may take another shadow in its
        # other beams (the ratio is then over the beams it has left).
        taken = owner.setdefault(s.label, {})
        t_taken = used_t.setdefault(t.label, set())
        columns = tuple(c for c in all_columns if c not in taken and c not in t_taken)
        if not columns:
            continue
        if t_taken and len(columns) < MIN_RUN_BEAMS:
            continue
        ratio = len(columns) / (n_t - len(t_taken))
        if not cfg.overlap_min <= ratio <= cfg.overlap_max:
            continue
        t_taken.update(columns)
        shadow_of[s.label] = s
        for c in columns:
            taken[c] = (t, ratio)
    pairs: list[Pair] = []
    for label, by_beam in owner.items():
        if not by_beam:
            continue
        s = shadow_of[label]
        shadow_extents = segmentation.column_extents(s)
        for run in _runs(segmentation, s, list(by_beam)):
            votes: dict[int, int] = {}
            for c in run:
                votes[by_beam[c][0].label] = votes.get(by_beam[c][0].label, 0) + 1
            t, ratio = max((by_beam[c] for c in run), key=lambda tr: votes[tr[0].label])
            columns = tuple(run)
            pairs.append(
                Pair(
                    highlight=t,
                    shadow=s,
                    overlap=ratio,
                    columns=columns,
                    fov_flags=fov_flags(segmentation, t, s, columns=columns),
                    highlight_extents=segmentation.column_extents(t),
                    shadow_extents=shadow_extents,
                )
            )
    pairs.sort(key=lambda p: (p.shadow.col_start, p.shadow.row_start))
    return pairs
