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
no rounding), with the fit's standard deviation.

Ranges are slant ranges from the sonar's acoustic centre (range ZERO), read from the
frame's ``range_m`` axis at the fractional row, never counted from the window start.

A shadow cut by an edge of the field of view -- the fan's, the range window's, or the
insonified band's (judged beam by beam from the image: no seabed after the shadow, or no
echo before it) -- is flagged ``truncated`` with a reason that says which edge and in how
many beams, and is not used for a height.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from perception.shadows.measurement.config import MeasureConfig
from perception.shadows.measurement.edges import PairEdges, find_edges
from perception.shadows.pairing.pair import Pair
from perception.shadows.segmentation.result import Segmentation

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
        Mean azimuth of the beams used, rad, positive to starboard.
    r_top_m, r_end_m : float
        Slant ranges of the shadow start and end from range zero, m (mean over the beams
        used); NaN when not measurable.
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
    """Measure one pair (:func:`measure_pairs` for a single pair)."""
    return measure_pairs(segmentation, [pair], range_m=range_m, beam_azimuth_rad=beam_azimuth_rad,
                         config=config)[0]


def _cuts(pair: Pair, edges: PairEdges, n_rows: int) -> list[str]:
    """Reasons (sentences) that cut this measurement, from the pair's flags and its beams."""
    reasons = [TRUNCATION_REASONS[f] for f in pair.fov_flags if f in _CUTTING_FLAGS and f != "band_far"
               and f != "band_near"]
    n = edges.n_central
    if n and 2 * edges.cut_far > n:
        where = "window_end" if pair.shadow.row_stop >= n_rows else "band_far"
        reasons.append(f"{TRUNCATION_REASONS[where]}, in {edges.cut_far} of its {n} central beams")
    if n and 2 * edges.cut_near > n:
        reasons.append(f"{TRUNCATION_REASONS['band_near']}, in {edges.cut_near} of its {n} central beams")
    return reasons


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
    all_edges = find_edges(segmentation, pairs, cfg)
    n_rows = segmentation.n_rows
    rows_axis = np.arange(n_rows, dtype=np.float64)
    sample_m = float(range_m[-1] - range_m[0]) / max(range_m.size - 1, 1)
    out = []
    for pair, edges in zip(pairs, all_edges, strict=True):
        reasons = _cuts(pair, edges, n_rows)
        highlight_m = (float(range_m[pair.highlight.row_start]) if pair.highlight is not None
                       else float(range_m[min(pair.shadow.row_start, n_rows - 1)]))
        count = len(edges.columns)
        if count < cfg.min_beams:
            if not reasons:
                reasons.append(f"no central beam of the shadow gave both its edges (of {edges.n_central})")
            out.append(ShadowMeasurement(
                azimuth_rad=float(np.mean(beam_azimuth_rad[list(pair.columns)])), r_top_m=math.nan,
                r_end_m=math.nan, sigma_r_m=math.nan, highlight_range_m=highlight_m, columns=(),
                r_top_per_beam_m=(), r_end_per_beam_m=(), truncated=True, reason="; ".join(reasons),
                overlap=pair.overlap, shadow_width_beams=pair.shadow.n_cols,
                has_highlight=pair.highlight is not None, echo_db=edges.echo_db, depth_db=edges.depth_db,
            ))
            continue
        top = np.interp(edges.top_rows, rows_axis, range_m)
        end = np.interp(edges.end_rows, rows_axis, range_m)
        near_all = np.where(np.isfinite(edges.near_rows),
                            np.interp(np.nan_to_num(edges.near_rows), rows_axis, range_m), np.nan)
        near = near_all[np.isfinite(near_all)]
        r_near = float(np.mean(near)) if near.size else math.nan
        std_rows = max(edges.top_std_rows, edges.end_std_rows, MIN_EDGE_STD_SAMPLES)
        out.append(ShadowMeasurement(
            azimuth_rad=float(np.mean(beam_azimuth_rad[list(edges.columns)])),
            r_top_m=float(np.mean(top)),
            r_end_m=float(np.mean(end)),
            sigma_r_m=std_rows * sample_m,
            highlight_range_m=r_near if math.isfinite(r_near) else highlight_m,
            columns=edges.columns,
            r_top_per_beam_m=tuple(float(v) for v in top),
            r_end_per_beam_m=tuple(float(v) for v in end),
            truncated=bool(reasons),
            reason="; ".join(reasons) if reasons else None,
            overlap=pair.overlap,
            shadow_width_beams=pair.shadow.n_cols,
            r_near_m=r_near,
            r_near_per_beam_m=tuple(float(v) for v in near_all),
            azimuth_per_beam_rad=tuple(float(v) for v in beam_azimuth_rad[list(edges.columns)]),
            has_highlight=pair.highlight is not None,
            echo_db=edges.echo_db,
            depth_db=edges.depth_db,
        ))
    return out
