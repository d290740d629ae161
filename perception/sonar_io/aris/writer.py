"""Write frames as a Sound Metrics ARIS recording (``.aris``).

The layout and field meanings are in :mod:`perception.sonar_io.aris.format`; use this through
:mod:`perception.sonar_io.aris.reader` (``write_aris``, ``aris_grid``), which re-exports it.
"""

from __future__ import annotations

import datetime as dt
import math
import os
import struct
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from perception.atomic_file import atomic_write
from perception.errors import FrameFormatError
from perception.sonar_io.aris.format import (
    ARIS_SIGNATURE,
    FILE_HEADER_FIELDS,
    FILE_HEADER_SIZE,
    FRAME_HEADER_FIELDS,
    FRAME_HEADER_SIZE,
    SOUND_SPEED_LIMITS_M_S,
    sample_ranges_m,
    window_edges_m,
)
from perception.sonar_io.beams import load_beam_table, table_name_for
from perception.sonar_io.frame import SonarFrame

#: Ping mode the writer records for each beam count (the first mode of each family).
PING_MODE_FOR_BEAMS = {48: 1, 96: 3, 64: 6, 128: 9}
_UINT32_MAX = 2**32 - 1


def aris_grid(
    window_start_m: float, window_end_m: float, n_samples: int, sound_speed_m_s: float
) -> tuple[int, int, np.ndarray]:
    """The ARIS range grid nearest a wanted window (whole-microsecond timing).

    ARIS stores the window as whole microseconds (SampleStartDelay, SamplePeriod) and the
    sound speed as float32, so only some sample ranges can be written; build frames on this
    grid to write them with :func:`write_aris`.

    Returns
    -------
    sample_start_delay_us, sample_period_us : int
    range_m : ndarray, shape (n_samples,), float64
        Row-centre slant ranges, m, as the reader will compute them.
    """
    if n_samples < 2:
        raise ValueError(f"n_samples must be >= 2, got {n_samples}")
    speed = float(np.float32(sound_speed_m_s))
    if not (math.isfinite(speed) and speed > 0):
        raise ValueError(f"sound_speed_m_s must be finite and positive, got {sound_speed_m_s}")
    if not (0 <= window_start_m < window_end_m):
        raise ValueError(f"need 0 <= window_start_m < window_end_m, got {window_start_m}, {window_end_m}")
    half_c = 0.5 * speed * 1e-6
    period_us = max(1, round((window_end_m - window_start_m) / n_samples / half_c))
    delay_us = round(window_start_m / half_c)
    return delay_us, period_us, sample_ranges_m(delay_us, period_us, n_samples, speed)


def _pack(buffer: bytearray, fields: dict[str, tuple[int, str]], values: dict[str, Any]) -> None:
    for name, value in values.items():
        offset, fmt = fields[name]
        struct.pack_into("<" + fmt, buffer, offset, value)


def _deg(value_rad: float) -> float:
    return math.degrees(value_rad) if math.isfinite(value_rad) else math.nan


@dataclass(frozen=True)
class _Timing:
    sample_start_delay_us: int
    sample_period_us: int
    sound_speed_m_s: float


def _timing_of(frame: SonarFrame, index: int, sound_speed_m_s: float | None) -> _Timing:
    """Whole-microsecond timing that reproduces ``frame.range_m``, or FrameFormatError."""
    speed = frame.sound_speed_m_s if frame.known("sound_speed_m_s") else sound_speed_m_s
    if speed is None or not math.isfinite(speed):
        raise FrameFormatError(
            "sound speed unknown; .aris needs it (set the frame's or pass sound_speed_m_s)",
            key="sound_speed_mps",
            frame_index=index,
        )
    speed32 = float(np.float32(speed))
    low, high = SOUND_SPEED_LIMITS_M_S
    if not low <= speed32 <= high:
        raise FrameFormatError(f"{speed} m/s outside [{low}, {high}]", key="sound_speed_mps", frame_index=index)
    half_c = 0.5 * speed32 * 1e-6
    ranges = frame.range_m
    period_us = round(float(ranges[-1] - ranges[0]) / (frame.n_samples - 1) / half_c)
    delay_us = round(float(ranges[0]) / half_c - 0.5 * period_us)
    expected = sample_ranges_m(delay_us, period_us, frame.n_samples, speed32)
    tolerance_m = 1e-3 * max(period_us, 1) * half_c
    if not (1 <= period_us <= _UINT32_MAX and 0 <= delay_us <= _UINT32_MAX) or not np.allclose(
        ranges, expected, rtol=0, atol=tolerance_m
    ):
        raise FrameFormatError(
            "range_m is not an ARIS grid (whole-microsecond SampleStartDelay and SamplePeriod "
            f"at {speed32} m/s); build it with perception.sonar_io.aris.reader.aris_grid",
            key="range_m",
            frame_index=index,
        )
    return _Timing(int(delay_us), int(period_us), speed32)


