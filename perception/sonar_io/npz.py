"""Read and write sonar frames as ``.npz`` files (``frame-format.md``).

One frame per file, or a stacked set with a leading frame axis on every array
(``range_m`` and ``beam_azimuth_deg`` shared (1-D) or per frame (2-D)). Degrees exist only
here, at the file edge; :class:`~perception.sonar_io.frame.SonarFrame` holds radians.
Writes are atomic (temporary file, then rename), so a crash never leaves half a file.
"""

from __future__ import annotations

import math
import os
import zipfile
import zlib
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from perception.atomic_file import atomic_write
from perception.errors import FrameFormatError
from perception.sonar_io.frame import SonarFrame
from perception.sonar_io.sniff import expect_kind
from perception.sonar_io.validate import check_real

REQUIRED_KEYS = ("image", "range_m", "beam_azimuth_deg", "elevation_aperture_deg", "timestamp_s")

#: file key -> (frame field, factor from file unit to SI)
OPTIONAL_KEYS: dict[str, tuple[str, float]] = {
    "sonar_depth_m": ("sonar_depth_m", 1.0),
    "altitude_m": ("altitude_m", 1.0),
    "tilt_deg": ("tilt_rad", math.pi / 180.0),
    "vehicle_pitch_deg": ("vehicle_pitch_rad", math.pi / 180.0),
    "vehicle_roll_deg": ("vehicle_roll_rad", math.pi / 180.0),
    "heading_deg": ("heading_rad", math.pi / 180.0),
    "north_m": ("north_m", 1.0),
    "east_m": ("east_m", 1.0),
    "sound_speed_mps": ("sound_speed_m_s", 1.0),
}


def _load_arrays(path: Path) -> dict[str, np.ndarray]:
    expect_kind(path, "npz")
    # The file is opened here, not by np.load: numpy leaves it open when the zip is broken.
    with open(path, "rb") as handle:
        try:
            archive = np.load(handle, allow_pickle=False)
        except (zipfile.BadZipFile, zlib.error, EOFError, OSError, ValueError, NotImplementedError,
                RuntimeError) as exc:
            raise FrameFormatError(f"not a readable .npz archive ({exc})", path=str(path)) from exc
        with archive:
            return {key: _member(archive, key, path) for key in archive.files}


def _member(archive: Any, key: str, path: Path) -> np.ndarray:
    try:
        return archive[key]
    except ValueError as exc:
        if "allow_pickle" in str(exc):
            raise FrameFormatError("holds Python objects (pickled), not a numeric array", path=str(path),
                                   key=key) from None
        raise FrameFormatError(f"unreadable array ({exc})", path=str(path), key=key) from exc
    except (zipfile.BadZipFile, zlib.error, EOFError, OSError, NotImplementedError, RuntimeError, KeyError,
            MemoryError) as exc:
        raise FrameFormatError(f"unreadable array ({type(exc).__name__}: {exc})", path=str(path), key=key) from exc


def _scalar_series(arrays: dict[str, np.ndarray], key: str, n_frames: int | None, path: str) -> np.ndarray:
    """The values of a scalar key: shape () for one frame, (n_frames,) for a stack."""
    value = np.asarray(arrays[key])
    if not np.issubdtype(value.dtype, np.number):
        raise FrameFormatError(f"must be numeric, got dtype {value.dtype}", path=path, key=key)
    _real(value, key, path)
    expected: tuple[int, ...] = () if n_frames is None else (n_frames,)
    if value.shape != expected:
        raise FrameFormatError(f"must have shape {expected}, got {value.shape}", path=path, key=key)
    return value.astype(np.float64)


def _real(value: np.ndarray, key: str, path: str) -> None:
    try:
        check_real(value, key)
    except FrameFormatError as exc:
        raise FrameFormatError(exc.detail, path=path, key=key) from None


def frames_from_arrays(arrays: dict[str, np.ndarray], *, path: str = "<arrays>") -> list[SonarFrame]:
    """Build frames from the arrays of a frame file (single or stacked).

    Raises
    ------
    FrameFormatError
        Naming ``path`` and the key for any missing, mis-shaped, non-increasing or
        non-finite array.
    """
    for key in REQUIRED_KEYS:
        if key not in arrays:
            raise FrameFormatError("required array is missing", path=path, key=key)
    image = np.asarray(arrays["image"])
    if image.ndim == 2:
        n_frames: int | None = None
    elif image.ndim == 3:
        n_frames = int(image.shape[0])
        if n_frames == 0:
            raise FrameFormatError("stacked file holds no frames", path=path, key="image")
    else:
        raise FrameFormatError(
            f"must be (n_samples, n_beams) or (n_frames, n_samples, n_beams), got shape {image.shape}",
            path=path,
            key="image",
        )

    def axis(key: str) -> np.ndarray:
        value = np.asarray(arrays[key])
        if not np.issubdtype(value.dtype, np.number):
            raise FrameFormatError(f"must be numeric, got dtype {value.dtype}", path=path, key=key)
        _real(value, key, path)
        if value.ndim == 1:
            return np.broadcast_to(value, (n_frames or 1, value.size))
        if value.ndim == 2 and n_frames is not None and value.shape[0] == n_frames:
            return value
        raise FrameFormatError(f"has shape {value.shape}, not 1-D or (n_frames, n)", path=path, key=key)

    ranges = axis("range_m")
    azimuths_deg = axis("beam_azimuth_deg")
    scalars = {key: _scalar_series(arrays, key, n_frames, path) for key in ("elevation_aperture_deg", "timestamp_s")}
    optional = {
        key: _scalar_series(arrays, key, n_frames, path) for key in OPTIONAL_KEYS if key in arrays
    }
    frames = []
    for i in range(n_frames or 1):
        def pick(series: np.ndarray, i: int = i) -> float:
            return float(series if n_frames is None else series[i])

        kwargs: dict[str, Any] = {
            OPTIONAL_KEYS[key][0]: pick(series) * OPTIONAL_KEYS[key][1] for key, series in optional.items()
        }
        try:
            frames.append(
                SonarFrame(
                    image=image if n_frames is None else image[i],
                    range_m=ranges[i],
                    beam_azimuth_rad=np.deg2rad(np.asarray(azimuths_deg[i], dtype=np.float64)),
                    elevation_aperture_rad=math.radians(pick(scalars["elevation_aperture_deg"])),
                    timestamp_s=pick(scalars["timestamp_s"]),
                    **kwargs,
                )
            )
        except FrameFormatError as exc:
            raise FrameFormatError(
                exc.detail, path=path, key=exc.key, frame_index=None if n_frames is None else i
            ) from exc
    return frames


