"""Drive MAVProxy 1.8.75 (an independent ground station) and ``shadowsurvey sim-vehicle`` from a test.

MAVProxy runs interactive with stdin and stdout piped (``--non-interactive`` stops reading
stdin, and ``--cmd`` runs before a vehicle is seen); a reader thread collects its lines and
each step sends one command and waits, with a timeout, for a pattern in the lines printed
after it. State is read by asking (``status HEARTBEAT``; ``watch PARAM_VALUE`` with ``param
fetch`` for the type, which MAVProxy does not decode for ArduPilot), not from MAVProxy's
announcements, which are throttled (``Mode X`` at most every 2 s). Its prompt (``MANUAL> ``)
is printed without a newline, so patterns are searched, never anchored.

MAVProxy is installed with ``pip install --no-deps MAVProxy==1.8.75`` (its full dependency
set replaces the headless OpenCV and adds vtk); a missing MAVProxy fails the test.
"""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Sequence
from pathlib import Path

import pytest

HEARTBEAT_RE = r"HEARTBEAT \{type : (\d+), autopilot : (\d+), base_mode : (\d+), custom_mode : (\d+)"
MAV_MODE_FLAG_SAFETY_ARMED = 128
#: pymavlink's ``mode_mapping_sub`` (it has no SURFTRAK 21).
SUB_MODES = {"STABILIZE": 0, "ACRO": 1, "ALT_HOLD": 2, "AUTO": 3, "GUIDED": 4, "CIRCLE": 7, "SURFACE": 9,
             "POSHOLD": 16, "MANUAL": 19}
#: A headless test's modules: no ftp (parameters by PARAM_REQUEST_LIST at once), nothing
#: that wants a display, writes tile caches or sends RC overrides.
TEST_MODULES = "wp,param,arm,mode,cmdlong,misc,fence"
INSTALL = "pip install --no-deps MAVProxy==1.8.75"


def console_script(name: str, *, install_hint: str) -> str:
    """The path of a console script of this venv; fails the test (not a skip) if absent."""
    path = Path(sys.executable).with_name(name)
    if not path.exists():
        pytest.fail(f"{name} is not installed in this environment; install it with: {install_hint}", pytrace=False)
    return str(path)


class Lines:
    """The lines of a text stream, collected by a thread; waits for patterns."""

    def __init__(self, stream: object) -> None:
        self.lines: list[str] = []
        self._cond = threading.Condition()
        self._closed = False
        self._thread = threading.Thread(target=self._read, args=(stream,), daemon=True)
        self._thread.start()

    def join(self, timeout_s: float = 5.0) -> None:
        """Wait for the end of the stream (the process has exited)."""
        self._thread.join(timeout_s)

    def _read(self, stream: object) -> None:
        for line in stream:  # type: ignore[attr-defined]
            with self._cond:
                self.lines.append(line.rstrip("\n"))
                self._cond.notify_all()
        with self._cond:
            self._closed = True
            self._cond.notify_all()

    def mark(self) -> int:
        with self._cond:
            return len(self.lines)

    def expect(self, pattern: str, timeout_s: float, since: int = 0) -> re.Match[str]:
        """The first match of ``pattern`` in the lines from ``since``; AssertionError on timeout."""
        rx = re.compile(pattern)
        deadline = time.monotonic() + timeout_s
        i = since
        with self._cond:
            while True:
                while i < len(self.lines):
                    m = rx.search(self.lines[i])
                    i += 1
                    if m:
                        return m
                left = deadline - time.monotonic()
                if left <= 0 or self._closed:
                    tail = "\n".join(self.lines[-15:])
                    raise AssertionError(f"no line matching {pattern!r} within {timeout_s} s; last lines:\n{tail}")
                self._cond.wait(left)

    def text_since(self, since: int) -> str:
        with self._cond:
            return "\n".join(self.lines[since:])


def stop(proc: subprocess.Popen, first: int = signal.SIGINT, wait_s: float = 5.0) -> None:
    """Stop one process this test started: a polite signal, then SIGKILL."""
    if proc.poll() is not None:
        return
    proc.send_signal(first)
    try:
        proc.wait(wait_s)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait(wait_s)


class SimVehicle:
    """``shadowsurvey sim-vehicle`` on a free loopback UDP port (read back from its stderr)."""

    def __init__(self, args: Sequence[str] = ()) -> None:
        cmd = [sys.executable, "-m", "planner.cli", "sim-vehicle", "--listen", "udp:127.0.0.1:0", *args]
        self.proc = subprocess.Popen(cmd, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                     stderr=subprocess.PIPE, text=True, bufsize=1)
        self.err = Lines(self.proc.stderr)
        self.port = int(self.err.expect(r"MAVLink 2 on udp:127\.0\.0\.1:(\d+)", timeout_s=60).group(1))

    @property
    def master(self) -> str:
        return f"udpout:127.0.0.1:{self.port}"

    def close(self) -> None:
        stop(self.proc)
        self.err.join()
        assert self.proc.stderr is not None
        self.proc.stderr.close()


