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
