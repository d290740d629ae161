"""Test helper: a scripted ArduSub-like MAVLink peer on loopback sockets (plain pymavlink).

It is NOT the simulated vehicle (sim_harness): it answers just enough of ArduSub's protocol
(heartbeats, COMMAND_ACK, the mission protocol as ArduPilot's MissionItemProtocol runs it)
and lets each test script faults: dropped acks, refusals, dropped or duplicated mission
messages, silence, garbage bytes, signing.
"""

from __future__ import annotations

import math
import os
import select
import socket
import threading
import time
import tty
from collections.abc import Callable
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from vehicle_link.config import LinkConfig

PEER_HEARTBEAT_PERIOD_S = 0.1
PEER_REREQUEST_S = 0.3  # ArduPilot re-requests a missing item after ~1 s; shortened here
WAIT_S = 5.0  # upper bound of every real-time wait in these tests


class ManualClock:
    """A clock that moves only when the test says so."""

    def __init__(self, start_s: float = 1000.0) -> None:
        self._t = start_s
        self._lock = threading.Lock()

    def now_s(self) -> float:
        with self._lock:
            return self._t

    def sleep_s(self, dt_s: float) -> None:
        self.advance(dt_s)

    def advance(self, dt_s: float) -> None:
        with self._lock:
            self._t += dt_s


