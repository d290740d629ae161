"""From sonar frames to seabed targets with heights: the whole perception chain.

Per frame (:mod:`perception.heights.detect`): segmentation, targets from shadows and
highlights (the paper's Algorithm 1), the shadow edges; across frames: association
(:mod:`perception.tracking.tracker`); per target (:mod:`perception.heights.target_solve`):
the N-frame height solver, and whether each shadow starts at the far top edge or at the
near foot (:mod:`perception.heights.near_foot`).

Frames may differ in everything but the scene: range window (start, length, sample count
and spacing), gain, TVG, dtype; every stage works in metres of slant range and in units of
each frame's own seabed spread, so frames are compared by physical quantities only.

:class:`HeightPipeline` is incremental, for use on board during a dive: add one frame at a
time (cost: one segmentation and a few targets' measurements) and ask for the targets at
any time. It keeps only the measurements, never the images.

Altitude information of a frame, first found wins: the ``altitude_m``/``delta_h_m``
passed to :meth:`HeightPipeline.add_frame` (e.g. from the altitude filter), the frame's
``altitude_m``, its ``sonar_depth_m`` (``delta_h = depth_first - depth``). A target's
height uses the absolute altitudes when all its frames have one, else the altitude
changes with one reference altitude shared by all targets, solved from their shadows
together with the seabed onset of each frame (:mod:`perception.heights.reference`), which
fixes it far better than Eq. 2's conditioning lets the shadows do.

Each height's sigma holds the range noise, the frames' disagreement, a systematic
offset of the edges per altitude (``HeightsConfig.edge_bias_samples``) and, for a
target whose echo fades towards its far top edge (a rounded top, whose shadow is cast
from a grazing point below the summit), the rounded-top model's gap
(``HeightsConfig.rounded_targets``).
"""

from __future__ import annotations

import math

from perception.heights.config import HeightsConfig
from perception.heights.detect import detect_shadows, frame_detections
from perception.heights.models import OnsetAltitude, altitude_groups, onset_altitude, top_echo_slope_db_per_m
from perception.heights.reference import onset_reference_altitude, shared_reference_altitude
from perception.heights.results import FrameResult, TargetHeight
from perception.heights.target_solve import EVERY_FRAME_UP_TO, TargetSolver
from perception.sonar_io.frame import SonarFrame
from perception.tracking.tracker import TargetTracker

__all__ = [
    "FrameResult",
    "HeightPipeline",
    "HeightsConfig",
    "OnsetAltitude",
    "TargetHeight",
    "altitude_groups",
    "detect_shadows",
    "onset_altitude",
    "top_echo_slope_db_per_m",
]


