"""Flying a planned survey: the executor, its safety envelope, on-board perception, the run folder.

The names below are imported on first use (PEP 562), so that importing one module of the
package does not load the others."""

from __future__ import annotations

from perception.lazy_exports import lazy_exports

_EXPORTS = {
    "DirectorySonarSource": "planner.mission.sonar_sources",
    "DiveResult": "planner.mission.executor",
    "ExecutorConfig": "planner.mission.executor",
    "MissionExecutor": "planner.mission.executor",
    "OnboardConfig": "planner.mission.onboard",
    "OnboardPerception": "planner.mission.onboard",
    "OnboardStatus": "planner.mission.onboard",
    "PlanTilt": "planner.mission.executor",
    "RunFolder": "planner.mission.run_folder",
    "SafetyLimits": "planner.mission.safety",
    "TiltSource": "planner.mission.executor",
    "Vehicle": "planner.mission.vehicle",
    "clamp_depth": "planner.mission.safety",
    "safe_depth_for_altitude": "planner.mission.safety",
    "summary_document": "planner.mission.products",
    "write_products": "planner.mission.products",
}

__all__ = sorted(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