def _frame_header_bytes(
    frame: SonarFrame, index: int, timing: _Timing, frame_rate_hz: float, constants: dict[str, Any]
) -> bytes:
    frame_time_us = round(frame.timestamp_s * 1e6)
    if not 0 <= frame_time_us < 2**64:
        raise FrameFormatError(
            f"{frame.timestamp_s} s cannot be stored as microseconds since 1970",
            key="timestamp_s",
            frame_index=index,
        )
    extra = frame.extra
    values: dict[str, Any] = dict(constants)
    values.update(
        FrameIndex=index,
        FrameTime=frame_time_us,
        Version=ARIS_SIGNATURE,
        sonarTimeStamp=frame_time_us,
        Velocity=math.nan,
        Depth=frame.sonar_depth_m,
        Altitude=frame.altitude_m,
        Pitch=_deg(frame.vehicle_pitch_rad),
        PitchRate=math.nan,
        Roll=_deg(frame.vehicle_roll_rad),
        RollRate=math.nan,
        Heading=_deg(frame.heading_rad),
        HeadingRate=math.nan,
        CompassHeading=_deg(extra.get("compass_heading_rad", math.nan)),
        CompassPitch=_deg(extra.get("compass_pitch_rad", math.nan)),
        CompassRoll=_deg(extra.get("compass_roll_rad", math.nan)),
        WaterTemp=extra.get("water_temperature_c", math.nan),
        SonarPan=math.nan,
        SonarTilt=-_deg(frame.tilt_rad),
        SonarRoll=math.nan,
        SampleRate=1e6 / timing.sample_period_us,
        SamplePeriod=timing.sample_period_us,
        FrameRate=frame_rate_hz,
        SoundSpeed=timing.sound_speed_m_s,
        SamplesPerBeam=frame.n_samples,
        SampleStartDelay=timing.sample_start_delay_us,
        Pressure=extra.get("pressure_psi", math.nan),
    )
    header = {
        "SoundSpeed": timing.sound_speed_m_s,
        "SamplesPerBeam": frame.n_samples,
        "SampleStartDelay": timing.sample_start_delay_us,
        "SamplePeriod": timing.sample_period_us,
    }
    values["WindowStart"], end = window_edges_m(header)
    values["WindowLength"] = end - values["WindowStart"]
    buffer = bytearray(FRAME_HEADER_SIZE)
    _pack(buffer, FRAME_HEADER_FIELDS, values)
    return bytes(buffer)


def write_aris(
    path: str | os.PathLike[str],
    frames: Iterable[SonarFrame],
    *,
    system_type: int = 1,
    telephoto: bool = False,
    sound_speed_m_s: float | None = None,
    serial_number: int = 0,
    frequency_hi: bool = True,
    header_id: str = "shadowsurvey",
) -> Path:
    """Write frames as an ARIS recording (atomically: temporary file, then rename).

    Parameters
    ----------
    path : path-like
        Output ``.aris`` file.
    frames : iterable of SonarFrame
        uint8 images of one shape (n_samples, n_beams) with n_beams in 48/64/96/128; beam
        azimuths must be the SDK table of (``system_type``, n_beams, ``telephoto``) and
        ``range_m`` an ARIS grid (see :func:`aris_grid`); timestamps >= 0 (s since 1970).
        Known pose fields are written to the header as the reader maps them back
        (north/east are dropped: ``.aris`` has no field for them).
    system_type : int
        FileHeader/FrameHeader ``TheSystemType``: 1 = ARIS 3000, 0 = ARIS 1800, 2 = ARIS 1200.
    telephoto : bool
        Whether a telephoto lens is recorded (``LargeLens``).
    sound_speed_m_s : float, optional
        Used for frames whose ``sound_speed_m_s`` is unknown.

    Returns
    -------
    Path
        The written file.

    Raises
    ------
    FrameFormatError
        For a frame the format cannot hold (names the frame and the key); nothing is written.
    ValueError
        When ``frames`` is empty.
    """
    p = Path(path)

    def write(handle: Any) -> None:
        count = _write_frames(
            handle,
            frames,
            system_type=system_type,
            telephoto=telephoto,
            sound_speed_m_s=sound_speed_m_s,
            serial_number=serial_number,
            frequency_hi=frequency_hi,
            header_id=header_id,
        )
        if count == 0:
            raise ValueError("no frames to write")

    atomic_write(p, write)
    return p


