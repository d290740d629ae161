"""Ways to fly one lane piece, by hand: one direction, the other, or one and back over what it misses."""

from __future__ import annotations

import pytest

from planner.survey.lane_options import minus, piece_options, seen_by, union, unseen
from planner.survey.run_order import Piece

G = 5.0  # the band's near edge, m ahead


def _runs_u(option) -> list[tuple[float, float]]:
    return [(float(a[0]), float(b[0])) for a, b in option.runs]


def test_interval_helpers() -> None:
    assert union([(3, 4), (0, 1), (0.5, 2)]) == [(0, 2), (3, 4)]
    assert minus(0, 10, [(2, 3), (-1, 1), (9, 12)]) == [(1, 2), (3, 9)]
    assert minus(0, 1, []) == [(0, 1)]
    assert minus(0, 1, [(-1, 2)]) == []


def test_open_piece_is_flown_either_way_alone() -> None:
    """Nothing in the way: each direction sees the whole piece; no run back is offered."""
    p = Piece(0, 0.0, 0.0, 40.0)
    opts = piece_options([p], [[(-100.0, 100.0)]], G)[0]
    assert sorted(_runs_u(o)[0] for o in opts) == [(-5.0, 35.0), (45.0, 5.0)]
    assert all(o.extra_loss_m == 0.0 and o.extra_run_m == 0.0 for o in opts)


def test_piece_between_two_obstacles_gets_a_short_run_back() -> None:
    """Obstacles (grown by a 1 m margin) at both ends of a 40 m piece: forward misses the
    first 6 m (its lead-in would be over the obstacle), backward the last 6 m. One
    direction and a 6 m run the other way over just what it misses sees it all, for 10 m
    more (the run back and the hop to the start), not a second 34 m run."""
    p = Piece(0, 0.0, 0.0, 40.0)
    opts = piece_options([p], [[(1.0, 39.0)]], G)[0]
    got = {tuple(_runs_u(o)): (o.extra_loss_m, o.extra_run_m) for o in opts}
    assert got == {
        ((1.0, 35.0),): (6.0, 0.0),
        ((39.0, 5.0),): (6.0, 0.0),
        ((11.0, 5.0), (1.0, 35.0)): (0.0, pytest.approx(10.0)),
        ((1.0, 35.0), (11.0, 5.0)): (0.0, pytest.approx(30.0)),
        ((29.0, 35.0), (39.0, 5.0)): (0.0, pytest.approx(10.0)),
        ((39.0, 5.0), (29.0, 35.0)): (0.0, pytest.approx(30.0)),
    }
    for o in opts:
        if o.extra_loss_m == 0.0:
            assert seen_by(o.runs, G, p) == [(0.0, 40.0)]


def test_short_corridor_keeps_its_middle_unseen() -> None:
    """An 8 m piece between two obstacles: from inside the 6 m free stretch each direction
    sees only the 2 m at the far obstacle; no way along the lane sees the middle."""
    p = Piece(0, 0.0, 0.0, 8.0)
    opts = piece_options([p], [[(1.0, 7.0)]], G)[0]
    assert min(o.extra_loss_m for o in opts) == 0.0
    assert unseen(p, opts, G) == [(2.0, 6.0)]


def test_piece_with_no_free_lead_in_has_no_option() -> None:
    p = Piece(0, 0.0, 0.0, 5.0)
    assert piece_options([p], [[(1.0, 4.0)]], G) == [[]]
    assert unseen(p, [], G) == [(0.0, 5.0)]
