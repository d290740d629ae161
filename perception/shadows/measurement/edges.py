"""A shadow's start and end, and its target's near edge, per beam, to a fraction of a sample.

For each pair (:mod:`perception.shadows.pairing.pair`) the beams through the middle of its
shadow are read at full resolution, one beam each (no averaging across beams: an edge
oblique to the beams would smear), as linear echo power:

1. *Rough edges*, beam by beam, in the profile smoothed over ``smooth_m``: the levels
   beside each edge are the means over ``level_m`` of the echo before the shadow, the
   shadow's interior and the seabed after it (the detection grid says where each lies to a
   grid step); the shadow's start is the last sample before its interior above the
   geometric mean of the echo and shadow levels, its end the first sample after its
   interior above the geometric mean of the shadow and seabed levels; likewise the
   target's near edge (a highlight's start) from the seabed before it.
2. *Cut beams*: where the seabed after the shadow does not stand ``cut_contrast_sigmas``
   spreads above the shadow, the shadow runs into the dark beyond the band's far edge (or
   the window's end) in that beam; where the echo before it does not, the shadow starts
   in the dark before the band.
3. *The fitted edge* of each pair: the beams' profiles are aligned on their rough edges
   and averaged (speckle averages out; the alignment's own errors only widen the blur),
   and a blurred step is fitted to the average (:func:`perception.shadows.measurement.stepfit.fit_steps`):
   its edge is unbiased for any blur symmetric about the edge, however wide, and
   whatever the levels (the midpoint of levels taken beside an edge is not, once the blur
   reaches the windows). Each beam's edge is its rough edge plus the fitted offset.

Rows are image rows (fractional); conversion to slant range is the caller's.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from perception.shadows.measurement.config import MeasureConfig
from perception.shadows.measurement.stepfit import fit_steps
from perception.shadows.pairing.pair import Pair
from perception.shadows.segmentation.result import Segmentation

FloatArray = NDArray[np.float64]

#: Largest fitted half window, samples.
MAX_FIT_HALF_SAMPLES = 48
#: Starting blur of the step fit, samples.
BLUR0_SAMPLES = 1.5


def central_beams(columns: tuple[int, ...], fraction: float) -> list[int]:
    """The middle ``fraction`` of a pair's beams (at least one), in order."""
    cols = sorted(columns)
    n = len(cols)
    keep = max(1, int(round(n * fraction)))
    start = (n - keep) // 2
    return cols[start : start + keep]


@dataclass(frozen=True)
class PairEdges:
    """The edges of one pair.

    Attributes
    ----------
    columns : tuple of int
        The central beams with both edges (not cut).
    top_rows, end_rows : ndarray, shape (len(columns),)
        Fractional rows of the shadow's start and end in those beams.
    near_rows : ndarray, shape (len(columns),)
        Fractional row of the target's near edge (the highlight's start) in those beams,
        NaN where the beam has no highlight.
    top_std_rows, end_std_rows, near_std_rows : float
        1-sigma of the pair's mean edges, rows (NaN when not measured).
    blur_rows : float
        Fitted blur of the shadow's start, rows.
    n_central : int
        Central beams looked at.
    cut_near, cut_far : int
        Central beams without echo before the shadow, without seabed after it.
    echo_db, depth_db, seabed_db : float
        Levels about the shadow (dB, relative): echo before its start over the shadow,
        seabed after its end over the shadow, and the seabed after it over the echo before.
    """

    columns: tuple[int, ...]
    top_rows: FloatArray
    end_rows: FloatArray
    near_rows: FloatArray
    top_std_rows: float
    end_std_rows: float
    near_std_rows: float
    blur_rows: float
    n_central: int
    cut_near: int
    cut_far: int
    echo_db: float
    depth_db: float
    seabed_db: float


def _window_means(cum: FloatArray, start: NDArray[np.intp], stop: NDArray[np.intp]) -> FloatArray:
    """Mean of each column of the values behind ``cum`` (cumulative sums with a zero row
    first, shape (M + 1, n)) over its rows ``start .. stop - 1`` (clamped; NaN when empty)."""
    m = cum.shape[0] - 1
    a = np.clip(start, 0, m)
    b = np.clip(stop, 0, m)
    cols = np.arange(cum.shape[1])
    total = cum[b, cols] - cum[a, cols]
    count = b - a
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(count > 0, total / np.maximum(count, 1), np.nan)


