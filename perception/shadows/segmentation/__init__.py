"""Highlight and cast-shadow segmentation of polar sonar images."""

from perception.shadows.segmentation.band import insonified_rows
from perception.shadows.segmentation.grid import (
    ColumnRows,
    Extents,
    Region,
    components,
    grid_components,
    label_mask,
    labelled_regions,
    with_core,
)
from perception.shadows.segmentation.levels import (
    BACKGROUND_MEDIAN_BLOCKS,
    as_levels,
    box_smooth,
    grid_smooth,
    row_background,
    running_min_max,
)
from perception.shadows.segmentation.result import Segmentation
from perception.shadows.segmentation.segment import SegmentationConfig, mask_iou, segment

__all__ = [
    "BACKGROUND_MEDIAN_BLOCKS",
    "ColumnRows",
    "Extents",
    "Region",
    "Segmentation",
    "SegmentationConfig",
    "as_levels",
    "box_smooth",
    "components",
    "grid_components",
    "grid_smooth",
    "insonified_rows",
    "label_mask",
    "labelled_regions",
    "mask_iou",
    "row_background",
    "running_min_max",
    "segment",
    "with_core",
]
