"""Altitude filter: dH precision across a 0.1 m step, consistency, speed; sonar altitude.

The dive is the one of ``tests/perception/navigation/test_altitude_filter_consistency.py``
(``tests.perception.navigation.altitude_dive``): descent 2 -> 4 m over 20 s, 12 s hold, 0.1 m step up
over 8 s, 12 s hold, seabed at 10 m; depth 1 cm at 10 Hz, altimeter 2 cm at 5 Hz; the
vehicle's uncommanded wander (white acceleration) and the seabed (random walk) drawn from
the filter's process model; the filter is told when the descent and the step are
commanded. dH is asked between 5 s before the step starts and 5 s after it ends.

Run from the repository root: ``python -m benchmarks.bench_altitude_filter [--runs N]``.
"""

from __future__ import annotations

import argparse
import math
import platform
import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from perception.navigation.altitude_filter import AltitudeFilter, AltitudeFilterConfig
from tests.perception.navigation.altitude_dive import chi2_interval, feed, in_maneuver, nees, simulate_dive

HOLD_PSD = 1e-5
MANEUVER_PSD = 3e-4
SEABED_PSD = 1e-8


@dataclass
class DhFigures:
    runs: int
    reported_std_m: float
    empirical_rms_m: float
    bias_m: float
    independent_std_m: float
    hold_nees: float
    nees_bounds: tuple[float, float]
    nis_depth: float
    nis_altimeter: float
    nis_bounds: tuple[float, float]


def dh_monte_carlo(
    runs: int, *, hold_psd: float = HOLD_PSD, seabed_psd: float = SEABED_PSD, seed: int = 1
) -> DhFigures:
    config = AltitudeFilterConfig(
        accel_psd_m2_s3=hold_psd, maneuver_accel_psd_m2_s3=MANEUVER_PSD, seabed_walk_psd_m2_s=seabed_psd
    )
    rng = np.random.default_rng(seed)
    err: list[float] = []
    var: list[float] = []
    ind: list[float] = []
    fn: list[float] = []
    nis_d: list[float] = []
    nis_a: list[float] = []
    for _ in range(runs):
        dive = simulate_dive(rng, accel_psd_m2_s3=hold_psd, seabed_walk_psd_m2_s=seabed_psd)
        key = dive.key_times
        flt = AltitudeFilter(config)
        for i, result in feed(flt, dive):
            t = dive.times_s[i]
            if t > 5.0 and not in_maneuver(t, key):
                x, p = flt.filtered_state()
                fn.append(nees(x, p, dive.truth[i]))
                (nis_d if dive.sensors[i] == "depth" else nis_a).append(result.nis)
        t1, t2 = key.step_start_s - 5.0, key.step_end_s + 5.0
        est = flt.delta_altitude(t1, t2)
        a1, a2 = dive.truth_at(t1), dive.truth_at(t2)
        err.append(est.mean - ((a2[2] - a2[0]) - (a1[2] - a1[0])))
        var.append(est.variance)
        ind.append(flt.altitude_at(t1).variance + flt.altitude_at(t2).variance)
    e = np.array(err)
    return DhFigures(
        runs,
        float(np.sqrt(np.mean(var))),
        float(np.sqrt(np.mean(e**2))),
        float(np.mean(e)),
        float(np.sqrt(np.mean(ind))),
        float(np.mean(fn)),
        chi2_interval(3, runs),
        float(np.mean(nis_d)),
        float(np.mean(nis_a)),
        chi2_interval(1, runs),
    )


def speed(window_s: float = 120.0) -> tuple[float, float, float]:
    """(us per update, ms for the first query after an update, us per further query)."""
    flt = AltitudeFilter(AltitudeFilterConfig(window_s=window_s))
    rng = np.random.default_rng(3)
    n = int(window_s * 10)
    t0 = time.perf_counter()
    for k in range(n):
        t = 0.1 * k
        flt.update_depth(t, 5.0 + 0.01 * rng.standard_normal(), 0.01)
        if k % 2:
            flt.update_altimeter(t, 3.0 + 0.02 * rng.standard_normal(), 0.02)
    per_update_us = (time.perf_counter() - t0) / (n * 1.5) * 1e6
    last = 0.1 * (n - 1)
    t1 = time.perf_counter()
    flt.delta_altitude(last - 60.0, last - 1.0)
    first_ms = (time.perf_counter() - t1) * 1e3
    t2 = time.perf_counter()
    for k in range(50):
        flt.delta_altitude(last - 60.0 + 0.37 * k, last - 1.0)
    per_query_us = (time.perf_counter() - t2) / 50 * 1e6
    return per_update_us, first_ms, per_query_us


