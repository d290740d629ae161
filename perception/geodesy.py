"""Georeference of the survey's local NED frame: WGS84 at the edges, metres inside.

The local frame is the tangent plane at a stated origin (pymap3d's NED). For rasters the
same plane is written as a transverse Mercator projection centred on the origin (scale 1,
no false easting or northing), which GDAL, QGIS and rasterio read from GeoTIFF keys or a
``.prj``: over a survey of a few kilometres the two agree to micrometres.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pymap3d
from numpy.typing import ArrayLike


@dataclass(frozen=True)
class LocalOrigin:
    """Origin of the survey's local NED frame (WGS84 latitude and longitude, degrees)."""

    lat_deg: float
    lon_deg: float

    def __post_init__(self) -> None:
        if not (math.isfinite(self.lat_deg) and -90 < self.lat_deg < 90):
            raise ValueError(f"origin latitude must be in (-90, 90) deg, got {self.lat_deg!r}")
        if not (math.isfinite(self.lon_deg) and -180 <= self.lon_deg <= 180):
            raise ValueError(f"origin longitude must be in [-180, 180] deg, got {self.lon_deg!r}")

    def to_lat_lon(self, north_m: ArrayLike, east_m: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """WGS84 (lat, lon) in degrees of local points on the origin's ellipsoid height."""
        n = np.asarray(north_m, dtype=np.float64)
        e = np.asarray(east_m, dtype=np.float64)
        lat, lon, _ = pymap3d.ned2geodetic(n, e, np.zeros_like(n), self.lat_deg, self.lon_deg, 0.0)
        return np.asarray(lat), np.asarray(lon)

    def to_local(self, lat_deg: ArrayLike, lon_deg: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """Local (north, east) in m of WGS84 points (degrees)."""
        lat = np.asarray(lat_deg, dtype=np.float64)
        lon = np.asarray(lon_deg, dtype=np.float64)
        n, e, _ = pymap3d.geodetic2ned(lat, lon, np.zeros_like(lat), self.lat_deg, self.lon_deg, 0.0)
        return np.asarray(n), np.asarray(e)

    def proj4(self) -> str:
        """PROJ string of the local transverse Mercator plane."""
        return (
            f"+proj=tmerc +lat_0={self.lat_deg:.10f} +lon_0={self.lon_deg:.10f} +k=1 "
            "+x_0=0 +y_0=0 +datum=WGS84 +units=m +no_defs"
        )

    def wkt(self) -> str:
        """ESRI-style WKT of the local transverse Mercator plane (for a ``.prj``)."""
        return (
            'PROJCS["shadowsurvey local TM",GEOGCS["GCS_WGS_1984",DATUM["D_WGS_1984",'
            'SPHEROID["WGS_1984",6378137.0,298.257223563]],PRIMEM["Greenwich",0.0],'
            'UNIT["Degree",0.0174532925199433]],PROJECTION["Transverse_Mercator"],'
            'PARAMETER["False_Easting",0.0],PARAMETER["False_Northing",0.0],'
            f'PARAMETER["Central_Meridian",{self.lon_deg:.10f}],PARAMETER["Scale_Factor",1.0],'
            f'PARAMETER["Latitude_Of_Origin",{self.lat_deg:.10f}],UNIT["Meter",1.0]]'
        )


# GeoTIFF key ids (OGC GeoTIFF 1.1).
_GT_MODEL_TYPE = 1024
_GT_RASTER_TYPE = 1025
_GT_CITATION = 1026
_GEOGRAPHIC_TYPE = 2048
_PROJECTED_CS_TYPE = 3072
_PROJECTION = 3074
_PROJ_COORD_TRANS = 3075
_PROJ_LINEAR_UNITS = 3076
_PROJ_NAT_ORIGIN_LONG = 3080
_PROJ_NAT_ORIGIN_LAT = 3081
_PROJ_FALSE_EASTING = 3082
_PROJ_FALSE_NORTHING = 3083
_PROJ_SCALE_AT_NAT_ORIGIN = 3092
_USER_DEFINED = 32767
_TAG_DOUBLE_PARAMS = 34736
_TAG_ASCII_PARAMS = 34737


def geotiff_tags(
    origin: LocalOrigin, *, west_m: float, north_m: float, pixel_m: float
) -> list[tuple[int, str, int, object, bool]]:
    """tifffile ``extratags`` georeferencing a north-up raster in the local TM plane.

    Parameters
    ----------
    origin : LocalOrigin
    west_m, north_m : float
        Local east and north of the raster's upper-left CORNER, m.
    pixel_m : float
        Square pixel size, m.
    """
    citation = "shadowsurvey local TM|"
    doubles = [origin.lon_deg, origin.lat_deg, 0.0, 0.0, 1.0]
    keys = [
        (_GT_MODEL_TYPE, 0, 1, 1),  # projected
        (_GT_RASTER_TYPE, 0, 1, 1),  # pixel is area
        (_GT_CITATION, _TAG_ASCII_PARAMS, len(citation), 0),
        (_GEOGRAPHIC_TYPE, 0, 1, 4326),
        (_PROJECTED_CS_TYPE, 0, 1, _USER_DEFINED),
        (_PROJECTION, 0, 1, _USER_DEFINED),
        (_PROJ_COORD_TRANS, 0, 1, 1),  # transverse Mercator
        (_PROJ_LINEAR_UNITS, 0, 1, 9001),  # metre
        (_PROJ_NAT_ORIGIN_LONG, _TAG_DOUBLE_PARAMS, 1, 0),
        (_PROJ_NAT_ORIGIN_LAT, _TAG_DOUBLE_PARAMS, 1, 1),
        (_PROJ_FALSE_EASTING, _TAG_DOUBLE_PARAMS, 1, 2),
        (_PROJ_FALSE_NORTHING, _TAG_DOUBLE_PARAMS, 1, 3),
        (_PROJ_SCALE_AT_NAT_ORIGIN, _TAG_DOUBLE_PARAMS, 1, 4),
    ]
    directory = [1, 1, 0, len(keys)]
    for key in sorted(keys):
        directory.extend(key)
    return [
        (33550, "d", 3, (pixel_m, pixel_m, 0.0), True),  # ModelPixelScale
        (33922, "d", 6, (0.0, 0.0, 0.0, west_m, north_m, 0.0), True),  # ModelTiepoint
        (34735, "H", len(directory), tuple(directory), True),  # GeoKeyDirectory
        (_TAG_DOUBLE_PARAMS, "d", len(doubles), tuple(doubles), True),
        (_TAG_ASCII_PARAMS, "s", 0, citation, True),
        (42113, "s", 0, "nan", True),  # GDAL_NODATA
    ]