class MAVProxy:
    """MAVProxy with piped stdin/stdout, its state kept out of the cwd and $HOME."""

    def __init__(self, master: str, workdir: Path) -> None:
        script = console_script("mavproxy.py", install_hint=INSTALL)
        home = workdir / "home"  # ~/.mavinit.scr, ~/.mavproxy, the matplotlib config
        home.mkdir(parents=True, exist_ok=True)
        env = dict(os.environ, HOME=str(home), PYTHONUNBUFFERED="1", MPLBACKEND="Agg")
        env.pop("DISPLAY", None)
        cmd = [sys.executable, "-u", script, f"--master={master}", "--no-state", f"--default-modules={TEST_MODULES}"]
        self.proc = subprocess.Popen(cmd, cwd=workdir, env=env, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                     stderr=subprocess.STDOUT, text=True, bufsize=1)
        self.out = Lines(self.proc.stdout)

    def send(self, command: str) -> int:
        """Send one command line; returns the mark to wait from."""
        mark = self.out.mark()
        assert self.proc.stdin is not None
        self.proc.stdin.write(command + "\n")
        self.proc.stdin.flush()
        return mark

    def expect(self, pattern: str, timeout_s: float, since: int = 0) -> re.Match[str]:
        return self.out.expect(pattern, timeout_s, since)

    def command(self, command: str, pattern: str, timeout_s: float) -> re.Match[str]:
        return self.expect(pattern, timeout_s, since=self.send(command))

    def wait_ready(self, timeout_s: float = 30.0) -> None:
        """The vehicle seen and its whole parameter list received."""
        self.expect(r"Detected vehicle \d+:\d+ on link", timeout_s)
        self.expect(r"Received \d+ parameters", timeout_s)

    def heartbeat(self) -> tuple[int, int]:
        """(base_mode, custom_mode) of the newest vehicle HEARTBEAT."""
        m = self.command("status HEARTBEAT", HEARTBEAT_RE, 5.0)
        return int(m.group(3)), int(m.group(4))

    def wait_heartbeat(self, pred: Callable[[int, int], bool], timeout_s: float) -> tuple[int, int]:
        deadline = time.monotonic() + timeout_s
        while True:
            hb = self.heartbeat()
            if pred(*hb):
                return hb
            if time.monotonic() > deadline:
                raise AssertionError(f"heartbeat (base_mode, custom_mode) stayed {hb}")
            time.sleep(0.25)

    def set_mode(self, name: str) -> None:
        mark = self.send(f"mode {name}")
        if self.heartbeat()[1] != SUB_MODES[name]:
            self.expect(r"Got COMMAND_ACK: DO_SET_MODE: ACCEPTED", 5.0, since=mark)
            self.wait_heartbeat(lambda _b, c: c == SUB_MODES[name], 5.0)

    def arm(self, *, force: bool = False) -> None:
        self.command("arm throttle force" if force else "arm throttle",
                     r"Got COMMAND_ACK: COMPONENT_ARM_DISARM: ACCEPTED", 5.0)
        self.wait_heartbeat(lambda b, _c: bool(b & MAV_MODE_FLAG_SAFETY_ARMED), 5.0)

    def disarm(self, *, force: bool = False) -> None:
        self.command("disarm force" if force else "disarm", r"Got COMMAND_ACK: COMPONENT_ARM_DISARM: ACCEPTED", 5.0)
        self.wait_heartbeat(lambda b, _c: not b & MAV_MODE_FLAG_SAFETY_ARMED, 5.0)

    def param(self, name: str) -> tuple[float, int]:
        """(value, MAV_PARAM_TYPE) read fresh from the vehicle."""
        self.send("watch PARAM_VALUE")
        m = self.command(f"param fetch {name}", rf"< PARAM_VALUE \{{param_id : {re.escape(name)}, "
                                                r"param_value : ([-0-9.e+]+), param_type : (\d+)", 5.0)
        self.send("watch")  # no pattern: stop watching
        return float(m.group(1)), int(m.group(2))

    def wp_load(self, path: Path) -> int:
        """Upload a ``.waypoints`` file; returns the number of items (home included)."""
        mark = self.send(f"wp load {path}")
        n = int(self.expect(r"Loaded (\d+) waypoints from", 10.0, since=mark).group(1))
        ack = self.expect(r"Got MISSION_ACK: TYPE_MISSION: (\w+)", 60.0, since=mark).group(1)
        assert ack == "ACCEPTED", f"MISSION_ACK {ack}"
        return n

    def wp_save(self, path: Path) -> int:
        """Download the mission into ``path`` (``wp list`` prints no end line with --no-state)."""
        return int(self.command(f"wp save {path}", rf"Saved (\d+) waypoints to {re.escape(str(path))}", 60.0).group(1))

    def close(self) -> None:
        if self.proc.poll() is None:
            try:
                self.send("exit")  # exits (status 1, always) once stdin is at EOF too
                assert self.proc.stdin is not None
                self.proc.stdin.close()
                self.proc.wait(5)
            except (BrokenPipeError, subprocess.TimeoutExpired):
                stop(self.proc, signal.SIGTERM)
        self.out.join()
        for stream in (self.proc.stdin, self.proc.stdout):
            if stream is not None and not stream.closed:
                try:
                    stream.close()
                except BrokenPipeError:
                    pass


def read_waypoints(path: Path) -> list[list[float]]:
    """The rows of a QGC WPL 110 file as numbers."""
    rows = path.read_text().splitlines()
    assert rows[0].startswith("QGC WPL 110"), rows[0]
    return [[float(x) for x in row.split("\t")] for row in rows[1:] if row.strip()]
