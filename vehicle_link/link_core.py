"""LinkCore: the I/O half of one MAVLink 2 link to one vehicle - thread, clock, heartbeats,
link health, the telemetry store.

Threading model
---------------
One I/O thread (``threaded=True``, the default) owns the socket: it waits for bytes at
most ``config.io_poll_s`` real seconds at a time, parses them, stores the latest telemetry
record of each kind under a lock, notifies a condition variable, and on every pass reads
the injected clock to send our heartbeat when due and to detect link loss/recovery.
Caller threads wait on that condition, measuring timeouts on the injected clock. With
``threaded=False`` there is no thread: the caller drives the link with ``pump()``, and
every blocking method pumps while it waits. On a lockstep simulation clock the passes
run where :mod:`vehicle_link.io_driver` says (the simulator's thread, where it can).

Callbacks (telemetry listeners, ``on_link_lost``, ``on_link_restored``) run on the I/O
thread (or inside ``pump``, or the simulator's poll), outside the lock: keep them short,
never block in them.

Other systems are recorded too (:class:`~vehicle_link.records.PeerSeen`): every
HEARTBEAT not from the vehicle's autopilot (the topside ground station, BlueOS's own
services) and every MANUAL_CONTROL (a pilot's joystick), so the companion can tell
whether a topside is there. The request/response protocols on top (commands with their
ACK, parameters, missions) are :class:`vehicle_link.link.VehicleLink`.
"""

from __future__ import annotations

import logging
import threading
from collections import deque
from collections.abc import Callable
from typing import Any, TypeVar

from vehicle_link import commands
from vehicle_link.clock import Clock, WallClock
from vehicle_link.config import LinkConfig
from vehicle_link.errors import LinkLost, StaleTelemetry
from vehicle_link.io_driver import IoDriver
from vehicle_link.records import LinkHealth, LinkStats, PeerSeen
from vehicle_link.signing import enable_signing
from vehicle_link.store import TelemetryStore
from vehicle_link.telemetry import (
    MAV_TYPE_SUBMARINE,
    Heartbeat,
    TelemetryRecord,
    decode,
)
from vehicle_link.tlog import TlogWriter
from vehicle_link.transport import MavlinkTransport

_log = logging.getLogger(__name__)

T = TypeVar("T")

_MISSION_MESSAGES = frozenset({"MISSION_REQUEST", "MISSION_REQUEST_INT", "MISSION_ACK", "MISSION_COUNT",
                               "MISSION_ITEM_INT", "MISSION_ITEM"})


