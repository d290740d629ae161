"""Plausibility of sonar frame fields, and of a set of frames as one scene.

The readers and :class:`~perception.sonar_io.frame.SonarFrame` check the form of a frame
(shapes, dtypes, increasing axes); this module checks that its values are physically
possible, so a frame that parses but cannot be true is refused with the key named:

- ranges: the window ends within :data:`MAX_RANGE_M` (a 3,083 km window is a corrupt
  header, not a sonar);
- numbers are real: a complex ``range_m`` is refused, not silently cut to its real part;
- pose: ``altitude_m`` > 0 (the sonar is above the seabed), ``sonar_depth_m`` not above
  the surface (beyond :data:`DEPTH_ABOVE_SURFACE_TOLERANCE_M`), tilt and pitch within
  +-90 deg, roll within +-180 deg, heading within ten turns, north/east within
  :data:`MAX_LOCAL_OFFSET_M` of the origin, sound speed within
  :data:`SOUND_SPEED_LIMITS_M_S`, the timestamp within :data:`MAX_TIMESTAMP_S`.

:func:`check_one_scene` asks that frames meant to show one scene (``heights``, one map of
``mosaic``) agree on the water's sound speed and the seabed's depth (sonar depth plus
altitude), so frames of two different recordings are not mixed silently.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np

from perception.errors import FrameFormatError

#: Farthest slant range any sonar frame may reach, m (forward-looking sonars reach tens
#: of metres, a few hundred at most).
MAX_RANGE_M = 1000.0
#: Plausible sound speed in water, m/s (fresh water near freezing ~1400, warm brine ~1600).
SOUND_SPEED_LIMITS_M_S = (1300.0, 1800.0)
#: A depth sensor at the surface may read a little above it, m.
DEPTH_ABOVE_SURFACE_TOLERANCE_M = 1.0
#: Deepest a sonar can be, m.
MAX_DEPTH_M = 11_000.0
#: Farthest a sonar may be from its survey's local origin, m (north_m, east_m).
MAX_LOCAL_OFFSET_M = 1.0e6
#: Largest heading magnitude, rad (ten turns: an unwrapped compass; beyond that, corrupt).
MAX_HEADING_RAD = 20.0 * math.pi
#: Largest timestamp magnitude, s (Unix time in microseconds read as seconds is beyond it).
MAX_TIMESTAMP_S = 1.0e11
#: Frames of one scene share the water: their sound speeds differ by at most this, m/s.
SOUND_SPEED_TOLERANCE_M_S = 20.0

_HALF_TURN = math.pi
_QUARTER_TURN = math.pi / 2


def check_real(array: np.ndarray, key: str) -> np.ndarray:
    """``array`` if its dtype is a real number type (integer or floating, not bool or complex)."""
    dtype = np.asarray(array).dtype
    if dtype == np.bool_ or not (np.issubdtype(dtype, np.integer) or np.issubdtype(dtype, np.floating)):
        raise FrameFormatError(f"must hold real numbers, got dtype {dtype}", key=key)
    return array


def check_range_window(range_m: np.ndarray) -> None:
    """The window's far end within :data:`MAX_RANGE_M`."""
    far = float(range_m[-1])
    if far > MAX_RANGE_M:
        raise FrameFormatError(f"the range window reaches {far:,.1f} m, beyond the {MAX_RANGE_M:g} m any sonar "
                               "sees (corrupt timing or sound speed?)", key="range_m")


