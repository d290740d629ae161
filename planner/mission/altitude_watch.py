"""Altitude warnings: the vehicle lower than the pass it flies, or lower than the clearance.

Two checks, on every sample of altitude above the seabed:

- **below the pass**: in DESCEND (toward pass 1), in a pass, and in ALTITUDE_CHANGE
  (between two passes, the lower of the two), the altitude is below the pass altitude by
  more than ``sigmas`` (3) standard deviations of the altitude filter's estimate: an
  overshoot the filter's own uncertainty does not explain;
- **below the clearance**: in any state, the altitude is below the survey's lowest
  allowed altitude, ``site.target_height_max_m + vehicle.min_clearance_m``
  (:attr:`planner.config.Settings.min_altitude_m`: the clearance is kept above the tallest
  expected target, as survey.toml says and the safety envelope applies).

Each excursion gives one ``warning`` event when it starts (what, how low, the limit, the
state) and one ``info`` event when it ends (the lowest altitude and how long), an
excursion ending once the altitude has been back above its limit for
:data:`END_AFTER_S`. :class:`AltitudeWatch` is pure (samples in, events out);
:class:`DiveWatch` hooks it to the executor's ``on_cycle`` with the filter's estimate,
and the dry-run scorer feeds it the simulator's true altitude afterwards
(``source="truth"``).
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

#: An excursion ends once the altitude has been back above its limit this long, s.
END_AFTER_S = 2.0
#: States in which the vehicle flies toward or along a pass (the pass check applies).
PASS_STATES = ("DESCEND", "ALTITUDE_CHANGE")


@dataclass(frozen=True)
class AltitudeLimits:
    """What the altitude is checked against.

    Attributes
    ----------
    pass_altitudes_m : tuple of float
        The plan's pass altitudes in flying order, m above the seabed.
    min_altitude_m : float
        The lowest allowed altitude above the seabed, m (clearance over the tallest target).
    sigmas : float
        How many filter standard deviations below the pass altitude are tolerated.
    """

    pass_altitudes_m: tuple[float, ...]
    min_altitude_m: float
    sigmas: float = 3.0


@dataclass
class Excursion:
    """One stretch below a limit (``check`` ``"pass"`` or ``"clearance"``)."""

    check: str
    source: str
    state: str
    limit_m: float
    start_s: float
    lowest_m: float
    lowest_s: float
    end_s: float = math.nan
    _above_since_s: float = field(default=math.nan, repr=False)

    def to_dict(self) -> dict[str, Any]:
        """The excursion for summary.json."""
        return {"check": self.check, "source": self.source, "state": self.state, "limit_m": round(self.limit_m, 4),
                "start_s": round(self.start_s, 2), "end_s": None if math.isnan(self.end_s) else round(self.end_s, 2),
                "lowest_m": round(self.lowest_m, 4), "lowest_s": round(self.lowest_s, 2)}


#: (t_s, kind, message, fields) of one event to write.
Event = tuple[float, str, str, dict[str, Any]]


class AltitudeWatch:
    """Feed it altitude samples in time order; it returns the events to log (module docstring)."""

    def __init__(self, limits: AltitudeLimits, *, source: str = "filter"):
        self.limits = limits
        self.source = source
        self.excursions: list[Excursion] = []
        self._open: dict[str, Excursion] = {}
        self._passes_begun = 0
        self._state = ""

    def _pass_limit(self, state: str, std_m: float) -> float | None:
        alts = self.limits.pass_altitudes_m
        if state.startswith("PASS_") and 0 < self._passes_begun <= len(alts):
            ref = alts[self._passes_begun - 1]
        elif state == "DESCEND" and alts:
            ref = alts[0]
        elif state == "ALTITUDE_CHANGE" and 0 < self._passes_begun < len(alts):
            ref = min(alts[self._passes_begun - 1], alts[self._passes_begun])
        else:
            return None
        return ref - self.limits.sigmas * (std_m if math.isfinite(std_m) else 0.0)

    def note_state(self, state: str) -> None:
        """The executor entered ``state`` (``PASS_k`` says which pass; ALTITUDE_CHANGE follows it)."""
        self._state = state
        number = state[5:] if state.startswith("PASS_") else ""
        if number.isdigit():
            self._passes_begun = max(self._passes_begun, int(number))

    def update(self, t_s: float, state: str, altitude_m: float, std_m: float = math.nan) -> list[Event]:
        """One sample: the events it starts or ends."""
        if state != self._state:
            self.note_state(state)
        if not math.isfinite(altitude_m):
            return []
        out: list[Event] = []
        limits = {"pass": self._pass_limit(state, std_m), "clearance": self.limits.min_altitude_m}
        for check, limit in limits.items():
            below = limit is not None and altitude_m < limit
            ex = self._open.get(check)
            if ex is None:
                if below and limit is not None:
                    ex = Excursion(check, self.source, state, limit, t_s, altitude_m, t_s)
                    self._open[check] = ex
                    self.excursions.append(ex)
                    out.append((t_s, "warning", self._start_message(ex, std_m), self._fields(ex, std_m)))
                continue
            if below:
                ex._above_since_s = math.nan
                if altitude_m < ex.lowest_m:
                    ex.lowest_m, ex.lowest_s = altitude_m, t_s
            elif math.isnan(ex._above_since_s):
                ex._above_since_s = t_s
            elif t_s - ex._above_since_s >= END_AFTER_S:
                out.append(self._close(ex, ex._above_since_s))
        return out

    def finish(self, t_s: float) -> list[Event]:
        """Close every open excursion at ``t_s`` (the end of the dive)."""
        return [self._close(ex, t_s if math.isnan(ex._above_since_s) else ex._above_since_s)
                for ex in list(self._open.values())]

    def _close(self, ex: Excursion, end_s: float) -> Event:
        ex.end_s = end_s
        del self._open[ex.check]
        return (end_s, "info", f"{self._what(ex)}: back above {ex.limit_m:.2f} m at {end_s:.1f} s; lowest "
                f"{ex.lowest_m:.2f} m at {ex.lowest_s:.1f} s, {end_s - ex.start_s:.1f} s below",
                {"check": f"altitude_{ex.check}", "source": ex.source, "lowest_m": ex.lowest_m,
                 "limit_m": ex.limit_m, "duration_s": end_s - ex.start_s})

    def _what(self, ex: Excursion) -> str:
        where = "true altitude (simulator)" if ex.source == "truth" else "altitude (filter estimate)"
        return f"{where} below the {'pass altitude' if ex.check == 'pass' else 'clearance'}"

    def _start_message(self, ex: Excursion, std_m: float) -> str:
        if ex.check == "pass":
            limit = (f"the pass altitude less {self.limits.sigmas:g} sigma of the filter "
                     f"({ex.limit_m:.2f} m, sigma {std_m:.3f} m)")
        else:
            limit = (f"the lowest allowed altitude {ex.limit_m:.2f} m (min_clearance_m above the tallest expected "
                     "target)")
        return f"{self._what(ex)}: {ex.lowest_m:.2f} m during {ex.state}, below {limit}"

    def _fields(self, ex: Excursion, std_m: float) -> dict[str, Any]:
        return {"check": f"altitude_{ex.check}", "source": ex.source, "altitude_m": ex.lowest_m,
                "altitude_std_m": std_m, "limit_m": ex.limit_m, "state": ex.state}


def replay(watch: AltitudeWatch, samples: Sequence[tuple[float, float, float]],
           states: Sequence[tuple[float, str]]) -> list[Event]:
    """Feed ``(t_s, altitude_m, std_m)`` samples through ``watch`` with the state at each time
    (``states``: ``(t_s, state)`` entries in time order); returns every event, finished."""
    events: list[Event] = []
    k, state = 0, ""
    last_t = math.nan
    for t_s, altitude_m, std_m in samples:
        while k < len(states) and states[k][0] <= t_s:
            state = states[k][1]
            watch.note_state(state)
            k += 1
        events += watch.update(t_s, state, altitude_m, std_m)
        last_t = t_s
    return events + (watch.finish(last_t) if math.isfinite(last_t) else [])


class DiveWatch:
    """The :class:`AltitudeWatch` of a dive on the filter's estimate, hooked to the executor.

    Pass :meth:`on_cycle` as (or call it from) the executor's ``on_cycle``; call
    :meth:`finish` when the dive ends. ``log(t_s, kind, message, **fields)`` writes an
    event (:meth:`planner.mission.run_folder.RunFolder.event`). The filter's standard
    deviation at each cycle is kept (:meth:`std_at`) for checking the simulator's truth
    against the same tolerance afterwards.
    """

    def __init__(self, limits: AltitudeLimits, log: Callable[..., Any]):
        self.watch = AltitudeWatch(limits)
        self._log = log
        self._times: list[float] = []
        self._stds: list[float] = []

    def on_cycle(self, executor: Any) -> None:
        """One control cycle of ``executor`` (its clock, result state and on-board filter)."""
        now = executor.clock.now_s()
        altitude, std = executor.onboard.altitude(now)
        if math.isfinite(std):
            self._times.append(now)
            self._stds.append(std)
        for t_s, kind, message, fields in self.watch.update(now, executor.result.state, altitude, std):
            self._log(t_s, kind, message, **fields)

    def finish(self, t_s: float) -> list[Excursion]:
        """Close open excursions at the end of the dive; returns every excursion."""
        for end_s, kind, message, fields in self.watch.finish(t_s):
            self._log(end_s, kind, message, **fields)
        return list(self.watch.excursions)

    def std_at(self, t_s: float) -> float:
        """The filter's altitude standard deviation at ``t_s`` (nearest cycle), m; NaN before any."""
        if not self._times:
            return math.nan
        i = bisect.bisect_left(self._times, t_s)
        candidates = [j for j in (i - 1, i) if 0 <= j < len(self._times)]
        return self._stds[min(candidates, key=lambda j: abs(self._times[j] - t_s))]
