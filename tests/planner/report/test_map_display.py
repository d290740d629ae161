"""The map figure draws a field-scale mosaic from block means, never the full raster."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from planner.report.map_plot import display_image


def test_a_small_mosaic_is_drawn_as_it_is() -> None:
    image = np.arange(12, dtype=np.float32).reshape(3, 4)
    assert display_image(image, 10) is image


@given(arrays(np.float32, st.tuples(st.integers(1, 300), st.integers(1, 200)),
              elements=st.one_of(st.just(np.nan), st.floats(0, 255, width=32))), st.integers(1, 40))
def test_block_means_leave_empty_cells_out(image: np.ndarray, max_px: int) -> None:
    shown = display_image(image, max_px)
    k = int(np.ceil(max(image.shape) / max_px))
    assert max(shown.shape) <= max_px or k == 1
    if k == 1:
        return
    for i, j in [(0, 0), (shown.shape[0] - 1, shown.shape[1] - 1), (shown.shape[0] // 2, shown.shape[1] // 2)]:
        block = image[i * k:(i + 1) * k, j * k:(j + 1) * k]
        finite = block[np.isfinite(block)]
        if finite.size:
            assert shown[i, j] == pytest.approx(np.mean(finite.astype(np.float64)), rel=1e-6)
        else:
            assert np.isnan(shown[i, j])
