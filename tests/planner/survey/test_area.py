"""Area input: GeoJSON roles, holes, keep-outs, local metres, geodesy round trips, errors."""

from __future__ import annotations

import json
from importlib import resources
from pathlib import Path

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

from perception.geodesy import LocalOrigin
from planner.errors import AreaError
from planner.survey.area import (
    SurveyArea,
    area_from_geojson,
    area_to_geojson,
    load_area,
)


def _square(cx: float, cy: float, half: float) -> list[list[float]]:
    return [[cx - half, cy - half], [cx + half, cy - half], [cx + half, cy + half],
            [cx - half, cy + half], [cx - half, cy - half]]


def _local_doc() -> dict:
    return {
        "type": "FeatureCollection",
        "local_origin": {"lat_deg": 43.3, "lon_deg": 5.36},
        "features": [
            {"type": "Feature", "properties": {"role": "boundary"},
             "geometry": {"type": "Polygon", "coordinates": [_square(0, 0, 50), _square(10, 10, 5)]}},
            {"type": "Feature", "properties": {"role": "keepout"},
             "geometry": {"type": "Polygon", "coordinates": [_square(50, 0, 10)]}},
            {"type": "Feature", "properties": {"name": "marker"},
             "geometry": {"type": "Point", "coordinates": [0, 0]}},
        ],
    }


def test_local_metres_with_hole_and_keepout() -> None:
    area = area_from_geojson(_local_doc())
    assert (area.origin_lat_deg, area.origin_lon_deg) == (43.3, 5.36)
    assert area.outer.area == pytest.approx(100 * 100)
    assert len(area.boundary.interiors) == 1
    # Ground to cover: square minus hole minus the part of the keep-out inside.
    assert area.coverage_region.area == pytest.approx(100 * 100 - 10 * 10 - 10 * 20)
    assert area.obstacles.area == pytest.approx(100 + 400)


def test_shipped_example_area_loads() -> None:
    path = resources.files("planner").joinpath("data", "example_area.geojson")
    area = load_area(Path(str(path)))
    assert len(area.boundary.interiors) == 1 and len(area.keepouts) == 1
    assert 10_000 < area.coverage_region.area < 30_000


def test_geojson_round_trip_keeps_the_polygons() -> None:
    area = area_from_geojson(_local_doc())
    back = area_from_geojson(area_to_geojson(area), origin=(area.origin_lat_deg, area.origin_lon_deg))
    assert shapely.hausdorff_distance(back.boundary, area.boundary) < 1e-3
    assert shapely.hausdorff_distance(back.keepouts[0], area.keepouts[0]) < 1e-3


@given(
    radii=st.lists(st.floats(20.0, 400.0), min_size=3, max_size=12),
    lat0=st.floats(-70, 70),
    lon0=st.floats(-179, 179),
)
@settings(max_examples=40, deadline=None)
def test_random_areas_round_trip_through_wgs84_geojson(radii: list[float], lat0: float,
                                                       lon0: float) -> None:
    ang = np.arange(len(radii)) * 2 * np.pi / len(radii)
    poly = shapely.Polygon(np.column_stack([np.cos(ang) * radii, np.sin(ang) * radii]))
    area = SurveyArea(lat0, lon0, shapely.orient_polygons(poly))
    doc = json.loads(json.dumps(area_to_geojson(area)))
    back = area_from_geojson(doc, origin=(lat0, lon0))
    assert shapely.hausdorff_distance(back.boundary, area.boundary) < 2e-3  # metres
    # Coordinates are written to 1e-9 deg (0.1 mm): the area moves by perimeter x 0.1 mm.
    assert back.coverage_region.area == pytest.approx(area.coverage_region.area, abs=poly.length * 1e-4)


@given(e=st.floats(-5000, 5000), n=st.floats(-5000, 5000), lat0=st.floats(-70, 70),
       lon0=st.floats(-179, 179))
@settings(max_examples=60, deadline=None)
def test_local_geodetic_round_trip(e: float, n: float, lat0: float, lon0: float) -> None:
    origin = LocalOrigin(lat0, lon0)
    lat, lon = origin.to_lat_lon([n], [e])
    n2, e2 = origin.to_local(lat, lon)
    # The tangent plane curves away from the ellipsoid: millimetres over 5 km.
    assert abs(e2[0] - e) < 5e-3 and abs(n2[0] - n) < 5e-3


def test_a_north_step_is_a_latitude_step() -> None:
    lat, lon = LocalOrigin(0.0, 0.0).to_lat_lon([1000.0], [0.0])
    # One arc-minute of latitude at the equator is ~1842.9 m.
    assert (lat[0] * 60) * 1842.9 == pytest.approx(1000.0, rel=1e-3)
    assert lon[0] == pytest.approx(0.0, abs=1e-12)


@pytest.mark.parametrize(
    ("doc", "message"),
    [
        ({"type": "FeatureCollection", "features": []}, "no polygon"),
        ({"coordinates": []}, "not a GeoJSON"),
        ({"type": "Polygon", "coordinates": [[[0, 0], [1e-3, 1e-3], [1e-3, 0], [0, 1e-3], [0, 0]]]},
         "not a valid polygon"),
        ({"type": "Polygon", "coordinates": [[[0, 0], [1000, 0], [1000, 10], [0, 0]]]},
         "out of range"),
        ({"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [0, 0]]]}, "at least 4"),
        ({"type": "GeometryCollection", "geometries": []}, "unsupported"),
    ],
)
def test_bad_documents_are_refused(doc: dict, message: str) -> None:
    with pytest.raises(AreaError, match=message):
        area_from_geojson(doc, path="a.geojson")


def test_two_boundaries_and_unknown_role_are_refused() -> None:
    doc = _local_doc()
    doc["features"][1]["properties"]["role"] = "boundary"
    with pytest.raises(AreaError, match="more than one"):
        area_from_geojson(doc)
    doc = _local_doc()
    doc["features"][1]["properties"]["role"] = "mooring"
    with pytest.raises(AreaError, match="unknown role"):
        area_from_geojson(doc)


def test_file_errors(tmp_path: Path) -> None:
    with pytest.raises(AreaError, match="cannot read"):
        load_area(tmp_path / "missing.geojson")
    bad = tmp_path / "bad.geojson"
    bad.write_text("{", encoding="utf-8")
    with pytest.raises(AreaError, match="not valid JSON"):
        load_area(bad)
    good = tmp_path / "good.geojson"
    good.write_text(json.dumps(_local_doc()), encoding="utf-8")
    assert isinstance(load_area(good), SurveyArea)
    assert np.isfinite(load_area(good).coverage_region.area)
