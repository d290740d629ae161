"""The judge's coverage: footprints from first principles, passes from the executor's states."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pytest
import shapely
from hypothesis import given
from hypothesis import strategies as st

from planner.dryrun.coverage import insonified_ground, pass_coverage, pass_intervals

FAN = np.radians(np.linspace(-15.0, 15.0, 128))
APERTURE = math.radians(14.0)


def _footprint(**kw):
    args = dict(north_m=0.0, east_m=0.0, heading_rad=0.0, pitch_rad=0.0, roll_rad=0.0, tilt_rad=math.radians(30.0),
                altitude_m=2.0, beam_azimuth_rad=FAN, window_start_m=1.0, window_end_m=8.0,
                elevation_aperture_rad=APERTURE)
    args.update(kw)
    return insonified_ground(**args)


def test_a_level_ping_sees_the_ground_between_its_aperture_edges() -> None:
    polygon = _footprint()
    # Straight ahead (north), the seabed from H / tan(30 + 7 deg) to H / tan(30 - 7 deg).
    near, far = 2.0 / math.tan(math.radians(37.0)), 2.0 / math.tan(math.radians(23.0))
    ahead = polygon.intersection(shapely.LineString([(0.0, 0.0), (0.0, 20.0)]))
    assert ahead.bounds[1] == pytest.approx(near, abs=0.08)
    assert ahead.bounds[3] == pytest.approx(far, abs=0.08)
    # About the annular sector of the fan's 30 deg.
    sector = 0.5 * math.radians(30.0) * (far**2 - near**2)
    assert polygon.area == pytest.approx(sector, rel=0.08)


def test_the_window_cuts_the_footprint_and_the_heading_turns_it() -> None:
    cut = _footprint(window_end_m=3.5)  # far edge at sqrt(3.5^2 - 2^2) = 2.87 m ground range
    assert cut.bounds[3] == pytest.approx(math.sqrt(3.5**2 - 4.0), abs=0.05)
    east = _footprint(heading_rad=math.pi / 2)
    assert east.centroid.x > 2.0 and abs(east.centroid.y) < 0.1  # (east_m, north_m)
    assert _footprint(tilt_rad=math.radians(-20.0)) is None  # looking up: no seabed


@given(st.floats(0.3, 5.0), st.floats(0.2, 1.2), st.floats(-0.2, 0.2), st.floats(-0.2, 0.2))
def test_every_footprint_point_is_within_the_window_on_the_ground(altitude_m, tilt_rad, pitch_rad, roll_rad) -> None:
    polygon = _footprint(altitude_m=altitude_m, tilt_rad=tilt_rad, pitch_rad=pitch_rad, roll_rad=roll_rad)
    if polygon is None:
        return
    points = np.asarray(polygon.exterior.coords)
    ground = np.hypot(points[:, 0], points[:, 1])
    assert np.all(ground <= math.sqrt(max(8.0**2 - altitude_m**2, 0.0)) + 1e-6)
    assert np.all(ground >= math.sqrt(max(1.0**2 - altitude_m**2, 0.0)) - 1e-6)


@dataclass
class _Pose:
    north_m: float
    east_m: float
    heading_rad: float = 0.0
    pitch_rad: float = 0.0
    roll_rad: float = 0.0
    tilt_rad: float = math.radians(30.0)


@dataclass
class _Truth:
    pose: _Pose
    altitude_m: float


def test_coverage_of_a_lane_by_two_passes() -> None:
    # Pass 1 runs north along east = 0 at 2 m; pass 2 only the first half of it.
    frames = [(0.1 * i, _Truth(_Pose(0.05 * i - 10.0, 0.0), 2.0)) for i in range(400)]
    frames += [(100.0 + 0.1 * i, _Truth(_Pose(0.05 * i - 10.0, 0.0), 2.0)) for i in range(200)]
    states = [(0.0, "PASS_1"), (40.0, "ALTITUDE_CHANGE"), (100.0, "PASS_2"), (120.0, "FINISH")]
    passes = pass_intervals(states, 130.0)
    assert passes == {"PASS_1": (0.0, 40.0), "PASS_2": (100.0, 120.0)}
    region = shapely.box(-1.0, -5.0, 1.0, 5.0)  # 2 m wide (east), 10 m long (north)
    out = pass_coverage(frames, passes, region, beam_azimuth_rad=FAN, window_start_m=1.0, window_end_m=8.0,
                        elevation_aperture_rad=APERTURE)
    assert out["region_m2"] == pytest.approx(20.0)
    # Pass 1 sees from north -10 + 2.65 m on: all of the region; pass 2 up to 0 + 4.7 m ahead.
    assert out["pass_1"] == pytest.approx(1.0, abs=0.02)
    assert 0.85 < out["pass_2"] < 1.0
    assert out["every_pass"] == pytest.approx(out["pass_2"], abs=1e-3)
    assert out["any_pass"] == pytest.approx(1.0, abs=0.02)
