"""Altitude and tilt choice: the shadow model, optimality, feasibility, refusals."""

from __future__ import annotations

import dataclasses
import math

import casadi as ca
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from perception.geometry import seabed_hit_slant_m
from planner.config import Settings, default_settings
from planner.errors import InfeasibleError
from planner.survey.altitudes import (
    _np_constraints,
    _objective_terms,
    choose_altitudes,
    constraint_values,
    shadow_length_m,
    shadow_slope,
)


@pytest.fixture(scope="module")
def defaults() -> Settings:
    return default_settings()


@pytest.fixture(scope="module")
def choice(defaults: Settings):
    return choose_altitudes(defaults)


@given(
    altitude=st.floats(0.5, 10.0),
    frac=st.floats(0.02, 0.8),
    ground=st.floats(0.5, 20.0),
)
@settings(max_examples=60, deadline=None)
def test_shadow_end_lies_on_the_ray_over_the_top_edge(altitude: float, frac: float,
                                                      ground: float) -> None:
    """Cast a ray through the target top with perception's geometry: it meets the seabed
    at r_s = r_top + L."""
    h = frac * altitude
    r_top = math.hypot(ground, altitude - h)
    depression = math.atan2(altitude - h, ground)
    r_seabed = float(seabed_hit_slant_m(0.0, 0.0, altitude_m=altitude, tilt_rad=depression))
    assert r_seabed - r_top == pytest.approx(shadow_length_m(altitude, h, ground), rel=1e-9)


@given(altitude=st.floats(0.5, 10.0), frac=st.floats(0.02, 0.8), ground=st.floats(0.5, 20.0))
@settings(max_examples=60, deadline=None)
def test_slope_is_the_derivative_in_numpy_and_casadi(altitude: float, frac: float,
                                                      ground: float) -> None:
    h = frac * altitude
    eps = 1e-6 * altitude
    fd = (shadow_length_m(altitude, h + eps, ground) - shadow_length_m(altitude, h - eps, ground)) / (
        2 * eps
    )
    assert shadow_slope(altitude, h, ground) == pytest.approx(fd, rel=1e-5)
    hs = ca.SX.sym("h")
    jac = ca.Function("j", [hs], [ca.jacobian(shadow_length_m(altitude, hs, ground, ca.sqrt), hs)])
    assert float(jac(h)) == pytest.approx(shadow_slope(altitude, h, ground), rel=1e-9)
    assert float(shadow_slope(altitude, h, ground, ca.sqrt)) == pytest.approx(
        shadow_slope(altitude, h, ground), rel=1e-12)


def test_choice_meets_every_constraint(defaults: Settings, choice) -> None:
    values = constraint_values(choice, defaults)
    assert min(values.values()) >= 0.0
    assert choice.altitude1_m >= defaults.site.target_height_max_m + defaults.vehicle.min_clearance_m
    assert choice.altitude2_m <= defaults.altitudes.altitude_max_m + 1e-9
    assert choice.delta_altitude_m >= 30 * 0.003
    assert defaults.vehicle.tilt_min_rad <= choice.tilt1_rad <= defaults.vehicle.tilt_max_rad
    assert defaults.vehicle.tilt_min_rad <= choice.tilt2_rad <= defaults.vehicle.tilt_max_rad
    # Reported resolution is consistent with the reported sensitivity.
    assert choice.height_resolution_m == pytest.approx(0.01 / choice.samples_per_cm)
    assert choice.height_std_from_dh_m == pytest.approx(0.5 * 0.003 / choice.delta_altitude_m)
    assert min(choice.pass_samples_per_cm) >= defaults.altitudes.min_pass_samples_per_cm - 1e-6


def test_tilts_centre_the_design_shadow(defaults: Settings, choice) -> None:
    """Each tilt points the beam axis at the middle of the tallest target's shadow."""
    g, h = choice.design_ground_range_m, defaults.site.target_height_max_m
    for altitude, tilt in ((choice.altitude1_m, choice.tilt1_rad),
                           (choice.altitude2_m, choice.tilt2_rad)):
        shadow_end = g * altitude / (altitude - h)  # similar triangles
        assert tilt == pytest.approx(math.atan2(altitude, (g + shadow_end) / 2), abs=1e-6)


def test_no_random_feasible_point_beats_the_optimum(defaults: Settings, choice, rng) -> None:
    """Sample the box of decision variables; every feasible sample scores no better."""
    lo = np.array([0.3, 0.0, 0.0, 0.0, 0.05])
    hi = np.array([4.0, 3.7, math.radians(60), math.radians(60), 12.0])
    xs = lo + (hi - lo) * rng.random((20000, 5))
    best = choice.samples_per_cm
    n_feasible = 0
    for x in xs:
        if x[0] + x[1] > 4.0 or min(_np_constraints(x, defaults).values()) < 0:
            continue
        n_feasible += 1
        assert min(_objective_terms(x, defaults, math.sqrt)) <= best + 1e-6
    assert n_feasible > 20


def _with(s: Settings, **changes: dict) -> Settings:
    out = s
    for table, values in changes.items():
        out = dataclasses.replace(out, **{table: dataclasses.replace(getattr(out, table), **values)})
    return out


def test_shallow_depth_limit_is_named(defaults: Settings) -> None:
    s = _with(defaults, vehicle={"max_depth_m": 10.0})  # seabed 25 m: altitude >= 15 m needed
    with pytest.raises(InfeasibleError) as info:
        choose_altitudes(s)
    assert "depth_limit" in info.value.reason
    assert "vehicle.max_depth_m" in info.value.reason


def test_short_window_is_named(defaults: Settings) -> None:
    s = _with(defaults, sonar={"window_end_m": 1.6})
    with pytest.raises(InfeasibleError) as info:
        choose_altitudes(s)
    assert "window_end" in info.value.reason


def test_dh_range_too_narrow_is_named(defaults: Settings) -> None:
    s = _with(defaults, altitudes={"altitude_min_m": 3.95, "altitude_max_m": 4.0})
    with pytest.raises(InfeasibleError, match="dh_vs_filter"):
        choose_altitudes(s)


def test_taller_targets_need_more_clearance(defaults: Settings, choice) -> None:
    s = _with(defaults, site={"target_height_max_m": 1.0})
    taller = choose_altitudes(s)
    assert taller.altitude1_m >= 2.0 - 1e-9
    assert taller.altitude1_m > choice.altitude1_m
