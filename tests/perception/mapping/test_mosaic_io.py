"""The 2.5D map files: GeoTIFF (read back by GDAL through rasterio), PNG + world file,
GeoJSON, the heights raster and atomic writes."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import rasterio
from hypothesis import given, settings
from hypothesis import strategies as st
from rasterio.warp import transform as warp_transform

from perception.geodesy import LocalOrigin
from perception.mapping.builder import MosaicBuilder
from perception.mapping.heights_layer import MappedTarget, height_raster, targets_feature_collection
from perception.mapping.mosaic import MosaicConfig
from perception.mapping.products import (
    atomic_write,
    map_raster,
    write_footprints_geojson,
    write_geotiff,
    write_png_with_world_file,
    write_targets_geojson,
)
from perception.sonar_io.beams import aris3000_128
from tests.perception.heights.synth_seabed import render, texture

RES_M = 0.01
ORIGIN = LocalOrigin(lat_deg=43.2951, lon_deg=5.3745)
TARGET = MappedTarget(
    target_id=3, north_m=3.6, east_m=5.1, height_m=0.124, height_std_m=0.003, frames_used=14,
    footprint_ne_m=((3.5, 5.0), (3.7, 5.0), (3.7, 5.2), (3.5, 5.2)),
)


@pytest.fixture(scope="module")
def built() -> MosaicBuilder:
    tex = texture(np.random.default_rng(3), 800, blur_cells=2.0)
    builder = MosaicBuilder(MosaicConfig(resolution_m=RES_M, tile_cells=64))
    for k in range(12):
        builder.add_frame(render(tex, res_m=RES_M, north_m=1.5 + 0.05 * k, east_m=5.0, altitude_m=1.0,
                                 heading_rad=0.0, tilt_rad=math.radians(25), range_m=np.linspace(0.7, 3.0, 500),
                                 azimuth_rad=np.asarray(aris3000_128().azimuth_rad)))
    return builder


def test_geotiff_georeference_reads_back_in_gdal(built, tmp_path):
    raster = map_raster(built.mosaic, [TARGET])
    path = write_geotiff(tmp_path / "mosaic.tif", raster, ORIGIN)
    with rasterio.open(path) as ds:
        assert ds.count == 2 and ds.dtypes == ("float32", "float32")
        assert ds.crs is not None and ds.crs.is_projected
        assert ds.res == pytest.approx((RES_M, RES_M))
        # The target's centre: pixel from GDAL's transform, lat/lon from GDAL's CRS.
        row, col = ds.index(TARGET.east_m, TARGET.north_m)
        heights = ds.read(2)
        assert heights[row, col] == pytest.approx(TARGET.height_m)
        lon, lat = warp_transform(ds.crs, "EPSG:4326", [TARGET.east_m], [TARGET.north_m])
        want_lat, want_lon = ORIGIN.to_lat_lon(TARGET.north_m, TARGET.east_m)
        assert lat[0] == pytest.approx(float(want_lat), abs=1e-8)  # ~1 mm
        assert lon[0] == pytest.approx(float(want_lon), abs=1e-8)
        intensity = ds.read(1)
        assert np.array_equal(np.isnan(intensity), np.isnan(raster.intensity))
        assert np.nanmax(intensity) > 100


def test_geotiff_compressed_on_several_threads_is_the_same_file(built, tmp_path, monkeypatch):
    """The strips compressed in parallel come out byte for byte as on one thread, and GDAL reads
    back every cell (a mosaic of many strips: 16 rows each)."""
    import perception.mapping.products as products

    raster = map_raster(built.mosaic, [TARGET])
    assert raster.intensity.shape[0] > 64  # several strips per band
    files = []
    for workers in (1, 4):
        monkeypatch.setattr(products, "GEOTIFF_WORKERS", workers)
        files.append(write_geotiff(tmp_path / f"mosaic_{workers}.tif", raster, ORIGIN).read_bytes())
    assert files[0] == files[1]
    with rasterio.open(tmp_path / "mosaic_4.tif") as ds:
        assert np.array_equal(ds.read(1), raster.intensity.astype(np.float32), equal_nan=True)
        assert np.array_equal(ds.read(2), raster.height_m.astype(np.float32), equal_nan=True)


def test_png_world_file_places_the_pixels(built, tmp_path):
    raster = map_raster(built.mosaic)
    png, pgw, prj, aux = write_png_with_world_file(tmp_path / "mosaic.png", raster, ORIGIN)
    values = [float(v) for v in pgw.read_text().split()]
    assert values[0] == pytest.approx(RES_M) and values[3] == pytest.approx(-RES_M)
    assert values[4] == pytest.approx(raster.west_m + RES_M / 2)
    assert values[5] == pytest.approx(raster.north_m - RES_M / 2)
    assert "Transverse_Mercator" in prj.read_text()
    with rasterio.open(png) as ds:
        assert ds.crs is not None and ds.crs.is_projected
        assert ds.transform.c == pytest.approx(raster.west_m)
        assert ds.count == 4  # grey as RGB plus alpha where there is no data
        alpha = ds.read(4)
        assert np.array_equal(alpha == 0, np.isnan(raster.intensity))
    assert aux.exists()


def test_targets_geojson_is_rfc7946(tmp_path):
    path = write_targets_geojson(tmp_path / "targets.geojson", [TARGET], ORIGIN)
    doc = json.loads(path.read_text())
    assert doc["type"] == "FeatureCollection"
    (feature,) = doc["features"]
    lon, lat = feature["geometry"]["coordinates"]
    assert 5.37 < lon < 5.38 and 43.29 < lat < 43.30  # [lon, lat] order
    assert feature["properties"]["height_m"] == pytest.approx(0.124)
    assert feature["properties"]["frames_used"] == 14
    foot = json.loads(write_footprints_geojson(tmp_path / "f.geojson", [TARGET], ORIGIN).read_text())
    ring = foot["features"][0]["geometry"]["coordinates"][0]
    assert ring[0] == ring[-1] and len(ring) == 5
    xs, ys = np.array(ring).T
    assert 0.5 * np.sum(xs[:-1] * ys[1:] - xs[1:] * ys[:-1]) > 0  # counter-clockwise


def test_unsolved_target_has_null_height():
    doc = targets_feature_collection([MappedTarget(1, 0.0, 0.0, math.nan, math.nan, 1)], ORIGIN)
    assert doc["features"][0]["properties"]["height_m"] is None


@settings(max_examples=40, deadline=None)
@given(north=st.floats(-50, 50), east=st.floats(-50, 50), height=st.floats(0.01, 0.5))
def test_height_raster_puts_the_height_under_the_centre(north, east, height):
    target = MappedTarget(1, north, east, height, 0.01, 2,
                          ((north - 0.1, east - 0.1), (north + 0.1, east - 0.1),
                           (north + 0.1, east + 0.1), (north - 0.1, east + 0.1)))
    row0 = int(math.floor(north / RES_M)) - 30
    col0 = int(math.floor(east / RES_M)) - 30
    raster = height_raster([target], row0=row0, col0=col0, shape=(60, 60), resolution_m=RES_M)
    assert raster[30, 30] == pytest.approx(height)
    covered = np.count_nonzero(np.isfinite(raster))
    assert 18 * 18 <= covered <= 22 * 22  # a 20 x 20 cm footprint at 1 cm cells


def test_failed_write_keeps_the_previous_file(tmp_path):
    path = tmp_path / "out.bin"
    atomic_write(path, lambda h: h.write(b"complete"))

    def broken(handle):
        handle.write(b"half")
        raise RuntimeError("crash mid-write")

    with pytest.raises(RuntimeError):
        atomic_write(path, broken)
    assert path.read_bytes() == b"complete"
    assert [p.name for p in tmp_path.iterdir()] == ["out.bin"]


def test_origin_round_trip_and_validation():
    n, e = ORIGIN.to_local(*ORIGIN.to_lat_lon(123.4, -56.7))
    assert float(n) == pytest.approx(123.4, abs=1e-6) and float(e) == pytest.approx(-56.7, abs=1e-6)
    with pytest.raises(ValueError, match="latitude"):
        LocalOrigin(95.0, 0.0)


def test_empty_mosaic_is_refused(tmp_path: Path):
    with pytest.raises(ValueError, match="empty"):
        map_raster(MosaicBuilder().mosaic)