def load_frames(path: str | os.PathLike[str]) -> list[SonarFrame]:
    """Load every frame of a ``.npz`` frame file (one frame or a stacked set).

    Raises
    ------
    FileNotFoundError
        When the file does not exist.
    FrameFormatError
        When the file breaks a rule of ``frame-format.md``; names the file and the key.
    """
    p = Path(path)
    return frames_from_arrays(_load_arrays(p), path=str(p))


def frame_to_arrays(frame: SonarFrame) -> dict[str, np.ndarray]:
    """The arrays of one frame in file form (degrees); unknown optional fields left out."""
    arrays: dict[str, np.ndarray] = {
        "image": np.asarray(frame.image),
        "range_m": np.asarray(frame.range_m, dtype=np.float64),
        "beam_azimuth_deg": np.rad2deg(frame.beam_azimuth_rad),
        "elevation_aperture_deg": np.asarray(math.degrees(frame.elevation_aperture_rad)),
        "timestamp_s": np.asarray(frame.timestamp_s, dtype=np.float64),
    }
    for key, (name, factor) in OPTIONAL_KEYS.items():
        value = getattr(frame, name)
        if not math.isnan(value):
            arrays[key] = np.asarray(value / factor, dtype=np.float64)
    return arrays


def frames_to_arrays(frames: Sequence[SonarFrame]) -> dict[str, np.ndarray]:
    """The arrays of a stacked frame file; shared axes stay 1-D, optional keys NaN-filled."""
    if not frames:
        raise ValueError("no frames to stack")
    first = frames[0]
    for i, frame in enumerate(frames):
        if frame.image.shape != first.image.shape or frame.image.dtype != first.image.dtype:
            raise FrameFormatError(
                f"image {frame.image.shape} {frame.image.dtype} differs from frame 0's "
                f"{first.image.shape} {first.image.dtype}; cannot stack",
                key="image",
                frame_index=i,
            )
    # Axes are shared when every frame has the same ranges and azimuths (the aperture is a
    # per-frame scalar anyway, so it does not decide this).
    shared = all(
        np.array_equal(f.range_m, first.range_m)
        and np.array_equal(f.beam_azimuth_rad, first.beam_azimuth_rad)
        for f in frames
    )
    arrays: dict[str, np.ndarray] = {
        "image": np.stack([f.image for f in frames]),
        "elevation_aperture_deg": np.array([math.degrees(f.elevation_aperture_rad) for f in frames]),
        "timestamp_s": np.array([f.timestamp_s for f in frames]),
    }
    if shared:
        arrays["range_m"] = np.asarray(first.range_m, dtype=np.float64)
        arrays["beam_azimuth_deg"] = np.rad2deg(first.beam_azimuth_rad)
    else:
        arrays["range_m"] = np.stack([f.range_m for f in frames])
        arrays["beam_azimuth_deg"] = np.rad2deg(np.stack([f.beam_azimuth_rad for f in frames]))
    for key, (name, factor) in OPTIONAL_KEYS.items():
        values = np.array([getattr(f, name) for f in frames]) / factor
        if not np.all(np.isnan(values)):
            arrays[key] = values
    return arrays


def _atomic_savez(path: Path, arrays: dict[str, np.ndarray], compressed: bool) -> None:
    save = np.savez_compressed if compressed else np.savez
    atomic_write(path, lambda handle: save(handle, **arrays))  # type: ignore[arg-type]


def save_frame(path: str | os.PathLike[str], frame: SonarFrame, *, compressed: bool = True) -> Path:
    """Write one frame to ``path`` (atomically); returns the path."""
    p = Path(path)
    _atomic_savez(p, frame_to_arrays(frame), compressed)
    return p


def save_frames(
    path: str | os.PathLike[str], frames: Iterable[SonarFrame], *, compressed: bool = True
) -> Path:
    """Write frames as one stacked file (atomically); returns the path."""
    p = Path(path)
    _atomic_savez(p, frames_to_arrays(list(frames)), compressed)
    return p