def _running_means(cum: FloatArray, length: int) -> FloatArray:
    """Means of ``length`` consecutive rows starting at each row (fewer at the end), shape (M, n)."""
    m = cum.shape[0] - 1
    start = np.arange(m)
    stop = np.minimum(start + length, m)
    return (cum[stop] - cum[start]) / (stop - start)[:, None]


def _last_at_least(q: FloatArray, level: FloatArray, start: NDArray[np.intp], stop: NDArray[np.intp]) -> FloatArray:
    """Per column, the last row in ``start .. stop - 1`` where ``q >= level`` (NaN: none)."""
    rows = np.arange(q.shape[0])[:, None]
    hit = (q >= level[None, :]) & (rows >= start[None, :]) & (rows < stop[None, :])
    found = hit.any(axis=0)
    last = q.shape[0] - 1 - hit[::-1].argmax(axis=0)
    return np.where(found, last, np.nan)


def _first_at_least(q: FloatArray, level: FloatArray, start: NDArray[np.intp], stop: NDArray[np.intp]) -> FloatArray:
    """Per column, the first row in ``start .. stop - 1`` where ``q >= level`` (NaN: none)."""
    rows = np.arange(q.shape[0])[:, None]
    hit = (q >= level[None, :]) & (rows >= start[None, :]) & (rows < stop[None, :])
    found = hit.any(axis=0)
    return np.where(found, hit.argmax(axis=0), np.nan)


