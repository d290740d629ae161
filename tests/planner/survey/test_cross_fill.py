"""Cross lanes over the ground no run along the lanes can see (a corridor between two obstacles)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely

from planner.config import default_settings
from planner.survey.altitudes import choose_altitudes
from planner.survey.area import SurveyArea
from planner.survey.cross_fill import cross_lanes, pockets
from planner.survey.footprint import footprint
from planner.survey.lane_options import piece_options
from planner.survey.lawnmower import LaneFrame, free_region, plan_survey
from planner.survey.pieces import free_intervals, lane_pieces

SETTINGS = default_settings()
CHOICE = choose_altitudes(SETTINGS)


def _corridor(gap_m: float) -> SurveyArea:
    """A 60 m square with two 40 m x 5 m holes one above the other, ``gap_m`` apart."""
    holes = [shapely.box(10, 20, 50, 25), shapely.box(10, 25 + gap_m, 50, 30 + gap_m)]
    boundary = shapely.Polygon(shapely.box(0, 0, 60, 60).exterior, [h.exterior for h in holes])
    return SurveyArea(43.0, 5.0, shapely.orient_polygons(boundary))


def _pockets(area: SurveyArea, heading_rad: float) -> shapely.Geometry:
    fps = (footprint(CHOICE.altitude1_m, CHOICE.tilt1_rad, SETTINGS.sonar),
           footprint(CHOICE.altitude2_m, CHOICE.tilt2_rad, SETTINGS.sonar))
    spacing = min(f.swath_m for f in fps) * (1 - SETTINGS.survey.overlap)
    frame = LaneFrame(heading_rad)
    region = frame.to_lane(area.coverage_region)
    pieces = lane_pieces(region, spacing)
    free = frame.to_lane(free_region(area, max(math.hypot(f.near_ground_m, spacing / 2) for f in fps),
                                     SETTINGS.survey.obstacle_margin_m))
    free_iv = free_intervals(pieces, free)
    opts = [piece_options(pieces, free_iv, f.near_ground_m) for f in fps]
    return pockets(region, pieces, opts, fps, spacing)


def test_corridor_across_the_lanes_is_flown_along_it() -> None:
    """Lanes north, a 6 m corridor between the holes: a lane run can neither lead in from
    below the lower hole nor look at the corridor from inside it (the band starts 5.4 and
    6.4 m ahead), so no way along the lanes sees it (coverage 0.960 and 0.991 before).
    Two cross lanes fly it east-west, inside its free band (1 m from each hole), and both
    passes fly them."""
    area = _corridor(6.0)
    plan = plan_survey(area, SETTINGS, choice=CHOICE, heading_rad=0.0)
    lanes = []
    for p in plan.passes:
        assert p.coverage_fraction > 0.999
        cross = [r for r in p.runs if r.lane >= plan.summary.n_lanes]
        assert len(cross) == 2
        for r in cross:
            assert abs(math.sin(r.heading_rad)) == pytest.approx(1.0)
            assert 26.0 <= r.start_north_m <= 30.0
            assert min(r.start_east_m, r.end_east_m) < 10.0 or max(r.start_east_m, r.end_east_m) > 50.0
        lanes.append(sorted({r.lane for r in p.runs}))
    assert lanes[0] == lanes[1]


def test_wide_corridor_and_lanes_along_it_need_no_cross_lanes() -> None:
    """A 16 m corridor is seen flying each of its pieces one way and back; with the lanes
    east-west the corridor is open along them. No pockets either way."""
    assert _pockets(_corridor(16.0), 0.0).is_empty
    assert _pockets(_corridor(6.0), math.pi / 2).is_empty
    pocket = _pockets(_corridor(6.0), 0.0)
    # The corridor's middle (lane frame: u north, v west), the holes' width across.
    u0, v0, u1, v1 = pocket.bounds
    assert 25.0 <= u0 and u1 <= 31.0 and -50.5 <= v0 and v1 <= -9.5
    assert pocket.area > 100.0


def test_cross_lanes_turn_the_lane_frame() -> None:
    """Cross pieces run along the lane frame's v; their runs come back in the lane frame."""
    pocket = shapely.box(0.0, -20.0, 4.0, 20.0)  # lane frame: 4 m along u, 40 m across
    free = shapely.box(-100.0, -100.0, 100.0, 100.0)
    cross = cross_lanes(pocket, free, 2.0, first_lane=10)
    assert [p.k for p in cross.pieces] == [10, 11]
    assert all(p.b - p.a == pytest.approx(40.0) for p in cross.pieces)
    for opts in cross.options(5.0, first_index=7):
        for o in opts:
            assert o.piece >= 7
            (a, b), = o.runs
            assert a[0] == pytest.approx(b[0])  # constant u: across the lanes
            assert 0.0 <= a[0] <= 4.0
            assert abs(b[1] - a[1]) == pytest.approx(40.0)
    assert np.isclose(sorted({float(o.runs[0][0][0]) for opts in cross.options(5.0, 0) for o in opts}),
                      [1.0, 3.0]).all()
