"""What the pitch loop takes and gives: tracked shadows, the state, margins, commands.

Frames and signs: see :mod:`planner.pitch.qp` (level frame along the heading)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from perception.errors import GeometryError

FloatArray = NDArray[np.float64]


#: Reasons a target is not served (``DroppedShadow.reason``).
BEHIND = "behind"


OUTSIDE_FAN = "outside_fan"


BEYOND_WINDOW_END = "beyond_window_end"


BEFORE_WINDOW_START = "before_window_start"


TOO_CLOSE = "too_close"


EXTENT_EXCEEDS_APERTURE = "extent_exceeds_aperture"


BEYOND_MOUNT_LIMITS = "beyond_mount_limits"


TOO_MANY_TARGETS = "too_many_targets"


@dataclass(frozen=True)
class TrackedShadow:
    """A target the loop serves, in the level frame at the time of the state.

    Attributes
    ----------
    target_id : int or str
        The tracker's id.
    along_m, cross_m : float
        Horizontal position of the target's far top edge from the sonar, m (forward
        along the heading, starboard).
    height_m : float or None
        Height estimate, m; None uses ``PitchLoopConfig.height_prior_m``.
    footprint_m : float
        Horizontal extent from the near foot to the far top edge along the line of
        sight, m (0 for a post).
    measured : bool
        True when this comes from the current sonar frame, False for a prediction
        (a previous pass's map, dead reckoning).
    """

    target_id: int | str
    along_m: float
    cross_m: float
    height_m: float | None = None
    footprint_m: float = 0.0
    measured: bool = False

    def __post_init__(self) -> None:
        for key in ("along_m", "cross_m", "footprint_m"):
            if not math.isfinite(float(getattr(self, key))):
                raise GeometryError(f"target {self.target_id!r}: {key} must be finite, got {getattr(self, key)!r}")
        if self.footprint_m < 0:
            raise GeometryError(f"target {self.target_id!r}: footprint_m must be >= 0, got {self.footprint_m!r}")
        if self.height_m is not None and not (math.isfinite(self.height_m) and self.height_m >= 0):
            raise GeometryError(f"target {self.target_id!r}: height_m must be finite and >= 0, got {self.height_m!r}")


@dataclass(frozen=True)
class PitchState:
    """What telemetry shows at the time of a control step.

    Attributes
    ----------
    altitude_m : float
        Sonar altitude above the seabed, m (> 0).
    vehicle_pitch_rad, pitch_rate_rad_s : float
        Vehicle pitch (nose up positive), rad, and its rate, rad/s.
    speed_m_s : float
        Horizontal speed along the heading, m/s (>= 0).
    current_tilt_rad : float
        The mount's present tilt, rad (positive down).
    climb_rate_m_s : float
        Rate of change of the altitude, m/s (positive up).
    predicted_pitch_rad : tuple of float or None
        The pitch at the ends of the next ``horizon_steps`` steps when the caller has
        a better prediction than the loop's extrapolation, rad.
    """

    altitude_m: float
    vehicle_pitch_rad: float
    speed_m_s: float
    current_tilt_rad: float
    pitch_rate_rad_s: float = 0.0
    climb_rate_m_s: float = 0.0
    predicted_pitch_rad: tuple[float, ...] | None = None

    def __post_init__(self) -> None:
        if not (math.isfinite(self.altitude_m) and self.altitude_m > 0):
            raise GeometryError(f"altitude_m must be finite and > 0, got {self.altitude_m!r}")
        if not (math.isfinite(self.speed_m_s) and self.speed_m_s >= 0):
            raise GeometryError(f"speed_m_s must be finite and >= 0, got {self.speed_m_s!r}")
        for key in ("vehicle_pitch_rad", "current_tilt_rad", "pitch_rate_rad_s", "climb_rate_m_s"):
            if not math.isfinite(float(getattr(self, key))):
                raise GeometryError(f"{key} must be finite, got {getattr(self, key)!r}")
        if self.predicted_pitch_rad is not None and not all(math.isfinite(p) for p in self.predicted_pitch_rad):
            raise GeometryError("predicted_pitch_rad must hold finite values")


@dataclass(frozen=True)
class ShadowMargin:
    """Predicted margins of one served target's shadow at the end of the first step.

    Elevation margins are angles (rad) in the sonar frame, positive inside:
    ``far_margin_rad`` from the shadow end's ray to the shallow aperture edge,
    ``near_margin_rad`` from the near foot's ray to the steep edge. Window margins are
    slant distances (m), positive inside the range window.
    """

    target_id: int | str
    far_margin_rad: float
    near_margin_rad: float
    window_far_margin_m: float
    window_near_margin_m: float
    constrained: bool

    @property
    def inside(self) -> bool:
        """True when the whole shadow is predicted inside the field of view."""
        return min(self.far_margin_rad, self.near_margin_rad, self.window_far_margin_m,
                   self.window_near_margin_m) >= 0.0


@dataclass(frozen=True)
class DroppedShadow:
    """A target the loop does not serve and why (one of the module's reason constants)."""

    target_id: int | str
    reason: str


@dataclass(frozen=True)
class PitchCommand:
    """The loop's answer for one control step.

    Attributes
    ----------
    tilt_rad : float
        Mount tilt to command now, rad (positive down); within the angle limits and
        reachable within one step at the rate limit.
    planned_tilt_rad : tuple of float
        The planned tilts at the ends of the ``horizon_steps`` steps, rad.
    margins : tuple of ShadowMargin
        Every served target's predicted margins with the commanded tilt.
    dropped : tuple of DroppedShadow
        Targets not served, with reasons.
    slack_rad : float
        Total violation of the shadow constraints at the first step (0 when all served
        shadows are kept inside with margin), rad.
    solver_ok : bool
        False when the QP solver failed; then the tilt holds the current one.
    """

    tilt_rad: float
    planned_tilt_rad: tuple[float, ...]
    margins: tuple[ShadowMargin, ...]
    dropped: tuple[DroppedShadow, ...]
    slack_rad: float = 0.0
    solver_ok: bool = True

    @property
    def tilt_deg(self) -> float:
        """The tilt in degrees, for MAV_CMD_DO_MOUNT_CONTROL."""
        return math.degrees(self.tilt_rad)


class TiltLaw(Protocol):
    """Anything that turns a state and the tracked shadows into a tilt command."""

    def step(self, state: PitchState, shadows: Sequence[TrackedShadow]) -> PitchCommand: ...
