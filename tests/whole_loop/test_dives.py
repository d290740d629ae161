"""Whole-loop dry-run dives: executor + vehicle_link over real MAVLink/UDP against the
simulated ArduSub vehicle and sonar. Every assertion is a physical fact checked against
the simulator's truth (never the controller's own view).

The site (tests/whole_loop/data/compact) is a two-lane strip over the paper's five Table I
targets, so that each dive dry-runs in well under a minute.
"""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import pytest

from planner.dryrun.dive import DryRun, run_dry_dive
from planner.dryrun.scenario import load_scenario
from sim_harness.faults import FaultConfig, TimeWindow
from sim_harness.vehicle.dynamics import AttitudeDisturbance

SITE = Path(__file__).parent / "data" / "compact"
MIN_CLEARANCE_M = 0.3  # survey.toml [vehicle] min_clearance_m
DEPTH_LIMIT_M = 10.0  # survey.toml [vehicle] max_depth_m
MAV_CMD_COMPONENT_ARM_DISARM = 400


#: A nose-down trim of 3 deg, 3 deg pitch waves of 8 s and 3 deg roll waves: a light ROV
#: near the surface in a swell, or pulled by its tether.
TRIM_AND_WAVES = AttitudeDisturbance(pitch_bias_rad=math.radians(-3.0), pitch_amplitude_rad=math.radians(3.0),
                                     pitch_period_s=8.0, roll_amplitude_rad=math.radians(3.0))


def _dive(tmp_path: Path, name: str = "run", **overrides) -> DryRun:
    return run_dry_dive(load_scenario(SITE, **overrides), tmp_path / name)


def _assert_safe(dry: DryRun) -> None:
    """Clearance and depth limit held over the whole dive, from the simulator's truth."""
    armed = [h for h in dry.simulator.truth_history() if h.armed]
    if not armed:  # aborted before arming: it never left the surface
        assert dry.summary["status"] == "aborted"
        assert max(h.depth_m for h in dry.simulator.truth_history()) < 0.5
    else:
        assert min(h.altitude_m for h in armed) >= MIN_CLEARANCE_M
    assert max(h.depth_m for h in dry.simulator.truth_history()) <= DEPTH_LIMIT_M
    assert dry.summary["depth_limit_violations"] == 0


@pytest.fixture(scope="module")
def nominal(tmp_path_factory: pytest.TempPathFactory) -> DryRun:
    return _dive(tmp_path_factory.mktemp("nominal"))


@pytest.mark.slow
def test_nominal_dive_completes_safely(nominal: DryRun):
    assert nominal.summary["status"] == "completed", nominal.summary["reason"]
    states = [s["state"] for s in nominal.summary["states"]]
    assert states == ["CONNECT", "PREFLIGHT", "ARM", "DESCEND", "PASS_1", "ALTITUDE_CHANGE", "PASS_2", "FINISH",
                      "COMPLETED"]
    _assert_safe(nominal)
    # Both passes flown at their planned altitudes (truth, while on the lanes).
    with (nominal.out_dir / "truth_track.csv").open(newline="") as handle:
        track = list(csv.DictReader(handle))
    for k, pass_ in enumerate(nominal.plan.passes):
        start = next(s["t_s"] for s in nominal.summary["states"] if s["state"] == f"PASS_{k + 1}")
        end = next(s["t_s"] for s in nominal.summary["states"] if s["t_s"] > start)
        alts = [float(r["altitude_m"]) for r in track if start + 2 <= float(r["t_s"]) <= end]
        assert alts and abs(sum(alts) / len(alts) - pass_.altitude_m) < 0.03


@pytest.mark.slow
def test_nominal_dive_measures_the_paper_targets(nominal: DryRun):
    """Paper targets (2.8-4.7 cm high): mean |error| <= 0.2 cm against the truth."""
    scored = [t for t in nominal.summary["heights_vs_truth"] if t["matched"]]
    assert len(scored) >= 4, nominal.summary["heights_vs_truth"]
    mean_err = sum(abs(t["error_m"]) for t in scored) / len(scored)
    assert mean_err <= 0.002, nominal.summary["heights_vs_truth"]


@pytest.mark.slow
def test_nominal_dive_writes_a_complete_run_folder(nominal: DryRun):
    out = nominal.out_dir
    for name in ("plan/plan.json", "plan/survey.plan", "plan/survey.waypoints", "dive.tlog", "events.jsonl",
                 "nav.csv", "filter.csv", "tilt.csv", "targets.geojson", "targets.csv", "mosaic.tif", "mosaic.png",
                 "mosaic_heights.png", "summary.json", "truth.json"):
        assert (out / name).is_file() and (out / name).stat().st_size > 0, name
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "completed"
    truth = json.loads((out / "truth.json").read_text())
    assert {t["id"] for t in truth["targets"]} == {"T1", "T2", "T3", "T4", "T5"}
    assert all(-90 < t["lat"] < 90 and -180 < t["lon"] < 180 for t in truth["targets"])
    geo = json.loads((out / "targets.geojson").read_text())
    assert geo["type"] == "FeatureCollection" and geo["features"]


