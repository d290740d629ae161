"""The ARIS recording format (``.aris``): layout, header fields, and frames from headers.

Pure functions only; :mod:`perception.sonar_io.aris.reader` reads and writes files with them.

Written from Sound Metrics' public ARIS File SDK (github SoundMetrics/aris-file-sdk, MIT):
``docs/understanding-aris-data.md``, ``type-definitions/C/FileHeader.h``,
``type-definitions/C/FrameHeader.h`` and ``common-code/FrameFuncs.c``.

File layout (all little-endian, packed)::

    FileHeader   1024 bytes at offset 0 (Version = 0x05464444 "DDF\\x05")
    frame 0      FrameHeader (1024 bytes), then SamplesPerBeam * BeamCount uint8 samples
    frame 1      ...

Frame ``i`` starts at ``1024 + i * (1024 + SamplesPerBeam * BeamCount)``; the frame count
comes from the file size, never from ``FileHeader.FrameCount`` (the SDK's advice). The
beam count comes from the frame's ``PingMode`` (1-2: 48, 3-5: 96, 6-8: 64, 9-12: 128).

Sample data, with ``ReorderedSamples`` = 1 (every recording): sample-major, i.e. an array
(SamplesPerBeam, BeamCount) in C order; row 0 is the nearest sample; column k is SDK beam
k, and SDK beam 0 is the right-most (starboard) beam. (FrameHeader.h calls it a
"[beam,sample] array"; the bytes of the SDK's sample.aris settle the order: bytes
``BeamCount`` apart are more alike than neighbouring bytes, and the mean echo falls with
the row index.) The reader reorders the columns so azimuth increases
(:mod:`perception.sonar_io.beams`), giving the (n_samples, n_beams) image of
:mod:`perception.sonar_io.frame`.

Ranges (SDK formulas, with the frame's ``SoundSpeed``, not the header's ``WindowStart``
floats, which assume a nominal sound speed)::

    sample_length_m = SamplePeriod_us * 1e-6 * SoundSpeed / 2
    window start    = SampleStartDelay_us * 1e-6 * SoundSpeed / 2
    window end      = window start + SamplesPerBeam * sample_length_m

The SDK's ``SampleRange[i] = start + i * sample_length_m`` is where sample cell i begins;
:class:`~perception.sonar_io.frame.SonarFrame` wants each row's centre, so
``range_m[i] = start + (i + 0.5) * sample_length_m``. The window edges (start, end) are
what :func:`window_edges_m` and ``describe()`` report.

Pose mapping (header floats, degrees for angles; see :func:`frame_from_header`):

- ``Depth`` (m), ``Altitude`` (m), ``Pitch``, ``Roll``, ``Heading`` (deg) are the
  platform values from a vehicle ("AUV") integration. When the whole group (these five
  plus ``Velocity`` and the three rates) is exactly 0.0 - what the ARIS software records
  with no integration, as in sample.aris - they are unknown (NaN); otherwise each value is
  used as is (NaN stays NaN), except an ``Altitude`` of 0 or less, which is unknown (an
  integration without an altimeter). The header states no units or signs for them: metres and
  degrees are assumed, and pitch and roll are assumed to follow ArduPilot's signs.
- ``heading_rad`` falls back to ``CompassHeading`` (the sonar's own compass) when the
  platform heading is unknown and the compass triple is not all exactly 0.0.
- ``tilt_rad`` comes from ``SonarTilt`` (AR2 rotator tilt output, degrees, positive
  up - it agrees in sign with ``CompassPitch`` in sample.aris), so
  ``tilt_rad = -radians(SonarTilt)``; unknown when NaN or when pan, tilt and roll are
  all exactly 0.0 (no rotator).
- ``sound_speed_m_s`` = ``SoundSpeed``. North/east are not carried by ``.aris``.
- Extras in ``SonarFrame.extra``: ``aris_frame_index``, ``ping_mode``, ``system_type``,
  ``large_lens``, ``frequency_hi``, ``sample_period_s``, ``sample_start_delay_s``,
  ``compass_heading_rad``, ``compass_pitch_rad``, ``compass_roll_rad``,
  ``water_temperature_c``, ``pressure_psi``.

The elevation aperture is not in the file: 14 deg (ARIS 1200/1800/3000 standard lenses)
unless the caller says otherwise; the telephoto lens is narrower in elevation, so pass its
aperture when it matters.
"""

