"""Cross-checks of recorded frames against each other and against the command line.

``heights`` and ``mosaic`` read frames that should show one scene; these checks refuse,
with the files named, what would otherwise give confident nonsense:

- :func:`check_one_scene`: the frames agree on the water's sound speed and the seabed's
  depth (:func:`perception.sonar_io.validate.check_one_scene`);
- :func:`check_delta_h`: ``--delta-h`` agrees with the altitudes (or depths) the frames
  carry, keeps both altitudes above the seabed, and is smaller than the range window
  (both frames see the seabed within it);
- :class:`MapExtent`: the frames of one map fit a raster of at most :data:`MAX_MAP_CELLS`
  cells at the chosen resolution (a navigation jump of 1,000 km would ask for hundreds of
  gigabytes).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from perception.errors import FrameFormatError
from perception.sonar_io import validate
from perception.sonar_io.frame import SonarFrame
from planner.errors import UsageError

#: ``heights``: frames of one place from two altitudes; their seabed depths agree within this, m.
HEIGHTS_SEABED_TOLERANCE_M = 0.5
#: ``mosaic``: frames of one survey; the seabed may slope, but not by this much, m.
MOSAIC_SEABED_TOLERANCE_M = 10.0
#: ``--delta-h`` may differ from the frames' own altitude change by this much, m, or ...
DELTA_H_TOLERANCE_M = 0.05
#: ... this fraction of it, whichever is larger (the option is for a better dH than the frames').
DELTA_H_TOLERANCE_FRACTION = 0.5


def seabed_depth_m(frame: SonarFrame) -> float:
    """Sonar depth plus altitude (NaN unless both are known), m."""
    return frame.sonar_depth_m + frame.altitude_m


def check_one_scene(labels: Sequence[str], frames: Sequence[SonarFrame], *, seabed_tolerance_m: float) -> None:
    """Refuse frames of two scenes (see the module docstring); the message names both frames."""
    try:
        validate.check_one_scene(labels, [f.sound_speed_m_s for f in frames], [seabed_depth_m(f) for f in frames],
                                 seabed_tolerance_m=seabed_tolerance_m)
    except FrameFormatError as exc:
        raise UsageError(f"{exc.detail} (key {exc.key})") from None


def check_altitudes(labels: Sequence[str], frames: Sequence[SonarFrame], altitudes_m: Sequence[float]) -> None:
    """Refuse an altitude (the frame's own, or from ``--altitude``/``--delta-h``) at or beyond the
    frame's range window: the seabed, and every shadow on it, lies beyond the altitude."""
    for label, frame, altitude in zip(labels, frames, altitudes_m, strict=True):
        if math.isfinite(altitude) and altitude >= frame.window_m[1]:
            raise UsageError(f"{label}: altitude {altitude:.3f} m is beyond the range window's far end "
                             f"({frame.window_m[1]:.3f} m): the seabed cannot be in this frame (a wrong altitude_m, "
                             "--altitude or --delta-h?)")


def check_delta_h(labels: Sequence[str], frames: Sequence[SonarFrame], delta_h_m: float,
                  altitude_m: float | None) -> None:
    """Refuse a ``--delta-h`` that the frames (two of them) contradict."""
    first, second = frames
    far_m = min(first.window_m[1], second.window_m[1])
    if abs(delta_h_m) >= far_m:
        raise UsageError(f"--delta-h {delta_h_m:g} m: the sonar cannot have moved farther than its range window "
                         f"reaches ({far_m:.2f} m) and seen the seabed from both altitudes ({labels[0]}, {labels[1]})")
    if first.known("altitude_m") and second.known("altitude_m"):
        own, what = second.altitude_m - first.altitude_m, "altitude_m"
    elif first.known("sonar_depth_m") and second.known("sonar_depth_m"):
        own, what = first.sonar_depth_m - second.sonar_depth_m, "sonar_depth_m"
    else:
        own, what = math.nan, ""
    if math.isfinite(own) and abs(delta_h_m - own) > max(DELTA_H_TOLERANCE_M, DELTA_H_TOLERANCE_FRACTION * abs(own)):
        raise UsageError(f"--delta-h {delta_h_m:g} m contradicts the frames' {what} ({labels[0]} to {labels[1]}: "
                         f"{own:+.3f} m); --delta-h is the second altitude minus the first")
    base = altitude_m if altitude_m is not None else first.altitude_m
    if math.isfinite(base) and base + delta_h_m <= 0.0:
        raise UsageError(f"--delta-h {delta_h_m:g} m puts {labels[1]} at {base + delta_h_m:.3f} m altitude, on or "
                         f"below the seabed ({labels[0]} is at {base:.3f} m)")


#: Most cells a map raster may have (each layer float32: 400 MB at this size).
MAX_MAP_CELLS = 1.0e8


class MapExtent:
    """The ground the frames of one map cover, checked as they come (see the module docstring)."""

    def __init__(self, resolution_m: float):
        self.resolution_m = resolution_m
        self._box = [math.inf, -math.inf, math.inf, -math.inf]  # north min/max, east min/max

    def add(self, label: str, frame: SonarFrame) -> None:
        """Take ``frame``'s footprint (its position +- its farthest range) or refuse it."""
        reach = frame.window_m[1]
        box = self._box
        box[0], box[1] = min(box[0], frame.north_m - reach), max(box[1], frame.north_m + reach)
        box[2], box[3] = min(box[2], frame.east_m - reach), max(box[3], frame.east_m + reach)
        rows, cols = (box[1] - box[0]) / self.resolution_m, (box[3] - box[2]) / self.resolution_m
        if rows * cols > MAX_MAP_CELLS:
            raise UsageError(f"{label}: with this frame the map spans {box[1] - box[0]:,.0f} m x "
                             f"{box[3] - box[2]:,.0f} m, {rows * cols:.3g} cells of {self.resolution_m:g} m (more than "
                             f"{MAX_MAP_CELLS:.0e}): check the frames' north_m/east_m (or the navigation CSV), or give "
                             "a coarser --resolution-m")