@pytest.mark.slow
def test_link_cut_ends_in_the_configured_safe_action(tmp_path):
    """The link is cut for 40 s mid-survey: the dive aborts with link_lost, and the
    vehicle's own failsafe (pointed at us in PREFLIGHT) surfaces it."""
    dry = _dive(tmp_path, faults=FaultConfig(link_cuts=(TimeWindow(45.0, 85.0),)))
    assert dry.summary["status"] == "aborted"
    assert dry.summary["reason"] == "link_lost"
    _assert_safe(dry)
    history = dry.simulator.truth_history()
    after = [h for h in history if h.time_s > 75.0]
    assert after and after[-1].depth_m < 1.0  # surfaced (FS_GCS_ENABLE = 4)
    events = [json.loads(line) for line in (dry.out_dir / "events.jsonl").read_text().splitlines()]
    assert any(e["kind"] == "failsafe" and "link" in e["message"] for e in events)


@pytest.mark.slow
def test_refused_arming_aborts_without_moving(tmp_path):
    dry = _dive(tmp_path, faults=FaultConfig(refuse_commands=frozenset({MAV_CMD_COMPONENT_ARM_DISARM})))
    assert dry.summary["status"] == "aborted"
    assert dry.summary["reason"] == "command_refused"
    assert not any(h.armed for h in dry.simulator.truth_history())
    assert max(h.depth_m for h in dry.simulator.truth_history()) < 0.5


@pytest.mark.slow
def test_packet_loss_and_latency(tmp_path):
    """30 % packet loss each way and 200 ms latency: the dive completes or aborts safely,
    with the reason, and the limits hold."""
    dry = _dive(tmp_path, faults=FaultConfig(seed=5, packet_loss=0.3, latency_s=0.2))
    assert dry.summary["status"] in ("completed", "aborted")
    if dry.summary["status"] == "aborted":
        assert dry.summary["reason"]
    else:
        # Tilt commands and telemetry arrive late or not at all: 1.000 observed over the
        # tracking zone (0.89 over the old 2-altitude zone); asserted with room for the spread.
        assert dry.summary["shadow_in_fov_ratio"] >= 0.75
    _assert_safe(dry)


@pytest.mark.slow
def test_altimeter_dropouts_and_depth_spikes(tmp_path):
    dry = _dive(tmp_path, faults=FaultConfig(seed=7, depth_spike_prob=0.02, depth_spike_m=1.0,
                                             altimeter_dropouts=(TimeWindow(50.0, 52.5), TimeWindow(70.0, 72.0))))
    assert dry.summary["status"] == "completed", dry.summary["reason"]
    _assert_safe(dry)
    counters = dry.summary["filter_counters"]
    assert counters["depth"]["rejected"] > 0  # the spikes were gated out
    assert dry.summary["shadow_in_fov_ratio"] >= 0.85  # 1.000 observed (0.95 over the old 2-altitude zone)


@pytest.mark.slow
def test_current_and_disturbances(tmp_path):
    dry = _dive(tmp_path, current_north_m_s=0.05, current_east_m_s=0.08)
    assert dry.summary["status"] == "completed", dry.summary["reason"]
    _assert_safe(dry)
    assert math.isfinite(dry.summary["min_clearance_m"])
    assert dry.summary["shadow_in_fov_ratio"] >= 0.85  # 1.000 observed (crab angle, pitch/roll waves)


def _tilt_sign_changes_per_min(run_dir: Path) -> float:
    with (run_dir / "tilt.csv").open(newline="") as handle:
        rows = [r for r in csv.DictReader(handle) if r["tilt_cmd_deg"]]
    t = [float(r["t_s"]) for r in rows]
    tilt = [float(r["tilt_cmd_deg"]) for r in rows]
    steps = [b - a for a, b in zip(tilt, tilt[1:], strict=False) if abs(b - a) > 0.05]
    changes = sum(1 for a, b in zip(steps, steps[1:], strict=False) if a * b < 0)
    return changes / ((t[-1] - t[0]) / 60.0)


