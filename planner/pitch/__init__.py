"""The pitch loop that keeps every tracked shadow inside the sonar's vertical aperture.

- :mod:`planner.pitch.config`: the loop's settings and the tilt mount's limits;
- :mod:`planner.pitch.types`: tracked shadows, the state, margins, commands;
- :mod:`planner.pitch.aperture`: depressions that keep points, shadows, the tracking zone in view;
- :mod:`planner.pitch.measurements`: shadows from perception's measurements or the map;
- :mod:`planner.pitch.prediction`: pitch, altitude and shadow intervals over the horizon;
- :mod:`planner.pitch.selection`: which shadows are served, conflict yielding;
- :mod:`planner.pitch.qp`: the QP (casadi) itself, :class:`PitchLoop`;
- :mod:`planner.pitch.baseline`: the fixed-tilt baseline, :class:`NominalTilt`;
- :mod:`planner.pitch.control`: the executor's side: what the sonar shows -> the loop -> a tilt.
"""

from planner.pitch.aperture import (
    aperture_interval_rad,
    depression_interval_rad,
    point_elevation_rad,
    shadow_geometry,
    shadow_margins_rad,
    tracking_zone_start_m,
)
from planner.pitch.baseline import NominalTilt
from planner.pitch.config import MountLimits, PitchLoopConfig
from planner.pitch.control import (
    DEFAULT_MOUNT,
    ShadowPitchLoop,
    ZoneCentredTilt,
    describe_zone,
    footprint_from_highlight_m,
    loop_config,
    merge_pieces,
)
from planner.pitch.measurements import shadow_from_measurement, shadow_from_ned, shadow_measurement
from planner.pitch.prediction import predict_pitch_rad
from planner.pitch.qp import PitchLoop
from planner.pitch.types import (
    BEFORE_WINDOW_START,
    BEHIND,
    BEYOND_MOUNT_LIMITS,
    BEYOND_WINDOW_END,
    EXTENT_EXCEEDS_APERTURE,
    OUTSIDE_FAN,
    TOO_CLOSE,
    TOO_MANY_TARGETS,
    PitchCommand,
    PitchState,
    TiltLaw,
    TrackedShadow,
)

__all__ = [
    "BEFORE_WINDOW_START",
    "BEHIND",
    "BEYOND_MOUNT_LIMITS",
    "BEYOND_WINDOW_END",
    "DEFAULT_MOUNT",
    "EXTENT_EXCEEDS_APERTURE",
    "MountLimits",
    "NominalTilt",
    "OUTSIDE_FAN",
    "PitchCommand",
    "PitchLoop",
    "PitchLoopConfig",
    "PitchState",
    "ShadowPitchLoop",
    "TOO_CLOSE",
    "TOO_MANY_TARGETS",
    "TiltLaw",
    "TrackedShadow",
    "ZoneCentredTilt",
    "aperture_interval_rad",
    "depression_interval_rad",
    "describe_zone",
    "footprint_from_highlight_m",
    "loop_config",
    "merge_pieces",
    "point_elevation_rad",
    "predict_pitch_rad",
    "shadow_from_measurement",
    "shadow_from_ned",
    "shadow_geometry",
    "shadow_margins_rad",
    "shadow_measurement",
    "tracking_zone_start_m",
]
