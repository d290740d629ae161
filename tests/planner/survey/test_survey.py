"""Survey geometry, as properties over random areas with holes and keep-outs.

Every path (lanes, lead-ins, turns, transits) stays clear of holes and keep-outs and
inside the boundary grown by the pass's excursion limit (exactly inside with
``stay_inside``); the swept sonar band covers >= 99 % of the ground at both altitudes;
every waypoint is above the clearance and within the depth limit.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
import shapely
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from planner.config import default_settings
from planner.errors import InfeasibleError
from planner.survey.altitudes import choose_altitudes
from planner.survey.area import SurveyArea
from planner.survey.footprint import footprint
from planner.survey.lawnmower import choose_heading, free_region, lane_pieces, plan_survey
from planner.survey.plan import SurveyPass, SurveyPlan

SETTINGS = default_settings()
CHOICE = choose_altitudes(SETTINGS)


@st.composite
def areas(draw: st.DrawFn) -> SurveyArea:
    """A concave star-shaped boundary (60-110 m), 0-3 holes, 0-1 keep-out across the edge."""
    n = draw(st.integers(5, 11))
    radius = draw(st.floats(60.0, 110.0))
    radii = draw(st.lists(st.floats(0.55, 1.0), min_size=n, max_size=n))
    phase = draw(st.floats(0.0, 2 * math.pi))
    ang = phase + np.arange(n) * 2 * math.pi / n
    outer = shapely.Polygon(np.column_stack([radius * np.array(radii) * np.cos(ang),
                                             radius * np.array(radii) * np.sin(ang)]))
    holes: list[shapely.Polygon] = []
    for _ in range(draw(st.integers(0, 3))):
        r = draw(st.floats(0.0, 0.45)) * radius
        a = draw(st.floats(0.0, 2 * math.pi))
        size = draw(st.floats(4.0, 14.0))
        rot = draw(st.floats(0.0, math.pi))
        hole = shapely.affinity.rotate(
            shapely.box(-size, -size / 2, size, size / 2), rot, use_radians=True
        )
        hole = shapely.affinity.translate(hole, r * math.cos(a), r * math.sin(a))
        # Holes well inside and apart from each other, as real obstacles in a survey area.
        if outer.buffer(-3.0).contains(hole) and all(hole.distance(h) > 3.0 for h in holes):
            holes.append(hole)
    keepouts: tuple[shapely.Polygon, ...] = ()
    if draw(st.booleans()):
        a = draw(st.floats(0.0, 2 * math.pi))
        edge = outer.exterior.interpolate(outer.exterior.project(
            shapely.Point(2 * radius * math.cos(a), 2 * radius * math.sin(a))))
        k = shapely.box(edge.x - 8, edge.y - 5, edge.x + 8, edge.y + 5)
        if all(k.distance(h) > 3.0 for h in holes):
            keepouts = (k,)
    boundary = shapely.Polygon(outer.exterior, [h.exterior for h in holes])
    return SurveyArea(43.0, 5.0, shapely.orient_polygons(boundary), keepouts)


def _segments(plan: SurveyPlan, i: int) -> shapely.Geometry:
    pts = np.array([[w.east_m, w.north_m] for w in plan.passes[i].waypoints])
    return shapely.LineString(pts)


def _seen_fraction(area: SurveyArea, p: SurveyPass, step_m: float = 1.0) -> float:
    """Fraction of grid points of the ground to cover that some run's band sweeps over,
    computed apart from the planner: a point at ``along``/``lateral`` of a run of length
    L is seen when some vehicle position s in [0, L] puts it at forward distance
    ``along - s`` in [max(g_near, |lateral| / tan(fan/2)), g_far]."""
    region = area.coverage_region
    x0, y0, x1, y1 = region.bounds
    gx, gy = np.meshgrid(np.arange(x0, x1, step_m) + step_m / 2,
                         np.arange(y0, y1, step_m) + step_m / 2)
    inside = shapely.contains_xy(region, gx, gy)
    pts = np.column_stack([gx[inside], gy[inside]])
    tan_half = p.swath_m / (2 * p.near_ground_m)
    seen = np.zeros(len(pts), dtype=bool)
    for r in p.runs:
        start = np.array([r.start_east_m, r.start_north_m])
        fwd = np.array([math.sin(r.heading_rad), math.cos(r.heading_rad)])
        stb = np.array([fwd[1], -fwd[0]])
        rel = pts - start
        along, lateral = rel @ fwd, rel @ stb
        lo = np.maximum(p.near_ground_m, np.abs(lateral) / tan_half)
        seen |= (np.maximum(along - r.length_m, lo) <= np.minimum(along, p.far_ground_m))
    return float(seen.mean())


def _check(area: SurveyArea, plan: SurveyPlan, stay_inside: bool) -> None:
    obstacles = area.obstacles
    for i, p in enumerate(plan.passes):
        path = _segments(plan, i)
        # No path segment crosses a hole or a keep-out (touching excluded by the margin).
        assert not path.intersects(obstacles), f"{p.name} crosses an obstacle"
        limit = 0.0 if stay_inside else p.excursion_limit_m
        grown = area.outer.buffer(limit + 1e-6) if limit > 0 else area.outer.buffer(1e-6)
        assert grown.covers(path), f"{p.name} leaves the boundary grown by {limit:.2f} m"
        assert p.max_excursion_m <= limit + 1e-6
        # Staying inside costs at most a sliver at the edges (the runs' starts): the band
        # still sweeps >= 99 % of the ground, counted apart from the planner.
        seen = _seen_fraction(area, p)
        assert seen >= 0.99, f"{p.name} sweeps {seen:.4f} of the ground"
        # The planner's own figure (shapely union) agrees with the grid count.
        assert seen == pytest.approx(p.coverage_fraction, abs=0.01)
        if not stay_inside:
            assert p.coverage_fraction >= 0.99, f"{p.name} covers {p.coverage_fraction:.4f}"
        # Waypoints: above the clearance, within the depth limit, and where the plan says.
        clearance = SETTINGS.site.target_height_max_m + SETTINGS.vehicle.min_clearance_m
        for w in p.waypoints:
            assert w.altitude_m >= clearance
            assert w.depth_m <= SETTINGS.vehicle.max_depth_m
            assert w.depth_m + w.altitude_m == pytest.approx(SETTINGS.site.water_depth_m)
        lat, lon = area.origin.to_lat_lon([p.waypoints[0].north_m], [p.waypoints[0].east_m])
        assert lat[0] == pytest.approx(p.waypoints[0].lat_deg, abs=1e-12)
        assert lon[0] == pytest.approx(p.waypoints[0].lon_deg, abs=1e-12)


@pytest.mark.slow
@given(area=areas(), heading_deg=st.floats(0.0, 180.0))
@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_random_areas_are_planned_safely_with_full_coverage(area: SurveyArea,
                                                           heading_deg: float) -> None:
    plan = plan_survey(area, SETTINGS, choice=CHOICE, heading_rad=math.radians(heading_deg))
    _check(area, plan, stay_inside=False)
    # Both passes fly the same lanes.
    lanes = [sorted({r.lane for r in p.runs}) for p in plan.passes]
    assert lanes[0] == lanes[1]


@pytest.mark.slow
@given(area=areas(), heading_deg=st.floats(0.0, 180.0))
@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_stay_inside_keeps_every_path_inside(area: SurveyArea, heading_deg: float) -> None:
    try:
        plan = plan_survey(area, SETTINGS, choice=CHOICE, heading_rad=math.radians(heading_deg),
                           stay_inside=True)
    except InfeasibleError as exc:
        # Refused only where the free region (a keep-out across a neck) truly falls apart.
        assert "separate parts" in str(exc)
        free = free_region(area, 0.0, SETTINGS.survey.obstacle_margin_m)
        assert free.geom_type == "MultiPolygon" and len(free.geoms) > 1, str(exc)
        return
    _check(area, plan, stay_inside=True)
    free = plan_survey(area, SETTINGS, choice=CHOICE, heading_rad=math.radians(heading_deg))
    # Staying inside does not gain coverage (unless it flies some pieces both ways, to see
    # the ground its runs' starts at the edge miss), and what it loses is reported. Not to
    # the last square centimetre: the two plans end their lanes differently, so a sliver
    # at a sharp vertex (a few cm^2 of a 10^4 m^2 area, as hypothesis once found) may be
    # seen by one and missed by the other.
    region_m2 = area.coverage_region.area
    sliver_m2 = 1e-5 * region_m2
    for inside, out in zip(plan.passes, free.passes, strict=True):
        if not _flies_a_piece_both_ways(inside):
            assert inside.uncovered_area_m2 >= out.uncovered_area_m2 - sliver_m2
            assert inside.coverage_fraction <= out.coverage_fraction + sliver_m2 / region_m2
        assert inside.uncovered_area_m2 == pytest.approx((1.0 - inside.coverage_fraction) * region_m2,
                                                         abs=max(sliver_m2, 1e-6))


def test_stay_inside_covers_a_rectangle_whole() -> None:
    """Known answer: lanes along a 100 m x 40 m rectangle's long side, kept inside it,
    still sweep all of it at both altitudes (the lane spacing is the one without
    ``stay_inside``: the swath less the overlap)."""
    area = SurveyArea(43.0, 5.0, shapely.orient_polygons(shapely.box(0.0, 0.0, 100.0, 40.0)), ())
    plan = plan_survey(area, SETTINGS, choice=CHOICE, heading_rad=math.pi / 2, stay_inside=True)
    _check(area, plan, stay_inside=True)
    assert [p.coverage_fraction for p in plan.passes] == [pytest.approx(1.0), pytest.approx(1.0)]
    for p in plan.passes:
        assert _seen_fraction(area, p, step_m=0.5) == pytest.approx(1.0)


def _flies_a_piece_both_ways(p: SurveyPass) -> bool:
    """Whether two runs of the pass on one lane overlap, flown in opposite directions."""
    for a in p.runs:
        for b in p.runs:
            if a.lane == b.lane and math.cos(a.heading_rad - b.heading_rad) < -0.99:
                ends = [(a.start_east_m, a.start_north_m), (a.end_east_m, a.end_north_m)]
                seg_b = shapely.LineString([(b.start_east_m, b.start_north_m), (b.end_east_m, b.end_north_m)])
                if shapely.LineString(ends).buffer(0.01).intersection(seg_b).length > 0.1:
                    return True
    return False


def test_piece_between_two_obstacles_is_flown_both_ways() -> None:
    """Two holes one behind the other along the lanes, 15 m apart: a run starting at an
    obstacle misses the ground just past it (its lead-in would be over the obstacle), in
    either direction, so pieces between them are flown there and back; 100 % coverage
    (hypothesis found 0.9898 before, with one direction per piece)."""
    outer = shapely.Polygon([(60, 0), (13.906, 42.798), (-36.406, 26.450), (-30.338, -22.042), (13.906, -42.798)])
    holes = [shapely.box(-0.745, -16.884, 9.255, -11.884), shapely.box(-1.948, 3.311, 10.052, 9.311)]
    area = SurveyArea(43.0, 5.0, shapely.orient_polygons(shapely.Polygon(outer.exterior, [h.exterior for h in holes])))
    plan = plan_survey(area, SETTINGS, choice=CHOICE, heading_rad=math.radians(1.0))
    _check(area, plan, stay_inside=False)
    assert all(p.coverage_fraction > 0.9999 for p in plan.passes)
    assert any(_flies_a_piece_both_ways(p) for p in plan.passes)


def test_rectangle_known_answer() -> None:
    """A 100 m x 40 m rectangle with lanes east-west: lane count, run ends and lead-ins."""
    area = SurveyArea(43.0, 5.0, shapely.box(0, 0, 100, 40))
    plan = plan_survey(area, SETTINGS, choice=CHOICE, heading_rad=math.pi / 2)
    fps = [footprint(CHOICE.altitude1_m, CHOICE.tilt1_rad, SETTINGS.sonar),
           footprint(CHOICE.altitude2_m, CHOICE.tilt2_rad, SETTINGS.sonar)]
    spacing = min(f.swath_m for f in fps) * (1 - SETTINGS.survey.overlap)
    assert plan.summary.lane_spacing_m == pytest.approx(spacing)
    assert plan.summary.n_lanes == math.ceil(40 / spacing)
    for p, fp in zip(plan.passes, fps, strict=True):
        assert len(p.runs) == plan.summary.n_lanes
        for r in p.runs:
            east = sorted([r.start_east_m, r.end_east_m])
            going_east = r.end_east_m > r.start_east_m
            # The run starts g_near before the ground it covers and stops g_near before
            # the far edge: [0 - g, 100 - g] going east, [0 + g, 100 + g] going west.
            shift = -fp.near_ground_m if going_east else fp.near_ground_m
            assert east[0] == pytest.approx(0 + shift, abs=1e-6)
            assert east[1] == pytest.approx(100 + shift, abs=1e-6)
            assert r.start_north_m == pytest.approx(r.end_north_m)
        assert p.coverage_fraction == pytest.approx(1.0, abs=1e-9)
        # Neighbouring runs alternate direction (lawnmower).
        dirs = [r.end_east_m > r.start_east_m for r in p.runs]
        assert all(a != b for a, b in zip(dirs, dirs[1:], strict=False))
    # Duration: path length at the set speed plus the turns in place.
    total = sum(p.length_m for p in plan.passes)
    assert plan.summary.total_length_m == pytest.approx(total)
    assert plan.summary.total_duration_s > total / SETTINGS.vehicle.speed_m_s


def test_transit_goes_around_a_wall() -> None:
    """A U-shaped area: lanes across both arms; the hop between arms routes around."""
    u = shapely.Polygon([(0, 0), (60, 0), (60, 60), (40, 60), (40, 10), (20, 10), (20, 60),
                         (0, 60)])
    area = SurveyArea(43.0, 5.0, u, (shapely.box(25, 0.5, 35, 9.5),))
    plan = plan_survey(area, SETTINGS, choice=CHOICE, heading_rad=0.0)  # lanes north-south
    _check(area, plan, stay_inside=False)


def test_auto_heading_follows_the_long_side() -> None:
    area = SurveyArea(43.0, 5.0, shapely.affinity.rotate(shapely.box(0, 0, 200, 20), 30))
    spacing = 2.0
    heading = choose_heading(area, spacing, SETTINGS)
    # The long side points 30 deg north of east: compass heading 60 deg.
    assert math.degrees(heading) == pytest.approx(60.0, abs=1.0)
    assert len(lane_pieces(area.coverage_region, spacing)) > 0


NO_LOSS = dataclasses.replace(
    SETTINGS,
    survey=dataclasses.replace(SETTINGS.survey, edge_loss_budget=0.0, overlap=0.3),
    sonar=dataclasses.replace(SETTINGS.sonar, fan_width_rad=math.radians(20.0)),
)


@given(area=areas())
@settings(max_examples=10, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_no_edge_loss_budget_still_flies_every_piece(area: SurveyArea) -> None:
    """Regression: with no loss budget every piece is still flown (toward obstacles)."""
    choice = choose_altitudes(NO_LOSS)
    plan = plan_survey(area, NO_LOSS, choice=choice, heading_rad=0.0)
    for p in plan.passes:
        assert p.coverage_fraction >= 0.99
        assert _seen_fraction(area, p) >= 0.99


def _star(radii: list[float], radius_m: float = 60.0) -> shapely.Polygon:
    """The strategy's boundary with phase 0: vertex ``i`` at ``radius_m * radii[i]``."""
    ang = np.arange(len(radii)) * 2 * math.pi / len(radii)
    return shapely.Polygon(np.column_stack([radius_m * np.array(radii) * np.cos(ang),
                                            radius_m * np.array(radii) * np.sin(ang)]))