@pytest.mark.slow
def test_nominal_dive_keeps_shadows_in_view(nominal: DryRun):
    """Issue #8: >= 99 % of the in-range target-frames (after settling) see the whole shadow.

    In range = inside the tracking zone (planner.pitch.aperture.tracking_zone_start_m), the
    same zone the loop serves: from the larger of 2 altitudes and the ground range from
    which the zone, up to the window's end, spans at most the aperture less the loop's
    margin at both edges. Observed on this site: 1.000 in 6 runs (111-147 target-frames);
    over the plain 2-altitude zone (shadow_in_fov_ratio_2alt, where the loop serves the
    near band where that costs the zone nothing) 0.846-0.892.
    """
    summary = nominal.summary
    assert summary["shadow_frames_within_range"] >= 100
    assert summary["shadow_in_fov_ratio"] >= 0.99, summary["shadow_in_fov_ratio"]
    assert summary["shadow_fov_model_agreement"] == 1.0
    zones = {z["pass"]: z for z in summary["tracking_zone"]}
    assert set(zones) == {p.name for p in nominal.plan.passes}
    for zone in zones.values():
        # The zone is geometry: at least 2 altitudes ahead, and within the aperture less both margins.
        assert zone["start_m"] >= 2.0 * zone["altitude_m"] - 1e-9
        assert zone["depression_span_deg"] <= zone["aperture_deg"] - 2 * zone["margin_deg"] + 1e-6
        assert zone["start_m"] < zone["end_ground_m"]
    events = [json.loads(line) for line in (nominal.out_dir / "events.jsonl").read_text().splitlines()]
    assert {e["pass_"] for e in events if e["kind"] == "tracking_zone"} == set(zones)


@pytest.mark.slow
def test_pitch_loop_against_fixed_tilt(nominal: DryRun, tmp_path):
    """Side by side with the fixed tilt that centres the same tracking zone, and without
    limit cycling (the tilt reverses a bounded number of times per minute).

    The zone fits the aperture with the loop's margins, so at this site's steady attitude
    one centred tilt holds nearly every shadow in it as well: observed 0.993-1.000
    (fixed) and 1.000 (loop). The loop also follows targets on in through the near band
    to 2 altitudes wherever that costs no shadow in the zone and keeps the window's far
    end in view: over the 2-altitude zone 0.846-0.892 (loop, 4 runs) against 0.811-0.834
    (fixed, 4).
    Where the attitude moves, see test_pitch_trim_and_waves_pitch_loop_against_fixed_tilt.
    """
    fixed = _dive(tmp_path, pitch_loop=False)
    closed_ratio = nominal.summary["shadow_in_fov_ratio"]
    fixed_ratio = fixed.summary["shadow_in_fov_ratio"]
    assert [z["start_m"] for z in fixed.summary["tracking_zone"]] == pytest.approx(
        [z["start_m"] for z in nominal.summary["tracking_zone"]], abs=0.01)  # the same zone
    assert closed_ratio >= 0.99
    assert fixed_ratio >= 0.97, fixed_ratio  # one tilt holds the whole zone: the zone's defining property
    closed_2alt, fixed_2alt = (d.summary["shadow_in_fov_ratio_2alt"] for d in (nominal, fixed))
    assert closed_2alt >= 0.8 and closed_2alt >= fixed_2alt - 0.02, (closed_2alt, fixed_2alt)
    # The tilt answers the simulated pitch disturbance (0.1-0.3 Hz: up to 36 reversals a
    # minute) and reverses about twice per target passing; a limit cycle at the 5 Hz control
    # rate would reverse up to 300 times a minute.
    assert _tilt_sign_changes_per_min(nominal.out_dir) <= 60.0


@pytest.mark.slow
def test_pitch_trim_and_waves_pitch_loop_against_fixed_tilt(tmp_path):
    """Pitch and roll disturbances (TRIM_AND_WAVES): the loop takes the vehicle's pitch
    into the tilt and keeps >= 99 % of the shadows whole; the fixed tilt, which centres
    the zone for a level vehicle, loses many. Observed (compact site): loop 1.000 (4 runs),
    fixed 0.73-0.84 (4 runs); over the 2-altitude zone 0.81-0.85 and 0.73-0.80."""
    closed = _dive(tmp_path, "loop", attitude=TRIM_AND_WAVES)
    fixed = _dive(tmp_path, "fixed", attitude=TRIM_AND_WAVES, pitch_loop=False)
    for dry in (closed, fixed):
        assert dry.summary["status"] == "completed", dry.summary["reason"]
        _assert_safe(dry)
    pitch = [h.pitch_rad for h in closed.simulator.truth_history() if h.armed]
    assert min(pitch) < math.radians(-5.0) and max(pitch) > math.radians(-1.0)  # the premise: it pitched
    assert closed.summary["shadow_frames_within_range"] >= 80
    assert closed.summary["shadow_in_fov_ratio"] >= 0.99, closed.summary["shadow_in_fov_ratio"]
    assert fixed.summary["shadow_in_fov_ratio"] <= 0.92, fixed.summary["shadow_in_fov_ratio"]
    scored = [t for t in closed.summary["heights_vs_truth"] if t["matched"]]
    assert len(scored) >= 4
    assert sum(abs(t["error_m"]) for t in scored) / len(scored) <= 0.002
