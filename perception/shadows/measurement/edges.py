"""The shadow's start and end rows per beam, for all pairs' central beams at once
(:mod:`perception.shadows.measurement.measure` combines them into measurements; see its docstring for the
method)."""

from __future__ import annotations

import functools
from collections.abc import Sequence
from typing import TYPE_CHECKING, NamedTuple, cast

import cv2
import numpy as np
from numpy.typing import NDArray

from perception.shadows.measurement.refine import clamp, cumsum0, neighbour_power, refine_shadow_rows
from perception.shadows.pairing.pair import Pair
from perception.shadows.segmentation.segment import Segmentation

if TYPE_CHECKING:
    from perception.shadows.measurement.config import MeasureConfig

#: Extra samples of the echo before a shadow's first row read for its top edge.
EDGE_MARGIN_SAMPLES = 8


def central_beams(columns: tuple[int, ...], fraction: float) -> list[int]:
    """The middle ``fraction`` of a pair's beams (at least one), in order: the beams
    measured (the outer ones cross the target's rounded or sloping sides)."""
    cols = sorted(columns)
    n = len(cols)
    keep = max(1, int(round(n * fraction)))
    start = (n - keep) // 2
    return cols[start : start + keep]


class Edges(NamedTuple):
    """The edges found in the pairs' central beams, all pairs' beams in one array
    (a named tuple: built once per frame, cheaper than a frozen dataclass).

    ``columns`` lists the beams with both edges, grouped by pair in the pairs' order:
    ``counts[n]`` of them belong to pair ``n``; ``rows[0]`` and ``rows[1]`` hold their
    shadow starts and ends (fractional rows). ``far_cut[n]`` is True when most of pair
    ``n``'s beams are cut by the band's far edge.
    """

    columns: NDArray[np.intp]
    rows: NDArray[np.float64]
    counts: list[int]
    far_cut: list[bool]


def no_edges(far_cut: list[bool]) -> Edges:
    """The :class:`Edges` of pairs none of whose beams gave both edges."""
    return Edges(np.zeros(0, dtype=np.intp), np.zeros((2, 0)), [0] * len(far_cut), far_cut)




