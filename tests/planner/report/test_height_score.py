"""Matching estimated targets to truth and scoring heights (planner.report.height_score)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from planner.report.height_score import match_targets, score_heights


@dataclass(frozen=True)
class T:
    north_m: float
    east_m: float
    height_m: float = math.nan
    height_std_m: float = math.nan


def test_match_pairs_nearest_and_leaves_far_ones_out() -> None:
    truth = [T(0.0, 0.0), T(10.0, 0.0), T(0.0, 10.0)]
    est = [T(10.2, 0.1), T(50.0, 50.0), T(-0.1, 0.3)]
    m = match_targets(est, truth, 1.0)
    assert [(p.estimated, p.truth) for p in m.pairs] == [(2, 0), (0, 1)]
    assert m.pairs[0].distance_m == pytest.approx(math.hypot(0.1, 0.3))
    assert m.unmatched_estimated == (1,)
    assert m.unmatched_truth == (2,)


def test_match_maximises_matches_where_greedy_nearest_would_not() -> None:
    # Greedy nearest-first takes x-A (0.4 m) and leaves y without a partner; the one-to-one
    # assignment pairs y-A (0.5 m) and x-B (0.6 m), both within 0.65 m.
    truth = [T(0.0, 0.0), T(1.0, 0.0)]
    est = [T(0.4, 0.0), T(-0.5, 0.0)]
    m = match_targets(est, truth, 0.65)
    assert [(p.estimated, p.truth) for p in m.pairs] == [(1, 0), (0, 1)]
    assert m.unmatched_estimated == () and m.unmatched_truth == ()


def test_match_with_empty_sides() -> None:
    assert match_targets([], [T(0, 0)], 1.0).unmatched_truth == (0,)
    assert match_targets([T(0, 0)], [], 1.0).unmatched_estimated == (0,)


@pytest.mark.parametrize("radius", [0.0, -1.0, math.nan, math.inf])
def test_match_rejects_bad_radius(radius: float) -> None:
    with pytest.raises(ValueError, match="radius_m"):
        match_targets([T(0, 0)], [T(0, 0)], radius)


@settings(max_examples=60, deadline=None)
@given(
    cells=st.lists(st.tuples(st.integers(-20, 20), st.integers(-20, 20)), min_size=1, max_size=12, unique=True),
    offsets=st.lists(st.tuples(st.floats(-0.35, 0.35), st.floats(-0.35, 0.35)), min_size=12, max_size=12),
    order=st.randoms(use_true_random=False),
)
def test_match_recovers_a_shuffled_perturbed_copy(cells: list[tuple[int, int]],
                                                   offsets: list[tuple[float, float]], order: object) -> None:
    """Targets 3 m apart, estimates within 0.5 m of their truth: the match is the permutation."""
    truth = [T(3.0 * a, 3.0 * b) for a, b in cells]
    perm = list(range(len(truth)))
    order.shuffle(perm)  # type: ignore[attr-defined]
    est = [T(truth[i].north_m + offsets[k][0], truth[i].east_m + offsets[k][1]) for k, i in enumerate(perm)]
    m = match_targets(est, truth, 1.0)
    assert {(p.estimated, p.truth) for p in m.pairs} == {(k, i) for k, i in enumerate(perm)}
    assert all(p.distance_m <= 0.5 for p in m.pairs)
    assert m.unmatched_estimated == () and m.unmatched_truth == ()


@settings(max_examples=60, deadline=None)
@given(
    est=st.lists(st.tuples(st.floats(-5, 5), st.floats(-5, 5)), max_size=8),
    tru=st.lists(st.tuples(st.floats(-5, 5), st.floats(-5, 5)), max_size=8),
    radius=st.floats(0.1, 4.0),
)
def test_match_is_one_to_one_within_radius(est: list[tuple[float, float]], tru: list[tuple[float, float]],
                                           radius: float) -> None:
    m = match_targets([T(*p) for p in est], [T(*p) for p in tru], radius)
    used_e = [p.estimated for p in m.pairs]
    used_t = [p.truth for p in m.pairs]
    assert len(set(used_e)) == len(used_e) and len(set(used_t)) == len(used_t)
    assert sorted(used_e + list(m.unmatched_estimated)) == list(range(len(est)))
    assert sorted(used_t + list(m.unmatched_truth)) == list(range(len(tru)))
    for p in m.pairs:
        d = math.hypot(est[p.estimated][0] - tru[p.truth][0], est[p.estimated][1] - tru[p.truth][1])
        assert p.distance_m == pytest.approx(d) and d <= radius
    # Maximal: no unmatched estimate lies within the radius of an unmatched truth.
    for i in m.unmatched_estimated:
        for j in m.unmatched_truth:
            assert math.hypot(est[i][0] - tru[j][0], est[i][1] - tru[j][1]) > radius


def test_score_heights_known_errors() -> None:
    truth = [T(0, 0, 0.10), T(5, 0, 0.20), T(10, 0, 0.30), T(20, 0, 0.05)]
    est = [T(5.1, 0, 0.23, 0.01), T(0.2, 0, 0.09, 0.02), T(10, 0.3, math.nan, math.nan), T(40, 0, 0.1, 0.01)]
    s = score_heights(est, truth, radius_m=0.5)
    assert [(e.truth, e.estimated) for e in s.errors] == [(0, 1), (1, 0)]
    assert [e.error_m for e in s.errors] == pytest.approx([-0.01, 0.03])
    assert s.errors[1].z == pytest.approx(3.0)
    assert s.mean_abs_error_m == pytest.approx(0.02)
    assert s.max_abs_error_m == pytest.approx(0.03)
    assert s.rms_error_m == pytest.approx(math.sqrt((0.01 ** 2 + 0.03 ** 2) / 2))
    assert s.mean_error_m == pytest.approx(0.01)
    assert [(m.truth, m.estimated) for m in s.no_height] == [(2, 2)]
    assert s.unmatched_estimated == (3,) and s.unmatched_truth == (3,)


def test_score_heights_without_matches_gives_nan_statistics() -> None:
    s = score_heights([T(0, 0, 0.1, 0.01)], [T(9, 9, 0.1)], radius_m=1.0)
    assert s.errors == ()
    assert math.isnan(s.mean_abs_error_m) and math.isnan(s.max_abs_error_m) and math.isnan(s.rms_error_m)


def test_an_estimate_with_a_height_wins_over_a_nearer_one_without() -> None:
    truth = [T(0, 0, 0.10)]
    est = [T(0.05, 0, math.nan, math.nan), T(0.4, 0, 0.11, 0.01)]
    s = score_heights(est, truth, radius_m=0.5)
    assert [(e.truth, e.estimated) for e in s.errors] == [(0, 1)]
    assert s.errors[0].error_m == pytest.approx(0.01)
    assert s.no_height == () and s.unmatched_estimated == (0,) and s.unmatched_truth == ()
