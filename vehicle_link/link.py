"""VehicleLink: one MAVLink 2 link to one vehicle - the request/response protocols.

On top of :class:`vehicle_link.link_core.LinkCore` (I/O thread, clock, heartbeats, link
health, telemetry store; its threading notes apply): COMMAND_LONG with its COMMAND_ACK
and bounded retries, MAV_CMD_SET_MESSAGE_INTERVAL and REQUEST_MESSAGE, parameters
(PARAM_REQUEST_READ, PARAM_SET confirmed by the echo) and the mission channel the
mission transfers run over. ArduSub-specific commands live in
:class:`vehicle_link.client.ArduSubClient`, which subclasses this.
"""

from __future__ import annotations

import contextlib
import logging
import math
from collections.abc import Iterator
from typing import Any, Self

from vehicle_link import commands
from vehicle_link.dialect import mavlink2
from vehicle_link.errors import CommandRejected, CommandTimeout, ConfigError, HeartbeatTimeout
from vehicle_link.link_core import LinkCore, LinkHealth, LinkStats
from vehicle_link.telemetry import Heartbeat, ParamValue

__all__ = ["LinkHealth", "LinkStats", "MissionChannel", "VehicleLink", "result_name"]

_log = logging.getLogger(__name__)

MAV_RESULT_ACCEPTED = mavlink2.MAV_RESULT_ACCEPTED
MAV_RESULT_IN_PROGRESS = mavlink2.MAV_RESULT_IN_PROGRESS
MAX_IN_PROGRESS_EXTENSIONS = 20


def result_name(result: int) -> str:
    """Name of a MAV_RESULT."""
    entry = mavlink2.enums["MAV_RESULT"].get(result)
    return entry.name if entry is not None else f"MAV_RESULT({result})"


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


class VehicleLink(LinkCore):
    """MAVLink 2 link to one vehicle (same constructor as :class:`LinkCore`)."""

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

    def __enter__(self) -> Self:
        self.connect()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

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
        if self.in_io_pass():
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

    def get_parameter(self, name: str, *, timeout_s: float | None = None,
                      attempts: int | None = None) -> ParamValue:
        """PARAM_REQUEST_READ by name; the vehicle's PARAM_VALUE (with its type).

        Raises
        ------
        CommandTimeout
            No answer after the bounded retries (ArduSub does not answer an unknown name).
        """
        timeout = self.config.command_timeout_s if timeout_s is None else timeout_s
        tries = self.config.command_attempts if attempts is None else attempts
        start = self._clock.now_s()

        def answered() -> bool:
            record = self._store.get(f"ParamValue:{name}")
            return isinstance(record, ParamValue) and record.time_s >= start

        for _ in range(tries):
            self._send(mavlink2.MAVLink_param_request_read_message(
                self._target(), self.config.target_component, name.encode("ascii"), -1))
            if self._wait_until(answered, timeout):
                record = self._store[f"ParamValue:{name}"]
                assert isinstance(record, ParamValue)
                return record
        raise CommandTimeout(0, f"PARAM_REQUEST_READ {name}", tries, timeout)

    def request_message(self, message_id: int) -> None:
        """MAV_CMD_REQUEST_MESSAGE (acknowledged; the message itself arrives as telemetry)."""
        self.send_command(commands.request_message(message_id))

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
