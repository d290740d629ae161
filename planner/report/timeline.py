"""The executor's state timeline in a run folder: states and their colours, spans, alerts.

Read from ``events.jsonl`` (:class:`~planner.report.data.Event`); the figures and the
report's text share these definitions.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from planner.report.data import Event, RunData

#: Colours of the executor's states; other states take colours from ``_SPARE``.
STATE_COLOURS = {
    "CONNECT": "#b0b0b0", "PREFLIGHT": "#8c8c8c", "ARM": "#c2a26b", "DESCEND": "#2a9d8f",
    "PASS_1": "#1f6fb4", "ALTITUDE_CHANGE": "#8e44ad", "PASS_2": "#d9541e", "FINISH": "#5a9e3a",
    "ASCEND": "#5a9e3a", "SURFACE": "#5a9e3a", "COMPLETED": "#2e7d32", "ABORTED": "#c62828",
}
_SPARE = ("#17becf", "#bcbd22", "#e377c2", "#7f7f7f", "#9467bd", "#8c564b")
PASS_COLOURS = ("#1f6fb4", "#d9541e", "#2a9d8f", "#8e44ad")
ALERT_KINDS = ("failsafe", "abort", "error")
TERMINAL_STATES = ("COMPLETED", "ABORTED")


def state_colour(state: str, order: Sequence[str] = ()) -> str:
    """The colour of a state (known states fixed, others by first appearance in ``order``)."""
    if state in STATE_COLOURS:
        return STATE_COLOURS[state]
    unknown = [s for s in dict.fromkeys(order) if s not in STATE_COLOURS]
    return _SPARE[unknown.index(state) % len(_SPARE)] if state in unknown else _SPARE[0]


@dataclass(frozen=True)
class StateSpan:
    """The executor was in ``state`` from ``start_s`` to ``end_s`` (s since the start)."""

    state: str
    start_s: float
    end_s: float


def state_spans(events: Sequence[Event] | None, end_s: float) -> tuple[StateSpan, ...]:
    """The state timeline from the ``state`` events; the last span ends at ``end_s``."""
    changes = [(e.t_s, e.state) for e in events or () if e.kind == "state"]
    changes.sort(key=lambda c: c[0])
    spans = []
    for i, (t, s) in enumerate(changes):
        t_end = changes[i + 1][0] if i + 1 < len(changes) else max(end_s, t)
        spans.append(StateSpan(s, t, t_end))
    return tuple(spans)


def state_at(spans: Sequence[StateSpan], t_s: np.ndarray) -> list[str]:
    """The state at each time of ``t_s`` (shape (n,), s); ``""`` before the first change."""
    starts = np.array([s.start_s for s in spans])
    idx = np.searchsorted(starts, t_s, side="right") - 1 if len(spans) else np.full(len(t_s), -1)
    return [spans[int(i)].state if i >= 0 else "" for i in idx]


def alerts(run: RunData) -> list[Event]:
    """The failsafes, aborts and errors of a run (the red marks of the figures)."""
    return [e for e in run.events or () if e.kind in ALERT_KINDS or (e.kind == "state" and e.state == "ABORTED")]
