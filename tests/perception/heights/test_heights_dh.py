"""Heights with only the altitude change known: the seabed onset's altitude, the edges'
systematic offset in the sigma, and the rounded-top model."""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from perception.errors import SolverError
from perception.heights.pipeline import (
    HeightPipeline,
    HeightsConfig,
    altitude_groups,
    detect_shadows,
    onset_altitude,
    top_echo_slope_db_per_m,
)
from perception.heights.solver import fit_rounded_top, grazing_tan2
from perception.sonar_io.frame import SonarFrame
from tests.perception.shadows.shadow_synth import Box, SynthConfig, edges_at, render

BOXES = (
    Box(1.2, 0.0, 0.10, 0.05, 0.039),
    Box(1.1, -0.18, 0.06, 0.05, 0.028),
    Box(1.2, 0.25, 0.05, 0.04, 0.047),
)
TILT_DEG = 25.0


def _frames(rng: np.random.Generator, altitudes=(0.5, 0.6), boxes=BOXES, **fields: float):
    """Frames with the altitude withheld, the depth gauge's changes and a known attitude."""
    out = []
    for altitude in altitudes:
        frame, _, truths = render(SynthConfig(boxes=boxes, altitude_m=altitude, tilt_deg=TILT_DEG), rng=rng)
        out.append(
            frame.with_fields(altitude_m=math.nan, sonar_depth_m=5.0 - altitude, vehicle_pitch_rad=0.0, **fields)
        )
    return out, truths


def _run(frames, config: HeightsConfig | None = None) -> HeightPipeline:
    pipeline = HeightPipeline(config)
    for frame in frames:
        pipeline.add_frame(frame)
    return pipeline


def test_seabed_onset_measures_each_frames_altitude(rng: np.random.Generator) -> None:
    frames, _ = _frames(rng)
    pipeline = HeightPipeline()
    onsets = [pipeline.add_frame(frame).onset_altitude_m for frame in frames]
    # The synthetic band's near edge is where the steepest ray (tilt + 7 deg) meets the seabed.
    assert onsets == pytest.approx([0.5, 0.6], rel=0.02)
    reference = pipeline.onset_reference_altitude()
    assert reference is not None
    h0, h0_std = reference
    assert abs(h0 - 0.5) < 2 * h0_std
    # The common (tilt, beam-edge model) error does not average out: sigma >= 1 % of H0.
    assert h0_std >= 0.01 * h0 * 0.99


def test_onset_joins_the_shared_altitude_and_tightens_it(rng: np.random.Generator) -> None:
    frames, truths = _frames(rng)
    with_onset = _run(frames)
    shadows_only = _run(frames, HeightsConfig(seabed_onset_altitude=False))
    joint, alone = with_onset.shared_reference_altitude(), shadows_only.shared_reference_altitude()
    onset = with_onset.onset_reference_altitude()
    assert joint is not None and alone is not None and onset is not None
    assert shadows_only.onset_reference_altitude() is None
    # The onset leads (targets as sure as it join it): between the inputs, at least as
    # tight as the onset.
    assert min(alone[0], onset[0]) <= joint[0] <= max(alone[0], onset[0])
    assert joint[1] <= onset[1] < alone[1]
    assert joint[0] == pytest.approx(0.5, abs=3 * joint[1])
    for truth in truths:
        target = min(with_onset.targets(), key=lambda t: abs(t.azimuth_rad - truth.azimuth_rad))
        assert target.height_m is not None and target.height_std_m is not None
        assert target.ref_altitude_m == joint[0]
        assert abs(target.height_m - truth.box.height_m) < max(3 * target.height_std_m, 0.001)


def test_a_wrong_tilt_moves_the_onset_but_not_the_shadows_altitude(rng: np.random.Generator) -> None:
    # A wrong tilt moves the onset's altitude by ~30 % (the onset trusts the frames' tilt);
    # the shadows' own estimate, without the onset, stays right.
    frames, _ = _frames(rng)
    tilted = [f.with_fields(tilt_rad=f.tilt_rad + math.radians(15.0)) for f in frames]
    pipeline = _run(tilted)
    onset = pipeline.onset_reference_altitude()
    assert onset is not None and onset[0] > 0.6
    shadows = _run(tilted, HeightsConfig(seabed_onset_altitude=False)).shared_reference_altitude()
    assert shadows is not None and shadows[0] == pytest.approx(0.5, abs=max(3 * shadows[1], 0.02))


