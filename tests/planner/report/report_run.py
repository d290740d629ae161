"""A synthetic run folder in the agreed run-folder format, for the report tests.

A two-pass lawnmower over a flat seabed 10 m deep: pass 1 at 2.0 m, pass 2 at 1.4 m,
with the executor's states, a noisy altimeter with a few rejected spikes, a lagging tilt
mount, shadow margins, five true targets and their estimates. ``abort_at_s`` cuts the
dive short with a failsafe and an ABORTED state.
"""

from __future__ import annotations

import csv
import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

SEABED_DEPTH_M = 10.0
PASSES = (("pass_1", 2.0, 20.0), ("pass_2", 1.4, 28.0))
SPEED_M_S = 0.5
TRUE_TARGETS = (  # id, north, east, height (m), shape
    ("1", 4.0, 1.5, 0.12, "box"), ("2", 9.0, 4.4, 0.20, "cylinder"), ("3", 14.0, 7.6, 0.08, "sphere"),
    ("4", 17.0, 2.9, 0.30, "tyre"), ("5", 6.0, 10.5, 0.15, "box"),
)
#: Estimates: id, north, east, height, std (NaN height = none); "9" is a false detection.
ESTIMATES = (
    ("a", 4.2, 1.4, 0.127, 0.006), ("b", 9.1, 4.6, 0.188, 0.008), ("c", 13.7, 7.7, math.nan, math.nan),
    ("d", 17.3, 3.1, 0.316, 0.010), ("9", 0.5, 12.0, 0.05, 0.02),
)


@dataclass(frozen=True)
class WrittenRun:
    """What was written: paths and the final time."""

    root: Path
    end_s: float
    n_nav_rows: int


def lanes_ne_m() -> np.ndarray:
    """Four north-going lanes 20 m long, 3 m apart, shape (4, 2, 2)."""
    out = []
    for k in range(4):
        e = 1.5 + 3.0 * k
        run = [[0.0, e], [20.0, e]]
        out.append(run if k % 2 == 0 else run[::-1])
    return np.array(out)


def _write_csv(path: Path, header: list[str], rows: list[list[object]]) -> None:
    with path.open("w", newline="", encoding="utf-8") as handle:
        w = csv.writer(handle)
        w.writerow(header)
        for r in rows:
            w.writerow(["" if isinstance(v, float) and not math.isfinite(v) else
                        (f"{v:.6g}" if isinstance(v, float) else v) for v in r])


