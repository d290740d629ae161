"""Pressure to depth: hydrostatics, ArduSub's convention, round trips, bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from perception.errors import MeasurementError
from perception.navigation.pressure import (
    ARDUSUB_GRAVITY_M_S2,
    PA_PER_HPA,
    SEA_WATER_SPECIFIC_GRAVITY,
    STANDARD_ATMOSPHERE_PA,
    depth_from_pressure_m,
    pascals_per_metre,
    pressure_from_depth_pa,
    surface_pressure_from_samples_pa,
)


def test_ten_metres_of_fresh_water_is_98066_pa() -> None:
    p = STANDARD_ATMOSPHERE_PA + 1000.0 * 9.80665 * 10.0
    assert float(depth_from_pressure_m(p)) == pytest.approx(10.0, abs=1e-12)


def test_sea_water_is_denser_so_the_same_pressure_is_shallower() -> None:
    p = STANDARD_ATMOSPHERE_PA + 100_000.0
    fresh = float(depth_from_pressure_m(p))
    sea = float(depth_from_pressure_m(p, specific_gravity=SEA_WATER_SPECIFIC_GRAVITY))
    assert sea == pytest.approx(fresh / 1.024, rel=1e-12)


def test_ardusub_convention_is_9800_pa_per_metre() -> None:
    # AP_Baro (water sensors): depth = (ground_pressure - pressure) / 9800 / BARO_SPEC_GRAV
    assert pascals_per_metre(gravity_m_s2=ARDUSUB_GRAVITY_M_S2) == pytest.approx(9800.0)
    p_hpa = 1013.25 + 49.0  # SCALED_PRESSURE2.press_abs is in hPa
    depth = float(
        depth_from_pressure_m(p_hpa * PA_PER_HPA, gravity_m_s2=ARDUSUB_GRAVITY_M_S2, specific_gravity=1.0)
    )
    assert depth == pytest.approx(0.5, abs=1e-9)


@given(
    depth=st.floats(-1.0, 6000.0),
    surface=st.floats(50_000.0, 110_000.0),
    sg=st.floats(0.99, 1.05),
)
def test_round_trip(depth: float, surface: float, sg: float) -> None:
    p = pressure_from_depth_pa(depth, surface_pressure_pa=surface, specific_gravity=sg)
    back = float(depth_from_pressure_m(p, surface_pressure_pa=surface, specific_gravity=sg))
    assert back == pytest.approx(depth, abs=1e-9 * max(1.0, abs(depth)))


def test_arrays_keep_their_shape() -> None:
    p = np.full((2, 3), STANDARD_ATMOSPHERE_PA)
    assert depth_from_pressure_m(p).shape == (2, 3)


@pytest.mark.parametrize("bad", [math.nan, math.inf, -1.0, 0.0])
def test_bad_pressure_raises(bad: float) -> None:
    with pytest.raises(MeasurementError) as info:
        depth_from_pressure_m([101_325.0, bad])
    assert info.value.sensor == "pressure"


@pytest.mark.parametrize(
    "kwargs", [{"surface_pressure_pa": -1.0}, {"specific_gravity": 0.0}, {"gravity_m_s2": math.nan}]
)
def test_bad_settings_raise(kwargs: dict[str, float]) -> None:
    with pytest.raises(MeasurementError):
        depth_from_pressure_m(101_325.0, **kwargs)


def test_surface_pressure_is_the_median_of_the_samples() -> None:
    assert surface_pressure_from_samples_pa([101_000.0, 101_010.0, 150_000.0]) == 101_010.0
    with pytest.raises(MeasurementError):
        surface_pressure_from_samples_pa([])
    with pytest.raises(MeasurementError):
        surface_pressure_from_samples_pa([101_000.0, math.nan])
