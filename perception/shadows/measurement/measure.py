"""Where a target's shadow starts and ends, to a fraction of a range sample, and why not.

For each highlight-shadow pair (:mod:`perception.shadows.pairing.pair`) the beams through
the middle of its shadow give:

- the shadow START, the target's far top edge (the paper's critical line), or -- for a
  target whose far top edge lies nearer in slant range than the seabed at its near foot
  -- the seabed at that foot, where the occluded seabed begins;
- the shadow END, where the ray over the far top edge meets the seabed;
- the target's NEAR edge, where its echo (highlight) starts, when it has one.

:mod:`perception.shadows.measurement.edges` finds them (fitted steps, unbiased for any
symmetric blur); here the beams are combined: each range is the mean over the beams
(each beam's edge is its rough edge plus the pair's fitted offset, so the mean carries
no rounding) but those whose shadow is much shorter than the others' (they cross the
target's side), with the fit's standard deviation.

Ranges are slant ranges from the sonar's acoustic centre (range ZERO), read from the
frame's ``range_m`` axis at the fractional row, never counted from the window start.

A shadow cut by an edge of the field of view -- the fan's, the range window's, or the
insonified band's (judged beam by beam from the image: no seabed after the shadow, or no
echo before it) -- is flagged ``truncated`` with a reason that says which edge and in how
many beams, and is not used for a height.
"""

from __future__ import annotations

import functools
import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from perception.shadows.measurement.config import MeasureConfig
from perception.shadows.measurement.edges import FrameEdges, find_edges
from perception.shadows.pairing.pair import Pair
from perception.shadows.segmentation.result import Segmentation
from perception.stored_init import check_init_takes_fields

__all__ = [
    "TRUNCATION_REASONS",
    "MeasureConfig",
    "ShadowMeasurement",
    "measure_pair",
    "measure_pairs",
]

#: Reasons, by field-of-view flag, why a shadow cannot give a height.
TRUNCATION_REASONS = {
    "first_beam": "the shadow or its highlight touches the first beam (edge of the fan)",
    "last_beam": "the shadow or its highlight touches the last beam (edge of the fan)",
    "window_start": "the shadow starts at the range window's start",
    "window_end": "the shadow runs to the end of the range window",
    "band_near": "the shadow starts at the near edge of the insonified band (no echo before it)",
    "band_far": "the shadow runs beyond the far edge of the insonified band (no seabed after it)",
}

#: Field-of-view flags of a pair that cut its measurement (a highlight cut at the window start does not).
_CUTTING_FLAGS = ("first_beam", "last_beam", "window_end", "band_near", "band_far")
#: Smallest standard deviation of a combined edge, in samples.
MIN_EDGE_STD_SAMPLES = 0.1


