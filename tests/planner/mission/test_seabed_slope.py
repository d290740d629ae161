"""The seabed's slope from the filter's seabed depths along the track, and the rise the
helm leads by (:mod:`planner.mission.seabed_slope`)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from planner.mission.seabed_slope import MIN_SPAN_M, SeabedSlope


def fly(slope: SeabedSlope, *, grad_north: float, grad_east: float, heading_rad: float, length_m: float,
        start=(0.0, 0.0), noise_m: float = 0.0, seed: int = 0, std_m: float = 0.02) -> tuple[float, float]:
    """Samples every 0.1 m along a straight track over the plane depth = 10 + g . (n, e)."""
    rng = np.random.default_rng(seed)
    n = e = 0.0
    for k in range(int(length_m / 0.1) + 1):
        n = start[0] + 0.1 * k * math.cos(heading_rad)
        e = start[1] + 0.1 * k * math.sin(heading_rad)
        depth = 10.0 + grad_north * n + grad_east * e + noise_m * rng.standard_normal()
        slope.add(n, e, depth, std_m)
    return n, e


def test_the_slope_along_a_lane_is_recovered_and_across_it_stays_level() -> None:
    s = SeabedSlope()
    fly(s, grad_north=-math.tan(math.radians(3.0)), grad_east=0.05, heading_rad=0.0, length_m=6.0)
    got = s.slope()
    assert got is not None
    assert got.north == pytest.approx(-math.tan(math.radians(3.0)), abs=0.005)  # along the lane: the samples
    assert abs(got.east) < 1e-6 and got.east_std == pytest.approx(0.1, rel=0.01)  # across it: the level prior


def test_a_second_lane_beside_the_first_gives_the_slope_across() -> None:
    s = SeabedSlope()
    end = fly(s, grad_north=0.02, grad_east=-0.04, heading_rad=0.0, length_m=2.0)
    fly(s, grad_north=0.02, grad_east=-0.04, heading_rad=math.pi, length_m=2.0, start=(end[0], end[1] + 1.0))
    got = s.slope()
    assert got is not None
    assert got.north == pytest.approx(0.02, abs=0.003) and got.east == pytest.approx(-0.04, abs=0.003)


def test_only_a_rising_seabed_is_led() -> None:
    rising, falling, level = SeabedSlope(), SeabedSlope(), SeabedSlope()
    tan3 = math.tan(math.radians(3.0))
    fly(rising, grad_north=-tan3, grad_east=0.0, heading_rad=0.0, length_m=5.0)  # shallower northwards
    fly(falling, grad_north=tan3, grad_east=0.0, heading_rad=0.0, length_m=5.0)
    fly(level, grad_north=0.0, grad_east=0.0, heading_rad=0.0, length_m=5.0, noise_m=0.01, seed=3)
    # Flying on north at 0.5 m/s for 3 s: 1.5 m of a 3 deg rise is 7.9 cm, less one sigma
    # of the slope (about 1.3 cm from samples of 2 cm, one independent per metre).
    sigma = rising.slope().north_std
    assert 0.005 < sigma < 0.015
    assert rising.rise_ahead_m(0.5, 0.0, 3.0) == pytest.approx(1.5 * (tan3 - sigma), abs=0.002)
    assert falling.rise_ahead_m(0.5, 0.0, 3.0) == 0.0
    assert rising.rise_ahead_m(-0.5, 0.0, 3.0) == 0.0  # turned back: the seabed falls away
    assert level.rise_ahead_m(0.5, 0.0, 3.0) < 0.01
    assert rising.rise_ahead_m(0.0, 0.0, 3.0) == 0.0  # stopped
    assert rising.rise_ahead_m(0.5, 0.0, 0.0) == 0.0  # no lead


def test_too_short_a_track_and_bad_samples_give_no_slope() -> None:
    s = SeabedSlope()
    fly(s, grad_north=-0.1, grad_east=0.0, heading_rad=0.0, length_m=0.5 * MIN_SPAN_M)
    assert s.slope() is None and s.rise_ahead_m(0.5, 0.0, 3.0) == 0.0
    s.add(math.nan, 0.0, 10.0, 0.02)
    s.add(0.0, 0.0, math.inf, 0.02)
    assert s.slope() is None
    with pytest.raises(ValueError):
        SeabedSlope(span_m=0.5)


@settings(max_examples=60, deadline=None)
@given(slope_deg=st.floats(2.0, 8.0), heading_deg=st.floats(0.0, 360.0), seed=st.integers(0, 10_000))
def test_the_rise_ahead_never_exceeds_the_true_rise_by_more_than_the_noise(slope_deg: float, heading_deg: float,
                                                                         seed: int) -> None:
    """Up a plane of 2-8 deg in any direction, with 1 cm of noise on the seabed depths: the
    lead is at most the true rise plus a centimetre, and short of it by at most three
    sigmas of the slope (one is held back, two for the noise)."""
    s = SeabedSlope()
    heading = math.radians(heading_deg)
    tan = math.tan(math.radians(slope_deg))
    # The seabed rises along the heading: depth falls by tan per metre flown.
    fly(s, grad_north=-tan * math.cos(heading), grad_east=-tan * math.sin(heading), heading_rad=heading,
        length_m=6.0, noise_m=0.01, seed=seed)
    true_rise = tan * 0.5 * 3.0
    lead = s.rise_ahead_m(0.5 * math.cos(heading), 0.5 * math.sin(heading), 3.0)
    assert lead <= true_rise + 0.01
    sigma = math.hypot(s.slope().north_std * math.cos(heading), s.slope().east_std * math.sin(heading))
    assert lead >= 0.5 * 3.0 * (tan - 3.0 * sigma)