def write_run(root: Path, rng: np.random.Generator, *, simulated: bool = True,
              abort_at_s: float | None = None, full_plan: bool = True) -> WrittenRun:
    """Write the synthetic run folder into ``root`` (created)."""
    root.mkdir(parents=True, exist_ok=True)
    lanes = lanes_ne_m()
    path = lanes.reshape(-1, 2)
    # States and the time each begins.
    timeline: list[tuple[str, float]] = [("CONNECT", 0.0), ("PREFLIGHT", 3.0), ("ARM", 8.0), ("DESCEND", 10.0)]
    t = 10.0 + (SEABED_DEPTH_M - PASSES[0][1]) / 0.25
    leg_lengths = np.hypot(*np.diff(path, axis=0).T)
    pass_s = float(leg_lengths.sum()) / SPEED_M_S
    timeline += [("PASS_1", t), ("ALTITUDE_CHANGE", t + pass_s), ("PASS_2", t + pass_s + 15.0),
                 ("FINISH", t + 2 * pass_s + 15.0), ("COMPLETED", t + 2 * pass_s + 35.0)]
    end_s = timeline[-1][1]
    if abort_at_s is not None:
        timeline = [s for s in timeline if s[1] < abort_at_s] + [("ABORTED", abort_at_s)]
        end_s = abort_at_s
    starts = dict(timeline)
    times = np.arange(0.0, end_s + 1e-9, 0.5)

    def pos(ts: float) -> tuple[float, float, float]:
        """north, east, altitude at time ts."""
        p1, p2 = starts.get("PASS_1", math.inf), starts.get("PASS_2", math.inf)
        if ts < p1:
            alt = max(PASSES[0][1], SEABED_DEPTH_M - 0.25 * max(ts - 10.0, 0.0)) if ts >= 10.0 else SEABED_DEPTH_M
            return path[0][0], path[0][1], alt
        in_pass2 = ts >= p2
        s = (ts - (p2 if in_pass2 else p1)) * SPEED_M_S
        alt = PASSES[1][1] if in_pass2 else PASSES[0][1]
        if not in_pass2 and ts >= p1 + pass_s:  # altitude change at the end of pass 1, back to the start
            frac = min((ts - p1 - pass_s) / 15.0, 1.0)
            return (path[-1][0] * (1 - frac) + path[0][0] * frac, path[-1][1] * (1 - frac) + path[0][1] * frac,
                    PASSES[0][1] + (PASSES[1][1] - PASSES[0][1]) * frac)
        cum = np.concatenate([[0.0], np.cumsum(leg_lengths)])
        if s >= cum[-1]:
            return path[-1][0], path[-1][1], alt + (ts - p2 - pass_s) * 0.3 if in_pass2 else alt
        k = int(np.searchsorted(cum, s, side="right") - 1)
        f = (s - cum[k]) / leg_lengths[k]
        n, e = path[k] + f * (path[k + 1] - path[k])
        return float(n), float(e), alt

    truth = np.array([pos(float(x)) for x in times])
    nav_n = truth[:, 0] + rng.normal(0, 0.08, len(times))
    nav_e = truth[:, 1] + rng.normal(0, 0.08, len(times))
    alt_true = truth[:, 2]
    depth_true = SEABED_DEPTH_M - alt_true
    altimeter = alt_true + rng.normal(0, 0.03, len(times))
    spikes = rng.choice(np.arange(20, len(times)), size=min(4, max(len(times) - 20, 0)), replace=False)
    altimeter[spikes] += 1.5
    rejected = np.cumsum(np.isin(np.arange(len(times)), spikes))
    clean = np.where(np.isin(np.arange(len(times)), spikes), alt_true, altimeter)
    est = np.convolve(np.pad(clean, 2, mode="edge"), np.ones(5) / 5, mode="valid")
    std = 0.02 + 0.05 * np.exp(-times / 30.0)
    states = np.array([max((s for s in timeline if s[1] <= x), key=lambda s: s[1])[0] for x in times])
    in_p2 = np.isin(states, ["PASS_2", "FINISH"])
    tilt_cmd = np.where(in_p2, PASSES[1][2], PASSES[0][2])
    tilt_meas = np.copy(tilt_cmd).astype(float)
    for i in range(1, len(times)):
        tilt_meas[i] = tilt_meas[i - 1] + 0.3 * (tilt_cmd[i] - tilt_meas[i - 1])
    pitch = rng.normal(0, 0.8, len(times))
    margin = 3.0 - np.abs(tilt_meas - tilt_cmd) - np.abs(pitch) + rng.normal(0, 0.3, len(times))
    survey = np.isin(states, ["PASS_1", "PASS_2"])
    margin = np.where(survey, margin, np.nan)
    n_tracked = np.where(survey, rng.integers(0, 3, len(times)), 0)
    armed = ~np.isin(states, ["CONNECT", "PREFLIGHT"])
    _write_csv(root / "nav.csv", ["t_s", "north_m", "east_m", "depth_m", "altitude_m", "heading_deg", "pitch_deg",
                                  "roll_deg", "mode", "armed"],
               [[float(times[i]), float(nav_n[i]), float(nav_e[i]), float(depth_true[i]), float(altimeter[i]),
                 0.0, float(pitch[i]), 0.1, "ALT_HOLD" if armed[i] else "MANUAL", int(armed[i])]
                for i in range(len(times))])
    _write_csv(root / "filter.csv", ["t_s", "depth_est_m", "altitude_est_m", "altitude_std_m", "seabed_depth_est_m",
                                     "altimeter_m", "rejected_total"],
               [[float(times[i]), float(depth_true[i]), float(est[i]), float(std[i]), SEABED_DEPTH_M + 0.01,
                 float(altimeter[i]), int(rejected[i])] for i in range(len(times))])
    _write_csv(root / "tilt.csv", ["t_s", "tilt_cmd_deg", "tilt_meas_deg", "pitch_deg", "min_margin_deg", "n_tracked",
                                   "altitude_target_m"],
               [[float(times[i]), float(tilt_cmd[i]), float(tilt_meas[i]), float(pitch[i]), float(margin[i]),
                 int(n_tracked[i]), PASSES[1][1] if in_p2[i] else PASSES[0][1]] for i in range(len(times))])
    with (root / "events.jsonl").open("w", encoding="utf-8") as handle:
        for state, ts in timeline:
            record = {"t_s": ts, "kind": "state", "message": f"entering {state}", "state": state}
            handle.write(json.dumps(record) + "\n")
        handle.write(json.dumps({"t_s": 12.0, "kind": "command", "message": "set mode ALT_HOLD"}) + "\n")
        if end_s > 61.0:
            handle.write(json.dumps({"t_s": 61.0, "kind": "warning", "message": "altimeter spike | rejected",
                                     "value_m": 3.5}) + "\n")
        if abort_at_s is not None:
            handle.write(json.dumps({"t_s": abort_at_s - 0.5, "kind": "failsafe", "message": "leak detected",
                                     "source": "LEAK"}) + "\n")
    (root / "plan").mkdir(exist_ok=True)
    if full_plan:
        plan = {"format": "shadowsurvey-plan", "version": 1, "origin_lat_deg": 43.0, "origin_lon_deg": 5.0,
                "passes": [{"name": name, "altitude_m": alt, "tilt_rad": math.radians(tilt),
                            "waypoints": [{"north_m": float(n), "east_m": float(e), "kind": "lane_start"}
                                          for n, e in path],
                            "runs": [{"lane": k, "start_north_m": float(r[0][0]), "start_east_m": float(r[0][1]),
                                      "end_north_m": float(r[1][0]), "end_east_m": float(r[1][1])}
                                     for k, r in enumerate(lanes)]}
                           for name, alt, tilt in PASSES]}
    else:
        plan = {"origin": {"lat_deg": 43.0, "lon_deg": 5.0},
                "passes": [{"name": name, "altitude_m": alt, "tilt_deg": tilt, "waypoints_ne_m": path.tolist()}
                           for name, alt, tilt in PASSES]}
    (root / "plan" / "plan.json").write_text(json.dumps(plan), encoding="utf-8")
    _write_csv(root / "targets.csv", ["id", "lat_deg", "lon_deg", "north_m", "east_m", "height_m", "height_std_m",
                                      "frames_used", "reason"],
               [[i, 43.0, 5.0, n, e, h, s, 0 if math.isnan(h) else 6, "shadow not found" if math.isnan(h) else ""]
                for i, n, e, h, s in ESTIMATES])
    summary = {"status": "aborted" if abort_at_s is not None else "completed",
               "reason": "failsafe: leak detected" if abort_at_s is not None else "survey finished",
               "sim_duration_s": end_s, "wall_duration_s": end_s / 8.0, "min_clearance_m": 1.31,
               "depth_limit_violations": 0, "shadow_in_fov_ratio": 0.93, "n_targets": len(ESTIMATES),
               "controller": "pitch-loop v1", "frames_processed": 4071,
               "states": [{"t_s": ts, "state": st} for st, ts in timeline],
               "filter_counters": {"altimeter": {"accepted": 10, "rejected": 4}}}
    (root / "summary.json").write_text(json.dumps(summary), encoding="utf-8")
    if simulated:
        (root / "truth.json").write_text(json.dumps({"targets": [
            {"id": i, "lat": 43.0, "lon": 5.0, "north_m": n, "east_m": e, "height_m": h, "shape": shape}
            for i, n, e, h, shape in TRUE_TARGETS]}), encoding="utf-8")
        _write_csv(root / "truth_track.csv", ["t_s", "north_m", "east_m", "depth_m", "altitude_m", "tilt_deg"],
                   [[float(times[i]), float(truth[i, 0]), float(truth[i, 1]), float(depth_true[i]),
                     float(alt_true[i]), float(tilt_meas[i])] for i in range(len(times))])
        rows = []
        for i in np.flatnonzero(survey)[::2]:
            for tid, n, e, _, _ in TRUE_TARGETS:
                if math.hypot(n - truth[i, 0], e - truth[i, 1]) < 6.0:
                    rows.append([float(times[i]), tid, 1, int(margin[i] > 0), int(margin[i] > 0.5)])
        _write_csv(root / "shadows.csv", ["t_s", "target_id", "within_range", "in_fov", "settled"], rows)
    return WrittenRun(root, float(end_s), len(times))
