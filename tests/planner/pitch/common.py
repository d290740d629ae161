"""Settings shared by the pitch loop's tests."""

from __future__ import annotations

import math

from planner.pitch.config import MountLimits, PitchLoopConfig

APERTURE = math.radians(14.0)
LIMITS = MountLimits(0.0, math.radians(60.0), math.radians(20.0))


def pitch_config(**kw: object) -> PitchLoopConfig:
    """The loop's settings with a 15 deg nominal tilt, changed by ``kw``."""
    kw.setdefault("nominal_tilt_rad", math.radians(15.0))
    return PitchLoopConfig(**kw)  # type: ignore[arg-type]
