"""Writing the 2.5D map: GeoTIFF, PNG with a world file, GeoJSON of the targets.

Every file is written through :mod:`perception.atomic_file` (temporary name, fsync, rename),
so a crash mid-write never leaves a broken file, and an earlier complete version survives
until replaced.
"""

from __future__ import annotations

import io
import json
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any
from xml.sax.saxutils import escape as xml_escape

import numpy as np
import tifffile

from perception import imaging
from perception.atomic_file import atomic_write, atomic_write_text
from perception.geodesy import LocalOrigin, geotiff_tags
from perception.mapping.heights_layer import MappedTarget, height_raster, targets_feature_collection
from perception.mapping.mosaic import TiledMosaic


@dataclass(frozen=True)
class MapRaster:
    """The mosaic cropped to its data, north up.

    ``intensity`` and ``height_m`` are float32 (n_rows, n_cols), row 0 the NORTHERN edge,
    NaN where there is no data; ``west_m``/``north_m`` the local coordinates of the
    upper-left corner; ``resolution_m`` the cell size.
    """

    intensity: np.ndarray
    height_m: np.ndarray
    weight: np.ndarray
    west_m: float
    north_m: float
    resolution_m: float

    def cell_of(self, north_m: float, east_m: float) -> tuple[float, float]:
        """(row, col), fractional, of a local point (cell centres at integers)."""
        return (
            (self.north_m - north_m) / self.resolution_m - 0.5,
            (east_m - self.west_m) / self.resolution_m - 0.5,
        )


def map_raster(
    mosaic: TiledMosaic, targets: Sequence[MappedTarget] = (), *, min_weight: float = 1e-3
) -> MapRaster:
    """Crop the mosaic to cells with data and add the heights layer (north up)."""
    mean, weight, row0, col0 = mosaic.raster()
    covered = weight > min_weight
    rows = np.flatnonzero(covered.any(axis=1))
    cols = np.flatnonzero(covered.any(axis=0))
    if rows.size == 0:
        raise ValueError("the mosaic holds no cell with weight above min_weight")
    r_lo, r_hi, c_lo, c_hi = int(rows[0]), int(rows[-1]) + 1, int(cols[0]), int(cols[-1]) + 1
    res = mosaic.config.resolution_m
    crop = (slice(r_lo, r_hi), slice(c_lo, c_hi))
    intensity = np.where(covered[crop], mean[crop], np.nan)
    heights = height_raster(
        targets, row0=row0 + r_lo, col0=col0 + c_lo, shape=intensity.shape, resolution_m=res
    )
    return MapRaster(
        intensity=np.ascontiguousarray(intensity[::-1]),
        height_m=np.ascontiguousarray(heights[::-1]),
        weight=np.ascontiguousarray(weight[r_lo:r_hi, c_lo:c_hi][::-1]),
        west_m=(col0 + c_lo) * res,
        north_m=(row0 + r_hi) * res,
        resolution_m=res,
    )


#: Threads compressing the GeoTIFF's strips (zlib lets go of the interpreter): a field-scale
#: mosaic has hundreds of strips, 1.3 s of compression on one core. The file is the same
#: byte for byte with any number (each strip is compressed on its own, written in order).
GEOTIFF_WORKERS = max(1, min(4, os.cpu_count() or 1))


def write_geotiff(path: Path, raster: MapRaster, origin: LocalOrigin) -> Path:
    """Two-band float32 GeoTIFF: band 1 echo intensity, band 2 target height (m); NaN = none."""
    data = np.stack([raster.intensity, raster.height_m]).astype(np.float32)
    tags = geotiff_tags(origin, west_m=raster.west_m, north_m=raster.north_m, pixel_m=raster.resolution_m)

    def write(handle: IO[bytes]) -> None:
        buffer = io.BytesIO()
        tifffile.imwrite(
            buffer,
            data,
            photometric="minisblack",
            planarconfig="separate",
            extratags=tags,
            metadata=None,
            compression="zlib",
            maxworkers=GEOTIFF_WORKERS,
        )
        handle.write(buffer.getvalue())

    return atomic_write(Path(path), write)


def to_uint8(intensity: np.ndarray, *, percentile: float = 99.5) -> np.ndarray:
    """Intensity scaled to uint8 by a robust maximum; NaN -> 0."""
    valid = np.isfinite(intensity)
    top = float(np.percentile(intensity[valid], percentile)) if np.any(valid) else 1.0
    scaled = np.where(valid, intensity, 0.0) * (255.0 / max(top, 1e-6))
    return np.clip(scaled, 0, 255).astype(np.uint8)


def write_png_with_world_file(path: Path, raster: MapRaster, origin: LocalOrigin) -> list[Path]:
    """Grey PNG with alpha (transparent where no data), its ``.pgw`` world file, ``.prj``
    and ``.png.aux.xml`` (the coordinate system as GDAL and QGIS read it)."""
    path = Path(path)
    grey = to_uint8(raster.intensity)
    alpha = np.where(np.isfinite(raster.intensity), 255, 0).astype(np.uint8)
    try:
        encoded = imaging.encode_png(np.dstack([grey, grey, grey, alpha]))
    except OSError:
        raise OSError(f"{path}: PNG encoding failed") from None
    res = raster.resolution_m
    world = "\n".join(
        f"{v:.10f}"
        for v in (res, 0.0, 0.0, -res, raster.west_m + res / 2, raster.north_m - res / 2)
    )
    return [
        atomic_write(path, lambda h: h.write(encoded)),
        atomic_write_text(path.with_suffix(".pgw"), world + "\n"),
        atomic_write_text(path.with_suffix(".prj"), origin.wkt() + "\n"),
        # GDAL (so QGIS) takes a PNG's coordinate system from its PAM side-car.
        atomic_write_text(
            path.with_name(path.name + ".aux.xml"),
            f"<PAMDataset>\n  <SRS>{xml_escape(origin.wkt())}</SRS>\n</PAMDataset>\n",
        ),
    ]


def write_targets_geojson(path: Path, targets: Sequence[MappedTarget], origin: LocalOrigin) -> Path:
    """Targets as GeoJSON points (WGS84) with height properties."""
    doc: dict[str, Any] = targets_feature_collection(targets, origin)
    return atomic_write_text(Path(path), json.dumps(doc, indent=1) + "\n")


def write_footprints_geojson(path: Path, targets: Sequence[MappedTarget], origin: LocalOrigin) -> Path:
    """Target footprints as GeoJSON polygons (WGS84) with height properties."""
    doc = targets_feature_collection(targets, origin, footprints=True)
    return atomic_write_text(Path(path), json.dumps(doc, indent=1) + "\n")
