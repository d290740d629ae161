"""The whole chain: frames in, targets with heights out (exact synthetic frames)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from perception.heights.pipeline import HeightPipeline, HeightsConfig
from tests.perception.shadows.shadow_synth import Box, SynthConfig, render

BOXES = (
    Box(1.2, 0.0, 0.10, 0.05, 0.039),
    Box(1.1, -0.18, 0.06, 0.05, 0.028),
    Box(1.2, 0.25, 0.05, 0.04, 0.047),
)
TILT_DEG = 25.0


def _frame(rng: np.random.Generator, altitude: float, boxes=BOXES, **fields: float):
    frame, _, truths = render(SynthConfig(boxes=boxes, altitude_m=altitude, tilt_deg=TILT_DEG), rng=rng)
    return frame.with_fields(**fields) if fields else frame, truths


def _height_by_azimuth(pipeline: HeightPipeline, truths) -> list[tuple[float, float | None, float | None]]:
    """(true height, estimate, std) per true target, matched by azimuth."""
    out = []
    for truth in truths:
        target = min(pipeline.targets(), key=lambda t: abs(t.azimuth_rad - truth.azimuth_rad))
        assert abs(target.azimuth_rad - truth.azimuth_rad) < math.radians(1.0)
        out.append((truth.box.height_m, target.height_m, target.height_std_m))
    return out


def test_known_altitudes_give_millimetre_heights(rng: np.random.Generator) -> None:
    pipeline = HeightPipeline()
    for altitude in (0.5, 0.6):
        frame, truths = _frame(rng, altitude)
        pipeline.add_frame(frame)
    assert len(pipeline.targets()) == 3
    for true, estimate, std in _height_by_azimuth(pipeline, truths):
        assert estimate is not None and std is not None
        assert estimate == pytest.approx(true, abs=0.0015)
        assert 0 < std < 0.002
    assert all(t.frames_used == 2 and t.reason is None for t in pipeline.targets())


def test_altitude_changes_from_depth_alone(rng: np.random.Generator) -> None:
    # The paper's setting: only the depth gauge's changes are known; five altitudes.
    pipeline = HeightPipeline()
    for altitude in (0.5, 0.55, 0.6, 0.65, 0.7):
        frame, truths = _frame(rng, altitude, altitude_m=math.nan, sonar_depth_m=5.0 - altitude)
        result = pipeline.add_frame(frame)
        assert math.isnan(result.altitude_m)
        assert result.delta_h_m == pytest.approx(altitude - 0.5)
    for true, estimate, std in _height_by_azimuth(pipeline, truths):
        assert estimate is not None and std is not None
        assert abs(estimate - true) < max(4 * std, 0.001)
        assert abs(estimate - true) < 0.006
    for target in pipeline.targets():
        assert target.ref_altitude_m == pytest.approx(0.5, abs=0.06)


def test_targets_are_queryable_after_every_frame(rng: np.random.Generator) -> None:
    pipeline = HeightPipeline()
    frame, _ = _frame(rng, 0.5)
    pipeline.add_frame(frame)
    assert pipeline.n_frames == 1
    first = pipeline.targets()
    assert len(first) == 3
    for target in first:
        assert target.height_m is None and target.height_std_m is None
        assert target.reason is not None and "1 frame" in target.reason
    frame, _ = _frame(rng, 0.6)
    pipeline.add_frame(frame)
    assert all(t.height_m is not None for t in pipeline.targets())


def test_targets_are_solved_once_per_frame(rng: np.random.Generator, monkeypatch: pytest.MonkeyPatch) -> None:
    pipeline = HeightPipeline()
    for altitude in (0.5, 0.6):
        pipeline.add_frame(_frame(rng, altitude)[0])
    calls = []
    solver = pipeline._solver
    solve = solver.solve
    monkeypatch.setattr(solver, "solve", lambda *a, **k: calls.append(1) or solve(*a, **k))
    first = pipeline.targets()
    again = pipeline.targets()
    assert again == first and again is not first and len(calls) == 3
    again.clear()  # the caller's list is its own
    assert pipeline.targets() == first and len(calls) == 3
    pipeline.add_frame(_frame(rng, 0.55)[0])
    third = pipeline.targets()
    assert len(calls) == 6 and all(t.frames_used == 3 for t in third)


def test_one_frame_is_enough_when_allowed_and_the_altitude_is_known(rng: np.random.Generator) -> None:
    pipeline = HeightPipeline(HeightsConfig(min_frames=1))
    frame, truths = _frame(rng, 0.5)
    pipeline.add_frame(frame)
    for true, estimate, _ in _height_by_azimuth(pipeline, truths):
        assert estimate == pytest.approx(true, abs=0.002)


def test_without_altitude_information_there_is_no_height(rng: np.random.Generator) -> None:
    pipeline = HeightPipeline()
    for altitude in (0.5, 0.6):
        frame, _ = _frame(rng, altitude, altitude_m=math.nan)
        pipeline.add_frame(frame)
    for target in pipeline.targets():
        assert target.height_m is None
        assert target.reason is not None and "no altitude information" in target.reason


def test_given_altitude_change_overrides_the_frame(rng: np.random.Generator) -> None:
    pipeline = HeightPipeline()
    frame, truths = _frame(rng, 0.5, altitude_m=math.nan)
    pipeline.add_frame(frame, delta_h_m=0.0)
    frame, _ = _frame(rng, 0.6, altitude_m=math.nan)
    result = pipeline.add_frame(frame, delta_h_m=0.1)
    assert result.delta_h_m == 0.1
    for true, estimate, std in _height_by_azimuth(pipeline, truths):
        assert estimate is not None and std is not None
        assert abs(estimate - true) < max(4 * std, 0.002)


def test_a_truncated_shadow_gives_no_height_and_says_why(rng: np.random.Generator) -> None:
    edge_box = (Box(1.2, -0.34, 0.06, 0.06, 0.04),)  # cut by the fan's first beam
    pipeline = HeightPipeline()
    for altitude in (0.5, 0.6):
        frame, _ = _frame(rng, altitude, boxes=edge_box)
        pipeline.add_frame(frame)
    (target,) = pipeline.targets()
    assert target.height_m is None and target.frames_used == 0
    assert target.reason is not None and "edge of the fan" in target.reason


def test_targets_share_one_reference_altitude(rng: np.random.Generator) -> None:
    # Depth changes only, two altitudes: the targets' common altitude is solved once.
    frames = [_frame(rng, h, altitude_m=math.nan, sonar_depth_m=5.0 - h) for h in (0.5, 0.6)]
    shared = HeightPipeline()
    alone = HeightPipeline(HeightsConfig(shared_altitude=False))
    for frame, _ in frames:
        shared.add_frame(frame)
        alone.add_frame(frame)
    reference = shared.shared_reference_altitude()
    assert reference is not None
    h0, h0_std = reference
    assert h0 == pytest.approx(0.5, abs=max(3 * h0_std, 0.01))
    own = [t.ref_altitude_m for t in alone.targets() if t.ref_altitude_m is not None]
    assert len(own) == 3
    assert min(own) - 1e-9 <= h0 <= max(own) + 1e-9  # a weighted mean of the targets' own
    truths = frames[0][1]
    for true, estimate, std in _height_by_azimuth(shared, truths):
        assert estimate is not None and std is not None
        assert abs(estimate - true) < max(4 * std, 0.001)
    assert all(t.ref_altitude_m == h0 for t in shared.targets())


def test_one_target_has_no_shared_altitude(rng: np.random.Generator) -> None:
    pipeline = HeightPipeline()
    for h in (0.5, 0.6):
        frame, _ = _frame(rng, h, boxes=BOXES[:1], altitude_m=math.nan, sonar_depth_m=5.0 - h)
        pipeline.add_frame(frame)
    assert pipeline.shared_reference_altitude() is None
    (target,) = pipeline.targets()
    assert target.height_m is not None  # solved on its own


def test_a_track_is_solved_again_only_when_its_answer_can_change(
        rng: np.random.Generator, monkeypatch: pytest.MonkeyPatch) -> None:
    # A long recording (past the per-frame reasons of a short one) where two of the three
    # targets leave the view: their answers are kept, and every answer equals a fresh solve.
    from perception.heights.target_solve import EVERY_FRAME_UP_TO, TargetSolver

    pipeline = HeightPipeline()
    calls: list[int] = []
    solve = pipeline._solver.solve
    monkeypatch.setattr(pipeline._solver, "solve", lambda *a, **k: calls.append(a[0]) or solve(*a, **k))
    n_all = EVERY_FRAME_UP_TO + 3
    for i in range(n_all + 6):
        boxes = BOXES if i < n_all else BOXES[:1]
        pipeline.add_frame(_frame(rng, (0.5, 0.6)[i % 2], boxes=boxes)[0])
        before = len(calls)
        answers = pipeline.targets()
        fresh_solver = TargetSolver(pipeline.config, pipeline._sample_m)
        shared = pipeline.shared_reference_altitude()
        fresh = [fresh_solver.solve(t.track_id, t.detections, shared, t.position_m()[:2], n_frames=pipeline.n_frames)
                 for t in pipeline._tracker.tracks]
        assert [repr(a) for a in answers] == [repr(f) for f in fresh]
        if i > n_all:  # only the target still in view is solved again
            assert len(calls) - before == 1
    assert sum(1 for t in pipeline.targets() if t.height_m is not None) == 3
