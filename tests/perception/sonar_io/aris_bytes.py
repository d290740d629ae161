"""Build ARIS recordings byte for byte, straight from the SDK's documented offsets.

Independent of :mod:`perception.sonar_io.aris.format`: the offsets below are copied by hand from
SoundMetrics/aris-file-sdk ``type-definitions/C/FileHeader.h`` and ``FrameHeader.h`` so
the tests check the reader (and the writer) against the documentation, not against
themselves.
"""

from __future__ import annotations

import math
import struct
from pathlib import Path
from typing import Any

import numpy as np

SIGNATURE = 0x05464444

# FileHeader.h
FILE_OFFSETS = {"Version": 0, "FrameCount": 4, "NumRawBeams": 16, "SamplesPerChannel": 24, "SN": 44, "LargeLens": 452}

# FrameHeader.h: name -> (offset, struct code)
FRAME_OFFSETS: dict[str, tuple[int, str]] = {
    "FrameIndex": (0, "I"),
    "FrameTime": (4, "Q"),
    "Version": (12, "I"),
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
    "SonarPan": (244, "f"),
    "SonarTilt": (248, "f"),
    "SonarRoll": (252, "f"),
    "PingMode": (436, "I"),
    "FrequencyHiLow": (440, "I"),
    "SamplePeriod": (452, "I"),
    "FrameRate": (460, "f"),
    "SoundSpeed": (464, "f"),
    "SamplesPerBeam": (468, "I"),
    "SampleStartDelay": (476, "I"),
    "LargeLens": (480, "I"),
    "TheSystemType": (484, "I"),
    "SonarSerialNumber": (488, "I"),
    "ReorderedSamples": (516, "I"),
}

PING_MODE = {48: 1, 96: 3, 64: 6, 128: 9}


def file_header(n_beams: int, n_samples: int, frame_count: int, **overrides: int) -> bytes:
    """A 1024-byte FileHeader."""
    buf = bytearray(1024)
    values = {
        "Version": SIGNATURE,
        "FrameCount": frame_count,
        "NumRawBeams": n_beams,
        "SamplesPerChannel": n_samples,
        "SN": 77,
        "LargeLens": 0,
    }
    values.update(overrides)
    for name, value in values.items():
        struct.pack_into("<I", buf, FILE_OFFSETS[name], value)
    return bytes(buf)


def frame_header(index: int, n_beams: int, n_samples: int, **overrides: Any) -> bytes:
    """A 1024-byte FrameHeader; defaults: ARIS 3000, 1500 m/s, 2000 us delay, 10 us period."""
    values: dict[str, Any] = {
        "FrameIndex": index,
        "FrameTime": 1_700_000_000_000_000 + index * 100_000,
        "Version": SIGNATURE,
        "PingMode": PING_MODE[n_beams],
        "FrequencyHiLow": 1,
        "SamplePeriod": 10,
        "SoundSpeed": 1500.0,
        "SamplesPerBeam": n_samples,
        "SampleStartDelay": 2000,
        "LargeLens": 0,
        "TheSystemType": 1,
        "SonarSerialNumber": 77,
        "ReorderedSamples": 1,
    }
    values.update(overrides)
    buf = bytearray(1024)
    for name, value in values.items():
        offset, code = FRAME_OFFSETS[name]
        struct.pack_into("<" + code, buf, offset, value)
    return bytes(buf)


def raw_samples(rng: np.random.Generator, n_beams: int, n_samples: int) -> np.ndarray:
    """Random sample block as stored: (SamplesPerBeam, BeamCount) uint8, SDK beam order."""
    return rng.integers(0, 256, size=(n_samples, n_beams), dtype=np.uint8)


def write_recording(
    path: Path,
    raws: list[np.ndarray],
    headers: list[dict[str, Any]] | None = None,
    *,
    file_overrides: dict[str, int] | None = None,
) -> Path:
    """Write FileHeader + (FrameHeader + samples) per frame; returns ``path``."""
    n_samples, n_beams = raws[0].shape
    headers = headers or [{} for _ in raws]
    with open(path, "wb") as handle:
        handle.write(file_header(n_beams, n_samples, len(raws), **(file_overrides or {})))
        for i, (raw, extra) in enumerate(zip(raws, headers, strict=True)):
            handle.write(frame_header(i, n_beams, n_samples, **extra))
            handle.write(np.ascontiguousarray(raw, dtype=np.uint8).tobytes())
    return path


def read_frame_field(data: bytes, frame: int, frame_size: int, name: str) -> Any:
    """A frame header field straight from a file's bytes."""
    offset, code = FRAME_OFFSETS[name]
    (value,) = struct.unpack_from("<" + code, data, 1024 + frame * frame_size + offset)
    return value


def expected_ranges_m(delay_us: float, period_us: float, n: int, speed_m_s: float) -> np.ndarray:
    """Row centres from the SDK formula SampleRange[i] = (delay + i*period)*1e-6*c/2, + half a cell."""
    c = float(np.float32(speed_m_s))
    return np.array([(delay_us + (i + 0.5) * period_us) * 1e-6 * c / 2 for i in range(n)])


NAN = math.nan
