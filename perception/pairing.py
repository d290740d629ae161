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

import functools
from dataclasses import dataclass, field

import numpy as np

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
    in_pair = None if columns is None else (list(columns), _Band(segmentation))
    flags: list[str] = []
    for region in regions:
        flags.extend(_edge_flags(region, lo_col, hi_col, n_rows=n_rows, n_cols=n_cols))
        if region.kind != "shadow":
            continue
        if in_pair is not None:
            cols, band = in_pair
            first = segmentation.shadow_rows[0][region.label, cols].tolist()
            last = segmentation.shadow_rows[1][region.label, cols].tolist()
            flags.extend(_band_flags(cols, first, last, band))
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


def _touches_edge(region: Region, n_rows: int, n_cols: int) -> bool:
    """Whether ``region`` reaches the edge of the image (else :func:`_edge_flags` has none)."""
    return region.col_start == 0 or region.col_stop == n_cols or region.row_start == 0 or region.row_stop == n_rows


def _edge_flags(region: Region, lo_col: int, hi_col: int, *, n_rows: int, n_cols: int) -> list[str]:
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


class _Band:
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


def _band_flags(cols: list[int], first: list[int], last: list[int], band: _Band) -> list[str]:
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


def _runs(cols: list[int], first: list[int], last: list[int]) -> list[tuple[int, int]]:
    """The beams a shadow region received, split into targets (see the module docstring).

    ``cols`` are the beams (increasing), ``first`` and ``last`` the shadow's first and last
    row in them. Returns each run as (start, stop) positions in ``cols``. Plain Python: a
    region holds a few dozen beams, fewer than numpy's call overhead pays for.
    """
    n = len(cols)
    # _starts_run tests only the beams where a run may start. The running medians of two
    # neighbouring beams both lie among the raw rows of the four beams around them, so they
    # differ by at most the three raw steps there together, while a jump exceeds at least
    # JUMP_MIN_SAMPLES: a run can start only next to a raw step above a third of that, or
    # after a wide beam step.
    rough = JUMP_MIN_SAMPLES // 3
    maybe: set[int] = set()
    for k in range(1, n):
        if abs(first[k] - first[k - 1]) > rough or abs(last[k] - last[k - 1]) > rough:
            maybe.update((k - 1, k, k + 1))
        elif cols[k] - cols[k - 1] > MAX_BEAM_STEP:
            maybe.add(k)
    starts = [0, *(k for k in sorted(maybe) if 0 < k < n and _starts_run(cols, first, last, k))]
    runs = list(zip(starts, [*starts[1:], n], strict=True))
    if len(runs) > 1:
        runs = [r for r in runs if r[1] - r[0] >= MIN_RUN_BEAMS]
    return runs


def _starts_run(cols: list[int], first: list[int], last: list[int], k: int) -> bool:
    """Whether beam ``k`` (a position in ``cols``) starts a new target: a wide beam step from
    the beam before, or a jump of the first or last row's running median of three there
    (the ends of the sequence kept: a single odd beam is not a jump)."""
    if cols[k] - cols[k - 1] > MAX_BEAM_STEP:
        return True
    f0, f1 = _median3_at(first, k - 1), _median3_at(first, k)
    l0, l1 = _median3_at(last, k - 1), _median3_at(last, k)
    limit = max(JUMP_MIN_SAMPLES, JUMP_FRACTION * min(l0 - f0, l1 - f1) + 1)
    return abs(f1 - f0) > limit or abs(l1 - l0) > limit


def _median3_at(values: list[int], k: int) -> int:
    """The running median of three of ``values`` at ``k``, the ends kept."""
    if k == 0 or k == len(values) - 1:
        return values[k]
    a, b, c = values[k - 1], values[k], values[k + 1]
    return b if a <= b <= c or c <= b <= a else (a if b <= a <= c or c <= a <= b else c)


#: Stands in for the last row of a highlight absent from a beam: no gap then lies in
#: [-1, max_gap_samples]. (Far beyond any image's rows, and within int32 should the rows
#: come as int32.)
_FAR_ROW = 1 << 30

_Candidate = tuple[float, int, Region, Region, tuple[int, ...], int]


