"""Target heights from cast shadows: the solvers (Eq. 2 and its N-frame form) and the frame-to-target pipeline."""

from perception.heights.models import altitude_groups, onset_altitude, top_echo_slope_db_per_m
from perception.heights.pipeline import FrameResult, HeightPipeline, HeightsConfig, TargetHeight, detect_shadows
from perception.heights.solver import (
    HeightEstimate,
    ShadowObservation,
    eq2_paper,
    fit_rounded_top,
    grazing_tan2,
    height_one_frame,
    height_two_frames,
    solve_height,
    solve_height_batch,
    solve_height_sloped,
)

__all__ = [
    "FrameResult",
    "HeightEstimate",
    "HeightPipeline",
    "HeightsConfig",
    "ShadowObservation",
    "TargetHeight",
    "altitude_groups",
    "detect_shadows",
    "eq2_paper",
    "fit_rounded_top",
    "grazing_tan2",
    "height_one_frame",
    "height_two_frames",
    "onset_altitude",
    "solve_height",
    "solve_height_batch",
    "solve_height_sloped",
    "top_echo_slope_db_per_m",
]
