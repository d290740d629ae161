"""The survey area: GeoJSON (WGS84) or local metres in, local plane geometry out.

Inside the planner everything is in a local tangent plane about a stated origin, as
shapely coordinates ``(x, y) = (east_m, north_m)``; NED waypoints are
``(north_m, east_m)``. Geodesy happens only here, through :mod:`perception.geodesy` (pymap3d, WGS84 ellipsoid, the plane
at height 0 at the origin).

Input file (GeoJSON, RFC 7946): a FeatureCollection, a Feature or a bare Polygon.
Polygon features carry ``properties.role``: ``"boundary"`` (exactly one; its interior
rings are holes, i.e. obstacles) or ``"keepout"`` (extra obstacles, which may reach
outside the boundary). A feature without a role is the boundary if it is the first
polygon, else a keep-out. A MultiPolygon is one polygon per part (a boundary must have
one part). Coordinates are ``[lon, lat]`` in degrees, unless the document has the
foreign member ``"local_origin": {"lat_deg": .., "lon_deg": ..}``: then they are
``[east_m, north_m]`` about that origin. An area may cross the antimeridian (longitudes
are taken the short way round); it must lie within :data:`MAX_EXTENT_M` of its origin
and cover at least :data:`MIN_AREA_M2`. Point and line features, and the planner's own
output features (roles ``path``, ``lane``, ``footprint``), are skipped, so a plan's
GeoJSON reads back as its area. The strict reading of the document is
:mod:`planner.survey.area_geojson`.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import shapely
from numpy.typing import NDArray

from perception.geodesy import LocalOrigin
from planner.errors import AreaError
from planner.survey.area_geojson import RawPolygon, local_origin_of, polygons_of


@dataclass(frozen=True)
class SurveyArea:
    """The area to survey in local plane metres ``(east_m, north_m)``.

    Attributes
    ----------
    origin_lat_deg, origin_lon_deg : float
        WGS84 origin of the local plane, degrees.
    boundary : shapely.Polygon
        Outer boundary; its interior rings are holes (obstacles).
    keepouts : tuple of shapely.Polygon
        Extra obstacles.
    """

    origin_lat_deg: float
    origin_lon_deg: float
    boundary: shapely.Polygon
    keepouts: tuple[shapely.Polygon, ...] = ()

    @property
    def outer(self) -> shapely.Polygon:
        """The boundary without its holes."""
        return shapely.Polygon(self.boundary.exterior)

    @property
    def obstacles(self) -> shapely.Geometry:
        """Union of holes and keep-outs (may be empty)."""
        parts = [shapely.Polygon(r) for r in self.boundary.interiors] + list(self.keepouts)
        return shapely.union_all(parts) if parts else shapely.Polygon()

    @property
    def coverage_region(self) -> shapely.Geometry:
        """The ground to cover: the boundary minus holes and keep-outs."""
        return self.outer.difference(self.obstacles) if self.keepouts or self.boundary.interiors \
            else self.boundary

    @property
    def origin(self) -> LocalOrigin:
        """The origin of the local frame (the product's one geodesy, :mod:`perception.geodesy`)."""
        return LocalOrigin(self.origin_lat_deg, self.origin_lon_deg)


#: The local plane is a tangent plane: every vertex must lie within this distance of the
#: origin (a survey area is hundreds of metres; this also catches degrees typed as metres).
MAX_EXTENT_M = 50_000.0
#: Areas smaller than this are a mistake in the coordinates, not a survey, m^2.
MIN_AREA_M2 = 1.0


def _unwrapped_lon(lon_deg: NDArray[np.float64], reference_deg: float) -> NDArray[np.float64]:
    """Longitudes moved by whole turns to within 180 deg of ``reference_deg`` (across the antimeridian)."""
    return reference_deg + (lon_deg - reference_deg + 180.0) % 360.0 - 180.0


def _geographic_origin(rings: list[NDArray[np.float64]]) -> tuple[float, float]:
    """Centre of the bounding box of lon/lat rings, the antimeridian crossed the short way."""
    lon0 = float(rings[0][0, 0])
    lon = _unwrapped_lon(np.concatenate([r[:, 0] for r in rings]), lon0)
    lat = np.concatenate([r[:, 1] for r in rings])
    centre = float((lon.min() + lon.max()) / 2)
    return float((lat.min() + lat.max()) / 2), (centre + 180.0) % 360.0 - 180.0


def _planar(polys: list[RawPolygon], origin: LocalOrigin | None, path: str | None) -> list[list[NDArray[np.float64]]]:
    """Rings in local metres (east, north); geographic rings converted about ``origin``."""
    out = []
    for poly in polys:
        rings = []
        for k, r in enumerate(poly.rings):
            if origin is None:
                rings.append(r)
                continue
            if np.any(np.abs(r[:, 0]) > 180) or np.any(np.abs(r[:, 1]) > 90):
                raise AreaError(f"{poly.where}[{k}]: coordinates out of range for [lon, lat] degrees; for local "
                                "metres add a \"local_origin\" member", path=path)
            n, e = origin.to_local(r[:, 1], _unwrapped_lon(r[:, 0], origin.lon_deg))
            rings.append(np.column_stack([e, n]))
        for k, r in enumerate(rings):
            far = float(np.max(np.hypot(r[:, 0], r[:, 1])))
            if not far <= MAX_EXTENT_M:
                raise AreaError(f"{poly.where}[{k}]: a vertex lies {far / 1000:.0f} km from the origin; a survey "
                                f"area must lie within {MAX_EXTENT_M / 1000:.0f} km of it (check the coordinates)",
                                path=path)
        out.append(rings)
    return out


def area_from_geojson(
    doc: Any, *, path: str | None = None, origin: tuple[float, float] | None = None
) -> SurveyArea:
    """Build a :class:`SurveyArea` from a parsed GeoJSON document.

    Parameters
    ----------
    doc : dict
        The GeoJSON (see the module docstring and :mod:`planner.survey.area_geojson`).
    origin : (lat_deg, lon_deg), optional
        Origin of the local plane for geographic input; default: the centre of the
        boundary's bounding box (across the antimeridian, the short way round). Ignored
        for local input.

    Raises
    ------
    AreaError
        For a malformed document, no or several boundaries, invalid polygons,
        coordinates out of range, an area too small or too far from its origin.
    """
    polys = polygons_of(doc, path=path)
    if not polys:
        raise AreaError("no polygon found", path=path)
    boundary_idx = [i for i, p in enumerate(polys) if p.role == "boundary"]
    if len(boundary_idx) > 1:
        raise AreaError("more than one polygon has role 'boundary'; survey one area at a time", path=path)
    b_idx = boundary_idx[0] if boundary_idx else 0
    if polys[b_idx].role == "keepout":
        raise AreaError("every polygon is a keep-out; give the survey area role \"boundary\"", path=path)
    local = local_origin_of(doc, path=path)
    if local is not None:
        lat0, lon0 = local
        planar = _planar(polys, None, path)
    else:
        if origin is None:
            lat0, lon0 = _geographic_origin(list(polys[b_idx].rings[:1]))
        else:
            lat0, lon0 = origin
        if not (-90 <= lat0 <= 90 and -180 <= lon0 <= 180):
            raise AreaError(f"origin ({lat0}, {lon0}) out of range", path=path)
        planar = _planar(polys, LocalOrigin(lat0, lon0), path)
    polygons = []
    for i, rings in enumerate(planar):
        poly = shapely.Polygon(rings[0], rings[1:])
        if not poly.is_valid or poly.area <= 0:
            reason = shapely.is_valid_reason(poly)
            raise AreaError(f"{polys[i].where}: polygon {i} is not a valid polygon ({reason})", path=path)
        polygons.append(shapely.orient_polygons(poly))
    boundary = polygons[b_idx]
    keepouts = tuple(p for i, p in enumerate(polygons) if i != b_idx)
    remaining = boundary.area - sum(k.intersection(boundary).area for k in keepouts)
    if remaining <= 0 or math.isclose(remaining, 0.0, abs_tol=1e-6):
        raise AreaError("keep-outs cover the whole boundary; nothing to survey", path=path)
    if boundary.area < MIN_AREA_M2:
        raise AreaError(f"{polys[b_idx].where}: the area is {boundary.area:.3g} m^2, smaller than {MIN_AREA_M2:g} m^2; "
                        "check the coordinates (degrees, [lon, lat] order)", path=path)
    return SurveyArea(lat0, lon0, boundary, keepouts)


def load_area(path: str | Path, *, origin: tuple[float, float] | None = None) -> SurveyArea:
    """Read a GeoJSON area file (see :func:`area_from_geojson`).

    Raises
    ------
    AreaError
        Naming the file, for an unreadable file, text that is not UTF-8 JSON, or any
        problem :func:`area_from_geojson` finds.
    """
    p = Path(path)
    try:
        doc = json.loads(p.read_bytes().decode("utf-8"))
    except OSError as exc:
        raise AreaError(f"cannot read area file: {exc.strerror or exc}", path=str(p)) from exc
    except UnicodeDecodeError as exc:
        raise AreaError(f"not UTF-8 text ({exc.reason} at byte {exc.start})", path=str(p)) from None
    except json.JSONDecodeError as exc:
        raise AreaError(f"not valid JSON: {exc}", path=str(p)) from exc
    except RecursionError:
        raise AreaError("not valid JSON: nested too deeply", path=str(p)) from None
    return area_from_geojson(doc, path=str(p), origin=origin)


def area_to_geojson(area: SurveyArea) -> dict[str, Any]:
    """The area as a WGS84 GeoJSON FeatureCollection with roles (round-trips)."""

    def ring(coords: Any) -> list[list[float]]:
        xy = np.asarray(coords)
        lat, lon = area.origin.to_lat_lon(xy[:, 1], xy[:, 0])
        return [[round(float(a), 9), round(float(b), 9)] for a, b in zip(lon, lat, strict=True)]

    def poly(p: shapely.Polygon) -> dict[str, Any]:
        return {"type": "Polygon",
                "coordinates": [ring(p.exterior.coords)] + [ring(r.coords) for r in p.interiors]}

    feats = [{"type": "Feature", "properties": {"role": "boundary"}, "geometry": poly(area.boundary)}]
    feats += [{"type": "Feature", "properties": {"role": "keepout"}, "geometry": poly(k)}
              for k in area.keepouts]
    return {"type": "FeatureCollection", "features": feats}
