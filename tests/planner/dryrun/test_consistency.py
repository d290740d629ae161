"""A scenario's files against one another (``planner.dryrun.consistency``): the area near the
vehicle's start, every target inside the area."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from planner.dryrun.consistency import check_consistent
from planner.dryrun.dive import prepare_dry_dive
from planner.dryrun.scenario import BUILTIN_SCENARIOS, load_scenario
from planner.errors import ConfigError
from tests.conftest import REPO_ROOT

COMPACT = REPO_ROOT / "tests" / "whole_loop" / "data" / "compact"


@pytest.mark.parametrize("source", [*BUILTIN_SCENARIOS, str(COMPACT)])
def test_the_shipped_scenarios_agree(source: str) -> None:
    check_consistent(prepare_dry_dive(load_scenario(source)))


def _compact(tmp_path: Path, old: str, new: str) -> Path:
    site = tmp_path / "compact"
    shutil.copytree(COMPACT, site)
    scene = site / "scene.toml"
    text = scene.read_text(encoding="utf-8")
    assert old in text
    scene.write_text(text.replace(old, new, 1), encoding="utf-8")
    return site


def test_a_target_outside_the_area_is_named(tmp_path: Path) -> None:
    site = _compact(tmp_path, "north_m = 1.8\neast_m = 0.3", "north_m = 1.8\neast_m = 4.3")
    with pytest.raises(ConfigError) as info:
        check_consistent(prepare_dry_dive(load_scenario(site)))
    assert info.value.key == "targets[2]" and info.value.path == str(site / "scene.toml")
    assert "'T3'" in str(info.value) and "outside the survey area" in str(info.value)


def test_a_target_on_the_boundary_is_inside(tmp_path: Path) -> None:
    prepared = prepare_dry_dive(load_scenario(COMPACT))
    west = prepared.area.outer.bounds[0]
    site = _compact(tmp_path, "north_m = 1.8\neast_m = 0.3", f"north_m = 1.8\neast_m = {west!r}")
    check_consistent(prepare_dry_dive(load_scenario(site)))


def test_an_origin_far_from_the_area_is_named(tmp_path: Path) -> None:
    # 0.05 deg of latitude: the area (in degrees) lies about 5.6 km south of the moved origin and the start
    site = _compact(tmp_path, "lat_deg = 43.2951", "lat_deg = 43.3451")
    with pytest.raises(ConfigError) as info:
        check_consistent(prepare_dry_dive(load_scenario(site)))
    assert info.value.key == "origin" and info.value.path == str(site / "scene.toml")
    assert "5.6 km from the vehicle's start" in str(info.value)
