"""The safety envelope every command to the vehicle passes through.

Two hard limits, never crossed whatever the plan, the pitch loop or a bad estimate asks:
the lowest altitude above the seabed and the depth limit. A depth target is computed
from the wanted altitude and the estimated seabed depth, then clamped: shallower than
``seabed - min_clearance_m`` (with the estimate's uncertainty added) and not deeper than
the depth limit. When no clamp can satisfy both (the seabed is shallower than the
clearance allows) the command is refused with the reason.

What the clearance means (one thing everywhere): survey.toml's ``vehicle.min_clearance_m``
is kept between the vehicle and the top of the tallest expected target
(``site.target_height_max_m``), because the seabed estimate is of the seabed, not of the
targets standing on it, and the vehicle flies over them. So the limit given here,
``SafetyLimits.min_clearance_m``, is the altitude above the SEABED that keeps it:
:attr:`planner.config.Settings.min_altitude_m`, ``target_height_max_m +
min_clearance_m``. The planner keeps the lower pass at or above the same altitude, and
:mod:`planner.mission.altitude_watch` warns when the vehicle goes below it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from planner.errors import SafetyViolation


@dataclass(frozen=True)
class SafetyLimits:
    """Hard limits of the dive.

    Attributes
    ----------
    min_clearance_m : float
        Smallest allowed altitude of the vehicle above the SEABED, m: for a survey,
        :attr:`planner.config.Settings.min_altitude_m` (the clearance over the tallest
        target plus that target's height; see the module docstring).
    depth_limit_m : float
        Greatest allowed depth, m (positive down).
    uncertainty_sigmas : float
        How many standard deviations of the seabed estimate are added to the clearance.
    """

    min_clearance_m: float
    depth_limit_m: float
    uncertainty_sigmas: float = 3.0

    def __post_init__(self) -> None:
        if not (math.isfinite(self.min_clearance_m) and self.min_clearance_m > 0):
            raise ValueError(f"min_clearance_m must be > 0, got {self.min_clearance_m!r}")
        if not (math.isfinite(self.depth_limit_m) and self.depth_limit_m > 0):
            raise ValueError(f"depth_limit_m must be > 0, got {self.depth_limit_m!r}")
        if not (math.isfinite(self.uncertainty_sigmas) and self.uncertainty_sigmas >= 0):
            raise ValueError(f"uncertainty_sigmas must be >= 0, got {self.uncertainty_sigmas!r}")


@dataclass(frozen=True)
class DepthCommand:
    """A depth target that passed the envelope, with what was asked and why it changed."""

    depth_m: float
    wanted_depth_m: float
    clamped_by: str | None


def safe_depth_for_altitude(
    altitude_m: float,
    *,
    seabed_depth_m: float,
    seabed_std_m: float,
    limits: SafetyLimits,
) -> DepthCommand:
    """Depth target that holds ``altitude_m`` above the estimated seabed, within the limits.

    Raises
    ------
    SafetyViolation
        When an input is not finite, or no depth satisfies both the clearance and the
        depth limit.
    """
    for name, value in (("altitude_m", altitude_m), ("seabed_depth_m", seabed_depth_m), ("seabed_std_m", seabed_std_m)):
        if not math.isfinite(value):
            raise SafetyViolation(f"{name} is not finite ({value!r}); no depth target sent", reason="bad_estimate")
    wanted = seabed_depth_m - altitude_m
    return clamp_depth(wanted, seabed_depth_m=seabed_depth_m, seabed_std_m=seabed_std_m, limits=limits)


def clamp_depth(
    depth_m: float, *, seabed_depth_m: float | None, seabed_std_m: float = 0.0, limits: SafetyLimits
) -> DepthCommand:
    """Clamp a depth target into the envelope (see the module docstring)."""
    if not math.isfinite(depth_m):
        raise SafetyViolation(f"depth target is not finite ({depth_m!r})", reason="bad_estimate")
    deepest = limits.depth_limit_m
    limit_name = "depth limit"
    if seabed_depth_m is not None:
        if not math.isfinite(seabed_depth_m) or not math.isfinite(seabed_std_m):
            raise SafetyViolation("seabed estimate is not finite; no depth target sent", reason="bad_estimate")
        floor = seabed_depth_m - limits.min_clearance_m - limits.uncertainty_sigmas * max(seabed_std_m, 0.0)
        if floor < deepest:
            deepest, limit_name = floor, "clearance"
    if deepest < 0:
        raise SafetyViolation(
            f"no safe depth: the seabed at {seabed_depth_m} m leaves no room for the clearance "
            f"{limits.min_clearance_m} m",
            reason="no_safe_depth",
        )
    shallowest = 0.0
    if depth_m > deepest:
        return DepthCommand(deepest, depth_m, limit_name)
    if depth_m < shallowest:
        return DepthCommand(shallowest, depth_m, "surface")
    return DepthCommand(depth_m, depth_m, None)