@dataclass(frozen=True)
class ShadowMeasurement:
    """One target's shadow in one frame.

    Attributes
    ----------
    azimuth_rad : float
        Mean azimuth of the beams used (as the ranges), rad, positive to starboard.
    r_top_m, r_end_m : float
        Slant ranges of the shadow start and end from range zero, m (mean over the beams
        used but those crossing the target's side); NaN when not measurable.
    sigma_r_m : float
        1-sigma of each of the two ranges, m.
    highlight_range_m : float
        Slant range where the target's echo starts, m: the fitted near edge when measured,
        else the highlight's nearest sample, else the shadow's start.
    columns : tuple of int
        The beams (image columns) used.
    r_top_per_beam_m, r_end_per_beam_m : tuple of float
        Per-beam edges of those beams, m.
    truncated : bool
        True when the shadow is cut by an edge and must not give a height.
    reason : str or None
        Why it is truncated or not measurable.
    overlap : float
        Algorithm 1's overlap ratio of the pair (0 without a highlight).
    shadow_width_beams : int
        Number of beams the shadow spans.
    r_near_m : float
        Fitted slant range of the target's near edge (where its echo starts), m; NaN when
        the target has no highlight or it was not measured.
    r_near_per_beam_m : tuple of float
        The near edge in each beam of ``columns``, m (NaN where not measured).
    azimuth_per_beam_rad : tuple of float
        Azimuth of each beam of ``columns``, rad.
    has_highlight : bool
        Whether a highlight precedes the shadow.
    echo_db, depth_db : float
        Echo before the shadow's start over the shadow, seabed after its end over the
        shadow, dB (NaN when not measured).
    cut_by : tuple of str
        The edges that cut it (keys of :data:`TRUNCATION_REASONS`); empty when none does.

    A frame builds one per target, so the class writes its own ``__init__`` (as
    :class:`perception.shadows.segmentation.grid.Region` does): it stores the fields in the
    instance's ``__dict__`` at once instead of one ``object.__setattr__`` at a time, at
    about a quarter of the cost (same object: equal, same hash, repr and pickle). Its
    parameters are the fields, in order, with their defaults (checked when the module loads).
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
    r_near_m: float = math.nan
    r_near_per_beam_m: tuple[float, ...] = ()
    azimuth_per_beam_rad: tuple[float, ...] = ()
    has_highlight: bool = True
    echo_db: float = math.nan
    depth_db: float = math.nan
    cut_by: tuple[str, ...] = ()

    def __init__(self, azimuth_rad: float, r_top_m: float, r_end_m: float, sigma_r_m: float,
                 highlight_range_m: float, columns: tuple[int, ...], r_top_per_beam_m: tuple[float, ...],
                 r_end_per_beam_m: tuple[float, ...], truncated: bool, reason: str | None, overlap: float,
                 shadow_width_beams: int, r_near_m: float = math.nan, r_near_per_beam_m: tuple[float, ...] = (),
                 azimuth_per_beam_rad: tuple[float, ...] = (), has_highlight: bool = True,
                 echo_db: float = math.nan, depth_db: float = math.nan, cut_by: tuple[str, ...] = ()) -> None:
        self.__dict__.update(
            azimuth_rad=azimuth_rad, r_top_m=r_top_m, r_end_m=r_end_m, sigma_r_m=sigma_r_m,
            highlight_range_m=highlight_range_m, columns=columns, r_top_per_beam_m=r_top_per_beam_m,
            r_end_per_beam_m=r_end_per_beam_m, truncated=truncated, reason=reason, overlap=overlap,
            shadow_width_beams=shadow_width_beams, r_near_m=r_near_m, r_near_per_beam_m=r_near_per_beam_m,
            azimuth_per_beam_rad=azimuth_per_beam_rad, has_highlight=has_highlight, echo_db=echo_db,
            depth_db=depth_db, cut_by=cut_by,
        )

    @property
    def usable(self) -> bool:
        """True when the measurement can give a height."""
        return not self.truncated and math.isfinite(self.r_top_m) and math.isfinite(self.r_end_m)


check_init_takes_fields(ShadowMeasurement)


def measure_pair(
    segmentation: Segmentation,
    pair: Pair,
    *,
    range_m: NDArray[np.float64],
    beam_azimuth_rad: NDArray[np.float64],
    config: MeasureConfig | None = None,
) -> ShadowMeasurement:
    """Measure one pair (:func:`measure_pairs` for a single pair)."""
    return measure_pairs(segmentation, [pair], range_m=range_m, beam_azimuth_rad=beam_azimuth_rad,
                         config=config)[0]


def _cuts(pair: Pair, edges: FrameEdges, n: int, segmentation: Segmentation) -> list[tuple[str, str]]:
    """What cuts the measurement of pair ``n``: (flag, sentence) pairs, from its flags and its
    beams (where the insonified band runs to the window's last grid step, a shadow cut at
    the band's far edge runs to the window's end)."""
    reasons = [(f, TRUNCATION_REASONS[f]) for f in pair.fov_flags
               if f in _CUTTING_FLAGS and f not in ("band_far", "band_near")]
    central = int(edges.n_central[n])
    cut_far, cut_near = int(edges.cut_far[n]), int(edges.cut_near[n])
    if central and 2 * cut_far > central:
        n_rows = segmentation.n_rows
        band_end = int(np.max(segmentation.band_stop_rows[list(pair.columns)]))
        where = ("window_end" if pair.shadow.row_stop >= n_rows or band_end >= n_rows - 2 * segmentation.row_step
                 else "band_far")
        reasons.append((where, f"{TRUNCATION_REASONS[where]}, in {cut_far} of its {central} central beams"))
    if central and 2 * cut_near > central:
        sentence = f"{TRUNCATION_REASONS['band_near']}, in {cut_near} of its {central} central beams"
        reasons.append(("band_near", sentence))
    return reasons


@functools.lru_cache(maxsize=8)
def _row_axis(n_rows: int) -> NDArray[np.float64]:
    """0 .. n_rows - 1 as float64, read-only: the rows at which ``range_m`` is given."""
    axis = np.arange(n_rows, dtype=np.float64)
    axis.flags.writeable = False
    return axis


#: A beam whose shadow is shorter than this fraction of the pair's median shadow crosses the
#: target's side (a corner, the rounded edge of its top): left out of the pair's ranges.
SIDE_LENGTH_FRACTION = 0.75


def _without_sides(top: list[float], end: list[float], azimuth: list[float]) -> tuple[float, float, float]:
    """The pair's start, end and azimuth: means over its beams but those crossing the target's
    side (shadow under :data:`SIDE_LENGTH_FRACTION` of the median length). Plain Python: a
    pair has a few dozen beams at most."""
    lengths = [e - t for t, e in zip(top, end, strict=True)]
    n = len(lengths)
    ordered = sorted(lengths)
    half = n // 2
    median = ordered[half] if n % 2 else (ordered[half - 1] + ordered[half]) / 2  # statistics.median's
    least = SIDE_LENGTH_FRACTION * median
    if ordered[0] >= least:  # no beam crosses a side (the usual case): every beam, in order
        return sum(top) / n, sum(end) / n, sum(azimuth) / n
    keep = [i for i, length in enumerate(lengths) if length >= least] or list(range(n))
    k = len(keep)
    return (sum(top[i] for i in keep) / k, sum(end[i] for i in keep) / k, sum(azimuth[i] for i in keep) / k)


def measure_pairs(
    segmentation: Segmentation,
    pairs: Sequence[Pair],
    *,
    range_m: NDArray[np.float64],
    beam_azimuth_rad: NDArray[np.float64],
    config: MeasureConfig | None = None,
) -> list[ShadowMeasurement]:
    """Measure every pair of a frame, their beams processed together.

    Parameters
    ----------
    segmentation : Segmentation
        The frame's segmentation (its levels are read, not modified).
    pairs : sequence of Pair
        Pairs of that segmentation.
    range_m : ndarray, shape (n_samples,)
        Slant range of each row from range zero, m.
    beam_azimuth_rad : ndarray, shape (n_beams,)
        Azimuth of each beam, rad.
    config : MeasureConfig, optional

    Returns
    -------
    list of ShadowMeasurement
        One per pair, in order.
    """
    cfg = config or MeasureConfig()
    if not pairs:
        return []
    edges = find_edges(segmentation, pairs, cfg)
    n_rows = segmentation.n_rows
    n_pairs = len(pairs)
    sample_m = float(range_m[-1] - range_m[0]) / max(range_m.size - 1, 1)
    # Every beam's ranges at once (the three edges in one interpolation; the near edge's
    # missing rows read at row 0, then NaN); each pair's beams are a run of the good beams
    # (in pair order).
    good = edges.good.nonzero()[0]
    n_beams = good.size
    owner = edges.owner[good]
    near_rows = edges.near_rows[good]
    near_ok = np.isfinite(near_rows)
    ranges = np.interp(np.concatenate((edges.top_rows[good], edges.end_rows[good], np.where(near_ok, near_rows, 0.0))),
                       _row_axis(n_rows), range_m)
    near = np.where(near_ok, ranges[2 * n_beams :], np.nan)
    azimuth = np.asarray(beam_azimuth_rad, dtype=np.float64)[edges.beams[good]]
    with np.errstate(invalid="ignore", divide="ignore"):
        mean_near = (np.bincount(owner, weights=np.where(near_ok, near, 0.0), minlength=n_pairs)
                     / np.bincount(owner, weights=near_ok, minlength=n_pairs)).tolist()
    std_rows = np.maximum(np.fmax(edges.top_std_rows, edges.end_std_rows), MIN_EDGE_STD_SAMPLES).tolist()
    bounds = list(itertools.accumulate(np.bincount(owner, minlength=n_pairs).tolist(), initial=0))
    columns = edges.beams[good].tolist()
    top_l, end_l = ranges[:n_beams].tolist(), ranges[n_beams : 2 * n_beams].tolist()
    near_l, azimuth_l = near.tolist(), azimuth.tolist()
    echo_l, depth_l = edges.echo_db.tolist(), edges.depth_db.tolist()
    out = []
    for n, pair in enumerate(pairs):
        cuts = _cuts(pair, edges, n, segmentation)
        reasons = [sentence for _, sentence in cuts]
        cut_by = tuple(flag for flag, _ in cuts)
        highlight_m = (float(range_m[pair.highlight.row_start]) if pair.highlight is not None
                       else float(range_m[min(pair.shadow.row_start, n_rows - 1)]))
        a, b = bounds[n], bounds[n + 1]
        echo, depth = echo_l[n], depth_l[n]
        if b - a < cfg.min_beams:
            if not reasons:
                reasons.append(f"no central beam of the shadow gave both its edges (of {int(edges.n_central[n])})")
            out.append(ShadowMeasurement(
                azimuth_rad=float(np.mean(beam_azimuth_rad[list(pair.columns)])), r_top_m=math.nan,
                r_end_m=math.nan, sigma_r_m=math.nan, highlight_range_m=highlight_m, columns=(),
                r_top_per_beam_m=(), r_end_per_beam_m=(), truncated=True, reason="; ".join(reasons),
                overlap=pair.overlap, shadow_width_beams=pair.shadow.n_cols,
                has_highlight=pair.highlight is not None, echo_db=echo, depth_db=depth, cut_by=cut_by,
            ))
            continue
        r_near = mean_near[n]
        r_top, r_end, azimuth = _without_sides(top_l[a:b], end_l[a:b], azimuth_l[a:b])
        out.append(ShadowMeasurement(
            azimuth_rad=azimuth,
            r_top_m=r_top,
            r_end_m=r_end,
            sigma_r_m=std_rows[n] * sample_m,
            highlight_range_m=r_near if math.isfinite(r_near) else highlight_m,
            columns=tuple(columns[a:b]),
            r_top_per_beam_m=tuple(top_l[a:b]),
            r_end_per_beam_m=tuple(end_l[a:b]),
            truncated=bool(reasons),
            reason="; ".join(reasons) if reasons else None,
            overlap=pair.overlap,
            shadow_width_beams=pair.shadow.n_cols,
            r_near_m=r_near,
            r_near_per_beam_m=tuple(near_l[a:b]),
            azimuth_per_beam_rad=tuple(azimuth_l[a:b]),
            has_highlight=pair.highlight is not None,
            echo_db=echo,
            depth_db=depth,
            cut_by=cut_by,
        ))
    return out
