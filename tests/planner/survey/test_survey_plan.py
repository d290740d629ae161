"""plan.json: the SurveyPlan round-trips exactly; foreign documents are refused."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from planner.survey.plan import (
    LaneRun,
    PlanSummary,
    PlanWaypoint,
    SurveyPass,
    SurveyPlan,
    load_plan,
)


def _plan() -> SurveyPlan:
    wps = (
        PlanWaypoint(1.0, 2.0, 43.1, 5.2, 1.5, 23.5, "lane_start", 0),
        PlanWaypoint(11.0, 2.0, 43.2, 5.2, 1.5, 23.5, "lane_end", 0),
        PlanWaypoint(12.5, 4.0, 43.3, 5.3, 1.5, 23.5, "transit", -1),
    )
    run = LaneRun(0, 1.0, 2.0, 11.0, 2.0)
    p = SurveyPass("pass1", 1.5, 23.5, 0.2, 4.0, 11.0, 2.5, 4.0, 4.2, (run,), wps, 12.0, 30.0,
                   0.995, 3.0, 4.1)
    s = PlanSummary(100.0, 1.2, 2.1, 1, 1, 12.0, 30.0, 0.5, 0.995, False, 4.1, 3.6, 0.0027,
                    0.0006, ("clearance",))
    return SurveyPlan(43.0, 5.0, 25.0, (p,), s)


def test_round_trip_is_exact() -> None:
    plan = _plan()
    again = SurveyPlan.from_json(plan.to_json())
    assert again == plan
    assert again.passes[0].runs[0].heading_rad == pytest.approx(0.0)
    assert again.passes[0].runs[0].length_m == pytest.approx(10.0)


def test_foreign_documents_are_refused() -> None:
    doc = json.loads(_plan().to_json())
    with pytest.raises(ValueError, match="not a shadowsurvey plan"):
        SurveyPlan.from_json(json.dumps({**doc, "format": "other"}))
    with pytest.raises(ValueError, match="version"):
        SurveyPlan.from_json(json.dumps({**doc, "version": 99}))
    del doc["passes"][0]["tilt_rad"]
    with pytest.raises(ValueError, match="tilt_rad"):
        SurveyPlan.from_json(json.dumps(doc))
    with pytest.raises(ValueError, match="not valid JSON"):
        SurveyPlan.from_json("{")


def test_figures_not_computed_survive_as_nan() -> None:
    import dataclasses
    import math

    plan = _plan()
    p = dataclasses.replace(plan.passes[0], coverage_fraction=math.nan)
    nan_plan = dataclasses.replace(plan, passes=(p,))
    text = nan_plan.to_json()
    assert "NaN" not in text
    again = SurveyPlan.from_json(text)
    assert math.isnan(again.passes[0].coverage_fraction)
    assert again.passes[0].runs == plan.passes[0].runs


def test_load_plan_from_folder_or_file(tmp_path: Path) -> None:
    plan = _plan()
    (tmp_path / "plan.json").write_text(plan.to_json(), encoding="utf-8")
    assert load_plan(tmp_path) == plan
    assert load_plan(tmp_path / "plan.json") == plan
    with pytest.raises(ValueError, match="cannot read plan"):
        load_plan(tmp_path / "nothing")
    (tmp_path / "bad.json").write_text("{}", encoding="utf-8")
    with pytest.raises(ValueError, match="bad.json: not a shadowsurvey plan"):
        load_plan(tmp_path / "bad.json")
