"""Polar -> fan conversion: true range-zero origin, round trips, known-answer images."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from perception.errors import GeometryError
from perception.mapping.fan import frame_to_fan, polar_to_fan
from perception.mapping.fan_geometry import FanGeometry, fan_geometry
from perception.sonar_io.beams import aris3000_128
from perception.sonar_io.frame import SonarFrame

ARIS_AZ = aris3000_128().azimuth_rad  # non-uniform beam spacing


def _aris_geometry(*, r0: float = 3.0, r1: float = 8.0, n: int = 400, pixel_size_m: float = 0.02) -> FanGeometry:
    return fan_geometry(np.linspace(r0, r1, n), ARIS_AZ, pixel_size_m=pixel_size_m)


def _fan_polar_coords(geometry: FanGeometry) -> tuple[np.ndarray, np.ndarray]:
    rows = np.arange(geometry.n_rows)[:, None]
    cols = np.arange(geometry.n_cols)[None, :]
    return geometry.pixel_to_polar(rows, cols)


def _interior(geometry: FanGeometry, r: np.ndarray, a: np.ndarray, *, margin_samples: float = 1.0) -> np.ndarray:
    """Pixels inside the fan by at least a margin (1 sample, 1 beam) from its edges."""
    dr = margin_samples * float(np.max(np.diff(geometry.range_m)))
    da = margin_samples * float(np.max(np.diff(geometry.beam_azimuth_rad)))
    rng, az = geometry.range_m, geometry.beam_azimuth_rad
    return (r > rng[0] + dr) & (r < rng[-1] - dr) & (a > az[0] + da) & (a < az[-1] - da)


def _exterior(geometry: FanGeometry, r: np.ndarray, a: np.ndarray) -> np.ndarray:
    """Pixels outside the fan by at least one sample or beam."""
    dr = float(np.max(np.diff(geometry.range_m)))
    da = float(np.max(np.diff(geometry.beam_azimuth_rad)))
    rng, az = geometry.range_m, geometry.beam_azimuth_rad
    return (r < rng[0] - dr) | (r > rng[-1] + dr) | (a < az[0] - da) | (a > az[-1] + da)


# --- geometry: origin and round trips ----------------------------------------------------


def test_apex_is_the_sonar_and_the_window_start_is_an_arc() -> None:
    geometry = _aris_geometry(r0=3.0)
    r, _ = geometry.pixel_to_polar(geometry.origin_row, geometry.origin_col)
    assert float(r) == 0.0
    # The apex lies below the image: the bottom edge is not range zero ...
    bottom_edge_row = geometry.n_rows - 0.5
    assert geometry.origin_row > bottom_edge_row
    x_bottom = (geometry.origin_row - bottom_edge_row) * geometry.pixel_size_m
    edge_az = max(abs(ARIS_AZ[0]), abs(ARIS_AZ[-1]))
    assert x_bottom == pytest.approx(3.0 * math.cos(edge_az), abs=geometry.pixel_size_m)
    # ... and the window start is an arc: its centre lies above its ends.
    rows, _ = geometry.polar_to_pixel(3.0, np.array([ARIS_AZ[0], 0.0, ARIS_AZ[-1]]))
    assert rows[1] < rows[0] and rows[1] < rows[2]
    assert (rows[0] - rows[1]) * geometry.pixel_size_m == pytest.approx(3.0 * (1 - math.cos(ARIS_AZ[0])), rel=1e-9)


def test_include_origin_puts_the_apex_in_the_image() -> None:
    geometry = fan_geometry(np.linspace(3.0, 8.0, 400), ARIS_AZ, pixel_size_m=0.02, include_origin=True)
    assert -0.5 <= geometry.origin_row <= geometry.n_rows - 0.5  # within the pixel area
    assert -0.5 <= geometry.origin_col <= geometry.n_cols - 0.5
    assert geometry.n_rows * geometry.pixel_size_m >= 8.0


geometries = st.builds(
    lambda r0, span, n, px: fan_geometry(np.linspace(r0, r0 + span, n), ARIS_AZ, pixel_size_m=px),
    st.floats(0.0, 20.0),
    st.floats(0.5, 30.0),
    st.integers(2, 3000),
    st.floats(0.005, 0.2),
)


@given(geometry=geometries, row=st.floats(-500, 5000), col=st.floats(-500, 5000))
def test_pixel_polar_round_trip(geometry: FanGeometry, row: float, col: float) -> None:
    r, a = geometry.pixel_to_polar(row, col)
    row_back, col_back = geometry.polar_to_pixel(r, a)
    assert float(row_back) == pytest.approx(row, abs=1e-8)
    assert float(col_back) == pytest.approx(col, abs=1e-8)


@given(geometry=geometries, r=st.floats(0.01, 60.0), a=st.floats(-1.5, 1.5))
def test_polar_pixel_round_trip(geometry: FanGeometry, r: float, a: float) -> None:
    row, col = geometry.polar_to_pixel(r, a)
    r_back, a_back = geometry.pixel_to_polar(row, col)
    assert float(r_back) == pytest.approx(r, rel=1e-11, abs=1e-11)
    assert float(a_back) == pytest.approx(a, abs=1e-9)


@given(sample=st.floats(0.0, 399.0), beam=st.floats(0.0, 127.0))
def test_sample_beam_round_trip(sample: float, beam: float) -> None:
    # Non-uniform in both axes: quadratic range spacing and the ARIS beam table.
    geometry = fan_geometry(
        2.0 + np.linspace(0.0, 1.0, 400) ** 2 * 6.0 + np.linspace(0, 0.1, 400),
        ARIS_AZ,
        pixel_size_m=0.01,
    )
    row, col = geometry.sample_beam_to_pixel(sample, beam)
    s_back, b_back = geometry.pixel_to_sample_beam(row, col)
    assert float(s_back) == pytest.approx(sample, abs=1e-7)
    assert float(b_back) == pytest.approx(beam, abs=1e-7)


def test_outside_indices_are_nan() -> None:
    geometry = _aris_geometry()
    row, col = geometry.sample_beam_to_pixel(-1.0, 10.0)
    assert math.isnan(float(row)) and math.isnan(float(col))
    s, b = geometry.pixel_to_sample_beam(geometry.origin_row, geometry.origin_col)
    assert math.isnan(float(s)) and math.isnan(float(b))


def test_width_px_gives_that_width_and_spans_the_fan() -> None:
    geometry = fan_geometry(np.linspace(1.0, 11.0, 2000), ARIS_AZ, width_px=512)
    assert geometry.n_cols == 512
    span = 11.0 * (math.sin(ARIS_AZ[-1]) - math.sin(ARIS_AZ[0]))
    assert geometry.pixel_size_m == pytest.approx(span / 512, rel=1e-12)


def test_equal_geometries_compare_and_hash_equal() -> None:
    a = _aris_geometry()
    b = fan_geometry(np.linspace(3.0, 8.0, 400).copy(), ARIS_AZ.copy(), pixel_size_m=0.02)
    assert a == b and hash(a) == hash(b)
    assert a != _aris_geometry(pixel_size_m=0.021)
    assert a != _aris_geometry(r0=3.01)
    assert a != fan_geometry(np.linspace(3.0, 8.0, 400), ARIS_AZ, pixel_size_m=0.02, include_origin=True)


# --- images: known answers ---------------------------------------------------------------


def test_range_ramp_lands_at_its_range_from_the_apex() -> None:
    """Each polar row holds its own slant range: every fan pixel shows its distance from
    the apex (the sonar), to the 1/32-sample precision of the fixed-point maps."""
    geometry = _aris_geometry()
    image = np.repeat(geometry.range_m.astype(np.float32)[:, None], ARIS_AZ.size, axis=1)
    fan = polar_to_fan(image, geometry, fill=-1.0)
    r, a = _fan_polar_coords(geometry)
    inner = _interior(geometry, r, a)
    step = float(geometry.range_m[1] - geometry.range_m[0])
    assert inner.sum() > 0.4 * fan.size
    np.testing.assert_allclose(fan[inner], r[inner], atol=step / 32 + 1e-5)
    assert np.all(fan[_exterior(geometry, r, a)] == -1.0)


def test_azimuth_ramp_follows_the_non_uniform_beam_table() -> None:
    """Each column holds its beam's azimuth: fan pixels show their own azimuth, which only
    holds because the column is interpolated from the (non-uniform) ARIS table."""
    geometry = _aris_geometry()
    image = np.repeat(ARIS_AZ.astype(np.float32)[None, :], geometry.range_m.size, axis=0)
    fan = polar_to_fan(image, geometry, fill=9.0)
    r, a = _fan_polar_coords(geometry)
    inner = _interior(geometry, r, a)
    tolerance = float(np.max(np.diff(ARIS_AZ))) / 32 + 1e-6
    np.testing.assert_allclose(fan[inner], a[inner], atol=tolerance)
    # Assuming uniform spacing would miss by more than that tolerance.
    uniform = np.linspace(ARIS_AZ[0], ARIS_AZ[-1], ARIS_AZ.size)
    assert float(np.max(np.abs(uniform - ARIS_AZ))) > 3 * tolerance


def test_bright_arc_and_bright_beam_land_where_they_belong() -> None:
    geometry = _aris_geometry()
    k, j = 250, 40
    arc = np.zeros(geometry.polar_shape, dtype=np.uint8)
    arc[k, :] = 255
    ray = np.zeros(geometry.polar_shape, dtype=np.uint8)
    ray[:, j] = 255
    r, a = _fan_polar_coords(geometry)
    bright_arc = polar_to_fan(arc, geometry) > 127
    bright_ray = polar_to_fan(ray, geometry) > 127
    assert bright_arc.sum() > 100 and bright_ray.sum() > 100
    # Range measured from the apex, not from the image bottom.
    assert np.all(np.abs(r[bright_arc] - geometry.range_m[k]) <= geometry.pixel_size_m)
    beam_step = float(np.max(np.diff(ARIS_AZ)))
    # Bilinear weights > 1/2 within half a beam, +1/32 beam for the fixed-point weights.
    assert np.all(np.abs(a[bright_ray] - ARIS_AZ[j]) <= beam_step * (0.5 + 1 / 32))


def test_nearest_only_returns_input_values(rng: np.random.Generator) -> None:
    geometry = _aris_geometry()
    image = rng.choice(np.array([10, 20, 30], dtype=np.uint8), size=geometry.polar_shape)
    fan = polar_to_fan(image, geometry, interpolation="nearest", fill=0)
    assert set(np.unique(fan).tolist()) <= {0, 10, 20, 30}
    r, a = _fan_polar_coords(geometry)
    assert np.all(fan[_interior(geometry, r, a)] > 0)


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16, np.float32])
def test_dtype_kept_and_input_untouched(dtype: type, rng: np.random.Generator) -> None:
    geometry = _aris_geometry(pixel_size_m=0.05)
    image: np.ndarray = (rng.random(geometry.polar_shape) * 200).astype(dtype)
    image.flags.writeable = False  # frames hold read-only images
    before = image.copy()
    fan = polar_to_fan(image, geometry)
    assert fan.dtype == image.dtype and fan.shape == geometry.shape
    np.testing.assert_array_equal(image, before)
    # A constant image stays constant inside the fan, whatever the dtype.
    flat: np.ndarray = np.full(geometry.polar_shape, 77, dtype=dtype)
    out = polar_to_fan(flat, geometry)
    np.testing.assert_array_equal(out[geometry.inside_mask()], 77)


def test_frame_to_fan_matches_polar_to_fan(rng: np.random.Generator) -> None:
    ranges = np.linspace(1.0, 6.0, 300)
    image = (rng.random((300, ARIS_AZ.size)) * 255).astype(np.uint8)
    frame = SonarFrame(image, ranges, ARIS_AZ, math.radians(14.0), 0.0)
    fan, geometry = frame_to_fan(frame, width_px=200)
    assert geometry == FanGeometry.from_frame(frame, width_px=200)
    np.testing.assert_array_equal(fan, polar_to_fan(image, geometry))
    mask = geometry.inside_mask()
    r, a = _fan_polar_coords(geometry)
    np.testing.assert_array_equal(mask, geometry.inside(r, a))


# --- bad input ---------------------------------------------------------------------------


def test_bad_input_raises_geometry_error() -> None:
    ranges = np.linspace(1.0, 6.0, 300)
    with pytest.raises(GeometryError, match="exactly one"):
        fan_geometry(ranges, ARIS_AZ)
    with pytest.raises(GeometryError, match="exactly one"):
        fan_geometry(ranges, ARIS_AZ, pixel_size_m=0.01, width_px=100)
    with pytest.raises(GeometryError, match="strictly increasing"):
        fan_geometry(ranges[::-1], ARIS_AZ, pixel_size_m=0.01)
    with pytest.raises(GeometryError, match="pi/2"):
        fan_geometry(ranges, np.array([-2.0, 0.0]), pixel_size_m=0.01)
    with pytest.raises(GeometryError, match="width_px"):
        fan_geometry(ranges, ARIS_AZ, width_px=0)
    with pytest.raises(GeometryError, match="too large"):
        fan_geometry(ranges, ARIS_AZ, pixel_size_m=1e-5)
    geometry = fan_geometry(ranges, ARIS_AZ, pixel_size_m=0.05)
    with pytest.raises(GeometryError, match="shape"):
        polar_to_fan(np.zeros((10, 128), np.uint8), geometry)
    with pytest.raises(GeometryError, match="dtype"):
        polar_to_fan(np.zeros((300, 128), np.int32), geometry)
    with pytest.raises(GeometryError, match="interpolation"):
        polar_to_fan(np.zeros((300, 128), np.uint8), geometry, interpolation="cubic")
