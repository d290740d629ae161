"""Which remembered tracks the pitch loop can leave out before placing them: those no step
of its horizon could serve (behind the sonar, or past the window's end for the whole
horizon). A field dive remembers hundreds of tracks; placing each one every control step
made the step's cost grow with the dive."""

from __future__ import annotations

import math

from planner.pitch.config import PitchLoopConfig
from planner.pitch.types import TrackedShadow

#: How far past the horizon's reach a remembered track must lie to be left out, m: wide
#: enough that no chain of tracks within ``SAME_TARGET_RADIUS_M`` of each other (the
#: tracker's split pieces, one suppressing the next) reaches from a left-out track to one
#: the loop could serve.
REACH_MARGIN_M = 1.0


def beyond_reach(shadow: TrackedShadow, config: PitchLoopConfig, *, speed_m_s: float) -> bool:
    """Whether no step of the horizon can serve ``shadow`` (level frame, now): behind the
    sonar (the vehicle only moves on, so it stays behind: ``BEHIND`` at every step), or so far
    that even at the horizon's end its top, seen from the seabed distance alone (the slant
    range is longer), lies past the window's end and the lead band (``BEYOND_WINDOW_END``
    at every step); both with :data:`REACH_MARGIN_M` to spare. Never for a negative speed."""
    if speed_m_s < 0.0:
        return False
    if shadow.along_m < -REACH_MARGIN_M:
        return True
    travel_m = speed_m_s * config.horizon_steps * config.dt_s
    return math.hypot(shadow.along_m, shadow.cross_m) - travel_m > config.window_m[1] + config.zone_lead_m \
        + REACH_MARGIN_M
