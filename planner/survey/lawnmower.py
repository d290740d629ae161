"""Dual-altitude lawnmower surveys: lanes, decomposition around obstacles, lead-ins, turns.

How a pass is built (plane coordinates ``(east_m, north_m)``; the work happens in a lane
frame ``(u, v)`` with lanes along ``+u``):

1. Lanes ``v_k`` are ``spacing`` apart, centred on the area; ``spacing`` is the narrower
   pass's swath times ``1 - overlap``, and both passes fly the same lanes, so the same
   ground is seen from both altitudes.
2. Each lane owns the strip ``|v - v_k| <= spacing / 2`` of the ground to cover (the area
   minus holes and keep-outs); the strip splits into u-intervals, one per connected piece
   (the decomposition, :mod:`planner.survey.pieces`: concave notches and obstacles give
   several pieces per lane).
3. The forward-looking band sees ground ``g_near..g_far`` ahead, so covering ``[a, b]``
   flying ``+u`` needs the vehicle on ``[a - g_near, b - g_near]`` (the lead-in before the
   first ground; flying ``-u``: ``[a + g_near, b + g_near]``). That run is cut to where the
   vehicle may be: inside the outer boundary grown by the excursion limit
   ``hypot(g_near, spacing / 2)`` (the distance from the vehicle to the near corner of
   its strip; the larger of the two passes'; 0 with ``stay_inside``), outside holes and
   keep-outs grown by the obstacle margin. A run that starts at an obstacle cannot see
   the ground just past it (its lead-in would be over the obstacle), so one direction
   may lose that strip; the piece may then also be flown one way and back over just
   what that way misses (:mod:`planner.survey.lane_options`).
4. Ground that no way along the lanes sees (a corridor across the lanes between two
   obstacles, shorter than about ``2 (g_near + margin)``) is planned again as cross lanes
   at right angles (:mod:`planner.survey.cross_fill`), the same for both passes, and
   flown among the other pieces.
5. Pieces on consecutive lanes that overlap one to one form boustrophedon cells; cells
   are flown one after the other (the cheapest cell end next), each as a lawnmower; a
   plain nearest-next order is also built and the shorter of the two kept. Each piece
   is flown in its way of cheapest start: a way that leaves ground unseen beyond the
   piece's best way costs ``planner.survey.run_order.LOSS_PENALTY`` m of transit per m
   lost and is allowed only within ``[survey] edge_loss_budget`` of the area; a run back
   costs its length. Every turn or transit between runs follows
   :class:`planner.survey.routing.Router`, straight when free, else the shortest path
   around obstacles inside the free region.

The second pass flies the same pieces with its own lead-in, starting where the first
pass ended.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import shapely
from numpy.typing import NDArray

from planner.config import Settings
from planner.errors import InfeasibleError
from planner.survey.altitudes import AltitudeChoice, choose_altitudes
from planner.survey.area import SurveyArea
from planner.survey.cross_fill import cross_lanes, pockets
from planner.survey.footprint import Footprint, footprint, swept_polygons
from planner.survey.lane_options import piece_options
from planner.survey.pieces import free_intervals, lane_pieces
from planner.survey.plan import LaneRun, PlanSummary, PlanWaypoint, SurveyPass, SurveyPlan
from planner.survey.routing import Router
from planner.survey.run_order import Option, Piece, order_runs

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class LaneFrame:
    """Rotation between the plane ``(east_m, north_m)`` and the lane frame ``(u, v)``."""

    heading_rad: float

    @property
    def _beta(self) -> float:
        return math.pi / 2 - self.heading_rad

    def to_lane(self, geom: shapely.Geometry) -> shapely.Geometry:
        c, s = math.cos(self._beta), math.sin(self._beta)
        return shapely.transform(geom, lambda xy: xy @ np.array([[c, -s], [s, c]]))

    def points_to_plane(self, uv: FloatArray) -> FloatArray:
        c, s = math.cos(self._beta), math.sin(self._beta)
        return np.asarray(uv, dtype=float) @ np.array([[c, s], [-s, c]])


def _turn_time_s(points: FloatArray, settings: Settings) -> float:
    """Time spent turning at the path's corners (in place, or on the turn radius)."""
    if len(points) < 3:
        return 0.0
    d = np.diff(points, axis=0)
    d = d[np.hypot(*d.T) > 1e-9]
    if len(d) < 2:
        return 0.0
    h = np.arctan2(d[:, 0], d[:, 1])
    turn = np.abs((np.diff(h) + np.pi) % (2 * np.pi) - np.pi)
    v = settings.vehicle
    if v.turn_radius_m > 0:
        return float(np.sum(turn) * v.turn_radius_m / v.speed_m_s)
    return float(np.sum(turn) / v.yaw_rate_rad_s)


@dataclass(frozen=True)
class _PassGeometry:
    runs_en: tuple[tuple[FloatArray, FloatArray, int], ...]
    path_en: FloatArray
    kinds: tuple[str, ...]
    lanes: tuple[int, ...]


