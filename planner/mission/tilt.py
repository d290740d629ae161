"""Where the mount's tilt comes from each control step: the :class:`TiltSource` protocol
(the pitch loop, :class:`planner.pitch.control.ShadowPitchLoop`, or a fixed tilt) and the
plain :class:`PlanTilt`."""

from __future__ import annotations

import math
from typing import Protocol

from planner.mission.onboard import OnboardPerception
from planner.survey.plan import SurveyPass


class TiltSource(Protocol):
    """Chooses the mount tilt each control step (the pitch loop, or a fixed tilt).

    Its tilts are in the mount's frame, which the executor tells it with
    ``set_mount_frame`` once it has read MNT1_TYPE: "earth" for ArduSub's stabilised
    servo mount (it takes the vehicle's pitch out itself), "body" otherwise.
    """

    def set_mount_frame(self, frame: str) -> None: ...

    def tilt_command(self, *, now_s: float, pass_: SurveyPass, onboard: OnboardPerception,
                     current_tilt_rad: float, speed_m_s: float) -> tuple[float, float]:
        """(tilt to command, smallest shadow margin in rad or NaN)."""
        ...

    def tracking_zone(self, pass_: SurveyPass) -> dict[str, float] | None:
        """The pass's tracking zone for the log (``planner.pitch.control.describe_zone``), or None."""
        ...


class PlanTilt:
    """Holds the plan's tilt for the pass (the baseline the pitch loop is compared with)."""

    def set_mount_frame(self, frame: str) -> None:
        """The plan's tilt is the depression below the horizontal: right in either frame
        for a level vehicle, and held whatever the pitch by a stabilised mount."""
        del frame

    def tracking_zone(self, pass_: SurveyPass) -> dict[str, float] | None:
        """No tracking zone: nothing is tracked."""
        del pass_
        return None

    def tilt_command(self, *, now_s: float, pass_: SurveyPass, onboard: OnboardPerception,
                     current_tilt_rad: float, speed_m_s: float) -> tuple[float, float]:
        del now_s, onboard, current_tilt_rad, speed_m_s
        return pass_.tilt_rad, math.nan
