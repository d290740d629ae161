"""Settings: the shipped defaults load; every kind of bad input names its key."""

from __future__ import annotations

import math
import tomllib

import pytest

from perception.sonar_io.beams import load_beam_table
from planner.config import (
    default_settings,
    default_settings_text,
    load_settings,
    parse_settings,
    parse_settings_text,
)
from planner.errors import ConfigError


def _defaults() -> dict:
    return tomllib.loads(default_settings_text())


def test_defaults_load_in_si_units() -> None:
    s = default_settings()
    assert s.sonar.fan_width_rad == pytest.approx(load_beam_table("ARIS3000_128").fan_width_rad)
    assert s.sonar.elevation_aperture_rad == pytest.approx(math.radians(14.0))
    assert s.sonar.range_resolution_m == pytest.approx((12.0 - 0.7) / 1200)
    assert s.survey.lane_heading_rad is None  # "auto"
    assert s.vehicle.tilt_max_rad == pytest.approx(math.radians(60.0))


def test_fan_width_instead_of_table() -> None:
    d = _defaults()
    del d["sonar"]["beam_table"]
    d["sonar"]["fan_width_deg"] = 20.0
    s = parse_settings(d)
    assert s.sonar.fan_width_rad == pytest.approx(math.radians(20.0))
    assert s.sonar.beam_table is None


def test_given_lane_heading_is_folded_to_half_turn() -> None:
    d = _defaults()
    d["survey"]["lane_heading_deg"] = 225.0
    assert parse_settings(d).survey.lane_heading_rad == pytest.approx(math.radians(45.0))


@pytest.mark.parametrize(
    ("table", "key", "value", "named"),
    [
        ("vehicle", "speed_m_s", -1.0, "vehicle.speed_m_s"),
        ("vehicle", "speed_m_s", "fast", "vehicle.speed_m_s"),
        ("vehicle", "speedd_m_s", 1.0, "vehicle.speedd_m_s"),
        ("sonar", "window_end_m", 0.5, "sonar.window_end_m"),
        ("sonar", "samples_per_beam", 10.5, "sonar.samples_per_beam"),
        ("sonar", "beam_table", "ARIS9999", "sonar.beam_table"),
        ("sonar", "fan_width_deg", 30.0, "sonar.fan_width_deg"),
        ("site", "target_height_max_m", 0.01, "site.target_height_max_m"),
        ("site", "target_height_max_m", 30.0, "site.target_height_max_m"),
        ("survey", "overlap", 0.95, "survey.overlap"),
        ("altitudes", "altitude_max_m", 0.1, "altitudes.altitude_max_m"),
        ("mission", "altitude_reference", "sky", "mission.altitude_reference"),
        ("vehicle", "tilt_max_deg", -10.0, "vehicle.tilt_max_deg"),
        ("vehicle", "max_depth_m", float("inf"), "vehicle.max_depth_m"),
        ("survey", "obstacle_margin_m", 0.0, "survey.obstacle_margin_m"),
        ("survey", "edge_loss_budget", 0.9, "survey.edge_loss_budget"),
    ],
)
def test_bad_values_name_the_key(table: str, key: str, value: object, named: str) -> None:
    d = _defaults()
    d[table][key] = value
    with pytest.raises(ConfigError) as info:
        parse_settings(d, path="x.toml")
    assert info.value.key == named
    assert str(info.value).startswith("x.toml: " + named)


def test_missing_table_and_key_and_version() -> None:
    d = _defaults()
    del d["vehicle"]
    with pytest.raises(ConfigError, match="vehicle: missing table"):
        parse_settings(d)
    d = _defaults()
    del d["site"]["water_depth_m"]
    with pytest.raises(ConfigError, match="site.water_depth_m: missing"):
        parse_settings(d)
    d = _defaults()
    d["version"] = 2
    with pytest.raises(ConfigError, match="version"):
        parse_settings(d)
    d = _defaults()
    d["extra"] = {}
    with pytest.raises(ConfigError, match="extra"):
        parse_settings(d)


def test_file_errors(tmp_path) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text("version = 1\n[sonar\n", encoding="utf-8")
    with pytest.raises(ConfigError, match="not valid TOML"):
        load_settings(bad)
    with pytest.raises(ConfigError, match="cannot read"):
        load_settings(tmp_path / "none.toml")
    good = tmp_path / "good.toml"
    good.write_text(default_settings_text(), encoding="utf-8")
    assert load_settings(good).source == str(good)
    assert parse_settings_text(default_settings_text()).site == default_settings().site
