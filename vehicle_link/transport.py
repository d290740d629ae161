"""Thin I/O layer: open a pymavlink connection and speak MAVLink 2 on it.

The connection string is parsed by ``mavutil.mavlink_connection`` (udpin, udpout, tcp,
tcpin, serial). Its protocol object is then replaced by our own MAVLink 2 ``MAVLink`` from
:mod:`vehicle_link.dialect`, with robust parsing on, so garbage bytes become BAD_DATA
instead of exceptions, and mavutil's automatic protocol switching (which writes the
MAVLINK20 environment variable process-wide) is switched off.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any

from pymavlink import mavutil

from vehicle_link.dialect import mavlink2
from vehicle_link.errors import ConfigError

_READ_CHUNK = 4096
_MAX_READS_PER_PASS = 64  # datagrams/chunks drained per pass before timers run again


def parse_bytes(mav: Any, data: bytes) -> list[Any]:
    """Feed bytes to a robust-parsing ``MAVLink`` object; return every message completed.

    Never raises for bad input: garbage, bad CRCs, bad signatures and truncated frames come
    back as BAD_DATA messages (unknown ids as UNKNOWN_n), so the caller can count them.
    """
    msgs = mav.parse_buffer(data)
    return list(msgs) if msgs else []


class MavlinkTransport:
    """One MAVLink 2 connection: ``send(msg)`` and ``receive(wait_s) -> list[msg]``.

    Parameters
    ----------
    connection : str
        pymavlink connection string.
    source_system, source_component : int
        Our MAVLink ids.
    baud : int
        Serial baud rate (ignored for sockets).
    on_bytes_sent : callable or None
        Called with the raw bytes of every message sent (for the tlog).
    """

    def __init__(
        self,
        connection: str,
        source_system: int,
        source_component: int,
        *,
        baud: int = 115200,
        on_bytes_sent: Callable[[bytes], None] | None = None,
    ) -> None:
        try:
            self._conn: Any = mavutil.mavlink_connection(
                connection,
                baud=baud,
                source_system=source_system,
                source_component=source_component,
                dialect="ardupilotmega",
                autoreconnect=True,
            )
        except ModuleNotFoundError as exc:
            raise ConfigError(
                f"cannot open MAVLink connection {connection!r}: {exc.name} is not installed "
                "(serial links need pyserial)"
            ) from exc
        except (OSError, ValueError) as exc:
            raise ConfigError(f"cannot open MAVLink connection {connection!r}: {exc}") from exc
        mav = mavlink2.MAVLink(self._conn, srcSystem=source_system, srcComponent=source_component)
        mav.robust_parsing = True
        self._conn.mav = mav
        self._conn.WIRE_PROTOCOL_VERSION = "2.0"
        self._conn.first_byte = False  # no auto protocol switch (it edits os.environ)
        self.mav = mav
        self._send_lock = threading.Lock()
        self._on_bytes_sent = on_bytes_sent
        self.connection = connection

    def send(self, msg: Any) -> bytes:
        """Pack (sign if signing is on) and send one message; return its bytes."""
        with self._send_lock:
            buf = bytes(msg.pack(self.mav))
            self.mav.seq = (self.mav.seq + 1) % 256
            self.mav.total_packets_sent += 1
            self.mav.total_bytes_sent += len(buf)
            self._conn.write(buf)
        if self._on_bytes_sent is not None:
            self._on_bytes_sent(buf)
        return buf

    def receive(self, wait_s: float) -> list[Any]:
        """Wait up to ``wait_s`` real seconds for bytes; return the messages parsed.

        BAD_DATA entries (garbage, bad CRC, rejected signatures) are returned too, for
        counting; callers must not dispatch them.
        """
        conn = self._conn
        if self.mav.buf_len() == 0 and not conn.select(wait_s):
            return []
        out: list[Any] = []
        for _ in range(_MAX_READS_PER_PASS):
            try:
                data = conn.recv(_READ_CHUNK)
            except OSError:
                break
            if isinstance(data, str):
                data = data.encode("latin-1")
            out.extend(parse_bytes(self.mav, data or b""))
            if not data:
                break
        return out

    def close(self) -> None:
        """Close the socket or serial port."""
        try:
            self._conn.close()
        except OSError:
            pass
