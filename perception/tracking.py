"""Follow targets across frames and across altitudes.

Each frame's shadow measurements are associated with the targets seen so far:

- by position on the seabed when the frames carry pose (``north_m``, ``east_m``,
  ``heading_rad`` and the altitude): the far top edge's ground distance follows from
  one frame's own geometry, ``g_top = r_top * sqrt(r_end^2 - H^2) / r_end`` (the top
  edge and the shadow end share a ray), placed along the beam's bearing;
- otherwise by azimuth-range continuity: a vertical move keeps a target's azimuth and
  changes its slant range by less than the altitude change (``|dr| <= |dH|``), so the
  range gate widens with the altitude change between the frames.

The assignment is a minimum-cost matching inside the gates (Hungarian method); a
measurement that fits no target starts a new one. Targets are never dropped: the
pipeline asks each one for its observations when it solves heights.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import linear_sum_assignment

from perception.measure import ShadowMeasurement

#: Cost given to pairs outside the gates (never chosen).
_FORBIDDEN = 1e6


@dataclass(frozen=True)
class TrackingConfig:
    """Gates of :class:`TargetTracker`.

    Attributes
    ----------
    azimuth_gate_rad : float
        Largest azimuth difference for one target between frames, rad.
    range_gate_m : float
        Largest shadow-start range difference at equal altitude, m.
    range_gate_per_dh : float
        Extra range gate per metre of altitude change between the frames (``|dr| <= |dH|``
        for a vertical move, so 1.0 is enough).
    position_gate_m : float
        Largest seabed distance between positions of one target, m (pose mode).
    unknown_delta_h_m : float
        Altitude change assumed for the range gate when the frames do not say, m.
    """

    azimuth_gate_rad: float = math.radians(3.0)
    range_gate_m: float = 0.04
    range_gate_per_dh: float = 1.1
    position_gate_m: float = 0.15
    unknown_delta_h_m: float = 0.3

    def __post_init__(self) -> None:
        for name in ("azimuth_gate_rad", "range_gate_m", "position_gate_m"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")
        if self.range_gate_per_dh < 0 or self.unknown_delta_h_m < 0:
            raise ValueError("range_gate_per_dh and unknown_delta_h_m must be >= 0")


@dataclass(frozen=True)
class Detection:
    """One measured shadow in one frame, with what the frame knew about its pose.

    Attributes
    ----------
    frame_index : int
        Order of the frame in the pipeline (0 = first).
    measurement : ShadowMeasurement
    altitude_m : float
        The frame's altitude above the seabed, m; NaN when unknown.
    delta_h_m : float
        The frame's altitude minus the first frame's, m; NaN when unknown.
    north_m, east_m : float
        Seabed position of the target's far top edge in local NED, m; NaN without pose.
    """

    frame_index: int
    measurement: ShadowMeasurement
    altitude_m: float = math.nan
    delta_h_m: float = math.nan
    north_m: float = math.nan
    east_m: float = math.nan

    @property
    def has_position(self) -> bool:
        """True when the seabed position is known."""
        return math.isfinite(self.north_m) and math.isfinite(self.east_m)


def seabed_position(
    measurement: ShadowMeasurement,
    *,
    altitude_m: float,
    north_m: float,
    east_m: float,
    heading_rad: float,
) -> tuple[float, float]:
    """Local NED (north, east) of a target's far top edge, m; NaNs when not computable.

    Uses one frame's geometry (flat seabed): ``g_top = r_top sqrt(r_end^2 - H^2) / r_end``
    along the bearing ``heading + azimuth`` (the small change of bearing with tilt is
    neglected; the tracker's gate absorbs it).
    """
    values = (measurement.r_top_m, measurement.r_end_m, altitude_m, north_m, east_m, heading_rad)
    if not all(math.isfinite(v) for v in values) or measurement.r_end_m <= altitude_m:
        return math.nan, math.nan
    ground_end = math.sqrt(measurement.r_end_m**2 - altitude_m**2)
    ground_top = measurement.r_top_m * ground_end / measurement.r_end_m
    bearing = heading_rad + measurement.azimuth_rad
    return north_m + ground_top * math.cos(bearing), east_m + ground_top * math.sin(bearing)


@dataclass
class Track:
    """A target followed across frames (mutable; owned by :class:`TargetTracker`)."""

    track_id: int
    detections: list[Detection] = field(default_factory=list)

    @property
    def last(self) -> Detection:
        """The most recent detection."""
        return self.detections[-1]

    def frame_indices(self) -> set[int]:
        """Frames this target was seen in."""
        return {d.frame_index for d in self.detections}


class TargetTracker:
    """Associates each frame's detections with targets; see the module docstring.

    Parameters
    ----------
    config : TrackingConfig, optional
    """

    def __init__(self, config: TrackingConfig | None = None):
        self.config = config or TrackingConfig()
        self._tracks: list[Track] = []

    @property
    def tracks(self) -> tuple[Track, ...]:
        """Every target so far, in order of first sight."""
        return tuple(self._tracks)

    def _cost(self, track: Track, det: Detection) -> float:
        cfg = self.config
        ref = track.last
        if det.frame_index == ref.frame_index:  # frames arrive in order: one per frame
            return _FORBIDDEN
        if ref.has_position and det.has_position:
            distance = math.hypot(det.north_m - ref.north_m, det.east_m - ref.east_m)
            return distance / cfg.position_gate_m if distance <= cfg.position_gate_m else _FORBIDDEN
        m, r = det.measurement, ref.measurement
        d_az = abs(m.azimuth_rad - r.azimuth_rad)
        if d_az > cfg.azimuth_gate_rad:
            return _FORBIDDEN
        dh = det.delta_h_m - ref.delta_h_m
        if not math.isfinite(dh):
            dh = det.altitude_m - ref.altitude_m
        if not math.isfinite(dh):
            dh = cfg.unknown_delta_h_m
        gate = cfg.range_gate_m + cfg.range_gate_per_dh * abs(dh)
        if math.isfinite(m.r_top_m) and math.isfinite(r.r_top_m):
            d_r = abs(m.r_top_m - r.r_top_m)
        else:
            d_r = abs(m.highlight_range_m - r.highlight_range_m)
        if d_r > gate:
            return _FORBIDDEN
        return d_az / cfg.azimuth_gate_rad + d_r / gate

    def update(self, detections: list[Detection]) -> list[int]:
        """Associate one frame's detections; returns the track id of each, in order."""
        ids = [-1] * len(detections)
        if self._tracks and detections:
            cost = np.array([[self._cost(t, d) for d in detections] for t in self._tracks])
            rows, cols = linear_sum_assignment(cost)
            for row, col in zip(rows, cols, strict=True):
                if cost[row, col] < _FORBIDDEN:
                    self._tracks[row].detections.append(detections[col])
                    ids[col] = self._tracks[row].track_id
        for i, det in enumerate(detections):
            if ids[i] < 0:
                track = Track(track_id=len(self._tracks), detections=[det])
                self._tracks.append(track)
                ids[i] = track.track_id
        return ids
