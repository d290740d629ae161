"""The dry run's closing lines read any summary a dive can end with."""

from __future__ import annotations

from pathlib import Path

from planner.commands.sim import format_summary


def _summary(**extra: object) -> dict[str, object]:
    return {"status": "completed", "reason": "survey flown", "final_state": "COMPLETED", "sim_duration_s": 2380.4,
            "wall_duration_s": 300.0, "n_targets": 12, "n_targets_with_height": 9, "min_clearance_m": 0.99,
            "min_altitude_allowed_m": 1.0, "depth_limit_violations": 0, "shadow_in_fov_ratio": 0.997,
            "shadow_frames_within_range": 1606, **extra}


def test_no_true_target_matched_is_said_not_raised() -> None:
    text = format_summary(_summary(n_truth_targets=20, n_matched=0, height_mean_abs_error_m=None,
                                   height_max_abs_error_m=None), Path("run"))
    assert "none of the 20 true targets has an estimate" in text
    assert text.splitlines()[-1] == '{"status": "completed", "reason": "survey flown"}'


def test_matched_heights_are_given_in_centimetres() -> None:
    text = format_summary(_summary(n_truth_targets=8, n_matched=8, height_mean_abs_error_m=0.0017,
                                   height_max_abs_error_m=0.0123), Path("run"))
    assert "mean |error| 0.17 cm, max 1.23 cm over 8 targets" in text
