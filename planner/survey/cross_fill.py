"""Cross lanes: the ground no run along the lanes can see, flown at right angles to them.

A run along the lanes sees ground only from ``g_near`` ahead, and its lead-in must be
free. Between two obstacles one behind the other along the lanes (a corridor across
them) the vehicle can neither lead in from behind the first obstacle nor, inside the
corridor, look at its own ground: where the corridor is shorter than about
``2 (g_near + margin)`` no way along the lane (one way, the other, or both) sees its
middle. Such pockets are planned again as lanes at right angles (the same spacing, the
same pieces and ways to fly, :mod:`planner.survey.lane_options`), whose runs lead in
from the corridor's open ends; the pass flies them among its other pieces.

Both passes fly the same cross lanes: the pockets of either altitude, found by sweeping
the band of every option of every piece (2D, so ground that a neighbouring lane's band
reaches sideways is no pocket). Pockets smaller than ``POCKET_MIN_M2``, or thinner than
``POCKET_MIN_WIDTH_M``, are left: slivers at obstacle corners and strips a few
centimetres wide along an obstacle's edge, not worth a detour (they still count against
the pass's coverage figure).

Everything here is in the lane frame ``(u, v)``; the cross frame is it turned by a
right angle, ``(u', v') = (v, -u)``, so that cross lanes run along ``+u'``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely

from planner.survey.footprint import Footprint, swept_polygons
from planner.survey.lane_options import Interval, piece_options, unseen
from planner.survey.pieces import free_intervals, lane_pieces
from planner.survey.run_order import Option, Piece

#: Pockets smaller than this (m^2) are not flown.
POCKET_MIN_M2 = 1.0
POCKET_MIN_WIDTH_M = 0.2

#: Row vectors times these turn the lane frame into the cross frame and back.
_TO_CROSS = np.array([[0.0, -1.0], [1.0, 0.0]])
_TO_LANE = _TO_CROSS.T


@dataclass(frozen=True)
class CrossLanes:
    """The cross-lane pieces (cross frame, lane numbers after the plan's own) and the free
    intervals of their lane lines."""

    pieces: list[Piece]
    free_iv: list[list[Interval]]

    def options(self, g_near: float, first_index: int) -> list[list[Option]]:
        """Ways to fly each cross piece, as options on pieces ``first_index`` onwards, with
        their runs in the lane frame."""
        return [[Option(first_index + o.piece,
                        tuple((a @ _TO_LANE, b @ _TO_LANE) for a, b in o.runs), o.extra_loss_m, o.extra_run_m)
                 for o in opts]
                for opts in piece_options(self.pieces, self.free_iv, g_near)]


def pockets(region_lane: shapely.Geometry, pieces: list[Piece], options: list[list[list[Option]]],
            fps: tuple[Footprint, ...], spacing_m: float) -> shapely.Geometry:
    """Ground that no option of any piece sees, at some altitude (``options[j]`` are the
    options of every piece for footprint ``fps[j]``); parts under ``POCKET_MIN_M2`` left out."""
    half = spacing_m / 2
    found = []
    for opts, fp in zip(options, fps, strict=True):
        strips = [shapely.box(lo, p.v - half, hi, p.v + half)
                  for p, o in zip(pieces, opts, strict=True) for lo, hi in unseen(p, o, fp.near_ground_m)]
        if not strips:
            continue
        candidates = [g for g in shapely.get_parts(shapely.union_all(strips).intersection(region_lane))
                      if _worth_a_detour(g)]
        if not candidates:
            continue
        runs = {(float(a[0]), float(a[1]), float(b[0]), float(b[1])) for o in opts for opt in o for a, b in opt.runs}
        ends = np.array(sorted(runs)).reshape(-1, 4)
        reach = fp.far_ground_m + spacing_m  # farther runs' bands cannot reach the ground
        for c in candidates:
            c0, c1, c2, c3 = c.bounds
            lo, hi, v = np.minimum(ends[:, 0], ends[:, 2]), np.maximum(ends[:, 0], ends[:, 2]), ends[:, 1]
            near = ends[(lo - reach <= c2) & (hi + reach >= c0) & (v >= c1 - reach) & (v <= c3 + reach)]
            swept = shapely.union_all(swept_polygons(fp, near[:, :2], near[:, 2:]))
            found += [g for g in shapely.get_parts(c.difference(swept)) if _worth_a_detour(g)]
    return shapely.union_all(found) if found else shapely.Polygon()


def _worth_a_detour(pocket: shapely.Geometry) -> bool:
    """At least ``POCKET_MIN_M2`` and wider than ``POCKET_MIN_WIDTH_M`` somewhere."""
    return bool(pocket.area >= POCKET_MIN_M2 and not pocket.buffer(-POCKET_MIN_WIDTH_M / 2).is_empty)


def cross_lanes(pocket_lane: shapely.Geometry, free_lane: shapely.Geometry, spacing_m: float,
                first_lane: int) -> CrossLanes:
    """Cross lanes over the pockets (lane frame), numbered from ``first_lane``."""
    if pocket_lane.is_empty:
        return CrossLanes([], [])
    pieces = [Piece(p.k + first_lane, p.v, p.a, p.b)
              for p in lane_pieces(shapely.transform(pocket_lane, lambda xy: xy @ _TO_CROSS), spacing_m)]
    free_cross = shapely.transform(free_lane, lambda xy: xy @ _TO_CROSS)
    return CrossLanes(pieces, free_intervals(pieces, free_cross))
