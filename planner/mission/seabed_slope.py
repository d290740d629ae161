"""The seabed's slope under the vehicle, from the altitude filter's seabed depths along the
track: what lets the helm lead a rising seabed instead of trailing it.

The filter's seabed depth is where the seabed is under the vehicle now; flown over a slope
it lags the rise (a random walk follows a ramp late), and the vehicle's depth hold lags the
command. Both lags put the vehicle below its pass altitude while the seabed rises ahead.
Knowing the slope, the helm takes the seabed where the vehicle will be ``lead_s`` later
(:meth:`SeabedSlope.rise_ahead_m`), but only where that makes it shallower: a seabed that
falls away is followed late, as before, which errs high (safe).

The slope is the plane through the recent seabed samples (north, east, depth) over the
last ``span_m`` of track, by weighted least squares with a prior of level ground
(``prior_slope``, 1-sigma per axis, as a tangent): a lane's samples lie on a line, so the
slope across it is unknown and stays near the prior, while along it (the one that
matters for the vehicle flying it) the samples decide. Units: metres, depth positive down,
slopes as tangents (depth change per metre).
"""

from __future__ import annotations

import collections
import math
from dataclasses import dataclass

import numpy as np

#: Track over which the plane is fitted, m.
SPAN_M = 4.0
#: Least track before any slope is reported, m (shorter: level ground assumed).
MIN_SPAN_M = 1.0
#: Level-ground prior: 1-sigma of each slope component, as a tangent (about 6 deg).
PRIOR_SLOPE = 0.1
#: Samples closer together than this along the track are not kept, m.
SAMPLE_SPACING_M = 0.05


@dataclass(frozen=True)
class Slope:
    """Depth change per metre north and east (tangents; positive: deeper that way) and
    the 1-sigma of each."""

    north: float
    east: float
    north_std: float
    east_std: float


class SeabedSlope:
    """Seabed samples along the track and the plane through the recent ones."""

    def __init__(self, *, span_m: float = SPAN_M, prior_slope: float = PRIOR_SLOPE) -> None:
        if not (span_m > MIN_SPAN_M and prior_slope > 0):
            raise ValueError(f"span_m must exceed {MIN_SPAN_M} m and prior_slope be > 0")
        self.span_m, self.prior_slope = span_m, prior_slope
        # (track distance, north, east, depth, depth std)
        self._samples: collections.deque[tuple[float, float, float, float, float]] = collections.deque()
        self._travelled_m = 0.0

    def add(self, north_m: float, east_m: float, seabed_depth_m: float, seabed_std_m: float) -> None:
        """A seabed depth at a place of the track (ignored when not finite)."""
        if not all(math.isfinite(v) for v in (north_m, east_m, seabed_depth_m, seabed_std_m)):
            return
        if self._samples:
            _, n0, e0, _, _ = self._samples[-1]
            step = math.hypot(north_m - n0, east_m - e0)
            if step < SAMPLE_SPACING_M:
                return
            self._travelled_m += step
        self._samples.append((self._travelled_m, north_m, east_m, seabed_depth_m, max(seabed_std_m, 1e-3)))
        while self._samples and self._samples[0][0] < self._travelled_m - self.span_m:
            self._samples.popleft()

    def slope(self) -> Slope | None:
        """The plane's slope over the recent track (None over less than ``MIN_SPAN_M``)."""
        if len(self._samples) < 3 or self._samples[-1][0] - self._samples[0][0] < MIN_SPAN_M:
            return None
        s = np.array(self._samples)
        north, east, depth, std = s[:, 1] - s[-1, 1], s[:, 2] - s[-1, 2], s[:, 3], s[:, 4]
        # Depth = c + gn north + ge east; the samples' errors are correlated along the track
        # (a filter's output), so each counts as one of the span's independent metres.
        per_metre = max(len(s) / max(s[-1, 0] - s[0, 0], MIN_SPAN_M), 1.0)
        w = 1.0 / (std * std * per_metre)
        a = np.column_stack([np.ones_like(north), north, east])
        normal = (a * w[:, None]).T @ a + np.diag([0.0, 1.0, 1.0]) / self.prior_slope**2
        rhs = (a * w[:, None]).T @ depth
        try:
            solution = np.linalg.solve(normal, rhs)
            cov = np.linalg.inv(normal)
        except np.linalg.LinAlgError:
            return None
        return Slope(float(solution[1]), float(solution[2]), float(math.sqrt(max(cov[1, 1], 0.0))),
                     float(math.sqrt(max(cov[2, 2], 0.0))))

    def rise_ahead_m(self, vel_north_m_s: float, vel_east_m_s: float, lead_s: float) -> float:
        """How much the seabed rises (m, >= 0) along the velocity over ``lead_s``: the slope
        along the path, less one sigma of it (only a rise the samples show for sure)."""
        slope = self.slope()
        speed = math.hypot(vel_north_m_s, vel_east_m_s)
        if slope is None or not (math.isfinite(speed) and speed > 0 and lead_s > 0):
            return 0.0
        un, ue = vel_north_m_s / speed, vel_east_m_s / speed
        along = slope.north * un + slope.east * ue  # depth change per metre along the path
        along_std = math.hypot(slope.north_std * un, slope.east_std * ue)
        rise_per_m = max(-along - along_std, 0.0)  # a rising seabed: depth decreasing
        return rise_per_m * speed * lead_s
