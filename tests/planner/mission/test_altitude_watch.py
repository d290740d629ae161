"""Altitude warnings: below the pass by more than 3 filter sigma, or below the clearance (known answers)."""

from __future__ import annotations

import math

from planner.mission.altitude_watch import AltitudeLimits, AltitudeWatch, replay

LIMITS = AltitudeLimits(pass_altitudes_m=(0.5, 1.0), min_altitude_m=0.4)
STATES = [(0.0, "DESCEND"), (10.0, "PASS_1"), (20.0, "ALTITUDE_CHANGE"), (25.0, "PASS_2"), (40.0, "FINISH")]


def _run(profile: list[tuple[float, float, float]]) -> tuple[list[tuple[float, str, str, dict]], AltitudeWatch]:
    watch = AltitudeWatch(LIMITS)
    return replay(watch, profile, STATES), watch


def test_within_three_sigma_of_the_pass_is_no_warning() -> None:
    events, watch = _run([(t, 0.5 - 0.029, 0.01) for t in (11.0, 12.0, 13.0)])
    assert events == [] and watch.excursions == []


def test_an_overshoot_in_the_descent_warns_once_with_its_lowest_point() -> None:
    profile = [(t, a, 0.01) for t, a in ((5.0, 0.8), (6.0, 0.46), (6.5, 0.45), (7.0, 0.44), (8.0, 0.5), (9.0, 0.5),
                                         (11.0, 0.5))]
    events, watch = _run(profile)
    warnings = [e for e in events if e[1] == "warning"]
    assert [(e[0], e[3]["check"]) for e in warnings] == [(6.0, "altitude_pass")]
    (ex,) = watch.excursions
    assert (ex.check, ex.state, ex.lowest_m, ex.lowest_s, ex.end_s) == ("pass", "DESCEND", 0.44, 7.0, 8.0)
    assert math.isclose(ex.limit_m, 0.47)
    assert [e[1] for e in events] == ["warning", "info"]  # and one line when it is over


def test_below_the_clearance_in_any_state_and_both_checks_at_once() -> None:
    events, watch = _run([(12.0, 0.35, 0.01), (13.0, 0.38, 0.01), (30.0, 1.0, 0.01)])
    assert sorted(ex.check for ex in watch.excursions) == ["clearance", "pass"]
    clearance = next(ex for ex in watch.excursions if ex.check == "clearance")
    assert (clearance.lowest_m, clearance.state, clearance.limit_m) == (0.35, "PASS_1", 0.4)
    assert sum(e[1] == "warning" for e in events) == 2


def test_altitude_change_is_held_to_the_lower_pass() -> None:
    _, watch = _run([(21.0, 0.6, 0.01), (22.0, 0.45, 0.01)])
    (ex,) = watch.excursions
    assert ex.state == "ALTITUDE_CHANGE" and math.isclose(ex.limit_m, 0.47)


def test_an_excursion_open_at_the_end_is_closed_there() -> None:
    watch = AltitudeWatch(LIMITS, source="truth")
    events = replay(watch, [(12.0, 0.3, 0.01), (13.0, 0.3, 0.01)], STATES)
    assert events[-1][1] == "info" and watch.excursions[0].end_s == 13.0
    assert "true altitude (simulator)" in events[0][2]