class HeightPipeline:
    """Incremental frames-to-heights pipeline; see the module docstring.

    Parameters
    ----------
    config : HeightsConfig, optional
    """

    def __init__(self, config: HeightsConfig | None = None):
        self.config = config or HeightsConfig()
        self._tracker = TargetTracker(self.config.tracking)
        self._n_frames = 0
        self._first_altitude_m = math.nan
        self._first_depth_m = math.nan
        self._onsets: list[OnsetAltitude] = []
        self._sample_m: dict[int, float] = {}
        self._targets_cache: tuple[int, list[TargetHeight]] | None = None
        # per track: what its answer depends on, the frame count then, the answer
        self._solved: dict[int, tuple[tuple[object, ...], int, TargetHeight]] = {}  # (key, n, answer)
        self._beam_rad: dict[int, float] = {}
        self._solver = TargetSolver(self.config, self._sample_m, self._beam_rad)

    @property
    def n_frames(self) -> int:
        """Frames added so far."""
        return self._n_frames

    def _altitude_info(
        self, frame: SonarFrame, altitude_m: float | None, delta_h_m: float | None
    ) -> tuple[float, float]:
        altitude = frame.altitude_m if altitude_m is None else float(altitude_m)
        first = self._n_frames == 0
        if first:
            self._first_altitude_m = altitude
            self._first_depth_m = frame.sonar_depth_m
        if delta_h_m is not None:
            delta = float(delta_h_m)
        elif first:
            delta = 0.0
        elif math.isfinite(altitude) and math.isfinite(self._first_altitude_m):
            delta = altitude - self._first_altitude_m
        elif math.isfinite(frame.sonar_depth_m) and math.isfinite(self._first_depth_m):
            delta = self._first_depth_m - frame.sonar_depth_m
        else:
            delta = math.nan
        return altitude, delta

    def add_frame(
        self,
        frame: SonarFrame,
        *,
        altitude_m: float | None = None,
        delta_h_m: float | None = None,
    ) -> FrameResult:
        """Process one frame and associate its shadows with the targets.

        Parameters
        ----------
        frame : SonarFrame
        altitude_m : float, optional
            The frame's altitude above the seabed, m (overrides ``frame.altitude_m``).
        delta_h_m : float, optional
            The frame's altitude minus the first frame's, m (overrides what the frame
            fields give).
        """
        altitude, delta = self._altitude_info(frame, altitude_m, delta_h_m)
        r = frame.range_m
        self._sample_m[self._n_frames] = float(r[-1] - r[0]) / max(r.size - 1, 1)
        beams = frame.beam_azimuth_rad
        self._beam_rad[self._n_frames] = abs(float(beams[-1] - beams[0])) / max(beams.size - 1, 1)
        measurements = detect_shadows(
            frame.image,
            range_m=frame.range_m,
            beam_azimuth_rad=frame.beam_azimuth_rad,
            config=self.config,
        )
        detections = frame_detections(frame, measurements, frame_index=self._n_frames, altitude_m=altitude,
                                      delta_h_m=delta, config=self.config)
        ids = self._tracker.update(detections)
        onset = None
        if self.config.seabed_onset_altitude and not math.isfinite(altitude) and math.isfinite(delta):
            onset = onset_altitude(frame, frame_index=self._n_frames, delta_h_m=delta, config=self.config)
            if onset is not None:
                self._onsets.append(onset)
        result = FrameResult(
            frame_index=self._n_frames,
            timestamp_s=frame.timestamp_s,
            altitude_m=altitude,
            delta_h_m=delta,
            measurements=measurements,
            target_ids=tuple(ids),
            onset_altitude_m=math.nan if onset is None else onset.altitude_m,
        )
        self._n_frames += 1
        return result

    def targets(self) -> list[TargetHeight]:
        """Every target so far with its height (or the reason there is none).

        Solved once per frame added: a second call before the next frame returns the same
        estimates without solving again (the pitch loop asks several times a second). A
        track is solved again only when something its answer depends on has changed
        (:meth:`_solve_key`): most tracks of a dive are behind the vehicle, their answers
        fixed.
        """
        if self._targets_cache is not None and self._targets_cache[0] == self._n_frames:
            return list(self._targets_cache[1])
        tracks = self._tracker.tracks
        shared = self.shared_reference_altitude() if self.config.shared_altitude else None
        solved = []
        for track in tracks:
            position = track.position_m()[:2]
            key = self._solve_key(track.detections, shared, position, lacks_altitude=track.lacks_altitude)
            memo = self._solved.get(track.track_id)
            if memo is not None and memo[0] == key:
                solved.append(memo[2])
                continue
            answer = self._solver.solve(track.track_id, track.detections, shared, position, n_frames=self._n_frames)
            self._solved[track.track_id] = (key, self._n_frames, answer)
            solved.append(answer)
        if len(self._solved) > len(tracks):  # tracks the tracker folded into others
            live = {track.track_id for track in tracks}
            self._solved = {k: v for k, v in self._solved.items() if k in live}
        self._targets_cache = (self._n_frames, solved)
        return list(solved)

    def _solve_key(self, detections: list, shared: tuple[float, float] | None,
                   position: tuple[float, float], *, lacks_altitude: bool) -> tuple[object, ...]:
        """What :meth:`TargetSolver.solve`'s answer for a track depends on: its detections
        (appended in frame order, so their count and ends name them), its position, the
        shared reference altitude (only when a frame lacks an absolute altitude:
        ``lacks_altitude``, :attr:`Track.lacks_altitude`), and the frame count in a short
        recording (its per-frame reasons, and "of N frames")."""
        needs_shared = lacks_altitude
        counts_frames = self._n_frames <= EVERY_FRAME_UP_TO
        ends = (detections[0].frame_index, detections[-1].frame_index) if detections else ()
        return (len(detections), ends, id(detections[-1]) if detections else 0, tuple(position),
                shared if needs_shared else None, self._n_frames if counts_frames else None)

    def onset_reference_altitude(self) -> tuple[float, float] | None:
        """The first frame's altitude and its 1-sigma from the seabed onsets, m
        (:func:`perception.heights.reference.onset_reference_altitude`)."""
        return onset_reference_altitude(self._onsets)

    def shadows_reference_altitude(self) -> tuple[float, float] | None:
        """The first frame's altitude and its 1-sigma, m, from the targets' shadows alone (no
        seabed onset): a check of the altitude changes given (a wrong sign puts it below the
        seabed, where the onset would not)."""
        return shared_reference_altitude(self._tracker.tracks, self._solver, (), self.config)

    def shared_reference_altitude(self) -> tuple[float, float] | None:
        """The first frame's altitude and its 1-sigma, m, from all targets and the seabed
        onsets (:func:`perception.heights.reference.shared_reference_altitude`)."""
        return shared_reference_altitude(self._tracker.tracks, self._solver, self._onsets, self.config)
