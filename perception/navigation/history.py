"""The vehicle's navigation over the last seconds: position, attitude and mount angle by time.

One history serves every user that needs the pose at a time other than now: stamping
sonar frames with the pose at their ping (on board, and offline from a navigation CSV),
the pitch loop's speed and pitch-rate estimates, and the executor's position checks.

Three streams are kept apart, each with its own times, because they arrive apart (on a
real vehicle LOCAL_POSITION_NED, ATTITUDE and the mount's status come at their own
rates): positions (north, east and, when known, their velocity), attitude (heading,
pitch, roll) and the mount's tilt. :meth:`NavigationHistory.at` interpolates the
position linearly between the two reports around the time and extrapolates it past the
newest with that report's velocity (for at most ``max_extrapolation_s``); the attitude
and the tilt are those of the nearest sample in time (they change little between
samples, and a mean of two headings across north would be wrong).

Frames and units: local NED metres about the survey's origin; angles in radians,
ArduPilot's conventions (pitch positive nose up, roll positive starboard down, heading
clockwise from north in [0, 2 pi)); tilt positive down. NaN = not known.
"""

from __future__ import annotations

import bisect
import math
from collections import deque
from dataclasses import dataclass
from typing import Any

#: Longest a position is extrapolated past the newest report, s.
MAX_EXTRAPOLATION_S = 0.5


@dataclass(frozen=True)
class NavSample:
    """The vehicle's navigation at one time (NaN = not known).

    Attributes
    ----------
    time_s : float
        Time of the sample, s (the caller's clock).
    north_m, east_m : float
        Position in the survey's local NED frame, m.
    heading_rad, pitch_rad, roll_rad : float
        Attitude, rad (ArduPilot conventions).
    tilt_rad : float
        The mount's tilt as reported, rad, positive down (its frame is the mount's: see
        the caller).
    """

    time_s: float
    north_m: float
    east_m: float
    heading_rad: float
    pitch_rad: float
    roll_rad: float
    tilt_rad: float