def _fly_pass(
    pieces: list[Piece],
    opts: list[list[Option]],
    frame: LaneFrame,
    router: Router,
    start_en: FloatArray | None,
    loss_budget_m: float,
) -> _PassGeometry:
    start_uv = None
    if start_en is not None:
        start_uv = np.asarray(shapely.get_coordinates(frame.to_lane(shapely.Point(start_en))))[0]
    order = order_runs(opts, pieces, start_uv, loss_budget_m)
    if not order:
        raise InfeasibleError("no lane run fits inside the free region (area too small or "
                              "obstacles too close for the lead-in)")
    pts: list[tuple[float, float]] = []
    kinds: list[str] = []
    lanes: list[int] = []
    runs: list[tuple[FloatArray, FloatArray, int]] = []
    here = start_uv
    flat = [(a, b, pieces[opt.piece].k) for opt in order for a, b in opt.runs]
    first = flat[0][0] if here is None else here
    hops_from = np.array([first] + [b for _, b, _ in flat[:-1]])
    hops_to = np.array([a for a, _, _ in flat])
    free_hop = router.visible(hops_from, hops_to)
    for idx, (a, b, k) in enumerate(flat):
        if not free_hop[idx] and np.hypot(*(a - hops_from[idx])) > 1e-6:
            for q in router.route(tuple(hops_from[idx]), tuple(a))[1:-1]:
                pts.append(q)
                kinds.append("transit")
                lanes.append(-1)
        pts += [tuple(a), tuple(b)]
        kinds += ["lane_start", "lane_end"]
        lanes += [k, k]
        runs.append((a, b, k))
    path_en = frame.points_to_plane(np.array(pts))
    ends = frame.points_to_plane(np.array([[a, b] for a, b, _ in runs]).reshape(-1, 2))
    runs_en = tuple((ends[2 * i], ends[2 * i + 1], k) for i, (_, _, k) in enumerate(runs))
    return _PassGeometry(runs_en, path_en, tuple(kinds), tuple(lanes))


def free_region(area: SurveyArea, excursion_m: float, margin_m: float) -> shapely.Geometry:
    """Where the vehicle may be: the outer boundary grown by ``excursion_m`` minus the
    obstacles grown by ``margin_m`` (plane coordinates)."""
    outer = area.outer.buffer(excursion_m, quad_segs=2) if excursion_m > 0 else area.outer
    obstacles = area.obstacles
    if obstacles.is_empty:
        return outer
    return outer.difference(obstacles.buffer(margin_m, quad_segs=2) if margin_m > 0 else obstacles)


def coverage(area: SurveyArea, fp: Footprint, runs_en: tuple[tuple[FloatArray, FloatArray, int], ...]
             ) -> tuple[float, float]:
    """Covered fraction of the ground to cover and the uncovered area (m^2) for one pass."""
    region = area.coverage_region
    ends = np.array([[a, b] for a, b, _ in runs_en]).reshape(-1, 2, 2)
    swept = shapely.union_all(swept_polygons(fp, ends[:, 0], ends[:, 1]))
    covered = region.intersection(swept).area
    return covered / region.area, max(region.area - covered, 0.0)


def choose_heading(area: SurveyArea, spacing_m: float, settings: Settings) -> float:
    """Lane heading (rad, [0, pi)) with the shortest estimated survey time.

    Candidates: north, east and the directions of the convex hull's edges (the narrowest
    width lies along one of them); each is scored by lane length over speed plus one
    turn and one lane change per piece.
    """
    hull = np.asarray(area.outer.convex_hull.exterior.coords)
    d = np.diff(hull, axis=0)
    cands = np.concatenate([[0.0, math.pi / 2], np.arctan2(d[:, 0], d[:, 1]) % math.pi])
    cands = np.unique(np.round(cands, 4))
    v = settings.vehicle
    turn_s = (math.pi * v.turn_radius_m / v.speed_m_s) if v.turn_radius_m > 0 else math.pi / v.yaw_rate_rad_s
    best, best_cost = 0.0, math.inf
    for h in cands:
        pieces = lane_pieces(LaneFrame(float(h)).to_lane(area.coverage_region), spacing_m)
        cost = sum(p.b - p.a for p in pieces) / v.speed_m_s + len(pieces) * (
            turn_s + spacing_m / v.speed_m_s
        )
        if cost < best_cost - 1e-6:
            best, best_cost = float(h), cost
    return best


