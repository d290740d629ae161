"""Where a target's shadow starts and ends, per beam, to a fraction of a range sample.

For each beam through the middle of a paired shadow (:mod:`perception.shadows.pairing.pair`):

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

On a detection grid (:mod:`perception.shadows.segmentation.segment`) the shadow's first and last rows in
each beam are known to the grid's row step; they are refined at full resolution here,
only in the beams measured, before the edges are sought.

The per-beam edge search lives in :mod:`perception.shadows.measurement.edges` (all pairs' beams in
one block) and the full-resolution refinement in :mod:`perception.shadows.measurement.refine`; this
module combines the beams into measurements.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from perception.shadows.measurement.config import MeasureConfig
from perception.shadows.measurement.edges import EDGE_MARGIN_SAMPLES, find_edges
from perception.shadows.pairing.pair import Pair
from perception.shadows.segmentation.segment import Segmentation

__all__ = [
    "EDGE_MARGIN_SAMPLES",
    "TRUNCATION_REASONS",
    "MeasureConfig",
    "ShadowMeasurement",
    "measure_pair",
    "measure_pairs",
]

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


def _new_measurement(**values: object) -> ShadowMeasurement:
    """``ShadowMeasurement(**values)`` (every field by name) at about a third of the cost.

    A frozen dataclass's ``__init__`` sets each field through ``object.__setattr__``;
    filling the new instance's ``__dict__`` gives the same object (equal, same hash,
    repr and pickle), as ``perception.shadows.segmentation.grid`` does for its regions.
    """
    measurement = object.__new__(ShadowMeasurement)
    measurement.__dict__.update(values)
    return measurement


@functools.lru_cache(maxsize=64)
def _truncation(fov_flags: tuple[str, ...], far_flag: str | None) -> tuple[bool, str | None]:
    """Whether a measurement is truncated, and why (cached: a few combinations recur).

    ``fov_flags`` are the pair's flags; ``far_flag`` ("band_far", "window_end" or None)
    says whether, and where, the shadow runs on beyond the band's far edge as judged
    beam by beam from the seabed after it, not from the band's estimated edge.
    """
    cutting = [f for f in fov_flags if f in _CUTTING_FLAGS and f != "band_far"]
    if far_flag is not None and "band_far" not in cutting and "window_end" not in cutting:
        cutting.append(far_flag)
    if not cutting:
        return False, None
    return True, "; ".join(TRUNCATION_REASONS[f] for f in cutting)


def _unmeasured(
    pair: Pair,
    truncated: bool,
    reason: str | None,
    *,
    beam_azimuth_rad: NDArray[np.float64],
    range_m: NDArray[np.float64],
) -> ShadowMeasurement:
    """The measurement of a pair without enough beams with both edges."""
    return _new_measurement(
        azimuth_rad=_mean(beam_azimuth_rad[list(pair.columns)]), r_top_m=math.nan, r_end_m=math.nan,
        sigma_r_m=math.nan, highlight_range_m=float(range_m[pair.highlight.row_start]), columns=(),
        r_top_per_beam_m=(), r_end_per_beam_m=(), truncated=truncated,
        reason=reason or "no beam with both shadow edges found", overlap=pair.overlap,
        shadow_width_beams=pair.shadow.n_cols,
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


#: numpy sums fewer values than this one after another from 0.0, as Python's ``sum`` does
#: (pairwise summation starts at 8 values).
_SEQUENTIAL_SUM_MAX = 7


def _median_and_spread(values: list[float]) -> tuple[float, float]:
    """Median of a short list, and 1.4826 x its median absolute deviation (0 for a single value).

    (Cheaper than ``np.median`` for a few values; the median of an even count is the
    mean of the two middle values, as numpy's.)
    """
    items = sorted(values)
    h = len(items) // 2
    if len(items) % 2:
        middle = items[h]
        deviations = sorted([abs(v - middle) for v in items])
        return middle, 1.4826 * deviations[h]
    middle = 0.5 * (items[h - 1] + items[h])
    deviations = sorted([abs(v - middle) for v in items])
    return middle, 1.4826 * (0.5 * (deviations[h - 1] + deviations[h]))


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
    edges = find_edges(segmentation, pairs, cfg)
    n_all = edges.columns.size
    n_rows = segmentation.levels.shape[0]
    # All pairs' edges to metres in one interpolation (starts, then ends), then plain
    # Python per pair.
    metres = np.interp(edges.rows.ravel(), _rows_axis(n_rows), range_m).tolist()
    azimuths = beam_azimuth_rad[edges.columns]
    azimuth_list = azimuths.tolist()
    columns = edges.columns.tolist()
    quarter_sample_m = 0.25 * (float(range_m[-1] - range_m[0]) / (range_m.size - 1))
    min_beams = cfg.min_beams
    out = []
    start = 0
    # Each pair's per-beam edges (m, and the azimuths of those beams) combined.
    for pair, count, far_cut in zip(pairs, edges.counts, edges.far_cut, strict=True):
        far_flag = ("band_far" if pair.shadow.row_stop < n_rows else "window_end") if far_cut else None
        truncated, reason = _truncation(pair.fov_flags, far_flag)
        if count < min_beams:
            out.append(_unmeasured(pair, truncated, reason, beam_azimuth_rad=beam_azimuth_rad, range_m=range_m))
            start += count
            continue
        stop = start + count
        top_m, end_m = metres[start:stop], metres[n_all + start : n_all + stop]
        r_top, spread_top = _median_and_spread(top_m)
        r_end, spread_end = _median_and_spread(end_m)
        root_n = math.sqrt(count)
        # The mean azimuth as _mean's: the same sum, in Python for a few beams.
        if count <= _SEQUENTIAL_SUM_MAX:
            azimuth = sum(azimuth_list[start:stop]) / count
        else:
            azimuth = float(np.add.reduce(azimuths[start:stop]) / count)
        out.append(_new_measurement(
            azimuth_rad=azimuth, r_top_m=r_top, r_end_m=r_end,
            sigma_r_m=max(1.2533 * max(spread_top, spread_end) / root_n, quarter_sample_m / root_n),
            highlight_range_m=float(range_m[pair.highlight.row_start]), columns=tuple(columns[start:stop]),
            r_top_per_beam_m=tuple(top_m), r_end_per_beam_m=tuple(end_m), truncated=truncated, reason=reason,
            overlap=pair.overlap, shadow_width_beams=pair.shadow.n_cols,
        ))
        start = stop
    return out
