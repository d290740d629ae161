"""Flying a planned survey: the executor, its safety envelope, on-board perception, the run folder.

The names below are imported on first use (PEP 562), so that importing one module of the
package does not load the others."""

from __future__ import annotations

import importlib
from typing import Any

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


def __getattr__(name: str) -> Any:
    """Import a public name's module on first use (PEP 562)."""
    try:
        module = _EXPORTS[name]
    except KeyError:
        raise AttributeError(f"module 'planner.mission' has no attribute {name!r}") from None
    return getattr(importlib.import_module(module), name)


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