from __future__ import annotations

import math
import struct
from collections.abc import Mapping
from typing import Any

import numpy as np

from perception.sonar_io import validate
from perception.sonar_io.beams import BeamTable, load_beam_table, table_name_for
from perception.sonar_io.frame import SonarFrame

ARIS_SIGNATURE = 0x05464444
FILE_HEADER_SIZE = 1024
FRAME_HEADER_SIZE = 1024
#: Default full elevation opening of ARIS lenses, rad (14 deg).
DEFAULT_ELEVATION_APERTURE_RAD = math.radians(14.0)
#: Plausible sound speed in water, m/s; outside this a header is taken as corrupt (the
#: same limits as every frame's, :mod:`perception.sonar_io.validate`).
SOUND_SPEED_LIMITS_M_S = validate.SOUND_SPEED_LIMITS_M_S

#: FileHeader fields used here: name -> (byte offset, struct format).
FILE_HEADER_FIELDS: dict[str, tuple[int, str]] = {
    "Version": (0, "I"),
    "FrameCount": (4, "I"),
    "FrameRate": (8, "I"),
    "HighResolution": (12, "I"),
    "NumRawBeams": (16, "I"),
    "SampleRate": (20, "f"),
    "SamplesPerChannel": (24, "I"),
    "WindowStart": (32, "f"),
    "WindowLength": (36, "f"),
    "SN": (44, "I"),
    "strDate": (48, "32s"),
    "strHeaderID": (80, "256s"),
    "LargeLens": (452, "I"),
}

#: FrameHeader fields used here: name -> (byte offset, struct format), in offset order.
FRAME_HEADER_FIELDS: dict[str, tuple[int, str]] = {
    "FrameIndex": (0, "I"),
    "FrameTime": (4, "Q"),
    "Version": (12, "I"),
    "sonarTimeStamp": (20, "Q"),
    "WindowStart": (52, "f"),
    "WindowLength": (56, "f"),
    "Velocity": (124, "f"),
    "Depth": (128, "f"),
    "Altitude": (132, "f"),
    "Pitch": (136, "f"),
    "PitchRate": (140, "f"),
    "Roll": (144, "f"),
    "RollRate": (148, "f"),
    "Heading": (152, "f"),
    "HeadingRate": (156, "f"),
    "CompassHeading": (160, "f"),
    "CompassPitch": (164, "f"),
    "CompassRoll": (168, "f"),
    "WaterTemp": (224, "f"),
    "SonarPan": (244, "f"),
    "SonarTilt": (248, "f"),
    "SonarRoll": (252, "f"),
    "SampleRate": (420, "f"),
    "PingMode": (436, "I"),
    "FrequencyHiLow": (440, "I"),
    "PulseWidth": (444, "I"),
    "CyclePeriod": (448, "I"),
    "SamplePeriod": (452, "I"),
    "TransmitEnable": (456, "I"),
    "FrameRate": (460, "f"),
    "SoundSpeed": (464, "f"),
    "SamplesPerBeam": (468, "I"),
    "Enable150V": (472, "I"),
    "SampleStartDelay": (476, "I"),
    "LargeLens": (480, "I"),
    "TheSystemType": (484, "I"),
    "SonarSerialNumber": (488, "I"),
    "ReorderedSamples": (516, "I"),
    "Salinity": (520, "I"),
    "Pressure": (524, "f"),
}

_PLATFORM_GROUP = (
    "Depth",
    "Altitude",
    "Pitch",
    "Roll",
    "Heading",
    "Velocity",
    "PitchRate",
    "RollRate",
    "HeadingRate",
)
_COMPASS_GROUP = ("CompassHeading", "CompassPitch", "CompassRoll")
_ROTATOR_GROUP = ("SonarPan", "SonarTilt", "SonarRoll")