PENTAGON_A = _star([1.0, 0.75, 0.75, 0.75, 0.75])
PENTAGON_B = _star([1.0, 0.75, 1.0, 0.75, 0.75])

#: Counterexamples of test_no_edge_loss_budget_still_flies_every_piece (explore runs,
#: shrunk), with pass2's coverage (planner's figure, grid check) before the fix.
NO_LOSS_COUNTEREXAMPLES = {
    # Two holes one above the other (lanes north): the ground between them, a corridor
    # 8.4 m long along the lanes, is seen by no run along them. 0.9893, 0.9875.
    "corridor-8.4m": (PENTAGON_A, [shapely.box(-7, -3.5, 7, 3.5),
                                   shapely.box(-1.843198117966855, 11.93309715817767,
                                               26.156801882033143, 25.93309715817767)], []),
    # The same, 6.3 m. 0.9909, 0.9897.
    "corridor-6.3m": (PENTAGON_A, [shapely.box(-13, -6.5, 13, 6.5),
                                   shapely.box(4.1306682350276205, 12.77758096514806,
                                               16.13066823502762, 18.77758096514806)], []),
    # The same, 6.7 m, under a long hole. 0.9895, 0.9886.
    "corridor-6.7m": (PENTAGON_B, [shapely.box(-14.844849153976785, -1.136984411570646,
                                               10.162925861188317, 11.366903096011905),
                                   shapely.box(-2.808800413538705, -13.787898089960308,
                                               9.191199586461295, -7.787898089960308)], []),
    # Pieces between a hole and a keep-out at the edge: each direction misses 6 m at its
    # start and a second run over the whole 30-40 m piece was not worth it. 0.9898, 0.9901.
    "hole-keepout": (PENTAGON_B, [shapely.Polygon([(16.43805715365486, -21.210087860989468),
                                                   (0.6415710396281495, -29.83974755586512),
                                                   (-3.6732588078096784, -21.941504498851764),
                                                   (12.123227306217032, -13.311844803976111)]),
                                  shapely.box(-4, -2, 4, 2)],
                     [shapely.box(2.3564706607095953, 37.36953554386671, 18.356470660709597, 47.36953554386671)]),
    # The same under a keep-out on a vertex of another pentagon. 0.9900, 0.9908.
    "hole-keepout-vertex": (
        shapely.Polygon([(-24.93852869215875, -37.45757315510943), (27.917839853184947, -35.292976892462875),
                         (56.2569368185379, 20.86041849520364), (-2.4550874141014596, 59.949750172866615),
                         (-57.7742642858047, 16.190564728692816)]),
        [shapely.Polygon([(-5.516594955423072, 3.8166975381605397), (6.363315003782274, 2.1232574414421332),
                          (5.516594955423072, -3.8166975381605397), (-6.363315003782274, -2.1232574414421332)])],
        [shapely.box(-10.45508741410146, 54.949750172866615, 5.54491258589854, 64.94975017286662)]),
}


@pytest.mark.parametrize("name", sorted(NO_LOSS_COUNTEREXAMPLES))
def test_no_edge_loss_counterexamples_are_covered(name: str) -> None:
    """Known answers: the counterexamples above, each pass >= 99.9 % seen by both counts
    (the fix: a short run back over what one direction misses, cross lanes over corridors)."""
    outer, holes, keepouts = NO_LOSS_COUNTEREXAMPLES[name]
    boundary = shapely.orient_polygons(shapely.Polygon(outer.exterior, [h.exterior for h in holes]))
    area = SurveyArea(43.0, 5.0, boundary, tuple(keepouts))
    plan = plan_survey(area, NO_LOSS, choice=choose_altitudes(NO_LOSS), heading_rad=0.0)
    for p in plan.passes:
        seen = _seen_fraction(area, p)
        assert p.coverage_fraction >= 0.999, f"{p.name} covers {p.coverage_fraction:.4f}"
        assert seen >= 0.999
        assert seen == pytest.approx(p.coverage_fraction, abs=0.01)
