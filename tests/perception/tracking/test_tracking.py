"""Association of shadows across frames and altitudes."""

from __future__ import annotations

import math

import numpy as np
import pytest

from perception.heights.pipeline import HeightPipeline
from perception.shadows.measurement.measure import ShadowMeasurement
from perception.tracking.tracker import Detection, TargetTracker, TrackingConfig, seabed_position
from tests.perception.shadows.shadow_synth import Box, SynthConfig, render

BOXES = (
    Box(1.2, 0.0, 0.10, 0.05, 0.039),
    Box(1.05, -0.18, 0.06, 0.05, 0.028),
    Box(1.2, 0.2, 0.05, 0.04, 0.047),
)


def _measurement(azimuth_deg: float, r_top: float, r_end: float) -> ShadowMeasurement:
    return ShadowMeasurement(
        azimuth_rad=math.radians(azimuth_deg), r_top_m=r_top, r_end_m=r_end, sigma_r_m=1e-3,
        highlight_range_m=r_top - 0.05, columns=(1,), r_top_per_beam_m=(r_top,),
        r_end_per_beam_m=(r_end,), truncated=False, reason=None, overlap=1.0,
        shadow_width_beams=5,
    )


def test_targets_are_followed_across_two_altitudes(rng: np.random.Generator) -> None:
    pipeline = HeightPipeline()
    for altitude in (0.5, 0.6):
        config = SynthConfig(boxes=BOXES, altitude_m=altitude, tilt_deg=25.0)
        frame, _, _ = render(config, rng=rng)
        result = pipeline.add_frame(frame.with_fields(altitude_m=math.nan, sonar_depth_m=5 - altitude))
        assert len(result.measurements) == 3
    targets = pipeline.targets()
    assert len(targets) == 3
    for target in targets:
        assert target.frames_seen == 2
        azimuths = [d.measurement.azimuth_rad for d in target.detections]
        assert abs(azimuths[0] - azimuths[1]) < math.radians(0.6)
        assert [d.delta_h_m for d in target.detections] == pytest.approx([0.0, 0.1])


def test_pose_lets_targets_be_followed_when_the_sonar_moves(rng: np.random.Generator) -> None:
    # The sonar moves 0.2 m north between pings: azimuths and ranges change, seabed
    # positions do not.
    moved = tuple(Box(b.x0_m - 0.2, b.y_m, b.length_m, b.width_m, b.height_m) for b in BOXES)
    frames = []
    for north, boxes in ((0.0, BOXES), (0.2, moved)):
        frame, _, _ = render(SynthConfig(boxes=boxes, tilt_deg=25.0), rng=rng)
        frames.append(frame.with_fields(north_m=north, east_m=0.0, heading_rad=0.0))
    with_pose = HeightPipeline()
    without_pose = HeightPipeline()
    for frame in frames:
        with_pose.add_frame(frame)
        without_pose.add_frame(frame.with_fields(north_m=math.nan, east_m=math.nan))
    assert sorted(t.frames_seen for t in with_pose.targets()) == [2, 2, 2]
    assert len(without_pose.targets()) == 6  # azimuth-range gates cannot bridge the move
    for target in with_pose.targets():
        norths = [d.north_m for d in target.detections]
        assert norths[0] == pytest.approx(norths[1], abs=0.02)


def test_seabed_position_of_a_known_geometry() -> None:
    # Sonar 0.5 m up, top edge 0.1 m high at ground distance 1.2 m, azimuth 30 deg.
    r_top = math.hypot(1.2, 0.4)
    m = _measurement(30.0, r_top, r_top * 0.5 / 0.4)
    north, east = seabed_position(m, altitude_m=0.5, north_m=10.0, east_m=-2.0, heading_rad=math.pi / 2)
    assert north == pytest.approx(10.0 + 1.2 * math.cos(math.radians(120)))
    assert east == pytest.approx(-2.0 + 1.2 * math.sin(math.radians(120)))
    assert all(math.isnan(v) for v in seabed_position(
        m, altitude_m=math.nan, north_m=0.0, east_m=0.0, heading_rad=0.0
    ))


def test_gates_and_one_detection_per_frame_per_target() -> None:
    tracker = TargetTracker(TrackingConfig())
    first = [Detection(0, _measurement(0.0, 1.5, 1.6), delta_h_m=0.0)]
    assert tracker.update(first) == [0]
    # Frame 1: one close detection (same target), one 5 deg away (a new one).
    ids = tracker.update(
        [
            Detection(1, _measurement(5.0, 1.5, 1.6), delta_h_m=0.1),
            Detection(1, _measurement(0.2, 1.55, 1.64), delta_h_m=0.1),
        ]
    )
    assert ids == [1, 0]
    # Two detections in one frame never join one target.
    ids = tracker.update(
        [
            Detection(2, _measurement(0.1, 1.5, 1.6), delta_h_m=0.0),
            Detection(2, _measurement(0.1, 1.51, 1.61), delta_h_m=0.0),
        ]
    )
    assert sorted(ids) == [0, 2]
    # A range jump larger than the gate (0.04 m + 1.1 x |dH|) starts a new target.
    assert tracker.update([Detection(3, _measurement(0.0, 1.75, 1.85), delta_h_m=0.1)]) == [3]
    assert [len(t.detections) for t in tracker.tracks] == [3, 1, 1, 1]


def test_tracking_config_is_validated() -> None:
    with pytest.raises(ValueError, match="azimuth_gate_rad"):
        TrackingConfig(azimuth_gate_rad=0.0)


def test_a_track_knows_whether_a_detection_lacks_its_altitude() -> None:
    """``Track.lacks_altitude`` follows the detections as they are added, sorted in out of
    order and replaced (a merge), without reading them all again."""
    from perception.tracking.tracker import Track

    def det(frame: int, altitude_m: float) -> Detection:
        return Detection(frame, _measurement(0.0, 1.5, 1.6), altitude_m=altitude_m, delta_h_m=0.0)

    track = Track(1, [det(0, 1.0), det(1, 1.1)])
    assert not track.lacks_altitude
    track.add(det(3, 1.2))
    assert not track.lacks_altitude
    track.add(det(2, math.nan))  # out of order: sorted into the middle
    assert track.lacks_altitude and [d.frame_index for d in track.detections] == [0, 1, 2, 3]
    track.reset([d for d in track.detections if math.isfinite(d.altitude_m)])
    assert not track.lacks_altitude