def sonar_altitude_figures() -> list[tuple[float, float, float, float, float]]:
    """Renderer frames (sim_harness, ARIS 3000 defaults) over a flat seabed:
    (altitude, tilt deg, error mm, reported std mm, ms per frame)."""
    from perception.navigation.seabed_start import sonar_altitude
    from sim_harness.sonar.renderer import SonarConfig, SonarPose, SonarRenderer
    from sim_harness.world.world import Seabed, World

    renderer = SonarRenderer(World(Seabed(10.0)), SonarConfig())
    rows = []
    for altitude, tilt_deg in [(1.0, 25.0), (1.5, 30.0), (2.0, 40.0)]:
        pose = SonarPose(0.0, 0.0, 10.0 - altitude, 0.3, 0.0, 0.0, math.radians(tilt_deg))
        errors, stds, times = [], [], []
        for k in range(10):
            frame, _ = renderer.render(pose, 1.0 + 0.1 * k)
            t0 = time.perf_counter()
            result = sonar_altitude(frame)
            times.append(time.perf_counter() - t0)
            errors.append(result.altitude_m - altitude)
            stds.append(result.std_m)
        rows.append((altitude, tilt_deg, float(np.mean(errors)) * 1e3, float(np.mean(stds)) * 1e3,
                     float(np.median(times)) * 1e3))
    return rows


def run(runs: int) -> str:
    main_fig = dh_monte_carlo(runs)
    sweep = [(h, s, dh_monte_carlo(max(runs // 2, 10), hold_psd=h, seabed_psd=s, seed=2))
             for h, s in [(3e-6, 1e-8), (1e-5, 1e-8), (1e-4, 1e-8), (1e-5, 1e-6)]]
    per_update_us, first_ms, per_query_us = speed()
    sonar = sonar_altitude_figures()
    f = main_fig
    lines = [
        "## altitude_filter",
        "",
        f"Monte Carlo of the simulated dive ({f.runs} runs; see `benchmarks/bench_altitude_filter.py`): "
        "depth 1 cm at 10 Hz, altimeter 2 cm at 5 Hz, hold accel PSD "
        f"{HOLD_PSD:g} m^2/s^3, manoeuvre PSD {MANEUVER_PSD:g}, seabed walk {SEABED_PSD:g} m^2/s; "
        "dH between 5 s before and 5 s after the 0.1 m step.",
        "",
        "| measure | figure |",
        "| --- | --- |",
        f"| dH std reported by the filter (joint covariance) | {f.reported_std_m * 1e3:.2f} mm |",
        f"| dH error RMS over the runs | {f.empirical_rms_m * 1e3:.2f} mm (bias {f.bias_m * 1e3:+.2f} mm) |",
        f"| dH std if the two altitudes were independent | {f.independent_std_m * 1e3:.2f} mm |",
        f"| filtered NEES while holding (3 states), mean | {f.hold_nees:.2f} "
        f"(95 % bounds for a {f.runs}-run average {f.nees_bounds[0]:.2f}-{f.nees_bounds[1]:.2f}) |",
        f"| NIS depth / altimeter while holding, mean | {f.nis_depth:.2f} / {f.nis_altimeter:.2f} "
        f"(bounds {f.nis_bounds[0]:.2f}-{f.nis_bounds[1]:.2f}) |",
        "",
        "dH precision against the process-noise settings (the filter's and the truth's):",
        "",
        "| hold accel PSD m^2/s^3 | seabed walk PSD m^2/s | runs | dH std reported | dH error RMS |",
        "| --- | --- | --- | --- | --- |",
    ]
    for h, s, fig in sweep:
        lines.append(f"| {h:g} | {s:g} | {fig.runs} | {fig.reported_std_m * 1e3:.2f} mm | "
                     f"{fig.empirical_rms_m * 1e3:.2f} mm |")
    lines += [
        "",
        "Speed (120 s window, depth 10 Hz + altimeter 5 Hz = 1800 steps):",
        "",
        "| measure | figure |",
        "| --- | --- |",
        f"| one update (predict, gate, filterpy update, store the smoother gain) | {per_update_us:.0f} us |",
        f"| first dH query after an update, t1 60 s back (backward pass over 900 steps) | {first_ms:.1f} ms |",
        f"| further dH queries until the next update (gain-chain product) | {per_query_us / 1e3:.1f} ms |",
        "",
        "Sonar altitude from the seabed onset (`perception.navigation.seabed_start.sonar_altitude`) on "
        "`sim_harness` renderer frames (ARIS 3000 defaults, 128 x 1000, flat seabed, 10 pings each):",
        "",
        "| altitude m | tilt deg | mean error | reported std | time per frame |",
        "| --- | --- | --- | --- | --- |",
    ]
    for altitude, tilt, err_mm, std_mm, ms in sonar:
        lines.append(f"| {altitude:.1f} | {tilt:.0f} | {err_mm:+.1f} mm | {std_mm:.1f} mm | {ms:.2f} ms |")
    lines += [
        "",
        f"Machine: {platform.machine()}, {platform.system()}, Python {platform.python_version()}; "
        f"taken {time.strftime('%Y-%m-%d', time.gmtime())} while other jobs ran (timings noisy). "
        "Repeat: `python -m benchmarks.bench_altitude_filter --runs 50`.",
    ]
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=50, help="Monte Carlo runs (default 50)")
    args = parser.parse_args(argv)
    print(run(args.runs))


if __name__ == "__main__":
    main()