def plan_survey(
    area: SurveyArea,
    settings: Settings,
    *,
    choice: AltitudeChoice | None = None,
    stay_inside: bool = False,
    heading_rad: float | None = None,
    with_coverage: bool = True,
) -> SurveyPlan:
    """Plan both passes over ``area`` (see the module docstring).

    Parameters
    ----------
    choice : AltitudeChoice, optional
        Altitudes and tilts; chosen with :func:`planner.survey.altitudes.choose_altitudes` if
        not given.
    stay_inside : bool
        Keep every path inside the outer boundary (coverage lost at the edges is
        reported in the passes' ``coverage_fraction``).
    heading_rad : float, optional
        Lane heading; default the settings' heading, or the fastest if that is "auto".
    with_coverage : bool
        Compute the covered fractions (NaN otherwise).

    Raises
    ------
    InfeasibleError
        When no altitudes/tilts fit, or no run or transit fits the free region.
    """
    if choice is None:
        choice = choose_altitudes(settings)
    fps = (
        footprint(choice.altitude1_m, choice.tilt1_rad, settings.sonar),
        footprint(choice.altitude2_m, choice.tilt2_rad, settings.sonar),
    )
    spacing = min(f.swath_m for f in fps) * (1.0 - settings.survey.overlap)
    if heading_rad is None:
        heading_rad = settings.survey.lane_heading_rad
    if heading_rad is None:
        heading_rad = choose_heading(area, spacing, settings)
    frame = LaneFrame(heading_rad % math.pi)
    region_lane = frame.to_lane(area.coverage_region)
    pieces = lane_pieces(region_lane, spacing)
    margin = settings.survey.obstacle_margin_m
    depth_of = settings.site.water_depth_m
    passes = []
    start: FloatArray | None = None
    # One excursion limit and free region for both passes, so the hop between them fits.
    exc = 0.0 if stay_inside else max(math.hypot(f.near_ground_m, spacing / 2) for f in fps)
    free_lane = frame.to_lane(free_region(area, exc, margin))
    router = Router(free_lane, margin_m=margin)
    free_iv = free_intervals(pieces, free_lane)
    lane_opts = [piece_options(pieces, free_iv, fp.near_ground_m) for fp in fps]
    # Cross lanes numbered after a gap, so that no cell joins them to the last lane.
    cross = cross_lanes(pockets(region_lane, pieces, lane_opts, fps, spacing), free_lane, spacing,
                        first_lane=max((p.k for p in pieces), default=0) + 2)
    budget_m = settings.survey.edge_loss_budget * area.coverage_region.area / spacing
    for idx, fp in enumerate(fps, start=1):
        opts = lane_opts[idx - 1] + cross.options(fp.near_ground_m, first_index=len(pieces))
        geo = _fly_pass(pieces + cross.pieces, opts, frame, router, start, budget_m)
        path = geo.path_en
        seg = np.hypot(*np.diff(path, axis=0).T)
        length = float(seg.sum())
        duration = length / settings.vehicle.speed_m_s + _turn_time_s(path, settings)
        if start is not None:
            link = math.hypot(*(path[0] - start))
            length += link
            duration += (link + choice.delta_altitude_m) / settings.vehicle.speed_m_s
        cov, lost = coverage(area, fp, geo.runs_en) if with_coverage else (math.nan, math.nan)
        line = shapely.LineString(path) if len(path) > 1 else shapely.Point(path[0])
        beyond = line.difference(area.outer)  # only the parts outside can be far from it
        dense = shapely.get_coordinates(shapely.segmentize(beyond, 1.0))
        outside = shapely.distance(area.outer, shapely.points(dense)) if len(dense) else np.zeros(0)
        lat, lon = area.origin.to_lat_lon(path[:, 1], path[:, 0])
        depth = depth_of - fp.altitude_m
        wps = tuple(
            PlanWaypoint(float(n), float(e), float(la), float(lo), fp.altitude_m, depth, kd, ln)
            for (e, n), la, lo, kd, ln in zip(path, lat, lon, geo.kinds, geo.lanes, strict=True)
        )
        runs = tuple(LaneRun(k, float(a[1]), float(a[0]), float(b[1]), float(b[0]))
                     for a, b, k in geo.runs_en)
        passes.append(SurveyPass(
            name=f"pass{idx}", altitude_m=fp.altitude_m, depth_m=depth, tilt_rad=fp.tilt_rad,
            near_ground_m=fp.near_ground_m, far_ground_m=fp.far_ground_m, swath_m=fp.swath_m,
            lead_in_m=fp.lead_in_m, excursion_limit_m=exc, runs=runs, waypoints=wps,
            length_m=length, duration_s=duration, coverage_fraction=cov,
            uncovered_area_m2=lost, max_excursion_m=float(np.max(outside, initial=0.0)),
        ))
        start = path[-1]
    summary = PlanSummary(
        area_m2=float(area.coverage_region.area),
        lane_heading_rad=frame.heading_rad,
        lane_spacing_m=spacing,
        n_lanes=len({p.k for p in pieces}),
        n_runs=sum(len(p.runs) for p in passes),
        total_length_m=sum(p.length_m for p in passes),
        total_duration_s=sum(p.duration_s for p in passes),
        speed_m_s=settings.vehicle.speed_m_s,
        coverage_fraction=min(p.coverage_fraction for p in passes),
        stay_inside=stay_inside,
        max_excursion_m=max(p.max_excursion_m for p in passes),
        samples_per_cm=choice.samples_per_cm,
        height_resolution_m=choice.height_resolution_m,
        height_std_from_dh_m=choice.height_std_from_dh_m,
        binding_constraints=choice.binding,
    )
    return SurveyPlan(area.origin_lat_deg, area.origin_lon_deg, depth_of, tuple(passes), summary)
