"""Detection in rendered scenes that used to lose targets (sim_harness frames, 2000 samples).

Each scene is one of the benchmark's random scenes where a target was missed: neighbours
whose highlights and shadows merged into one region, and a shadow ending at the band's
far edge that was taken for one cut by it. Heights are checked with the altitude known
(``h = H (r_end - r_top) / r_end``), against the renderer's truth.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from perception.heights.pipeline import detect_shadows
from perception.shadows.measurement.measure import ShadowMeasurement
from perception.shadows.segmentation.segment import segment
from perception.sonar_io.frame import SonarFrame
from sim_harness.sonar.renderer import SonarConfig, SonarPose, SonarRenderer
from sim_harness.sonar.truth import FrameTruth, Label, TargetTruth
from sim_harness.sonar.viewpoint import choose_tilt_rad
from sim_harness.world.world import Seabed, TargetSpec, World


def _render(
    targets: tuple[TargetSpec, ...],
    *,
    altitude_m: float,
    tilt_altitude_m: float,
    seabed_depth_m: float,
    window_m: tuple[float, float],
    seed: int,
) -> tuple[SonarFrame, FrameTruth]:
    world = World(seabed=Seabed(depth_m=seabed_depth_m), targets=targets)
    config = SonarConfig(window_start_m=window_m[0], window_length_m=window_m[1] - window_m[0],
                         samples_per_beam=2000, seed=seed)
    tilt = choose_tilt_rad(world, north_m=0.0, east_m=0.0, altitude_m=tilt_altitude_m, heading_rad=0.0,
                           pitch_rad=0.0, config=config)
    renderer = SonarRenderer(world, config)
    return renderer.render(SonarPose(0.0, 0.0, seabed_depth_m - altitude_m, tilt_rad=tilt), 1000.0)


def _measured(frame: SonarFrame, truth: TargetTruth) -> list[ShadowMeasurement]:
    found = detect_shadows(frame.image, range_m=frame.range_m, beam_azimuth_rad=frame.beam_azimuth_rad)
    return [m for m in found if abs(m.azimuth_rad - truth.azimuth_rad) < math.radians(2.5)]


def _height_m(m: ShadowMeasurement, altitude_m: float) -> float:
    return altitude_m * (m.r_end_m - m.r_top_m) / m.r_end_m


def _box(name: str, north_m: float, east_m: float, length_m: float, width_m: float, height_m: float,
         yaw_rad: float) -> TargetSpec:
    return TargetSpec(name, "box", north_m, east_m, length_m, width_m, height_m, yaw_rad=yaw_rad)


def test_neighbours_merged_in_range_and_azimuth_are_both_measured() -> None:
    # A tall narrow box just in front of a low wide one, touching in azimuth: their
    # highlights and shadows form one region each.
    targets = (
        _box("low", 1.700, -0.300, 0.156, 0.150, 0.041, -0.479),
        _box("tall", 1.678, -0.147, 0.063, 0.056, 0.168, 0.425),
    )
    frame, truth = _render(targets, altitude_m=0.615, tilt_altitude_m=0.669, seabed_depth_m=1.723,
                           window_m=(1.045, 3.479), seed=53)
    seg = segment(frame.image, range_m=frame.range_m)
    cols = [int(np.argmin(abs(frame.beam_azimuth_rad - t.azimuth_rad))) for t in truth.targets]
    labels = {int(seg.grid_shadow_labels[:, c].max()) for c in cols}
    assert len(labels) == 1 and 0 not in labels  # one shadow region holds both targets
    for t in truth.targets:
        assert t.whole_shadow_in_band and t.whole_shadow_in_window
        (m,) = _measured(frame, t)
        assert m.usable
        assert abs(m.azimuth_rad - t.azimuth_rad) < math.radians(1.0)
        assert _height_m(m, truth.altitude_m) == pytest.approx(t.height_m, rel=0.05)


def test_neighbours_side_by_side_at_one_range_are_both_measured() -> None:
    # Two boxes whose far top edges lie at the same range, side by side: one highlight and
    # one shadow region; their shadows end at different ranges (heights 22 and 8 cm).
    targets = (
        _box("A", 2.760, -0.241, 0.114, 0.093, 0.096, 0.278),
        _box("B", 2.382, 0.208, 0.190, 0.190, 0.084, -0.322),
        _box("C", 2.433, 0.000, 0.200, 0.149, 0.220, 0.388),
    )
    frame, truth = _render(targets, altitude_m=0.981, tilt_altitude_m=1.012, seabed_depth_m=2.042,
                           window_m=(1.666, 4.499), seed=23)
    for t in truth.targets:
        assert t.whole_shadow_in_band and t.whole_shadow_in_window
        found = _measured(frame, t)
        assert found, f"target {t.target_id} not found"
        m = min(found, key=lambda m: abs(m.azimuth_rad - t.azimuth_rad))
        assert m.usable and abs(m.azimuth_rad - t.azimuth_rad) < math.radians(1.0)
        assert _height_m(m, truth.altitude_m) == pytest.approx(t.height_m, rel=0.05)


def test_a_shadow_ending_at_the_band_edge_is_not_taken_as_cut() -> None:
    stone = TargetSpec("cyl", "cylinder", 1.454, 0.127, 0.125, 0.112, 0.0864, yaw_rad=-0.177)
    frame, truth = _render((stone,), altitude_m=0.578, tilt_altitude_m=0.722, seabed_depth_m=1.866,
                           window_m=(0.981, 3.472), seed=45)
    (t,) = truth.targets
    col = int(np.argmin(abs(frame.beam_azimuth_rad - t.azimuth_rad)))
    last_band_row = int(np.flatnonzero(truth.labels[:, col] != Label.OUTSIDE_BEAM).max())
    end_row = float(np.interp(t.central_shadow_end_m, frame.range_m, np.arange(frame.n_samples)))
    assert abs(end_row - last_band_row) < 8  # the shadow ends at the band's far edge
    (m,) = _measured(frame, t)
    # A few samples of dimming seabed (the aperture's edge) lie between the shadow's end
    # and the band's: measured, or cut with the band's far edge named and counted -- never
    # a height from a shadow whose end is not seen.
    if m.usable:
        assert _height_m(m, truth.altitude_m) == pytest.approx(t.height_m, rel=0.05)
    else:
        assert m.reason is not None and "far edge of the insonified band" in m.reason and "central beams" in m.reason


def test_a_shadow_running_past_the_band_edge_is_cut() -> None:
    # The same scene with a target three times as tall: its shadow runs into the dark.
    stone = TargetSpec("cyl", "cylinder", 1.454, 0.127, 0.125, 0.112, 0.26, yaw_rad=-0.177)
    frame, truth = _render((stone,), altitude_m=0.578, tilt_altitude_m=0.722, seabed_depth_m=1.866,
                           window_m=(0.981, 3.472), seed=45)
    (t,) = truth.targets
    assert not t.whole_shadow_in_band
    found = _measured(frame, t)
    assert found and all(m.truncated and not m.usable for m in found)
    assert all(m.reason is not None and "band" in m.reason for m in found)
