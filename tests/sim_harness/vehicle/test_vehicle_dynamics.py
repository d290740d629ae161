"""Vehicle model: numpy, plain floats and casadi agree; physical facts of thrust, drag, buoyancy, current."""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sim_harness.errors import SimConfigError
from sim_harness.vehicle.dynamics import (
    MountMechanics,
    RovParams,
    UniformCurrent,
    derivative,
    rate_terms,
    saturate_thrust,
    slew_tilt,
    step_rk4,
)

P = RovParams()
finite = st.floats(-3.0, 3.0, allow_nan=False)


def _casadi_derivative() -> ca.Function:
    """The model's rates written once in casadi's algebra (``rate_terms``), as a Function."""
    x, tau, cur = ca.SX.sym("x", 8), ca.SX.sym("tau", 4), ca.SX.sym("current", 3)
    rates = rate_terms([x[i] for i in range(8)], [tau[i] for i in range(4)], [cur[i] for i in range(3)], P,
                       ca.sin, ca.cos, ca.fabs)
    return ca.Function("rates", [x, tau, cur], [ca.vertcat(*rates)])


CASADI_RATES = _casadi_derivative()


@settings(max_examples=200, deadline=None)
@given(state=st.lists(finite, min_size=8, max_size=8),
       thrust=st.lists(st.floats(-200.0, 200.0), min_size=4, max_size=4),
       current=st.lists(finite, min_size=3, max_size=3))
def test_numpy_float_and_casadi_rates_agree(state, thrust, current):
    """The same rates in numpy (``derivative``, which also saturates the thrust), in plain
    floats (``math``, as ``step_rk4`` evaluates them) and in casadi's symbolic algebra."""
    expected = derivative(np.array(state), np.array(thrust), np.array(current), P)
    tau = saturate_thrust(thrust, P)
    floats = np.array(rate_terms(state, tau, current, P, math.sin, math.cos, abs))
    symbolic = np.array(CASADI_RATES(state, tau, current)).ravel()
    assert floats == pytest.approx(expected, rel=1e-12, abs=1e-12)
    assert symbolic == pytest.approx(expected, rel=1e-12, abs=1e-12)


def _steady(thrust, current=(0.0, 0.0, 0.0), seconds=60.0):
    x = (0.0, 0.0, 10.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    for _ in range(int(seconds / 0.02)):
        x = step_rk4(x, thrust, current, 0.02, P)
    return x


def test_full_surge_reaches_the_speed_where_thrust_equals_drag():
    x = _steady((P.max_surge_n, 0.0, P.net_buoyancy_n, 0.0))
    u = x[4]
    assert P.drag_lin_surge * u + P.drag_quad_surge * u * u == pytest.approx(P.max_surge_n, rel=1e-3)
    # Thrust beyond the limit is clipped: the same top speed.
    x2 = _steady((10 * P.max_surge_n, 0.0, P.net_buoyancy_n, 0.0))
    assert x2[4] == pytest.approx(u, rel=1e-9)


def test_unpowered_vehicle_floats_up_and_drifts_with_the_current():
    x = _steady((0.0, 0.0, 0.0, 0.0), current=(0.3, -0.1, 0.0), seconds=60.0)
    assert x[6] < 0.0  # rising (down velocity negative)
    assert x[2] < 10.0
    # After a minute it moves with the water.
    assert x[4] == pytest.approx(0.3, abs=1e-3)
    assert x[5] == pytest.approx(-0.1, abs=1e-3)


def test_yaw_rate_turns_the_body_velocity_into_the_ned_frame():
    x = (0.0, 0.0, 5.0, math.pi / 2, 1.0, 0.0, 0.0, 0.0)  # facing east, moving forward
    d = derivative(np.array(x), np.zeros(4), np.zeros(3), P)
    assert d[0] == pytest.approx(0.0, abs=1e-12)
    assert d[1] == pytest.approx(1.0)


def test_mount_slews_at_its_rate_and_stops_at_its_limit():
    lim = MountMechanics(max_rate_rad_s=math.radians(10.0))
    tilt = 0.0
    for _ in range(50):  # 1 s
        tilt = slew_tilt(tilt, math.radians(200.0), 0.02, lim)
    assert tilt == pytest.approx(math.radians(10.0))
    for _ in range(2000):
        tilt = slew_tilt(tilt, math.radians(200.0), 0.02, lim)
    assert tilt == pytest.approx(lim.max_tilt_rad)


def test_bad_shapes_and_params_are_refused():
    with pytest.raises(ValueError, match="state"):
        derivative(np.zeros(7), np.zeros(4), np.zeros(3))
    with pytest.raises(SimConfigError, match="mass_surge_kg"):
        RovParams(mass_surge_kg=0.0)
    with pytest.raises(SimConfigError):
        MountMechanics(min_tilt_rad=1.0, max_tilt_rad=0.5)
    assert UniformCurrent(0.1).velocity_ned_m_s(0, 0, 0, 0) == (0.1, 0.0, 0.0)
