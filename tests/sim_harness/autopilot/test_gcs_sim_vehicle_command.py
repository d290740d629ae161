"""``shadowsurvey sim-vehicle`` serves a sub that plain mavutil connects to (UDP and TCP)."""

from __future__ import annotations

import socket
import threading

import pytest
from pymavlink import mavutil
from pymavlink.dialects.v20 import ardupilotmega as M  # MAVLink 2 messages

from planner.cli import main

#: Wall-clock limits for this real-time test (the command runs paced, not in lockstep).
WAIT_WALL_S = 10.0
HEARTBEAT_WALL_S = 1.0


def _free_port(kind: int) -> int:
    with socket.socket(socket.AF_INET, kind) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _start(argv: list[str]) -> tuple[threading.Thread, dict]:
    result: dict = {}
    th = threading.Thread(target=lambda: result.setdefault("code", main(argv)), daemon=True)
    th.start()
    return th, result


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["udp", "tcp"])
def test_sim_vehicle_command_serves_a_submarine(kind):
    port = _free_port(socket.SOCK_DGRAM if kind == "udp" else socket.SOCK_STREAM)
    th, result = _start(["sim-vehicle", "--listen", f"{kind}:127.0.0.1:{port}",
                         "--duration-s", "20", "--speedup", "10", "--start-depth-m", "2"])
    url = f"udpout:127.0.0.1:{port}" if kind == "udp" else f"tcp:127.0.0.1:{port}"
    conn = mavutil.mavlink_connection(url, source_system=255, source_component=190,
                                      dialect="ardupilotmega", retries=20)
    try:
        hb = None
        for _ in range(int(WAIT_WALL_S / HEARTBEAT_WALL_S)):  # a GCS says hello at 1 Hz
            conn.mav.heartbeat_send(M.MAV_TYPE_GCS, M.MAV_AUTOPILOT_INVALID, 0, 0, 0)
            hb = conn.recv_match(type="HEARTBEAT", blocking=True, timeout=HEARTBEAT_WALL_S)
            if hb is not None and hb.get_srcComponent() == 1:  # not BlueOS's services (component 194)
                break
        assert hb is not None and hb.type == M.MAV_TYPE_SUBMARINE
        conn.mav.command_long_send(1, 1, M.MAV_CMD_DO_SET_MODE, 0,
                                   M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 2, 0, 0, 0, 0, 0)
        ack = conn.recv_match(type="COMMAND_ACK", blocking=True, timeout=WAIT_WALL_S)
        assert ack is not None and ack.result == M.MAV_RESULT_ACCEPTED
        att = conn.recv_match(type="ATTITUDE", blocking=True, timeout=WAIT_WALL_S)
        assert att is not None
    finally:
        conn.close()
    th.join(WAIT_WALL_S * 3)
    assert not th.is_alive()
    assert result["code"] == 0


def test_sim_vehicle_command_rejects_a_bad_address(capsys):
    assert main(["sim-vehicle", "--listen", "serial:ttyS0:57600", "--duration-s", "1"]) == 2
    assert "kind must be udp or tcp" in capsys.readouterr().err
    assert main(["sim-vehicle", "--speedup", "-1", "--duration-s", "1"]) == 2


@pytest.mark.slow
def test_sim_vehicle_runs_until_interrupted_and_exits_cleanly():
    import select
    import signal
    import subprocess
    import sys

    proc = subprocess.Popen(
        [sys.executable, "-m", "planner.cli", "sim-vehicle", "--listen", "udp:127.0.0.1:0"],
        stderr=subprocess.PIPE, text=True)
    try:
        ready, _, _ = select.select([proc.stderr], [], [], WAIT_WALL_S * 3)
        assert ready, "sim-vehicle did not announce its address"
        assert "MAVLink 2 on udp:127.0.0.1:" in proc.stderr.readline()
        proc.send_signal(signal.SIGINT)
        assert proc.wait(timeout=WAIT_WALL_S) == 0
        assert "interrupted" in proc.stderr.read()
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(timeout=WAIT_WALL_S)
        assert proc.stderr is not None
        proc.stderr.close()
