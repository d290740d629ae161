"""Follow targets across frames, altitudes, passes and viewing directions.

Each frame's shadow measurements are associated with the targets seen so far.

With pose (the frame's ``north_m``, ``east_m``, ``heading_rad`` and altitude), by the
target's seabed CENTRE, estimated from one frame's own geometry (flat seabed, bearing
``heading + azimuth``):

- the far top edge lies at ground distance ``g_top = r_top * g_end / r_end`` with
  ``g_end = sqrt(r_end^2 - H^2)`` (the top edge and the shadow end share a ray), and the
  frame's own height guess is ``h = H (1 - g_top / g_end)``;
- the near face (the highlight's start, slant range ``r_hl``) lies at
  ``g_near = sqrt(r_hl^2 - (H - h)^2)``;
- the centre is ``(g_near + g_top) / 2``. Unlike the far top edge, it does not jump to
  the other side of the target when the lane runs the other way. Without a shadow edge
  (a cut shadow), the centre is guessed ``default_half_length_m`` beyond the near face and
  the gate is widened by ``highlight_only_extra_gate_m``.

Each detection carries a gate that grows with slant range (heading and azimuth errors)
and altitude (altitude errors, the beam's footprint); a target's position is the
inverse-gate-squared weighted mean of its detections' centres. Without pose, by
azimuth-range continuity with the target's last detection: a vertical move keeps a
target's azimuth and changes its slant range by less than the altitude change
(``|dr| <= |dH|``), so the range gate widens with the altitude change between frames.

The assignment is a minimum-cost matching inside the gates (Hungarian method, on the
targets within reach only); a measurement that fits no target starts a new one. After
each frame, targets that turn out to be one (positions within both gates, compatible
height guesses, seen together in at most a few frames) are merged, keeping one
detection per frame; targets seen in fewer than ``prune_min_detections`` frames, never
with a complete shadow, and not for ``prune_after_frames`` frames are dropped (they give
no height and are most often speckle); at most ``max_tracks`` targets are kept. A cut
shadow joining a target takes the target's recent far top edge (``carry_top_frames``), so
consumers that follow the far top edge (the pitch loop) keep the target while its shadow
is cut.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
from scipy.optimize import linear_sum_assignment

from perception.tracking.config import TrackingConfig
from perception.tracking.detection import CentreEstimate, Detection, seabed_centre, seabed_position

__all__ = [
    "CentreEstimate",
    "Detection",
    "TargetTracker",
    "Track",
    "TrackingConfig",
    "seabed_centre",
    "seabed_position",
]

#: Cost given to pairs outside the gates (never chosen).
_FORBIDDEN = 1e6


@dataclass
class Track:
    """A target followed across frames (mutable; owned by :class:`TargetTracker`).

    ``detections`` are kept in frame order. The weighted sums behind :meth:`position_m`
    are kept up to date by :meth:`add`, so a position costs O(1).
    """

    track_id: int
    detections: list[Detection] = field(default_factory=list)
    default_gate_m: float = TrackingConfig.position_gate_m
    _sums: list[float] = field(default_factory=lambda: [0.0] * 5, init=False, repr=False)
    #: Whether a detection lacks its frame's absolute altitude (kept as they are added: reading
    #: every detection of every track each time the targets are solved grew with the square
    #: of a dive's length).
    lacks_altitude: bool = field(default=False, init=False)

    def __post_init__(self) -> None:
        self.reset(self.detections)

    def reset(self, detections: list[Detection]) -> None:
        """Replace the detections (any order) and recompute the position sums."""
        self.detections = []
        self._sums = [0.0] * 5
        self.lacks_altitude = False
        for det in sorted(detections, key=lambda d: d.frame_index):
            self.add(det)

    def add(self, det: Detection) -> None:
        """Append one detection (frames arrive in order) and update the position sums."""
        self.detections.append(det)
        self.lacks_altitude = self.lacks_altitude or not math.isfinite(det.altitude_m)
        if len(self.detections) > 1 and det.frame_index < self.detections[-2].frame_index:
            self.detections.sort(key=lambda d: d.frame_index)
        if det.is_placed:
            gate = det.gate_m if math.isfinite(det.gate_m) else self.default_gate_m
            w = 1.0 / gate**2
            north, east = det.position_m
            for i, v in enumerate((w, w * north, w * east, gate, 1.0)):
                self._sums[i] += v

    @property
    def last(self) -> Detection:
        """The most recent detection."""
        return self.detections[-1]

    def frame_indices(self) -> set[int]:
        """Frames this target was seen in."""
        return {d.frame_index for d in self.detections}

    def position_m(self) -> tuple[float, float, float]:
        """(north, east, gate) of the target, m: the inverse-gate-squared weighted mean of
        its detections' centres and their mean gate; NaNs when none has a position."""
        w, wn, we, gates, n = self._sums
        if n == 0:
            return math.nan, math.nan, math.nan
        return wn / w, we / w, gates / n

    def height_guess_m(self) -> float:
        """Median of the detections' one-frame heights, m; NaN when none has one."""
        values = [d.height_guess_m for d in self.detections if math.isfinite(d.height_guess_m)]
        return float(np.median(values)) if values else math.nan


