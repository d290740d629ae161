"""``shadowsurvey plan``: the whole command on the shipped example, and its errors."""

from __future__ import annotations

import json
from importlib import resources
from pathlib import Path

import pytest

from planner.cli import main
from planner.config import default_settings_text
from planner.survey.plan import SurveyPlan

EXAMPLE = str(resources.files("planner").joinpath("data", "example_area.geojson"))


@pytest.mark.slow
def test_plan_writes_everything(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "run"
    assert main(["plan", EXAMPLE, "--out", str(out), "--lane-heading-deg", "90"]) == 0
    names = {p.name for p in out.iterdir()}
    assert {"plan.json", "survey.plan", "survey.waypoints", "survey.geojson", "summary.txt",
            "survey.png"} <= names
    plan = SurveyPlan.from_json((out / "plan.json").read_text())
    assert len(plan.passes) == 2
    assert plan.summary.coverage_fraction >= 0.99
    assert (out / "survey.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    printed = capsys.readouterr().out
    assert "height resolution" in printed and "pass2" in printed


def test_stay_inside_and_origin(tmp_path: Path) -> None:
    out = tmp_path / "inside"
    code = main(["plan", EXAMPLE, "--out", str(out), "--stay-inside", "--no-plot",
                 "--origin", "43.295,5.36", "--lane-heading-deg", "0"])
    assert code == 0
    plan = SurveyPlan.from_json((out / "plan.json").read_text())
    assert plan.summary.stay_inside
    assert (plan.origin_lat_deg, plan.origin_lon_deg) == (43.295, 5.36)
    assert all(p.max_excursion_m < 1e-6 for p in plan.passes)
    # Kept inside, the lanes still sweep the example area (a sliver at its edges aside).
    assert plan.summary.coverage_fraction >= 0.99
    assert all(p.coverage_fraction >= 0.99 for p in plan.passes)


def test_bad_inputs_exit_2_naming_the_problem(tmp_path: Path,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    cfg = tmp_path / "s.toml"
    cfg.write_text(default_settings_text().replace("speed_m_s = 0.5", "speed_m_s = -1"),
                   encoding="utf-8")
    assert main(["plan", EXAMPLE, "--config", str(cfg), "--out", str(tmp_path / "o")]) == 2
    assert "vehicle.speed_m_s" in capsys.readouterr().err
    shallow = tmp_path / "shallow.toml"
    shallow.write_text(default_settings_text().replace("max_depth_m = 100.0", "max_depth_m = 5.0"),
                       encoding="utf-8")
    assert main(["plan", EXAMPLE, "--config", str(shallow), "--out", str(tmp_path / "o")]) == 2
    assert "depth_limit" in capsys.readouterr().err
    area = tmp_path / "a.geojson"
    area.write_text(json.dumps({"type": "Point", "coordinates": [0, 0]}), encoding="utf-8")
    assert main(["plan", str(area), "--out", str(tmp_path / "o")]) == 2
    assert str(area) in capsys.readouterr().err
    assert main(["plan", EXAMPLE, "--out", str(tmp_path / "o"), "--origin", "x"]) == 2
