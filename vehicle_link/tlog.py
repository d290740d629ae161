"""Telemetry log in pymavlink's .tlog format, readable by mavlogdump and MAVExplorer.

Each record is an 8-byte big-endian timestamp in microseconds since the Unix epoch
followed by the raw bytes of one MAVLink message. Timestamps come from the injected
clock, anchored to the wall-clock date at opening: ``unix_at_open + (now - clock_at_open)``,
so a simulated dive that runs faster than real time still has consistent time stamps.
Each record is flushed as it is written, so a crash leaves a complete file behind.
"""

from __future__ import annotations

import struct
import threading
import time
from pathlib import Path

from vehicle_link.clock import Clock

_TIMESTAMP = struct.Struct(">Q")


class TlogWriter:
    """Append MAVLink messages to a .tlog file.

    Parameters
    ----------
    path : str or Path
        File to create (truncated if it exists); its folder must exist.
    clock : Clock
        The injected clock whose time stamps the records.
    """

    def __init__(self, path: str | Path, clock: Clock) -> None:
        self.path = Path(path)
        if not self.path.parent.is_dir():
            raise FileNotFoundError(f"tlog folder {self.path.parent} does not exist")
        self._clock = clock
        self._clock_at_open_s = clock.now_s()
        self._unix_at_open_s = time.time()
        self._lock = threading.Lock()
        self._file = open(self.path, "wb")  # noqa: SIM115 - closed in close()
        self.records_written = 0

    def timestamp_us(self) -> int:
        """Time stamp for a record written now, microseconds since the Unix epoch."""
        elapsed_s = self._clock.now_s() - self._clock_at_open_s
        return max(0, int((self._unix_at_open_s + elapsed_s) * 1.0e6))

    def write(self, msgbuf: bytes | bytearray) -> None:
        """Write one message's raw bytes with the current time stamp.

        The stamp is taken under the file lock, so records from several threads stay in
        time order.
        """
        payload = bytes(msgbuf)
        with self._lock:
            if self._file.closed:
                return
            self._file.write(_TIMESTAMP.pack(self.timestamp_us()) + payload)
            self._file.flush()
            self.records_written += 1

    def close(self) -> None:
        """Close the file (further writes are ignored)."""
        with self._lock:
            if not self._file.closed:
                self._file.close()
