"""Open a sonar recording of any supported format as a sequence of frames.

``open_recording(path)`` picks the reader by suffix (``.aris``, ``.npz``) and returns a
:class:`Recording`: ``len(rec)``, ``rec[i]`` (negative indices too), ``rec[a:b]`` (a list),
iteration, :meth:`Recording.describe` and :meth:`Recording.close` (or ``with``).
``.aris`` recordings are read lazily (memory map, one frame per access); ``.npz`` frame
files (``frame-format.md``) are small and are loaded when opened.
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterator, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, Protocol, overload

import numpy as np

from perception.errors import FrameFormatError
from perception.sonar_io.aris.reader import ArisRecording, describe_sonar, pose_from_header, window_edges_m
from perception.sonar_io.frame import OPTIONAL_FIELDS, SonarFrame
from perception.sonar_io.npz import load_frames

#: Suffix (lower case) -> format name.
FORMATS = {".aris": "aris", ".npz": "npz"}
#: ``describe()`` looks at no more than this many frame headers (evenly spaced) for pose fields.
DESCRIBE_MAX_FRAMES = 64


@dataclass(frozen=True)
class RecordingInfo:
    """What a recording holds (the ``shadowsurvey info`` summary).

    Attributes
    ----------
    path, format : str
        The file and its format (``"aris"`` or ``"npz"``).
    sonar : str
        Sonar model as far as the file says (``"unknown"`` for ``.npz``).
    n_frames : int
        Complete frames.
    n_beams, n_samples : int or None
        Image columns and rows of frame 0 (None without frames).
    image_dtype : str or None
        dtype of frame 0's image.
    range_window_m : (float, float) or None
        Slant range of the first and last row centres of frame 0, m.
    acquisition_window_m : (float, float) or None
        ``.aris`` only: the window's edges from the SDK formulas, m.
    beam_azimuth_rad : (float, float) or None
        Azimuth of the first and last beam axes of frame 0, rad, positive to starboard.
    elevation_aperture_rad, sound_speed_m_s : float
        From frame 0 (NaN when unknown).
    time_span_s : (float, float) or None
        Timestamps of the first and last frame, s.
    frame_rate_hz : float
        (n_frames - 1) / duration; NaN with fewer than 2 frames or no elapsed time.
    pose_fields : tuple of str
        Optional :class:`SonarFrame` fields known (not NaN) in at least one frame looked at.
    frames_examined : int
        How many frames (or frame headers) ``pose_fields`` rests on.
    truncation : str or None
        What a partial trailing frame lacks (names the frame and the field).
    problems : tuple of str
        Corrupt frames met while describing (each names the frame and the field).
    """

    path: str
    format: str
    sonar: str
    n_frames: int
    n_beams: int | None
    n_samples: int | None
    image_dtype: str | None
    range_window_m: tuple[float, float] | None
    acquisition_window_m: tuple[float, float] | None
    beam_azimuth_rad: tuple[float, float] | None
    elevation_aperture_rad: float
    sound_speed_m_s: float
    time_span_s: tuple[float, float] | None
    frame_rate_hz: float
    pose_fields: tuple[str, ...]
    frames_examined: int
    truncation: str | None = None
    problems: tuple[str, ...] = ()

    @property
    def duration_s(self) -> float:
        """Time from the first to the last frame, s (NaN without frames)."""
        if self.time_span_s is None:
            return math.nan
        return self.time_span_s[1] - self.time_span_s[0]

    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready dict (tuples as lists, NaN as None)."""

        def clean(value: Any) -> Any:
            if isinstance(value, float) and math.isnan(value):
                return None
            if isinstance(value, (tuple, list)):
                return [clean(v) for v in value]
            return value

        out = {key: clean(value) for key, value in asdict(self).items()}
        out["duration_s"] = clean(self.duration_s)
        return out


def _frame_rate_hz(n_frames: int, time_span_s: tuple[float, float] | None) -> float:
    if time_span_s is None or n_frames < 2 or time_span_s[1] <= time_span_s[0]:
        return math.nan
    return (n_frames - 1) / (time_span_s[1] - time_span_s[0])


def _sample_indices(n_frames: int) -> list[int]:
    if n_frames <= DESCRIBE_MAX_FRAMES:
        return list(range(n_frames))
    return sorted({int(round(x)) for x in np.linspace(0, n_frames - 1, DESCRIBE_MAX_FRAMES)})


class _Source(Protocol):
    def __len__(self) -> int: ...

    def __getitem__(self, index: int) -> SonarFrame: ...