def _aligned_fit(
    power: FloatArray,
    anchor: FloatArray,
    owner: NDArray[np.intp],
    use: NDArray[np.bool_],
    lower: NDArray[np.intp],
    upper: NDArray[np.intp],
    n_pairs: int,
    half: int,
    sign: float,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Average each pair's beam profiles about their rough edges and fit one step per pair.

    ``power`` (M, n) profiles; ``anchor`` (n,) rough edges (rows of ``power``, NaN where
    absent); ``use`` beams taking part; ``lower``/``upper`` each beam's usable rows
    [lower, upper). Returns per pair the offset of the fitted edge from the beams'
    ``floor(anchor)`` (rows; NaN when no fit), its 1-sigma and the fitted blur.
    """
    nan = np.full(n_pairs, np.nan)
    ok = use & np.isfinite(anchor)
    if not np.any(ok):
        return nan, nan.copy(), nan.copy()
    m_rows = power.shape[0]
    base = np.floor(np.where(ok, anchor, 0.0)).astype(np.intp)
    offsets = np.arange(-half, half + 1)
    rows = base[None, :] + offsets[:, None]  # (2 half + 1, n)
    valid = ok[None, :] & (rows >= np.maximum(lower, 0)[None, :]) & (rows < np.minimum(upper, m_rows)[None, :])
    values = power[np.clip(rows, 0, m_rows - 1), np.arange(power.shape[1])[None, :]]
    values = np.where(valid, values, 0.0)
    sums = np.zeros((n_pairs, offsets.size))
    counts = np.zeros((n_pairs, offsets.size))
    np.add.at(sums, owner, values.T)
    np.add.at(counts, owner, valid.T.astype(np.float64))
    beams = np.bincount(owner[ok], minlength=n_pairs).astype(np.float64)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.where(counts > 0, sums / np.maximum(counts, 1.0), 0.0)
    weights = (counts >= 0.5 * np.maximum(beams, 1.0)[:, None]) & (beams[:, None] > 0)
    has = weights.sum(axis=1) >= 5
    if not np.any(has):
        return nan, nan.copy(), nan.copy()
    # The rough edge lies between base and base + 1 (anchors at half rows): start there.
    start = np.full(int(np.count_nonzero(has)), half + 0.5)
    fit = fit_steps(mean[has], weights[has].astype(np.float64), edge0=start, blur0=BLUR0_SAMPLES, sign=sign)
    offset, std, blur = nan.copy(), nan.copy(), nan.copy()
    good = np.flatnonzero(has)[fit.ok]
    offset[good] = fit.edge[fit.ok] - half  # window index ``half`` is each beam's floor(anchor)
    std[good] = fit.edge_std[fit.ok] / np.sqrt(np.maximum(beams[good], 1.0))
    blur[good] = fit.blur[fit.ok]
    return offset, std, blur


def find_edges(segmentation: Segmentation, pairs: Sequence[Pair], cfg: MeasureConfig) -> list[PairEdges]:
    """The edges of every pair of a frame (module docstring), all pairs' beams together."""
    seg = segmentation
    n_pairs = len(pairs)
    n_rows = seg.n_rows
    dr = seg.sample_m
    d = seg.row_step
    k = max(1, int(round(cfg.smooth_m / dr))) | 1
    level_n = max(3, int(round(cfg.level_m / dr)))
    half = int(min(MAX_FIT_HALF_SAMPLES, max(4, round(cfg.fit_half_window_m / dr))))
    centrals = [central_beams(p.columns, cfg.central_fraction) for p in pairs]
    counts = [len(c) for c in centrals]
    beams = np.array([c for central in centrals for c in central], dtype=np.intp)
    if beams.size == 0:
        return [_empty(0) for _ in pairs]
    owner = np.repeat(np.arange(n_pairs), counts)
    s_label = np.repeat(np.array([p.shadow.label for p in pairs]), counts)
    h_label = np.repeat(np.array([p.highlight.label if p.highlight is not None else -1 for p in pairs]), counts)
    s_first = seg.shadow_rows[0][s_label, beams]
    s_last = seg.shadow_rows[1][s_label, beams]
    has_h = h_label >= 0
    t_first = np.where(has_h, seg.highlight_rows[0][np.maximum(h_label, 0), beams], -1)
    t_last = np.where(has_h, seg.highlight_rows[1][np.maximum(h_label, 0), beams], -1)
    has_h &= t_first >= 0
    present = s_last >= 0
    s_first = np.where(present, s_first, 0)
    s_last = np.where(present, s_last, 0)
    reach = level_n + half + k + d
    start_row = np.where(has_h, np.minimum(t_first, s_first), s_first) - reach - level_n
    lo = np.maximum(start_row, 0)
    hi = np.minimum(s_last + d + reach, n_rows)
    length = int(np.max(hi - lo)) if hi.size else 0
    rows = lo[None, :] + np.arange(max(length, 1))[:, None]
    levels = seg.levels
    taken = levels[np.minimum(rows, n_rows - 1), beams[None, :]]
    power = seg.power_of(taken)
    m_rows = power.shape[0]
    cum = np.zeros((m_rows + 1, power.shape[1]))
    np.cumsum(power, axis=0, out=cum[1:])
    # The profiles smoothed over k rows centred on each row (fewer at the ends).
    h = (k - 1) // 2
    idx = np.arange(m_rows)
    a_idx, b_idx = np.maximum(idx - h, 0), np.minimum(idx + h + 1, m_rows)
    q = (cum[b_idx] - cum[a_idx]) / (b_idx - a_idx)[:, None]
    # In local rows (of ``power``). The region's rows can hold more than the cast shadow:
    # a target's dim top (seen at grazing incidence, or low-contrast), a few dB under the
    # seabed, passes the segmentation's test as well. The shadow proper is where the echo
    # falls to the shadow floor: below the geometric mean of the floor (the deepest mean
    # over ``level_n`` rows of the region) and the row's seabed level.
    sf, sl = s_first - lo, s_last - lo
    half_level = max(2, level_n // 2)
    run = _running_means(cum, half_level)  # run[i]: mean of rows i .. i + half_level - 1
    local = np.arange(m_rows)[:, None]
    in_region = (local >= sf[None, :] - d) & (local <= sl[None, :] + d - half_level + 1)
    floor = np.where(in_region, run, np.inf).min(axis=0)
    seabed_row = seg.power_of(np.asarray(seg.background, dtype=np.float32))
    b_lin = seabed_row[np.minimum(rows, n_rows - 1)]
    deep = (run < np.sqrt(floor[None, :] * b_lin)) & in_region
    found = deep.any(axis=0)
    deep_start = np.where(found, deep.argmax(axis=0), sf)
    deep_end = np.where(found, m_rows - 1 - deep[::-1].argmax(axis=0) + half_level - 1, sl)
    interior_a = deep_start + half_level
    interior_b = np.maximum(deep_end - half_level + 1, interior_a + 1)
    mid_shadow = (deep_start + deep_end) // 2
    short = interior_b - interior_a < 2
    interior_a = np.where(short, mid_shadow, interior_a)
    interior_b = np.where(short, mid_shadow + 1, interior_b)
    shadow_level = _window_means(cum, interior_a, interior_b)
    echo_level = _window_means(cum, deep_start - d - level_n, deep_start - d)
    f_a = deep_end + d + 1
    seabed_level = _window_means(cum, f_a, f_a + level_n)
    seabed_inside = (lo + f_a + level_n) <= n_rows
    with np.errstate(invalid="ignore", divide="ignore"):
        echo_db = 10.0 * np.log10(echo_level / shadow_level)
        depth_db = 10.0 * np.log10(seabed_level / shadow_level)
    cut_level_db = cfg.cut_contrast_sigmas * seg.sigma_db
    dark_before = ~(echo_db >= cut_level_db)
    dark_after = ~(depth_db >= cut_level_db) | ~seabed_inside
    top_mid = np.sqrt(echo_level * shadow_level)
    end_mid = np.sqrt(seabed_level * shadow_level)
    # Each rough edge lies between two rows: at the last bright row + 0.5, the first - 0.5.
    rough_top = _last_at_least(q, top_mid, deep_start - d - level_n, interior_a) + 0.5
    rough_end = _first_at_least(q, end_mid, interior_b, f_a + level_n) - 0.5
    use_top = present & ~dark_before & ~dark_after
    use_end = use_top
    top_off, top_std, top_blur = _aligned_fit(power, rough_top, owner, use_top, deep_start - reach,
                                              mid_shadow + 1, n_pairs, half, 1.0)
    end_off, end_std, _ = _aligned_fit(power, rough_end, owner, use_end, mid_shadow, hi - lo, n_pairs, half, -1.0)
    # The target's near edge: the rise from the seabed before a highlight to the highlight.
    tf, tl = t_first - lo, t_last - lo
    near_before = _window_means(cum, tf - d - level_n, tf - d)
    near_inside = _window_means(cum, tf + d, np.maximum(tl - d + 1, tf + d + 1))
    rough_near = _first_at_least(q, np.sqrt(near_before * near_inside), tf - d - level_n, tf + d + 1) - 0.5
    use_near = use_top & has_h & (near_inside > near_before)
    near_off, near_std, _ = _aligned_fit(power, rough_near, owner, use_near, tf - reach, (tf + tl) // 2 + 1,
                                         n_pairs, half, -1.0)
    out = []
    start = 0
    for n, count in enumerate(counts):
        sel = slice(start, start + count)
        start += count
        good = use_top[sel] & np.isfinite(rough_top[sel]) & np.isfinite(rough_end[sel])
        if not (np.isfinite(top_off[n]) and np.isfinite(end_off[n])):
            good[:] = False
        near = np.where(use_near[sel] & np.isfinite(rough_near[sel]) & np.isfinite(near_off[n]),
                        np.floor(np.nan_to_num(rough_near[sel])) + near_off[n], np.nan)
        lo_sel = lo[sel]
        echo = np.nanmedian(echo_db[sel][good]) if np.any(good) else math.nan
        depth = np.nanmedian(depth_db[sel][good]) if np.any(good) else math.nan
        out.append(PairEdges(
            columns=tuple(int(c) for c in beams[sel][good]),
            top_rows=(np.floor(np.nan_to_num(rough_top[sel])) + top_off[n] + lo_sel)[good],
            end_rows=(np.floor(np.nan_to_num(rough_end[sel])) + end_off[n] + lo_sel)[good],
            near_rows=(near + lo_sel)[good],
            top_std_rows=float(top_std[n]),
            end_std_rows=float(end_std[n]),
            near_std_rows=float(near_std[n]),
            blur_rows=float(top_blur[n]),
            n_central=count,
            cut_near=int(np.count_nonzero(present[sel] & dark_before[sel])),
            cut_far=int(np.count_nonzero(present[sel] & dark_after[sel])),
            echo_db=float(echo),
            depth_db=float(depth),
            seabed_db=float(depth - echo) if math.isfinite(echo) and math.isfinite(depth) else math.nan,
        ))
    return out


def _empty(n_central: int) -> PairEdges:
    e = np.zeros(0)
    return PairEdges((), e, e.copy(), e.copy(), math.nan, math.nan, math.nan, math.nan, n_central, 0, 0,
                     math.nan, math.nan, math.nan)
