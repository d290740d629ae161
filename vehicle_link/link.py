"""VehicleLink: one MAVLink 2 link to one vehicle, with its I/O thread and clock.

Threading model
---------------
One I/O thread (``threaded=True``, the default) owns the socket: it waits for bytes at
most ``config.io_poll_s`` real seconds at a time, parses them, stores the latest telemetry
record of each kind under a lock, notifies a condition variable, and on every pass reads
the injected clock to send our heartbeat when due and to detect link loss/recovery.
Caller threads send commands and wait on that condition, measuring timeouts on the
injected clock. With ``threaded=False`` there is no thread: the caller drives the link with
``pump()``, and every blocking method pumps while it waits.

Callbacks (telemetry listeners, ``on_link_lost``, ``on_link_restored``) run on the I/O
thread (or inside ``pump``), outside the link's lock: keep them short and never call a
blocking method from them; hand the work to another thread instead.

ArduSub-specific commands live in :class:`vehicle_link.client.ArduSubClient`, which
subclasses this.
"""

from __future__ import annotations

import contextlib
import logging
import math
import threading
from collections import deque
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any, Self, TypeVar

from vehicle_link import commands
from vehicle_link.clock import Clock, WallClock
from vehicle_link.config import LinkConfig
from vehicle_link.dialect import mavlink2
from vehicle_link.errors import (
    CommandRejected,
    CommandTimeout,
    ConfigError,
    HeartbeatTimeout,
    LinkLost,
    StaleTelemetry,
)
from vehicle_link.signing import enable_signing
from vehicle_link.telemetry import (
    MAV_TYPE_SUBMARINE,
    Heartbeat,
    ParamValue,
    TelemetryRecord,
    decode,
    store_key,
)
from vehicle_link.tlog import TlogWriter
from vehicle_link.transport import MavlinkTransport

_log = logging.getLogger(__name__)

T = TypeVar("T")

MAV_RESULT_ACCEPTED = mavlink2.MAV_RESULT_ACCEPTED
MAV_RESULT_IN_PROGRESS = mavlink2.MAV_RESULT_IN_PROGRESS
MAX_IN_PROGRESS_EXTENSIONS = 20
_MISSION_MESSAGES = frozenset(
    {
        "MISSION_REQUEST",
        "MISSION_REQUEST_INT",
        "MISSION_ACK",
        "MISSION_COUNT",
        "MISSION_ITEM_INT",
        "MISSION_ITEM",
    }
)


def result_name(result: int) -> str:
    """Name of a MAV_RESULT."""
    entry = mavlink2.enums["MAV_RESULT"].get(result)
    return entry.name if entry is not None else f"MAV_RESULT({result})"


@dataclass(frozen=True)
class LinkHealth:
    """Link state on the injected clock. ``up`` is None before the first heartbeat."""

    up: bool | None
    last_heartbeat_s: float | None
    silence_s: float | None
    losses: int
    restorations: int


@dataclass(frozen=True)
class LinkStats:
    """Counters of the session."""

    messages_received: int
    messages_sent: int
    bad_data: int
    signature_rejects: int
    unknown_messages: int
    sticky_resends: int


class MissionChannel:
    """The mission-protocol messages addressed to us, while a transfer holds the channel.

    Obtained from :meth:`VehicleLink.mission_channel`; one transfer at a time.
    """

    def __init__(self, link: VehicleLink) -> None:
        self._link = link

    def send(self, msg: Any) -> None:
        """Send one message to the vehicle."""
        self._link._send(msg)

    def next_message(self, timeout_s: float) -> Any | None:
        """The next MISSION_* message from the vehicle, or None after ``timeout_s`` (clock)."""
        return self._link._next_mission_message(timeout_s)


