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

import functools
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from perception import imaging
from perception.shadows.measurement.config import MeasureConfig
from perception.shadows.measurement.stepfit import fit_steps
from perception.shadows.pairing.pair import Pair
from perception.shadows.segmentation.result import Segmentation

FloatArray = NDArray[np.float64]

#: Largest fitted half window, samples.
MAX_FIT_HALF_SAMPLES = 48


def central_beams(columns: tuple[int, ...], fraction: float) -> list[int]:
    """The middle ``fraction`` of a pair's beams (at least one), in order."""
    cols = sorted(columns)
    n = len(cols)
    keep = max(1, int(round(n * fraction)))
    start = (n - keep) // 2
    return cols[start : start + keep]


@dataclass(frozen=True)
class FrameEdges:
    """The edges of every pair of a frame: per central beam (the pairs' beams one after the
    other, pair by pair) and per pair.

    Attributes
    ----------
    beams, owner : ndarray, shape (n,), int
        Image column of each central beam, and the index of its pair.
    good : ndarray, shape (n,), bool
        Beams with both edges of the shadow measured (not cut).
    top_rows, end_rows : ndarray, shape (n,)
        Fractional rows of the shadow's start and end (NaN where not ``good``).
    near_rows : ndarray, shape (n,)
        Row of the target's near edge (the highlight's start; its rough edge, to half a
        row: it places the target, no height depends on it), NaN where the beam has no
        highlight or it was not measured.
    top_std_rows, end_std_rows : ndarray, shape (n_pairs,)
        1-sigma of each pair's mean shadow edges, rows (NaN when not measured).
    blur_rows : ndarray, shape (n_pairs,)
        Fitted blur of each shadow's start, rows.
    n_central, n_good, cut_near, cut_far : ndarray, shape (n_pairs,), int
        Central beams looked at, beams ``good``, central beams without echo before the
        shadow, without seabed after it.
    echo_db, depth_db : ndarray, shape (n_pairs,)
        Mean over the central beams holding the shadow of the echo before its start over it,
        and of the seabed after its end over it, dB (NaN where none was read).
    """

    beams: NDArray[np.intp]
    owner: NDArray[np.intp]
    good: NDArray[np.bool_]
    top_rows: FloatArray
    end_rows: FloatArray
    near_rows: FloatArray
    top_std_rows: FloatArray
    end_std_rows: FloatArray
    blur_rows: FloatArray
    n_central: NDArray[np.intp]
    n_good: NDArray[np.intp]
    cut_near: NDArray[np.intp]
    cut_far: NDArray[np.intp]
    echo_db: FloatArray
    depth_db: FloatArray


def _window_means(cum: FloatArray, start: NDArray[np.intp], stop: NDArray[np.intp]) -> FloatArray:
    """Mean of each column of the values behind ``cum`` (cumulative sums with a zero row
    first, shape (M + 1, n)) over its rows ``start .. stop - 1`` (clamped; NaN when empty);
    ``start`` and ``stop`` of shape (k, n) for k windows per column at once."""
    m = cum.shape[0] - 1
    a = np.minimum(np.maximum(start, 0), m)  # (np.clip costs several times more than the two calls)
    b = np.minimum(np.maximum(stop, 0), m)
    cols = np.arange(cum.shape[1])[None, :]
    total = cum[b, cols] - cum[a, cols]
    count = b - a
    return np.where(count > 0, total / np.maximum(count, 1), np.nan)


