"""Property tests: damaged survey areas, settings and scenarios, through the readers and the CLI.

Each reader, given random or mutated bytes and values, returns a result or raises the
package's narrow error (a ValueError or OSError subclass) naming the file; the commands
(``plan``, ``sim``) exit 0 or exit 2 with one stderr line that names the file or the
option (tests/fuzz.py). Larger explorations run under the ``soak`` marker.
"""

from __future__ import annotations

import json
import shutil
import tempfile
from importlib import resources
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from planner.config import load_settings
from planner.dryrun.scenario import load_scenario
from planner.survey.area import load_area
from tests.fuzz import assert_contract, check_reader, file_case, mutated_bytes, mutated_json, mutated_toml, run_cli

DATA = Path(str(resources.files("planner").joinpath("data")))
SITE = DATA / "scenarios" / "paper-targets"
AREA_DOC = json.loads((SITE / "area.geojson").read_text(encoding="utf-8"))
AREA_BYTES = (SITE / "area.geojson").read_bytes()
SURVEY_TEXT = (SITE / "survey.toml").read_text(encoding="utf-8")
SCENARIO_TEXT = (SITE / "scenario.toml").read_text(encoding="utf-8")
_CHECKS = [HealthCheck.too_slow, HealthCheck.function_scoped_fixture]
FAST = settings(max_examples=40, deadline=None, suppress_health_check=_CHECKS)
SOAK = settings(max_examples=400, deadline=None, suppress_health_check=_CHECKS)


def _write(folder: Path, name: str, data: bytes | str) -> Path:
    path = folder / name
    path.write_bytes(data if isinstance(data, bytes) else data.encode("utf-8"))
    return path


def _area_case(doc_or_bytes: Any) -> None:
    data = doc_or_bytes if isinstance(doc_or_bytes, bytes) else json.dumps(doc_or_bytes)
    config = SITE / "survey.toml"
    file_case("area.geojson", data, load_area, lambda area, tmp: [
        "plan", str(area), "--config", str(config), "--out", str(tmp / "out"), "--no-plot"], names=[str(config)])


@FAST
@given(data=mutated_bytes(AREA_BYTES) | st.binary(max_size=64))
def test_damaged_area_bytes(data: bytes) -> None:
    _area_case(data)


@FAST
@given(doc=mutated_json(AREA_DOC))
def test_damaged_area_documents(doc: Any) -> None:
    _area_case(doc)


def _settings_case(text: str | bytes) -> None:
    file_case("survey.toml", text, load_settings, lambda survey, tmp: [
        "plan", str(SITE / "area.geojson"), "--config", str(survey), "--out", str(tmp / "out"), "--no-plot"])


@FAST
@given(text=mutated_toml(SURVEY_TEXT))
def test_damaged_survey_settings(text: str) -> None:
    _settings_case(text)


@FAST
@given(data=mutated_bytes(SURVEY_TEXT.encode("utf-8")))
def test_damaged_survey_settings_bytes(data: bytes) -> None:
    _settings_case(data)


@pytest.fixture
def stub_dive(monkeypatch: pytest.MonkeyPatch) -> list[Any]:
    """``sim`` with the dive itself replaced: these tests are about reading the scenario."""
    import planner.dryrun.dive as dive

    flown: list[Any] = []

    def fly(prepared: Any, out: Path, **_: Any) -> Any:
        flown.append(prepared)
        raise KeyboardInterrupt  # stops the command before it flies; nothing is written

    monkeypatch.setattr(dive, "dry_dive_into", fly)
    return flown


def _scenario_case(text: str | bytes, flown: list[Any]) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        site = Path(tmp) / "site"
        shutil.copytree(SITE, site)
        scenario = _write(site, "scenario.toml", text)
        check_reader(lambda _: load_scenario(site), scenario)
        before = len(flown)
        code, _, err = run_cli(["sim", str(site), "--out", str(Path(tmp) / "run"), "--no-progress"])
        if len(flown) > before:  # the scenario was valid: the (stubbed) dive was reached
            assert code == 130
            return
        assert_contract(code, err, [str(scenario), str(site)])


@FAST
@given(text=mutated_toml(SCENARIO_TEXT))
def test_damaged_scenarios(stub_dive: list[Any], text: str) -> None:
    _scenario_case(text, stub_dive)


@FAST
@given(data=mutated_bytes(SCENARIO_TEXT.encode("utf-8")))
def test_damaged_scenario_bytes(stub_dive: list[Any], data: bytes) -> None:
    _scenario_case(data, stub_dive)


@pytest.mark.soak
@SOAK
@given(doc=mutated_json(AREA_DOC))
def test_soak_damaged_area_documents(doc: Any) -> None:
    _area_case(doc)


@pytest.mark.soak
@SOAK
@given(text=mutated_toml(SURVEY_TEXT))
def test_soak_damaged_survey_settings(text: str) -> None:
    _settings_case(text)


@pytest.mark.soak
@SOAK
@given(text=mutated_toml(SCENARIO_TEXT))
def test_soak_damaged_scenarios(stub_dive: list[Any], text: str) -> None:
    _scenario_case(text, stub_dive)
