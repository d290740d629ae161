"""Planner benchmark: a 1 km x 1 km area with three holes at a 5 m swath.

``python -m benchmarks.bench_planner`` prints a Markdown section: the time to plan both
passes (lanes, decomposition, lead-ins, routing around the holes) with and without the
coverage computation, with the lane heading chosen automatically, the altitude/tilt
optimisation, and writing every output file; best of N runs.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import platform
import tempfile
import time
from collections.abc import Callable

import shapely

from planner.config import Settings, default_settings
from planner.survey.altitudes import AltitudeChoice, choose_altitudes
from planner.survey.area import SurveyArea
from planner.survey.footprint import footprint
from planner.survey.lawnmower import plan_survey
from planner.survey.mission_files import write_outputs

SWATH_M = 5.0
#: Bisection aims a hair above the swath so that 200 lanes span the kilometre.
_SWATH_AIM_M = 5.002


def bench_area() -> SurveyArea:
    """1 km x 1 km with three holes (a square, a rotated rectangle, an octagon)."""
    holes = [
        shapely.box(200, 250, 320, 330),
        shapely.affinity.rotate(shapely.box(550, 500, 750, 560), 35),
        shapely.Point(400, 780).buffer(60, quad_segs=2),
    ]
    boundary = shapely.Polygon(
        [(0, 0), (1000, 0), (1000, 1000), (0, 1000)], [h.exterior.coords for h in holes]
    )
    return SurveyArea(43.29, 5.36, shapely.orient_polygons(boundary))


def _tilt_for_swath(altitude_m: float, settings: Settings) -> float:
    """Mount tilt at which the footprint's swath is SWATH_M (bisection; swath falls with tilt)."""
    lo, hi = math.radians(1.0), math.radians(60.0)
    for _ in range(50):
        mid = 0.5 * (lo + hi)
        try:
            wide = footprint(altitude_m, mid, settings.sonar).swath_m > _SWATH_AIM_M
        except ValueError:
            wide = False  # too shallow: the band starts past the window
            lo = mid
            continue
        lo, hi = (mid, hi) if wide else (lo, mid)
    return 0.5 * (lo + hi)


def bench_setup() -> tuple[SurveyArea, Settings, AltitudeChoice]:
    base = default_settings()
    settings = dataclasses.replace(
        base,
        sonar=dataclasses.replace(base.sonar, window_end_m=30.0, samples_per_beam=2000),
        survey=dataclasses.replace(base.survey, overlap=0.0),
    )
    h1, h2 = 3.0, 4.0
    choice = AltitudeChoice(h1, h2 - h1, _tilt_for_swath(h1, settings), _tilt_for_swath(h2, settings),
                            10.0, math.nan, (math.nan, math.nan), math.nan, math.nan, ())
    return bench_area(), settings, choice


def best_of(fn: Callable[[], object], runs: int) -> tuple[float, float]:
    """Best wall-clock and best CPU (this process) time over ``runs`` calls, s."""
    wall, cpu = math.inf, math.inf
    for _ in range(runs):
        t0, c0 = time.perf_counter(), time.process_time()
        fn()
        wall = min(wall, time.perf_counter() - t0)
        cpu = min(cpu, time.process_time() - c0)
    return wall, cpu


def _ms(t: tuple[float, float]) -> str:
    return f"{1000 * t[0]:.0f} ms ({1000 * t[1]:.0f} ms CPU)"


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--runs", type=int, default=5)
    args = parser.parse_args(argv)
    area, settings, choice = bench_setup()
    plan = plan_survey(area, settings, choice=choice, heading_rad=0.0)
    t_plan = best_of(lambda: plan_survey(area, settings, choice=choice, heading_rad=0.0,
                                         with_coverage=False), args.runs)
    t_cov = best_of(lambda: plan_survey(area, settings, choice=choice, heading_rad=0.0), args.runs)
    t_auto = best_of(lambda: plan_survey(area, settings, choice=choice, with_coverage=False),
                     max(1, args.runs // 2))
    t_alt = best_of(lambda: choose_altitudes(default_settings()), max(1, args.runs // 2))
    with tempfile.TemporaryDirectory() as tmp:
        t_write = best_of(lambda: write_outputs(plan, area, tmp), max(1, args.runs // 2))
    s = plan.summary
    n_wp = sum(len(p.waypoints) for p in plan.passes)
    print("## planner\n")
    print(f"1 km x 1 km area with three holes (square, rotated rectangle, octagon), swath "
          f"{min(p.swath_m for p in plan.passes):.2f} m, overlap 0: {s.n_lanes} lanes, "
          f"{s.n_runs} runs and {n_wp} waypoints over both passes, "
          f"{s.total_length_m / 1000:.1f} km; coverage {100 * s.coverage_fraction:.2f} % "
          f"(worse pass). Best of {args.runs} runs. Machine: {platform.machine()}, "
          f"{platform.system()}, Python {platform.python_version()}.\n")
    print("| measure | figure |")
    print("| --- | --- |")
    print(f"| plan both passes, lanes north-south (no coverage figure) | {_ms(t_plan)} |")
    print(f"| plan both passes + coverage of each (shapely union) | {_ms(t_cov)} |")
    print(f"| plan both passes, lane heading chosen (auto) | {_ms(t_auto)} |")
    print(f"| altitude/tilt choice (casadi/ipopt, shipped settings) | {_ms(t_alt)} |")
    print(f"| write plan.json, .plan, .waypoints, .geojson, summary | {_ms(t_write)} |")
    print()


if __name__ == "__main__":
    main()
