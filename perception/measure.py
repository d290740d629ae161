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


#: An empty float array shared by the results without edges (read-only).
_NONE = np.zeros(0)
_NONE.flags.writeable = False


@dataclass(frozen=True)
class _Edges:
    columns: list[int]
    tops: NDArray[np.float64]
    ends: NDArray[np.float64]
    far_cut: bool


def _window_mean(cum: NDArray[np.float64], a: NDArray[np.intp], b: NDArray[np.intp]) -> NDArray[np.float64]:
    """Per column j, mean of the rows [a_j, b_j) of the array whose cumulative sum is ``cum``.

    An empty window gives NaN (call with numpy's invalid warnings off).
    """
    n = cum.shape[0] - 1
    a = np.minimum(np.maximum(a, 0), n)
    b = np.minimum(np.maximum(b, 0), n)
    cols = np.arange(cum.shape[1])
    return (cum[b, cols] - cum[a, cols]) / (b - a)


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
    # Two windows of 2d rows per beam: around the first cell and around the last one.
    starts = np.concatenate([s_first - d, s_last - d + 1])
    both = np.concatenate([beams, beams])
    rows = starts[None, :] + np.arange(2 * d)[:, None]
    rows_c = np.minimum(np.maximum(rows, 0), n_rows - 1)
    smoothed = segmentation.smoothed_windows(starts, 2 * d, both)
    limit = np.interp(rows_c, segmentation.level_rows, segmentation.grid_shadow_limit)
    shadow = (
        (smoothed < limit)
        & (rows_c >= segmentation.band_start_rows[both][None, :])
        & (rows_c <= segmentation.band_stop_rows[both][None, :])
        & (rows == rows_c)
    )
    local = np.arange(2 * d)[:, None]
    # the sampled row of the first cell is at d + d // 2, that of the last at d // 2
    before, has_before = _last_true(~shadow[:, :n] & (local < d + d // 2))
    first = np.where(has_before, starts[:n] + before + 1, np.maximum(s_first - d, 0))
    after, has_after = _first_true(~shadow[:, n:] & (local > d // 2))
    last = np.where(has_after, starts[n:] + after - 1, np.minimum(s_last + d, n_rows - 1))
    return first.astype(np.intp), last.astype(np.intp)


def _edges(segmentation: Segmentation, pairs: Sequence[Pair], cfg: MeasureConfig) -> list[_Edges]:
    """Fractional rows of the shadow start and end in each pair's central beams.

    All pairs' beams are processed together, each beam in its own window of rows (from
    before the target's highlight to the seabed after its shadow), as columns of one
    block. Empty windows and dark levels give NaN and infinities, which the tests below
    reject, so numpy's warnings about them are off here.
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        return _edges_quiet(segmentation, pairs, cfg)


def _edges_quiet(segmentation: Segmentation, pairs: Sequence[Pair], cfg: MeasureConfig) -> list[_Edges]:
    """:func:`_edges` with numpy's divide and invalid warnings already off."""
    n_rows, n_cols = segmentation.levels.shape
    half = cfg.smooth_samples // 2
    k_smooth = cfg.smooth_samples
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
        return [_Edges([], _NONE, _NONE, False) for _ in pairs]
    beams = np.array(beam_list, dtype=np.intp)
    s_labels = np.array(shadow_list, dtype=np.intp)
    t_labels = np.array(highlight_list, dtype=np.intp)
    # The regions' first and last rows in those beams (see Segmentation.column_extents).
    s_last = segmentation.shadow_rows[1][s_labels, beams]
    ok = s_last >= 0
    owner = np.array(owner_list, dtype=np.intp)[ok]
    beams, s_labels, t_labels, s_last = beams[ok], s_labels[ok], t_labels[ok], s_last[ok]
    if beams.size == 0:
        return [_Edges([], _NONE, _NONE, False) for _ in pairs]
    s_first = segmentation.shadow_rows[0][s_labels, beams]
    # The highlight's first row (where it is in the beam) bounds the window below.
    t_first = np.maximum(segmentation.highlight_rows[0][t_labels, beams], 0)
    if segmentation.row_step > 1:
        s_first, s_last = _refine_shadow_rows(segmentation, beams, s_first, s_last)
    # The seabed just after the shadow; a beam where it lies beyond the window is cut.
    ba = s_last + 1 + k_smooth
    bb = np.minimum(n_rows, ba + cfg.level_samples)
    cut = bb - ba < max(2, cfg.level_samples // 2)
    n_beams = np.bincount(owner, minlength=len(pairs))
    n_cut = np.bincount(owner[cut], minlength=len(pairs))
    keep = ~cut
    owner, beams, t_first, s_first, s_last, ba, bb = (
        v[keep] for v in (owner, beams, t_first, s_first, s_last, ba, bb)
    )
    if beams.size == 0:
        return [_Edges([], _NONE, _NONE, bool(2 * c > b)) for c, b in zip(n_cut, n_beams, strict=True)]
    # Linear power of the beams (each averaged with its neighbours), smoothed in range;
    # beam c's window starts at row lo[c], and p[i, c] belongs to row off[c] + i.
    # The window starts a little before the shadow (room for the target's echo level
    # before its far top edge) and ends past the seabed window after the shadow.
    lead = 2 * k_smooth + cfg.level_samples + 2 * segmentation.row_step + EDGE_MARGIN_SAMPLES
    lo = np.maximum(0, np.maximum(t_first, s_first - lead) - half)
    hi = np.minimum(n_rows, np.maximum(bb, s_last + k_smooth + 2) + k_smooth)
    length = int((hi - lo).max())
    if length < k_smooth + 2:
        return [_Edges([], _NONE, _NONE, bool(2 * c > b)) for c, b in zip(n_cut, n_beams, strict=True)]
    rows = np.minimum(lo[None, :] + np.arange(length)[:, None], n_rows - 1)
    b_half = cfg.smooth_beams // 2
    shifts = np.minimum(np.maximum((beams[None, :] + np.arange(-b_half, b_half + 1)[:, None]).ravel(), 0), n_cols - 1)
    index = (rows * n_cols)[:, None, :] + shifts.reshape(cfg.smooth_beams, beams.size)[None, :, :]
    block = segmentation.power_take(index.reshape(length, -1))
    power = block[:, : beams.size]
    for j in range(1, cfg.smooth_beams):
        power = power + block[:, j * beams.size : (j + 1) * beams.size]
    power *= 1.0 / cfg.smooth_beams
    cum = _cumsum0(power)
    p = (cum[k_smooth:] - cum[:-k_smooth]) / k_smooth
    off = lo + half
    cum_p = _cumsum0(p)
    idx = np.arange(p.shape[0])[:, None]
    cols = np.arange(p.shape[1])
    # Levels: shadow inside, seabed just after the shadow.
    sa, sb = s_first + half, s_last + 1 - half
    short = sb <= sa
    sa = np.where(short, s_first, sa)
    sb = np.where(short, s_last + 1, sb)
    shadow_level = _window_mean(cum_p, sa - off, sb - off)
    seabed_level = _window_mean(cum_p, ba - off, bb - off)
    # Where the "seabed" after the shadow is hardly brighter than the shadow, the shadow
    # runs on into the dark beyond the band's far edge: cut there.
    seabed_db = 10.0 * np.log10(seabed_level)
    contrast_db = seabed_db - 10.0 * np.log10(shadow_level)
    beyond = ~(contrast_db >= cfg.end_contrast_db)
    # A shadow cut by the far edge is cut across its width: most of its beams.
    n_cut = n_cut + np.bincount(owner[beyond], minlength=len(pairs))
    far_cut = [bool(2 * c > b) for c, b in zip(n_cut.tolist(), n_beams.tolist(), strict=True)]
    # The target's echo just before its far top edge (which may be weaker than the
    # highlight's brightest part, e.g. a top seen at grazing incidence): find the edge
    # roughly as the last sample above the dB-midpoint of shadow and seabed, then take
    # the echo level a smoothing width before it.
    core = np.minimum(s_first + k_smooth, s_last) - off
    rough_level = np.sqrt(shadow_level * seabed_level)
    rough, has_rough = _last_true((p >= rough_level) & (idx <= core))
    hb = rough - k_smooth
    echo_level = _window_mean(cum_p, np.maximum(0, hb - cfg.level_samples), np.maximum(1, hb))
    mid_top = 0.5 * (echo_level + shadow_level)
    k_top, has_top = _last_true((p >= mid_top) & (idx < core))
    k_next = np.minimum(k_top + 1, p.shape[0] - 1)
    a_top, b_top = p[k_top, cols], p[k_next, cols]
    top = k_top + (a_top - mid_top) / (a_top - b_top)
    has_top &= b_top < mid_top
    mid_end = 0.5 * (shadow_level + seabed_level)
    start = np.maximum(np.maximum(s_first, (s_first + s_last) // 2) - off, 1)
    stop = s_last + k_smooth + 2 - off
    k_end, has_end = _first_true((p >= mid_end) & (idx >= start) & (idx < stop))
    a_end, b_end = p[k_end - 1, cols], p[k_end, cols]
    end = (k_end - 1) + (mid_end - a_end) / (b_end - a_end)
    has_end &= (k_end >= 1) & (a_end < mid_end)
    good = (
        (shadow_level < seabed_level) & has_rough & (echo_level > shadow_level)
        & has_top & has_end & (end > top) & ~beyond
    )
    top = top + off
    end = end + off
    out = []
    for n in range(len(pairs)):
        mine = good & (owner == n)
        out.append(_Edges(beams[mine].tolist(), top[mine], end[mine], far_cut[n]))
    return out


def _cumsum0(values: NDArray[np.float64]) -> NDArray[np.float64]:
    """Cumulative sums down the rows with a row of zeros first, shape (n + 1, m)."""
    out = np.empty((values.shape[0] + 1, values.shape[1]))
    out[0] = 0.0
    np.cumsum(values, axis=0, out=out[1:])
    return out


def _last_true(mask: NDArray[np.bool_]) -> tuple[NDArray[np.intp], NDArray[np.bool_]]:
    """Per column, the last row where ``mask`` holds, and whether any does."""
    n = mask.shape[0]
    last = (n - 1 - np.argmax(mask[::-1], axis=0)).astype(np.intp)
    return last, np.asarray(mask.any(axis=0), dtype=bool)


def _first_true(mask: NDArray[np.bool_]) -> tuple[NDArray[np.intp], NDArray[np.bool_]]:
    """Per column, the first row where ``mask`` holds, and whether any does."""
    return np.argmax(mask, axis=0).astype(np.intp), np.asarray(mask.any(axis=0), dtype=bool)


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
    cfg = config or MeasureConfig()
    return _measurement(
        segmentation, pair, _edges(segmentation, [pair], cfg)[0],
        range_m=range_m, beam_azimuth_rad=beam_azimuth_rad, config=cfg,
    )


def _measurement(
    segmentation: Segmentation,
    pair: Pair,
    edges: _Edges,
    *,
    range_m: NDArray[np.float64],
    beam_azimuth_rad: NDArray[np.float64],
    config: MeasureConfig,
) -> ShadowMeasurement:
    """Combine one pair's per-beam edges into its measurement."""
    cfg = config
    n_rows = segmentation.levels.shape[0]
    t, s = pair.highlight, pair.shadow
    # Whether the far edge of the band cuts the shadow is decided beam by beam from the
    # seabed after it (``edges.far_cut``), not from the band's estimated edge.
    cutting = [f for f in pair.fov_flags if f in _CUTTING_FLAGS and f != "band_far"]
    far_cut = edges.far_cut
    used = edges.columns
    tops = edges.tops
    ends = edges.ends
    if far_cut and "band_far" not in cutting and "window_end" not in cutting:
        cutting.append("band_far" if s.row_stop < n_rows else "window_end")
    dr = float(range_m[-1] - range_m[0]) / (range_m.size - 1)
    highlight_range = float(range_m[t.row_start])
    width = s.n_cols
    if len(used) < cfg.min_beams:
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
    n = len(used)
    # Both edges in one interpolation, then plain Python on the few per-beam values.
    both_m = np.interp(np.concatenate((tops, ends)), _rows_axis(n_rows), range_m).tolist()
    top_m, end_m = both_m[:n], both_m[n:]
    r_top = _median(top_m)
    r_end = _median(end_m)
    spread = max(_robust_std(top_m), _robust_std(end_m))
    sigma = max(1.2533 * spread / math.sqrt(n), 0.25 * dr / math.sqrt(n))
    return ShadowMeasurement(
        azimuth_rad=_mean(beam_azimuth_rad[used]),
        r_top_m=r_top,
        r_end_m=r_end,
        sigma_r_m=sigma,
        highlight_range_m=highlight_range,
        columns=tuple(used),
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


def _robust_std(values: list[float]) -> float:
    """1.4826 x median absolute deviation (0 for a single value)."""
    if len(values) < 2:
        return 0.0
    middle = _median(values)
    return 1.4826 * _median([abs(v - middle) for v in values])


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
    return [
        _measurement(
            segmentation, pair, e, range_m=range_m, beam_azimuth_rad=beam_azimuth_rad, config=cfg
        )
        for pair, e in zip(pairs, edges, strict=True)
    ]
