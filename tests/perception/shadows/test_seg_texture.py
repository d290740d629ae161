"""Segmentation on a textured seabed: dark and bright patches are not shadows and targets.

The renderer's persistent seabed texture (``sim_harness.world.texture``, 3 dB, 10 cm
patches, as the shipped ``open-seabed`` scene) puts dark patches a few dB below the
seabed and bright ones a few dB above it. A cast shadow holds only the noise floor, tens
of dB down, and a target's echo stands well above the seabed; the segmentation keeps only
regions with such a core (``SegmentationConfig.shadow_core_db``/``highlight_core_db``).
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

#: The segmentation before the texture was handled: 6 dB shadows, no core tests.
PLAIN_THRESHOLD = HeightsConfig(
    segmentation=SegmentationConfig(shadow_db=6.0, min_shadow_core_px=0, min_highlight_core_px=0)
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
        seg = segment(frame.image)
        assert seg.highlights == ()  # no bright patch stands 12 dB above the seabed


def test_only_regions_with_a_core_are_kept() -> None:
    # Known answer on a hand-made display image (80 dB over 0-255, no speckle): seabed at
    # level 120; patches 9 dB and 25 dB below it, 8 dB and 20 dB above it, and a 9 dB
    # dark patch holding a small 25 dB deep spot (40 px).
    per_db = 255.0 / 80.0
    image = np.full((400, 64), 120, np.uint8)
    image[100:140, 6:16] = round(120 - 9 * per_db)  # texture-like dark patch
    image[100:140, 26:36] = round(120 - 25 * per_db)  # cast shadow (noise floor)
    image[100:140, 46:56] = round(120 - 9 * per_db)
    image[118:122, 48:58] = round(120 - 25 * per_db)  # ... with a deep spot
    image[250:280, 6:16] = round(120 + 8 * per_db)  # bright patch
    image[250:280, 26:36] = round(120 + 20 * per_db)  # target echo
    seg = segment(image, config=SegmentationConfig(smooth_samples=1, smooth_beams=1))
    boxes = sorted((r.row_start, r.row_stop, r.col_start, r.col_stop) for r in seg.shadows)
    assert boxes == [(100, 140, 26, 36), (100, 140, 46, 58)]
    assert [(r.row_start, r.row_stop, r.col_start, r.col_stop) for r in seg.highlights] == [(250, 280, 26, 36)]
    # Without the core tests every patch past the 8 dB / 6 dB thresholds is a region.
    plain = segment(image, config=SegmentationConfig(
        smooth_samples=1, smooth_beams=1, min_shadow_core_px=0, min_highlight_core_px=0))
    assert len(plain.shadows) == 3 and len(plain.highlights) == 2
    # A deep spot smaller than min_shadow_core_px does not make a shadow.
    strict = segment(image, config=SegmentationConfig(smooth_samples=1, smooth_beams=1, min_shadow_core_px=41))
    assert [(r.col_start, r.col_stop) for r in strict.shadows] == [(26, 36)]


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
    with pytest.raises(ValueError, match="shadow_core_db"):
        SegmentationConfig(shadow_db=10.0, shadow_core_db=8.0)
    with pytest.raises(ValueError, match="highlight_core_db"):
        SegmentationConfig(highlight_core_db=3.0)
    with pytest.raises(ValueError, match="min_shadow_core_px"):
        SegmentationConfig(min_shadow_core_px=-1)
    with pytest.raises(ValueError, match="min_highlight_core_px"):
        SegmentationConfig(min_highlight_core_px=-1)
