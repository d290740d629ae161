"""Flying a planned survey: the executor, its safety envelope, on-board perception, the run folder."""

from planner.mission.executor import DiveResult, ExecutorConfig, MissionExecutor, PlanTilt, TiltSource
from planner.mission.onboard import OnboardConfig, OnboardPerception, OnboardStatus
from planner.mission.products import summary_document, write_products
from planner.mission.run_folder import RunFolder
from planner.mission.safety import SafetyLimits, clamp_depth, safe_depth_for_altitude
from planner.mission.sonar_sources import DirectorySonarSource
from planner.mission.vehicle import Vehicle

__all__ = [
    "DirectorySonarSource",
    "DiveResult",
    "ExecutorConfig",
    "PlanTilt",
    "MissionExecutor",
    "OnboardConfig",
    "OnboardPerception",
    "OnboardStatus",
    "RunFolder",
    "SafetyLimits",
    "TiltSource",
    "Vehicle",
    "clamp_depth",
    "safe_depth_for_altitude",
    "summary_document",
    "write_products",
]
