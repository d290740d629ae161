"""The polygons of a survey-area GeoJSON document, checked strictly, with where each came from.

:func:`polygons_of` walks a parsed document (a FeatureCollection, a Feature or a bare
Polygon/MultiPolygon) and returns every area polygon as a :class:`RawPolygon`: its role,
its rings as float arrays, and the JSON path of its coordinates
(``features[2].geometry.coordinates``) for messages. Anything that is not what RFC 7946
says (a position that is not two or three numbers, a coordinate given as a string or
``true``, a ring that is not closed or has fewer than four positions, a role that is not
a string) raises :class:`~planner.errors.AreaError` naming the file and that path.

A MultiPolygon is one polygon per part. Its parts share the feature's role: a keep-out
MultiPolygon is several keep-outs; a boundary (or role-less) MultiPolygon of more than
one part is refused, since a survey covers one area (its second part must not silently
become a keep-out).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from planner.errors import AreaError

#: Features the reader skips: the planner's own outputs and non-area geometries.
IGNORED_ROLES = ("path", "lane", "footprint")
IGNORED_GEOMETRIES = ("Point", "MultiPoint", "LineString", "MultiLineString")
AREA_ROLES = ("boundary", "keepout")


@dataclass(frozen=True)
class RawPolygon:
    """One polygon as the file gives it.

    Attributes
    ----------
    role : str or None
        ``"boundary"``, ``"keepout"`` or None (not said).
    rings : tuple of ndarray, shape (n, 2), float64
        Exterior ring first, then holes; ``(x, y)`` as written (lon, lat or east, north).
    where : str
        JSON path of its coordinates, for messages.
    """

    role: str | None
    rings: tuple[NDArray[np.float64], ...]
    where: str


def _fail(path: str | None, where: str, message: str) -> AreaError:
    return AreaError(f"{where}: {message}" if where else message, path=path)


def _at(where: str, key: str) -> str:
    return f"{where}.{key}" if where else key


def _coordinate(value: Any) -> float | None:
    if isinstance(value, bool) or not isinstance(value, int | float):
        return None
    v = float(value)
    return v if math.isfinite(v) else None


def _ring(value: Any, where: str, path: str | None) -> NDArray[np.float64]:
    if not isinstance(value, list):
        raise _fail(path, where, f"a ring must be a list of positions, got {type(value).__name__}")
    if len(value) < 4:
        raise _fail(path, where, f"a ring needs at least 4 positions [x, y] (closed), got {len(value)}")
    out = np.empty((len(value), 2))
    for i, position in enumerate(value):
        if not isinstance(position, list) or not 2 <= len(position) <= 3:
            raise _fail(path, f"{where}[{i}]", f"a position must be [x, y] (or [x, y, z]), got {position!r:.60}")
        xy = [_coordinate(c) for c in position[:2]]
        if xy[0] is None or xy[1] is None or (len(position) == 3 and _coordinate(position[2]) is None):
            raise _fail(path, f"{where}[{i}]", f"coordinates must be finite numbers (not text), got {position!r:.60}")
        out[i] = xy
    if not np.array_equal(out[0], out[-1]):
        raise _fail(path, where, "the ring is not closed (its last position must repeat its first)")
    return out


def _rings(value: Any, where: str, path: str | None) -> tuple[NDArray[np.float64], ...]:
    if not isinstance(value, list) or not value:
        raise _fail(path, where, "a Polygon's coordinates must be a non-empty list of rings")
    return tuple(_ring(r, f"{where}[{k}]", path) for k, r in enumerate(value))


def _geometry(geom: Any, role: str | None, where: str, path: str | None) -> list[RawPolygon]:
    if not isinstance(geom, dict):
        raise _fail(path, where, f"must be a GeoJSON geometry object, got {type(geom).__name__}")
    kind = geom.get("type")
    if kind in IGNORED_GEOMETRIES:
        return []
    coords = geom.get("coordinates")
    if kind == "Polygon":
        return [RawPolygon(role, _rings(coords, _at(where, "coordinates"), path), _at(where, "coordinates"))]
    if kind == "MultiPolygon":
        if not isinstance(coords, list) or not coords:
            raise _fail(path, _at(where, "coordinates"),
                        "a MultiPolygon's coordinates must be a non-empty list of polygons")
        if len(coords) > 1 and role != "keepout":
            raise _fail(path, where, f"a MultiPolygon of {len(coords)} parts as the survey area: survey one polygon at "
                        "a time, or give the other parts their own features with role \"keepout\"")
        return [RawPolygon(role, _rings(p, _at(where, f"coordinates[{k}]"), path), _at(where, f"coordinates[{k}]"))
                for k, p in enumerate(coords)]
    raise _fail(path, where, f"unsupported GeoJSON type {kind!r} (need Polygon features)")


def _role(props: Any, where: str, path: str | None) -> str | None:
    if props is None:
        return None
    if not isinstance(props, dict):
        raise _fail(path, _at(where, "properties"), "must be an object or null")
    role = props.get("role")
    if role is None or (isinstance(role, str) and role in (*AREA_ROLES, *IGNORED_ROLES)):
        return role
    raise _fail(path, _at(where, "properties.role"), f"unknown role {role!r:.40} (use 'boundary' or 'keepout')")


def polygons_of(doc: Any, *, path: str | None = None) -> list[RawPolygon]:
    """Every area polygon of a parsed GeoJSON document, in file order (see the module docstring)."""
    if not isinstance(doc, dict) or "type" not in doc:
        raise AreaError("not a GeoJSON object (no 'type')", path=path)
    kind = doc["type"]
    if kind == "FeatureCollection":
        features = doc.get("features")
        if not isinstance(features, list):
            raise AreaError("FeatureCollection without a 'features' list", path=path)
        out: list[RawPolygon] = []
        for i, feature in enumerate(features):
            if not isinstance(feature, dict) or feature.get("type") != "Feature":
                raise _fail(path, f"features[{i}]", "is not a Feature")
            out += _feature(feature, f"features[{i}]", path)
        return out
    if kind == "Feature":
        return _feature(doc, "", path)
    return _geometry(doc, None, "", path)


def _feature(feature: dict[str, Any], where: str, path: str | None) -> list[RawPolygon]:
    geom = feature.get("geometry")
    if not isinstance(geom, dict):
        raise _fail(path, where, "Feature without a geometry")
    if geom.get("type") in IGNORED_GEOMETRIES:
        return []
    role = _role(feature.get("properties"), where, path)
    if role in IGNORED_ROLES:
        return []
    return _geometry(geom, role, _at(where, "geometry"), path)


def local_origin_of(doc: Any, *, path: str | None = None) -> tuple[float, float] | None:
    """The document's ``local_origin`` (lat_deg, lon_deg), or None when it has none."""
    local = doc.get("local_origin") if isinstance(doc, dict) else None
    if local is None:
        return None
    if not isinstance(local, dict) or set(local) != {"lat_deg", "lon_deg"}:
        raise _fail(path, "local_origin", 'must be {"lat_deg": .., "lon_deg": ..}')
    lat, lon = _coordinate(local["lat_deg"]), _coordinate(local["lon_deg"])
    if lat is None or not -90.0 <= lat <= 90.0:
        raise _fail(path, "local_origin.lat_deg", f"must be a number within -90..90, got {local['lat_deg']!r:.40}")
    if lon is None or not -180.0 <= lon <= 180.0:
        raise _fail(path, "local_origin.lon_deg", f"must be a number within -180..180, got {local['lon_deg']!r:.40}")
    return lat, lon
