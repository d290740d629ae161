"""OnboardPerception keeps the filter's answers for a time until the filter changes
(``_ask``): every answer must be the one a perception that never asked before gives."""

from __future__ import annotations

import math

from planner.mission.onboard import OnboardConfig, OnboardPerception
from vehicle_link.telemetry import GlobalPosition, Rangefinder


def _records(k: int) -> list[object]:
    t = 10.0 + 0.2 * k
    depth = 3.0 + 0.01 * k
    return [GlobalPosition(t, t, 43.0, 5.0, -depth, depth, 0.0, 0.0, 0.0, 0.0),
            Rangefinder(t, "DISTANCE_SENSOR", 0, 2.0 - 0.005 * k + 0.02 * (k % 3), 0.2, 50.0, 25, 100, True)]


def _answers(onboard: OnboardPerception, t: float) -> list[float]:
    return [*onboard.altitude(t), *onboard.depth(t), *onboard.seabed_depth(t)]


def _same(a: list[float], b: list[float]) -> bool:
    return all((math.isnan(x) and math.isnan(y)) or x == y for x, y in zip(a, b, strict=True))


def test_remembered_answers_are_the_filters_own() -> None:
    asked, fresh_records = OnboardPerception(OnboardConfig()), []
    try:
        assert _same(_answers(asked, 10.0), [math.nan] * 6)  # nothing known yet: NaN, remembered as NaN
        for k in range(30):
            for record in _records(k):
                asked.listener(record)
            fresh_records += _records(k)
            asked.drain()
            now = 10.0 + 0.2 * k
            if k % 7 == 3:
                asked.ground_track_changed()
            if k == 12:
                asked.expect_vertical_motion(True)
            first = [_answers(asked, t) for t in (now, now - 0.1, now + 0.05, 11.0)]
            again = [_answers(asked, t) for t in (now, now - 0.1, now + 0.05, 11.0)]
            fresh = OnboardPerception(OnboardConfig())
            try:
                for j, record in enumerate(fresh_records):
                    fresh.listener(record)
                    fresh.drain()
                    if j % 2 == 1 and (j // 2) % 7 == 3:
                        fresh.ground_track_changed()
                    if j == 25:
                        fresh.expect_vertical_motion(True)
                expected = [_answers(fresh, t) for t in (now, now - 0.1, now + 0.05, 11.0)]
            finally:
                fresh.close()
            assert all(_same(a, e) for a, e in zip(first, expected, strict=True)), k
            assert all(_same(a, e) for a, e in zip(again, expected, strict=True)), k
            assert math.isfinite(first[0][0])
    finally:
        asked.close()
