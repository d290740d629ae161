"""Exceptions of the seabed world, scene files and sonar renderer (narrow, built-in bases),
and the world's one check of a number (:func:`finite`).

Kept apart from :mod:`sim_harness.errors` (the vehicle side's) so the two halves of the
simulator can grow independently.
"""

from __future__ import annotations

import math


class SceneError(ValueError):
    """A scene file or scene value is invalid.

    Attributes
    ----------
    path : str or None
        The scene file (or built-in scene name) that holds the error.
    key : str or None
        Dotted path of the offending entry, e.g. ``"targets[2].height_m"``.
    """

    def __init__(self, message: str, *, path: str | None = None, key: str | None = None):
        where = f"{path}: " if path else ""
        what = f"{key}: " if key else ""
        super().__init__(f"{where}{what}{message}")
        self.path = path
        self.key = key


class WorldError(ValueError):
    """A world object (seabed, material, target) was built with invalid values."""

    def __init__(self, message: str, *, key: str | None = None):
        super().__init__(f"{key}: {message}" if key else message)
        self.key = key


class PoseError(ValueError):
    """A sonar pose cannot be rendered (not finite, above the water, under the seabed...).

    ``field`` names the offending pose field when one is to blame.
    """

    def __init__(self, message: str, *, field: str | None = None):
        super().__init__(f"pose.{field}: {message}" if field else f"pose: {message}")
        self.field = field


class SonarConfigError(ValueError):
    """A sonar renderer setting is invalid; ``key`` names the setting."""

    def __init__(self, message: str, *, key: str):
        super().__init__(f"sonar config {key}: {message}")
        self.key = key


def finite(value: float, key: str, *, positive: bool = False, nonneg: bool = False) -> float:
    """``value`` as a float; a :class:`WorldError` naming ``key`` unless finite (and > 0 or >= 0
    when asked)."""
    v = float(value)
    if not math.isfinite(v):
        raise WorldError(f"must be finite, got {value!r}", key=key)
    if positive and v <= 0:
        raise WorldError(f"must be > 0, got {value!r}", key=key)
    if nonneg and v < 0:
        raise WorldError(f"must be >= 0, got {value!r}", key=key)
    return v
