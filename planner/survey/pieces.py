"""The decomposition: the ground to cover cut into per-lane pieces, and where their lane lines are free.

Works in the lane frame ``(u, v)`` of :mod:`planner.survey.lawnmower` (lanes along ``+u``).
Lanes ``v_k`` are ``spacing`` apart, centred on the ground; each lane owns the strip
``|v - v_k| <= spacing / 2``, which splits into u-intervals, one per connected part (a
:class:`planner.survey.run_order.Piece`).
"""

from __future__ import annotations

import math

import numpy as np
import shapely
from numpy.typing import NDArray

from planner.errors import InfeasibleError
from planner.survey.lane_options import Interval, union
from planner.survey.run_order import Piece

#: Most lanes a plan may have (guards against a swath far too small for the area).
MAX_LANES = 20000


def part_intervals(geoms: NDArray) -> list[list[Interval]]:
    """Merged u-intervals of the parts of each geometry (their bounds along ``u``)."""
    return [union([(part.bounds[0], part.bounds[2]) for part in shapely.get_parts(g) if not part.is_empty])
            for g in geoms]


def free_intervals(pieces: list[Piece], free_lane: shapely.Geometry) -> list[list[Interval]]:
    """For each piece, the u-intervals of its lane line inside the free region."""
    if not pieces:
        return []
    u0, _, u1, _ = free_lane.bounds
    vs = np.array([p.v for p in pieces])
    uniq, inv = np.unique(vs, return_inverse=True)
    lines = shapely.linestrings(
        np.stack([np.stack([np.full_like(uniq, u0 - 1), uniq], -1),
                  np.stack([np.full_like(uniq, u1 + 1), uniq], -1)], axis=1)
    )
    free = part_intervals(shapely.intersection(lines, free_lane))
    return [free[j] for j in inv]


def lane_pieces(region_lane: shapely.Geometry, spacing_m: float) -> list[Piece]:
    """Cut the ground to cover (lane frame) into per-lane pieces (see the module docstring)."""
    u0, v0, u1, v1 = region_lane.bounds
    n = max(1, math.ceil((v1 - v0) / spacing_m - 1e-9))
    if n > MAX_LANES:
        raise InfeasibleError(f"{n} lanes of {spacing_m:.3g} m would be needed; the swath is "
                              "too small for this area")
    vs = (v0 + v1) / 2 + (np.arange(n) - (n - 1) / 2) * spacing_m
    half = spacing_m / 2 * (1 + 1e-9)
    boxes = shapely.box(u0 - 1.0, vs - half, u1 + 1.0, vs + half)
    inter = shapely.intersection(boxes, region_lane)
    pieces = []
    for k, spans in enumerate(part_intervals(inter)):
        pieces += [Piece(k, float(vs[k]), lo, hi) for lo, hi in spans]
    return pieces