class LinkCore(TelemetryStore):
    """The I/O half of a MAVLink 2 link to one vehicle (heartbeat type ``MAV_TYPE_SUBMARINE``).

    Parameters
    ----------
    config : LinkConfig
        Validated settings.
    clock : Clock, optional
        Injected clock (default: WallClock).
    threaded : bool
        Run the I/O thread (default) or let the caller ``pump()``.
    on_link_lost, on_link_restored : callable, optional
        Called with the LinkHealth once per transition.
    """

    def __init__(
        self,
        config: LinkConfig,
        *,
        clock: Clock | None = None,
        threaded: bool = True,
        on_link_lost: Callable[[LinkHealth], None] | None = None,
        on_link_restored: Callable[[LinkHealth], None] | None = None,
    ) -> None:
        self.config = config
        self._clock: Clock = clock if clock is not None else WallClock()
        self._wall_clock = isinstance(self._clock, WallClock)
        self._threaded = threaded
        self._on_link_lost = on_link_lost
        self._on_link_restored = on_link_restored
        super().__init__()
        self._command_lock = threading.Lock()
        self._mission_lock = threading.Lock()
        self._acks: dict[int, tuple[int, int]] = {}  # command -> (serial, result)
        self._ack_serial = 0
        self._mission_queue: deque[Any] = deque()
        self._mission_active = False
        self._target_system = config.target_system
        self._last_hb_s: float | None = None
        self._link_up: bool | None = None
        self._losses = 0
        self._restorations = 0
        self._next_heartbeat_s = 0.0
        self._received = 0
        self._bad_data = 0
        self._sig_rejects = 0
        self._unknown = 0
        self._t0_s = self._clock.now_s()
        self._transport: MavlinkTransport | None = None
        self._tlog: TlogWriter | None = None
        self._io = IoDriver(self._clock, self._service_pass, config.io_poll_s) if threaded else None

    # ---- lifecycle ---------------------------------------------------------------------

    def open(self) -> None:
        """Open the connection (and tlog), start the I/O thread; does not wait."""
        if self._transport is not None:
            return
        if self.config.tlog_path is not None:
            self._tlog = TlogWriter(self.config.tlog_path, self._clock)
        self._transport = MavlinkTransport(
            self.config.connection,
            self.config.source_system,
            self.config.source_component,
            baud=self.config.baud,
            on_bytes_sent=self._log_bytes,
        )
        if self.config.signing_key is not None:
            enable_signing(
                self._transport.mav, self.config.signing_key, link_id=self.config.signing_link_id
            )
        self._next_heartbeat_s = self._clock.now_s()
        if self._io is not None:
            self._io.start()

    def close(self) -> None:
        """Stop the I/O thread, close the connection and the tlog."""
        if self._io is not None:
            self._io.stop()
        if self._transport is not None:
            self._transport.close()
            self._transport = None
        if self._tlog is not None:
            self._tlog.close()

    # ---- I/O passes ----------------------------------------------------------------------

    def in_io_pass(self) -> bool:
        """Whether the calling thread is in an I/O pass (a callback: the I/O thread, or the
        lockstep clock's poller)."""
        return self._io is not None and self._io.in_pass()

    def _service_pass(self, wait_s: float) -> None:
        try:
            self._service_once(wait_s)
        except Exception:  # keep the link alive whatever one message does
            _log.exception("vehicle_link I/O pass failed")

    def pump(self, max_wait_s: float = 0.0) -> None:
        """Receive and dispatch what has arrived, send the heartbeat if due (unthreaded use)."""
        if self._threaded:
            raise RuntimeError("pump() is for threaded=False clients; the I/O thread pumps")
        self._service_once(max_wait_s)

    def _service_once(self, wait_s: float) -> None:
        transport = self._transport
        if transport is None:
            return
        self._timers()
        for msg in transport.receive(wait_s):
            self._handle(msg)
        self._timers()

    def _timers(self) -> None:
        now = self._clock.now_s()
        if now >= self._next_heartbeat_s:
            self._next_heartbeat_s = now + self.config.heartbeat_period_s
            self._send(commands.heartbeat_onboard_computer())
        callback: Callable[[LinkHealth], None] | None = None
        with self._cond:
            if (
                self._link_up
                and self._last_hb_s is not None
                and now - self._last_hb_s > self.config.link_timeout_s
            ):
                self._link_up = False
                self._losses += 1
                callback = self._on_link_lost
                self._cond.notify_all()
        if callback is not None:
            _log.warning("link lost: no heartbeat for %.1f s", now - (self._last_hb_s or now))
            callback(self.link_health())

    def _handle(self, msg: Any) -> None:
        mtype = msg.get_type()
        if mtype == "BAD_DATA":
            self._bad_data += 1
            if "signature" in str(getattr(msg, "reason", "")).lower():
                self._sig_rejects += 1
            return
        if mtype.startswith("UNKNOWN_"):
            self._unknown += 1
            return
        self._received += 1
        if self._tlog is not None:
            self._tlog.write(msg.get_msgbuf())
        src = msg.get_srcSystem()
        if mtype == "HEARTBEAT":
            self._handle_heartbeat(msg)
            return
        now = self._clock.now_s()
        if mtype == "MANUAL_CONTROL" and src != self._target_system:
            # A pilot's joystick (the router forwards it to every endpoint).
            self._publish(PeerSeen(now, src, int(msg.get_srcComponent()), "MANUAL_CONTROL"))
            return
        if self._target_system is None or src != self._target_system:
            return
        addressed_to_us = getattr(msg, "target_system", 0) in (0, self.config.source_system) and (
            getattr(msg, "target_component", 0) in (0, self.config.source_component)
        )
        if mtype == "COMMAND_ACK":
            if addressed_to_us:
                with self._cond:
                    self._ack_serial += 1
                    self._acks[int(msg.command)] = (self._ack_serial, int(msg.result))
                    self._cond.notify_all()
            return
        if mtype in _MISSION_MESSAGES:
            if addressed_to_us:
                with self._cond:
                    if self._mission_active:
                        self._mission_queue.append(msg)
                        self._cond.notify_all()
            return
        try:
            record = decode(msg, now)
        except (ValueError, ArithmeticError):  # valid CRC, impossible values
            self._bad_data += 1
            return
        if record is not None:
            self._publish(record)

    def _handle_heartbeat(self, msg: Any) -> None:
        src = msg.get_srcSystem()
        now = self._clock.now_s()
        if msg.type == MAV_TYPE_SUBMARINE and self._target_system is None:
            self._target_system = src
        if msg.type != MAV_TYPE_SUBMARINE or src != self._target_system or msg.get_srcComponent() != 1:
            # Another system or component: the topside, BlueOS's services, other computers.
            self._publish(PeerSeen(now, src, int(msg.get_srcComponent()), "HEARTBEAT", int(msg.type)))
            return
        record = decode(msg, now)
        assert isinstance(record, Heartbeat)
        restored = False
        with self._cond:
            self._last_hb_s = now
            if self._link_up is False:
                restored = True
                self._restorations += 1
            self._link_up = True
        if restored:
            _log.warning("link restored")
            if self._on_link_restored is not None:
                self._on_link_restored(self.link_health())
        self._publish(record)

    def _log_bytes(self, buf: bytes) -> None:
        if self._tlog is not None:
            self._tlog.write(buf)

    def _send(self, msg: Any) -> None:
        if self._transport is None:
            raise ConnectionError("vehicle link is not open")
        self._transport.send(msg)

    def _target(self) -> int:
        if self._target_system is None:
            raise LinkLost("no vehicle heartbeat yet: target system unknown")
        return self._target_system

    def _time_boot_ms(self) -> int:
        return int((self._clock.now_s() - self._t0_s) * 1000.0)

    def _wait_until(self, predicate: Callable[[], bool], timeout_s: float) -> bool:
        """Wait until ``predicate()`` (evaluated under the lock) or the clock passes the timeout."""
        deadline = self._clock.now_s() + timeout_s
        poll_s = self.config.io_poll_s
        with self._cond:
            while True:
                if predicate():
                    return True
                remaining = deadline - self._clock.now_s()
                if remaining <= 0.0:
                    return False
                if self._threaded and self._wall_clock:
                    self._cond.wait(timeout=min(remaining, poll_s))
                elif self._threaded:
                    # An injected (simulated) clock: wait on it, so simulated time goes on.
                    self._cond.release()
                    try:
                        self._clock.sleep_s(min(remaining, poll_s))
                    finally:
                        self._cond.acquire()
                else:
                    self._cond.release()
                    try:
                        self._service_once(min(remaining, poll_s))
                    finally:
                        self._cond.acquire()

    # ---- telemetry ---------------------------------------------------------------------

    def wait_for_record(
        self, predicate: Callable[[TelemetryRecord], bool], timeout_s: float
    ) -> TelemetryRecord | None:
        """Wait for a stored record satisfying ``predicate``; None on timeout."""
        found: list[TelemetryRecord] = []

        def check() -> bool:
            for record in self._store.values():
                if predicate(record):
                    found.append(record)
                    return True
            return False

        return found[0] if self._wait_until(check, timeout_s) else None

    @property
    def mode(self) -> int | None:
        """The vehicle's current ArduSub mode number (HEARTBEAT.custom_mode)."""
        hb = self.latest(Heartbeat)
        return None if hb is None else hb.custom_mode

    @property
    def armed(self) -> bool | None:
        """Whether the vehicle reports itself armed."""
        hb = self.latest(Heartbeat)
        return None if hb is None else hb.armed

    @property
    def target_system(self) -> int | None:
        """The vehicle's system id (None before its first heartbeat)."""
        return self._target_system

    def link_health(self) -> LinkHealth:
        """Current link state."""
        now = self._clock.now_s()
        with self._cond:
            last = self._last_hb_s
            return LinkHealth(self._link_up, last, None if last is None else now - last, self._losses,
                              self._restorations)

    def stats(self) -> LinkStats:
        """Session counters."""
        sent = 0 if self._transport is None else self._transport.mav.total_packets_sent
        return LinkStats(self._received, sent, self._bad_data, self._sig_rejects, self._unknown)

    def _fresh(self, kind: type[T], what: str, key: str | None = None) -> T:
        record = self.latest(kind, key)
        max_age = self.config.telemetry_max_age_s
        if record is None:
            raise StaleTelemetry(what, None, max_age)
        age = self._clock.now_s() - record.time_s  # type: ignore[attr-defined]
        if age > max_age:
            raise StaleTelemetry(what, age, max_age)
        return record

    def peers(self, kind: str, max_age_s: float) -> list[PeerSeen]:
        """Other systems heard within ``max_age_s`` (clock): ``kind`` "HEARTBEAT" or "MANUAL_CONTROL"."""
        return self.peers_heard(kind, self._clock.now_s() - max_age_s)
