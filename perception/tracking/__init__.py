"""Following targets across frames, altitudes, passes and viewing directions."""

from perception.tracking.tracker import Detection, TargetTracker, TrackingConfig, seabed_centre, seabed_position

__all__ = [
    "Detection",
    "TargetTracker",
    "TrackingConfig",
    "seabed_centre",
    "seabed_position",
]
