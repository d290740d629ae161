"""Whole-loop dry-run dives: executor + vehicle_link over real MAVLink/UDP against the
simulated ArduSub vehicle and sonar. Every assertion is a physical fact checked against
the simulator's truth (never the controller's own view).

The site and its helpers: tests/whole_loop/dives.py. The vehicle's own safety (link
cut, companion killed, navigation lost, the pilot taking over) is
tests/whole_loop/test_vehicle_safety.py.
"""

from __future__ import annotations

import csv
import json
import math
import subprocess
import sys
from pathlib import Path

import pytest

from perception.geodesy import LocalOrigin
from planner.dryrun.dive import DryRun
from sim_harness.autopilot.autopilot import Mode
from sim_harness.faults import FaultConfig, TimeWindow
from tests.whole_loop.dives import (
    MAV_CMD_COMPONENT_ARM_DISARM,
    TRIM_AND_WAVES,
    assert_safe,
    dive,
    events,
)
from vehicle_link.mission import ardusub_stored


@pytest.fixture(scope="module")
def nominal(tmp_path_factory: pytest.TempPathFactory) -> DryRun:
    calls: list[tuple[float, float, str]] = []
    dry = dive(tmp_path_factory.mktemp("nominal"), progress=lambda *call: calls.append(call))
    dry.progress_calls = calls  # type: ignore[attr-defined]
    return dry


@pytest.mark.slow
def test_progress_follows_the_simulated_time_and_ends_at_the_whole(nominal: DryRun):
    calls = nominal.progress_calls  # type: ignore[attr-defined]
    sim_s = [c[0] for c in calls]
    assert sim_s == sorted(sim_s) and sim_s[0] < 1.0
    *during, last = calls
    assert all(s < planned for s, planned, _ in during)  # the planned duration holds the dive
    assert last[0] == last[1] >= nominal.summary["sim_duration_s"] - 1.0
    assert last[2].startswith("COMPLETED") and "writing the run folder" in last[2]


@pytest.mark.slow
def test_nominal_dive_completes_safely(nominal: DryRun):
    assert nominal.summary["status"] == "completed", nominal.summary["reason"]
    states = [s["state"] for s in nominal.summary["states"]]
    assert states == ["CONNECT", "PREFLIGHT", "ARM", "DESCEND", "PASS_1", "ALTITUDE_CHANGE", "PASS_2", "FINISH",
                      "COMPLETED"]
    assert_safe(nominal)
    # Both passes flown at their planned altitudes (truth, while on the lanes).
    with (nominal.out_dir / "truth_track.csv").open(newline="") as handle:
        track = list(csv.DictReader(handle))
    for k, pass_ in enumerate(nominal.plan.passes):
        start = next(s["t_s"] for s in nominal.summary["states"] if s["state"] == f"PASS_{k + 1}")
        end = next(s["t_s"] for s in nominal.summary["states"] if s["t_s"] > start)
        alts = [float(r["altitude_m"]) for r in track if start + 2 <= float(r["t_s"]) <= end]
        assert alts and abs(sum(alts) / len(alts) - pass_.altitude_m) < 0.03


@pytest.mark.slow
def test_topside_pilot_throughout_never_disarms(nominal: DryRun):
    """The topside's joystick (MANUAL_CONTROL from SYSID_MYGCS) all dive: the checks saw it,
    the vehicle stayed armed from arming to the end (no failsafe of ours, none of the
    pilot's), and the surface was reached in ALT_HOLD, the pilot's to take."""
    assert any("FS_PILOT_INPUT disarms the vehicle 3 s after the topside's joystick stops" in line
               for line in nominal.summary["preflight"])
    history = nominal.simulator.truth_history()
    armed_at = next(h.time_s for h in history if h.armed)
    assert all(h.armed for h in history if h.time_s >= armed_at)
    assert history[-1].mode == Mode.ALT_HOLD and history[-1].depth_m < 0.5
    assert not any(e["kind"] == "failsafe" for e in events(nominal))


