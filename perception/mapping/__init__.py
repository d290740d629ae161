"""The 2.5D map: georeference, mosaic, drift registration, heights layer, map products."""

from perception.atomic_file import atomic_write, atomic_write_text
from perception.geodesy import LocalOrigin
from perception.mapping.builder import MosaicBuilder, masks_from_shadows
from perception.mapping.fan import frame_to_fan, polar_to_fan
from perception.mapping.fan_geometry import FanGeometry, fan_geometry
from perception.mapping.heights_layer import MappedTarget, height_raster, targets_feature_collection
from perception.mapping.mosaic import MosaicConfig, TiledMosaic, placement_from_frame
from perception.mapping.products import (
    MapRaster,
    map_raster,
    write_footprints_geojson,
    write_geotiff,
    write_png_with_world_file,
    write_targets_geojson,
)
from perception.mapping.projection import project_frame
from perception.mapping.registration import DriftEstimator, RegistrationConfig, RegistrationResult, measure_shift

__all__ = [
    "DriftEstimator",
    "FanGeometry",
    "LocalOrigin",
    "MapRaster",
    "MappedTarget",
    "MosaicBuilder",
    "MosaicConfig",
    "RegistrationConfig",
    "RegistrationResult",
    "TiledMosaic",
    "atomic_write",
    "atomic_write_text",
    "fan_geometry",
    "frame_to_fan",
    "height_raster",
    "map_raster",
    "masks_from_shadows",
    "measure_shift",
    "placement_from_frame",
    "polar_to_fan",
    "project_frame",
    "targets_feature_collection",
    "write_footprints_geojson",
    "write_geotiff",
    "write_png_with_world_file",
    "write_targets_geojson",
]
