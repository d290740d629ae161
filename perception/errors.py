"""Exceptions of the perception package.

Every exception subclasses a built-in so callers can catch broadly (``ValueError``) or
narrowly, and carries public attributes that name what was wrong.
"""

from __future__ import annotations


class FrameFormatError(ValueError):
    """A sonar frame file or array violates ``frame-format.md``.

    Attributes
    ----------
    path : str or None
        The file, when the frame came from one.
    key : str or None
        The array key (or header field) that is wrong.
    frame_index : int or None
        The frame, for multi-frame files.
    """

    def __init__(
        self,
        message: str,
        *,
        path: str | None = None,
        key: str | None = None,
        frame_index: int | None = None,
    ):
        parts = []
        if path is not None:
            parts.append(str(path))
        if frame_index is not None:
            parts.append(f"frame {frame_index}")
        if key is not None:
            parts.append(f"key {key!r}")
        prefix = ", ".join(parts)
        super().__init__(f"{prefix}: {message}" if prefix else message)
        self.path = path
        self.key = key
        self.frame_index = frame_index
        self.detail = message


class GeometryError(ValueError):
    """Impossible sonar geometry (negative altitude, a ray that never meets the seabed...)."""


class SolverError(ValueError):
    """The height solver cannot produce an estimate from the given measurements."""


class MeasurementError(ValueError):
    """A sensor measurement is invalid (NaN, negative pressure, non-positive noise...).

    Attributes
    ----------
    sensor : str or None
        The sensor it came from (``"pressure"``, ``"depth"``, ``"altimeter"``, ``"sonar"``).
    value : float or None
        The offending value, when there is one.
    """

    def __init__(self, message: str, *, sensor: str | None = None, value: object = None):
        super().__init__(f"{sensor}: {message}" if sensor else message)
        self.sensor = sensor
        self.value = value


class OutsideWindowError(ValueError):
    """A query time lies outside the altitude filter's retained window.

    Attributes
    ----------
    time_s : float
        The time asked for.
    window_start_s, window_end_s : float
        The times the filter can answer for (NaN when it holds no data yet).
    """

    def __init__(self, time_s: float, window_start_s: float, window_end_s: float):
        super().__init__(
            f"time {time_s!r} s is outside the filtered window "
            f"[{window_start_s!r}, {window_end_s!r}] s"
        )
        self.time_s = time_s
        self.window_start_s = window_start_s
        self.window_end_s = window_end_s


class SeabedNotFoundError(ValueError):
    """No start of the insonified seabed can be found in a sonar frame."""