def find_edges(segmentation: Segmentation, pairs: Sequence[Pair], cfg: MeasureConfig) -> Edges:
    """Fractional rows of the shadow start and end in each pair's central beams.

    All pairs' beams are processed together, each beam in its own window of rows (from
    before the target's highlight to the seabed after its shadow), as columns of one
    block. Empty windows and dark levels give NaN and infinities, which the tests below
    reject, so numpy's warnings about them are off here.
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        return _edges_quiet(segmentation, pairs, cfg)


def _last_true(
    mask: NDArray[np.bool_], stop: int, cols: NDArray[np.intp]
) -> tuple[NDArray[np.intp], NDArray[np.bool_]]:
    """Per column, the last row before ``stop`` where a mask holds, and whether any does.

    ``mask`` holds that mask's rows reversed (its row i is row stop - 1 - i), so the
    search runs forwards; ``cols`` is ``arange(mask.shape[1])``.
    """
    back = mask.argmax(axis=0)
    return stop - 1 - back, mask[back, cols]


def _first_true(
    mask: NDArray[np.bool_], start: int, cols: NDArray[np.intp]
) -> tuple[NDArray[np.intp], NDArray[np.bool_]]:
    """Per column, the first row where ``mask`` holds (counted from row ``start``), and whether any does.

    ``cols`` is ``arange(mask.shape[1])``.
    """
    ahead = mask.argmax(axis=0)
    return start + ahead, mask[ahead, cols]


def _most(n_cut: NDArray[np.intp] | None, n_beams: NDArray[np.intp] | None, n_pairs: int) -> list[bool]:
    """Per pair, whether most of its beams are cut (``n_cut`` None: none is)."""
    if n_cut is None or n_beams is None:
        return [False] * n_pairs
    return [2 * c > b for c, b in zip(n_cut.tolist(), n_beams.tolist(), strict=True)]


@functools.lru_cache(maxsize=8)
def _bound_offsets(half: int, k_smooth: int, level_samples: int) -> NDArray[np.intp]:
    """What :func:`_edges_quiet` adds to its stack of per-beam rows, shape (9, 1) (read-only).

    Added to (s_first, s_last, s_last, s_last, s_first, s_last, s_first, middle, s_last)
    they give sa, sb, ba, bb, the two candidates of the core, the two of the end
    search's start, and its stop.
    """
    out = np.array([half, 1 - half, 1 + k_smooth, 1 + k_smooth + level_samples, k_smooth, 0, 0, 0, k_smooth + 2])
    out.flags.writeable = False
    return out[:, None]


#: The least rows (eb, ea) of the echo before the far top edge (see :func:`_echo_offsets`).
_ECHO_FIRST_ROWS = np.array([[1], [0]])
_ECHO_FIRST_ROWS.flags.writeable = False


@functools.lru_cache(maxsize=8)
def _echo_offsets(k_smooth: int, level_samples: int) -> NDArray[np.intp]:
    """What :func:`_edges_quiet` subtracts from the rough edge's row for the echo's rows (eb, ea), shape (2, 1)."""
    out = np.array([[k_smooth], [k_smooth + level_samples]])
    out.flags.writeable = False
    return out


def _edges_quiet(segmentation: Segmentation, pairs: Sequence[Pair], cfg: MeasureConfig) -> Edges:
    """:func:`find_edges` with numpy's divide and invalid warnings already off."""
    levels = segmentation.levels
    n_rows, n_cols = levels.shape
    half = cfg.smooth_samples // 2
    k_smooth = cfg.smooth_samples
    level_samples = cfg.level_samples
    n_pairs = len(pairs)
    centrals = [central_beams(pair.columns, cfg.central_fraction) for pair in pairs]
    beam_list = [c for central in centrals for c in central]
    if not beam_list:
        return no_edges([False] * n_pairs)
    # Beams per pair (None once beams are dropped), the beams' range and, per beam, its
    # pair and the labels of the pair's shadow and highlight.
    per_pair = [len(central) for central in centrals]
    counts: list[int] | None = per_pair
    beam_range = (min(beam_list), max(beam_list))
    beams = np.array(beam_list)
    owner, s_labels, t_labels = (
        np.array([(n, pair.shadow.label, pair.highlight.label) for n, pair in enumerate(pairs)])
        .repeat(per_pair, axis=0)
        .T
    )
    # The regions' first and last rows in those beams (see Segmentation.column_extents).
    s_last = segmentation.shadow_rows[1][s_labels, beams]
    if np.minimum.reduce(s_last) < 0:
        ok = s_last >= 0
        owner, beams, s_labels, t_labels, s_last = (v[ok] for v in (owner, beams, s_labels, t_labels, s_last))
        counts = None
        if beams.size == 0:
            return no_edges([False] * n_pairs)
    s_first = segmentation.shadow_rows[0][s_labels, beams]
    # The highlight's first row (where it is in the beam: -1 elsewhere) bounds the window below.
    t_first = segmentation.highlight_rows[0][t_labels, beams]
    if segmentation.row_step > 1:
        s_first, s_last = refine_shadow_rows(segmentation, beams, s_first, s_last, beam_range=beam_range)
    # The seabed just after the shadow, rows ba .. bb - 1; a beam where fewer than
    # `need` of them lie inside the window is cut (bb - ba is least for the deepest shadow).
    need = max(2, level_samples // 2)
    n_beams = n_cut = None
    last_max = int(np.maximum.reduce(s_last))
    if min(n_rows - (last_max + 1 + k_smooth), level_samples) < need:
        ba = s_last + 1 + k_smooth
        cut = np.minimum(n_rows, ba + level_samples) - ba < need
        n_beams = np.bincount(owner, minlength=n_pairs)
        n_cut = np.bincount(owner[cut], minlength=n_pairs)
        keep = ~cut
        owner, beams, t_first, s_first, s_last = (v[keep] for v in (owner, beams, t_first, s_first, s_last))
        counts = None
        if beams.size == 0:
            return no_edges(_most(n_cut, n_beams, n_pairs))
        last_max = int(np.maximum.reduce(s_last))
    # Linear power of the beams (each averaged with its neighbours), smoothed in range;
    # beam c's window starts at row lo[c], and p[i, c] belongs to row off[c] + i.
    # The window starts a little before the shadow (room for the target's echo level
    # before its far top edge), at lo = max(0, max(t_first, s_first - lead) - half), and
    # ends past the seabed window after the shadow, at min(n_rows, max(bb, s_last +
    # k_smooth + 2) + k_smooth) = min(n_rows, s_last + span) as level_samples >= 1.
    lead = 2 * k_smooth + level_samples + 2 * segmentation.row_step + EDGE_MARGIN_SAMPLES
    off = np.maximum(np.maximum(t_first, s_first - lead), half)
    lo = off - half
    span = 1 + 2 * k_smooth + level_samples
    if last_max + span <= n_rows:
        length = int(np.maximum.reduce(s_last - lo)) + span
    else:
        length = int(np.maximum.reduce(np.minimum(s_last + span, n_rows) - lo))
    if length < k_smooth + 2:
        return no_edges(_most(n_cut, n_beams, n_pairs))
    m = beams.size
    power = neighbour_power(segmentation, lo, beams, length, cfg.smooth_beams, beam_range=beam_range)
    cum = cumsum0(power)
    # (OpenCV's subtraction, the same differences, walks the strided sums faster)
    p = cast("NDArray[np.float64]", cv2.subtract(cum[k_smooth:], cum[:-k_smooth]))
    p /= k_smooth
    n_p = p.shape[0]
    cum_p = cumsum0(p)
    cols = np.arange(m)
    # Per beam, rows of p (one stack, one subtraction): the shadow inside (sa .. sb - 1)
    # and the seabed just after it (ba .. bb - 1, within the image), whose levels are
    # means (cum_p[b] - cum_p[a]) / (b - a); the shadow's core (s_first + k_smooth or,
    # if nearer, s_last); and the start (the shadow's middle, at least 1) and stop of
    # the search for its end.
    rows_p = np.array(
        (s_first, s_last, s_last, s_last, s_first, s_last, s_first, (s_first + s_last) // 2, s_last)
    ) + _bound_offsets(half, k_smooth, level_samples) - off
    sa, sb, ba, bb, core_first, core_last, start_first, start_middle, stop = rows_p
    if last_max + 1 + k_smooth + level_samples > n_rows:
        np.minimum(bb, n_rows - off, out=bb)
    short = sb <= sa
    if np.logical_or.reduce(short):
        # (a shadow too short for the smoothing: all its rows)
        sa[short] = start_first[short]
        sb[short] = core_last[short] + 1
    bounds = clamp(rows_p[:4], 0, n_p)
    at = cum_p[bounds, cols]
    levels_sb = (at[1::2] - at[::2]) / (bounds[1::2] - bounds[::2])
    shadow_level, seabed_level = levels_sb
    # Where the "seabed" after the shadow is hardly brighter than the shadow, the shadow
    # runs on into the dark beyond the band's far edge: cut there.
    levels_db = 10.0 * np.log10(levels_sb)
    contrast = levels_db[1] - levels_db[0] >= cfg.end_contrast_db
    if not np.logical_and.reduce(contrast):
        # A shadow cut by the far edge is cut across its width: most of its beams.
        if n_beams is None:
            n_beams = np.bincount(owner, minlength=n_pairs)
        beyond = np.bincount(owner[~contrast], minlength=n_pairs)
        n_cut = beyond if n_cut is None else n_cut + beyond
    far_cut = _most(n_cut, n_beams, n_pairs)
    # The target's echo just before its far top edge (which may be weaker than the
    # highlight's brightest part, e.g. a top seen at grazing incidence): find the edge
    # roughly as the last sample above the dB-midpoint of shadow and seabed, then take
    # the echo level a smoothing width before it. Both searches end at the core of the
    # shadow: only the rows before the farthest core are searched (backwards), and
    # each beam's own core bounds the search only where the cores differ.
    core = np.minimum(core_first, core_last)
    core_min, core_max = int(np.minimum.reduce(core)), int(np.maximum.reduce(core))
    rough_level = np.sqrt(shadow_level * seabed_level)
    n_near = min(max(core_max + 1, 1), n_p)  # rows idx <= core
    near = p[n_near - 1 :: -1] >= rough_level
    if core_min < n_near - 1:
        near &= np.arange(n_near - 1, -1, -1)[:, None] <= core
    rough, has_rough = _last_true(near, n_near, cols)
    # The echo's rows ea .. eb - 1 (never past the rows of p: rough < n_p), as a stack
    # (eb, ea), and the midpoints of the far top edge (echo and shadow) and of the end
    # (shadow and seabed).
    echo_rows = np.maximum(rough - _echo_offsets(k_smooth, level_samples), _ECHO_FIRST_ROWS)
    at = cum_p[echo_rows, cols]
    echo_level = (at[0] - at[1]) / (echo_rows[0] - echo_rows[1])
    mids = 0.5 * (np.array((echo_level, seabed_level)) + shadow_level)
    mid_top = mids[0]
    n_top = min(max(core_max, 1), n_p)  # rows idx < core
    above = p[n_top - 1 :: -1] >= mid_top
    if core_min < n_top:
        above &= np.arange(n_top - 1, -1, -1)[:, None] < core
    k_top, has_top = _last_true(above, n_top, cols)
    # The shadow end: searched from the middle of the shadow to just past its last row,
    # in the rows c0 .. c1 - 1 that hold every beam's search.
    start = np.maximum(np.maximum(start_first, start_middle), 1)
    c0 = min(int(np.minimum.reduce(start)), n_p - 1)
    c1 = max(min(int(np.maximum.reduce(stop)), n_p), c0 + 1)
    # The first crossing from c0 is the one sought where it lies in its beam's search;
    # before the search's start (rarely: the search starts inside the shadow) the rows
    # before each start are masked and the search is run again; at or past its stop,
    # the beam has no shadow end.
    k_end, has_end = _first_true(p[c0:c1] >= mids[1], c0, cols)
    if np.logical_or.reduce(has_end & (k_end < start)):
        idx_far = np.arange(c0, c1)[:, None]
        k_end, has_end = _first_true((p[c0:c1] >= mids[1]) & (idx_far >= start), c0, cols)
    has_end &= k_end < stop
    # The samples either side of both crossings, in one gather: k_top + 1 <= n_top is
    # past the rows of p only when n_top = n_p, and k_end >= c0 >= 1 (start >= 1 and
    # n_p >= 3), so row k_end - 1 is inside p. Each crossing lies between sample a
    # (at row k) and sample b (at row k + 1): the edge is k + (a - mid) / (a - b), the
    # shadow end's as before_end + (mid - a) / (b - a) with both signs turned (the
    # same value: IEEE subtraction and division are symmetric in sign).
    after_top = k_top + 1 if n_top < n_p else np.minimum(k_top + 1, n_p - 1)
    k_rows = np.array((k_top, k_end - 1, after_top, k_end))
    samples = p[k_rows, cols]
    a, b = samples[:2], samples[2:]
    edge_rows = k_rows[:2] + (a - mids) / (a - b)
    # Kept: beams with both edges, in order, between levels that make sense
    # (shadow < seabed, shadow < echo, ...; one comparison of two stacks).
    good = np.logical_and.reduce(
        np.array((shadow_level, shadow_level, b[0], a[1], edge_rows[0]))
        < np.array((seabed_level, echo_level, mid_top, mids[1], edge_rows[1]))
    )
    good &= np.logical_and.reduce(np.array((has_rough, has_top, has_end, contrast)))
    rows = edge_rows + off
    if np.logical_and.reduce(good):
        if counts is None:
            counts = np.bincount(owner, minlength=n_pairs).tolist()
        return Edges(beams, rows, counts, far_cut)
    return Edges(beams[good], rows[:, good], np.bincount(owner[good], minlength=n_pairs).tolist(), far_cut)
