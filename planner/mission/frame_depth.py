"""The depth the companion stamps on a sonar frame (:func:`frame_depth_m`)."""

from __future__ import annotations

import math

#: An estimate less sure than this says nothing useful about where the sonar is (the depth
#: change between a survey's two altitudes is a few decimetres), m.
MAX_DEPTH_STD_M = 1.0


def frame_depth_m(mean_m: float, std_m: float) -> float:
    """The depth a frame is stamped with, from the filter's estimate (m, positive down).

    Unknown (NaN) when the filter cannot say (its 1-sigma over :data:`MAX_DEPTH_STD_M`):
    before the first depth reading the altitude filter's prior, 0 +- 100 m for both the
    depth and the seabed, turns a first altimeter reading of 2 m into a depth of -1 m
    +- 70 m, as happened on a lossy link in a whole-loop dive. A sonar cannot be above the
    surface either: an estimate there is the surface when the surface lies within 3 sigma
    of it (a pressure offset at the surface), otherwise unknown. So no frame carries a
    depth it may not (``frame-format.md``), and the dive goes on.
    """
    if not (math.isfinite(mean_m) and math.isfinite(std_m)) or std_m > MAX_DEPTH_STD_M:
        return math.nan
    if mean_m >= 0.0:
        return mean_m
    return 0.0 if mean_m >= -3.0 * std_m else math.nan
