"""Transit routing: straight when free, else the shortest way round, never through."""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

from planner.errors import InfeasibleError
from planner.survey.routing import Router, segments_cross


def test_segment_crossing_known_answers() -> None:
    edges = np.array([[[0.0, -1.0], [0.0, 1.0]]])
    a = np.array([[-1.0, 0.0], [-1.0, 2.0], [0.0, 1.0], [-1.0, 0.0]])
    b = np.array([[1.0, 0.0], [1.0, 2.0], [1.0, 1.0], [0.0, 0.0]])
    # Crosses; passes above; starts at the edge's end point; ends on the edge.
    assert segments_cross(a, b, edges).tolist() == [True, False, False, False]


def test_straight_when_free_and_around_a_square_when_blocked() -> None:
    free = shapely.box(-50, -50, 50, 50).difference(shapely.box(-10, -10, 10, 10))
    router = Router(free, margin_m=1.0)
    assert router.route((-30.0, 20.0), (30.0, 20.0)) == [(-30.0, 20.0), (30.0, 20.0)]
    path = router.route((-30.0, 0.0), (30.0, 0.0))
    line = shapely.LineString(path)
    assert not line.crosses(shapely.box(-10, -10, 10, 10))
    assert not line.intersects(shapely.box(-9.99, -9.99, 9.99, 9.99))
    # Shortest way: over two corners of the square grown by the 1 m margin.
    c = 11.0
    best = 2 * math.hypot(30 - c, c) + 2 * c
    assert line.length == pytest.approx(best, rel=1e-6)


def test_separate_parts_are_refused() -> None:
    free = shapely.box(0, 0, 10, 10).union(shapely.box(20, 0, 30, 10))
    with pytest.raises(InfeasibleError, match="separate parts"):
        Router(free).route((5.0, 5.0), (25.0, 5.0))


@given(
    ax=st.floats(-45, 45), ay=st.floats(-45, 45), bx=st.floats(-45, 45), by=st.floats(-45, 45),
    angle=st.floats(0, math.pi), w=st.floats(2, 30), h=st.floats(2, 30),
)
@settings(max_examples=80, deadline=None)
def test_routes_never_cross_the_obstacle(ax: float, ay: float, bx: float, by: float,
                                         angle: float, w: float, h: float) -> None:
    obstacle = shapely.affinity.rotate(shapely.box(-w / 2, -h / 2, w / 2, h / 2), angle,
                                       use_radians=True)
    free = shapely.box(-50, -50, 50, 50).difference(obstacle)
    if not (free.contains(shapely.Point(ax, ay)) and free.contains(shapely.Point(bx, by))):
        return
    path = shapely.LineString(Router(free, margin_m=0.5).route((ax, ay), (bx, by)))
    assert not path.intersects(obstacle.buffer(-1e-6))
    assert shapely.box(-50, -50, 50, 50).buffer(1e-9).covers(path)
    assert path.length >= math.hypot(bx - ax, by - ay) - 1e-9


def test_passage_narrower_than_twice_the_margin() -> None:
    """Two rooms joined by a bent 1.2 m passage (the 1 m margin parts the shrunk region
    there, and no straight hop sees through the bend): the transit goes through the
    passage with the nodes nearer the walls, not refused."""
    rooms = shapely.box(0, 0, 10, 10).union(shapely.box(20, 12, 30, 22))
    passage = shapely.union_all([shapely.box(9, 4.4, 15.6, 5.6), shapely.box(14.4, 4.4, 15.6, 14),
                                 shapely.box(14.4, 12.8, 21, 14)])
    free = rooms.union(passage)
    assert free.buffer(-1.0).geom_type == "MultiPolygon"  # the premise
    router = Router(free, margin_m=1.0)
    path = router.route((2.0, 9.0), (28.0, 20.0))
    line = shapely.LineString(path)
    assert free.buffer(1e-9).contains(line)
    assert line.length < 45.0
    # still refused where the region itself is in two parts (the passage closed)
    with pytest.raises(InfeasibleError, match="separate parts"):
        Router(rooms, margin_m=1.0).route((2.0, 9.0), (28.0, 20.0))


def test_a_diagonal_through_two_corners_is_not_free() -> None:
    # Hypothesis counterexample: the straight hop (4, 4) -> (-1.5, -1.5) runs through the
    # 2 m box's corners (1, 1) and (-1, -1); it crosses no edge properly and its midpoint
    # lies outside the box, yet its middle piece lies inside.
    obstacle = shapely.box(-1, -1, 1, 1)
    free = shapely.box(-50, -50, 50, 50).difference(obstacle)
    router = Router(free, margin_m=0.5)
    assert not router.visible(np.array([[4.0, 4.0]]), np.array([[-1.5, -1.5]]))[0]
    path = shapely.LineString(router.route((4.0, 4.0), (-1.0, -2.0)))
    assert not path.intersects(obstacle.buffer(-1e-6))