@pytest.mark.slow
def test_mission_verified_against_what_ardusub_stores(nominal: DryRun):
    """The AUTO mission is checked by download against what ArduSub 4.5 keeps (int32 1e-7
    degrees, whole centimetres, NAV_WAYPOINT's param1 only), not against the floats sent:
    the items are written as 4.5 stores them, so the vehicle keeps them to the last unit,
    and the upload verified at the first try."""
    from planner.mission.preflight_steps import link_item
    from planner.survey.mission_files import mission_items

    sent = [link_item(it) for it in mission_items(nominal.plan)]
    stored = nominal.simulator.autopilot.mission.items[1:]  # seq 0 is home
    assert [s.command for s in stored] == [item.command for item in sent]
    located = [(item, s) for item, s in zip(sent, stored, strict=True) if s.has_location]
    assert located
    for item, s in located:  # sent in whole 1e-7 degrees and centimetres: kept unchanged
        assert abs(item.latitude_deg * 1e7 - s.lat_e7) < 1e-3 and abs(item.longitude_deg * 1e7 - s.lon_e7) < 1e-3
        assert abs(item.altitude_m * 100.0 - s.alt_cm) < 1e-6
    for item, s in located:  # the client's model of what 4.5 keeps matches the vehicle's
        model = ardusub_stored(item)
        assert (model.lat_e7, model.lon_e7, model.alt_cm) == (s.lat_e7, s.lon_e7, s.alt_cm)
        assert s.terrain_alt  # frame 10: altitude above the seabed, as the survey flies
    uploads = [e for e in events(nominal) if e["kind"] == "command" and e["message"].startswith("mission upload")]
    assert [e["message"] for e in uploads] == [f"mission upload ({len(sent)} items, verified)"]


@pytest.mark.slow
def test_nominal_dive_measures_the_paper_targets(nominal: DryRun):
    """Paper targets (2.8-4.7 cm high): mean |error| <= 0.2 cm against the truth."""
    scored = [t for t in nominal.summary["heights_vs_truth"] if t["matched"]]
    assert len(scored) >= 4, nominal.summary["heights_vs_truth"]
    mean_err = sum(abs(t["error_m"]) for t in scored) / len(scored)
    assert mean_err <= 0.002, nominal.summary["heights_vs_truth"]


@pytest.mark.slow
def test_mavlogdump_reads_the_tlog_near_the_plans_origin(nominal: DryRun):
    """pymavlink's own ``mavlogdump.py`` reads the dive's tlog: the EKF origin the vehicle
    reports (GPS_GLOBAL_ORIGIN) is the plan's, and every position it reported once it had
    one is within the site, not 460 km away at a default origin."""
    script = Path(sys.executable).with_name("mavlogdump.py")
    out = subprocess.run([sys.executable, str(script), "--format", "csv", "--types",
                          "GLOBAL_POSITION_INT,GPS_GLOBAL_ORIGIN", str(nominal.out_dir / "dive.tlog")],
                         capture_output=True, text=True, check=True, timeout=120).stdout
    rows = list(csv.DictReader(out.splitlines()))
    origins = {(r["GPS_GLOBAL_ORIGIN.latitude"], r["GPS_GLOBAL_ORIGIN.longitude"]) for r in rows
               if r["GPS_GLOBAL_ORIGIN.latitude"]}
    plan = nominal.plan
    assert origins == {(str(round(plan.origin_lat_deg * 1e7)), str(round(plan.origin_lon_deg * 1e7)))}
    site = LocalOrigin(plan.origin_lat_deg, plan.origin_lon_deg)
    fixes = [(int(r["GLOBAL_POSITION_INT.lat"]) * 1e-7, int(r["GLOBAL_POSITION_INT.lon"]) * 1e-7) for r in rows
             if r["GLOBAL_POSITION_INT.lat"] not in ("", "0")]
    assert len(fixes) > 100
    assert max(math.hypot(*site.to_local(lat, lon)) for lat, lon in fixes) < 20.0