def test_a_target_that_contradicts_the_onset_is_left_out(rng: np.random.Generator) -> None:
    # The third box "shrinks" by 1 cm between the altitudes (a shape the flat-top model
    # cannot explain): its own reference altitude is far off, the onset's is not.
    frames = []
    for altitude, third in ((0.5, 0.047), (0.6, 0.037)):
        boxes = (*BOXES[:2], Box(1.2, 0.25, 0.05, 0.04, third))
        frame, _, _ = render(SynthConfig(boxes=boxes, altitude_m=altitude, tilt_deg=TILT_DEG), rng=rng)
        frames.append(frame.with_fields(altitude_m=math.nan, sonar_depth_m=5.0 - altitude, vehicle_pitch_rad=0.0))
    joint = _run(frames).shared_reference_altitude()
    alone = _run(frames, HeightsConfig(seabed_onset_altitude=False)).shared_reference_altitude()
    assert joint is not None and alone is not None
    assert abs(joint[0] - 0.5) < 3 * joint[1] and abs(joint[0] - 0.5) < 0.01
    assert abs(alone[0] - 0.5) > abs(joint[0] - 0.5)


def test_one_target_gets_the_onset_altitude(rng: np.random.Generator) -> None:
    frames, truths = _frames(rng, boxes=BOXES[:1])
    pipeline = _run(frames)
    shared = pipeline.shared_reference_altitude()
    assert shared is not None and shared[0] == pytest.approx(0.5, abs=3 * shared[1])
    (target,) = pipeline.targets()
    assert target.height_m == pytest.approx(truths[0].box.height_m, abs=max(3 * (target.height_std_m or 0), 0.001))
    assert target.ref_altitude_m == shared[0]


def test_no_onset_without_the_attitude(rng: np.random.Generator) -> None:
    frame, _, _ = render(SynthConfig(boxes=BOXES, altitude_m=0.5, tilt_deg=TILT_DEG), rng=rng)
    assert math.isnan(frame.vehicle_pitch_rad)
    assert onset_altitude(frame, frame_index=0, delta_h_m=0.0, config=HeightsConfig()) is None
    pitched = frame.with_fields(vehicle_pitch_rad=0.0)
    found = onset_altitude(pitched, frame_index=0, delta_h_m=0.0, config=HeightsConfig())
    assert found is not None and found.altitude_m == pytest.approx(0.5, rel=0.02)
    assert found.common_std_m > found.noise_std_m > 0


def test_no_onset_when_the_window_starts_inside_the_band(rng: np.random.Generator) -> None:
    # Steepest ray 32 deg down: the seabed starts at 0.5 / sin(32 deg) = 0.94 m slant.
    cfg = SynthConfig(boxes=BOXES, altitude_m=0.5, tilt_deg=TILT_DEG, window_m=(1.0, 2.6))
    frame, _, _ = render(cfg, rng=rng)
    pitched = frame.with_fields(vehicle_pitch_rad=0.0, altitude_m=math.nan)
    assert onset_altitude(pitched, frame_index=0, delta_h_m=0.0, config=HeightsConfig()) is None
    pipeline = HeightPipeline()
    assert math.isnan(pipeline.add_frame(pitched, delta_h_m=0.0).onset_altitude_m)
    assert pipeline.onset_reference_altitude() is None


def test_known_altitudes_never_use_the_onset(rng: np.random.Generator) -> None:
    frames, _ = _frames(rng)
    pipeline = HeightPipeline()
    for frame, altitude in zip(frames, (0.5, 0.6), strict=True):
        result = pipeline.add_frame(frame.with_fields(altitude_m=altitude))
        assert math.isnan(result.onset_altitude_m)
    assert pipeline.onset_reference_altitude() is None


