"""The telemetry store: the newest record of each kind, under a condition variable.

:class:`vehicle_link.link_core.LinkCore` publishes decoded records into it from its I/O
thread; callers read them from any thread. Listeners run on the publishing thread,
outside the lock.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import TypeVar

from vehicle_link.records import PeerSeen, TelemetryRecord
from vehicle_link.telemetry import store_key

T = TypeVar("T")


class TelemetryStore:
    """Records by store key (:func:`vehicle_link.telemetry.store_key`) and their listeners."""

    def __init__(self) -> None:
        self._cond = threading.Condition(threading.Lock())
        self._store: dict[str, TelemetryRecord] = {}
        self._listeners: list[Callable[[TelemetryRecord], None]] = []

    def _publish(self, record: TelemetryRecord) -> None:
        with self._cond:
            self._store[store_key(record)] = record
            self._cond.notify_all()
            listeners = list(self._listeners)
        for listener in listeners:
            listener(record)

    def latest(self, kind: type[T], key: str | None = None) -> T | None:
        """Latest record of a class (``latest(Attitude)``), or by store key for records kept
        per instance (``latest(Pressure, "Pressure2")``)."""
        with self._cond:
            record = self._store.get(key if key is not None else kind.__name__)
        return record if isinstance(record, kind) else None

    def telemetry(self) -> dict[str, TelemetryRecord]:
        """Snapshot of the latest record of every kind, by store key."""
        with self._cond:
            return dict(self._store)

    def add_listener(self, callback: Callable[[TelemetryRecord], None]) -> None:
        """Call ``callback(record)`` for every telemetry record (on the I/O thread)."""
        with self._cond:
            self._listeners.append(callback)

    def peers_heard(self, kind: str, since_s: float) -> list[PeerSeen]:
        """Other systems heard at or after ``since_s``: ``kind`` "HEARTBEAT" or "MANUAL_CONTROL"."""
        with self._cond:
            return [r for r in self._store.values()
                    if isinstance(r, PeerSeen) and r.kind == kind and r.time_s >= since_s]
