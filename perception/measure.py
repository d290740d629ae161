"""Where a target's shadow starts and ends, per beam, to a fraction of a range sample.

For each beam through the middle of a paired shadow (:mod:`perception.pairing`):

- the shadow START is the highlight-to-shadow transition, the target's far top edge (the
  paper's critical line): the range where the smoothed, row-normalised intensity falls
  through the midpoint between the highlight level just before the edge and the shadow
  level;
- the shadow END is the shadow-to-seabed transition: the range where it rises through
  the midpoint between the shadow level and the seabed level just after the shadow.

Both crossings are interpolated linearly between the two samples that straddle the
midpoint. A symmetric smoothing kernel moves neither crossing, so the sub-sample edge is
unbiased for a step between flat levels. The beams are combined by their median; the
spread between beams gives the standard deviation.

Ranges are slant ranges from the sonar's acoustic centre (range ZERO), read from the
frame's ``range_m`` axis at the fractional row, never counted from the window start.

A shadow cut by the insonified band, the range window or the edge of the fan is flagged
``truncated`` with the reason, and is not to be used for a height. The band's far edge
is judged beam by beam from the image, not from the band's estimated edge: where the
"seabed" just after the shadow is less than ``end_contrast_db`` brighter than the shadow,
the shadow runs on into the dark beyond the band; when that holds in most of the pair's
beams the shadow is truncated there.

On a detection grid (:mod:`perception.segmentation`) the shadow's first and last rows in
each beam are known to the grid's row step; they are refined at full resolution here,
only in the beams measured, before the edges are sought.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import cast

import cv2
import numpy as np
from numpy.typing import NDArray

from perception.pairing import Pair
from perception.segmentation import Segmentation

#: Reasons, by field-of-view flag, why a shadow cannot give a height.
TRUNCATION_REASONS = {
    "first_beam": "shadow or highlight touches the first beam (edge of the fan)",
    "last_beam": "shadow or highlight touches the last beam (edge of the fan)",
    "window_start": "shadow starts at the range window's start",
    "window_end": "shadow runs to the end of the range window",
    "band_near": "shadow starts at the near edge of the insonified band",
    "band_far": "shadow runs beyond the far edge of the insonified band",
}

#: Field-of-view flags that cut a measurement (a highlight cut at the window start does not).
_CUTTING_FLAGS = ("first_beam", "last_beam", "window_end", "band_near", "band_far")


#: Extra samples of the echo before a shadow's first row read for its top edge.
EDGE_MARGIN_SAMPLES = 8


@dataclass(frozen=True)
class MeasureConfig:
    """Settings of :func:`measure_pair`.

    Attributes
    ----------
    central_fraction : float
        Fraction of the pair's beams, around the middle, used for the edges.
    min_beams : int
        Fewest beams with both edges found for a measurement.
    level_samples : int
        Samples averaged (median) for the highlight, shadow and seabed levels.
    smooth_samples : int
        Range smoothing (box, samples) of the linear power profiles; edges are also
        searched this far around the region boundaries.
    smooth_beams : int
        Beams averaged (centred, odd) into each beam's power profile.
    end_contrast_db : float
        The seabed just after a shadow must be this much brighter than the shadow, dB;
        where it is not, the shadow runs on into the dark beyond the band's far edge and
        that beam is cut (most beams cut: the shadow is truncated).
    """

    central_fraction: float = 0.6
    min_beams: int = 1
    level_samples: int = 6
    smooth_samples: int = 5
    smooth_beams: int = 3
    end_contrast_db: float = 6.0

    def __post_init__(self) -> None:
        if not 0 < self.central_fraction <= 1:
            raise ValueError(f"central_fraction must be in (0, 1], got {self.central_fraction}")
        if self.min_beams < 1 or self.level_samples < 1 or self.smooth_samples < 1:
            raise ValueError("min_beams, level_samples and smooth_samples must be >= 1")
        if self.smooth_beams < 1 or self.smooth_beams % 2 == 0:
            raise ValueError(f"smooth_beams must be an odd integer >= 1, got {self.smooth_beams}")
        if not self.end_contrast_db > 0:
            raise ValueError(f"end_contrast_db must be > 0 dB, got {self.end_contrast_db}")


@dataclass(frozen=True)
class ShadowMeasurement:
    """One target's shadow in one frame.

    Attributes
    ----------
    azimuth_rad : float
        Mean azimuth of the beams used, rad, positive to starboard.
    r_top_m, r_end_m : float
        Slant ranges of the shadow start (far top edge) and end from range zero, m
        (median over the beams used); NaN when not measurable.
    sigma_r_m : float
        1-sigma of each of the two ranges, m (from the spread between beams, floored at a
        quarter sample).
    highlight_range_m : float
        Slant range of the highlight's nearest sample, m.
    columns : tuple of int
        The beams (image columns) used.
    r_top_per_beam_m, r_end_per_beam_m : tuple of float
        Per-beam edges of those beams, m.
    truncated : bool
        True when the shadow is cut by an edge and must not give a height.
    reason : str or None
        Why it is truncated or not measurable.
    overlap : float
        Algorithm 1's overlap ratio of the pair.
    shadow_width_beams : int
        Number of beams the shadow spans.
    """

    azimuth_rad: float
    r_top_m: float
    r_end_m: float
    sigma_r_m: float
    highlight_range_m: float
    columns: tuple[int, ...]
    r_top_per_beam_m: tuple[float, ...]
    r_end_per_beam_m: tuple[float, ...]
    truncated: bool
    reason: str | None
    overlap: float
    shadow_width_beams: int

    @property
    def usable(self) -> bool:
        """True when the measurement can give a height."""
        return not self.truncated and math.isfinite(self.r_top_m) and math.isfinite(self.r_end_m)


def _central(columns: tuple[int, ...], fraction: float) -> list[int]:
    cols = sorted(columns)
    n = len(cols)
    keep = max(1, int(round(n * fraction)))
    start = (n - keep) // 2
    return cols[start : start + keep]


@dataclass(frozen=True)
class _Edges:
    """The edges found in the pairs' central beams, all pairs' beams in one array.

    ``columns`` lists the beams with both edges, grouped by pair in the pairs' order:
    ``counts[n]`` of them belong to pair ``n``; ``rows[0]`` and ``rows[1]`` hold their
    shadow starts and ends (fractional rows). ``far_cut[n]`` is True when most of pair
    ``n``'s beams are cut by the band's far edge.
    """

    columns: NDArray[np.intp]
    rows: NDArray[np.float64]
    counts: list[int]
    far_cut: list[bool]


def _no_edges(far_cut: list[bool]) -> _Edges:
    """The :class:`_Edges` of pairs none of whose beams gave both edges."""
    return _Edges(np.zeros(0, dtype=np.intp), np.zeros((2, 0)), [0] * len(far_cut), far_cut)


def _clamp(values: NDArray[np.intp], low: int, high: int) -> NDArray[np.intp]:
    """``values`` clamped to [low, high] (two ufunc calls, cheaper than ``np.clip``)."""
    return np.minimum(np.maximum(values, low), high)


def _window_mean(
    cum: NDArray[np.float64], bounds: NDArray[np.intp], cols: NDArray[np.intp]
) -> NDArray[np.float64]:
    """Per window j, mean of the rows [bounds[0, j], bounds[1, j]) of column ``cols[j]``.

    ``cum`` is the cumulative sum (:func:`_cumsum0`) of the array averaged. An empty
    window gives NaN (call with numpy's invalid warnings off).
    """
    a, b = _clamp(bounds, 0, cum.shape[0] - 1)
    at = cum[(a, b), cols]
    return (at[1] - at[0]) / (b - a)


#: Most channels of an OpenCV image (the columns :func:`_cumsum0` hands to OpenCV at once).
_CV_MAX_CHANNELS = 128


def _cumsum0(values: NDArray[np.float64]) -> NDArray[np.float64]:
    """Cumulative sums down the rows with a row of zeros first, shape (n + 1, m).

    OpenCV's integral image of the values taken as one column of m-channel pixels holds
    these sums in its second column: per channel, each row's sum is the previous one
    plus (zero plus) the value, the additions of ``np.cumsum`` in the same order, so the
    same sums (the values summed here are never -0.0), in about half numpy's time.
    Wider arrays than OpenCV's channels allow take ``np.cumsum``.
    """
    n, m = values.shape
    if m <= _CV_MAX_CHANNELS:
        image = np.ascontiguousarray(values).reshape(n, 1, m)
        return cast(NDArray[np.float64], cv2.integral(image, sdepth=cv2.CV_64F).reshape(n + 1, 2, m)[:, 1])
    out = np.empty((n + 1, m))
    out[0] = 0.0
    np.cumsum(values, axis=0, out=out[1:])
    return out


def _smoothed_windows(
    segmentation: Segmentation, start_rows: NDArray[np.intp], length: int, beams: NDArray[np.intp]
) -> NDArray[np.float64]:
    """``segmentation.smoothed_windows(start_rows, length, beams)``: the same sums, made faster.

    The beams are added in float64 one after another by one reduction, and the running
    sums down the rows come from :func:`_cumsum0`.
    """
    n_rows, n_cols = segmentation.levels.shape
    k_s, k_b = segmentation.smooth_samples, segmentation.smooth_beams
    h_s, h_b = k_s // 2, k_b // 2
    rows = _clamp(start_rows - h_s + np.arange(length + 2 * h_s)[:, None], 0, n_rows - 1)
    cols = _clamp(beams + np.arange(-h_b, h_b + 1)[:, None], 0, n_cols - 1)
    taken = segmentation.levels.ravel().take((rows * n_cols)[None, :, :] + cols[:, None, :])
    cum = _cumsum0(np.add.reduce(taken, axis=0, dtype=np.float64))
    return (cum[k_s:] - cum[:-k_s]) / (k_s * k_b)


def _refine_shadow_rows(
    segmentation: Segmentation,
    beams: NDArray[np.intp],
    s_first: NDArray[np.intp],
    s_last: NDArray[np.intp],
) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """A shadow's first and last full-resolution row in each beam, from its grid cells.

    On a detection grid of step d the shadow's first and last cells in a beam are known;
    the grid row's sample (``d i + d // 2``) is shadow, and the run of full-resolution
    shadow rows (``smoothed < shadow_limit``, inside the band) through it is followed to
    its ends, which lie within the neighbouring cells.
    """
    d = segmentation.row_step
    n_rows = segmentation.levels.shape[0]
    n = beams.size
    # Two windows per beam, one per column of the arrays below, from d rows before the
    # first cell (columns 0 .. n - 1) and from d - 1 rows before the last one (columns
    # n .. 2n - 1). Searched: the rows before the first cell's sampled row (d i + d // 2),
    # backwards, for the last row that is not shadow; the n_after rows after the last
    # cell's sampled row (d // 2 in its window), forwards, for the first.
    n_before = d + d // 2
    n_after = 2 * d - d // 2 - 1
    starts = np.concatenate((s_first - d, s_last - d + 1))
    both = np.concatenate((beams, beams))
    # (one row more than searched, so that both searches have n_before rows)
    rows = np.arange(2 * d + 1)[:, None] + starts
    smoothed = _smoothed_windows(segmentation, starts, 2 * d + 1, both)
    # (rows outside the image are not shadow below, whatever their limit)
    limit = np.interp(rows, segmentation.level_rows, segmentation.grid_shadow_limit)
    # Shadow rows lie inside the image and inside the band.
    band_start = np.maximum(segmentation.band_start_rows[both], 0)
    band_stop = np.minimum(segmentation.band_stop_rows[both], n_rows - 1)
    not_shadow = ~((smoothed < limit) & (rows >= band_start) & (rows <= band_stop))
    search = np.concatenate(
        (not_shadow[n_before - 1 :: -1, :n], not_shadow[d // 2 + 1 : d // 2 + 1 + n_before, n:]), axis=1
    )
    search[n_after:, n:] = False
    k, found = _first_true(search, 0, np.arange(2 * n))
    first = np.where(found[:n], s_first + d // 2 - k[:n], np.maximum(s_first - d, 0))
    last = np.where(found[n:], starts[n:] + d // 2 + k[n:], np.minimum(s_last + d, n_rows - 1))
    return first.astype(np.intp, copy=False), last.astype(np.intp, copy=False)


def _edges(segmentation: Segmentation, pairs: Sequence[Pair], cfg: MeasureConfig) -> _Edges:
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
    back = np.argmax(mask, axis=0)
    return stop - 1 - back, mask[back, cols]


def _first_true(
    mask: NDArray[np.bool_], start: int, cols: NDArray[np.intp]
) -> tuple[NDArray[np.intp], NDArray[np.bool_]]:
    """Per column, the first row where ``mask`` holds (counted from row ``start``), and whether any does.

    ``cols`` is ``arange(mask.shape[1])``.
    """
    ahead = np.argmax(mask, axis=0)
    return start + ahead, mask[ahead, cols]


def _edges_quiet(segmentation: Segmentation, pairs: Sequence[Pair], cfg: MeasureConfig) -> _Edges:
    """:func:`_edges` with numpy's divide and invalid warnings already off."""
    n_rows, n_cols = segmentation.levels.shape
    half = cfg.smooth_samples // 2
    k_smooth = cfg.smooth_samples
    n_pairs = len(pairs)
    owner_list: list[int] = []
    beam_list: list[int] = []
    shadow_list: list[int] = []
    highlight_list: list[int] = []
    for n, pair in enumerate(pairs):
        central = _central(pair.columns, cfg.central_fraction)
        owner_list += [n] * len(central)
        beam_list += central
        shadow_list += [pair.shadow.label] * len(central)
        highlight_list += [pair.highlight.label] * len(central)
    if not beam_list:
        return _no_edges([False] * n_pairs)
    beams = np.array(beam_list, dtype=np.intp)
    s_labels = np.array(shadow_list, dtype=np.intp)
    t_labels = np.array(highlight_list, dtype=np.intp)
    # The regions' first and last rows in those beams (see Segmentation.column_extents).
    s_last = segmentation.shadow_rows[1][s_labels, beams]
    owner = np.array(owner_list, dtype=np.intp)
    ok = s_last >= 0
    if not ok.all():
        owner, beams, s_labels, t_labels, s_last = owner[ok], beams[ok], s_labels[ok], t_labels[ok], s_last[ok]
        if beams.size == 0:
            return _no_edges([False] * n_pairs)
    s_first = segmentation.shadow_rows[0][s_labels, beams]
    # The highlight's first row (where it is in the beam) bounds the window below.
    t_first = np.maximum(segmentation.highlight_rows[0][t_labels, beams], 0)
    if segmentation.row_step > 1:
        s_first, s_last = _refine_shadow_rows(segmentation, beams, s_first, s_last)
    # The seabed just after the shadow; a beam where it lies beyond the window is cut.
    ba = s_last + 1 + k_smooth
    bb = np.minimum(n_rows, ba + cfg.level_samples)
    cut = bb - ba < max(2, cfg.level_samples // 2)
    n_beams = np.bincount(owner, minlength=n_pairs)
    n_cut = np.bincount(owner[cut], minlength=n_pairs)
    if cut.any():
        keep = ~cut
        owner, beams, t_first, s_first, s_last, ba, bb = (
            v[keep] for v in (owner, beams, t_first, s_first, s_last, ba, bb)
        )
    if beams.size == 0:
        return _no_edges([bool(2 * c > b) for c, b in zip(n_cut, n_beams, strict=True)])
    # Linear power of the beams (each averaged with its neighbours), smoothed in range;
    # beam c's window starts at row lo[c], and p[i, c] belongs to row off[c] + i.
    # The window starts a little before the shadow (room for the target's echo level
    # before its far top edge) and ends past the seabed window after the shadow.
    lead = 2 * k_smooth + cfg.level_samples + 2 * segmentation.row_step + EDGE_MARGIN_SAMPLES
    lo = np.maximum(0, np.maximum(t_first, s_first - lead) - half)
    hi = np.minimum(n_rows, np.maximum(bb, s_last + k_smooth + 2) + k_smooth)
    length = int((hi - lo).max())
    if length < k_smooth + 2:
        return _no_edges([bool(2 * c > b) for c, b in zip(n_cut, n_beams, strict=True)])
    m = beams.size
    b_half = cfg.smooth_beams // 2
    shifts = _clamp(beams + np.arange(-b_half, b_half + 1)[:, None], 0, n_cols - 1)
    # index[j, i, c]: row i of beam c's window in its j-th neighbour (one plane per
    # neighbour); rows past the image repeat its last row.
    index = (lo * n_cols + shifts)[:, None, :] + np.arange(0, length * n_cols, n_cols)[:, None]
    if int(lo.max()) + length > n_rows:
        index = np.minimum(index, (n_rows - 1) * n_cols + shifts[:, None, :])
    block = segmentation.power_take(index.reshape(cfg.smooth_beams, length * m))
    # The neighbours added one after another (a reduction over the first axis), then scaled.
    power = np.add.reduce(block.reshape(cfg.smooth_beams, length, m), axis=0)
    power *= 1.0 / cfg.smooth_beams
    cum = _cumsum0(power)
    p = (cum[k_smooth:] - cum[:-k_smooth]) / k_smooth
    n_p = p.shape[0]
    off = lo + half
    cum_p = _cumsum0(p)
    cols = np.arange(m)
    # Levels: shadow inside, seabed just after the shadow (both in one pass).
    sa, sb = s_first + half, s_last + 1 - half
    short = sb <= sa
    sa = np.where(short, s_first, sa)
    sb = np.where(short, s_last + 1, sb)
    bounds = (np.array((sa, ba, sb, bb)) - off).reshape(2, 2 * m)
    levels = _window_mean(cum_p, bounds, np.concatenate((cols, cols)))
    shadow_level, seabed_level = levels[:m], levels[m:]
    # Where the "seabed" after the shadow is hardly brighter than the shadow, the shadow
    # runs on into the dark beyond the band's far edge: cut there.
    levels_db = 10.0 * np.log10(levels)
    beyond = ~(levels_db[m:] - levels_db[:m] >= cfg.end_contrast_db)
    # A shadow cut by the far edge is cut across its width: most of its beams.
    n_cut = n_cut + np.bincount(owner[beyond], minlength=n_pairs)
    far_cut = [bool(2 * c > b) for c, b in zip(n_cut.tolist(), n_beams.tolist(), strict=True)]
    # The target's echo just before its far top edge (which may be weaker than the
    # highlight's brightest part, e.g. a top seen at grazing incidence): find the edge
    # roughly as the last sample above the dB-midpoint of shadow and seabed, then take
    # the echo level a smoothing width before it. Both searches end at the core of the
    # shadow: only the rows before the farthest core are searched (backwards), and
    # each beam's own core bounds the search only where the cores differ.
    core = np.minimum(s_first + k_smooth, s_last) - off
    core_min, core_max = int(core.min()), int(core.max())
    rough_level = np.sqrt(shadow_level * seabed_level)
    n_near = min(max(core_max + 1, 1), n_p)  # rows idx <= core
    near = p[n_near - 1 :: -1] >= rough_level
    if core_min < n_near - 1:
        near &= np.arange(n_near - 1, -1, -1)[:, None] <= core
    rough, has_rough = _last_true(near, n_near, cols)
    hb = rough - k_smooth
    echo_bounds = np.array((np.maximum(0, hb - cfg.level_samples), np.maximum(1, hb)))
    echo_level = _window_mean(cum_p, echo_bounds, cols)
    mid_top = 0.5 * (echo_level + shadow_level)
    n_top = min(max(core_max, 1), n_p)  # rows idx < core
    above = p[n_top - 1 :: -1] >= mid_top
    if core_min < n_top:
        above &= np.arange(n_top - 1, -1, -1)[:, None] < core
    k_top, has_top = _last_true(above, n_top, cols)
    a_top, b_top = p[k_top, cols], p[np.minimum(k_top + 1, n_p - 1), cols]
    top = k_top + (a_top - mid_top) / (a_top - b_top)
    # The shadow end: searched from the middle of the shadow to just past its last row,
    # in the rows c0 .. c1 - 1 that hold every beam's search.
    mid_end = 0.5 * (shadow_level + seabed_level)
    start = np.maximum(np.maximum(s_first, (s_first + s_last) // 2) - off, 1)
    stop = s_last + k_smooth + 2 - off
    c0 = min(int(start.min()), n_p - 1)
    c1 = max(min(int(stop.max()), n_p), c0 + 1)
    idx_far = np.arange(c0, c1)[:, None]
    k_end, has_end = _first_true((p[c0:c1] >= mid_end) & (idx_far >= start) & (idx_far < stop), c0, cols)
    # k_end >= c0 >= 1 (start >= 1 and n_p >= 3): row k_end - 1 is inside p.
    a_end, b_end = p[k_end - 1, cols], p[k_end, cols]
    end = (k_end - 1) + (mid_end - a_end) / (b_end - a_end)
    good = np.logical_and.reduce((
        shadow_level < seabed_level, has_rough, echo_level > shadow_level,
        has_top, b_top < mid_top, has_end, k_end >= 1, a_end < mid_end, end > top, ~beyond,
    ))
    kept = np.flatnonzero(good)
    rows = (np.array((top, end)) + off)[:, kept]
    return _Edges(beams[kept], rows, np.bincount(owner[kept], minlength=n_pairs).tolist(), far_cut)


def measure_pair(
    segmentation: Segmentation,
    pair: Pair,
    *,
    range_m: NDArray[np.float64],
    beam_azimuth_rad: NDArray[np.float64],
    config: MeasureConfig | None = None,
) -> ShadowMeasurement:
    """Measure the shadow start and end of one pair, per beam, and combine the beams.

    Parameters
    ----------
    segmentation : Segmentation
        The frame's segmentation (its image levels are read, not modified).
    pair : Pair
        A highlight-shadow pair of that segmentation.
    range_m : ndarray, shape (n_samples,)
        Slant range of each row from range zero, m.
    beam_azimuth_rad : ndarray, shape (n_beams,)
        Azimuth of each beam, rad.
    config : MeasureConfig, optional

    Returns
    -------
    ShadowMeasurement
    """
    return measure_pairs(
        segmentation, [pair], range_m=range_m, beam_azimuth_rad=beam_azimuth_rad, config=config
    )[0]


def _measurement(
    segmentation: Segmentation,
    pair: Pair,
    *,
    columns: list[int],
    top_m: list[float],
    end_m: list[float],
    azimuth_rad: NDArray[np.float64],
    far_cut: bool,
    dr: float,
    beam_azimuth_rad: NDArray[np.float64],
    range_m: NDArray[np.float64],
    config: MeasureConfig,
) -> ShadowMeasurement:
    """Combine one pair's per-beam edges (m, and the azimuths of those beams) into its measurement.

    ``dr`` is the range step, m.
    """
    cfg = config
    n_rows = segmentation.levels.shape[0]
    t, s = pair.highlight, pair.shadow
    # Whether the far edge of the band cuts the shadow is decided beam by beam from the
    # seabed after it (``far_cut``), not from the band's estimated edge.
    cutting = [f for f in pair.fov_flags if f in _CUTTING_FLAGS and f != "band_far"]
    if far_cut and "band_far" not in cutting and "window_end" not in cutting:
        cutting.append("band_far" if s.row_stop < n_rows else "window_end")
    highlight_range = float(range_m[t.row_start])
    width = s.n_cols
    if len(columns) < cfg.min_beams:
        reason = "; ".join(TRUNCATION_REASONS[f] for f in cutting) if cutting else (
            "no beam with both shadow edges found"
        )
        azimuth = _mean(beam_azimuth_rad[list(pair.columns)])
        return ShadowMeasurement(
            azimuth_rad=azimuth, r_top_m=math.nan, r_end_m=math.nan, sigma_r_m=math.nan,
            highlight_range_m=highlight_range, columns=(), r_top_per_beam_m=(),
            r_end_per_beam_m=(), truncated=bool(cutting), reason=reason,
            overlap=pair.overlap, shadow_width_beams=width,
        )
    n = len(columns)
    r_top, spread_top = _median_and_spread(top_m)
    r_end, spread_end = _median_and_spread(end_m)
    spread = max(spread_top, spread_end)
    sigma = max(1.2533 * spread / math.sqrt(n), 0.25 * dr / math.sqrt(n))
    return ShadowMeasurement(
        azimuth_rad=_mean(azimuth_rad),
        r_top_m=r_top,
        r_end_m=r_end,
        sigma_r_m=sigma,
        highlight_range_m=highlight_range,
        columns=tuple(columns),
        r_top_per_beam_m=tuple(top_m),
        r_end_per_beam_m=tuple(end_m),
        truncated=bool(cutting),
        reason="; ".join(TRUNCATION_REASONS[f] for f in cutting) if cutting else None,
        overlap=pair.overlap,
        shadow_width_beams=width,
    )


@functools.lru_cache(maxsize=8)
def _rows_axis(n_rows: int) -> NDArray[np.float64]:
    """Row numbers 0 .. n_rows - 1 as floats, shape (n_rows,), read-only (cached per frame size)."""
    out = np.arange(n_rows, dtype=np.float64)
    out.flags.writeable = False
    return out


def _mean(values: NDArray[np.float64]) -> float:
    """``float(np.mean(values))`` of a 1-D float64 array (the same sum), without its wrapper."""
    return float(np.add.reduce(values) / values.size)


def _median_and_spread(values: list[float]) -> tuple[float, float]:
    """Median of a short list, and 1.4826 x its median absolute deviation (0 for a single value)."""
    middle = _median(values)
    if len(values) < 2:
        return middle, 0.0
    return middle, 1.4826 * _median([abs(v - middle) for v in values])


def _median(values: list[float]) -> float:
    """Median of a short list (cheaper than ``np.median`` for a few values)."""
    items = sorted(values)
    n = len(items)
    return float(items[n // 2]) if n % 2 else 0.5 * (items[n // 2 - 1] + items[n // 2])


def measure_pairs(
    segmentation: Segmentation,
    pairs: Sequence[Pair],
    *,
    range_m: NDArray[np.float64],
    beam_azimuth_rad: NDArray[np.float64],
    config: MeasureConfig | None = None,
) -> list[ShadowMeasurement]:
    """:func:`measure_pair` for every pair of a frame, their beams processed together."""
    cfg = config or MeasureConfig()
    edges = _edges(segmentation, pairs, cfg)
    n_all = edges.columns.size
    # All pairs' edges to metres in one interpolation (starts, then ends), then plain
    # Python per pair.
    metres = np.interp(edges.rows.ravel(), _rows_axis(segmentation.levels.shape[0]), range_m).tolist()
    azimuths = beam_azimuth_rad[edges.columns]
    columns = edges.columns.tolist()
    dr = float(range_m[-1] - range_m[0]) / (range_m.size - 1)
    out = []
    start = 0
    for pair, count, far_cut in zip(pairs, edges.counts, edges.far_cut, strict=True):
        stop = start + count
        out.append(_measurement(
            segmentation, pair, columns=columns[start:stop], top_m=metres[start:stop],
            end_m=metres[n_all + start : n_all + stop], azimuth_rad=azimuths[start:stop], far_cut=far_cut,
            dr=dr, beam_azimuth_rad=beam_azimuth_rad, range_m=range_m, config=cfg,
        ))
        start = stop
    return out
