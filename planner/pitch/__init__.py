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

The names below are imported on first use (PEP 562), so that importing one module of the
package does not load the others."""

from __future__ import annotations

from perception.lazy_exports import lazy_exports

_EXPORTS = {
    "BEFORE_WINDOW_START": "planner.pitch.types",
    "BEHIND": "planner.pitch.types",
    "BEYOND_MOUNT_LIMITS": "planner.pitch.types",
    "BEYOND_WINDOW_END": "planner.pitch.types",
    "DEFAULT_MOUNT": "planner.pitch.control",
    "EXTENT_EXCEEDS_APERTURE": "planner.pitch.types",
    "MountLimits": "planner.pitch.config",
    "NominalTilt": "planner.pitch.baseline",
    "OUTSIDE_FAN": "planner.pitch.types",
    "PitchCommand": "planner.pitch.types",
    "PitchLoop": "planner.pitch.qp",
    "PitchLoopConfig": "planner.pitch.config",
    "PitchState": "planner.pitch.types",
    "ShadowPitchLoop": "planner.pitch.control",
    "TOO_CLOSE": "planner.pitch.types",
    "TOO_MANY_TARGETS": "planner.pitch.types",
    "TiltLaw": "planner.pitch.types",
    "TrackedShadow": "planner.pitch.types",
    "ZoneCentredTilt": "planner.pitch.control",
    "aperture_interval_rad": "planner.pitch.aperture",
    "depression_interval_rad": "planner.pitch.aperture",
    "describe_zone": "planner.pitch.control",
    "footprint_from_highlight_m": "planner.pitch.control",
    "loop_config": "planner.pitch.control",
    "merge_pieces": "planner.pitch.control",
    "point_elevation_rad": "planner.pitch.aperture",
    "predict_pitch_rad": "planner.pitch.prediction",
    "shadow_from_measurement": "planner.pitch.measurements",
    "shadow_from_ned": "planner.pitch.measurements",
    "shadow_and_whole_intervals_rad": "planner.pitch.aperture",
    "shadow_geometry": "planner.pitch.aperture",
    "shadow_margins_rad": "planner.pitch.aperture",
    "shadow_measurement": "planner.pitch.measurements",
    "tracking_zone_start_m": "planner.pitch.aperture",
}

__all__ = sorted(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