def test_edge_offset_widens_the_sigma_not_the_height(rng: np.random.Generator) -> None:
    frames, _ = _frames(rng)
    tight = _run(frames, HeightsConfig(edge_bias_samples=0.0, rounded_targets=False)).targets()
    wide = _run(frames, HeightsConfig(edge_bias_samples=1.0, rounded_targets=False)).targets()
    assert len(tight) == len(wide) == 3
    for a, b in zip(sorted(tight, key=lambda t: t.azimuth_rad), sorted(wide, key=lambda t: t.azimuth_rad), strict=True):
        assert a.height_std_m is not None and b.height_std_m is not None and a.height_m is not None
        assert b.height_std_m > a.height_std_m
        # The shared altitude moves (its inputs' weights change), the height only through it.
        assert b.height_m == pytest.approx(a.height_m, abs=3 * b.height_std_m)


def test_boxes_are_not_called_rounded(rng: np.random.Generator) -> None:
    frames, truths = _frames(rng, altitudes=(0.5, 0.55, 0.6, 0.65))
    known = [f.with_fields(altitude_m=h) for f, h in zip(frames, (0.5, 0.55, 0.6, 0.65), strict=True)]
    config = HeightsConfig(rounded_summit=True)
    for pipeline in (_run(frames, config), _run(known, config)):
        targets = pipeline.targets()
        assert len(targets) == 3
        assert not any(t.rounded for t in targets)


FADE_DB_PER_M = 450.0  # a rounded top's echo fading towards its grazing point


def _fade_before_edge(frame: SonarFrame, box: Box, altitude_m: float, *, db_per_m: float) -> SonarFrame:
    """The frame with the echo over the 3 cm before the box's far top edge falling
    linearly in dB towards the edge (uint8, 80 dB over 0-255), as a rounded top's does."""
    image = frame.image.astype(np.float64)
    r = frame.range_m
    for col, azimuth in enumerate(frame.beam_azimuth_rad):
        edges = edges_at(box, float(azimuth), altitude_m)
        if edges is None:
            continue
        top = edges[0]
        rows = (r > top - 0.03) & (r <= top)
        image[rows, col] -= db_per_m * (r[rows] - (top - 0.03)) * 255.0 / 80.0
    faded = np.clip(np.round(image), 0, 255).astype(np.uint8)
    return SonarFrame(
        image=faded,
        range_m=r,
        beam_azimuth_rad=frame.beam_azimuth_rad,
        elevation_aperture_rad=frame.elevation_aperture_rad,
        timestamp_s=frame.timestamp_s,
        altitude_m=frame.altitude_m,
        tilt_rad=frame.tilt_rad,
    )


def _rounded_top_frames(
    rng: np.random.Generator, summit_m: float, half_length_m: float, *, fade_db_per_m: float
) -> list[SonarFrame]:
    """Frames of a target whose far top edge is the grazing point of a half-ellipse.

    A box whose height, at each altitude, is that of the point where the ray to its far
    top edge grazes a half-ellipse of the given summit and half-length, with the echo
    fading towards that edge: to the pipeline, a rounded top seen from several altitudes.
    """
    box = Box(1.1, 0.0, 0.12, 0.08, summit_m)
    far_edge_m = box.x0_m + box.length_m
    frames = []
    for altitude in (0.45, 0.5, 0.55, 0.6, 0.65):
        z = summit_m
        for _ in range(60):  # z = c / sqrt(1 + (a/c)^2 tan^2), tan = (H - z) / g_far
            z = float(_grazing_height(summit_m, half_length_m, np.array(((altitude - z) / far_edge_m) ** 2)))
        grazing = Box(box.x0_m, box.y_m, box.length_m, box.width_m, z)
        frame, _, _ = render(SynthConfig(boxes=(grazing,), altitude_m=altitude, tilt_deg=TILT_DEG), rng=rng)
        frames.append(_fade_before_edge(frame, grazing, altitude, db_per_m=fade_db_per_m))
    return frames


