"""Tests of the pitch loop's settings and geometry: known answers, closed forms against
direct rays, measurement round trips."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from benchmarks.pitch_kinematics import (
    whole_shadow_visible,
)
from perception.errors import GeometryError, MeasurementError
from perception.geometry import insonified_band, ray_angles_sonar, sonar_to_ned
from planner.errors import ConfigError
from planner.pitch.aperture import (
    aperture_interval_rad,
    depression_interval_rad,
    point_elevation_rad,
    shadow_and_whole_intervals_rad,
    shadow_geometry,
    shadow_margins_rad,
)
from planner.pitch.config import MountLimits
from planner.pitch.measurements import shadow_from_measurement, shadow_from_ned, shadow_measurement
from planner.pitch.prediction import predict_pitch_rad
from planner.pitch.types import (
    PitchState,
    TrackedShadow,
)
from tests.planner.pitch.common import APERTURE, pitch_config


def _direct_elevation(x: float, y: float, z: float, *, tilt: float, pitch: float) -> tuple[float, float]:
    """Azimuth and elevation of a level-frame point by rotating it into the sonar frame."""
    p_sonar = sonar_to_ned(tilt_rad=tilt, pitch_rad=pitch).T @ np.array([x, y, z])
    az, el = ray_angles_sonar(p_sonar)
    return float(az), float(el)



# --------------------------------------------------------------------------- settings


@pytest.mark.parametrize(
    ("kw", "key"),
    [
        ({"margin_rad": math.radians(7.0)}, "margin_rad"),
        ({"horizon_steps": 0}, "horizon_steps"),
        ({"window_m": (5.0, 2.0)}, "window_m"),
        ({"solver": "nope"}, "solver"),
        ({"dt_s": 0.0}, "dt_s"),
        ({"height_min_m": 0.5, "height_prior_m": 0.4}, "height_min_m"),
        ({"hold_start_s": 0.6, "dt_s": 0.5}, "hold_start_s"),
        ({"search_weight_factor": 1.5}, "search_weight_factor"),
        ({"nominal_tilt_rad": float("nan")}, "nominal_tilt_rad"),
    ],
)
def test_bad_config_names_the_key(kw: dict[str, object], key: str) -> None:
    with pytest.raises(ConfigError) as info:
        pitch_config(**kw)
    assert info.value.key == key


def test_bad_limits_and_state_raise() -> None:
    with pytest.raises(ConfigError):
        MountLimits(0.5, 0.2, 1.0)
    with pytest.raises(ConfigError):
        MountLimits(0.0, 1.0, 0.0)
    with pytest.raises(GeometryError, match="altitude_m"):
        PitchState(altitude_m=0.0, vehicle_pitch_rad=0.0, speed_m_s=0.5, current_tilt_rad=0.2)
    with pytest.raises(GeometryError, match="footprint_m"):
        TrackedShadow(1, 3.0, 0.0, 0.1, footprint_m=-1.0)


# --------------------------------------------------------------------------- geometry


def test_on_axis_interval_known_answer() -> None:
    # A point 2 m ahead and 1 m down has depression atan(1/2); on the axis k = 1.
    lo, hi = aperture_interval_rad(2.0, 0.0, 1.0, half_aperture_rad=math.radians(6.0))
    dep = math.atan2(1.0, 2.0)
    assert float(lo) == pytest.approx(dep - math.radians(6.0), abs=1e-12)
    assert float(hi) == pytest.approx(dep + math.radians(6.0), abs=1e-12)


def test_shadow_geometry_known_answer() -> None:
    # H = 1 m, post of 0.2 m with its top 2 m ahead: r_top = sqrt(4 + 0.64), r_end = r_top / 0.8.
    g = shadow_geometry(2.0, 0.0, 0.2, 0.0, 1.0)
    r_top = math.sqrt(4.0 + 0.64)
    assert float(g.end_slant_m) == pytest.approx(r_top / 0.8, rel=1e-12)
    assert float(g.near_slant_m) == pytest.approx(r_top, rel=1e-12)
    assert float(g.base_ground_m) == pytest.approx(2.0)
    # A 0.5 m footprint moves the near foot 0.5 m closer along the line of sight.
    g2 = shadow_geometry(3.0, 4.0, 0.2, 0.5, 1.0)
    assert float(g2.base_ground_m) == pytest.approx(4.5)
    assert float(np.hypot(g2.base_along_m, g2.base_cross_m)) == pytest.approx(4.5)
    with pytest.raises(GeometryError):
        shadow_geometry(2.0, 0.0, 1.0, 0.0, 1.0)


@pytest.mark.parametrize(("altitude", "along", "height", "depression_deg"),
                         [(1.0, 3.0, 0.2, 15.0), (2.0, 8.0, 0.35, 12.0), (0.6, 2.0, 0.05, 20.0)])
def test_margins_match_insonified_band(altitude: float, along: float, height: float, depression_deg: float) -> None:
    """On the beam axis the angular margins are the band's slant edges seen as depressions:
    the far one at the shadow end, the near one at the shadow's start (the seabed at the top
    edge's slant range, which the image shows as the first shadowed sample)."""
    d = math.radians(depression_deg)
    g = shadow_geometry(along, 0.0, height, 0.0, altitude)
    far, near = shadow_margins_rad(g, depression_rad=d, elevation_aperture_rad=APERTURE)
    band = insonified_band(altitude, depression_rad=d, elevation_aperture_rad=APERTURE)
    r_end = float(g.end_slant_m)
    r_start = math.hypot(along, altitude - height)
    assert r_start < math.hypot(along, altitude)  # nearer than the far foot
    assert float(far) == pytest.approx(math.asin(altitude / r_end) - math.asin(altitude / band.far_slant_m), abs=1e-12)
    assert float(near) == pytest.approx(math.asin(altitude / band.near_slant_m) - math.asin(altitude / r_start),
                                        abs=1e-12)
    assert (float(far) >= 0) == (r_end <= band.far_slant_m)
    assert (float(near) >= 0) == band.contains_slant(r_start)


