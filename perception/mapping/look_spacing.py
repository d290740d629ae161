"""Which frames the mosaic blends: one per stretch of footprint motion, not every ping.

A forward-looking sonar pinging 10-15 times a second at survey speed sees each seabed cell
in a hundred pings or more (the insonified band's length on the ground over the distance
run per ping), and pings a few centimetres apart see much the same speckle. Projecting
every ping at 1 cm cells was most of the on-board chain's cost on a field survey, where
the band is metres long. So a frame is blended when its footprint has moved by
``1 / looks`` of the band's ground length since the last frame blended: the near and the
far end of the band on the beam axis are compared (on the seabed, local NED), so a turn
in place, a change of tilt or of altitude count as motion as well as running along the
lane. Each cell then still gets about ``looks`` frames.

A blended frame stands for the frames passed over since the previous one (:meth:`offer`
returns their count, the caller multiplies the frame's mosaic weights by it): the cells'
accumulated weights, and the shares of two passes at different altitudes in a cell's
mean, stay what they were with every frame blended. After an interruption (frames the
caller kept out of the mosaic: turns, transits) the count starts again at one.

The height pipeline is not affected: it takes every frame.
"""

from __future__ import annotations

import math

from perception.errors import GeometryError
from perception.geometry.sonar import insonified_band
from perception.sonar_io.frame import SonarFrame


class LookSpacing:
    """Picks the frames to blend (module docstring).

    Parameters
    ----------
    looks : int
        Frames wanted per seabed cell along the track (>= 1).
    """

    def __init__(self, looks: int):
        if int(looks) != looks or looks < 1:
            raise ValueError(f"looks must be a whole number >= 1, got {looks!r}")
        self.looks = int(looks)
        self._last: tuple[float, float, float, float] | None = None  # near and far band points, NED m
        self._passed = 0  # frames offered since the last one blended

    def interrupt(self) -> None:
        """Frames are being kept out of the mosaic: the next offered frame is blended alone."""
        self._last = None
        self._passed = 0

    def offer(self, frame: SonarFrame, *, altitude_m: float) -> int:
        """0: leave ``frame`` out of the mosaic; n >= 1: blend it, standing for n frames
        (itself and those left out since the last one blended).

        A frame whose band cannot be placed (no pose, no seabed in its aperture) is
        blended, counting one: the mosaic decides what to do with it.
        """
        self._passed += 1
        band = _band_points(frame, altitude_m)
        if band is None:
            count, self._passed = self._passed, 0
            return count
        near_n, near_e, far_n, far_e, length_m = band
        if self._last is not None:
            moved = max(math.hypot(near_n - self._last[0], near_e - self._last[1]),
                        math.hypot(far_n - self._last[2], far_e - self._last[3]))
            if moved < length_m / self.looks:
                return 0
        self._last = (near_n, near_e, far_n, far_e)
        count, self._passed = self._passed, 0
        return count


def _band_points(frame: SonarFrame, altitude_m: float) -> tuple[float, float, float, float, float] | None:
    """(north, east) of the band's near and far end on the beam axis, and its ground
    length, m; None when the frame lacks a pose or its aperture holds no seabed."""
    values = (frame.north_m, frame.east_m, frame.heading_rad, frame.tilt_rad, altitude_m)
    if not all(math.isfinite(v) for v in values) or altitude_m <= 0 or frame.range_m.size < 2:
        return None
    pitch = frame.vehicle_pitch_rad if math.isfinite(frame.vehicle_pitch_rad) else 0.0
    try:
        band = insonified_band(altitude_m, depression_rad=frame.tilt_rad - pitch,
                               elevation_aperture_rad=frame.elevation_aperture_rad,
                               window_m=(float(frame.range_m[0]), float(frame.range_m[-1])))
    except GeometryError:
        return None
    near, far = band.near_ground_m, band.far_ground_m
    if not (math.isfinite(far) and far > near):
        return None
    c, s = math.cos(frame.heading_rad), math.sin(frame.heading_rad)
    return (frame.north_m + near * c, frame.east_m + near * s, frame.north_m + far * c, frame.east_m + far * s,
            far - near)