def wait_real(predicate: Callable[[], bool], timeout_s: float = WAIT_S) -> bool:
    """Poll ``predicate`` every 5 ms of real time, at most ``timeout_s``."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(0.005)
    return predicate()


class ScriptedVehicle:
    """ArduSub-like peer (system 1, component 1) on a loopback UDP or TCP socket."""

    def __init__(
        self,
        *,
        transport: str = "udp",
        signing_key: bytes | None = None,
        system_id: int = 1,
        mav_type: int = mavlink2.MAV_TYPE_SUBMARINE,
        bind_port: int = 0,
        client_udp_port: int | None = None,
    ) -> None:
        self.transport = transport
        self.lock = threading.Lock()
        self.received: list[Any] = []
        self.raw_in: list[bytes] = []
        self.mav = mavlink2.MAVLink(self, srcSystem=system_id, srcComponent=1)
        self.mav.robust_parsing = True
        if signing_key is not None:
            self.mav.signing.secret_key = signing_key
            self.mav.signing.sign_outgoing = True
            self.mav.signing.link_id = 7
            self.mav.signing.timestamp = int((time.time() - 1420070400) * 100_000)
        self.mav_type = mav_type
        self.custom_mode = 19
        self.armed = False
        self.heartbeats = True
        self.apply_mode_changes = True
        self.apply_arming = True
        # command id -> list of scripted answers: an int MAV_RESULT, or None = stay silent
        self.command_script: dict[int, list[int | None]] = {}
        self.mission: list[Any] = []  # MISSION_ITEM_INT messages held
        self.use_request_int = False
        self.drop_item_once: set[int] = set()
        self.duplicate_requests = False
        self.drop_count_once = False
        self.drop_download_once: set[int] = set()
        self.mission_refusal: int | None = None
        self.answer_counts = True
        #: Read items back as ArduSub 4.5 stores them (AP_Mission::mission_cmd_to_mavlink_int):
        #: frames 3/10 for 6/11, altitude in whole cm, a NAV_WAYPOINT's params 2-4 zero.
        self.ardusub_readback = False
        # extra scripted reactions: message type -> callable(msg)
        self.on_message: dict[str, Callable[[Any], None]] = {}
        self.alter_item: Callable[[Any], None] | None = None
        self._upload_count: int | None = None
        self._upload_expected = 0
        self._upload_items: list[Any] = []
        self._last_request_s = 0.0
        self._client_addr: tuple[str, int] | None = None
        self._conn: socket.socket | None = None
        self.pty_name: str | None = None
        self._pty_fds: tuple[int, int] | None = None
        if transport == "pty":
            master, slave = os.openpty()
            tty.setraw(slave)  # no echo, no line discipline, before anyone writes
            self._pty_fds = (master, slave)
            self.pty_name = os.ttyname(slave)
            self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)  # unused placeholder
        elif transport == "udp":
            self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            self.sock.bind(("127.0.0.1", bind_port))
            if client_udp_port is not None:
                self._client_addr = ("127.0.0.1", client_udp_port)
        else:
            self.sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
            self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            self.sock.bind(("127.0.0.1", 0))
            self.sock.listen(1)
        self.port = self.sock.getsockname()[1]
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    # -- wire --
    def write(self, buf: bytes) -> None:
        try:
            if self._pty_fds is not None:
                os.write(self._pty_fds[0], buf)
            elif self.transport == "udp":
                if self._client_addr is not None:
                    self.sock.sendto(buf, self._client_addr)
            elif self._conn is not None:
                self._conn.sendall(buf)
        except OSError:
            pass

    def send(self, msg: Any) -> None:
        with self.lock:
            self.mav.send(msg)

    def send_raw(self, data: bytes) -> None:
        self.write(data)

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=WAIT_S)
        for s in (self._conn, self.sock):
            if s is not None:
                s.close()
        if self._pty_fds is not None:
            for fd in self._pty_fds:
                os.close(fd)

    def _run(self) -> None:
        next_hb = 0.0
        while not self._stop.is_set():
            now = time.monotonic()
            if self.heartbeats and now >= next_hb:
                next_hb = now + PEER_HEARTBEAT_PERIOD_S
                self.send_heartbeat()
            self._mission_timers(now)
            if self._pty_fds is not None:
                ready, _, _ = select.select([self._pty_fds[0]], [], [], 0.01)
                if ready:
                    try:
                        self._feed(os.read(self._pty_fds[0], 65535))
                    except OSError:
                        pass
                continue
            sock = self.sock
            if self.transport == "tcp":
                if self._conn is None:
                    r, _, _ = select.select([self.sock], [], [], 0.01)
                    if r:
                        self._conn, _ = self.sock.accept()
                    continue
                sock = self._conn
            r, _, _ = select.select([sock], [], [], 0.01)
            if not r:
                continue
            try:
                if self.transport == "udp":
                    data, addr = sock.recvfrom(65535)
                    self._client_addr = addr
                else:
                    data = sock.recv(65535)
            except OSError:
                continue
            self._feed(data)

    def _feed(self, data: bytes) -> None:
        self.raw_in.append(data)
        for msg in self.mav.parse_buffer(data) or []:
            if msg.get_type() == "BAD_DATA":
                continue
            with self.lock:
                self.received.append(msg)
            self._handle(msg)

    def send_heartbeat(self) -> None:
        base = mavlink2.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | (
            mavlink2.MAV_MODE_FLAG_SAFETY_ARMED if self.armed else 0
        )
        self.send(
            mavlink2.MAVLink_heartbeat_message(
                self.mav_type,
                mavlink2.MAV_AUTOPILOT_ARDUPILOTMEGA,
                base,
                self.custom_mode,
                mavlink2.MAV_STATE_STANDBY,
                3,
            )
        )

    # -- queries --
    def of_type(self, mtype: str) -> list[Any]:
        with self.lock:
            return [m for m in self.received if m.get_type() == mtype]

    def commands(self, command: int) -> list[Any]:
        return [m for m in self.of_type("COMMAND_LONG") if m.command == command]

    # -- behaviour --
    def _handle(self, msg: Any) -> None:
        mtype = msg.get_type()
        if mtype in self.on_message:
            self.on_message[mtype](msg)
        if mtype == "COMMAND_LONG":
            script = self.command_script.get(msg.command)
            if script:
                answer = script.pop(0)
            else:
                answer = mavlink2.MAV_RESULT_ACCEPTED
            if answer is None:
                return
            if answer == mavlink2.MAV_RESULT_ACCEPTED:
                self._apply(msg)
            self.send(
                mavlink2.MAVLink_command_ack_message(
                    msg.command, answer, 0, 0, msg.get_srcSystem(), msg.get_srcComponent()
                )
            )
            if answer == mavlink2.MAV_RESULT_ACCEPTED and msg.command in (
                mavlink2.MAV_CMD_DO_SET_MODE,
                mavlink2.MAV_CMD_COMPONENT_ARM_DISARM,
            ):
                self.send_heartbeat()
        elif mtype == "MISSION_COUNT":
            self._on_count(msg)
        elif mtype in ("MISSION_ITEM_INT", "MISSION_ITEM"):
            self._on_item(msg)
        elif mtype == "MISSION_REQUEST_LIST":
            self.send(
                mavlink2.MAVLink_mission_count_message(
                    msg.get_srcSystem(), msg.get_srcComponent(), len(self.mission), 0
                )
            )
        elif mtype in ("MISSION_REQUEST_INT", "MISSION_REQUEST"):
            if msg.seq in self.drop_download_once:
                self.drop_download_once.discard(msg.seq)
                return
            if 0 <= msg.seq < len(self.mission):
                item = self.mission[msg.seq]
                frame, z, params = item.frame, item.z, (item.param1, item.param2, item.param3, item.param4)
                if self.ardusub_readback:
                    frame = {6: 3, 11: 10, 5: 0}.get(frame, frame)
                    z = math.trunc(z * 100.0) / 100.0
                    if item.command == mavlink2.MAV_CMD_NAV_WAYPOINT:
                        params = (float(math.trunc(item.param1)), 0.0, 0.0, 0.0)
                self.send(
                    mavlink2.MAVLink_mission_item_int_message(
                        msg.get_srcSystem(), msg.get_srcComponent(), msg.seq, frame, item.command, 0,
                        1 if self.ardusub_readback else item.autocontinue, *params, item.x, item.y, z, 0,
                    )
                )
        elif mtype == "MISSION_CLEAR_ALL":
            self.mission = []
            self.send(
                mavlink2.MAVLink_mission_ack_message(
                    msg.get_srcSystem(), msg.get_srcComponent(), mavlink2.MAV_MISSION_ACCEPTED, 0
                )
            )

    def _apply(self, msg: Any) -> None:
        if msg.command == mavlink2.MAV_CMD_COMPONENT_ARM_DISARM and self.apply_arming:
            self.armed = msg.param1 > 0.5
        elif msg.command == mavlink2.MAV_CMD_DO_SET_MODE and self.apply_mode_changes:
            self.custom_mode = int(msg.param2)

    def _request(self, seq: int) -> None:
        cls = (
            mavlink2.MAVLink_mission_request_int_message
            if self.use_request_int
            else mavlink2.MAVLink_mission_request_message
        )
        for _ in range(2 if self.duplicate_requests else 1):
            self.send(cls(1, 191, seq, 0))
        self._last_request_s = time.monotonic()

    def _on_count(self, msg: Any) -> None:
        if not self.answer_counts:
            return
        if self.drop_count_once:
            self.drop_count_once = False
            return
        if self.mission_refusal is not None:
            self.send(mavlink2.MAVLink_mission_ack_message(1, 191, self.mission_refusal, 0))
            return
        self._upload_count = msg.count
        self._upload_expected = 0
        self._upload_items = []
        if msg.count == 0:
            self.mission = []
            self.send(
                mavlink2.MAVLink_mission_ack_message(1, 191, mavlink2.MAV_MISSION_ACCEPTED, 0)
            )
            self._upload_count = None
            return
        self._request(0)

    def _on_item(self, msg: Any) -> None:
        if self._upload_count is None:
            return
        if self.alter_item is not None:
            self.alter_item(msg)
        if msg.seq != self._upload_expected:
            self.send(
                mavlink2.MAVLink_mission_ack_message(
                    1, 191, mavlink2.MAV_MISSION_INVALID_SEQUENCE, 0
                )
            )
            return
        if msg.seq in self.drop_item_once:
            self.drop_item_once.discard(msg.seq)
            return  # "lost on the way": the re-request timer will ask again
        self._upload_items.append(msg)
        self._upload_expected += 1
        if self._upload_expected == self._upload_count:
            self.mission = list(self._upload_items)
            self._upload_count = None
            self.send(
                mavlink2.MAVLink_mission_ack_message(1, 191, mavlink2.MAV_MISSION_ACCEPTED, 0)
            )
            return
        self._request(self._upload_expected)

    def _mission_timers(self, now: float) -> None:
        if self._upload_count is not None and now - self._last_request_s > PEER_REREQUEST_S:
            self._request(self._upload_expected)


def make_config(peer: ScriptedVehicle, **overrides: Any) -> LinkConfig:
    """A fast LinkConfig talking to ``peer`` over udpout."""
    settings: dict[str, Any] = dict(
        connection=f"udpout:127.0.0.1:{peer.port}",
        heartbeat_period_s=0.1,
        link_timeout_s=0.6,
        connect_timeout_s=3.0,
        command_timeout_s=0.8,
        command_attempts=3,
        state_confirm_timeout_s=1.0,
        mission_item_timeout_s=0.4,
        mission_retries=4,
        message_intervals_s=(("ATTITUDE", 0.1),),
    )
    settings.update(overrides)
    return LinkConfig(**settings)