def test_a_rounded_top_reads_low_and_its_sigma_says_so(rng: np.random.Generator) -> None:
    summit = 0.04
    frames = _rounded_top_frames(rng, summit, 0.08, fade_db_per_m=FADE_DB_PER_M)
    (sharp,) = _run(frames, HeightsConfig(rounded_targets=False)).targets()
    (honest,) = _run(frames).targets()
    (summit_fit,) = _run(frames, HeightsConfig(rounded_summit=True)).targets()
    assert sharp.height_m is not None and sharp.height_std_m is not None
    assert honest.height_m is not None and honest.height_std_m is not None
    assert summit_fit.height_m is not None and summit_fit.height_std_m is not None
    # The fading echo is seen (its slope, measured over 6-20 mm before the edge).
    assert honest.top_slope_db_per_m == pytest.approx(-FADE_DB_PER_M, rel=0.35)
    # The grazing points lie 0.7-1.2 cm below the summit: the sharp-edge height is low,
    # beyond its own sigma.
    assert sharp.height_m < summit - 2 * sharp.height_std_m
    # By default the height stays, and the rounded fit widens the sigma to cover it.
    assert honest.height_m == sharp.height_m and not honest.rounded
    assert abs(honest.height_m - summit) <= 2 * honest.height_std_m
    # With the summit model on, the summit is recovered.
    assert summit_fit.rounded
    assert summit_fit.height_m == pytest.approx(summit, abs=max(3 * summit_fit.height_std_m, 0.001))


def test_the_same_heights_with_a_flat_echo_keep_a_tight_sigma(rng: np.random.Generator) -> None:
    # Without the fading echo nothing says the top is rounded: the sharp-edge sigma stays.
    frames = _rounded_top_frames(rng, 0.04, 0.08, fade_db_per_m=0.0)
    (sharp,) = _run(frames, HeightsConfig(rounded_targets=False)).targets()
    (target,) = _run(frames).targets()
    assert target.height_std_m is not None and sharp.height_std_m is not None
    assert abs(target.top_slope_db_per_m) < HeightsConfig().rounded_slope_db_per_m
    assert target.height_std_m == pytest.approx(sharp.height_std_m, rel=1e-9)


def test_echo_slope_known_answers(rng: np.random.Generator) -> None:
    box = Box(1.1, 0.0, 0.12, 0.08, 0.04)
    frame, _, _ = render(SynthConfig(boxes=(box,), altitude_m=0.5, tilt_deg=TILT_DEG, speckle_looks=0.0), rng=rng)
    for fade in (0.0, 300.0, 600.0):
        faded = _fade_before_edge(frame, box, 0.5, db_per_m=fade)
        (m,) = [
            m
            for m in detect_shadows(faded.image, range_m=faded.range_m, beam_azimuth_rad=faded.beam_azimuth_rad)
            if m.usable
        ]
        slope = top_echo_slope_db_per_m(faded.image, m, range_m=faded.range_m)
        assert slope == pytest.approx(-fade, abs=60.0)
    # A linear-power image gives the same slope as its uint8 display form.
    power = np.power(10.0, faded.image.astype(np.float64) * (80.0 / 255.0) / 10.0).astype(np.float32)
    assert top_echo_slope_db_per_m(power, m, range_m=faded.range_m) == pytest.approx(
        top_echo_slope_db_per_m(faded.image, m, range_m=faded.range_m), rel=1e-4
    )


@pytest.mark.parametrize(
    ("name", "value"),
    [
        ("edge_bias_samples", -0.1),
        ("edge_bias_samples", math.nan),
        ("rounded_min_sigmas", 0.0),
        ("onset_angle_std_rad", 0.0),
        ("onset_model_relative_std", -1.0),
        ("rounded_slope_db_per_m", 0.0),
        ("rounded_window_m", (0.02, 0.01)),
    ],
)
def test_bad_settings_are_refused(name: str, value: object) -> None:
    changes: dict[str, Any] = {name: value}
    with pytest.raises(ValueError, match=name):
        replace(HeightsConfig(), **changes)


# --- altitude groups --------------------------------------------------------------------


def test_altitude_groups_known_answer() -> None:
    dh = np.array([0.1, 0.0, 0.101, 0.002, 0.05])
    groups = altitude_groups(dh)
    assert [sorted(g.tolist()) for g in groups] == [[1, 3], [4], [0, 2]]
    assert [g.tolist() for g in altitude_groups(np.array([0.3, 0.3]))] == [[0, 1]]
    assert altitude_groups(np.array([])) == []