SYSTEM_NAMES = {0: "ARIS 1800", 1: "ARIS 3000", 2: "ARIS 1200"}

Header = Mapping[str, Any]


def beams_from_ping_mode(ping_mode: int) -> int:
    """Beam count of an ARIS ping mode (the SDK's ``get_beams_from_pingmode``).

    Raises
    ------
    ValueError
        For a ping mode outside 1..12.
    """
    for modes, beams in (((1, 2), 48), ((3, 4, 5), 96), ((6, 7, 8), 64), ((9, 10, 11, 12), 128)):
        if ping_mode in modes:
            return beams
    raise ValueError(f"PingMode {ping_mode} is not one of the ARIS ping modes 1..12")


def sample_ranges_m(
    sample_start_delay_us: float, sample_period_us: float, n_samples: int, sound_speed_m_s: float
) -> np.ndarray:
    """Slant range of each sample row's centre, m, shape (n_samples,).

    ``range_m[i] = (SampleStartDelay + (i + 0.5) * SamplePeriod) * 1e-6 * SoundSpeed / 2``
    (the SDK's ``SampleRange[i]`` is the cell's start; this is its centre).
    """
    half_c = 0.5 * float(sound_speed_m_s) * 1e-6
    cells = np.arange(n_samples, dtype=np.float64) + 0.5
    return (float(sample_start_delay_us) + cells * float(sample_period_us)) * half_c


def window_edges_m(header: Header) -> tuple[float, float]:
    """(start, end) of a frame's range window, m, from the SDK formulas."""
    half_c = 0.5 * float(header["SoundSpeed"]) * 1e-6
    start = header["SampleStartDelay"] * half_c
    return start, start + header["SamplesPerBeam"] * header["SamplePeriod"] * half_c


def beam_table_for(header: Header) -> BeamTable:
    """The SDK's beam table for a frame header (system type, ping mode, lens)."""
    n_beams = beams_from_ping_mode(int(header["PingMode"]))
    return load_beam_table(
        table_name_for(int(header["TheSystemType"]), n_beams, telephoto=bool(header["LargeLens"]))
    )


def describe_sonar(header: Header) -> str:
    """Human-readable sonar model of a frame header, e.g. ``"ARIS 3000 (serial 1234)"``."""
    name = SYSTEM_NAMES.get(int(header["TheSystemType"]), f"ARIS type {header['TheSystemType']}")
    lens = ", telephoto lens" if header["LargeLens"] else ""
    return f"{name}{lens}, serial {header['SonarSerialNumber']}"


def unpack_fields(
    buffer: Any, offset: int, fields: Mapping[str, tuple[int, str]], available: int
) -> tuple[dict[str, Any], str | None]:
    """Unpack header fields from ``buffer`` at ``offset``.

    Only the first ``available`` bytes of the header exist. Returns the fields that could be
    read and the name of the first field cut off by the end of the data (None if none was).
    """
    values: dict[str, Any] = {}
    for name, (field_offset, fmt) in fields.items():
        end = field_offset + struct.calcsize("<" + fmt)
        if end > available:
            return values, name
        (values[name],) = struct.unpack_from("<" + fmt, buffer, offset + field_offset)
    return values, None


def _deg_to_rad(value: float) -> float:
    return math.radians(value) if math.isfinite(value) else math.nan


def _group_unknown(header: Header, names: tuple[str, ...]) -> bool:
    return all(header[name] == 0.0 for name in names)


