"""Random two-altitude scenes: what they hold (geometry, windows, outputs, attitude) and the
paper's Table I targets at any orientation."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sim_harness.sonar.family import presets
from sim_harness.sonar.random_scenes import (
    FRAME_OUTPUTS,
    MIN_WIDTH_M,
    PAPER_ALTITUDES_M,
    PAPER_TARGETS,
    draw_scene,
    paper_scene,
    render_scene,
)


@given(seed=st.integers(0, 2**32 - 1))
@settings(max_examples=40, deadline=None, derandomize=True)
def test_drawn_scenes_hold_what_they_promise(seed: int) -> None:
    scene = draw_scene(np.random.default_rng(seed))
    assert 1 <= len(scene.world.targets) <= 3
    low, high = scene.frames
    altitudes = [scene.world.seabed.depth_m - f.pose.depth_m for f in scene.frames]
    assert 0.4 <= altitudes[0] <= 2.0 and 0.05 <= altitudes[1] - altitudes[0] <= 0.3 + 1e-9
    assert (low.pose.north_m, low.pose.east_m) == (high.pose.north_m, high.pose.east_m)  # a vertical climb
    sectors = []
    for t in scene.world.targets:
        assert 0.02 <= t.height_m <= 0.35 * altitudes[0] + 1e-9
        assert t.width_m >= MIN_WIDTH_M - 1e-12 and 0.0 <= math.degrees(t.yaw_rad) <= 90.0
        ground = math.hypot(t.north_m, t.east_m)
        az = math.atan2(t.east_m, t.north_m)
        half = 0.5 * math.hypot(t.length_m, t.width_m) / ground
        sectors.append((az - half, az + half))
    sectors.sort()
    assert all(a[1] < b[0] for a, b in zip(sectors, sectors[1:], strict=False))  # no shared sector
    for f in scene.frames:
        assert f.output in FRAME_OUTPUTS and 1000 <= f.samples <= 2000 and f.window_length_m >= 0.5


def test_attitude_errors_are_reported_as_zero() -> None:
    scene = draw_scene(np.random.default_rng(3), attitude_error_deg=2.0)
    for f in scene.frames:
        assert abs(f.pose.pitch_rad) <= math.radians(2.0) and abs(f.pose.roll_rad) <= math.radians(2.0)
        assert f.reported_pitch_rad == 0.0 and f.reported_roll_rad == 0.0
    assert any(f.pose.pitch_rad != 0.0 for f in scene.frames)


def test_rendered_frames_follow_their_specs() -> None:
    scene = draw_scene(np.random.default_rng(11), attitude_error_deg=2.0)
    shots = render_scene(scene, presets()[0], seed=4)
    for (frame, truth), spec in zip(shots, scene.frames, strict=True):
        assert frame.n_samples == spec.samples
        assert frame.range_m[0] == pytest.approx(spec.window_start_m + spec.window_length_m / spec.samples / 2)
        assert frame.image.dtype == {"uint8": np.uint8, "uint16_amplitude": np.uint16,
                                     "float32_power": np.float32}[spec.output]
        assert frame.vehicle_pitch_rad == 0.0 and frame.vehicle_roll_rad == 0.0  # what it reports
        assert truth.altitude_m == pytest.approx(scene.world.seabed.depth_m - spec.pose.depth_m, abs=0.05)
    without = render_scene(scene, presets()[0], seed=4, altitude_known=False)
    assert all(math.isnan(f.altitude_m) for f, _ in without)


@pytest.mark.parametrize("orientation_deg", [0, 45, 90])
def test_paper_scene_is_the_table_i_target_at_its_orientation(orientation_deg: float) -> None:
    for index, ((length, width, height), (north, east), material) in enumerate(PAPER_TARGETS):
        scene = paper_scene(index, orientation_deg)
        (t,) = scene.world.targets
        assert (t.length_m, t.width_m, t.height_m, t.material) == (length, width, height, material)
        assert (t.north_m, t.east_m) == (north, east)
        assert math.degrees(t.yaw_rad) == pytest.approx(orientation_deg)
        altitudes = [scene.world.seabed.depth_m - f.pose.depth_m for f in scene.frames]
        assert altitudes == pytest.approx(list(PAPER_ALTITUDES_M))
