"""Segmentation on the decimated detection grid: same regions and edges as full resolution."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.ndimage import maximum_filter1d, median_filter, minimum_filter1d

from perception.heights.pipeline import detect_shadows
from perception.shadows.measurement.measure import measure_pairs
from perception.shadows.pairing.pair import pair_regions
from perception.shadows.segmentation.segment import (
    BACKGROUND_MEDIAN_BLOCKS,
    Region,
    SegmentationConfig,
    box_smooth,
    grid_components,
    grid_smooth,
    label_mask,
    labelled_regions,
    mask_iou,
    row_background,
    running_min_max,
    segment,
    with_core,
)
from tests.perception.shadows.shadow_synth import (
    LABEL_HIGHLIGHT,
    LABEL_SHADOW,
    Box,
    SynthConfig,
    edges_at,
    render,
)

THREE_BOXES = (
    Box(1.2, 0.0, 0.10, 0.05, 0.039),
    Box(1.05, -0.18, 0.06, 0.05, 0.028),
    Box(1.3, 0.3, 0.05, 0.04, 0.047),
)
FULL = SegmentationConfig(detection_rows=0)


@given(
    n_rows=st.integers(3, 60),
    n_cols=st.integers(1, 12),
    samples=st.sampled_from([1, 3, 5, 7]),
    beams=st.sampled_from([1, 3, 5]),
    as_float=st.booleans(),
    seed=st.integers(0, 2**16),
)
@settings(max_examples=60, deadline=None, derandomize=True)
def test_grid_smooth_is_box_smooth_at_those_rows(
    n_rows: int, n_cols: int, samples: int, beams: int, as_float: bool, seed: int
) -> None:
    gen = np.random.default_rng(seed)
    levels = gen.integers(0, 256, (n_rows, n_cols))
    image = levels.astype(np.float32) if as_float else levels.astype(np.uint8)
    rows = np.unique(gen.integers(0, n_rows, 5))
    full = np.asarray(box_smooth(image, samples=samples, beams=beams), dtype=np.float64)
    found = np.asarray(grid_smooth(image, rows, samples=samples, beams=beams), dtype=np.float64)
    np.testing.assert_allclose(found, full[rows], rtol=1e-5, atol=1e-3)


@given(
    n_blocks=st.integers(1, 40),
    step=st.integers(1, 12),
    extra=st.integers(0, 11),
    samples=st.sampled_from([1, 3, 5, 7]),
    seed=st.integers(0, 2**16),
)
@settings(max_examples=60, deadline=None, derandomize=True)
def test_grid_smooth_on_the_detection_grid_is_box_smooth(
    n_blocks: int, step: int, extra: int, samples: int, seed: int
) -> None:
    # The detection grid's rows (the middle row of every block of ``step`` rows), with and
    # without a partial last block: the blocked fast path and the general one agree.
    n_rows = n_blocks * step + (extra % step)
    image = np.random.default_rng(seed).integers(0, 256, (n_rows, 9)).astype(np.uint8)
    rows = np.minimum(np.arange(step // 2, n_rows + step // 2, step), n_rows - 1)
    full = np.asarray(box_smooth(image, samples=samples, beams=3), dtype=np.float64)
    found = np.asarray(grid_smooth(image, rows, samples=samples, beams=3), dtype=np.float64)
    np.testing.assert_allclose(found, full[rows], rtol=1e-5, atol=1e-3)


@given(start=st.integers(0, 770), length=st.integers(1, 30), beam=st.integers(0, 127))
@settings(max_examples=30, deadline=None, derandomize=True)
def test_smoothed_windows_are_slices_of_the_smoothed_image(start: int, length: int, beam: int) -> None:
    frame, _, _ = render(SynthConfig(boxes=THREE_BOXES), rng=np.random.default_rng(3))
    seg = segment(frame.image)
    window = seg.smoothed_windows(np.array([start, start]), length, np.array([beam, max(beam - 1, 0)]))
    rows = np.arange(start, start + length)
    np.testing.assert_allclose(window[:, 0], seg.smoothed[rows, beam], atol=1e-3)
    np.testing.assert_allclose(window[:, 1], seg.smoothed[rows, max(beam - 1, 0)], atol=1e-3)


def test_smoothed_windows_of_uint8_levels_are_exact_box_means() -> None:
    # The uint8 path sums the boxes by a matrix product: the means are exactly the integer
    # box sums over samples x beams (edge rows and beams repeated), divided in float64.
    frame, _, _ = render(SynthConfig(boxes=THREE_BOXES), rng=np.random.default_rng(4))
    seg = segment(frame.image)
    levels = seg.levels.astype(np.int64)
    n_rows, n_cols = levels.shape
    starts, beams, length = np.array([-3, 0, 500, n_rows - 5]), np.array([0, 5, n_cols - 1, 64]), 9
    window = seg.smoothed_windows(starts, length, beams)
    for j, (start, beam) in enumerate(zip(starts.tolist(), beams.tolist(), strict=True)):
        for i in range(length):
            rows = np.clip(np.arange(start + i - 2, start + i + 3), 0, n_rows - 1)
            cols = np.clip(np.arange(beam - 1, beam + 2), 0, n_cols - 1)
            assert window[i, j] == levels[np.ix_(rows, cols)].sum() / 15


@given(n=st.integers(1, 300), size=st.sampled_from([1, 3, 5, 17]), seed=st.integers(0, 2**16))
@settings(max_examples=40, deadline=None, derandomize=True)
def test_running_min_max_is_scipys(n: int, size: int, seed: int) -> None:
    values = np.random.default_rng(seed).normal(0.0, 10.0, n).astype(np.float32)
    low, high = running_min_max(values, size=size)
    assert np.array_equal(low, minimum_filter1d(values, size, mode="nearest"))
    assert np.array_equal(high, maximum_filter1d(values, size, mode="nearest"))


@given(
    n_rows=st.integers(1, 300), n_cols=st.integers(1, 40), block=st.sampled_from([1, 2, 8]),
    negative=st.booleans(), seed=st.integers(0, 2**16),
)
@settings(max_examples=40, deadline=None, derandomize=True)
def test_row_background_is_the_capped_upper_quartile(
    n_rows: int, n_cols: int, block: int, negative: bool, seed: int
) -> None:
    # The reference: per-row partition and scipy's running median (what the fast paths replace).
    gen = np.random.default_rng(seed)
    smoothed = (gen.integers(0, 60, (n_rows, n_cols)) * np.float32(0.3) - (10 if negative else 0)).astype(np.float32)
    block = min(block, n_rows)
    level_rows = smoothed[: (n_rows // block) * block].reshape(-1, block, n_cols)
    small = level_rows[:, 0].copy()
    for k in range(1, block):
        small += level_rows[:, k]
    if block > 1:
        small *= np.float32(1.0 / block)
    k = (3 * n_cols) // 4
    level = np.partition(small, k, axis=1)[:, k]
    expected = np.minimum(level, median_filter(level, size=BACKGROUND_MEDIAN_BLOCKS, mode="nearest"))
    found = row_background(smoothed, block_samples=block)
    if block == 1:
        assert np.array_equal(found, expected)
    else:
        centres = (np.arange(level.size) + 0.5) * block - 0.5
        assert np.array_equal(found, np.interp(np.arange(n_rows), centres, expected).astype(np.float32))


def test_labelled_regions_with_core_are_with_core() -> None:
    # Filtering by core counts while the regions are built keeps what with_core keeps, and
    # every region is a whole Region (all fields, equal to one built by its constructor).
    gen = np.random.default_rng(9)
    mask = (gen.random((60, 41)) < 0.3).astype(np.uint8)
    mask[:, 20] = 0
    core = gen.random(mask.shape) < 0.5
    labelled = label_mask(mask.view(bool))
    core_px = np.bincount(labelled.labels[core], minlength=labelled.n_labels) * 4
    second = ("highlight", 21, 8)
    labels, regions, rows = grid_components(mask, kind="shadow", min_area_px=12, row_step=4, n_rows=235, second=second)
    kept, kept_rows = labelled_regions(
        labelled, kind="shadow", min_area_px=12, row_step=4, n_rows=235, second=second,
        core_px=core_px, min_core_px=(16, 8),
    )
    expected = [
        *with_core(tuple(r for r in regions if r.kind == "shadow"), labels, core, min_core_px=16, row_step=4),
        *with_core(tuple(r for r in regions if r.kind == "highlight"), labels, core, min_core_px=8, row_step=4),
    ]
    assert 0 < len(kept) < len(regions)
    assert sorted(kept, key=lambda r: r.label) == sorted(expected, key=lambda r: r.label)
    assert all(np.array_equal(a, b) for a, b in zip(kept_rows, rows, strict=True))
    for region in regions:
        assert region == Region(**{f.name: getattr(region, f.name) for f in dataclasses.fields(Region)})
        assert set(vars(region)) == {f.name for f in dataclasses.fields(Region)}


def test_grid_components_known_answer() -> None:
    # On a grid of step 4: a 3 x 5 block of grid cells stands for 12 x 5 full pixels.
    mask = np.zeros((20, 10), np.uint8)
    mask[4:7, 2:7] = 1
    mask[15, 9] = 1  # 4 full pixels: dropped below 5
    labels, regions, (first, last) = grid_components(mask, kind="shadow", min_area_px=5, row_step=4, n_rows=78)
    (region,) = regions
    assert (region.row_start, region.row_stop, region.col_start, region.col_stop) == (16, 28, 2, 7)
    assert region.area_px == 60
    assert region.centroid_row == pytest.approx(5 * 4 + 1.5) and region.centroid_col == pytest.approx(4.0)
    assert np.all(labels[4:7, 2:7] == region.label)
    assert first[region.label, 2:7].tolist() == [16] * 5 and last[region.label, 2:7].tolist() == [27] * 5
    assert last[region.label, 0] == -1 and last[region.label, 7] == -1


@pytest.mark.parametrize(("speckle_looks", "detection_rows", "step"), [(0.0, 250, 8), (4.0, 250, 8), (4.0, 500, 4)])
def test_grid_finds_the_regions_of_full_resolution(speckle_looks: float, detection_rows: int, step: int) -> None:
    config = SynthConfig(boxes=THREE_BOXES, n_samples=2000, speckle_looks=speckle_looks)
    frame, labels, _ = render(config, rng=np.random.default_rng(5))
    grid = segment(frame.image, config=SegmentationConfig(detection_rows=detection_rows))
    full = segment(frame.image, config=FULL)
    assert grid.row_step == step and full.row_step == 1
    for found, reference in ((grid.shadows, full.shadows), (grid.highlights, full.highlights)):
        assert len(found) == len(reference) == 3
        for a, b in zip(sorted(found, key=lambda r: r.col_start), sorted(reference, key=lambda r: r.col_start),
                        strict=True):
            assert (a.col_start, a.col_stop) == (b.col_start, b.col_stop)
            assert abs(a.row_start - b.row_start) <= step and abs(a.row_stop - b.row_stop) <= step
    # the full-resolution masks built from the grid regions match the truth labels
    assert mask_iou(grid.shadow_mask, labels == LABEL_SHADOW) > 0.8
    assert mask_iou(grid.highlight_mask, labels == LABEL_HIGHLIGHT) > 0.75
    assert mask_iou(grid.shadow_mask, full.shadow_mask) > 0.95


@pytest.mark.parametrize("detection_rows", [250, 500])
def test_grid_edges_equal_full_resolution_edges(detection_rows: int) -> None:
    # The measurement refines the grid's shadow rows at full resolution: every per-beam
    # edge is the one found when segmenting every row.
    config = SynthConfig(boxes=THREE_BOXES, n_samples=2000)
    frame, _, _ = render(config, rng=np.random.default_rng(8))
    found = []
    for cfg in (SegmentationConfig(detection_rows=detection_rows), FULL):
        seg = segment(frame.image, config=cfg)
        found.append(measure_pairs(seg, pair_regions(seg), range_m=frame.range_m,
                                   beam_azimuth_rad=frame.beam_azimuth_rad))
    assert len(found[0]) == len(found[1]) == 3
    for a, b in zip(*found, strict=True):
        assert a.usable and b.usable
        common = sorted(set(a.columns) & set(b.columns))
        assert len(common) >= 0.8 * len(b.columns)
        tops_a = dict(zip(a.columns, a.r_top_per_beam_m, strict=True))
        tops_b = dict(zip(b.columns, b.r_top_per_beam_m, strict=True))
        ends_a = dict(zip(a.columns, a.r_end_per_beam_m, strict=True))
        ends_b = dict(zip(b.columns, b.r_end_per_beam_m, strict=True))
        tolerance_m = 0.01 * frame.range_resolution_m  # a hundredth of a sample: rounding only
        for c in common:
            assert tops_a[c] == pytest.approx(tops_b[c], abs=tolerance_m)
            assert ends_a[c] == pytest.approx(ends_b[c], abs=tolerance_m)


def test_noise_free_edges_on_the_grid_are_sub_sample() -> None:
    box = Box(1.2, 0.0, 0.10, 0.05, 0.039)
    frame, _, _ = render(SynthConfig(boxes=(box,), n_samples=2000, speckle_looks=0), rng=np.random.default_rng(0))
    assert segment(frame.image).row_step == 8  # the default grid: 250 rows
    (m,) = detect_shadows(frame.image, range_m=frame.range_m, beam_azimuth_rad=frame.beam_azimuth_rad)
    errors = []
    for j, top, end in zip(m.columns, m.r_top_per_beam_m, m.r_end_per_beam_m, strict=True):
        exact = edges_at(box, float(frame.beam_azimuth_rad[j]), 0.5)
        assert exact is not None
        errors.append((top - exact[0], end - exact[1]))
    assert len(errors) >= 5
    assert np.abs(np.array(errors)).max() / frame.range_resolution_m < 0.2


def test_detection_rows_is_validated() -> None:
    with pytest.raises(ValueError, match="detection_rows"):
        SegmentationConfig(detection_rows=-1)
    assert SegmentationConfig().row_step(2000) == 8 and SegmentationConfig().row_step(1000) == 4
    assert SegmentationConfig(detection_rows=500).row_step(2000) == 4
    assert SegmentationConfig(detection_rows=0).row_step(2000) == 1
    assert SegmentationConfig(method="classical").row_step(2000) == 1
