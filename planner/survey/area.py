"""The survey area: GeoJSON (WGS84) or local metres in, local plane geometry out.

Inside the planner everything is in a local tangent plane about a stated origin, as
shapely coordinates ``(x, y) = (east_m, north_m)``; NED waypoints are
``(north_m, east_m)``. Geodesy happens only here, through :mod:`perception.geodesy` (pymap3d, WGS84 ellipsoid, the plane
at height 0 at the origin).

Input file (GeoJSON, RFC 7946): a FeatureCollection, a Feature or a bare Polygon.
Polygon features carry ``properties.role``: ``"boundary"`` (exactly one; its interior
rings are holes, i.e. obstacles) or ``"keepout"`` (extra obstacles, which may reach
outside the boundary). A feature without a role is the boundary if it is the first
polygon, else a keep-out. Coordinates are ``[lon, lat]`` in degrees, unless the document
has the foreign member ``"local_origin": {"lat_deg": .., "lon_deg": ..}``: then they are
``[east_m, north_m]`` about that origin. Point and line features, and the planner's own
output features (roles ``path``, ``lane``, ``footprint``), are skipped, so a plan's
GeoJSON reads back as its area.
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


#: Features the reader skips: the planner's own outputs and non-area geometries.
IGNORED_ROLES = ("path", "lane", "footprint")
IGNORED_GEOMETRIES = ("Point", "MultiPoint", "LineString", "MultiLineString")


def _polygons(doc: Any, path: str | None) -> list[tuple[str | None, list]]:
    """(role, rings) of every polygon in a GeoJSON document, in file order."""
    if not isinstance(doc, dict) or "type" not in doc:
        raise AreaError("not a GeoJSON object (no 'type')", path=path)
    kind = doc["type"]
    if kind == "FeatureCollection":
        feats = doc.get("features")
        if not isinstance(feats, list):
            raise AreaError("FeatureCollection without a 'features' list", path=path)
        out: list[tuple[str | None, list]] = []
        for i, f in enumerate(feats):
            if not isinstance(f, dict) or f.get("type") != "Feature":
                raise AreaError(f"features[{i}] is not a Feature", path=path)
            out += _polygons(f, path)
        return out
    if kind == "Feature":
        props = doc.get("properties") or {}
        role = props.get("role") if isinstance(props, dict) else None
        geom = doc.get("geometry")
        if not isinstance(geom, dict):
            raise AreaError("Feature without a geometry", path=path)
        if role in IGNORED_ROLES or geom.get("type") in IGNORED_GEOMETRIES:
            return []
        return [(role, rings) for _, rings in _polygons(geom, path)]
    if kind == "Polygon":
        rings = doc.get("coordinates")
        if not isinstance(rings, list) or not rings:
            raise AreaError("Polygon without coordinates", path=path)
        return [(None, rings)]
    if kind == "MultiPolygon":
        polys = doc.get("coordinates") or []
        return [(None, rings) for rings in polys]
    raise AreaError(f"unsupported GeoJSON type {kind!r} (need Polygon features)", path=path)


def _ring_array(ring: Any, path: str | None) -> NDArray[np.float64]:
    try:
        arr = np.asarray(ring, dtype=float)
    except (TypeError, ValueError) as exc:
        raise AreaError(f"a ring holds non-numeric coordinates: {exc}", path=path) from exc
    if arr.ndim != 2 or arr.shape[1] < 2 or arr.shape[0] < 4:
        raise AreaError("every ring needs at least 4 positions [x, y] (closed)", path=path)
    if not np.all(np.isfinite(arr[:, :2])):
        raise AreaError("a ring holds non-finite coordinates", path=path)
    return arr[:, :2]


def area_from_geojson(
    doc: Any, *, path: str | None = None, origin: tuple[float, float] | None = None
) -> SurveyArea:
    """Build a :class:`SurveyArea` from a parsed GeoJSON document.

    Parameters
    ----------
    doc : dict
        The GeoJSON (see the module docstring).
    origin : (lat_deg, lon_deg), optional
        Origin of the local plane for geographic input; default: the centre of the
        boundary's bounding box. Ignored (and must agree) for local input.

    Raises
    ------
    AreaError
        For a malformed document, no or several boundaries, invalid polygons,
        coordinates out of range.
    """
    polys = _polygons(doc, path)
    if not polys:
        raise AreaError("no polygon found", path=path)
    local = doc.get("local_origin") if isinstance(doc, dict) else None
    boundary_idx = [i for i, (r, _) in enumerate(polys) if r == "boundary"]
    if not boundary_idx:
        boundary_idx = [0]
    if len(boundary_idx) > 1:
        raise AreaError("more than one polygon has role 'boundary'; survey one area at a time",
                        path=path)
    for role, _ in polys:
        if role not in (None, "boundary", "keepout"):
            raise AreaError(f"unknown role {role!r} (use 'boundary' or 'keepout')", path=path)
    rings_xy: list[list[NDArray[np.float64]]] = [[_ring_array(r, path) for r in rings]
                                                 for _, rings in polys]
    if local is not None:
        if not isinstance(local, dict) or not {"lat_deg", "lon_deg"} <= set(local):
            raise AreaError("local_origin must be {\"lat_deg\": .., \"lon_deg\": ..}", path=path)
        lat0, lon0 = float(local["lat_deg"]), float(local["lon_deg"])
        planar = rings_xy
    else:
        for rings in rings_xy:
            for r in rings:
                if np.any(np.abs(r[:, 0]) > 180) or np.any(np.abs(r[:, 1]) > 90):
                    raise AreaError("coordinates out of range for [lon, lat] degrees; for local "
                                    "metres add a \"local_origin\" member", path=path)
        b = rings_xy[boundary_idx[0]][0]
        if origin is None:
            lat0 = float((b[:, 1].min() + b[:, 1].max()) / 2)
            lon0 = float((b[:, 0].min() + b[:, 0].max()) / 2)
        else:
            lat0, lon0 = origin
        planar = []
        for rings in rings_xy:
            conv = []
            for r in rings:
                n, e = LocalOrigin(lat0, lon0).to_local(r[:, 1], r[:, 0])
                conv.append(np.column_stack([e, n]))
            planar.append(conv)
    if not (-90 <= lat0 <= 90 and -180 <= lon0 <= 180):
        raise AreaError(f"origin ({lat0}, {lon0}) out of range", path=path)
    polygons = []
    for i, rings in enumerate(planar):
        poly = shapely.Polygon(rings[0], rings[1:])
        if not poly.is_valid or poly.area <= 0:
            reason = shapely.is_valid_reason(poly)
            raise AreaError(f"polygon {i} is not a valid polygon ({reason})", path=path)
        polygons.append(shapely.orient_polygons(poly))
    boundary = polygons[boundary_idx[0]]
    keepouts = tuple(p for i, p in enumerate(polygons) if i != boundary_idx[0])
    remaining = boundary.area - sum(k.intersection(boundary).area for k in keepouts)
    if remaining <= 0 or math.isclose(remaining, 0.0, abs_tol=1e-6):
        raise AreaError("keep-outs cover the whole boundary; nothing to survey", path=path)
    return SurveyArea(lat0, lon0, boundary, keepouts)


def load_area(path: str | Path, *, origin: tuple[float, float] | None = None) -> SurveyArea:
    """Read a GeoJSON area file (see :func:`area_from_geojson`)."""
    p = Path(path)
    try:
        doc = json.loads(p.read_text(encoding="utf-8"))
    except OSError as exc:
        raise AreaError(f"cannot read area file: {exc.strerror}", path=str(p)) from exc
    except json.JSONDecodeError as exc:
        raise AreaError(f"not valid JSON: {exc}", path=str(p)) from exc
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
