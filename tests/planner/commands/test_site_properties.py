"""Property tests of ``shadowsurvey site``: any options and areas, and a written site's scene damaged.

Any depth, slope and rectangle anywhere on the Earth either writes a folder that plans as
written, with the scene's origin the area's own, or exits 2 with one line naming the
option or the file; a written scene.toml damaged as a user might damage it is refused by
``sim`` the same way, or reaches the dive (tests/fuzz.py).
"""

from __future__ import annotations

import math
import shutil
import tempfile
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from planner.dryrun.consistency import check_consistent
from planner.dryrun.dive import prepare_dry_dive
from planner.dryrun.scenario import load_scenario
from sim_harness.sonar.scene import load_scene
from tests.fuzz import assert_contract, check_reader, mutated_toml, run_cli
from tests.planner.commands.test_site import rectangle, uncomment_examples, write_area

_CHECKS = [HealthCheck.too_slow, HealthCheck.function_scoped_fixture]
FEW = settings(max_examples=25, deadline=None, suppress_health_check=_CHECKS)
FAST = settings(max_examples=30, deadline=None, suppress_health_check=_CHECKS)
SOAK = settings(max_examples=300, deadline=None, suppress_health_check=_CHECKS)

_NUMBERS = st.floats(allow_nan=True, allow_infinity=True).map(repr) | st.sampled_from(("", "abc", "1e999", "-0"))


@st.composite
def site_options(draw: Any) -> tuple[dict[str, Any], list[str]]:
    """A rectangle somewhere (its GeoJSON) and the options: mostly sensible, sometimes anything."""
    area = rectangle(draw(st.floats(1.5, 25.0)), draw(st.floats(1.5, 25.0)),
                     lat=draw(st.floats(-75.0, 75.0)), lon=draw(st.floats(-179.9, 179.9)))

    def number(lo: float, hi: float) -> str:  # in the range four times in five, else anything
        return repr(draw(st.floats(lo, hi))) if draw(st.integers(0, 4)) else draw(_NUMBERS)

    options = [f"--depth-m={number(2.0, 300.0)}"]
    if draw(st.booleans()):
        options.append(f"--slope-deg={number(0.0, 10.0)}")
        if draw(st.integers(0, 5)):  # now and then without its direction
            options.append(f"--slope-direction-deg={number(-360.0, 360.0)}")
    return area, options


def _site_case(area_doc: dict[str, Any], options: list[str]) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        area = write_area(Path(tmp), area_doc)
        folder = Path(tmp) / "site"
        code, _, err = run_cli(["site", str(folder), "--area", str(area), *options])
        assert_contract(code, err, [str(area), "--depth-m", "--slope-deg", "--slope-direction-deg", "--area"])
        if code == 2:
            assert not folder.exists()
            return
        prepared = prepare_dry_dive(load_scenario(folder))
        check_consistent(prepared)
        assert prepared.area.outer.contains(prepared.area.outer.centroid)
        west, south, east, north = prepared.area.outer.bounds
        assert math.isclose(west, -east, abs_tol=1e-3) and math.isclose(south, -north, abs_tol=1e-3)
        depth = float(options[0].split("=", 1)[1])
        assert prepared.scene.world.seabed.depth_m == depth == prepared.settings.site.water_depth_m


@FEW
@given(case=site_options())
def test_any_options_write_a_site_that_plans_or_are_named(case: tuple[dict[str, Any], list[str]]) -> None:
    _site_case(*case)


@pytest.fixture(scope="module")
def site_text(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, str]:
    """A written 6 m x 4 m site at 6 m, its example targets uncommented: the folder and its scene's text."""
    tmp = tmp_path_factory.mktemp("site")
    folder = tmp / "site"
    code, _, err = run_cli(["site", str(folder), "--area", str(write_area(tmp, rectangle(6.0, 4.0))),
                            "--depth-m", "6"])
    assert code == 0, err
    uncomment_examples(folder / "scene.toml")
    return folder, (folder / "scene.toml").read_text(encoding="utf-8")


def _scene_case(site: tuple[Path, str], text: str, flown: list[Any]) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / "site"
        shutil.copytree(site[0], folder)
        scene = folder / "scene.toml"
        scene.write_text(text, encoding="utf-8")
        check_reader(load_scene, scene)
        before = len(flown)
        code, _, err = run_cli(["sim", str(folder), "--out", str(Path(tmp) / "run"), "--no-progress"])
        if len(flown) > before:  # a valid site: the (stubbed) dive was reached
            assert code == 130
            return
        assert_contract(code, err, [str(scene), str(folder / "area.geojson")])


@FAST
@given(data=st.data())
def test_a_damaged_site_scene_is_named(site_text: tuple[Path, str], no_dive: list[Any], data: Any) -> None:
    _scene_case(site_text, data.draw(mutated_toml(site_text[1])), no_dive)


@pytest.mark.soak
@SOAK
@given(data=st.data())
def test_soak_damaged_site_scenes(site_text: tuple[Path, str], no_dive: list[Any], data: Any) -> None:
    _scene_case(site_text, data.draw(mutated_toml(site_text[1])), no_dive)


@pytest.mark.soak
@SOAK
@given(case=site_options())
def test_soak_site_options(case: tuple[dict[str, Any], list[str]]) -> None:
    _site_case(*case)