@settings(max_examples=60, deadline=None)
@given(st.lists(st.floats(-1.0, 1.0, allow_nan=False), min_size=1, max_size=30))
def test_altitude_groups_partition_into_separated_runs(values: list[float]) -> None:
    dh = np.array(values)
    groups = altitude_groups(dh)
    assert sorted(np.concatenate(groups).tolist()) == list(range(dh.size))
    spread = float(np.ptp(dh))
    for a, b in zip(groups, groups[1:], strict=False):
        assert dh[b].min() - dh[a].max() > 0.1 * spread  # a real gap between groups
    for g in groups:
        inner = np.diff(np.sort(dh[g]))
        assert np.all(inner <= 0.1 * spread + 1e-15)


# --- rounded tops -------------------------------------------------------------------------


def _grazing_height(c: float, a: float, t2: np.ndarray) -> np.ndarray:
    """Height of the point where a ray of depression tan^2 = t2 grazes a half-ellipse."""
    return c / np.sqrt(1.0 + (a / c) ** 2 * t2)


def test_grazing_tan2_known_answer() -> None:
    # A 3-4-5 triangle: altitude 3, ground 4, slant 5 -> tan = 3/4.
    assert grazing_tan2(3.0, 5.0) == pytest.approx(0.5625)
    with pytest.raises(SolverError, match="exceed the altitude"):
        grazing_tan2(1.0, 0.9)


def test_grazing_point_of_an_ellipse_by_brute_force() -> None:
    # The tangent line of slope -tan(theta) touches the ellipse at the model's height.
    c, a, theta = 0.04, 0.05, math.radians(25.0)
    phi = np.linspace(0.0, math.pi, 200001)
    x, z = a * np.cos(phi), c * np.sin(phi)
    # The grazing point maximises the line offset z + tan(theta) x (the tangent's intercept).
    k = int(np.argmax(z + math.tan(theta) * x))
    assert z[k] == pytest.approx(float(_grazing_height(c, a, np.array(math.tan(theta) ** 2))), rel=1e-6)


def test_rounded_fit_recovers_the_summit() -> None:
    t2 = np.array([0.12, 0.17, 0.25])
    fit = fit_rounded_top(_grazing_height(0.04, 0.05, t2), np.full(3, 1e-4), t2)
    assert fit.height_m == pytest.approx(0.04, rel=1e-9)
    assert fit.curvature_per_m2 == pytest.approx(0.05**2 / 0.04**4, rel=1e-9)
    assert fit.curvature_per_m2 > 3 * fit.curvature_std_per_m2


def test_sharp_edge_has_no_curvature() -> None:
    t2 = np.array([0.1, 0.2])
    fit = fit_rounded_top([0.03, 0.03], [2e-4, 2e-4], t2)
    assert fit.height_m == pytest.approx(0.03)
    assert fit.curvature_per_m2 == pytest.approx(0.0, abs=1e-6)
    # Two angles this close extrapolate poorly: the summit's sigma exceeds each point's.
    assert fit.height_std_m > 2e-4


@settings(max_examples=50, deadline=None)
@given(
    st.floats(0.01, 0.3),
    st.floats(0.0, 0.3),
    st.lists(st.floats(0.01, 2.0), min_size=2, max_size=6, unique=True),
)
def test_rounded_fit_is_exact_for_ellipses(c: float, a: float, t2_values: list[float]) -> None:
    t2 = np.array(t2_values)
    if np.ptp(t2) < 1e-3:
        return
    fit = fit_rounded_top(_grazing_height(c, a, t2), np.full(t2.size, 1e-4 * c), t2)
    assert fit.height_m == pytest.approx(c, rel=1e-6)
    assert fit.height_std_m > 0


def test_rounded_fit_refuses_bad_input() -> None:
    with pytest.raises(SolverError, match="two or more depression angles"):
        fit_rounded_top([0.03, 0.031], [1e-4, 1e-4], [0.1, 0.1])
    with pytest.raises(SolverError, match="grazing_height_m"):
        fit_rounded_top([0.03, -0.01], [1e-4, 1e-4], [0.1, 0.2])
    with pytest.raises(SolverError, match="one shape"):
        fit_rounded_top([0.03, 0.02], [1e-4], [0.1, 0.2])
    with pytest.raises(SolverError, match="no summit"):
        # Grazing heights falling fivefold: the line of 1/z^2 meets t = 0 below zero.
        fit_rounded_top([0.05, 0.01], [1e-6, 1e-6], [0.1, 0.2])
