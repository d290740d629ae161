"""Whole-loop dives of the vehicle's own safety against the simulated ArduSub 4.5: the
link cut, the companion killed mid-lane, the DVL's position lost, the topside pilot taking
over. Every assertion is checked against the simulator's truth, in simulated time.
"""

from __future__ import annotations

import math

import pytest

from sim_harness.autopilot.autopilot import Mode
from sim_harness.faults import FaultConfig, TimeWindow
from sim_harness.peers import TopsidePilot
from tests.whole_loop.dives import (
    LANE_SPEED_M_S,
    MID_LANE_S,
    MIN_ALTITUDE_M,
    assert_own_stop,
    assert_safe,
    dive,
    events,
    pass_1_start_s,
)

#: The pilot's button press, simulated s: in pass 1 in every dive.
PILOT_S = 35.0


@pytest.mark.slow
def test_link_cut_vehicle_stops_itself_then_surfaces_when_it_returns(tmp_path):
    """The link is cut mid-pass for 20 s: the position + velocity setpoints stop, so the
    vehicle stops by itself 3 s after the last one (ArduSub 4.5 ModeGuided::
    guided_posvel_control_run) and holds, armed; the executor aborts with link_lost and,
    when the link returns, commands the link-lost action (surface) and the vehicle surfaces.
    The GCS failsafe is not ours: the topside's heartbeat never stopped."""
    dry = dive(tmp_path, faults=FaultConfig(link_cuts=(TimeWindow(MID_LANE_S, MID_LANE_S + 20.0),)),
               faults_from_state="PASS_1")
    t0 = pass_1_start_s(dry)
    cut = TimeWindow(t0 + MID_LANE_S, t0 + MID_LANE_S + 20.0)
    assert dry.summary["status"] == "aborted"
    assert dry.summary["reason"] == "link_lost"
    assert dry.summary["safe_action"] == "surface"
    assert_safe(dry)
    history = dry.simulator.truth_history()
    during = [h for h in history if cut.start_s <= h.time_s <= cut.end_s]
    assert all(h.armed and h.mode == Mode.GUIDED for h in during)
    assert_own_stop(during, cut.start_s)
    assert max(h.depth_m for h in during) - min(h.depth_m for h in during) < 0.05
    assert history[-1].depth_m < 0.5 and history[-1].armed
    assert any(e["kind"] == "failsafe" and "stops within 3 s" in e["message"] for e in events(dry))


@pytest.mark.slow
def test_companion_killed_mid_pass_vehicle_stops_on_its_own(tmp_path):
    """The companion's process dies mid-lane (no goodbye, no safe action) while BlueOS's
    services keep heartbeating as system 1 and the topside as 255: 3 s after the last
    setpoint the vehicle zeroes its velocity target and holds the position target and
    depth, armed in GUIDED, for the pilot (ArduSub 4.5 ModeGuided::
    guided_posvel_control_run, GUIDED_POSVEL_TIMEOUT_MS 3000). Measured (simulated
    time after the death at full lane speed, 4 runs): braking from 3.1-3.2 s, stopped
    (< 5 cm/s) at 3.7 s, settled (< 2 cm/s) by 6.2 s, 1.4 m further along the lane, depth
    within 6 mm."""
    dry = dive(tmp_path, companion_dies_at_s=MID_LANE_S, faults_from_state="PASS_1", run_on_s=20.0)
    assert dry.summary["status"] == "killed"
    died_s = pass_1_start_s(dry) + MID_LANE_S
    history = dry.simulator.truth_history()
    after = [h for h in history if h.time_s >= died_s - 1e-6]
    at_death = after[0]
    assert abs(at_death.time_s - died_s) < 0.25 and at_death.mode == Mode.GUIDED  # flying the lane
    assert after[-1].time_s >= died_s + 19.0
    settled_s = assert_own_stop(after, died_s)
    assert all(h.armed and h.mode == Mode.GUIDED for h in after)
    held = [h for h in after if h.time_s >= died_s + settled_s]
    assert max(h.depth_m for h in after) - min(h.depth_m for h in after) < 0.05
    drift = math.hypot(held[-1].north_m - held[0].north_m, held[-1].east_m - held[0].east_m)
    assert drift < 0.1
    travelled = math.hypot(held[0].north_m - at_death.north_m, held[0].east_m - at_death.east_m)
    assert travelled < LANE_SPEED_M_S * 3.5 + 0.3  # the lane speed until the timeout, then braking
    assert min(h.altitude_m for h in after) >= MIN_ALTITUDE_M


@pytest.mark.slow
def test_dvl_position_lost_ascends_in_alt_hold(tmp_path):
    """The DVL loses bottom lock mid-pass for good: the EKF has no position, so GUIDED and
    SURFACE are both out (ArduSub 4.5 ModeSurface::requires_GPS); the executor aborts with
    navigation_lost and ascends in ALT_HOLD by GLOBAL_INT depth targets, which need no
    position (GCS_MAVLINK_Sub::handle_set_position_target_global_int), to the surface."""
    dry = dive(tmp_path, faults=FaultConfig(position_loss=(TimeWindow(MID_LANE_S, 1e9),)),
               faults_from_state="PASS_1")
    assert dry.summary["status"] == "aborted"
    assert dry.summary["reason"] == "navigation_lost", dry.summary["message"]
    assert dry.summary["safe_action"] == "surface"
    assert_safe(dry)
    lost_s = pass_1_start_s(dry) + MID_LANE_S
    history = dry.simulator.truth_history()
    after = [h for h in history if h.time_s >= lost_s + 3.0]
    assert all(h.armed and h.mode != Mode.SURFACE for h in after)
    assert after[-1].mode == Mode.ALT_HOLD and after[-1].depth_m < 0.5
    assert after[-1].time_s - lost_s < 40.0


@pytest.mark.slow
def test_pilot_mode_change_is_honoured(tmp_path):
    """Mid-pass the topside pilot presses the ALT_HOLD button (joystick button 2): the
    executor stops commanding at once, aborts with "pilot took over" and never sends
    another command (no mode change back, no safe action); the vehicle stays armed in the
    pilot's mode."""
    dry = dive(tmp_path, topside=TopsidePilot(buttons=((PILOT_S, 2),)), run_on_s=10.0)
    assert dry.summary["status"] == "aborted"
    assert dry.summary["reason"] == "pilot_took_over"
    assert "pilot took over" in dry.summary["message"]
    assert dry.summary["safe_action"].startswith("none")
    history = dry.simulator.truth_history()
    after = [h for h in history if h.time_s >= PILOT_S + 0.5]
    assert after[-1].time_s >= PILOT_S + 9.0  # the simulator ran on after the executor let go
    assert all(h.armed and h.mode == Mode.ALT_HOLD for h in after)
    assert not [e for e in events(dry) if e["kind"] == "command" and e["t_s"] >= PILOT_S]
