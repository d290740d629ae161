"""Gates of the target tracker (:class:`perception.tracking.tracker.TargetTracker`), validated once."""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class TrackingConfig:
    """Gates of :class:`TargetTracker`.

    Attributes
    ----------
    azimuth_gate_rad : float
        Largest azimuth difference for one target between frames, rad (no pose).
    range_gate_m : float
        Largest shadow-start range difference at equal altitude, m (no pose).
    range_gate_per_dh : float
        Extra range gate per metre of altitude change between the frames (``|dr| <= |dH|``
        for a vertical move, so 1.0 is enough).
    position_gate_m : float
        Seabed distance gate between a detection's centre and a target's position at
        zero range and altitude, m (pose mode).
    position_gate_per_range : float
        Growth of the position gate per metre of slant range, m/m.
    position_gate_per_altitude : float
        Growth of the position gate per metre of altitude, m/m.
    highlight_only_extra_gate_m : float
        Extra gate for a detection whose shadow edges are unknown, m.
    default_half_length_m : float
        Assumed half length of a target along the beam when only its near face is known, m.
    unknown_delta_h_m : float
        Altitude change assumed for the range gate when the frames do not say, m.
    merge_height_gate_m, merge_height_fraction : float
        Two targets merge only when their height guesses differ by at most
        ``merge_height_gate_m + merge_height_fraction * max(h1, h2)`` (m, -).
    merge_max_shared_fraction : float
        Two targets seen together in more than this fraction of the frames of the less
        seen one are distinct (a target split in two in a few frames still merges; in
        the frames both were seen, one detection is kept).
    prune_after_frames : int
        Frames after which a target seen in fewer than ``prune_min_detections`` frames
        and never with a complete shadow is dropped (>= 1).
    prune_min_detections : int
        See ``prune_after_frames``.
    carry_top_frames : int
        A cut shadow (no far top edge of its own) that joins a target takes the far top
        edge of the target's latest detection that had one, when that is at most this many
        frames old (a static target's edge from nearly the same viewpoint); 0: never.
    max_tracks : int
        Most targets kept; beyond it the least-seen, longest-unseen ones are dropped.
    """

    azimuth_gate_rad: float = math.radians(3.0)
    range_gate_m: float = 0.04
    range_gate_per_dh: float = 1.1
    position_gate_m: float = 0.10
    position_gate_per_range: float = 0.03
    position_gate_per_altitude: float = 0.05
    highlight_only_extra_gate_m: float = 0.08
    default_half_length_m: float = 0.05
    unknown_delta_h_m: float = 0.3
    merge_height_gate_m: float = 0.015
    merge_height_fraction: float = 0.25
    merge_max_shared_fraction: float = 0.5
    prune_after_frames: int = 150
    prune_min_detections: int = 3
    carry_top_frames: int = 30
    max_tracks: int = 2000

    def __post_init__(self) -> None:
        for name in ("azimuth_gate_rad", "range_gate_m", "position_gate_m"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")
        for name in (
            "range_gate_per_dh", "unknown_delta_h_m", "position_gate_per_range",
            "position_gate_per_altitude", "highlight_only_extra_gate_m",
            "default_half_length_m", "merge_height_gate_m", "merge_height_fraction",
            "merge_max_shared_fraction", "prune_min_detections", "carry_top_frames",
        ):
            if not getattr(self, name) >= 0:
                raise ValueError(f"{name} must be >= 0, got {getattr(self, name)}")
        if self.prune_after_frames < 1 or self.max_tracks < 1:
            raise ValueError(
                f"prune_after_frames and max_tracks must be >= 1, got "
                f"{self.prune_after_frames} and {self.max_tracks}"
            )
