"""The summary ``shadowsurvey sim`` prints after a dive (``planner.commands.sim.format_summary``)."""

from __future__ import annotations

from pathlib import Path

from planner.commands.sim import format_summary

_SUMMARY = {"status": "completed", "reason": "survey flown", "final_state": "COMPLETED", "sim_duration_s": 107.0,
            "wall_duration_s": 9.0, "n_targets": 0, "n_targets_with_height": 0, "min_clearance_m": 0.55,
            "min_altitude_allowed_m": 0.5, "depth_limit_violations": 0, "shadow_in_fov_ratio": None,
            "shadow_frames_within_range": 0, "n_matched": 0, "n_truth_targets": 0}


def test_a_dive_with_no_target_matched_is_summarised() -> None:
    # a site without targets (or none found): the scorer gives no error figures (null in summary.json)
    text = format_summary({**_SUMMARY, "height_mean_abs_error_m": None, "height_max_abs_error_m": None},
                          Path("runs/site"))
    assert "heights vs truth: no target matched of 0 in the scene" in text
    assert text.splitlines()[-1] == '{"status": "completed", "reason": "survey flown"}'


def test_heights_against_truth_in_centimetres() -> None:
    text = format_summary({**_SUMMARY, "n_matched": 4, "height_mean_abs_error_m": 0.0052,
                           "height_max_abs_error_m": 0.0121}, Path("runs/site"))
    assert "mean |error| 0.52 cm, max 1.21 cm over 4 targets" in text