@settings(max_examples=200, deadline=None)
@given(x=st.floats(0.3, 15.0), y=st.floats(-4.0, 4.0), z=st.floats(0.1, 3.0),
       tilt=st.floats(-0.3, 1.2), pitch=st.floats(-0.2, 0.2))
def test_closed_form_elevation_matches_direct_rays(x: float, y: float, z: float, tilt: float, pitch: float) -> None:
    _, el = _direct_elevation(x, y, z, tilt=tilt, pitch=pitch)
    assert float(point_elevation_rad(x, y, z, depression_rad=tilt - pitch)) == pytest.approx(el, abs=1e-9)


@settings(max_examples=200, deadline=None)
@given(x=st.floats(0.3, 15.0), y=st.floats(-3.0, 3.0), z=st.floats(0.1, 3.0), half_deg=st.floats(1.0, 10.0))
def test_interval_ends_put_the_point_on_the_aperture_edges(x: float, y: float, z: float, half_deg: float) -> None:
    half = math.radians(half_deg)
    lo, hi = aperture_interval_rad(x, y, z, half_aperture_rad=half)
    rho = math.hypot(x, z)
    if math.sin(half) * math.hypot(rho, y) / rho >= 1.0:
        return  # the whole half-space qualifies; the ends are not aperture edges
    _, el_lo = _direct_elevation(x, y, z, tilt=float(lo), pitch=0.0)
    _, el_hi = _direct_elevation(x, y, z, tilt=float(hi), pitch=0.0)
    assert el_lo == pytest.approx(half, abs=1e-9)  # beam raised: the point at the steep edge
    assert el_hi == pytest.approx(-half, abs=1e-9)
    _, el_mid = _direct_elevation(x, y, z, tilt=0.5 * float(lo + hi), pitch=0.0)
    assert abs(el_mid) < half


@settings(max_examples=150, deadline=None)
@given(x=st.floats(1.0, 10.0), y=st.floats(-1.0, 1.0), h=st.floats(0.02, 0.4), alt=st.floats(0.5, 2.5),
       pitch=st.floats(-0.06, 0.06), off=st.floats(-0.8, 0.8))
def test_measurement_round_trip(x: float, y: float, h: float, alt: float, pitch: float, off: float) -> None:
    if h >= 0.9 * alt:
        return
    # Point the beam at the shadow end so the measured ray is inside the aperture.
    tilt = math.atan2(alt - h, x) + pitch + off * APERTURE / 2
    truth = TrackedShadow(7, x, y, h)
    r_top, r_end, az = shadow_measurement(truth, altitude_m=alt, tilt_rad=tilt, pitch_rad=pitch)
    back = shadow_from_measurement(7, top_slant_m=r_top, end_slant_m=r_end, azimuth_rad=az, altitude_m=alt,
                                   tilt_rad=tilt, pitch_rad=pitch)
    assert back.measured
    assert back.height_m == pytest.approx(h, abs=1e-9)
    assert back.along_m == pytest.approx(x, abs=1e-7)
    assert back.cross_m == pytest.approx(y, abs=1e-7)
    # The lead's formula: g_top = sqrt(r_top^2 - (H - h)^2).
    assert math.hypot(back.along_m, back.cross_m) == pytest.approx(math.sqrt(r_top**2 - (alt - h) ** 2), abs=1e-7)