class Recording(Sequence[SonarFrame]):
    """Frames of one recording, read on demand; see :func:`open_recording`.

    Attributes
    ----------
    path : Path
        The file.
    format : str
        ``"aris"`` or ``"npz"``.
    """

    def __init__(self, path: Path, fmt: str, source: _Source):
        self.path = path
        self.format = fmt
        self._source = source

    def __len__(self) -> int:
        return len(self._source)

    @overload
    def __getitem__(self, index: int) -> SonarFrame: ...

    @overload
    def __getitem__(self, index: slice) -> list[SonarFrame]: ...

    def __getitem__(self, index: int | slice) -> SonarFrame | list[SonarFrame]:
        if isinstance(index, slice):
            return [self._source[i] for i in range(len(self))[index]]
        n = len(self)
        i = int(index) + n if int(index) < 0 else int(index)
        if not 0 <= i < n:
            raise IndexError(f"{self.path}: frame {index} out of range for {n} frames")
        return self._source[i]

    def __iter__(self) -> Iterator[SonarFrame]:
        for i in range(len(self)):
            yield self._source[i]

    @property
    def truncation(self) -> str | None:
        """What a partial trailing frame lacks, or None (``.aris`` only)."""
        if isinstance(self._source, ArisRecording):
            return self._source.truncation
        return None

    def describe(self) -> RecordingInfo:
        """Summarise the recording (reads at most :data:`DESCRIBE_MAX_FRAMES` frame headers)."""
        if isinstance(self._source, ArisRecording):
            return _describe_aris(self.path, self._source)
        return _describe_frames(self.path, self.format, self)

    def close(self) -> None:
        """Release the file (``.aris``); frames already read stay valid."""
        if isinstance(self._source, ArisRecording):
            self._source.close()

    def __enter__(self) -> Recording:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"Recording({str(self.path)!r}, format={self.format!r}, n_frames={len(self)})"


def _frame0_fields(frame: SonarFrame | None) -> dict[str, Any]:
    if frame is None:
        return {
            "n_beams": None,
            "n_samples": None,
            "image_dtype": None,
            "range_window_m": None,
            "beam_azimuth_rad": None,
            "elevation_aperture_rad": math.nan,
            "sound_speed_m_s": math.nan,
        }
    return {
        "n_beams": frame.n_beams,
        "n_samples": frame.n_samples,
        "image_dtype": str(frame.image.dtype),
        "range_window_m": frame.window_m,
        "beam_azimuth_rad": (float(frame.beam_azimuth_rad[0]), float(frame.beam_azimuth_rad[-1])),
        "elevation_aperture_rad": frame.elevation_aperture_rad,
        "sound_speed_m_s": frame.sound_speed_m_s,
    }


def _describe_frames(path: Path, fmt: str, frames: Sequence[SonarFrame]) -> RecordingInfo:
    n = len(frames)
    first = frames[0] if n else None
    span = (frames[0].timestamp_s, frames[n - 1].timestamp_s) if n else None
    known = {name for f in frames for name in OPTIONAL_FIELDS if f.known(name)}
    return RecordingInfo(
        path=str(path),
        format=fmt,
        sonar="unknown",
        n_frames=n,
        acquisition_window_m=None,
        time_span_s=span,
        frame_rate_hz=_frame_rate_hz(n, span),
        pose_fields=tuple(name for name in OPTIONAL_FIELDS if name in known),
        frames_examined=n,
        **_frame0_fields(first),
    )


def _describe_aris(path: Path, rec: ArisRecording) -> RecordingInfo:
    n = len(rec)
    problems: list[str] = []
    headers: dict[int, dict[str, Any]] = {}
    for i in _sample_indices(n):
        try:
            headers[i] = rec.header(i)
        except FrameFormatError as exc:
            problems.append(str(exc))
    first = None
    if 0 in headers:
        try:
            first = rec[0]
        except FrameFormatError as exc:
            problems.append(str(exc))
    known = {
        name
        for h in headers.values()
        for name, v in pose_from_header(h).items()
        if not math.isnan(v)
    }
    known |= {"sound_speed_m_s"} if headers else set()
    span = None
    if 0 in headers and n - 1 in headers:
        span = (headers[0]["FrameTime"] * 1e-6, headers[n - 1]["FrameTime"] * 1e-6)
    return RecordingInfo(
        path=str(path),
        format="aris",
        sonar=describe_sonar(headers[0]) if 0 in headers else "ARIS (no readable frame)",
        n_frames=n,
        acquisition_window_m=window_edges_m(headers[0]) if 0 in headers else None,
        time_span_s=span,
        frame_rate_hz=_frame_rate_hz(n, span),
        pose_fields=tuple(name for name in OPTIONAL_FIELDS if name in known),
        frames_examined=len(headers),
        truncation=rec.truncation,
        problems=tuple(problems),
        **_frame0_fields(first),
    )


def open_recording(
    path: str | os.PathLike[str], *, elevation_aperture_rad: float | None = None
) -> Recording:
    """Open a sonar recording (``.aris`` or ``.npz``) as a :class:`Recording`.

    Parameters
    ----------
    path : path-like
        The file; its suffix (any case) picks the reader.
    elevation_aperture_rad : float, optional
        ``.aris`` only: the lens's full elevation opening, rad (the file does not say;
        default 14 deg).

    Raises
    ------
    FileNotFoundError
        When the file does not exist.
    FrameFormatError
        For an unknown suffix, or a file that breaks its format (names file and key).
    """
    p = Path(path)
    fmt = FORMATS.get(p.suffix.lower())
    if fmt is None:
        raise FrameFormatError(
            f"unknown recording type {p.suffix!r}; expected one of {', '.join(FORMATS)}",
            path=str(p),
        )
    if not p.exists():
        raise FileNotFoundError(f"{p}: no such file")
    if fmt == "aris":
        kwargs = (
            {}
            if elevation_aperture_rad is None
            else {"elevation_aperture_rad": elevation_aperture_rad}
        )
        return Recording(p, fmt, ArisRecording(p, **kwargs))
    frames = load_frames(p)
    if elevation_aperture_rad is not None:
        frames = [f.with_fields(elevation_aperture_rad=elevation_aperture_rad) for f in frames]
    return Recording(p, fmt, frames)
