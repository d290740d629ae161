"""The detection grid's building blocks: levels, block means, row levels and spreads,
hysteresis along beams, labelling -- against plain reference implementations."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.ndimage import maximum_filter1d, median_filter, minimum_filter1d

from perception.shadows.segmentation.grid import grid_components
from perception.shadows.segmentation.levels import (
    as_levels,
    block_levels,
    level_spread,
    row_background,
    row_spread,
    running_median,
    running_min_max,
)
from perception.shadows.segmentation.segment import hysteresis_along_beams


@given(
    n_rows=st.integers(1, 60),
    n_cols=st.integers(1, 12),
    step=st.integers(1, 9),
    beams=st.sampled_from([1, 3, 5]),
    as_float=st.booleans(),
    seed=st.integers(0, 2**16),
)
@settings(max_examples=60, deadline=None, derandomize=True)
def test_block_levels_are_block_means_smoothed_over_beams(
    n_rows: int, n_cols: int, step: int, beams: int, as_float: bool, seed: int
) -> None:
    rng = np.random.default_rng(seed)
    image = rng.integers(0, 256, (n_rows, n_cols)).astype(np.float32 if as_float else np.uint8)
    d = min(step, n_rows)
    n = n_rows // d
    means = image[: n * d].astype(np.float64).reshape(n, d, n_cols).mean(axis=1)
    want = cv2.boxFilter(means, -1, (beams, 1), normalize=True, borderType=cv2.BORDER_REPLICATE)
    got = block_levels(image, step, beams=beams)
    assert got.dtype == np.float32 and got.shape == (n, n_cols)
    np.testing.assert_allclose(got, want, rtol=1e-5, atol=1e-4)


@given(n=st.integers(1, 80), size=st.sampled_from([1, 3, 5, 9, 17]), seed=st.integers(0, 2**16))
@settings(max_examples=60, deadline=None, derandomize=True)
def test_running_filters_are_scipys(n: int, size: int, seed: int) -> None:
    values = np.random.default_rng(seed).normal(size=n).astype(np.float32)
    np.testing.assert_array_equal(running_median(values, size=size), median_filter(values, size=size, mode="nearest"))
    low, high = running_min_max(values, size=size)
    np.testing.assert_array_equal(low, minimum_filter1d(values, size, mode="nearest"))
    np.testing.assert_array_equal(high, maximum_filter1d(values, size, mode="nearest"))


def test_row_background_is_the_capped_upper_quartile() -> None:
    # Seabed at 100 with a dark half (shadows) and one row where bright targets fill a third.
    grid = np.full((40, 16), 100.0, np.float32)
    grid[:, :8] = 20.0  # more than half of every row in shadow: the upper quartile is the seabed's
    grid[30, 10:16] = 250.0  # bright targets raise row 30's upper quartile
    level = row_background(grid, block_rows=1, median_blocks=5)
    assert level.shape == (40,)
    np.testing.assert_allclose(level, 100.0)  # the running median caps row 30


@given(sigma=st.floats(0.5, 5.0), seed=st.integers(0, 2**16))
@settings(max_examples=20, deadline=None, derandomize=True)
def test_level_spread_reads_the_seabed_through_shadows_and_echoes(sigma: float, seed: int) -> None:
    rng = np.random.default_rng(seed)
    grid = rng.normal(100.0, sigma, (200, 64)).astype(np.float32)
    grid[:, :12] -= 40.0  # shadows: far below
    grid[50:60, 30:40] += 40.0  # echoes: far above
    background = np.full(200, 100.0, np.float32)
    spread = level_spread(grid, background, np.ones(200, dtype=bool))
    assert spread == pytest.approx(sigma, rel=0.1)
    assert level_spread(grid, background, np.zeros(200, dtype=bool)) == 0.0


def test_row_spread_is_each_rows_own() -> None:
    rng = np.random.default_rng(3)
    grid = np.concatenate([rng.normal(0, 1.0, (100, 128)), rng.normal(0, 4.0, (100, 128))]).astype(np.float32)
    spread = row_spread(grid, np.zeros(200, np.float32), block_rows=4)
    assert np.median(spread[10:90]) == pytest.approx(1.0, rel=0.15)
    assert np.median(spread[110:190]) == pytest.approx(4.0, rel=0.15)


def _hysteresis_reference(strong: np.ndarray, weak: np.ndarray) -> np.ndarray:
    """Per column, runs of ``weak | strong`` rows holding a strong row (plain loops)."""
    mask = weak | strong
    out = np.zeros_like(mask)
    for c in range(mask.shape[1]):
        r = 0
        while r < mask.shape[0]:
            if not mask[r, c]:
                r += 1
                continue
            s = r
            while r < mask.shape[0] and mask[r, c]:
                r += 1
            if strong[s:r, c].any():
                out[s:r, c] = True
    return out


@given(n_rows=st.integers(1, 30), n_cols=st.integers(1, 20), p_strong=st.floats(0, 0.3), p_weak=st.floats(0, 0.8),
       seed=st.integers(0, 2**16))
@settings(max_examples=80, deadline=None, derandomize=True)
def test_hysteresis_along_beams_is_the_run_rule(n_rows: int, n_cols: int, p_strong: float, p_weak: float,
                                                seed: int) -> None:
    rng = np.random.default_rng(seed)
    g = rng.random((n_rows, n_cols))
    strong, weak = g < p_strong, g < p_weak
    np.testing.assert_array_equal(hysteresis_along_beams(strong, weak), _hysteresis_reference(strong, weak))


def test_hysteresis_does_not_cross_to_the_next_beam() -> None:
    strong = np.zeros((6, 3), bool)
    weak = np.zeros((6, 3), bool)
    strong[2, 1] = True
    weak[:, 1] = True  # the whole beam through the strong pixel
    weak[:, 0] = True  # a weak beam beside it, without a strong pixel
    out = hysteresis_along_beams(strong, weak)
    assert out[:, 1].all() and not out[:, 0].any() and not out[:, 2].any()


@pytest.mark.parametrize("dtype", [np.uint16, np.float32, np.float64])
def test_linear_levels_are_decibels_floored(dtype: type) -> None:
    image = np.array([[0, 1, 10, 100], [1000, 10, 10, 10]], dtype=dtype)
    levels, per_level = as_levels(image)
    assert per_level == 1.0 and levels.dtype == np.float32
    assert levels[0, 2] == pytest.approx(10.0) and levels[1, 0] == pytest.approx(30.0)
    # Zeros sit at a floor (50 dB below the median of the positive values, or half an LSB).
    assert np.isfinite(levels).all() and levels[0, 0] <= levels[0, 1]


def test_uint8_levels_are_the_display_image() -> None:
    image = np.arange(256, dtype=np.uint8).reshape(16, 16)
    levels, per_level = as_levels(image, uint8_db_range=80.0)
    assert levels is image or np.shares_memory(levels, image)
    assert per_level == pytest.approx(80 / 255)


def test_grid_components_known_answer() -> None:
    mask = np.zeros((30, 20), np.uint8)
    mask[2:6, 3:9] = 1  # 24 px
    mask[10:20, 12:15] = 1  # 30 px
    mask[25, 1] = 1  # 1 px, dropped
    labels, regions, (first, last) = grid_components(mask, kind="shadow", min_area_px=5)
    by_row = sorted(regions, key=lambda r: r.row_start)
    assert [(r.row_start, r.row_stop, r.col_start, r.col_stop) for r in by_row] == [(2, 6, 3, 9), (10, 20, 12, 15)]
    assert [r.area_px for r in by_row] == [24, 30]
    assert by_row[0].centroid_row == pytest.approx(3.5) and by_row[0].centroid_col == pytest.approx(5.5)
    second = by_row[1].label
    assert first[second, 13] == 10 and last[second, 13] == 19 and last[second, 0] == -1
    # On a grid of 4 rows per cell, rows and areas are full-resolution ones.
    _, regions4, _ = grid_components(mask, kind="shadow", min_area_px=5, row_step=4, n_rows=118)
    big = max(regions4, key=lambda r: r.area_px)
    assert (big.row_start, big.row_stop, big.area_px) == (40, 80, 120)