def test_bad_measurements_raise() -> None:
    kw = {"azimuth_rad": 0.0, "altitude_m": 1.0, "tilt_rad": 0.3, "pitch_rad": 0.0}
    with pytest.raises(MeasurementError, match="top"):
        shadow_from_measurement(1, top_slant_m=3.0, end_slant_m=2.0, **kw)
    with pytest.raises(MeasurementError, match="altitude"):
        shadow_from_measurement(1, top_slant_m=0.5, end_slant_m=0.8, **kw)
    with pytest.raises(MeasurementError, match="non-finite"):
        shadow_from_measurement(1, top_slant_m=float("nan"), end_slant_m=2.0, **kw)


def test_shadow_from_ned_known_answer() -> None:
    # Heading east: a target 3 m east and 1 m south of the sonar is 3 m ahead, 1 m to starboard.
    s = shadow_from_ned(4, target_ned_m=(9.0, 23.0), sonar_ned_m=(10.0, 20.0), heading_rad=math.pi / 2)
    assert (s.along_m, s.cross_m) == (pytest.approx(3.0), pytest.approx(1.0))
    assert not s.measured and s.height_m is None


def test_pitch_prediction() -> None:
    cfg = pitch_config(horizon_steps=4, dt_s=0.5, pitch_rate_time_s=1.0)
    state = PitchState(altitude_m=1.0, vehicle_pitch_rad=0.02, pitch_rate_rad_s=0.1, speed_m_s=0.5,
                       current_tilt_rad=0.2)
    t = np.arange(5) * 0.5
    np.testing.assert_allclose(predict_pitch_rad(state, cfg), 0.02 + 0.1 * (1 - np.exp(-t)), atol=1e-15)
    given_pitch = dataclasses.replace(state, predicted_pitch_rad=(0.1, 0.2, 0.3, 0.4))
    np.testing.assert_allclose(predict_pitch_rad(given_pitch, cfg), [0.02, 0.1, 0.2, 0.3, 0.4])
    with pytest.raises(GeometryError, match="4 values"):
        predict_pitch_rad(dataclasses.replace(state, predicted_pitch_rad=(0.1,)), cfg)


def test_truth_visibility_agrees_with_the_band() -> None:
    """The direct-ray truth check against the closed-form interval, on the beam axis."""
    cfg = pitch_config(window_m=(0.5, 30.0))
    g = shadow_geometry(np.array([4.0]), np.array([0.0]), np.array([0.2]), np.array([0.0]), 1.0)
    lo, hi = depression_interval_rad(g, half_aperture_rad=APERTURE / 2)
    for d, expect in [(0.5 * float(lo[0] + hi[0]), True), (float(lo[0]) - 0.01, False), (float(hi[0]) + 0.01, False)]:
        assert bool(whole_shadow_visible(g, tilt_rad=d + 0.03, pitch_rad=0.03, config=cfg)[0]) is expect


def test_shadow_and_whole_intervals_are_the_two_depression_intervals(rng: np.random.Generator) -> None:
    """The serviceability check takes both depression intervals from one call (the shared
    rays once): each must be the intersection of its rays' own aperture intervals, exactly
    (top/end ray, far foot, seabed at the start range; and the near foot for the whole)."""
    along = rng.uniform(-2.0, 16.0, (7, 1)) - 0.5 * np.arange(11) * 0.2
    cross = rng.uniform(-2.0, 2.0, (7, 1))
    g = shadow_geometry(along, cross, rng.uniform(0.0, 0.4, (7, 1)), rng.uniform(0.0, 1.0, (7, 1)), np.full(11, 1.2))
    for half in (math.radians(5.0), math.radians(7.0)):
        rays = [aperture_interval_rad(g.top_along_m, g.top_cross_m, g.altitude_m - g.height_m, half_aperture_rad=half)]
        rays += [aperture_interval_rad(x, y, g.altitude_m, half_aperture_rad=half)
                 for x, y in ((g.top_along_m, g.top_cross_m), (g.start_along_m, g.start_cross_m),
                              (g.base_along_m, g.base_cross_m))]
        lo = np.maximum.reduce([r[0] for r in rays])
        hi = np.minimum.reduce([r[1] for r in rays])
        lo_s, hi_s = np.maximum.reduce([r[0] for r in rays[:3]]), np.minimum.reduce([r[1] for r in rays[:3]])
        (got_lo, got_hi), (got_lo_s, got_hi_s) = shadow_and_whole_intervals_rad(g, half_aperture_rad=half)
        for got, want in ((got_lo, lo), (got_hi, hi), (got_lo_s, lo_s), (got_hi_s, hi_s)):
            np.testing.assert_array_equal(got, want)
        for got, want in zip(depression_interval_rad(g, half_aperture_rad=half, include_base=False), (lo_s, hi_s),
                             strict=True):
            np.testing.assert_array_equal(got, want)
        assert not np.array_equal(lo, lo_s)  # the near foot matters somewhere: the test sees both
