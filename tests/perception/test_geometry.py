"""Sonar geometry: slant/ground range, depression, insonified band, rotations, seabed plane."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from perception.errors import GeometryError
from perception.geometry import (
    SeabedPlane,
    altitude_from_band_start,
    ground_to_slant,
    insonified_band,
    ray_angles_sonar,
    ray_depression_of_angles_rad,
    ray_depression_rad,
    ray_direction_sonar,
    rot_x,
    rot_y,
    rot_z,
    seabed_hit_slant_m,
    slant_for_depression,
    slant_to_ground,
    sonar_to_ned,
)

altitudes = st.floats(0.2, 50.0)
angles = st.floats(-math.pi, math.pi)
small_angles = st.floats(-0.4, 0.4)


# --- slant and ground range ------------------------------------------------------------


def test_slant_ground_known_answer_345() -> None:
    assert float(slant_to_ground(5.0, 3.0)) == pytest.approx(4.0, abs=1e-12)
    assert float(ground_to_slant(4.0, 3.0)) == pytest.approx(5.0, abs=1e-12)


@given(altitude=altitudes, ground=st.floats(0.0, 200.0))
def test_ground_slant_round_trip(altitude: float, ground: float) -> None:
    slant = float(ground_to_slant(ground, altitude))
    assert slant >= altitude
    back = float(slant_to_ground(slant, altitude))
    # Near the nadir d(ground)/d(slant) = slant/ground is unbounded: one rounding of the
    # slant range (altitude * 1e-16) becomes sqrt(2 * altitude**2 * 1e-16) of ground range.
    assert back == pytest.approx(ground, abs=1e-9 + 3e-8 * altitude)
    assert float(ground_to_slant(back, altitude)) == pytest.approx(slant, rel=1e-14)


def test_slant_shorter_than_altitude_never_reaches_seabed() -> None:
    ground = slant_to_ground([1.0, 2.0, 3.0], 2.0)
    assert math.isnan(ground[0])
    assert ground[1] == 0.0
    assert ground[2] == pytest.approx(math.sqrt(5.0))


@pytest.mark.parametrize("bad", [0.0, -1.0, math.nan, math.inf])
def test_bad_altitude_raises(bad: float) -> None:
    with pytest.raises(GeometryError, match="altitude"):
        slant_to_ground(3.0, bad)


# --- ray depression ----------------------------------------------------------------------


def test_depression_known_answer() -> None:
    assert float(ray_depression_rad(2.0, 1.0)) == pytest.approx(math.radians(30.0))
    assert float(slant_for_depression(math.radians(30.0), 1.0)) == pytest.approx(2.0)
    assert math.isnan(float(ray_depression_rad(0.5, 1.0)))
    assert math.isinf(float(slant_for_depression(0.0, 1.0)))
    assert math.isinf(float(slant_for_depression(-0.1, 1.0)))


@given(altitude=altitudes, depression=st.floats(0.01, math.pi / 2))
def test_depression_slant_round_trip(altitude: float, depression: float) -> None:
    slant = float(slant_for_depression(depression, altitude))
    assert float(ray_depression_rad(slant, altitude)) == pytest.approx(depression, abs=1e-7)


# --- insonified band ---------------------------------------------------------------------


def test_band_known_answer_beam_limited() -> None:
    h, dep, ap = 2.0, math.radians(20.0), math.radians(14.0)
    band = insonified_band(h, depression_rad=dep, elevation_aperture_rad=ap)
    assert band.near_slant_m == pytest.approx(h / math.sin(math.radians(27.0)))
    assert band.far_slant_m == pytest.approx(h / math.sin(math.radians(13.0)))
    assert band.near_ground_m == pytest.approx(h / math.tan(math.radians(27.0)))
    assert band.far_ground_m == pytest.approx(h / math.tan(math.radians(13.0)))
    assert (band.near_limited_by, band.far_limited_by) == ("beam", "beam")
    assert not band.empty
    assert band.contains_slant(5.0) and not band.contains_slant(4.0)


def test_band_window_limits_both_ends() -> None:
    h, dep, ap = 2.0, math.radians(20.0), math.radians(14.0)
    band = insonified_band(h, depression_rad=dep, elevation_aperture_rad=ap, window_m=(5.0, 7.0))
    assert (band.near_slant_m, band.far_slant_m) == (5.0, 7.0)
    assert (band.near_limited_by, band.far_limited_by) == ("window", "window")
    assert band.near_ground_m == pytest.approx(math.sqrt(25.0 - 4.0))
    assert band.far_ground_m == pytest.approx(math.sqrt(49.0 - 4.0))


def test_band_shallow_ray_above_horizon_is_unbounded_unless_windowed() -> None:
    band = insonified_band(1.0, depression_rad=math.radians(5.0), elevation_aperture_rad=0.25)
    assert math.isinf(band.far_slant_m) and math.isinf(band.far_ground_m)
    windowed = insonified_band(1.0, depression_rad=math.radians(5.0), elevation_aperture_rad=0.25, window_m=(1.0, 30.0))
    assert windowed.far_slant_m == 30.0 and windowed.far_limited_by == "window"


def test_band_empty_when_window_ends_before_seabed() -> None:
    band = insonified_band(10.0, depression_rad=math.radians(20.0), elevation_aperture_rad=0.25, window_m=(1.0, 5.0))
    assert band.empty


def test_band_rejects_beam_above_horizon_and_bad_inputs() -> None:
    with pytest.raises(GeometryError, match="above the horizontal"):
        insonified_band(2.0, depression_rad=-0.5, elevation_aperture_rad=0.25)
    with pytest.raises(GeometryError, match="aperture"):
        insonified_band(2.0, depression_rad=0.3, elevation_aperture_rad=0.0)
    with pytest.raises(GeometryError, match="window"):
        insonified_band(2.0, depression_rad=0.3, elevation_aperture_rad=0.25, window_m=(5.0, 4.0))


@given(
    altitude=altitudes,
    depression=st.floats(0.0, 1.2),
    aperture=st.floats(0.05, 0.6),
)
def test_altitude_from_band_start_inverts_band(altitude: float, depression: float, aperture: float) -> None:
    band = insonified_band(altitude, depression_rad=depression, elevation_aperture_rad=aperture)
    back = altitude_from_band_start(band.near_slant_m, depression_rad=depression, elevation_aperture_rad=aperture)
    assert back == pytest.approx(altitude, rel=1e-12)


# --- rotations and rays ------------------------------------------------------------------


@given(tilt=angles, pitch=angles, roll=angles, heading=angles)
def test_sonar_to_ned_is_a_proper_rotation(tilt: float, pitch: float, roll: float, heading: float) -> None:
    rot = sonar_to_ned(tilt_rad=tilt, pitch_rad=pitch, roll_rad=roll, heading_rad=heading)
    np.testing.assert_allclose(rot @ rot.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(rot) == pytest.approx(1.0, abs=1e-12)


def test_sign_conventions() -> None:
    # Tilt down points the boresight down (positive NED z).
    boresight = sonar_to_ned(tilt_rad=math.radians(30.0)) @ np.array([1.0, 0.0, 0.0])
    np.testing.assert_allclose(boresight, [math.cos(math.radians(30)), 0, 0.5], atol=1e-12)
    # Nose-up pitch lifts the boresight: depression = tilt - pitch.
    dep = ray_depression_of_angles_rad(0.0, 0.0, tilt_rad=0.5, pitch_rad=0.2)
    assert float(dep) == pytest.approx(0.3)
    # Roll starboard down lowers starboard rays.
    starboard = ray_depression_of_angles_rad(0.2, 0.0, tilt_rad=0.0, roll_rad=0.3)
    port = ray_depression_of_angles_rad(-0.2, 0.0, tilt_rad=0.0, roll_rad=0.3)
    assert float(starboard) > 0 > float(port)
    # Heading turns north towards east (clockwise from above).
    np.testing.assert_allclose(rot_z(math.pi / 2) @ [1.0, 0, 0], [0, 1.0, 0], atol=1e-15)
    np.testing.assert_allclose(rot_x(math.pi / 2) @ [0, 1.0, 0], [0, 0, 1.0], atol=1e-15)
    np.testing.assert_allclose(rot_y(math.pi / 2) @ [1.0, 0, 0], [0, 0, -1.0], atol=1e-15)


@given(az=st.floats(-1.5, 1.5), el=st.floats(-1.5, 1.5))
def test_ray_angles_round_trip(az: float, el: float) -> None:
    direction = ray_direction_sonar(az, el)
    assert float(np.linalg.norm(direction)) == pytest.approx(1.0)
    az_back, el_back = ray_angles_sonar(3.7 * direction)
    assert float(az_back) == pytest.approx(az, abs=1e-12)
    assert float(el_back) == pytest.approx(el, abs=1e-12)


def test_ray_angles_rejects_zero_direction() -> None:
    with pytest.raises(GeometryError, match="non-zero"):
        ray_angles_sonar([0.0, 0.0, 0.0])
    with pytest.raises(GeometryError, match="length 3"):
        ray_angles_sonar([1.0, 0.0])


@given(
    altitude=altitudes,
    az=st.floats(-0.27, 0.27),
    el=st.floats(-0.12, 0.12),
    tilt=st.floats(0.3, 1.2),
    pitch=small_angles,
    roll=small_angles,
)
def test_seabed_hit_point_lies_on_the_seabed(
    altitude: float, az: float, el: float, tilt: float, pitch: float, roll: float
) -> None:
    slant = float(seabed_hit_slant_m(az, el, altitude_m=altitude, tilt_rad=tilt, pitch_rad=pitch, roll_rad=roll))
    dep = float(ray_depression_of_angles_rad(az, el, tilt_rad=tilt, pitch_rad=pitch, roll_rad=roll))
    if dep <= 0:
        assert math.isinf(slant)
        return
    rot = sonar_to_ned(tilt_rad=tilt, pitch_rad=pitch, roll_rad=roll, heading_rad=1.0)
    hit = slant * (rot @ ray_direction_sonar(az, el))
    assert hit[2] == pytest.approx(altitude, rel=1e-12)  # depth of the hit = altitude below
    assert slant == pytest.approx(float(slant_for_depression(dep, altitude)), rel=1e-9)


def test_seabed_hit_on_axis_matches_depression() -> None:
    slant = seabed_hit_slant_m(0.0, 0.0, altitude_m=2.0, tilt_rad=0.6, pitch_rad=0.1)
    assert float(slant) == pytest.approx(2.0 / math.sin(0.5))


# --- seabed plane ------------------------------------------------------------------------


@given(
    slope=st.floats(0.0, 1.2),
    direction=angles,
    depth=st.floats(-5.0, 100.0),
    seed=st.integers(0, 2**32 - 1),
)
def test_plane_fit_recovers_plane(slope: float, direction: float, depth: float, seed: int) -> None:
    normal = np.array(
        [
            math.sin(slope) * math.cos(direction),
            math.sin(slope) * math.sin(direction),
            -math.cos(slope),
        ]
    )
    origin = np.array([3.0, -2.0, depth])
    rng = np.random.default_rng(seed)
    # Points on the plane: origin + combinations of two in-plane directions.
    u = np.cross(normal, [0.0, 0.0, 1.0] if slope > 1e-6 else [1.0, 0.0, 0.0])
    u /= np.linalg.norm(u)
    v = np.cross(normal, u)
    coeffs = rng.uniform(-10, 10, size=(20, 2))
    points = origin + coeffs[:, :1] * u + coeffs[:, 1:] * v
    plane = SeabedPlane.fit(points)
    np.testing.assert_allclose(plane.normal_ned, normal, atol=1e-9)
    assert plane.slope_rad == pytest.approx(slope, abs=1e-6)
    above = origin + 1.7 * normal
    assert float(plane.height_above_m(above)) == pytest.approx(1.7, abs=1e-9)
    np.testing.assert_allclose(plane.height_above_m(points), 0.0, atol=1e-9)


def test_horizontal_plane_height_is_altitude() -> None:
    plane = SeabedPlane.horizontal(30.0)
    assert plane.slope_rad == 0.0
    assert float(plane.height_above_m([5.0, 7.0, 27.5])) == pytest.approx(2.5)


def test_plane_rejects_bad_input() -> None:
    with pytest.raises(GeometryError, match="point up"):
        SeabedPlane((0.0, 0.0, 1.0))
    with pytest.raises(GeometryError, match="non-zero"):
        SeabedPlane((0.0, 0.0, 0.0))
    with pytest.raises(GeometryError, match="collinear"):
        SeabedPlane.fit([[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [2.0, 0.0, 1.0]])
    with pytest.raises(GeometryError, match="shape"):
        SeabedPlane.fit([[0.0, 0.0, 1.0], [1.0, 0.0, 1.0]])
    with pytest.raises(GeometryError, match="unknown"):
        SeabedPlane((0.0, 0.0, -1.0)).height_above_m([0.0, 0.0, 0.0])
