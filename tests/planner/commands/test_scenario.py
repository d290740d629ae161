"""Scenario files of dry-run dives (``planner.dryrun.load_scenario``): the
built-in one, the ``[attitude]`` disturbance table and the errors that name what is wrong."""

from __future__ import annotations

import math
import shutil
from pathlib import Path

import pytest

from planner.dryrun.scenario import load_scenario
from planner.errors import ConfigError
from sim_harness.vehicle.dynamics import AttitudeDisturbance

COMPACT = Path(__file__).resolve().parents[2] / "whole_loop" / "data" / "compact"


def _site(tmp_path: Path, extra: str) -> Path:
    site = tmp_path / "site"
    shutil.copytree(COMPACT, site)
    scenario = site / "scenario.toml"
    scenario.write_text(scenario.read_text(encoding="utf-8") + "\n" + extra, encoding="utf-8")
    return site


def test_builtin_scenario_keeps_the_simulator_default_attitude() -> None:
    scenario = load_scenario("paper-targets")
    assert scenario.attitude == AttitudeDisturbance(
        pitch_amplitude_rad=math.radians(1.5), pitch_period_s=6.0, roll_amplitude_rad=math.radians(1.0),
        roll_period_s=4.5, pitch_bias_rad=0.0)


def test_attitude_table_in_degrees(tmp_path: Path) -> None:
    site = _site(tmp_path, "[attitude]\npitch_bias_deg = -4.0\npitch_amplitude_deg = 3\npitch_period_s = 8.0\n"
                           "roll_amplitude_deg = 2.5\nroll_period_s = 5\n")
    att = load_scenario(site).attitude
    assert att.pitch_bias_rad == pytest.approx(math.radians(-4.0))
    assert att.pitch_amplitude_rad == pytest.approx(math.radians(3.0))
    assert att.pitch_period_s == 8.0 and att.roll_period_s == 5.0
    assert att.roll_amplitude_rad == pytest.approx(math.radians(2.5))
    # what the simulator flies: at the wave's crest, bias plus amplitude (no thrust)
    pitch, _, rate, _ = att.attitude(2.0, 0.0)
    assert pitch == pytest.approx(math.radians(-1.0)) and rate == pytest.approx(0.0, abs=1e-12)


@pytest.mark.parametrize(("extra", "key"), [
    ("[attitude]\npitch_wobble_deg = 1\n", "attitude.pitch_wobble_deg"),
    ("[attitude]\npitch_period_s = 0\n", "attitude.pitch_period_s"),
    ("[attitude]\nroll_amplitude_deg = 'big'\n", "attitude.roll_amplitude_deg"),
    ("[attitude]\npitch_amplitude_deg = 45\n", "attitude.pitch_amplitude_deg"),
    ("[attitude]\npitch_bias_deg = nan\n", "attitude.pitch_bias_deg"),
    ("attitude = 3\n", "attitude"),
    ("[weather]\nwind = 3\n", "weather"),
])
def test_bad_scenario_names_the_key(tmp_path: Path, extra: str, key: str) -> None:
    site = _site(tmp_path, extra)
    with pytest.raises(ConfigError) as info:
        load_scenario(site)
    assert key in str(info.value) and "scenario.toml" in str(info.value)


def test_thrust_tips_the_nose_through_a_lag() -> None:
    """A step of surge thrust reaches the pitch over the lag, not at once (the vehicle's
    pitch inertia), and the reported pitch rate is that of the lagged term."""
    att = AttitudeDisturbance(pitch_amplitude_rad=0.0, roll_amplitude_rad=0.0, surge_pitch_lag_s=0.8)
    dt, filtered, rate = 0.01, 0.0, 0.0
    for _ in range(80):  # 0.8 s of full thrust
        new = att.lagged_surge_n(filtered, 40.0, dt)
        filtered, rate = new, (new - filtered) / dt
    pitch, _, pitch_rate, _ = att.attitude(0.8, filtered, rate)
    full = att.pitch_per_surge_rad_n * 40.0
    assert pitch == pytest.approx((1.0 - math.exp(-1.0)) * full, rel=1e-3)
    assert pitch_rate == pytest.approx(att.pitch_per_surge_rad_n * rate)
    assert AttitudeDisturbance(surge_pitch_lag_s=0.0).lagged_surge_n(0.0, 40.0, dt) == 40.0
