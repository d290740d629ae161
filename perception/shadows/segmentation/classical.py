"""The paper's classical adaptive-threshold segmentation (the baseline shown side by side).

Part of :mod:`perception.shadows.segmentation.segment`: OpenCV's adaptive mean threshold on the 8-bit
image at full resolution, components with their holes filled.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from perception import imaging
from perception.shadows.segmentation.grid import Region, components
from perception.shadows.segmentation.levels import Levels

if TYPE_CHECKING:
    from perception.shadows.segmentation.config import SegmentationConfig

#: Smallest shadow and highlight components the baseline keeps, pixels.
MIN_SHADOW_AREA_PX = 12
MIN_HIGHLIGHT_AREA_PX = 6


def classical_regions(
    levels: Levels, cfg: SegmentationConfig
) -> tuple[NDArray[np.int32], tuple[Region, ...], NDArray[np.int32], tuple[Region, ...]]:
    """The paper's adaptive mean threshold at full resolution: shadow and highlight components."""
    grey: NDArray[np.uint8] = (
        np.asarray(levels, dtype=np.uint8)
        if levels.dtype == np.uint8
        else _to_uint8(np.asarray(levels, np.float32))
    )
    block = min(cfg.classical_block_size, (min(grey.shape) // 2) * 2 - 1)
    block = max(block, 3)
    shadow_u8 = imaging.adaptive_mean_threshold(grey, block, cfg.classical_offset, below=True)
    highlight_u8 = imaging.adaptive_mean_threshold(grey, block, -cfg.classical_offset, below=False)
    shadow_labels, shadows = components(shadow_u8, kind="shadow", min_area_px=MIN_SHADOW_AREA_PX)
    highlight_labels, highlights = components(highlight_u8, kind="highlight", min_area_px=MIN_HIGHLIGHT_AREA_PX)
    return shadow_labels, shadows, highlight_labels, highlights


def _to_uint8(db: NDArray[np.float32]) -> NDArray[np.uint8]:
    """dB levels to 0..255 over the 80 dB below their 99.5th percentile (classical input)."""
    top = float(np.percentile(db, 99.5))
    return np.clip((db - (top - 80.0)) * (255.0 / 80.0), 0, 255).astype(np.uint8)
