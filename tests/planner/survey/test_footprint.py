"""The planning footprint lies inside what the sonar really insonifies."""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

from perception.geometry import insonified_band, sonar_to_ned
from planner.config import default_settings
from planner.errors import InfeasibleError
from planner.survey.footprint import exact_footprint_body, footprint, seen_mask, swept_polygon

SONAR = default_settings().sonar


def _seen(forward: float, starboard: float, altitude: float, tilt: float) -> bool:
    """Invert the sonar geometry: is this seabed point inside the fan, aperture and window?"""
    v_ned = np.array([forward, starboard, altitude])
    slant = float(np.linalg.norm(v_ned))
    v_sonar = sonar_to_ned(tilt_rad=tilt).T @ (v_ned / slant)
    azimuth = math.atan2(v_sonar[1], v_sonar[0])
    elevation = math.asin(v_sonar[2])
    tol = 1e-9
    return (
        abs(azimuth) <= SONAR.fan_width_rad / 2 + tol
        and abs(elevation) <= SONAR.elevation_aperture_rad / 2 + tol
        and SONAR.window_start_m - tol <= slant <= SONAR.window_end_m + tol
    )


@given(
    altitude=st.floats(0.5, 5.0),
    tilt_deg=st.floats(0.0, 60.0),
    weights=st.lists(st.floats(0.0, 1.0), min_size=4, max_size=4),
)
@settings(max_examples=80, deadline=None)
def test_trapezoid_is_inside_the_real_footprint(altitude: float, tilt_deg: float,
                                                weights: list[float]) -> None:
    tilt = math.radians(tilt_deg)
    band = insonified_band(altitude, depression_rad=tilt,
                           elevation_aperture_rad=SONAR.elevation_aperture_rad,
                           window_m=(SONAR.window_start_m, SONAR.window_end_m))
    if band.empty or band.far_ground_m <= band.near_ground_m:
        return
    try:
        fp = footprint(altitude, tilt, SONAR)
    except InfeasibleError:
        return
    corners = fp.corners_body()
    for c in corners:
        assert _seen(c[0], c[1], altitude, tilt)
    w = np.asarray(weights) + 1e-9
    point = (w / w.sum()) @ corners  # any point of the convex trapezoid
    assert _seen(point[0], point[1], altitude, tilt)


@pytest.mark.parametrize("tilt_deg", [8.0, 15.0, 25.0, 45.0])
def test_ray_casting_and_inversion_agree_and_trapezoid_is_not_tiny(tilt_deg: float) -> None:
    altitude, tilt = 2.0, math.radians(tilt_deg)
    fp = footprint(altitude, tilt, SONAR)
    assert fp.swath_m == pytest.approx(2 * fp.near_ground_m * math.tan(fp.half_fan_rad))
    assert fp.lead_in_m == fp.near_ground_m
    exact = exact_footprint_body(altitude, tilt, SONAR, n_azimuth=31, n_elevation=31)
    assert len(exact) > 100
    assert seen_mask(exact[:, 0], exact[:, 1], altitude, tilt, SONAR).all()
    # Area of the real footprint by counting cells; the trapezoid is a good part of it.
    xs, ys = np.meshgrid(np.linspace(0, 12, 600), np.linspace(-6, 6, 600))
    cell = (12 / 599) * (12 / 599)
    real_area = seen_mask(xs, ys, altitude, tilt, SONAR).sum() * cell
    trap_area = shapely.Polygon(fp.corners_body()).area
    assert trap_area <= real_area
    assert trap_area >= 0.5 * real_area


def test_swept_polygon_holds_both_ends() -> None:
    fp = footprint(1.5, math.radians(10.0), SONAR)
    poly = swept_polygon(fp, (0.0, 0.0), (0.0, 30.0))  # heading north
    for pos in ((0.0, 0.0), (0.0, 30.0)):
        assert poly.buffer(1e-9).contains(shapely.Polygon(fp.corners_plane(pos, 0.0)))
    # Width at mid-run is at least the swath, centred on the lane.
    mid = poly.intersection(shapely.LineString([(-50, 15.0 + fp.near_ground_m),
                                                (50, 15.0 + fp.near_ground_m)]))
    assert mid.length >= fp.swath_m - 1e-9
    assert mid.centroid.x == pytest.approx(0.0, abs=1e-9)


def test_beam_above_the_window_is_refused() -> None:
    # Level sonar at 2 m: the steepest ray meets the seabed at 16.4 m, past the 12 m window.
    with pytest.raises(InfeasibleError, match="no usable seabed"):
        footprint(2.0, 0.0, SONAR)
