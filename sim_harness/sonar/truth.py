"""Ground truth of a rendered sonar frame: label image and per-target shadow geometry.

The truth goes to scorers and tests, never to the controller under test. Everything is
measured along beam AXES (the ray plane of each beam's centre azimuth), in the frame's own
slant ranges (from the sonar's acoustic centre, range zero), SI units and radians.

Per target and beam the shadow is computed from the geometry of that target alone (other
targets ignored), by ray casting with refined edges (to ~0.3 mm), never from the image:

- ``shadow_start_m``: slant range of the target's far top edge, where the shallowest
  occluded ray grazes the target; the shadow starts there in the image;
- ``shadow_end_m``: slant range at which that grazing ray meets the seabed;
- ``highlight_start_m``: slant range of the target's nearest visible point in the beam.

For a flat seabed ``height = altitude * (shadow_end - shadow_start) / shadow_end`` holds
with the altitude measured perpendicular to the seabed (architecture.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import IntEnum
from typing import Any

import numpy as np


class Label(IntEnum):
    """Codes of the polar label image (uint8).

    OUTSIDE_BEAM: no seabed inside the vertical aperture at this range (water column, or
    past the shallowest ray). BEYOND_WINDOW: outside the range window or fan; never in the
    polar label image (which is the window), used by fan/Cartesian label maps.
    SEABED: insonified seabed. HIGHLIGHT: a target echoes here. SHADOW: seabed inside the
    aperture hidden (>= half its elevation span) by a target, and no target echo.
    """

    OUTSIDE_BEAM = 0
    BEYOND_WINDOW = 1
    SEABED = 2
    HIGHLIGHT = 3
    SHADOW = 4


@dataclass(frozen=True, eq=False)
class TargetTruth:
    """Shadow geometry of one target seen by at least one beam axis.

    Attributes
    ----------
    target_id, shape : str
    index : int
        1-based code of this target in :attr:`FrameTruth.owner`.
    north_m, east_m : float
        Target centre, local NED m.
    height_m : float
        True height of the top above the seabed under the centre (vertical), m.
    height_normal_m : float
        The same measured perpendicular to the seabed plane, m.
    top_depth_m : float
        Depth of the top, m.
    beams : ndarray of int, shape (n,)
        Beam (column) indices whose axis plane sees the target's shadow.
    shadow_start_m, shadow_end_m, highlight_start_m : ndarray, shape (n,)
        Per beam, slant ranges (module docstring), m.
    hidden_seabed_start_m : ndarray, shape (n,)
        Per beam, slant range where the seabed hidden by the target begins (its foot). The
        dark shadow seen in the image runs from ``max(shadow_start_m, hidden_seabed_start_m)``
        to ``shadow_end_m``: where a beam plane cuts a target's side obliquely, the top lies
        nearer than the foot (layover) and seabed shows between them.
    in_band, in_window : ndarray of bool, shape (n,)
        Per beam: the whole shadow lies on seabed inside the vertical aperture; the whole
        shadow lies inside the range window.
    central_beam : int
        The beam whose azimuth is nearest the azimuth of the target centre.
    azimuth_rad : float
        Azimuth of the central beam, rad (positive to starboard).
    central_shadow_start_m, central_shadow_end_m : float
        Shadow start and end along the central beam, m.
    whole_shadow_in_band, whole_shadow_in_window : bool
        ``in_band`` / ``in_window`` for every beam.
    """

    target_id: str
    shape: str
    index: int
    north_m: float
    east_m: float
    height_m: float
    height_normal_m: float
    top_depth_m: float
    beams: np.ndarray
    shadow_start_m: np.ndarray
    shadow_end_m: np.ndarray
    highlight_start_m: np.ndarray
    hidden_seabed_start_m: np.ndarray
    in_band: np.ndarray
    in_window: np.ndarray
    central_beam: int
    azimuth_rad: float
    central_shadow_start_m: float
    central_shadow_end_m: float
    whole_shadow_in_band: bool
    whole_shadow_in_window: bool

    def to_json_dict(self) -> dict[str, Any]:
        """A JSON-ready dict (degrees for angles, named ``_deg``)."""
        return {
            "target_id": self.target_id,
            "shape": self.shape,
            "index": self.index,
            "north_m": self.north_m,
            "east_m": self.east_m,
            "height_m": self.height_m,
            "height_normal_m": self.height_normal_m,
            "top_depth_m": self.top_depth_m,
            "central_beam": self.central_beam,
            "azimuth_deg": math.degrees(self.azimuth_rad),
            "shadow_start_m": self.central_shadow_start_m,
            "shadow_end_m": self.central_shadow_end_m,
            "whole_shadow_in_band": self.whole_shadow_in_band,
            "whole_shadow_in_window": self.whole_shadow_in_window,
            "beams": [int(b) for b in self.beams],
            "beam_shadow_start_m": [float(v) for v in self.shadow_start_m],
            "beam_shadow_end_m": [float(v) for v in self.shadow_end_m],
            "beam_highlight_start_m": [float(v) for v in self.highlight_start_m],
            "beam_hidden_seabed_start_m": [float(v) for v in self.hidden_seabed_start_m],
            "beam_in_band": [bool(v) for v in self.in_band],
            "beam_in_window": [bool(v) for v in self.in_window],
        }


@dataclass(frozen=True, eq=False)
class FrameTruth:
    """Everything known about a rendered frame that a real sonar would not report.

    Attributes
    ----------
    labels : ndarray, shape (n_samples, n_beams), uint8
        :class:`Label` codes.
    owner : ndarray, shape (n_samples, n_beams), uint8
        For HIGHLIGHT and SHADOW cells the 1-based index of the target responsible (see
        :attr:`TargetTruth.index`), else 0.
    targets : tuple of TargetTruth
        Targets whose shadow at least one beam axis sees, nearest first.
    timestamp_s : float
    pose : object
        The :class:`sim_harness.sonar.renderer.SonarPose` rendered.
    altitude_m : float
        True height of the sonar above the seabed directly below it (vertical), m.
    altitude_normal_m : float
        True distance from the sonar to the seabed plane (perpendicular), m.
    seabed_normal_ned : ndarray, shape (3,)
        Unit normal of the seabed plane, pointing up, NED.
    seed : int
        Renderer seed; with ``timestamp_s`` it fixes the noise.
    """

    labels: np.ndarray
    owner: np.ndarray
    targets: tuple[TargetTruth, ...]
    timestamp_s: float
    pose: Any
    altitude_m: float
    altitude_normal_m: float
    seabed_normal_ned: np.ndarray
    seed: int
    extra: dict[str, Any] = field(default_factory=dict)

    def target(self, target_id: str) -> TargetTruth:
        """The truth of one target by id."""
        for t in self.targets:
            if t.target_id == target_id:
                return t
        raise KeyError(f"target {target_id!r} is not seen in this frame")

    def to_json_dict(self) -> dict[str, Any]:
        """A JSON-ready dict of the scalar truth (the label image is not included)."""
        pose = self.pose
        return {
            "timestamp_s": self.timestamp_s,
            "seed": self.seed,
            "altitude_m": self.altitude_m,
            "altitude_normal_m": self.altitude_normal_m,
            "seabed_normal_ned": [float(v) for v in self.seabed_normal_ned],
            "pose": {
                "north_m": pose.north_m,
                "east_m": pose.east_m,
                "sonar_depth_m": pose.depth_m,
                "heading_deg": math.degrees(pose.heading_rad),
                "pitch_deg": math.degrees(pose.pitch_rad),
                "roll_deg": math.degrees(pose.roll_rad),
                "tilt_deg": math.degrees(pose.tilt_rad),
            },
            "label_codes": {label.name: int(label) for label in Label},
            "label_counts": {
                label.name: int(np.count_nonzero(self.labels == label)) for label in Label
            },
            "targets": [t.to_json_dict() for t in self.targets],
        }
