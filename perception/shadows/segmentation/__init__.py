"""Highlight and cast-shadow segmentation of polar sonar images."""

from perception.shadows.segmentation.grid import ColumnRows, Extents, Region, label_mask, labelled_regions
from perception.shadows.segmentation.levels import as_levels, block_levels, level_spread, row_background
from perception.shadows.segmentation.result import Segmentation
from perception.shadows.segmentation.segment import SegmentationConfig, mask_iou, sample_spacing_m, segment

__all__ = [
    "ColumnRows",
    "Extents",
    "Region",
    "Segmentation",
    "SegmentationConfig",
    "as_levels",
    "block_levels",
    "label_mask",
    "labelled_regions",
    "level_spread",
    "mask_iou",
    "row_background",
    "sample_spacing_m",
    "segment",
]
