"""A rounded top's summit from where its echo starts (perception.heights.rounded.summit_from_near_echo).

The ranges are worked out here from the half-ellipse itself, independently of the
function's own parametrisation: the tangent from the sonar by root finding on the
ellipse's angle, the echo's start by a dense search of the whole upper half for the point
nearest the sonar."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from scipy.optimize import brentq

from perception.heights.rounded import summit_from_near_echo


def ranges_of_half_ellipse(altitude_m: float, centre_m: float, half_length_m: float,
                           height_m: float) -> tuple[float, float, float]:
    """(echo start, far top edge, shadow end) slant ranges of the half-ellipse
    ``((x - centre) / a)^2 + (z / c)^2 = 1, z >= 0`` seen by a sonar at (0, altitude)."""
    a, c, h, xc = half_length_m, height_m, altitude_m, centre_m

    # The ray from the sonar grazing the far side: (P - S) x P' = 0 for P = (xc + a cos p, c sin p),
    # i.e. c xc cos p + a c - a h sin p = 0, on (0, pi/2).
    def tangency(p: float) -> float:
        return c * xc * math.cos(p) + a * c - a * h * math.sin(p)

    p = brentq(tangency, 1e-12, 0.5 * math.pi)
    x_t, z_t = xc + a * math.cos(p), c * math.sin(p)
    r_top = math.hypot(x_t, h - z_t)
    r_end = r_top * h / (h - z_t)  # where the ray reaches the seabed
    q = np.linspace(0.0, math.pi, 400_001)
    r_near = float(np.min(np.hypot(xc - a * np.cos(q), c * np.sin(q) - h)))
    return r_near, r_top, r_end


@settings(max_examples=60, deadline=None)
@given(
    altitude=st.floats(0.4, 4.0),
    ground=st.floats(0.5, 8.0),
    height=st.floats(0.01, 0.5),
    aspect=st.floats(0.2, 5.0),
)
def test_the_summit_and_length_of_a_half_ellipse_come_back(altitude: float, ground: float, height: float,
                                                          aspect: float) -> None:
    half_length = aspect * height
    assume(ground - half_length > 0.05 and height < 0.3 * altitude)
    depression = math.atan2(altitude, ground)
    assume(math.radians(5.0) < depression < math.radians(60.0))
    near, top, end = ranges_of_half_ellipse(altitude, ground, half_length, height)
    found = summit_from_near_echo(altitude, near, top, end)
    # The aspects are searched on a grid and interpolated: well inside the range noise.
    assert found.height_m == pytest.approx(height, rel=2e-3, abs=2e-5)
    assert found.half_length_m == pytest.approx(half_length, rel=5e-3, abs=1e-4)


def test_the_summit_lies_above_the_grazing_point_and_more_so_for_a_steeper_ray() -> None:
    # A hemisphere of 10 cm seen from 1 m and from 2 m altitude, 2 m away.
    lows = []
    for altitude in (1.0, 2.0):
        near, top, end = ranges_of_half_ellipse(altitude, 2.0, 0.1, 0.1)
        grazing = altitude * (1.0 - top / end)
        assert grazing < 0.1
        lows.append(0.1 - grazing)
        assert summit_from_near_echo(altitude, near, top, end).height_m == pytest.approx(0.1, rel=2e-3)
    assert lows[1] > lows[0] > 0.0


def test_an_echo_that_starts_at_the_edge_is_a_sharp_edge() -> None:
    found = summit_from_near_echo(1.0, 2.0, 2.0, 2.1)
    assert found.height_m == pytest.approx(1.0 * (1.0 - 2.0 / 2.1))
    assert found.half_length_m == 0.0


@pytest.mark.parametrize(
    ("altitude", "near", "top", "end"),
    [
        (1.0, 1.9, 2.1, 2.0),  # the shadow ends before it starts
        (1.0, 0.5, 0.9, 2.0),  # the far top edge nearer than the altitude
        (1.0, math.nan, 2.0, 2.1),
        (1.0, 0.2, 2.0, 2.1),  # the echo starts further forward than any body grazed there can
    ],
)
def test_ranges_that_give_no_body_give_nan(altitude: float, near: float, top: float, end: float) -> None:
    found = summit_from_near_echo(altitude, near, top, end)
    assert math.isnan(found.height_m) and math.isnan(found.half_length_m)