@pytest.mark.slow
def test_nominal_dive_writes_a_complete_run_folder(nominal: DryRun):
    out = nominal.out_dir
    for name in ("plan/plan.json", "plan/survey.plan", "plan/survey.waypoints", "plan/survey.png", "dive.tlog",
                 "events.jsonl",
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
    # one count of targets everywhere: summary, targets.csv, targets.geojson
    with (out / "targets.csv").open(newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert summary["n_targets"] == len(rows) == len(geo["features"])
    assert summary["n_targets_with_height"] == sum(1 for r in rows if r["height_m"])
    # the clearance over the tallest target (0.3 m over 0.2 m) as the lowest allowed altitude
    assert summary["min_altitude_allowed_m"] == pytest.approx(0.5)
    assert all(ex["lowest_m"] < ex["limit_m"] for ex in summary["altitude_excursions"])


@pytest.mark.slow
def test_the_same_dive_twice_is_the_same_dive(nominal: DryRun, tmp_path):
    """A dry run repeats step for step: the lockstep clock lets the link's reader go before
    the executor in every step (sim_harness.clock, ranks), so what the executor sees, and
    so everything it commanded and logged, never depends on the host's thread scheduling.
    Flown twice, the nominal dive writes the same navigation, tilt, filter, shadows,
    targets and events, byte for byte, and the same summary but for its wall time."""
    again = dive(tmp_path)
    for name in ("nav.csv", "tilt.csv", "filter.csv", "shadows.csv", "targets.csv", "events.jsonl",
                 "truth_track.csv"):
        assert (again.out_dir / name).read_bytes() == (nominal.out_dir / name).read_bytes(), name
    first, second = (dict(d.summary, wall_duration_s=None) for d in (nominal, again))
    assert first == second


@pytest.mark.slow
def test_refused_arming_aborts_without_moving(tmp_path):
    dry = dive(tmp_path, faults=FaultConfig(refuse_commands=frozenset({MAV_CMD_COMPONENT_ARM_DISARM})))
    assert dry.summary["status"] == "aborted"
    assert dry.summary["reason"] == "command_refused"
    assert not any(h.armed for h in dry.simulator.truth_history())
    assert max(h.depth_m for h in dry.simulator.truth_history()) < 0.5


@pytest.mark.slow
def test_packet_loss_and_latency(nominal: DryRun, tmp_path):
    """30 % packet loss each way and 200 ms latency: the survey is still flown to the end
    and measured (lost setpoints are replaced by the next, 0.2 s later, long before the
    vehicle's 3 s timeout; commands are retried), within the limits.

    The companion's heartbeat timeout is 8 s here, as a user sets it on so lossy a link:
    with the default 5 s, five of the vehicle's 1 Hz heartbeats lost in a row (0.3^5 =
    0.24 % at each) end the dive as "link lost", which over a 240 s dive happens in about
    one dive in ten (2 of 17 runs)."""
    dry = dive(tmp_path, faults=FaultConfig(seed=5, packet_loss=0.3, latency_s=0.2), link_timeout_s=8.0)
    assert dry.summary["status"] == "completed", dry.summary["message"]
    assert_safe(dry)
    assert dry.summary["waypoints_reached"] == nominal.summary["waypoints_reached"]
    # Tilt commands and telemetry arrive late or not at all: 1.000 observed over the
    # tracking zone; asserted with room for the spread.
    assert dry.summary["shadow_in_fov_ratio"] >= 0.75
    scored = [t for t in dry.summary["heights_vs_truth"] if t["matched"]]
    assert len(scored) >= 4
    assert sum(abs(t["error_m"]) for t in scored) / len(scored) <= 0.003


@pytest.mark.slow
def test_altimeter_dropouts_and_depth_spikes(tmp_path):
    dry = dive(tmp_path, faults=FaultConfig(seed=7, depth_spike_prob=0.02, depth_spike_m=1.0,
                                             altimeter_dropouts=(TimeWindow(50.0, 52.5), TimeWindow(70.0, 72.0))))
    assert dry.summary["status"] == "completed", dry.summary["reason"]
    assert_safe(dry)
    counters = dry.summary["filter_counters"]
    assert counters["depth"]["rejected"] > 0  # the spikes were gated out
    assert dry.summary["shadow_in_fov_ratio"] >= 0.85  # 1.000 observed (0.95 over the old 2-altitude zone)


@pytest.mark.slow
def test_current_and_disturbances(tmp_path):
    dry = dive(tmp_path, current_north_m_s=0.05, current_east_m_s=0.08)
    assert dry.summary["status"] == "completed", dry.summary["reason"]
    assert_safe(dry)
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
    fixed = dive(tmp_path, pitch_loop=False)
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
    """Pitch and roll disturbances (TRIM_AND_WAVES) with an unstabilised mount (MNT1_TYPE 7,
    angles in the body frame): the loop takes the vehicle's pitch into the tilt and keeps
    >= 99 % of the shadows whole; the fixed tilt, which centres the zone for a level
    vehicle, loses many. Observed (compact site): loop 1.000 (4 runs), fixed 0.73-0.84
    (4 runs); over the 2-altitude zone 0.81-0.85 and 0.73-0.80. (A stabilised servo mount,
    MNT1_TYPE 1, takes the pitch out itself.)"""
    body_mount = {"MNT1_TYPE": 7.0}
    closed = dive(tmp_path, "loop", attitude=TRIM_AND_WAVES, autopilot_params=body_mount)
    fixed = dive(tmp_path, "fixed", attitude=TRIM_AND_WAVES, pitch_loop=False, autopilot_params=body_mount)
    for dry in (closed, fixed):
        assert dry.summary["status"] == "completed", dry.summary["reason"]
        assert_safe(dry)
    pitch = [h.pitch_rad for h in closed.simulator.truth_history() if h.armed]
    assert min(pitch) < math.radians(-5.0) and max(pitch) > math.radians(-1.0)  # the premise: it pitched
    assert closed.summary["shadow_frames_within_range"] >= 80
    assert closed.summary["shadow_in_fov_ratio"] >= 0.99, closed.summary["shadow_in_fov_ratio"]
    assert fixed.summary["shadow_in_fov_ratio"] <= 0.92, fixed.summary["shadow_in_fov_ratio"]
    scored = [t for t in closed.summary["heights_vs_truth"] if t["matched"]]
    assert len(scored) >= 4
    assert sum(abs(t["error_m"]) for t in scored) / len(scored) <= 0.002


@pytest.mark.slow
def test_both_passes_see_the_whole_area(nominal: DryRun):
    # The judge's footprints from the true poses: the plan's swath covers the area at each altitude.
    coverage = nominal.summary["coverage_by_truth"]
    assert coverage["region_m2"] == pytest.approx(nominal.plan.summary.area_m2, abs=0.01)
    planned = [p.coverage_fraction for p in nominal.plan.passes]
    # What the planner promised for each pass, seen from the truth. The planner's swath is
    # the plan's tilt; the pitch loop moves the tilt to hold the shadows, which moves the
    # footprint (on this 14 m^2 site 3-6 % of the area, at its edges, is then missed by one
    # pass; 0.3-0.8 % on paper-targets): a known gap, bounded here.
    assert coverage["pass_1"] >= planned[0] - 0.08 and coverage["pass_2"] >= planned[1] - 0.08
    assert coverage["every_pass"] >= min(planned) - 0.10
    assert coverage["any_pass"] <= 1.0


def test_a_failing_simulator_is_the_error_the_dry_run_raises(tmp_path, monkeypatch):
    """When the simulated vehicle itself fails mid-dive (a bug of ours, not a fault of the
    scenario), it stops the clock: the dry run must raise the simulator's own error, not
    the stopped clock every other thread then meets."""
    from sim_harness.simulator import VehicleSimulator

    step = VehicleSimulator.step

    def failing(self):
        if self.clock.now_s() > 3.0:
            raise ArithmeticError("the simulated vehicle broke")
        return step(self)

    monkeypatch.setattr(VehicleSimulator, "step", failing)
    with pytest.raises(ArithmeticError, match="simulated vehicle broke"):
        dive(tmp_path)