class NavigationHistory:
    """Position, attitude and mount samples of the last ``history_s`` seconds.

    Samples of each stream must come in time order; one older than that stream's
    newest is ignored (it is a late duplicate, and the history stays sorted).

    Parameters
    ----------
    history_s : float
        How much of each stream is kept, s (> 0).
    max_extrapolation_s : float
        Longest a position is carried past the newest report with its velocity, s.
    """

    def __init__(self, history_s: float = 30.0, *, max_extrapolation_s: float = MAX_EXTRAPOLATION_S):
        if not (math.isfinite(history_s) and history_s > 0):
            raise ValueError(f"history_s must be > 0, got {history_s!r}")
        if not (math.isfinite(max_extrapolation_s) and max_extrapolation_s >= 0):
            raise ValueError(f"max_extrapolation_s must be >= 0, got {max_extrapolation_s!r}")
        self.history_s = history_s
        self.max_extrapolation_s = max_extrapolation_s
        self._pos_t: deque[float] = deque()
        self._pos: deque[tuple[float, float, float, float]] = deque()  # north, east, v_north, v_east
        self._att_t: deque[float] = deque()
        self._att: deque[tuple[float, float, float]] = deque()  # heading, pitch, roll
        self._tilt_t: deque[float] = deque()
        self._tilt: deque[float] = deque()

    # ---------------------------------------------------------------- adding
    def add_position(self, time_s: float, north_m: float, east_m: float, *,
                     velocity_north_m_s: float = math.nan, velocity_east_m_s: float = math.nan) -> bool:
        """Add a position report; False (ignored) when not finite or out of order."""
        if not (math.isfinite(time_s) and math.isfinite(north_m) and math.isfinite(east_m)):
            return False
        if self._pos_t and time_s <= self._pos_t[-1]:
            return False
        vn = velocity_north_m_s if math.isfinite(velocity_north_m_s) else 0.0
        ve = velocity_east_m_s if math.isfinite(velocity_east_m_s) else 0.0
        self._pos_t.append(time_s)
        self._pos.append((north_m, east_m, vn, ve))
        self._trim(self._pos_t, self._pos, time_s)
        return True

    def add_attitude(self, time_s: float, heading_rad: float, pitch_rad: float, roll_rad: float) -> bool:
        """Add an attitude sample (heading wrapped to [0, 2 pi)); False when out of order."""
        if not math.isfinite(time_s) or (self._att_t and time_s < self._att_t[-1]):
            return False
        heading = heading_rad % (2 * math.pi) if math.isfinite(heading_rad) else math.nan
        self._att_t.append(time_s)
        self._att.append((heading, pitch_rad, roll_rad))
        self._trim(self._att_t, self._att, time_s)
        return True

    def add_tilt(self, time_s: float, tilt_rad: float) -> bool:
        """Add a mount angle report, rad; False when out of order or not finite."""
        if not (math.isfinite(time_s) and math.isfinite(tilt_rad)) or (self._tilt_t and time_s < self._tilt_t[-1]):
            return False
        self._tilt_t.append(time_s)
        self._tilt.append(tilt_rad)
        self._trim(self._tilt_t, self._tilt, time_s)
        return True

    def _trim(self, times: deque[float], values: deque[Any], newest_s: float) -> None:
        while len(times) > 1 and times[0] < newest_s - self.history_s:
            times.popleft()
            values.popleft()

    # --------------------------------------------------------------- reading
    @property
    def empty(self) -> bool:
        """True before the first sample of any stream."""
        return not (self._pos_t or self._att_t or self._tilt_t)

    def position_at(self, time_s: float) -> tuple[float, float] | None:
        """(north, east) at ``time_s``, m: interpolated; past the newest report
        extrapolated with its velocity (at most ``max_extrapolation_s``); before the
        oldest, the oldest. None before any report."""
        if not self._pos_t:
            return None
        i = bisect.bisect_left(self._pos_t, time_s)
        if i >= len(self._pos_t):
            n, e, vn, ve = self._pos[-1]
            dt = min(max(time_s - self._pos_t[-1], 0.0), self.max_extrapolation_s)
            return n + vn * dt, e + ve * dt
        if i == 0 or self._pos_t[i] == time_s:
            return self._pos[i][0], self._pos[i][1]
        (n0, e0, _, _), (n1, e1, _, _) = self._pos[i - 1], self._pos[i]
        t0, t1 = self._pos_t[i - 1], self._pos_t[i]
        w = (time_s - t0) / (t1 - t0)
        return n0 + w * (n1 - n0), e0 + w * (e1 - e0)

    def at(self, time_s: float) -> NavSample | None:
        """The navigation at ``time_s`` (see the module docstring); None before any sample."""
        if self.empty:
            return None
        position = self.position_at(time_s) or (math.nan, math.nan)
        heading, pitch, roll = _nearest(self._att_t, self._att, time_s) or (math.nan, math.nan, math.nan)
        tilt = _nearest(self._tilt_t, self._tilt, time_s)
        return NavSample(time_s, position[0], position[1], heading, pitch, roll, math.nan if tilt is None else tilt)

    def latest(self) -> NavSample | None:
        """The newest of everything: time of the newest sample of any stream, the last
        position reported (not extrapolated), attitude and tilt; None before any sample."""
        if self.empty:
            return None
        time_s = max(t[-1] for t in (self._pos_t, self._att_t, self._tilt_t) if t)
        north, east = (self._pos[-1][0], self._pos[-1][1]) if self._pos else (math.nan, math.nan)
        heading, pitch, roll = self._att[-1] if self._att else (math.nan, math.nan, math.nan)
        tilt = self._tilt[-1] if self._tilt else math.nan
        return NavSample(time_s, north, east, heading, pitch, roll, tilt)

    def last_position_s(self) -> float:
        """Time of the newest position report, s (-inf before any)."""
        return self._pos_t[-1] if self._pos_t else -math.inf


def _nearest(times: deque[float], values: deque[Any], time_s: float) -> Any:
    """The value of the sample nearest ``time_s`` (the later one on a tie); None if empty."""
    if not times:
        return None
    i = bisect.bisect_left(times, time_s)
    if i <= 0:
        return values[0]
    if i >= len(times):
        return values[-1]
    return values[i] if times[i] - time_s <= time_s - times[i - 1] else values[i - 1]
