"""A target's reason on a long dive says which frames, in runs, not every frame of the dive."""

from __future__ import annotations

from perception.heights.target_solve import summarise_frame_reasons


def test_runs_of_one_reason_are_joined_and_the_rest_counted() -> None:
    reasons = [(i, "not found there") for i in range(3, 8)] + [(9, "cut by the window's end")]
    reasons += [(20 + 2 * k, "its shadow gave no edges") for k in range(10)]
    text = summarise_frame_reasons(reasons, max_groups=3)
    assert text.startswith("frames 3-7: not found there; frame 9: cut by the window's end; frame 20: ")
    assert text.endswith("and 9 more frame(s)")
    assert len(text) < 200
