"""Flying a planned survey: the executor, its safety envelope, on-board perception, the run folder."""

from planner.mission.executor import DiveResult, ExecutorConfig, MissionExecutor, PlanTilt, TiltSource
from planner.mission.onboard import MAX_EXTRAPOLATION_S, OnboardConfig, OnboardPerception
from planner.mission.products import summary_document, write_products
from planner.mission.run_folder import RunFolder
from planner.mission.safety import SafetyLimits, clamp_depth, safe_depth_for_altitude
from planner.mission.sonar_sources import DirectorySonarSource

__all__ = [
    "DirectorySonarSource",
    "DiveResult",
    "ExecutorConfig",
    "PlanTilt",
    "MAX_EXTRAPOLATION_S",
    "MissionExecutor",
    "OnboardConfig",
    "OnboardPerception",
    "RunFolder",
    "SafetyLimits",
    "TiltSource",
    "clamp_depth",
    "safe_depth_for_altitude",
    "summary_document",
    "write_products",
]