def pose_from_header(header: Header) -> dict[str, float]:
    """The optional :class:`SonarFrame` pose fields a frame header carries (SI, rad).

    See the module docstring for the mapping and the unknown (NaN) rules.
    """
    pose = dict.fromkeys(
        (
            "sonar_depth_m",
            "altitude_m",
            "vehicle_pitch_rad",
            "vehicle_roll_rad",
            "heading_rad",
            "tilt_rad",
        ),
        math.nan,
    )
    if not _group_unknown(header, _PLATFORM_GROUP):
        pose["sonar_depth_m"] = float(header["Depth"])
        # An integration without an altimeter records 0: no sonar sits on the seabed.
        pose["altitude_m"] = float(header["Altitude"]) if header["Altitude"] > 0.0 else math.nan
        pose["vehicle_pitch_rad"] = _deg_to_rad(header["Pitch"])
        pose["vehicle_roll_rad"] = _deg_to_rad(header["Roll"])
        pose["heading_rad"] = _deg_to_rad(header["Heading"])
    if math.isnan(pose["heading_rad"]) and not _group_unknown(header, _COMPASS_GROUP):
        pose["heading_rad"] = _deg_to_rad(header["CompassHeading"])
    if not math.isnan(pose["heading_rad"]):
        pose["heading_rad"] %= 2.0 * math.pi
    if not _group_unknown(header, _ROTATOR_GROUP):
        pose["tilt_rad"] = -_deg_to_rad(header["SonarTilt"])
    for key, value in pose.items():
        if math.isinf(value):
            pose[key] = math.nan
    return pose


def _extras(header: Header) -> dict[str, float]:
    return {
        "aris_frame_index": float(header["FrameIndex"]),
        "ping_mode": float(header["PingMode"]),
        "system_type": float(header["TheSystemType"]),
        "large_lens": float(header["LargeLens"]),
        "frequency_hi": float(header["FrequencyHiLow"]),
        "sample_period_s": header["SamplePeriod"] * 1e-6,
        "sample_start_delay_s": header["SampleStartDelay"] * 1e-6,
        "compass_heading_rad": _deg_to_rad(header["CompassHeading"]),
        "compass_pitch_rad": _deg_to_rad(header["CompassPitch"]),
        "compass_roll_rad": _deg_to_rad(header["CompassRoll"]),
        "water_temperature_c": float(header["WaterTemp"]),
        "pressure_psi": float(header["Pressure"]),
    }


def _columns_in_azimuth_order(raw: np.ndarray, table: BeamTable) -> np.ndarray:
    """A copy of ``raw`` (SDK beam order) with columns in azimuth order."""
    n = table.n_beams
    if table.sdk_beam[0] == n - 1 and np.array_equal(table.sdk_beam, np.arange(n - 1, -1, -1)):
        return np.fliplr(raw).copy()  # every shipped table: beam 0 right-most; 3x faster
    return raw[:, table.sdk_beam]


def frame_from_header(
    header: Header,
    samples: np.ndarray,
    *,
    elevation_aperture_rad: float = DEFAULT_ELEVATION_APERTURE_RAD,
) -> SonarFrame:
    """Build a :class:`SonarFrame` from a parsed frame header and its raw samples.

    Parameters
    ----------
    header : mapping
        Frame header fields by SDK name (see :data:`FRAME_HEADER_FIELDS`).
    samples : ndarray, shape (SamplesPerBeam * BeamCount,), uint8
        The frame's sample bytes as stored (sample-major, SDK beam order).
    elevation_aperture_rad : float
        Full elevation opening of the lens, rad.
    """
    table = beam_table_for(header)
    raw = np.asarray(samples, dtype=np.uint8).reshape(int(header["SamplesPerBeam"]), table.n_beams)
    return SonarFrame(
        image=_columns_in_azimuth_order(raw, table),
        range_m=sample_ranges_m(
            header["SampleStartDelay"],
            header["SamplePeriod"],
            int(header["SamplesPerBeam"]),
            header["SoundSpeed"],
        ),
        beam_azimuth_rad=table.azimuth_rad,
        elevation_aperture_rad=elevation_aperture_rad,
        timestamp_s=header["FrameTime"] * 1e-6,
        sound_speed_m_s=float(header["SoundSpeed"]),
        extra=_extras(header),
        **pose_from_header(header),
    )
