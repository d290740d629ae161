"""The streamed GUIDED setpoints: a point moving along the leg (rest to rest, within the
survey speed and the acceleration, never further ahead of the vehicle than the lead
limit) and the depth ramp (at most the vertical speed, arriving at rest)."""

from __future__ import annotations

import math

import pytest

from planner.mission.setpoints import DepthRamp, LegSetpoint

DT_S = 0.2


def test_leg_runs_rest_to_rest_within_speed_and_acceleration():
    leg = LegSetpoint((0.0, 0.0), (6.0, 8.0), speed_m_s=0.5, accel_m_s2=1.0, lead_limit_m=10.0)
    speeds, points = [], []
    while not leg.finished:
        sp = leg.advance(DT_S, None)
        speeds.append(math.hypot(sp.vel_north_m_s, sp.vel_east_m_s))
        points.append((sp.north_m, sp.east_m))
        assert len(speeds) < 1000
    assert max(speeds) == pytest.approx(0.5)
    steps = list(zip(speeds, speeds[1:], strict=False))
    assert all(abs(b - a) <= 1.0 * DT_S + 1e-9 for a, b in steps[:-1])
    assert points[-1] == pytest.approx((6.0, 8.0)) and speeds[-1] == 0.0
    assert speeds[-2] <= 2.0 * 1.0 * DT_S + 1e-9  # arriving: the last step lands on the end
    assert all(abs(n * 8.0 - e * 6.0) < 1e-9 for n, e in points)  # on the leg's line
    assert len(speeds) * DT_S == pytest.approx(10.0 / 0.5 + 0.5, abs=0.6)  # length / speed + speed / accel


def test_leg_waits_for_a_vehicle_held_back():
    leg = LegSetpoint((0.0, 0.0), (10.0, 0.0), speed_m_s=0.5, accel_m_s2=1.0, lead_limit_m=1.0)
    for _ in range(50):
        sp = leg.advance(DT_S, (0.0, 0.0))  # the vehicle does not move
    assert sp.north_m <= 1.0 + 0.5 * DT_S and sp.vel_north_m_s == 0.0


def test_depth_ramp_moves_at_most_the_vertical_speed_and_arrives_at_rest():
    ramp = DepthRamp(0.0, vertical_speed_m_s=0.5, accel_m_s2=0.25)
    rates = []
    for _ in range(200):
        depth, rate = ramp.advance(DT_S, 5.0)
        rates.append(rate)
    assert depth == pytest.approx(5.0) and rates[-1] == 0.0
    assert max(rates) <= 0.5 + 1e-9
    assert all(abs(b - a) <= 0.25 * DT_S + 1e-9 for a, b in zip(rates, rates[1:], strict=False) if b != 0.0)
    depth, rate = ramp.advance(DT_S, 4.0)  # back up: a negative rate
    assert depth < 5.0 and rate < 0.0