def _write_frames(
    handle: Any,
    frames: Iterable[SonarFrame],
    *,
    system_type: int,
    telephoto: bool,
    sound_speed_m_s: float | None,
    serial_number: int,
    frequency_hi: bool,
    header_id: str,
) -> int:
    handle.write(bytes(FILE_HEADER_SIZE))
    first: SonarFrame | None = None
    first_timing: _Timing | None = None
    previous_time_s = math.nan
    count = 0
    sdk_beam = np.empty(0, dtype=np.intp)
    constants: dict[str, Any] = {}
    for index, frame in enumerate(frames):
        if frame.image.dtype != np.uint8:
            raise FrameFormatError(f".aris samples are uint8; got {frame.image.dtype}", key="image", frame_index=index)
        if first is None:
            try:
                table = load_beam_table(table_name_for(system_type, frame.n_beams, telephoto=telephoto))
            except ValueError as exc:
                raise FrameFormatError(str(exc), key="image", frame_index=index) from None
            sdk_beam = np.asarray(table.sdk_beam)
            if not np.allclose(frame.beam_azimuth_rad, table.azimuth_rad, rtol=0, atol=1e-9):
                raise FrameFormatError(
                    f"beam azimuths are not the SDK's {table.name} table",
                    key="beam_azimuth_deg",
                    frame_index=index,
                )
            first = frame
            constants = {
                "PingMode": PING_MODE_FOR_BEAMS[frame.n_beams],
                "FrequencyHiLow": int(frequency_hi),
                "TransmitEnable": 1,
                "Enable150V": 1,
                "LargeLens": int(telephoto),
                "TheSystemType": system_type,
                "SonarSerialNumber": serial_number,
                "ReorderedSamples": 1,
            }
        elif frame.image.shape != first.image.shape or not np.array_equal(
            frame.beam_azimuth_rad, first.beam_azimuth_rad
        ):
            raise FrameFormatError(
                f"image {frame.image.shape} or beam azimuths differ from frame 0's "
                f"{first.image.shape}; one .aris file holds one geometry",
                key="image",
                frame_index=index,
            )
        timing = _timing_of(frame, index, sound_speed_m_s)
        first_timing = first_timing or timing
        rate = 1.0 / (frame.timestamp_s - previous_time_s) if frame.timestamp_s > previous_time_s else 0.0
        previous_time_s = frame.timestamp_s
        handle.write(_frame_header_bytes(frame, index, timing, rate, constants))
        raw = np.empty(frame.image.shape, dtype=np.uint8)
        raw[:, sdk_beam] = frame.image
        handle.write(raw.tobytes())
        count += 1
    if first is None or first_timing is None:
        return 0
    handle.seek(0)
    handle.write(_file_header_bytes(first, first_timing, count, constants, header_id))
    return count


def _file_header_bytes(
    first: SonarFrame, timing: _Timing, count: int, constants: dict[str, Any], header_id: str
) -> bytes:
    start, end = window_edges_m(
        {
            "SoundSpeed": timing.sound_speed_m_s,
            "SamplesPerBeam": first.n_samples,
            "SampleStartDelay": timing.sample_start_delay_us,
            "SamplePeriod": timing.sample_period_us,
        }
    )
    date = dt.datetime.fromtimestamp(first.timestamp_s, tz=dt.UTC).strftime("%Y-%m-%d %H:%M:%S")
    buffer = bytearray(FILE_HEADER_SIZE)
    _pack(
        buffer,
        FILE_HEADER_FIELDS,
        {
            "Version": ARIS_SIGNATURE,
            "FrameCount": min(count, _UINT32_MAX),
            "HighResolution": constants["FrequencyHiLow"],
            "NumRawBeams": first.n_beams,
            "SampleRate": 1e6 / timing.sample_period_us,
            "SamplesPerChannel": first.n_samples,
            "WindowStart": start,
            "WindowLength": end - start,
            "SN": constants["SonarSerialNumber"],
            "strDate": date.encode("ascii"),
            "strHeaderID": header_id.encode("utf-8")[:255],
            "LargeLens": constants["LargeLens"],
        },
    )
    return bytes(buffer)
