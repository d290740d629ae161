"""One target seen from opposite directions and altitudes stays one; near ones stay apart.

Frames are rendered exactly (``shadow_synth``) for boxes placed on the seabed in local NED
and a sonar at a given position, heading and altitude: the box's centre in the sonar's
frame is ``x = dN cos(psi) + dE sin(psi)`` ahead and ``y = -dN sin(psi) + dE cos(psi)`` to
starboard.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import perception.heights.pipeline as heights_module
from perception.heights.pipeline import HeightPipeline, HeightsConfig
from perception.shadows.measurement.measure import ShadowMeasurement
from perception.tracking.tracker import Detection, TargetTracker, TrackingConfig, seabed_centre
from tests.perception.shadows.shadow_synth import Box, SynthConfig, render


@dataclass(frozen=True)
class SeabedBox:
    """A box on the seabed: centre (local NED, m), length along north, width along east."""

    north_m: float
    east_m: float
    length_m: float
    width_m: float
    height_m: float


#: (sonar north, east, heading rad, altitude m): two lanes run in opposite directions,
#: each at two altitudes, 1.2 m short of / beyond the targets at north 2.0.
VIEWS = (
    (0.8, 0.0, 0.0, 0.5),
    (0.85, 0.0, 0.0, 0.6),
    (3.2, 0.0, math.pi, 0.5),
    (3.15, 0.0, math.pi, 0.6),
)


def _frame(boxes: tuple[SeabedBox, ...], view: tuple[float, float, float, float], rng: np.random.Generator):
    north, east, heading, altitude = view
    c, s = math.cos(heading), math.sin(heading)
    local = []
    for b in boxes:
        dn, de = b.north_m - north, b.east_m - east
        x, y = dn * c + de * s, -dn * s + de * c
        along, across = (b.length_m, b.width_m) if abs(c) > 0.5 else (b.width_m, b.length_m)
        local.append(Box(x - along / 2, y, along, across, b.height_m))
    frame, _, truths = render(
        SynthConfig(boxes=tuple(local), altitude_m=altitude, tilt_deg=25.0), rng=rng
    )
    assert all(t.in_band for t in truths)
    return frame.with_fields(north_m=north, east_m=east, heading_rad=heading)


def _run(boxes: tuple[SeabedBox, ...], rng: np.random.Generator) -> HeightPipeline:
    pipeline = HeightPipeline(HeightsConfig(shared_altitude=False))
    for view in VIEWS:
        pipeline.add_frame(_frame(boxes, view, rng))
    return pipeline


def test_one_target_from_opposite_directions_and_two_altitudes_is_one(rng: np.random.Generator) -> None:
    box = SeabedBox(2.0, 0.05, 0.10, 0.05, 0.039)
    pipeline = _run((box,), rng)
    (target,) = pipeline.targets()
    assert target.frames_seen == 4
    # The far top edges of the two lanes lie a target length apart; the centre does not move.
    tops = [(d.north_m, d.east_m) for d in target.detections]
    assert abs(tops[0][0] - tops[2][0]) == pytest.approx(box.length_m, abs=0.02)
    assert math.hypot(target.north_m - box.north_m, target.east_m - box.east_m) < 0.03
    assert target.height_m is not None and target.height_m == pytest.approx(box.height_m, abs=0.002)
    assert target.frames_used == 4


@pytest.mark.parametrize("separation_m", [0.30, 0.40])
def test_two_targets_a_few_decimetres_apart_stay_two(rng: np.random.Generator, separation_m: float) -> None:
    # Never in one frame together (as at the edges of the fan): only their positions
    # can keep them apart.
    half = separation_m / 2
    boxes = (SeabedBox(2.0, -half, 0.06, 0.05, 0.028), SeabedBox(2.0, half, 0.05, 0.04, 0.047))
    pipeline = HeightPipeline(HeightsConfig(shared_altitude=False))
    for view in VIEWS:
        for box in boxes:
            pipeline.add_frame(_frame((box,), view, rng))
    targets = pipeline.targets()
    assert len(targets) == 2
    for box in boxes:
        target = min(targets, key=lambda t: math.hypot(t.north_m - box.north_m, t.east_m - box.east_m))
        assert math.hypot(target.north_m - box.north_m, target.east_m - box.east_m) < 0.04
        assert target.frames_seen == 4
        assert target.height_m is not None and target.height_m == pytest.approx(box.height_m, abs=0.002)


def _measurement(*, azimuth_rad: float, r_top_m: float, r_end_m: float, highlight_range_m: float) -> ShadowMeasurement:
    return ShadowMeasurement(
        azimuth_rad=azimuth_rad, r_top_m=r_top_m, r_end_m=r_end_m, sigma_r_m=1e-3,
        highlight_range_m=highlight_range_m, columns=(1, 2, 3), r_top_per_beam_m=(r_top_m,),
        r_end_per_beam_m=(r_end_m,), truncated=False, reason=None, overlap=1.0, shadow_width_beams=5,
    )


@settings(max_examples=60, deadline=None)
@given(
    altitude=st.floats(0.3, 2.0),
    height_fraction=st.floats(0.02, 0.5),
    near=st.floats(0.5, 4.0),
    length=st.floats(0.02, 0.5),
    azimuth=st.floats(-0.26, 0.26),
    heading=st.floats(-math.pi, math.pi),
)
def test_seabed_centre_inverts_the_box_geometry(
    altitude: float, height_fraction: float, near: float, length: float, azimuth: float, heading: float
) -> None:
    # Forward: a box from ground distance `near` to `near + length` along the beam, height h.
    h = altitude * height_fraction
    r_top = math.hypot(near + length, altitude - h)
    m = _measurement(
        azimuth_rad=azimuth, r_top_m=r_top, r_end_m=r_top * altitude / (altitude - h),
        highlight_range_m=math.hypot(near, altitude - h),
    )
    centre = seabed_centre(m, altitude_m=altitude, north_m=1.0, east_m=-2.0, heading_rad=heading)
    ground = near + length / 2
    assert centre.north_m == pytest.approx(1.0 + ground * math.cos(heading + azimuth), abs=1e-9)
    assert centre.east_m == pytest.approx(-2.0 + ground * math.sin(heading + azimuth), abs=1e-9)
    assert centre.height_guess_m == pytest.approx(h, abs=1e-9)
    cfg = TrackingConfig()
    assert centre.gate_m == pytest.approx(
        cfg.position_gate_m + cfg.position_gate_per_range * m.highlight_range_m
        + cfg.position_gate_per_altitude * altitude
    )


def test_seabed_centre_of_a_cut_shadow_uses_the_near_face_and_a_wider_gate() -> None:
    m = _measurement(azimuth_rad=0.0, r_top_m=math.nan, r_end_m=math.nan, highlight_range_m=math.hypot(1.2, 0.5))
    cfg = TrackingConfig()
    centre = seabed_centre(m, altitude_m=0.5, north_m=0.0, east_m=0.0, heading_rad=0.0, config=cfg)
    assert centre.north_m == pytest.approx(1.2 + cfg.default_half_length_m)
    assert math.isnan(centre.height_guess_m)
    full = (
        cfg.position_gate_m + cfg.position_gate_per_range * m.highlight_range_m
        + cfg.position_gate_per_altitude * 0.5
    )
    assert centre.gate_m == pytest.approx(full + cfg.highlight_only_extra_gate_m)
    assert math.isnan(seabed_centre(m, altitude_m=math.nan, north_m=0.0, east_m=0.0, heading_rad=0.0).north_m)


def _placed(frame: int, north: float, *, usable: bool = True, gate: float = 0.2) -> Detection:
    m = _measurement(azimuth_rad=0.0, r_top_m=1.5, r_end_m=1.6, highlight_range_m=1.45)
    if not usable:
        m = _measurement(azimuth_rad=0.0, r_top_m=math.nan, r_end_m=math.nan, highlight_range_m=1.45)
    return Detection(frame, m, altitude_m=0.5, centre_north_m=north, centre_east_m=0.0, gate_m=gate)


def test_tracks_that_converge_are_merged_under_the_older_id() -> None:
    tracker = TargetTracker()
    assert tracker.update([_placed(0, 0.0)]) == [0]
    assert tracker.update([_placed(1, 0.25)]) == [1]  # beyond the 0.2 m gate: a new track
    # Nearer track 1: joins it, whose mean (0.19) is then within the gate of track 0.
    assert tracker.update([_placed(2, 0.13)]) == [0]
    (track,) = tracker.tracks
    assert track.track_id == 0 and track.frame_indices() == {0, 1, 2}
    north, _, _ = track.position_m()
    assert north == pytest.approx((0.0 + 0.25 + 0.13) / 3)


def test_targets_seen_together_are_never_merged() -> None:
    tracker = TargetTracker()
    for frame in range(5):
        ids = tracker.update([_placed(frame, 0.0), _placed(frame, 0.15)])
        assert ids == [0, 1]
    assert [len(t.detections) for t in tracker.tracks] == [5, 5]


def test_rare_targets_without_a_complete_shadow_are_pruned() -> None:
    cfg = TrackingConfig(prune_after_frames=10)
    tracker = TargetTracker(cfg)
    tracker.update([_placed(0, 0.0, usable=False), _placed(0, 5.0, usable=True)])
    tracker.update([_placed(9, 10.0)])
    assert len(tracker.tracks) == 3
    tracker.update([_placed(10, 20.0)])
    # The one-frame target without a complete shadow is gone; the one with one stays.
    assert [t.track_id for t in tracker.tracks] == [1, 2, 3]


def test_tracking_config_rejects_bad_merge_and_prune_settings() -> None:
    with pytest.raises(ValueError, match="merge_max_shared_fraction"):
        TrackingConfig(merge_max_shared_fraction=-0.1)
    with pytest.raises(ValueError, match="prune_after_frames"):
        TrackingConfig(prune_after_frames=0)


def test_the_far_top_edge_and_the_centre_are_separate_positions() -> None:
    # planner.pitch.control reads the far top edge (where the shadow starts) of the last
    # detection: a detection placed only by its centre must not claim that position.
    centre_only = _placed(0, 1.0, usable=False)
    assert centre_only.is_placed and not centre_only.has_position
    both = Detection(0, centre_only.measurement, north_m=1.2, east_m=0.0, centre_north_m=1.0, centre_east_m=0.0)
    assert both.has_position and both.position_m == (1.0, 0.0)
    top_only = Detection(0, centre_only.measurement, north_m=1.2, east_m=0.0)
    assert top_only.is_placed and top_only.position_m == (1.2, 0.0)


def test_a_frame_whose_own_height_is_an_outlier_is_left_out(
    rng: np.random.Generator, monkeypatch: pytest.MonkeyPatch
) -> None:
    # Exact shadows of a 4 cm target at six altitudes; in one frame the shadow was cut
    # short (as on one beam of a split target): its one-frame height reads 2.5 cm.
    h, near, length = 0.04, 1.2, 0.1
    altitudes = (0.5, 0.55, 0.6, 0.65, 0.7, 0.75)
    frame, _, _ = render(SynthConfig(), rng=rng)
    queue: list[tuple[ShadowMeasurement, ...]] = []
    monkeypatch.setattr(heights_module, "detect_shadows", lambda image, **_: queue.pop(0))

    def run(config: HeightsConfig) -> float | None:
        pipeline = HeightPipeline(config)
        for k, altitude in enumerate(altitudes):
            r_top = math.hypot(near + length, altitude - h)
            shadow_h = 0.025 if k == 2 else h
            r_end = r_top * altitude / (altitude - shadow_h)
            queue.append((_measurement(azimuth_rad=0.0, r_top_m=r_top, r_end_m=r_end,
                                       highlight_range_m=math.hypot(near, altitude - h)),))
            pipeline.add_frame(frame.with_fields(north_m=0.0, east_m=0.0, heading_rad=0.0), altitude_m=altitude)
        (target,) = pipeline.targets()
        assert target.frames_seen == 6
        return target.height_m

    robust = run(HeightsConfig(shared_altitude=False))
    assert robust == pytest.approx(h, abs=2e-4)
    everything = run(HeightsConfig(shared_altitude=False, outlier_floor_m=1.0))
    assert everything is not None and abs(everything - h) > 1e-3


def test_a_cut_shadow_carries_the_targets_recent_far_top_edge() -> None:
    tracker = TargetTracker(TrackingConfig(carry_top_frames=5))
    complete = Detection(0, _placed(0, 1.0).measurement, north_m=1.05, east_m=0.02, centre_north_m=1.0,
                         centre_east_m=0.0, gate_m=0.2)
    tracker.update([complete])
    tracker.update([_placed(3, 1.01, usable=False)])
    tracker.update([_placed(9, 1.0, usable=False)])  # 9 frames after the last own edge
    (track,) = tracker.tracks
    _, carried, stale = track.detections
    assert (carried.north_m, carried.east_m, carried.top_frame_index) == (1.05, 0.02, 0)
    assert not stale.has_position and stale.top_frame_index == -1
