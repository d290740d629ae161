"""The heights layer of the 2.5D map: targets with their heights, as vectors and a raster."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from perception import imaging
from perception.geodesy import LocalOrigin


@dataclass(frozen=True)
class MappedTarget:
    """A target placed on the seabed map.

    Attributes
    ----------
    target_id : int
    north_m, east_m : float
        Centre of the target in the survey's local NED frame, m.
    height_m, height_std_m : float
        Estimated height above the seabed and its 1-sigma, m (NaN when not solved).
    frames_used : int
        Frames that entered the height solution.
    footprint_ne_m : tuple of (north_m, east_m) pairs
        Outline on the seabed (empty when unknown).
    properties : dict
        Extra properties carried into the GeoJSON.
    """

    target_id: int
    north_m: float
    east_m: float
    height_m: float
    height_std_m: float
    frames_used: int
    footprint_ne_m: tuple[tuple[float, float], ...] = ()
    properties: dict[str, Any] = field(default_factory=dict, compare=False)


def _num(value: float, digits: int) -> float | None:
    return None if not math.isfinite(value) else round(float(value), digits)


def targets_feature_collection(
    targets: Sequence[MappedTarget], origin: LocalOrigin, *, footprints: bool = False
) -> dict[str, Any]:
    """RFC 7946 GeoJSON of the targets: points at their centres, or their footprints.

    Coordinates are [longitude, latitude] in WGS84 degrees with 8 decimals (about 1 mm).
    """
    features = []
    for t in targets:
        props: dict[str, Any] = {
            "id": t.target_id,
            "height_m": _num(t.height_m, 4),
            "height_std_m": _num(t.height_std_m, 4),
            "frames_used": int(t.frames_used),
            "north_m": round(t.north_m, 3),
            "east_m": round(t.east_m, 3),
        }
        props.update(t.properties)
        if footprints:
            if len(t.footprint_ne_m) < 3:
                continue
            ring = list(t.footprint_ne_m) + [t.footprint_ne_m[0]]
            lat, lon = origin.to_lat_lon([p[0] for p in ring], [p[1] for p in ring])
            coords = [[round(float(x), 8), round(float(y), 8)] for x, y in zip(lon, lat, strict=True)]
            if _signed_area(coords) < 0:  # RFC 7946: exterior rings counter-clockwise
                coords.reverse()
            geometry: dict[str, Any] = {"type": "Polygon", "coordinates": [coords]}
        else:
            lat, lon = origin.to_lat_lon(t.north_m, t.east_m)
            geometry = {"type": "Point", "coordinates": [round(float(lon), 8), round(float(lat), 8)]}
        features.append({"type": "Feature", "geometry": geometry, "properties": props})
    return {"type": "FeatureCollection", "features": features}


def _signed_area(coords: list[list[float]]) -> float:
    xs = np.array([c[0] for c in coords])
    ys = np.array([c[1] for c in coords])
    return float(0.5 * np.sum(xs[:-1] * ys[1:] - xs[1:] * ys[:-1]))


def height_raster(
    targets: Sequence[MappedTarget],
    *,
    row0: int,
    col0: int,
    shape: tuple[int, int],
    resolution_m: float,
) -> np.ndarray:
    """Target heights rasterised over their footprints, NaN elsewhere.

    Parameters
    ----------
    row0, col0 : int
        Global mosaic cell of element [0, 0] (rows increase NORTH, as in the mosaic).
    shape : (int, int)
        (n_rows, n_cols) of the raster.
    resolution_m : float
        Cell size, m.

    Returns
    -------
    ndarray, float32, shape ``shape``
        Height in m where a solved target's footprint (or, lacking one, a disc of one
        cell around its centre) lies. Where footprints overlap, the taller wins.
    """
    raster = np.full(shape, np.nan, dtype=np.float32)
    # One mask, drawn on and cleared again around each target only: a target costs its own
    # few cells, not a pass over the whole map.
    mask = np.zeros(shape, dtype=np.uint8)
    for t in sorted(targets, key=lambda t: t.height_m if math.isfinite(t.height_m) else -1):
        if not math.isfinite(t.height_m):
            continue
        if len(t.footprint_ne_m) >= 3:
            pts = np.array(
                [[(e / resolution_m - 0.5 - col0), (n / resolution_m - 0.5 - row0)] for n, e in t.footprint_ne_m]
            )
            imaging.fill_polygon(mask, pts, 1)
            box = _box(pts[:, 0].min(), pts[:, 0].max(), pts[:, 1].min(), pts[:, 1].max(), shape)
        else:
            centre = (
                int(round(t.east_m / resolution_m - 0.5 - col0)),
                int(round(t.north_m / resolution_m - 0.5 - row0)),
            )
            imaging.fill_disc(mask, centre, 1, 1)
            box = _box(centre[0], centre[0], centre[1], centre[1], shape)
        if box is None:
            continue
        drawn = mask[box]
        raster[box][drawn > 0] = t.height_m
        drawn[...] = 0
    return raster


#: Cells beyond a shape's corner points its drawing may reach (rounding to 1/16 cell, the
#: disc's radius of 1, the 8-connected edges), with room to spare.
_DRAW_MARGIN = 3


def _box(c_min: float, c_max: float, r_min: float, r_max: float,
         shape: tuple[int, int]) -> tuple[slice, slice] | None:
    """The cells of ``shape`` a shape drawn within those columns and rows can touch; None off the map."""
    if not all(math.isfinite(v) for v in (c_min, c_max, r_min, r_max)):
        return (slice(0, shape[0]), slice(0, shape[1]))
    c0 = max(0, math.floor(c_min) - _DRAW_MARGIN)
    c1 = min(shape[1], math.ceil(c_max) + _DRAW_MARGIN + 1)
    r0 = max(0, math.floor(r_min) - _DRAW_MARGIN)
    r1 = min(shape[0], math.ceil(r_max) + _DRAW_MARGIN + 1)
    if c1 <= c0 or r1 <= r0:
        return None
    return (slice(r0, r1), slice(c0, c1))