class TargetTracker:
    """Associates each frame's detections with targets; see the module docstring.

    Parameters
    ----------
    config : TrackingConfig, optional
    """

    def __init__(self, config: TrackingConfig | None = None):
        self.config = config or TrackingConfig()
        self._tracks: list[Track] = []
        self._next_id = 0

    @property
    def tracks(self) -> tuple[Track, ...]:
        """Every target so far, in order of first sight."""
        return tuple(self._tracks)

    def _new_track(self, det: Detection) -> Track:
        track = Track(self._next_id, [det], default_gate_m=self.config.position_gate_m)
        self._next_id += 1
        self._tracks.append(track)
        return track

    def _cost(self, track: Track, det: Detection) -> float:
        """Azimuth-range cost against the track's last detection (frames without pose)."""
        cfg = self.config
        ref = track.last
        if det.frame_index == ref.frame_index:  # frames arrive in order: one per frame
            return _FORBIDDEN
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

    def _cost_matrix(self, detections: list[Detection]) -> np.ndarray:
        """Costs, shape (n_tracks, n_detections): position gates with pose, else azimuth-range."""
        cfg = self.config
        n_t, n_d = len(self._tracks), len(detections)
        cost = np.full((n_t, n_d), _FORBIDDEN)
        state = self._positions()
        placed = np.isfinite(state[:, 0])
        for j, det in enumerate(detections):
            if det.is_placed:
                north, east = det.position_m
                gate_d = det.gate_m if math.isfinite(det.gate_m) else cfg.position_gate_m
                distance = np.hypot(state[:, 0] - north, state[:, 1] - east)
                gate = np.maximum(gate_d, np.nan_to_num(state[:, 2], nan=0.0))
                ok = placed & (distance <= gate) & (state[:, 3] != det.frame_index)
                cost[ok, j] = distance[ok] / gate[ok]
                rows = np.flatnonzero(~placed)
            else:
                rows = np.arange(n_t)
            for i in rows:  # without pose: azimuth-range continuity (Python, no-pose mode only)
                cost[i, j] = self._cost(self._tracks[i], det)
        return cost

    def update(self, detections: list[Detection]) -> list[int]:
        """Associate one frame's detections; returns the track id of each, in order.

        Targets merged after this frame keep the older id; the returned ids are the ids
        after merging.
        """
        ids = [-1] * len(detections)
        touched: list[Track] = []
        if self._tracks and detections:
            cost = self._cost_matrix(detections)
            rows_in_reach = np.flatnonzero(np.any(cost < _FORBIDDEN, axis=1))
            if rows_in_reach.size:
                sub = cost[rows_in_reach]
                rows, cols = linear_sum_assignment(sub)
                for row, col in zip(rows, cols, strict=True):
                    if sub[row, col] < _FORBIDDEN:
                        track = self._tracks[int(rows_in_reach[row])]
                        track.add(self._with_carried_top(track, detections[col]))
                        ids[col] = track.track_id
                        touched.append(track)
        for i, det in enumerate(detections):
            if ids[i] < 0:
                track = self._new_track(det)
                ids[i] = track.track_id
                touched.append(track)
        renamed = self._merge(touched)
        if detections:
            self._prune(max(d.frame_index for d in detections))
        return [renamed.get(i, i) for i in ids]

    def _with_carried_top(self, track: Track, det: Detection) -> Detection:
        """``det`` with the far top edge of the track's latest detection that had its own
        (config ``carry_top_frames``), when ``det`` has none."""
        if det.has_position or not det.is_placed:
            return det
        for ref in reversed(track.detections):
            if det.frame_index - ref.frame_index > self.config.carry_top_frames:
                break
            if ref.has_position and ref.top_frame_index < 0:
                return replace(det, north_m=ref.north_m, east_m=ref.east_m, top_frame_index=ref.frame_index)
        return det

    def _compatible_heights(self, a: Track, b: Track) -> bool:
        cfg = self.config
        ha, hb = a.height_guess_m(), b.height_guess_m()
        if not (math.isfinite(ha) and math.isfinite(hb)):
            return True
        return abs(ha - hb) <= cfg.merge_height_gate_m + cfg.merge_height_fraction * max(ha, hb)

    def _positions(self) -> np.ndarray:
        """(north, east, gate, last frame) of every track, shape (n_tracks, 4), m (NaN: unplaced)."""
        rows = [(*t.position_m(), t.last.frame_index) for t in self._tracks]
        return np.array(rows, dtype=float).reshape(len(rows), 4)

    def _merge(self, touched: list[Track]) -> dict[int, int]:
        """Merge each touched track with the others that are the same target; old id -> new."""
        cfg = self.config
        renamed: dict[int, int] = {}
        state = self._positions()
        for track in touched:
            if track.track_id in renamed:
                continue
            while True:
                north, east, gate = track.position_m()
                if not math.isfinite(north):
                    break
                distance = np.hypot(state[:, 0] - north, state[:, 1] - east)
                near = np.flatnonzero(distance <= np.minimum(gate, state[:, 2]))
                frames = track.frame_indices()
                partner = None
                for i in near[np.argsort(distance[near])]:
                    other = self._tracks[int(i)]
                    if other is track:
                        continue
                    shared = len(frames & other.frame_indices())
                    if shared > cfg.merge_max_shared_fraction * min(len(frames), len(other.detections)):
                        continue
                    if self._compatible_heights(track, other):
                        partner = other
                        break
                if partner is None:
                    break
                keep, gone = (track, partner) if track.track_id < partner.track_id else (partner, track)
                self._absorb(keep, gone)
                self._tracks.remove(gone)
                state = self._positions()
                renamed[gone.track_id] = keep.track_id
                for old, new in renamed.items():
                    if new == gone.track_id:
                        renamed[old] = keep.track_id
                track = keep
        return renamed

    def _absorb(self, keep: Track, gone: Track) -> None:
        """Move ``gone``'s detections into ``keep``; in a frame both saw, keep the complete
        shadow (or ``keep``'s detection)."""
        by_frame = {d.frame_index: d for d in keep.detections}
        merged = dict(by_frame)
        for det in gone.detections:
            mine = by_frame.get(det.frame_index)
            if mine is None or (det.measurement.usable and not mine.measurement.usable):
                merged[det.frame_index] = det
        keep.reset(list(merged.values()))

    def _prune(self, frame_index: int) -> None:
        """Drop rarely seen targets without a complete shadow not seen for a while; cap the
        number of targets."""
        cfg = self.config
        self._tracks = [
            t for t in self._tracks
            if len(t.detections) >= cfg.prune_min_detections
            or frame_index - t.last.frame_index < cfg.prune_after_frames
            or any(d.measurement.usable for d in t.detections)
        ]
        if len(self._tracks) > cfg.max_tracks:
            ranked = sorted(self._tracks, key=lambda t: (len(t.detections), t.last.frame_index))
            drop = {id(t) for t in ranked[: len(self._tracks) - cfg.max_tracks]}
            self._tracks = [t for t in self._tracks if id(t) not in drop]
