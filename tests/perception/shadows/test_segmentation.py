"""Segmentation against exact synthetic frames and hand-made masks."""

from __future__ import annotations

import numpy as np
import pytest

from perception.shadows.segmentation.segment import (
    SegmentationConfig,
    components,
    insonified_rows,
    mask_iou,
    segment,
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


def test_masks_match_the_truth_labels(rng: np.random.Generator) -> None:
    frame, labels, _ = render(SynthConfig(boxes=THREE_BOXES), rng=rng)
    seg = segment(frame.image)
    assert mask_iou(seg.shadow_mask, labels == LABEL_SHADOW) > 0.8
    assert mask_iou(seg.highlight_mask, labels == LABEL_HIGHLIGHT) > 0.75
    assert len(seg.shadows) == 3 and len(seg.highlights) == 3


def test_speckle_method_beats_the_classical_baseline(rng: np.random.Generator) -> None:
    frame, labels, _ = render(SynthConfig(boxes=THREE_BOXES), rng=rng)
    truth = labels == LABEL_SHADOW
    ours = mask_iou(segment(frame.image).shadow_mask, truth)
    classical = segment(frame.image, config=SegmentationConfig(method="classical"))
    assert classical.method == "classical"
    assert ours > mask_iou(classical.shadow_mask, truth) + 0.2


def test_darkness_outside_the_band_is_not_shadow(rng: np.random.Generator) -> None:
    # No targets: the dark rows before and beyond the insonified band hold no shadow.
    frame, labels, _ = render(SynthConfig(window_m=(0.6, 3.0)), rng=rng)
    seg = segment(frame.image)
    assert not seg.shadow_mask.any()
    truth_rows = (labels != LABEL_OUTSIDE).all(axis=1)
    first, last = seg.band_edges() or (-1, -1)
    truth = np.flatnonzero(truth_rows)
    assert first > 0 and last < frame.n_samples - 1  # the band lies inside the window
    assert abs(first - truth[0]) <= 8 and abs(last - truth[-1]) <= 8


@pytest.mark.parametrize("dtype", [np.uint16, np.float32, np.float64])
def test_linear_power_gives_the_masks_of_the_display_image(
    rng: np.random.Generator, dtype: type
) -> None:
    # uint8 frames are ARIS display levels (0-80 dB); other dtypes are linear power.
    frame, _, _ = render(SynthConfig(boxes=THREE_BOXES), rng=rng)
    before = frame.image.copy()
    reference = segment(frame.image)
    np.testing.assert_array_equal(frame.image, before)
    power = 10.0 ** (frame.image.astype(np.float64) * (80 / 255) / 10)
    if dtype is np.uint16:
        power = np.clip(np.round(power / 100), 0, 65535)
    image: np.ndarray = power.astype(dtype)
    copy = image.copy()
    seg = segment(image)
    np.testing.assert_array_equal(image, copy)
    assert seg.db_per_level == 1.0 and reference.db_per_level == pytest.approx(80 / 255)
    assert mask_iou(seg.shadow_mask, reference.shadow_mask) > 0.97
    assert mask_iou(seg.highlight_mask, reference.highlight_mask) > 0.97


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


def test_config_is_validated() -> None:
    with pytest.raises(ValueError, match="method"):
        SegmentationConfig(method="otsu")
    with pytest.raises(ValueError, match="odd"):
        SegmentationConfig(smooth_samples=4)
    with pytest.raises(ValueError, match="shadow_db"):
        SegmentationConfig(shadow_db=-1.0)
    with pytest.raises(ValueError, match="uint8_db_range"):
        SegmentationConfig(uint8_db_range=0.0)


def test_components_known_answer() -> None:
    mask = np.zeros((30, 20), np.uint8)
    mask[2:6, 3:9] = 1  # 24 px
    mask[10:20, 12:15] = 1  # 30 px, with a hole that is filled
    mask[14, 13] = 0
    mask[25, 1] = 1  # 1 px, dropped
    labels, regions = components(mask, kind="shadow", min_area_px=5)
    by_row = sorted(regions, key=lambda r: r.row_start)
    assert [(r.row_start, r.row_stop, r.col_start, r.col_stop) for r in by_row] == [
        (2, 6, 3, 9),
        (10, 20, 12, 15),
    ]
    assert [r.area_px for r in by_row] == [24, 30]
    assert labels[25, 1] == 0 and labels[14, 13] == by_row[1].label
    assert by_row[0].centroid_row == pytest.approx(3.5) and by_row[0].centroid_col == pytest.approx(5.5)


def test_insonified_rows_keep_the_longest_run() -> None:
    background = np.full(100, 10.0, np.float32)  # dB
    background[20:70] = 50.0
    background[90] = 50.0  # an isolated bright row in the dark
    rows = insonified_rows(background, drop=10.0)
    assert np.flatnonzero(rows).tolist() == list(range(20, 70))


def test_mask_iou_known_values() -> None:
    a = np.zeros((4, 4), bool)
    b = np.zeros((4, 4), bool)
    assert mask_iou(a, b) == 1.0
    a[0, :2] = True
    b[0, 1:3] = True
    assert mask_iou(a, b) == pytest.approx(1 / 3)
    with pytest.raises(ValueError, match="shapes"):
        mask_iou(a, np.zeros((3, 3), bool))


def test_components_of_a_speckled_mask() -> None:
    # More pieces than the contour path takes: the labelling path gives the same regions.
    mask = np.zeros((200, 128), np.uint8)
    for k in range(300):
        r, c = 3 * (k // 40), 3 * (k % 40)
        mask[r : r + 2, c : c + 2] = 1
    mask[150:170, 10:40] = 1
    labels, regions = components(mask, kind="shadow", min_area_px=4)
    assert len(regions) == 301
    big = max(regions, key=lambda r: r.area_px)
    assert (big.row_start, big.row_stop, big.col_start, big.col_stop, big.area_px) == (150, 170, 10, 40, 600)
    assert sorted({r.area_px for r in regions}) == [4, 600]
    assert np.count_nonzero(labels == big.label) == 600
    _, none_kept = components(mask, kind="shadow", min_area_px=5)
    assert len(none_kept) == 1
