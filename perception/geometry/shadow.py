"""The relation everything rests on: a target's top edge and its shadow's end share one ray.

For a sonar at height ``H`` above a flat seabed and a target of height ``h`` whose top
edge is at slant range ``r_top``, the ray through that edge meets the seabed at

    r_end = r_top * H / (H - h)

whatever the sonar's tilt, pitch or roll (similar triangles along one ray); so
``h = H * (r_end - r_top) / r_end``. On a sloped seabed the same holds with ``H`` and
``h`` measured perpendicular to the seabed plane. These functions are the one place the
relation is written; they take floats, numpy arrays or casadi expressions alike (only
arithmetic), except :func:`clamp_height_m`, which is numpy's.
"""

from __future__ import annotations

from typing import Any

import numpy as np

#: A target's height is taken at most this fraction of the sonar's altitude: at the
#: altitude itself the shadow would reach the horizon (``r_end`` infinite). Used where a
#: height prior or an estimate enters the relation (the planner, the pitch loop).
MAX_HEIGHT_OVER_ALTITUDE = 0.95


def shadow_end_slant_m(top_slant_m: Any, altitude_m: Any, height_m: Any) -> Any:
    """Slant range where the shadow of a top edge at ``top_slant_m`` ends, m (``h < H``)."""
    return top_slant_m * altitude_m / (altitude_m - height_m)


def shadow_scale(altitude_m: Any, height_m: Any) -> Any:
    """``r_end / r_top = H / (H - h)``: how much farther the shadow ends than the top edge."""
    return altitude_m / (altitude_m - height_m)


def height_from_shadow_m(top_slant_m: Any, end_slant_m: Any, altitude_m: Any) -> Any:
    """Target height from one frame: ``h = H (r_end - r_top) / r_end``, m."""
    return altitude_m * (end_slant_m - top_slant_m) / end_slant_m


def clamp_height_m(height_m: Any, altitude_m: Any) -> Any:
    """``height_m`` limited to :data:`MAX_HEIGHT_OVER_ALTITUDE` of ``altitude_m`` (numpy)."""
    return np.minimum(height_m, MAX_HEIGHT_OVER_ALTITUDE * np.asarray(altitude_m))