class VehicleLink:
    """MAVLink 2 link to one vehicle (heartbeat type ``MAV_TYPE_SUBMARINE``).

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
        self._cond = threading.Condition(threading.Lock())
        self._command_lock = threading.Lock()
        self._mission_lock = threading.Lock()
        self._store: dict[str, TelemetryRecord] = {}
        self._listeners: list[Callable[[TelemetryRecord], None]] = []
        self._acks: dict[int, tuple[int, int]] = {}  # command -> (serial, result)
        self._ack_serial = 0
        self._mission_queue: deque[Any] = deque()
        self._mission_active = False
        self._target_system = config.target_system
        self._last_hb_s: float | None = None
        self._link_up: bool | None = None
        self._losses = 0
        self._restorations = 0
        self._last_mode: int | None = None
        self._sticky: commands.CommandSpec | None = None  # re-sent after every mode change
        self._sticky_pending = False
        self._next_heartbeat_s = 0.0
        self._received = 0
        self._bad_data = 0
        self._sig_rejects = 0
        self._unknown = 0
        self._sticky_resends = 0
        self._t0_s = self._clock.now_s()
        self._transport: MavlinkTransport | None = None
        self._tlog: TlogWriter | None = None
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()

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
        if self._threaded:
            self._stop.clear()
            self._thread = threading.Thread(target=self._run, name="vehicle_link-io", daemon=True)
            self._thread.start()

    def connect(self, *, request_streams: bool = True) -> Heartbeat:
        """Open, wait for the vehicle's MAV_TYPE_SUBMARINE heartbeat, request the streams.

        Raises
        ------
        HeartbeatTimeout
            No submarine heartbeat within ``config.connect_timeout_s``.
        """
        self.open()
        if not self._wait_until(lambda: self._link_up is not None, self.config.connect_timeout_s):
            raise HeartbeatTimeout(self.config.connect_timeout_s)
        hb = self.latest(Heartbeat)
        assert hb is not None
        if request_streams:
            for name, period_s in self.config.message_intervals_s:
                try:
                    self.request_message_interval(name, period_s)
                except (CommandRejected, CommandTimeout) as exc:
                    _log.warning("stream %s not set: %s", name, exc)
        return hb

    def close(self) -> None:
        """Stop the I/O thread, close the connection and the tlog."""
        self._stop.set()
        notify = getattr(self._clock, "notify", None)
        if notify is not None:
            notify()
        if self._thread is not None:
            self._thread.join(timeout=5.0)
            self._thread = None
        if self._transport is not None:
            self._transport.close()
            self._transport = None
        if self._tlog is not None:
            self._tlog.close()

    def __enter__(self) -> Self:
        self.connect()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ---- I/O loop ----------------------------------------------------------------------

    def _run(self) -> None:
        participant = getattr(self._clock, "participant", None)
        wait_for = getattr(self._clock, "wait_for", None)
        if participant is None or wait_for is None:
            while not self._stop.is_set():
                self._service_pass(self.config.io_poll_s)
            return
        # A lockstep simulation clock (sim_harness.clock.SimClock) advances only while every
        # participant waits on it: this thread joins in, drains the socket without blocking,
        # then waits on the clock, so no reply of the simulated vehicle is ever missed or
        # late in simulated time.
        with participant("vehicle_link-io"):
            while not self._stop.is_set():
                self._service_pass(0.0)
                try:
                    wait_for(self._stop.is_set, self.config.io_poll_s)
                except Exception:  # the clock was stopped: the simulation is over
                    return

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
            resend = self._sticky if (self._sticky_pending and self._link_up) else None
            if resend is not None:
                self._sticky_pending = False
        if callback is not None:
            _log.warning("link lost: no heartbeat for %.1f s", now - (self._last_hb_s or now))
            callback(self.link_health())
        if resend is not None:
            # fire and forget: the I/O thread must not block waiting for its own ack
            self._send(commands.command_long(resend, self._target(), self.config.target_component))
            self._sticky_resends += 1

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
        if self._target_system is None or src != self._target_system:
            return
        now = self._clock.now_s()
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
        if msg.type != MAV_TYPE_SUBMARINE:
            return
        src = msg.get_srcSystem()
        if self._target_system is None:
            self._target_system = src
        if src != self._target_system:
            return
        now = self._clock.now_s()
        record = decode(msg, now)
        assert isinstance(record, Heartbeat)
        restored = False
        with self._cond:
            self._last_hb_s = now
            if self._link_up is False:
                restored = True
                self._restorations += 1
            self._link_up = True
            if self._last_mode is not None and record.custom_mode != self._last_mode:
                self._sticky_pending = self._sticky is not None
            self._last_mode = record.custom_mode
        if restored:
            _log.warning("link restored")
            if self._on_link_restored is not None:
                self._on_link_restored(self.link_health())
        self._publish(record)

    def _publish(self, record: TelemetryRecord) -> None:
        with self._cond:
            self._store[store_key(record)] = record
            self._cond.notify_all()
            listeners = list(self._listeners)
        for listener in listeners:
            listener(record)

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
            return LinkHealth(
                self._link_up,
                last,
                None if last is None else now - last,
                self._losses,
                self._restorations,
            )

    def stats(self) -> LinkStats:
        """Session counters."""
        sent = 0 if self._transport is None else self._transport.mav.total_packets_sent
        return LinkStats(
            self._received,
            sent,
            self._bad_data,
            self._sig_rejects,
            self._unknown,
            self._sticky_resends,
        )

    def _fresh(self, kind: type[T], what: str, key: str | None = None) -> T:
        record = self.latest(kind, key)
        max_age = self.config.telemetry_max_age_s
        if record is None:
            raise StaleTelemetry(what, None, max_age)
        age = self._clock.now_s() - record.time_s  # type: ignore[attr-defined]
        if age > max_age:
            raise StaleTelemetry(what, age, max_age)
        return record

    def send_command(
        self,
        spec: commands.CommandSpec,
        *,
        timeout_s: float | None = None,
        attempts: int | None = None,
    ) -> int:
        """Send a COMMAND_LONG and wait for its COMMAND_ACK, retrying on silence.

        Returns MAV_RESULT_ACCEPTED. IN_PROGRESS acks extend the wait.

        Raises
        ------
        CommandRejected
            Any other MAV_RESULT (``.result`` holds it).
        CommandTimeout
            No ack after ``attempts`` sends of ``timeout_s`` each.
        """
        if threading.current_thread() is self._thread:
            raise RuntimeError(
                "send_command called from the I/O thread (a callback): it would wait for its "
                "own ack; hand the work to another thread"
            )
        timeout_s = self.config.command_timeout_s if timeout_s is None else timeout_s
        attempts = self.config.command_attempts if attempts is None else attempts
        target = self._target()
        with self._command_lock:
            for attempt in range(attempts):
                with self._cond:
                    start_serial = self._ack_serial
                self._send(
                    commands.command_long(spec, target, self.config.target_component, attempt)
                )
                extensions = 0
                while True:
                    got: list[int] = []

                    def acked(serial: int = start_serial, out: list[int] = got) -> bool:
                        entry = self._acks.get(spec.command)
                        if entry is not None and entry[0] > serial:
                            out.append(entry[0])
                            out.append(entry[1])
                            return True
                        return False

                    if not self._wait_until(acked, timeout_s):
                        break
                    serial, result = got
                    if result == MAV_RESULT_ACCEPTED:
                        return result
                    if result == MAV_RESULT_IN_PROGRESS and extensions < MAX_IN_PROGRESS_EXTENSIONS:
                        extensions += 1
                        start_serial = serial
                        continue
                    raise CommandRejected(spec.command, result, result_name(result), spec.name)
            raise CommandTimeout(spec.command, spec.name, attempts, timeout_s)

    def request_message_interval(self, message: str | int, interval_s: float | None) -> None:
        """MAV_CMD_SET_MESSAGE_INTERVAL for a message name or id (None: default rate)."""
        if isinstance(message, str):
            msg_id = getattr(mavlink2, f"MAVLINK_MSG_ID_{message.upper()}", None)
            if msg_id is None:
                raise ConfigError(f"unknown MAVLink message {message!r}")
        else:
            msg_id = int(message)
        self.send_command(commands.message_interval(msg_id, interval_s))

    def set_parameter(self, name: str, value: float, *, timeout_s: float | None = None,
                      attempts: int | None = None) -> float:
        """PARAM_SET, confirmed by the vehicle's PARAM_VALUE echo; returns the value it holds.

        Raises
        ------
        CommandRejected
            When the vehicle echoes a different value (it clamped or refused it); the
            ``result`` is MAV_RESULT_DENIED.
        CommandTimeout
            When no echo comes back after the bounded retries.
        """
        timeout = self.config.command_timeout_s if timeout_s is None else timeout_s
        tries = self.config.command_attempts if attempts is None else attempts
        start = self._clock.now_s()

        def echoed() -> bool:
            record = self._store.get(f"ParamValue:{name}")
            return isinstance(record, ParamValue) and record.time_s >= start

        for _ in range(tries):
            self._send(commands.param_set(name, value, self._target(), 1))
            if self._wait_until(echoed, timeout):
                record = self._store[f"ParamValue:{name}"]
                assert isinstance(record, ParamValue)
                if not math.isclose(record.value, value, rel_tol=1e-6, abs_tol=1e-6):
                    raise CommandRejected(0, mavlink2.MAV_RESULT_DENIED, "DENIED", f"PARAM_SET {name}={value}")
                return record.value
        raise CommandTimeout(0, f"PARAM_SET {name}", tries, timeout)

    # ---- mission channel ---------------------------------------------------------------

    @contextlib.contextmanager
    def mission_channel(self) -> Iterator[MissionChannel]:
        """Hold the mission protocol for one transfer (queued MISSION_* messages)."""
        with self._mission_lock:
            with self._cond:
                self._mission_queue.clear()
                self._mission_active = True
            try:
                yield MissionChannel(self)
            finally:
                with self._cond:
                    self._mission_active = False
                    self._mission_queue.clear()

    def _next_mission_message(self, timeout_s: float) -> Any | None:
        if not self._wait_until(lambda: bool(self._mission_queue), timeout_s):
            return None
        with self._cond:
            return self._mission_queue.popleft()

    def _set_sticky_command(self, spec: commands.CommandSpec | None) -> None:
        """A command the I/O thread re-sends (unacknowledged) after every mode change."""
        with self._cond:
            self._sticky = spec