def check_pose(values: Mapping[str, float]) -> None:
    """The optional pose fields of a frame (SI, radians; NaN = unknown) are physically possible.

    Keys are :data:`perception.sonar_io.frame.OPTIONAL_FIELDS`; a message names the file key
    (degrees where the file stores degrees).
    """
    def known(name: str) -> float | None:
        v = values.get(name, math.nan)
        return None if math.isnan(v) else v

    altitude = known("altitude_m")
    if altitude is not None and not 0.0 < altitude <= MAX_RANGE_M:
        raise FrameFormatError(f"must be > 0 (the sonar's height above the seabed) and <= {MAX_RANGE_M:g} m, "
                               f"got {altitude:g}", key="altitude_m")
    depth = known("sonar_depth_m")
    if depth is not None and not -DEPTH_ABOVE_SURFACE_TOLERANCE_M <= depth <= MAX_DEPTH_M:
        raise FrameFormatError(f"must be the depth below the surface, 0..{MAX_DEPTH_M:g} m, got {depth:g}",
                               key="sonar_depth_m")
    for name, key, limit in (("tilt_rad", "tilt_deg", _QUARTER_TURN),
                             ("vehicle_pitch_rad", "vehicle_pitch_deg", _QUARTER_TURN),
                             ("vehicle_roll_rad", "vehicle_roll_deg", _HALF_TURN)):
        angle = known(name)
        if angle is not None and abs(angle) > limit + 1e-9:
            raise FrameFormatError(f"must be within +-{math.degrees(limit):g} deg, got {math.degrees(angle):g}",
                                   key=key)
    for name in ("north_m", "east_m"):
        offset = known(name)
        if offset is not None and abs(offset) > MAX_LOCAL_OFFSET_M:
            raise FrameFormatError(f"must be within +-{MAX_LOCAL_OFFSET_M:g} m of the survey's origin, got {offset:g}",
                                   key=name)
    heading = known("heading_rad")
    if heading is not None and abs(heading) > MAX_HEADING_RAD:
        raise FrameFormatError(f"must be within +-{math.degrees(MAX_HEADING_RAD):g} deg, got "
                               f"{math.degrees(heading):g}", key="heading_deg")
    timestamp = known("timestamp_s")
    if timestamp is not None and abs(timestamp) > MAX_TIMESTAMP_S:
        raise FrameFormatError(f"must be seconds within +-{MAX_TIMESTAMP_S:g}, got {timestamp:g}", key="timestamp_s")
    speed = known("sound_speed_m_s")
    low, high = SOUND_SPEED_LIMITS_M_S
    if speed is not None and not low <= speed <= high:
        raise FrameFormatError(f"must be a sound speed in water, {low:g}..{high:g} m/s, got {speed:g}",
                               key="sound_speed_mps")


def _spread(values: Sequence[tuple[str, float]]) -> tuple[tuple[str, float], tuple[str, float]] | None:
    known = [(label, v) for label, v in values if math.isfinite(v)]
    if len(known) < 2:
        return None
    return min(known, key=lambda x: x[1]), max(known, key=lambda x: x[1])


def check_one_scene(labels: Sequence[str], sound_speeds_m_s: Sequence[float], seabed_depths_m: Sequence[float],
                    *, seabed_tolerance_m: float) -> None:
    """Frames meant as one scene agree on the sound speed and the seabed depth.

    Parameters
    ----------
    labels : sequence of str
        Each frame's name for messages (``file`` or ``file#i``).
    sound_speeds_m_s, seabed_depths_m : sequence of float
        Each frame's sound speed and seabed depth (sonar depth + altitude), NaN when unknown.
    seabed_tolerance_m : float
        Largest spread of the seabed depths allowed.

    Raises
    ------
    FrameFormatError
        Naming the two frames that disagree most and the key.
    """
    speeds = _spread(list(zip(labels, sound_speeds_m_s, strict=True)))
    if speeds is not None and speeds[1][1] - speeds[0][1] > SOUND_SPEED_TOLERANCE_M_S:
        (a, va), (b, vb) = speeds
        raise FrameFormatError(f"{b} has {vb:.1f} m/s, {a} {va:.1f} m/s: frames of one scene share the water "
                               f"(within {SOUND_SPEED_TOLERANCE_M_S:g} m/s): frames of two scenes?",
                               key="sound_speed_mps")
    depths = _spread(list(zip(labels, seabed_depths_m, strict=True)))
    if depths is not None and depths[1][1] - depths[0][1] > seabed_tolerance_m:
        (a, va), (b, vb) = depths
        raise FrameFormatError(f"the seabed lies {vb:.2f} m deep in {b} but {va:.2f} m in {a} (sonar_depth_m + "
                               f"altitude_m; more than {seabed_tolerance_m:g} m apart): frames of two scenes?",
                               key="sonar_depth_m")
