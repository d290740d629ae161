"""What the height pipeline gives: per frame (:class:`FrameResult`) and per target (:class:`TargetHeight`)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from perception.shadows.measurement.measure import ShadowMeasurement
from perception.tracking.tracker import Detection


@dataclass(frozen=True)
class FrameResult:
    """What one frame added.

    Attributes
    ----------
    frame_index : int
    timestamp_s : float
    altitude_m, delta_h_m : float
        The altitude information used for the frame (NaN when unknown).
    measurements : tuple of ShadowMeasurement
    target_ids : tuple of int
        The target each measurement was associated with.
    onset_altitude_m : float
        The altitude measured from the seabed onset (``HeightsConfig.seabed_onset_altitude``),
        m; NaN when not measured (altitude given, no onset in the frame, unknown tilt).
    """

    frame_index: int
    timestamp_s: float
    altitude_m: float
    delta_h_m: float
    measurements: tuple[ShadowMeasurement, ...]
    target_ids: tuple[int, ...]
    onset_altitude_m: float = math.nan


@dataclass(frozen=True)
class TargetHeight:
    """One target and its height.

    Attributes
    ----------
    target_id : int
    first_frame_index : int
        The first frame the target was seen in; the location fields refer to it.
    azimuth_rad : float
        Mean azimuth of the beams measured through the shadow, rad (always finite).
    range_m, shadow_end_m : float
        Slant ranges of the shadow start (far top edge) and end in that frame, m. When
        that frame's shadow was cut, ``range_m`` is where the target was seen there (the
        shadow's or the echo's first sample: always finite) and ``shadow_end_m`` NaN.
    north_m, east_m : float
        Estimated seabed position of the target's centre, m: the weighted mean over all
        its frames (:mod:`perception.tracking.tracker`); NaN without pose.
    height_m, height_std_m : float or None
        Height above the seabed and its 1-sigma, m; None when not solvable (``reason``).
        The sigma combines the solver's (from the range noise) with the RMS of the
        per-frame residuals, so frames that disagree (a rounded target) widen it.
    ref_altitude_m : float or None
        The reference (first frame's) altitude used or solved, m.
    residual_rms_m : float or None
        RMS of the per-frame residuals of the height fit, m.
    frames_seen, frames_used : int
        Frames the target was detected in; frames whose shadow gave the height.
    reason : str or None
        Why ``height_m`` is None.
    detections : tuple of Detection
    rounded : bool
        True when the height is a rounded top's summit (``HeightsConfig.rounded_near_echo``
        or ``rounded_summit``), not the sharp-edge solution.
    top_slope_db_per_m : float
        Mean over the used frames of the echo's slope just before the shadow start, dB/m
        (``HeightsConfig.rounded_targets``); NaN when not measured.
    shadow_start : str
        What the shadow's start was taken for: ``"far top edge"`` (the usual case:
        Eq. 2's geometry) or ``"near foot"`` (a tall, short target whose far top edge lies
        nearer in slant range than the seabed at its near foot: the shadow starts at the
        foot, and the height comes from the shadow's ends over the altitudes,
        :mod:`perception.heights.near_foot`) or ``"rounded top"`` (the echo fades towards
        the edge, a rounded top's grazing point: the height is the summit of the
        half-ellipsoid that grazes the ray there and starts the echo where it starts,
        ``HeightsConfig.rounded_near_echo``).
    frame_reasons : tuple of (int, str)
        Per frame that did not give a usable shadow of this target: the frame index and
        why (not detected there, or which edge cut the shadow).
    """

    target_id: int
    first_frame_index: int
    azimuth_rad: float
    range_m: float
    shadow_end_m: float
    north_m: float
    east_m: float
    height_m: float | None
    height_std_m: float | None
    ref_altitude_m: float | None
    residual_rms_m: float | None
    frames_seen: int
    frames_used: int
    reason: str | None
    detections: tuple[Detection, ...]
    rounded: bool = False
    top_slope_db_per_m: float = math.nan
    shadow_start: str = "far top edge"
    frame_reasons: tuple[tuple[int, str], ...] = ()
