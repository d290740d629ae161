"""Label placement's overlap sums (planner/report/plotting.py) against matplotlib's own
box intersection, and the labels it places keeping clear of one another."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from matplotlib.transforms import Bbox

from planner.report.plotting import covered_area, place_labels

coords = st.floats(-500.0, 500.0, allow_nan=False, allow_infinity=False)
boxes = st.tuples(coords, coords, coords, coords)


def _by_matplotlib(box: tuple[float, float, float, float], others: list[tuple[float, float, float, float]]) -> float:
    """The sum as the placement once did it: Bbox.intersection box by box, in order."""
    mine = Bbox([[min(box[0], box[2]), min(box[1], box[3])], [max(box[0], box[2]), max(box[1], box[3])]])
    cover = 0.0
    for o in others:
        other = Bbox([[min(o[0], o[2]), min(o[1], o[3])], [max(o[0], o[2]), max(o[1], o[3])]])
        inter = Bbox.intersection(mine, other)
        if inter is not None:
            cover += inter.width * inter.height
    return cover


@settings(max_examples=300, deadline=None)
@given(boxes, st.lists(boxes, max_size=12))
def test_covered_area_is_matplotlibs_sum_bit_for_bit(box, others):
    got = covered_area(box, np.array(others, dtype=np.float64).reshape(-1, 4))
    assert got == _by_matplotlib(box, others)


def test_touching_and_nested_boxes():
    box = (0.0, 0.0, 10.0, 10.0)
    assert covered_area(box, np.array([[10.0, 0.0, 20.0, 10.0]])) == 0.0  # shares an edge only
    assert covered_area(box, np.array([[2.0, 2.0, 4.0, 5.0]])) == 6.0  # inside
    assert covered_area(box, np.array([[-5.0, -5.0, 15.0, 15.0]])) == 100.0  # covers it whole
    assert covered_area(box, np.array([[2.0, 2.0, 4.0, 5.0], [2.0, 2.0, 4.0, 5.0]])) == 12.0  # twice


def test_labels_of_a_crowd_of_points_do_not_overlap():
    """Twelve points in a tight cluster: every label finds a place free of the others."""
    fig, ax = plt.subplots(figsize=(6, 4), dpi=100)
    try:
        rng = np.random.default_rng(3)
        xy = rng.uniform(0.0, 10.0, size=(12, 2))
        ax.plot(xy[:, 0], xy[:, 1], "o")
        ax.set_xlim(-20, 30)
        ax.set_ylim(-20, 30)
        place_labels(ax, [(float(x), float(y), f"T{i}", {"fontsize": 8}) for i, (x, y) in enumerate(xy)])
        renderer = fig.canvas.get_renderer()
        placed = [t.get_window_extent(renderer) for t in ax.texts]
        assert len(placed) == 12
        for i, a in enumerate(placed):
            for b in placed[i + 1:]:
                inter = Bbox.intersection(a, b)
                assert inter is None or inter.width * inter.height == 0.0
    finally:
        plt.close(fig)