def _crossings(cum: FloatArray, h: int, level: FloatArray, start: NDArray[np.intp], stop: NDArray[np.intp],
               *, last: tuple[bool, ...]) -> FloatArray:
    """Per column of ``cum`` and per kind of edge (the rows of ``level``, ``start`` and
    ``stop``, shape (k, n)), the first row in ``start .. stop - 1`` -- the last for the kinds
    flagged in ``last`` -- whose smoothed value (the mean of the ``2 h + 1`` rows centred on
    it, fewer at the ends, of the values behind ``cum``) is at least ``level`` (NaN: none).

    All kinds in one pass: their windows side by side, as wide as the widest (the rows past
    a window's own end are outside it, so its answer is the same)."""
    m = cum.shape[0] - 1
    n_kinds, n = level.shape
    width = max(1, int(np.maximum.reduce(stop - start, axis=None)) if start.size else 1)
    rows = start.reshape(1, -1) + np.arange(width)[:, None]
    # rows < stop, >= 0 and < m in one comparison: as unsigned, a negative row is greater
    # than any bound (and the bound, stop within [0, m], has every row below it that is
    # below both).
    rows = rows.astype(np.intp, copy=False)
    bound = np.minimum(np.maximum(stop.reshape(1, -1), 0), m).astype(np.uintp)
    inside = rows.view(np.uintp) < bound
    # Each smoothing window's ends (a: first row, b: past its last; clamped), both in one
    # array, then as flat indices into ``cum`` (one take: cheaper than indexing by rows
    # and columns).
    ends = rows[None] + np.array((-h, h + 1)).reshape(2, 1, 1)  # (2, width, k n): rows - h, rows + h + 1
    np.maximum(ends, 0, out=ends)
    np.minimum(ends, m, out=ends)
    count = np.maximum(ends[1] - ends[0], 1)
    ends *= n
    ends += _tiled_columns(n, n_kinds)
    at_ends = cum.take(ends)
    smoothed = np.subtract(at_ends[1], at_ends[0], out=at_ends[1])
    smoothed /= count
    hit = (smoothed >= level.reshape(1, -1)) & inside
    found = hit.any(axis=0)
    at = hit.argmax(axis=0)
    for k in range(n_kinds):
        if last[k]:
            at[k * n : (k + 1) * n] = width - 1 - hit[::-1, k * n : (k + 1) * n].argmax(axis=0)
    return np.where(found, start.ravel() + at, np.nan).reshape(n_kinds, n)


def _column_rows(start: NDArray[np.intp], length: int, last: int) -> NDArray[np.intp]:
    """Rows ``start .. start + length - 1`` of each column, none past ``last``, shape (length, n)."""
    rows = start[None, :] + np.arange(length)[:, None]
    if int(np.maximum.reduce(start)) + length - 1 > last:
        np.minimum(rows, last, out=rows)
    return rows


def _run_means(cum: FloatArray, size: int) -> FloatArray:
    """Mean of rows ``i .. i + size - 1`` (fewer at the end) of the values behind ``cum``, for
    each row ``i``, shape (M, n): ``(cum[i + size] - cum[i]) / size``, the end's rows over
    what is left."""
    m = cum.shape[0] - 1
    head = max(m - size, 0)
    out = np.empty((m, cum.shape[1]))
    np.subtract(cum[size : size + head], cum[:head], out=out[:head])
    out[:head] /= size
    np.subtract(cum[m], cum[head:m], out=out[head:])
    out[head:] /= (m - np.arange(head, m))[:, None]
    return out


@functools.lru_cache(maxsize=16)
def _tiled_columns(n: int, n_kinds: int) -> NDArray[np.intp]:
    """0 .. n - 1, ``n_kinds`` times over, read-only."""
    cols = np.tile(np.arange(n), n_kinds)
    cols.flags.writeable = False
    return cols


