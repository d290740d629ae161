"""Segmentation on a textured seabed: dark and bright patches are not shadows and targets.

The renderer's persistent seabed texture (``sim_harness.world.texture``, 3 dB, 10 cm
patches, as the shipped ``open-seabed`` scene) puts dark patches a few dB below the
seabed and bright ones a few dB above it. A cast shadow holds only the noise floor, tens
of dB down, and a target's echo stands well above the seabed; the segmentation keeps only
regions with such a core (``SegmentationConfig.shadow_core_sigmas``/``highlight_core_sigmas``,
in units of the frame's seabed spread, over ``min_shadow_core_m``/``min_highlight_core_m``).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from perception.heights.pipeline import HeightsConfig, detect_shadows
from perception.shadows.segmentation.segment import SegmentationConfig, segment
from perception.sonar_io.frame import SonarFrame
from sim_harness.sonar.renderer import SonarConfig, SonarPose, SonarRenderer
from sim_harness.sonar.truth import FrameTruth
from sim_harness.sonar.viewpoint import choose_tilt_rad
from sim_harness.world.texture import SeabedTexture
from sim_harness.world.world import Seabed, TargetSpec, World

#: A segmentation without the core tests, its thresholds at 2 spreads.
PLAIN_THRESHOLD = HeightsConfig(
    segmentation=SegmentationConfig(shadow_sigmas=2.0, shadow_core_sigmas=2.0, shadow_weak_sigmas=1.0,
                                    highlight_sigmas=2.0, highlight_core_sigmas=2.0, min_shadow_core_m=0.0,
                                    min_highlight_core_m=0.0)
)

ALTITUDE_M = 1.2
SEABED_DEPTH_M = 4.0


def _frames(
    targets: tuple[TargetSpec, ...], *, texture_db: float, norths_m: tuple[float, ...], seed: int
) -> list[tuple[SonarFrame, FrameTruth]]:
    """Frames of a textured seabed (one per sonar position north), 128 x 2000."""
    texture = SeabedTexture(std_db=texture_db, correlation_m=0.1, seed=seed)
    world = World(seabed=Seabed(depth_m=SEABED_DEPTH_M, texture=texture), targets=targets)
    near = ALTITUDE_M / math.sin(math.radians(32.0))
    far = ALTITUDE_M / math.sin(math.radians(12.0))
    config = SonarConfig(window_start_m=0.9 * near, window_length_m=min(far, 1.35 * near + 2.0) - 0.9 * near,
                         samples_per_beam=2000, seed=seed)
    renderer = SonarRenderer(world, config)
    tilt = choose_tilt_rad(world, north_m=0.0, east_m=0.0, altitude_m=ALTITUDE_M, heading_rad=0.0,
                           pitch_rad=0.0, config=config)
    return [
        renderer.render(SonarPose(north, 0.0, SEABED_DEPTH_M - ALTITUDE_M, tilt_rad=tilt), 100.0 + k)
        for k, north in enumerate(norths_m)
    ]


def _detections(frame: SonarFrame, config: HeightsConfig | None = None) -> int:
    return len(detect_shadows(frame.image, range_m=frame.range_m, beam_azimuth_rad=frame.beam_azimuth_rad,
                              config=config))


def test_textured_seabed_without_targets_gives_no_detection() -> None:
    shots = _frames((), texture_db=3.0, norths_m=(0.0, 0.7, 1.4, 2.1), seed=5)
    # The plain threshold pairs dark patches with bright ones: the frames do fool it.
    assert sum(_detections(frame, PLAIN_THRESHOLD) for frame, _ in shots) >= 4
    for frame, _ in shots:
        assert _detections(frame) == 0
        seg = segment(frame.image, range_m=frame.range_m)
        assert seg.highlights == ()  # no bright patch stands 12 dB above the seabed


def test_only_regions_with_a_core_are_kept() -> None:
    # Known answer on a hand-made display image, 1 mm samples, grid = image (1 mm step, no
    # beam smoothing): seabed at level 120 with Gaussian texture of 3 levels (the frame's
    # spread); noise-free patches 4 spreads below it (texture-like: shadow, no core), 20
    # below (a cast shadow), 4 below with a deep spot of 80 px (60 mm of core over its
    # beams: enough) and one of 40 px (not), 4 and 20 spreads above it.
    rng = np.random.default_rng(1)
    image = np.clip(np.round(rng.normal(120, 3, (400, 80))), 0, 255).astype(np.uint8)
    # (One patch per range, so that no row is mostly patches.)
    image[20:60, 4:14] = 108  # texture-like dark patch
    image[80:120, 20:30] = 60  # cast shadow
    image[140:180, 36:46] = 108
    image[156:164, 38:48] = 60  # ... with a deep spot of 80 px
    image[200:240, 52:62] = 108
    image[218:222, 54:64] = 60  # ... with a deep spot of 40 px
    image[260:290, 4:14] = 132  # bright patch
    image[320:350, 20:30] = 180  # target echo
    config = SegmentationConfig(grid_step_m=0.001, max_grid_rows=400, smooth_beams=1, shadow_weak_sigmas=3.0)
    seg = segment(image, range_m=np.arange(400) * 0.001, config=config)
    assert seg.sigma == pytest.approx(3.0, rel=0.15)
    def boxes(regions):  # (a speckle pixel beside a patch may join it: one column of play)
        return sorted((r.col_start, r.col_stop) for r in regions if r.n_cols > 3)

    shadows = boxes(seg.shadows)
    assert len(shadows) == 2
    assert np.abs(np.array(shadows) - np.array([(20, 30), (36, 48)])).max() <= 1
    (highlight,) = boxes(seg.highlights)
    assert np.abs(np.array(highlight) - np.array((20, 30))).max() <= 1
    # Without the core tests every patch past the thresholds is a region.
    plain = segment(image, range_m=np.arange(400) * 0.001, config=SegmentationConfig(
        grid_step_m=0.001, max_grid_rows=400, smooth_beams=1, shadow_weak_sigmas=3.0, min_shadow_core_m=0.0,
        min_highlight_core_m=0.0))
    assert len(boxes(plain.shadows)) == 4 and len(boxes(plain.highlights)) == 2


@pytest.mark.parametrize("texture_db", [3.0, 4.0])
def test_targets_on_a_textured_seabed_are_measured(texture_db: float) -> None:
    targets = (
        TargetSpec("A", "box", 3.0, -0.45, 0.25, 0.2, 0.12, yaw_rad=0.2),
        TargetSpec("B", "box", 3.3, 0.05, 0.2, 0.15, 0.05, yaw_rad=-0.3),
        TargetSpec("C", "cylinder", 2.9, 0.5, 0.3, 0.2, 0.20),
    )
    ((frame, truth),) = _frames(targets, texture_db=texture_db, norths_m=(0.0,), seed=3)
    found = detect_shadows(frame.image, range_m=frame.range_m, beam_azimuth_rad=frame.beam_azimuth_rad)
    assert len(truth.targets) == 3
    for t in truth.targets:
        assert t.whole_shadow_in_band and t.whole_shadow_in_window
        near = [m for m in found if abs(m.azimuth_rad - t.azimuth_rad) < math.radians(1.5)]
        assert len(near) == 1, f"target {t.target_id}: {len(near)} detections"
        (m,) = near
        assert m.usable, m.reason
        height_m = truth.altitude_m * (m.r_end_m - m.r_top_m) / m.r_end_m
        assert height_m == pytest.approx(t.height_m, rel=0.05)
    assert len(found) == 3  # nothing else


def test_core_settings_are_validated() -> None:
    with pytest.raises(ValueError, match="shadow_core_sigmas"):
        SegmentationConfig(shadow_sigmas=6.0, shadow_core_sigmas=5.0)
    with pytest.raises(ValueError, match="highlight_core_sigmas"):
        SegmentationConfig(highlight_core_sigmas=2.0)
    with pytest.raises(ValueError, match="min_shadow_core_m"):
        SegmentationConfig(min_shadow_core_m=-1.0)
    with pytest.raises(ValueError, match="min_highlight_core_m"):
        SegmentationConfig(min_highlight_core_m=-1.0)
