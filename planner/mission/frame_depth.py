"""The depth the companion stamps on a sonar frame (:func:`frame_depth_m`)."""

from __future__ import annotations

import math


def frame_depth_m(mean_m: float, std_m: float) -> float:
    """The depth a frame is stamped with, from the filter's estimate (m, positive down).

    A sonar cannot be above the surface: an estimate there (the filter early in a dive, on
    a lossy link before the depth sensor's stream is set, or a pressure offset) is the
    surface when the surface lies within 3 sigma of it, otherwise unknown (NaN), so that
    no frame carries a depth it may not (``frame-format.md``) and the dive goes on.
    """
    if not math.isfinite(mean_m) or mean_m >= 0.0:
        return mean_m
    return 0.0 if math.isfinite(std_m) and mean_m >= -3.0 * std_m else math.nan
