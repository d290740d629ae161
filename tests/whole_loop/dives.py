"""Helpers of the whole-loop dives: the compact site, its limits, truth-side checks.

The site (tests/whole_loop/data/compact) is a two-lane strip over the paper's five Table I
targets, so that each dive dry-runs in well under a minute. As in the field, a topside
(QGroundControl, system 255 = SYSID_MYGCS) heartbeats and sends its joystick at rest all
dive, and BlueOS's own services heartbeat as system 1. The compact dive flies pass 1's
first 3 m lane, without a turn before it, for about 6.5 s from entering PASS_1 (at 21-25 s
simulated), so the mid-lane faults are placed
``MID_LANE_S`` after PASS_1 begins (``faults_from_state``), at lane speed in every dive.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

from planner.dryrun.dive import DryRun, run_dry_dive
from planner.dryrun.scenario import load_scenario
from sim_harness.vehicle.dynamics import AttitudeDisturbance

SITE = Path(__file__).parent / "data" / "compact"
#: Lowest true altitude the dives must keep: the survey's lowest allowed altitude,
#: target_height_max_m + min_clearance_m = 0.2 + 0.3 m (survey.toml): the clearance over
#: the tallest expected target, whatever the dive meets.
MIN_ALTITUDE_M = 0.5
DEPTH_LIMIT_M = 10.0  # survey.toml [vehicle] max_depth_m
MAV_CMD_COMPONENT_ARM_DISARM = 400
MID_LANE_S = 3.0  # s after entering PASS_1
LANE_SPEED_M_S = 0.5  # survey.toml [vehicle] speed_m_s
#: Horizontal speed below which the vehicle counts as stopped, m/s.
STOPPED_M_S = 0.02


#: A nose-down trim of 3 deg, 3 deg pitch waves of 8 s and 3 deg roll waves: a light ROV
#: near the surface in a swell, or pulled by its tether.
TRIM_AND_WAVES = AttitudeDisturbance(pitch_bias_rad=math.radians(-3.0), pitch_amplitude_rad=math.radians(3.0),
                                     pitch_period_s=8.0, roll_amplitude_rad=math.radians(3.0))


def dive(tmp_path: Path, name: str = "run", progress=None, **overrides) -> DryRun:
    return run_dry_dive(load_scenario(SITE, **overrides), tmp_path / name, progress=progress)


def pass_1_start_s(dry: DryRun) -> float:
    """When the executor entered PASS_1 (the anchor of ``faults_from_state="PASS_1"``), s."""
    return next(s["t_s"] for s in dry.summary["states"] if s["state"] == "PASS_1")


def assert_safe(dry: DryRun) -> None:
    """Clearance and depth limit held over the whole dive, from the simulator's truth."""
    armed = [h for h in dry.simulator.truth_history() if h.armed]
    if not armed:  # aborted before arming: it never left the surface
        assert dry.summary["status"] == "aborted"
        assert max(h.depth_m for h in dry.simulator.truth_history()) < 0.5
    else:
        assert min(h.altitude_m for h in armed) >= MIN_ALTITUDE_M
    assert max(h.depth_m for h in dry.simulator.truth_history()) <= DEPTH_LIMIT_M
    assert dry.summary["depth_limit_violations"] == 0


def events(dry: DryRun) -> list[dict]:
    return [json.loads(line) for line in (dry.out_dir / "events.jsonl").read_text().splitlines()]


def speed_m_s(h) -> float:
    return math.hypot(h.surge_m_s, h.sway_m_s)


def stopped_from_s(history: list, after_s: float) -> float:
    """The first time after ``after_s`` from which the vehicle stays stopped to the end."""
    moving = [h.time_s for h in history if h.time_s >= after_s and speed_m_s(h) >= STOPPED_M_S]
    return moving[-1] if moving else after_s


def assert_own_stop(history: list, from_s: float) -> float:
    """The setpoints stop at ``from_s``: the vehicle flies on along the last one until its
    own 3 s timeout (ArduSub 4.5 ModeGuided::guided_posvel_control_run), then is stopped
    (< 5 cm/s) within 4.5 s and settled (< 2 cm/s to the end) within 10 s. Returns the
    settling time, s after ``from_s``."""
    after = [h for h in history if h.time_s >= from_s]
    flying_on = [speed_m_s(h) for h in after if from_s + 0.5 <= h.time_s <= from_s + 2.9]
    assert min(flying_on) > 0.6 * LANE_SPEED_M_S, min(flying_on)  # not stopped before the timeout
    stopped_s = next(h.time_s for h in after if speed_m_s(h) < 0.05) - from_s
    settled_s = stopped_from_s(after, from_s) - from_s
    assert 3.0 <= stopped_s <= 4.5 and settled_s <= 10.0, (stopped_s, settled_s)
    return settled_s
