"""The sonar frame: one ping of a forward-looking sonar as a polar image.

Conventions (written once here, referred to everywhere else):

- ``image`` has shape (n_samples, n_beams) = (range rows, beam columns); row i is range
  sample i, nearest first; column j is beam j, azimuth increasing with j.
- ``range_m`` is the slant range of each row's centre from the sonar's acoustic centre,
  metres, strictly increasing. The window does not start at zero.
- ``beam_azimuth_rad`` is the azimuth of each beam axis in the sonar frame, radians,
  positive to starboard, strictly increasing.
- ``tilt_rad`` is the mount depression below the vehicle's horizontal, positive down.
- ``vehicle_pitch_rad`` positive nose up, ``vehicle_roll_rad`` positive starboard down,
  ``heading_rad`` clockwise from north (ArduPilot conventions).
- ``north_m``/``east_m`` are the sonar's position in the survey's local NED frame.
- Optional scalars are NaN when the source did not know them.

Inside the package everything is SI and radians; the file form (``frame-format.md``)
stores degrees, converted only in :mod:`perception.sonar_io.npz`.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field, fields, replace
from typing import Any

import numpy as np

from perception.errors import FrameFormatError
from perception.sonar_io.validate import check_pose, check_range_window, check_real

#: dtypes an image may have (frame-format.md).
IMAGE_DTYPES = (np.dtype(np.uint8), np.dtype(np.uint16), np.dtype(np.float32))

#: Optional pose and environment fields, NaN when unknown (SI units, radians).
OPTIONAL_FIELDS = (
    "sonar_depth_m",
    "altitude_m",
    "tilt_rad",
    "vehicle_pitch_rad",
    "vehicle_roll_rad",
    "heading_rad",
    "north_m",
    "east_m",
    "sound_speed_m_s",
)
_POSE_AND_TIME = frozenset(OPTIONAL_FIELDS) | {"timestamp_s"}


def _readonly(array: np.ndarray) -> np.ndarray:
    view = array.view()
    view.flags.writeable = False
    return view


def _check_axis(values: Any, key: str, *, dtype: type = np.float64) -> np.ndarray:
    array: np.ndarray = np.asarray(check_real(np.asarray(values), key), dtype=dtype)
    if array.ndim != 1:
        raise FrameFormatError(f"must be 1-D, got shape {array.shape}", key=key)
    if array.size < 2:
        raise FrameFormatError(f"needs at least 2 entries, got {array.size}", key=key)
    if not np.all(np.isfinite(array)):
        raise FrameFormatError("must be finite everywhere", key=key)
    if not np.all(np.diff(array) > 0):
        raise FrameFormatError("must be strictly increasing", key=key)
    return array


@dataclass(frozen=True, eq=False)
class SonarFrame:
    """One forward-looking-sonar ping, polar.

    Parameters
    ----------
    image : ndarray, shape (n_samples, n_beams), uint8, uint16 or float32
        Echo intensity; rows are range samples (nearest first), columns beams.
    range_m : ndarray, shape (n_samples,), float64
        Slant range of each row's centre from the acoustic centre, m, strictly increasing.
    beam_azimuth_rad : ndarray, shape (n_beams,), float64
        Beam axis azimuths, rad, positive to starboard, strictly increasing.
    elevation_aperture_rad : float
        Full vertical opening of the beams, rad.
    timestamp_s : float
        Ping time, s, any fixed epoch within one set of frames.
    sonar_depth_m, altitude_m, tilt_rad, vehicle_pitch_rad, vehicle_roll_rad,
    heading_rad, north_m, east_m, sound_speed_m_s : float
        Optional pose and environment, NaN when unknown (see module docstring).

    The arrays are stored as read-only views; the caller's arrays are not modified.
    """

    image: np.ndarray
    range_m: np.ndarray
    beam_azimuth_rad: np.ndarray
    elevation_aperture_rad: float
    timestamp_s: float
    sonar_depth_m: float = math.nan
    altitude_m: float = math.nan
    tilt_rad: float = math.nan
    vehicle_pitch_rad: float = math.nan
    vehicle_roll_rad: float = math.nan
    heading_rad: float = math.nan
    north_m: float = math.nan
    east_m: float = math.nan
    sound_speed_m_s: float = math.nan
    extra: dict[str, float] = field(default_factory=dict, compare=False)

    def __post_init__(self) -> None:
        image = np.asarray(self.image)
        if image.ndim != 2:
            raise FrameFormatError(
                f"must be 2-D (n_samples, n_beams), got shape {image.shape}", key="image"
            )
        if image.dtype not in IMAGE_DTYPES:
            raise FrameFormatError(
                f"dtype must be uint8, uint16 or float32, got {image.dtype}", key="image"
            )
        if image.dtype == np.float32 and not np.all(np.isfinite(image)):
            raise FrameFormatError("float32 image must be finite everywhere", key="image")
        range_m = _check_axis(self.range_m, "range_m")
        if range_m[0] < 0:
            raise FrameFormatError(f"slant ranges must be >= 0, first is {range_m[0]}", key="range_m")
        azimuth = _check_axis(self.beam_azimuth_rad, "beam_azimuth_deg")
        if np.any(np.abs(azimuth) >= math.pi / 2):
            raise FrameFormatError("beam azimuths must lie within (-90, 90) deg", key="beam_azimuth_deg")
        if image.shape != (range_m.size, azimuth.size):
            raise FrameFormatError(
                f"shape {image.shape} does not match range_m ({range_m.size}) x "
                f"beam_azimuth_deg ({azimuth.size})",
                key="image",
            )
        aperture = float(self.elevation_aperture_rad)
        if not (math.isfinite(aperture) and 0 < aperture < math.pi):
            raise FrameFormatError(
                f"must be finite and in (0, 180) deg, got {math.degrees(aperture)} deg",
                key="elevation_aperture_deg",
            )
        timestamp = float(self.timestamp_s)
        if not math.isfinite(timestamp):
            raise FrameFormatError("must be finite", key="timestamp_s")
        object.__setattr__(self, "image", _readonly(image))
        object.__setattr__(self, "range_m", _readonly(range_m))
        object.__setattr__(self, "beam_azimuth_rad", _readonly(azimuth))
        object.__setattr__(self, "elevation_aperture_rad", aperture)
        object.__setattr__(self, "timestamp_s", timestamp)
        for name in OPTIONAL_FIELDS:
            value = float(getattr(self, name))
            if math.isinf(value):
                raise FrameFormatError("must be finite or NaN (unknown)", key=name)
            object.__setattr__(self, name, value)
        check_range_window(range_m)  # physically possible values (perception.sonar_io.validate)
        check_pose({"timestamp_s": timestamp, **{name: getattr(self, name) for name in OPTIONAL_FIELDS}})

    @property
    def n_samples(self) -> int:
        """Number of range samples (image rows)."""
        return int(self.image.shape[0])

    @property
    def n_beams(self) -> int:
        """Number of beams (image columns)."""
        return int(self.image.shape[1])

    @property
    def range_resolution_m(self) -> float:
        """Mean spacing of the range samples, m."""
        return float((self.range_m[-1] - self.range_m[0]) / (self.n_samples - 1))

    @property
    def window_m(self) -> tuple[float, float]:
        """(first, last) sample slant range, m."""
        return float(self.range_m[0]), float(self.range_m[-1])

    def known(self, name: str) -> bool:
        """True when the optional field ``name`` is known (not NaN)."""
        if name not in OPTIONAL_FIELDS:
            raise KeyError(f"{name!r} is not an optional frame field")
        return not math.isnan(getattr(self, name))

    def with_fields(self, **changes: Any) -> SonarFrame:
        """A copy with some fields replaced (validated again).

        When only the ping time and pose fields change (what stamping a frame with the
        vehicle's navigation does, several times a ping), the new values get the checks
        ``__post_init__`` gives them and the arrays, checked when this frame was made, are
        shared as they are: the same frame and the same refusals, without re-reading the
        image (about 0.07 ms a frame)."""
        if not changes.keys() <= _POSE_AND_TIME:
            return replace(self, **changes)
        values = {name: float(value) for name, value in changes.items()}
        if not math.isfinite(values.get("timestamp_s", 0.0)):
            raise FrameFormatError("must be finite", key="timestamp_s")
        for name in OPTIONAL_FIELDS:  # in the order __post_init__ checks them
            if math.isinf(values.get(name, 0.0)):
                raise FrameFormatError("must be finite or NaN (unknown)", key=name)
        pose = {"timestamp_s": self.timestamp_s, **{name: getattr(self, name) for name in OPTIONAL_FIELDS}}
        pose.update(values)
        check_pose(pose)
        made = copy.copy(self)
        for name, value in values.items():
            object.__setattr__(made, name, value)
        return made

    def same_geometry(self, other: SonarFrame, *, rtol: float = 1e-9) -> bool:
        """True when both frames share range samples, beam azimuths and aperture."""
        return (
            self.image.shape == other.image.shape
            and np.allclose(self.range_m, other.range_m, rtol=rtol, atol=0)
            and np.allclose(self.beam_azimuth_rad, other.beam_azimuth_rad, rtol=rtol, atol=1e-12)
            and math.isclose(self.elevation_aperture_rad, other.elevation_aperture_rad, rel_tol=rtol)
        )


def frame_field_names() -> tuple[str, ...]:
    """Names of every dataclass field of :class:`SonarFrame`, in order."""
    return tuple(f.name for f in fields(SonarFrame))
