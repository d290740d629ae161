"""Polar -> fan (Cartesian, top-down) sonar images, with the sonar at true range zero.

The fan image shows the sonar's zero-elevation imaging plane from above, boresight up:

- shape ``(n_rows, n_cols)``; row 0 is the farthest forward, the column index increases
  to starboard (the same way as the beam index of the polar image);
- integer pixel coordinates are pixel centres; pixel ``(row, col)`` lies at
  ``x_m = (origin_row - row) * pixel_size_m`` forward and
  ``y_m = (col - origin_col) * pixel_size_m`` to starboard of the sonar's acoustic centre,
  so ``range_m = hypot(x_m, y_m)`` and ``azimuth_rad = atan2(y_m, x_m)``;
- ``(origin_row, origin_col)`` is the apex of the fan, the sonar itself (range ZERO). It
  usually lies below the image: the range window starts at an arc of radius
  ``range_m[0]``, not at the bottom edge. Measuring ranges from the bottom edge is the
  error the paper reports for its fan-shaped images; measure from the origin instead.

Beam azimuths need not be uniform (ARIS tables are not): the column of the polar image is
interpolated from the azimuth, the row from the range. Pixels outside the fan (between the
first and last range sample and beam centre) take a fill value.

The remap maps are built once per geometry and cached (:func:`functools.lru_cache` keyed on
the geometry) and cut into bands that skip the wedge's empty corners; the sampling is
:func:`perception.imaging.fixed_point_maps` and :func:`perception.imaging.remap_fixed_point`."""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from perception import imaging
from perception.errors import GeometryError
from perception.mapping.fan_geometry import MAP_CACHE_SIZE, FanGeometry, float_maps
from perception.sonar_io.frame import SonarFrame

#: Image dtypes :func:`polar_to_fan` accepts.
FAN_DTYPES = (np.dtype(np.uint8), np.dtype(np.uint16), np.dtype(np.float32))


#: Map coordinate given to pixels outside the fan (far enough out that bilinear
#: interpolation reads only the fill value).
_OUTSIDE = -16.0


#: Rows per band of the remap plan (see :func:`_remap_plan`).
_BAND_ROWS = 32




@dataclass(frozen=True)
class _Band:
    """One horizontal band of the fan image: rows [row0, row1), columns [col0, col1)."""

    row0: int
    row1: int
    col0: int
    col1: int
    map1: np.ndarray
    map2: np.ndarray | None


@lru_cache(maxsize=MAP_CACHE_SIZE)
def _remap_plan(geometry: FanGeometry, nearest: bool) -> tuple[_Band, ...]:
    """Fixed-point (CV_16SC2) remap maps for a geometry, cut into horizontal bands.

    Each band of ``_BAND_ROWS`` rows covers only the columns its rows have inside the fan,
    so the wedge's empty corners are never remapped (they keep the fill value): about
    half the pixels of the bounding box, and the slow border path of OpenCV's remap, saved.
    """
    sample, beam = float_maps(geometry)
    outside = np.isnan(sample)
    map_x = np.where(outside, _OUTSIDE, beam).astype(np.float32)  # column of the polar image
    map_y = np.where(outside, _OUTSIDE, sample).astype(np.float32)  # row of the polar image
    bands = []
    for row0 in range(0, geometry.n_rows, _BAND_ROWS):
        row1 = min(row0 + _BAND_ROWS, geometry.n_rows)
        cols = np.flatnonzero(~outside[row0:row1].all(axis=0))
        if cols.size == 0:
            continue
        col0, col1 = int(cols[0]), int(cols[-1]) + 1
        map1, map2 = imaging.fixed_point_maps(
            np.ascontiguousarray(map_x[row0:row1, col0:col1]),
            np.ascontiguousarray(map_y[row0:row1, col0:col1]),
            nearest=nearest,
        )
        bands.append(_Band(row0, row1, col0, col1, map1, map2))
    return tuple(bands)


def polar_to_fan(
    image: np.ndarray,
    geometry: FanGeometry,
    *,
    interpolation: str = "linear",
    fill: float = 0,
) -> np.ndarray:
    """Convert a polar sonar image to its fan image.

    Parameters
    ----------
    image : ndarray, shape (n_samples, n_beams), uint8, uint16 or float32
        Polar image (rows range samples nearest first, columns beams); not modified.
    geometry : FanGeometry
        The fan grid for this image's range samples and beam azimuths.
    interpolation : {"linear", "nearest"}
        Bilinear (fixed-point weights, 1/32 sample) or nearest sample and beam.
    fill : float
        Value of pixels outside the fan.

    Returns
    -------
    ndarray, shape geometry.shape, same dtype as ``image``
        Fan image; pixel positions as in the module docstring.

    Raises
    ------
    GeometryError
        For an image of the wrong shape or dtype, or an unknown interpolation.
    """
    arr = np.asarray(image)
    if arr.shape != geometry.polar_shape:
        raise GeometryError(
            f"image shape {arr.shape} does not match the fan geometry's polar shape "
            f"{geometry.polar_shape} (n_samples, n_beams)"
        )
    if arr.dtype not in FAN_DTYPES:
        raise GeometryError(f"image dtype must be uint8, uint16 or float32, got {arr.dtype}")
    if interpolation not in ("linear", "nearest"):
        raise GeometryError(f"interpolation must be 'linear' or 'nearest', got {interpolation!r}")
    if not math.isfinite(fill):
        raise GeometryError(f"fill must be finite, got {fill!r}")
    nearest = interpolation == "nearest"
    source = np.ascontiguousarray(arr)
    out = np.full(geometry.shape, fill, dtype=arr.dtype)
    for band in _remap_plan(geometry, nearest):
        imaging.remap_fixed_point(
            source,
            band.map1,
            band.map2,
            nearest=nearest,
            fill=float(fill),
            out=out[band.row0 : band.row1, band.col0 : band.col1],
        )
    return out


def frame_to_fan(
    frame: SonarFrame,
    *,
    pixel_size_m: float | None = None,
    width_px: int | None = None,
    include_origin: bool = False,
    interpolation: str = "linear",
    fill: float = 0,
) -> tuple[np.ndarray, FanGeometry]:
    """Fan image of a sonar frame and the geometry that locates its pixels."""
    geometry = FanGeometry.from_frame(
        frame, pixel_size_m=pixel_size_m, width_px=width_px, include_origin=include_origin
    )
    return polar_to_fan(frame.image, geometry, interpolation=interpolation, fill=fill), geometry
