"""Rounded targets through the whole height pipeline: half-buried stones rendered by the
simulator's sonar at two altitudes, with and without ``HeightsConfig.rounded_near_echo``."""

from __future__ import annotations

import math

import numpy as np
import pytest

from perception.heights.pipeline import HeightPipeline, HeightsConfig, TargetHeight
from sim_harness.sonar.renderer import SonarConfig, SonarPose, SonarRenderer
from sim_harness.sonar.truth import TargetTruth
from sim_harness.sonar.viewpoint import choose_tilt_rad
from sim_harness.world.world import Seabed, TargetSpec, World

ALTITUDES_M = (0.5, 0.6)
#: Stones (length, width, height), m: ellipsoids half under the seabed.
STONES_M = ((0.10, 0.08, 0.04), (0.12, 0.10, 0.06), (0.08, 0.08, 0.03), (0.15, 0.10, 0.08), (0.10, 0.07, 0.05))


@pytest.fixture(scope="module")
def stones() -> tuple[list, tuple[TargetTruth, ...]]:
    specs = tuple(TargetSpec(f"S{i}", "stone", 1.2 + 0.1 * (i % 2), -0.24 + 0.12 * i, length, width, height,
                             material="rock")
                  for i, (length, width, height) in enumerate(STONES_M))
    world = World(seabed=Seabed(depth_m=0.85), targets=specs)
    config = SonarConfig(seed=11)
    renderer = SonarRenderer(world, config)
    tilt = choose_tilt_rad(world, north_m=0.0, east_m=0.0, altitude_m=float(np.mean(ALTITUDES_M)), heading_rad=0.0,
                           pitch_rad=0.0, config=config)
    frames, truth = [], None
    for k, altitude in enumerate(ALTITUDES_M):
        for ping in range(2):
            pose = SonarPose(0.0, 0.0, 0.85 - altitude, tilt_rad=tilt)
            frame, truth_k = renderer.render(pose, 100.0 + k + 0.1 * ping)
            frames.append(frame)
            truth = truth if truth is not None else truth_k
    assert truth is not None
    return frames, truth.targets


def _heights(frames: list, config: HeightsConfig, truths: tuple[TargetTruth, ...]) -> list[tuple[float, TargetHeight]]:
    pipeline = HeightPipeline(config)
    for frame in frames:
        pipeline.add_frame(frame)
    targets = pipeline.targets()
    out = []
    for t in truths:
        near = [u for u in targets if abs(u.azimuth_rad - t.azimuth_rad) < math.radians(2.5) and u.height_m is not None]
        assert near, f"{t.target_id} not measured"
        out.append((t.height_m, min(near, key=lambda u: abs(u.range_m - t.central_shadow_start_m))))
    return out


def test_a_stones_summit_comes_from_where_its_echo_starts(stones: tuple[list, tuple[TargetTruth, ...]]) -> None:
    frames, truths = stones
    sharp = _heights(frames, HeightsConfig(), truths)
    summit = _heights(frames, HeightsConfig(rounded_near_echo=True), truths)
    # Each stone's echo fades towards its shadow, and by default the height is that of the
    # grazing point, below the summit.
    for true_m, target in sharp:
        assert target.top_slope_db_per_m < -HeightsConfig().rounded_slope_db_per_m
        assert target.height_m is not None and target.height_m < true_m and not target.rounded
    # With the half-ellipsoid from the echo's start, the summit.
    for (true_m, target), (_, low) in zip(summit, sharp, strict=True):
        assert target.rounded and target.shadow_start == "rounded top"
        assert target.height_m is not None and low.height_m is not None and target.height_m > low.height_m
        assert target.height_m == pytest.approx(true_m, abs=0.004)
        # The sigma holds the gap to the sharp-edge reading, the other explanation of the echo.
        assert target.height_std_m is not None and target.height_std_m >= target.height_m - low.height_m
    mean_sharp = np.mean([abs(t.height_m - h) for h, t in sharp if t.height_m is not None])
    mean_summit = np.mean([abs(t.height_m - h) for h, t in summit if t.height_m is not None])
    assert mean_summit < 0.75 * mean_sharp
