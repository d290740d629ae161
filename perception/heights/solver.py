"""Target height from cast shadows: the paper's Eq. 2 and the solvers built on its geometry.

One entry point for the pieces, each in its own module:

- :mod:`perception.heights.eq2`: the geometry, the paper's Eq. 2 as published, one- and
  two-frame heights;
- :mod:`perception.heights.least_squares`: the N-frame weighted least squares for
  ``(h, H0)`` with its uncertainty;
- :mod:`perception.heights.sloped`: a sloped seabed, through perpendicular distances;
- :mod:`perception.heights.rounded`: a rounded top's summit from its grazing points.
"""

from perception.heights.eq2 import eq2_paper, height_one_frame, height_two_frames, shadow_ranges
from perception.heights.least_squares import (
    WLS_ITERATIONS,
    BatchHeightEstimate,
    HeightEstimate,
    ShadowObservation,
    solve_height,
    solve_height_batch,
)
from perception.heights.rounded import RoundedTopFit, fit_rounded_top, grazing_tan2
from perception.heights.sloped import solve_height_sloped

__all__ = [
    "WLS_ITERATIONS",
    "BatchHeightEstimate",
    "HeightEstimate",
    "RoundedTopFit",
    "ShadowObservation",
    "eq2_paper",
    "fit_rounded_top",
    "grazing_tan2",
    "height_one_frame",
    "height_two_frames",
    "shadow_ranges",
    "solve_height",
    "solve_height_batch",
    "solve_height_sloped",
]
