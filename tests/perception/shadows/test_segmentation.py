"""Segmentation against exact synthetic frames: masks where the geometry puts them, in any
dtype, gain or sample spacing, and the paper's classical baseline."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from perception.shadows.segmentation.segment import (
    MIN_SIGMA_DB,
    SegmentationConfig,
    mask_iou,
    segment,
    sorted_percentile,
)
from tests.perception.shadows.shadow_synth import (
    LABEL_HIGHLIGHT,
    LABEL_OUTSIDE,
    LABEL_SHADOW,
    Box,
    SynthConfig,
    render,
)

THREE_BOXES = (
    Box(1.2, 0.0, 0.10, 0.05, 0.039),
    Box(1.05, -0.18, 0.06, 0.05, 0.028),
    Box(1.3, 0.3, 0.05, 0.04, 0.047),
)


def _power(image_uint8: np.ndarray) -> np.ndarray:
    """Linear power of ARIS display levels (80 dB over 0-255)."""
    return 10.0 ** (image_uint8.astype(np.float64) * (80 / 255) / 10)


def test_masks_match_the_truth_labels(rng: np.random.Generator) -> None:
    frame, labels, _ = render(SynthConfig(boxes=THREE_BOXES), rng=rng)
    seg = segment(frame.image, range_m=frame.range_m)
    assert len(seg.shadows) == 3 and len(seg.highlights) == 3
    # The grid's cells straddle the masks' edges: a grid step of slack at each end.
    assert mask_iou(seg.shadow_mask, labels == LABEL_SHADOW) > 0.7
    assert mask_iou(seg.highlight_mask, labels == LABEL_HIGHLIGHT) > 0.6


def test_speckle_method_beats_the_classical_baseline(rng: np.random.Generator) -> None:
    frame, labels, _ = render(SynthConfig(boxes=THREE_BOXES), rng=rng)
    truth = labels == LABEL_SHADOW
    ours = mask_iou(segment(frame.image, range_m=frame.range_m).shadow_mask, truth)
    classical = segment(frame.image, range_m=frame.range_m, config=SegmentationConfig(method="classical"))
    assert classical.method == "classical"
    assert ours > mask_iou(classical.shadow_mask, truth) + 0.2


def test_darkness_outside_the_band_is_not_shadow(rng: np.random.Generator) -> None:
    # No targets: the dark rows before and beyond the insonified band hold no shadow.
    frame, labels, _ = render(SynthConfig(window_m=(0.6, 3.0)), rng=rng)
    seg = segment(frame.image, range_m=frame.range_m)
    assert not seg.shadow_mask.any()
    # A row is the band's where a quarter of its beams or more see seabed (its seabed level
    # is the upper quartile over beams; the band's edges are curved across the beams).
    truth = np.flatnonzero((labels != LABEL_OUTSIDE).mean(axis=1) >= 0.25)
    first, last = seg.band_edges() or (-1, -1)
    assert first > 0 and last < frame.n_samples - 1  # the band lies inside the window
    # The rendered beam pattern's tail reaches a little past the aperture the labels use.
    assert abs(first - truth[0]) <= 12 and abs(last - truth[-1]) <= 12


@pytest.mark.parametrize("dtype", [np.uint16, np.float32, np.float64])
def test_linear_power_gives_the_masks_of_the_display_image(rng: np.random.Generator, dtype: type) -> None:
    # uint8 frames are ARIS display levels (0-80 dB); other dtypes are linear power.
    frame, _, _ = render(SynthConfig(boxes=THREE_BOXES), rng=rng)
    before = frame.image.copy()
    reference = segment(frame.image, range_m=frame.range_m)
    np.testing.assert_array_equal(frame.image, before)
    power = _power(frame.image)
    if dtype is np.uint16:
        power = np.clip(np.round(power / 100), 0, 65535)
    image: np.ndarray = power.astype(dtype)
    copy = image.copy()
    seg = segment(image, range_m=frame.range_m)
    np.testing.assert_array_equal(image, copy)
    assert seg.db_per_level == 1.0 and reference.db_per_level == pytest.approx(80 / 255)
    assert mask_iou(seg.shadow_mask, reference.shadow_mask) > 0.95
    assert mask_iou(seg.highlight_mask, reference.highlight_mask) > 0.95


@given(gain_db=st.floats(-30.0, 30.0), amplitude=st.booleans())
@settings(max_examples=12, deadline=None, derandomize=True)
def test_gain_and_amplitude_do_not_move_the_masks(gain_db: float, amplitude: bool) -> None:
    # Thresholds are in units of the frame's own spread: a gain multiplies every value, an
    # amplitude image halves every dB contrast and the spread alike.
    frame, _, _ = render(SynthConfig(boxes=THREE_BOXES), rng=np.random.default_rng(4))
    power = _power(frame.image).astype(np.float32)
    reference = segment(power, range_m=frame.range_m)
    image = power * np.float32(10.0 ** (gain_db / 10))
    if amplitude:
        image = np.sqrt(image)
    seg = segment(image, range_m=frame.range_m)
    assert mask_iou(seg.shadow_mask, reference.shadow_mask) > 0.97
    expected = max(reference.sigma_db * (0.5 if amplitude else 1.0), MIN_SIGMA_DB)
    assert seg.sigma_db == pytest.approx(expected, rel=0.02)


def test_regions_lie_at_the_same_ranges_whatever_the_sample_spacing(rng: np.random.Generator) -> None:
    # The same scene sampled at 800 and at 2000 samples over the window: the grid is in
    # metres, so each shadow region starts and ends at the same ranges (to a grid step and
    # the speckle's play at the ends).
    starts = []
    for n_samples in (800, 2000):
        frame, _, _ = render(SynthConfig(boxes=THREE_BOXES, n_samples=n_samples), rng=rng)
        seg = segment(frame.image, range_m=frame.range_m)
        regions = sorted(seg.shadows, key=lambda r: r.centroid_col)
        starts.append([(frame.range_m[r.row_start], frame.range_m[r.row_stop - 1]) for r in regions])
    assert len(starts[0]) == len(starts[1]) == 3
    for (a0, a1), (b0, b1) in zip(*starts, strict=True):
        assert a0 == pytest.approx(b0, abs=0.02) and a1 == pytest.approx(b1, abs=0.02)


def test_bad_images_are_rejected() -> None:
    with pytest.raises(ValueError, match="2-D"):
        segment(np.zeros((4, 4, 3), np.uint8))
    with pytest.raises(ValueError, match="dtype"):
        segment(np.zeros((40, 40), np.int64))
    bad = np.ones((40, 40), np.float32)
    bad[3, 3] = np.nan
    with pytest.raises(ValueError, match="finite"):
        segment(bad)
    with pytest.raises(ValueError, match=">= 0"):
        segment(-np.ones((40, 40), np.float32))
    with pytest.raises(ValueError, match="range_m"):
        segment(np.ones((40, 40), np.uint8), range_m=np.arange(39.0))


def test_config_is_validated() -> None:
    with pytest.raises(ValueError, match="method"):
        SegmentationConfig(method="otsu")
    with pytest.raises(ValueError, match="smooth_beams"):
        SegmentationConfig(smooth_beams=4)
    with pytest.raises(ValueError, match="shadow_sigmas"):
        SegmentationConfig(shadow_sigmas=-1.0)
    with pytest.raises(ValueError, match="shadow_core_sigmas"):
        SegmentationConfig(shadow_core_sigmas=2.0)
    with pytest.raises(ValueError, match="shadow_weak_sigmas"):
        SegmentationConfig(shadow_weak_sigmas=4.0)
    with pytest.raises(ValueError, match="uint8_db_range"):
        SegmentationConfig(uint8_db_range=0.0)
    with pytest.raises(ValueError, match="max_grid_rows"):
        SegmentationConfig(max_grid_rows=2)


def test_row_step_follows_the_sample_spacing() -> None:
    cfg = SegmentationConfig(grid_step_m=0.005, max_grid_rows=320)
    assert cfg.row_step(2000, 0.001) == 7  # ceil(2000 / 320) beats round(5 mm / 1 mm)
    assert cfg.row_step(800, 0.0025) == 3  # 800 / 320 = 2.5 -> 3 beats round(2)
    assert cfg.row_step(400, 0.001) == 5
    assert SegmentationConfig(method="classical").row_step(2000, 0.001) == 1


def test_mask_iou_known_values() -> None:
    a = np.zeros((4, 4), bool)
    b = np.zeros((4, 4), bool)
    assert mask_iou(a, b) == 1.0
    a[0, :2] = True
    b[0, 1:3] = True
    assert mask_iou(a, b) == pytest.approx(1 / 3)
    with pytest.raises(ValueError, match="shapes"):
        mask_iou(a, np.zeros((3, 3), bool))


@given(values=st.lists(st.floats(-1e6, 1e6), min_size=1, max_size=60), q=st.floats(0.0, 100.0))
@settings(max_examples=60, deadline=None, derandomize=True)
def test_sorted_percentile_is_numpys(values: list[float], q: float) -> None:
    ordered = np.sort(np.array(values, dtype=np.float64))
    assert sorted_percentile(ordered, q) == pytest.approx(float(np.percentile(ordered, q)), rel=1e-9, abs=1e-6)