def _aligned_fits(
    power: FloatArray,
    kinds: Sequence[tuple[FloatArray, NDArray[np.bool_], NDArray[np.intp], NDArray[np.intp], float]],
    owner: NDArray[np.intp],
    n_pairs: int,
    half: int,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Average each pair's beam profiles about their rough edges and fit one step per pair
    and kind of edge, all in one fit.

    ``power`` (M, n) profiles; per kind: ``anchor`` (n,) rough edges (rows of ``power``,
    NaN where absent), ``use`` beams taking part, ``lower``/``upper`` each beam's usable
    rows [lower, upper), and the step's sign (+1 a fall, -1 a rise). Returns arrays of
    shape (n_kinds, n_pairs): the offset of the fitted edge from the beams'
    ``floor(anchor)`` (rows; NaN when no fit), its 1-sigma and the fitted blur.
    """
    n_kinds = len(kinds)
    m_rows, n = power.shape
    anchor = np.concatenate([k[0] for k in kinds])
    ok = np.concatenate([k[1] for k in kinds]) & np.isfinite(anchor)
    lower = np.maximum(np.concatenate([k[2] for k in kinds]), 0)
    upper = np.minimum(np.concatenate([k[3] for k in kinds]), m_rows)
    group = (np.arange(n_kinds)[:, None] * n_pairs + owner[None, :]).ravel()
    n_groups = n_kinds * n_pairs
    out = np.full((3, n_groups), np.nan)
    if not ok.any():
        return out[0].reshape(n_kinds, n_pairs), out[1].reshape(n_kinds, n_pairs), out[2].reshape(n_kinds, n_pairs)
    base = np.floor(np.where(ok, anchor, 0.0)).astype(np.intp)
    rows = base[None, :] + np.arange(-half, half + 1)[:, None]  # (2 half + 1, n_kinds n)
    valid = ok[None, :] & (rows >= lower[None, :]) & (rows < upper[None, :])
    at_rows = np.minimum(np.maximum(rows, 0), m_rows - 1)
    at_rows *= n  # flat indices into ``power`` (one take: cheaper than indexing by rows and columns)
    at_rows += _tiled_columns(n, n_kinds)
    values = np.where(valid, power.take(at_rows), 0.0)
    # Sums over each group's beams by one product with the groups' indicator matrix.
    member = np.zeros((n_groups, group.size))
    member[group, np.arange(group.size)] = ok
    sums = member @ values.T
    counts = member @ valid.T.astype(np.float64)
    beams = np.add.reduce(member, axis=1)
    mean = sums / np.maximum(counts, 1.0)
    weights = (counts >= 0.5 * np.maximum(beams, 1.0)[:, None]) & (beams[:, None] > 0)
    has = (np.add.reduce(weights, axis=1, dtype=np.intp) >= 5).nonzero()[0]  # np.count_nonzero's sum
    if has.size:
        signs = np.repeat(np.array([k[4] for k in kinds], dtype=np.float64), n_pairs)[has]
        fit = fit_steps(mean[has], weights[has].astype(np.float64), edge0=half + 0.5, sign=signs)
        good = has[fit.ok]
        out[0, good] = fit.edge[fit.ok] - half  # window index ``half`` is each beam's floor(anchor)
        out[1, good] = fit.edge_std[fit.ok] / np.sqrt(np.maximum(beams[good], 1.0))
        out[2, good] = fit.blur[fit.ok]
    return out[0].reshape(n_kinds, n_pairs), out[1].reshape(n_kinds, n_pairs), out[2].reshape(n_kinds, n_pairs)


def find_edges(segmentation: Segmentation, pairs: Sequence[Pair], cfg: MeasureConfig) -> FrameEdges:
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
    counts = np.array([len(c) for c in centrals], dtype=np.intp)
    if not any(centrals):
        return _empty(counts)
    # Per central beam: its column, its pair, the pair's shadow and highlight labels (-1: none)
    # (the pairs' labels repeated over their beams: fewer Python objects than per beam).
    beams = np.array([c for central in centrals for c in central], dtype=np.intp)
    owner = np.arange(n_pairs).repeat(counts)
    s_label, h_label = np.array([(p.shadow.label, -1 if p.highlight is None else p.highlight.label)
                                 for p in pairs], dtype=np.intp)[owner].T
    s_first = seg.shadow_rows[0][s_label, beams]
    s_last = seg.shadow_rows[1][s_label, beams]
    has_h = h_label >= 0
    h_at = np.maximum(h_label, 0)
    t_first = np.where(has_h, seg.highlight_rows[0][h_at, beams], -1)
    t_last = np.where(has_h, seg.highlight_rows[1][h_at, beams], -1)
    has_h &= t_first >= 0
    present = s_last >= 0
    s_first = np.where(present, s_first, 0)
    s_last = np.where(present, s_last, 0)
    reach = level_n + half + k + d
    # (Integer rows throughout: sums of constants are taken first, the same rows in fewer calls.)
    start_row = np.where(has_h, np.minimum(t_first, s_first), s_first) - (reach + level_n)
    lo = np.maximum(start_row, 0)
    hi = np.minimum(s_last + (d + reach), n_rows)
    length = max(int(np.maximum.reduce(hi - lo)), 1)
    # Each beam's rows lo .. lo + length - 1 (the last row repeated past the image's end);
    # the levels read by flat index (one take: cheaper than indexing by rows and columns).
    first_row, last_row = int(np.minimum.reduce(lo)), min(int(np.maximum.reduce(lo)) + length - 1, n_rows - 1)
    rows = _column_rows(lo - first_row, length, last_row - first_row)  # from first_row
    # The seabed's level at those rows, in linear power (read first: the rows then become the
    # flat indices, in place).
    taken = np.asarray(seg.background_rows(first_row, last_row + 1), dtype=np.float32)
    b_lin = seg.power_of(taken).take(rows)
    n_cols = seg.levels.shape[1]
    flat = rows
    flat *= n_cols
    flat += first_row * n_cols + beams
    power = seg.power_of(seg.levels.ravel().take(flat))
    m_rows = length
    cum = imaging.column_cumsum(power)  # zero row first; numpy's cumsum's additions
    h = (k - 1) // 2
    # In local rows (of ``power``). The region's rows can hold more than the cast shadow:
    # a target's dim top (seen at grazing incidence, or low-contrast), a few dB under the
    # seabed, passes the segmentation's test as well. The shadow proper is where the echo
    # falls to the shadow floor: below the geometric mean of the floor (the deepest mean
    # over ``level_n`` rows of the region) and the row's seabed level.
    sf, sl = s_first - lo, s_last - lo
    half_level = max(2, level_n // 2)
    # run[i]: mean of rows i .. i + half_level - 1 (fewer at the end)
    run = _run_means(cum, half_level)
    local = np.arange(m_rows)[:, None]
    # The region's rows, within each beam's band (the dark beyond the band's far edge is
    # no part of a shadow that ends before it).
    band_start, band_stop = seg.band_start_rows[beams] - lo, seg.band_stop_rows[beams] - lo
    in_region = ((local >= np.maximum(sf - d, band_start)[None, :])
                 & (local <= np.minimum(sl + (d + 1 - half_level), band_stop + (2 - half_level))[None, :]))
    # The least over each beam's region of the run means: outside it +inf, then the plain
    # reduction (the same minimum of the same values, in half the time of ``where=``).
    masked = np.where(in_region, run, np.inf)
    floor = np.minimum.reduce(masked, axis=0)
    # (In place: neither is read again. Outside the region inf^2 is below nothing: False there.)
    deep = np.less(np.multiply(masked, masked, out=masked), np.multiply(floor[None, :], b_lin, out=b_lin))
    deep = deep.view(np.uint8)
    # Each beam's first and last deep row by argmax along contiguous memory (OpenCV turns
    # the rows into columns, as for the band's edges: far cheaper than along the first axis).
    by_beam = imaging.transpose(deep).view(bool)
    first_deep = by_beam.argmax(axis=1)
    found = (first_deep > 0) | by_beam[:, 0]
    deep_start = np.where(found, first_deep, sf)
    deep_end = np.where(found, (m_rows + half_level - 2) - imaging.rotate_clockwise(deep).view(bool).argmax(axis=1),
                        sl)
    interior_a = deep_start + half_level
    interior_b = np.maximum(deep_end + (1 - half_level), interior_a + 1)
    mid_shadow = (deep_start + deep_end) // 2
    short = interior_b - interior_a < 2
    interior_a = np.where(short, mid_shadow, interior_a)
    interior_b = np.where(short, mid_shadow + 1, interior_b)
    # The seabed after the shadow: from a grid step past its end, but inside the band
    # (a shadow ending near the band's far edge leaves less room there).
    f_a = np.maximum(deep_end + 3, np.minimum(deep_end + (d + 1), band_stop + (1 - level_n)))
    f_b = f_a + level_n
    tf, tl = t_first - lo, t_last - lo
    echo_a, near_a, near_b = deep_start - (d + level_n), tf - (d + level_n), tf + (d + 1)
    # The levels: shadow, echo before it, seabed after it, seabed before the highlight, highlight.
    means = _window_means(cum, np.array([interior_a, echo_a, f_a, near_a, tf + d]),
                          np.array([interior_b, deep_start - d, f_b, tf - d, np.maximum(tl + (1 - d), near_b)]))
    shadow_level, echo_level, seabed_level, near_before, near_inside = means
    seabed_inside = lo + f_a <= n_rows - level_n
    with np.errstate(invalid="ignore", divide="ignore"):
        echo_db, depth_db = 10.0 * np.log10(means[1:3] / shadow_level)  # echo, seabed after: over the shadow
    cut_level_db = cfg.cut_contrast_sigmas * seg.sigma_db
    dark_before = ~(echo_db >= cut_level_db)
    dark_after = ~(depth_db >= cut_level_db) | ~seabed_inside
    # Each rough edge lies between two rows: at the last bright row + 0.5, the first - 0.5.
    # The target's near edge: the rise from the seabed before a highlight to the highlight.
    top_end_near = _crossings(
        cum, h,
        np.array([0.5 * (echo_level + shadow_level), 0.5 * (seabed_level + shadow_level),
                  0.5 * (near_before + near_inside)]),
        np.array([echo_a, interior_b, near_a]),
        np.array([interior_a, f_b, near_b]),
        last=(True, False, False),
    )
    rough_top = top_end_near[0] + 0.5
    rough_end = top_end_near[1] - 0.5
    rough_near = top_end_near[2] - 0.5
    use_top = present & ~dark_before & ~dark_after
    use_near = use_top & has_h & (near_inside > near_before)
    offsets, stds, blurs = _aligned_fits(power, (
        (rough_top, use_top, deep_start - reach, mid_shadow + 1, 1.0),
        (rough_end, use_top, mid_shadow, hi - lo, -1.0),
    ), owner, n_pairs, half)
    top_off, end_off = offsets[0][owner], offsets[1][owner]
    good = use_top & np.isfinite(rough_top) & np.isfinite(rough_end) & np.isfinite(top_off) & np.isfinite(end_off)
    nan = np.full(beams.size, np.nan)
    top_rows = np.where(good, np.floor(rough_top) + top_off + lo, nan)
    end_rows = np.where(good, np.floor(rough_end) + end_off + lo, nan)
    # The near edge places the target (to a sample is enough): its rough edge.
    near_ok = good & use_near & np.isfinite(rough_near)
    near_rows = np.where(near_ok, rough_near + lo, nan)
    finite_echo = present & np.isfinite(echo_db)
    finite_depth = present & np.isfinite(depth_db)
    # The per-pair sums in one bincount (each quantity's pairs in bins of their own, summed in
    # beam order as one bincount each would).
    quantities = np.array([good, np.where(finite_echo, echo_db, 0.0), finite_echo,
                           np.where(finite_depth, depth_db, 0.0), finite_depth, present & dark_before,
                           present & dark_after])
    bins = owner[None, :] + (np.arange(quantities.shape[0]) * n_pairs)[:, None]
    n_good, echo_sum, n_echo, depth_sum, n_depth, cut_near, cut_far = np.bincount(
        bins.ravel(), weights=quantities.ravel(), minlength=quantities.shape[0] * n_pairs).reshape(-1, n_pairs)
    with np.errstate(invalid="ignore", divide="ignore"):
        echo = echo_sum / n_echo
        depth = depth_sum / n_depth
    return FrameEdges(
        beams=beams, owner=owner, good=good, top_rows=top_rows, end_rows=end_rows, near_rows=near_rows,
        top_std_rows=stds[0], end_std_rows=stds[1], blur_rows=blurs[0],
        n_central=counts, n_good=n_good.astype(np.intp),
        cut_near=cut_near.astype(np.intp), cut_far=cut_far.astype(np.intp),
        echo_db=echo, depth_db=depth,
    )


def _empty(counts: NDArray[np.intp]) -> FrameEdges:
    n = counts.size
    e = np.zeros(0)
    nan = np.full(n, np.nan)
    zero = np.zeros(n, dtype=np.intp)
    return FrameEdges(np.zeros(0, dtype=np.intp), np.zeros(0, dtype=np.intp), np.zeros(0, dtype=bool), e, e.copy(),
                      e.copy(), nan, nan.copy(), nan.copy(), counts, zero, zero.copy(), zero.copy(),
                      nan.copy(), nan.copy())