def _candidates(segmentation: Segmentation, cfg: PairingConfig) -> list[_Candidate]:
    """Every (highlight, shadow) that may pair: (ratio, median gap, highlight, shadow, the
    beams where the shadow follows the highlight, the highlight's number of beams)."""
    highlights, shadows = segmentation.highlights, segmentation.shadows
    # Every highlight against every shadow in every beam at once: (highlight, shadow, beam).
    t_last = segmentation.highlight_rows[1][[t.label for t in highlights]]
    t_present = t_last >= 0
    s_first = segmentation.shadow_rows[0][[s.label for s in shadows]]
    # A highlight's last row pushed far past the image's rows where it is absent makes every
    # gap there negative; so does an absent shadow's first row, -1 (Segmentation's rows are
    # -1 where absent). One test on the gap then also checks that both are in the beam.
    t_last = np.where(t_present, t_last, _FAR_ROW)
    # The shadow starts no more than max_gap_samples rows after the highlight's far end:
    # 0 <= s_first - t_last <= max_gap + 1, one unsigned comparison (a negative difference
    # wraps to a huge one). s_first >= t_last also puts the shadow's start at or after
    # the highlight's near end (t_first <= t_last).
    rise = np.subtract(s_first, t_last[:, None], dtype=np.int64)  # the gap + 1, (highlight, shadow, beam)
    follows = rise.view(np.uint64) <= cfg.max_gap_samples + 1
    n_beams = np.add.reduce(t_present, axis=1).tolist()
    n_common = np.add.reduce(follows, axis=2).ravel().tolist()
    # The beams and rises of all (highlight, shadow) in one go, in order of (highlight,
    # shadow, beam): each (highlight, shadow) owns the next n_common entries.
    # (The flat indices: np.nonzero on a 3-d array costs several times more.)
    hits = follows.ravel().nonzero()[0]
    beams = (hits % rise.shape[2]).tolist()
    rises = rise[follows].tolist()
    n_s = len(shadows)
    candidates: list[_Candidate] = []
    stop = 0
    for k, n in enumerate(n_common):
        if not n:
            continue
        start, stop = stop, stop + n
        i, j = divmod(k, n_s)
        ratio = n / n_beams[i]
        # A highlight merged from neighbours may fall short of overlap_min with each shadow
        # until its other beams are paired: enough common beams keep it a candidate.
        if ratio <= cfg.overlap_max and (ratio >= cfg.overlap_min or n >= MIN_RUN_BEAMS):
            ordered = sorted(rises[start:stop])
            # The median gap (rise - 1), truncated toward zero.
            median_gap = int((ordered[(n - 1) // 2] + ordered[n // 2] - 2) / 2)
            candidates.append((ratio, median_gap, highlights[i], shadows[j], tuple(beams[start:stop]), n_beams[i]))
    return candidates


def _share_beams(
    candidates: list[_Candidate], cfg: PairingConfig
) -> tuple[dict[int, dict[int, int]], list[tuple[Region, float]], dict[int, Region]]:
    """Share the beams out between the candidates, nearest shadow first.

    Returns, per shadow label, the beams it received (beam -> index into the second
    item), the accepted (highlight, ratio), and the shadows by label. The first dict keeps
    the order in which the candidates reached the shadows (that orders the pairs on ties).
    """
    # Nearest shadow first: two targets in one beam each take the shadow right behind them.
    candidates = sorted(candidates, key=lambda c: (c[1], -c[0], c[3].row_start))
    used_t: dict[int, set[int]] = {}  # highlight label -> its beams already paired
    owner: dict[int, dict[int, int]] = {}  # shadow label -> beam -> index in accepted
    accepted: list[tuple[Region, float]] = []  # (highlight, ratio)
    shadow_of: dict[int, Region] = {}
    for _, _, t, s, all_columns, n_t in candidates:
        # Neighbouring targets can merge into one shadow region and into one highlight
        # region: each highlight then takes the beams right behind itself, never beams
        # already taken, and a highlight paired already may take another shadow in its
        # other beams (the ratio is then over the beams it has left).
        taken = owner.setdefault(s.label, {})
        t_taken = used_t.setdefault(t.label, set())
        if taken or t_taken:
            columns = tuple(c for c in all_columns if c not in taken and c not in t_taken)
        else:
            columns = all_columns
        if not columns:
            continue
        if t_taken and len(columns) < MIN_RUN_BEAMS:
            continue
        ratio = len(columns) / (n_t - len(t_taken))
        if not cfg.overlap_min <= ratio <= cfg.overlap_max:
            continue
        t_taken.update(columns)
        shadow_of[s.label] = s
        taken.update(dict.fromkeys(columns, len(accepted)))
        accepted.append((t, ratio))
    return owner, accepted, shadow_of


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
    if not segmentation.highlights or not segmentation.shadows:
        return []
    owner, accepted, shadow_of = _share_beams(_candidates(segmentation, cfg), cfg)
    if not shadow_of:
        return []
    n_rows, n_cols = segmentation.levels.shape
    band = _Band(segmentation)
    received = [label for label, by_beam in owner.items() if by_beam]
    # The shadows' rows along the whole beam axis, for plain Python to pick from.
    first_rows = segmentation.shadow_rows[0][received].tolist()
    last_rows = segmentation.shadow_rows[1][received].tolist()
    highlight_extents: dict[int, Extents] = {}
    pairs: list[Pair] = []
    for label, first_row, last_row in zip(received, first_rows, last_rows, strict=True):
        by_beam = owner[label]
        s = shadow_of[label]
        shadow_extents = segmentation.column_extents(s)
        s_at_edge = _touches_edge(s, n_rows, n_cols)
        cols = sorted(by_beam)
        first = [first_row[c] for c in cols]
        last = [last_row[c] for c in cols]
        # Most shadows follow one highlight only: then it holds every run.
        holders = set(by_beam.values())
        sole = holders.pop() if len(holders) == 1 else None
        for p0, p1 in _runs(cols, first, last):
            if sole is None:
                # The highlight holding most of the run's beams (the first of them on a
                # tie: dict keeps the order of first appearance, max the first of equals).
                run_holders = [by_beam[c] for c in cols[p0:p1]]
                t, ratio = accepted[max(dict.fromkeys(run_holders), key=run_holders.count)]
            else:
                t, ratio = accepted[sole]
            columns = tuple(cols[p0:p1])
            # fov_flags' order: the highlight's edges, the shadow's, then the band's.
            flags = _band_flags(cols[p0:p1], first[p0:p1], last[p0:p1], band)
            if s_at_edge or _touches_edge(t, n_rows, n_cols):
                flags = (
                    _edge_flags(t, columns[0], columns[-1], n_rows=n_rows, n_cols=n_cols)
                    + _edge_flags(s, columns[0], columns[-1], n_rows=n_rows, n_cols=n_cols)
                    + flags
                )
            if t.label not in highlight_extents:
                highlight_extents[t.label] = segmentation.column_extents(t)
            pairs.append(
                Pair(
                    highlight=t,
                    shadow=s,
                    overlap=ratio,
                    columns=columns,
                    fov_flags=tuple(dict.fromkeys(flags)),
                    highlight_extents=highlight_extents[t.label],
                    shadow_extents=shadow_extents,
                )
            )
    pairs.sort(key=lambda p: (p.shadow.col_start, p.shadow.row_start))
    return pairs
