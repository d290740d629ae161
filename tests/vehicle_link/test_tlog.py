"""The session .tlog is readable by pymavlink's own tools (mavutil, mavlogdump)."""

from __future__ import annotations

import struct
import subprocess
import sys
import textwrap

from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from tests.vehicle_link.vl_peer import make_config, wait_real
from vehicle_link.telemetry import Attitude
from vehicle_link.tlog import TlogWriter

_READER = textwrap.dedent("""
    import sys
    from pymavlink import mavutil
    log = mavutil.mavlink_connection(sys.argv[1], dialect="ardupilotmega")
    while True:
        m = log.recv_match(blocking=False)
        if m is None:
            break
        print(m.get_type(), m.get_srcSystem(), m.get_srcComponent(), f"{m._timestamp:.6f}",
              getattr(m, "roll", ""))
""")


def test_session_tlog_read_back_by_mavutil_and_mavlogdump(peer, client_factory, tmp_path):
    path = tmp_path / "session.tlog"
    client = client_factory(make_config(peer, tlog_path=str(path)))
    client.connect()
    peer.send(mavlink2.MAVLink_attitude_message(1234, 0.125, 0.0, 0.0, 0, 0, 0))
    assert wait_real(lambda: client.latest(Attitude) is not None)
    client.arm()
    client.close()

    out = subprocess.run(
        [sys.executable, "-c", _READER, str(path)],
        capture_output=True,
        text=True,
        timeout=60,
        check=True,
    ).stdout.splitlines()
    rows = [line.split() for line in out]
    types = {(r[0], r[1], r[2]) for r in rows}
    assert ("HEARTBEAT", "1", "1") in types  # the vehicle's
    assert ("HEARTBEAT", "1", "191") in types  # ours
    assert ("COMMAND_LONG", "1", "191") in types and ("COMMAND_ACK", "1", "1") in types
    attitude = [r for r in rows if r[0] == "ATTITUDE"]
    assert len(attitude) == 1 and float(attitude[0][4]) == 0.125
    stamps = [float(r[3]) for r in rows]
    assert stamps == sorted(stamps) and stamps[0] > 1.6e9  # wall-anchored epoch seconds

    dump = subprocess.run(
        [sys.executable, "-m", "pymavlink.tools.mavlogdump", "--types", "ATTITUDE", str(path)],
        capture_output=True,
        text=True,
        timeout=60,
        check=True,
    ).stdout
    assert "ATTITUDE" in dump and "0.125" in dump


def test_tlog_record_layout_and_injected_clock_timestamps(tmp_path):
    from tests.vehicle_link.vl_peer import ManualClock

    clock = ManualClock(50.0)
    writer = TlogWriter(tmp_path / "x.tlog", clock)
    mav = mavlink2.MAVLink(None, srcSystem=1, srcComponent=191)
    a = mavlink2.MAVLink_heartbeat_message(18, 8, 0, 0, 4, 3).pack(mav)
    writer.write(a)
    clock.advance(2.5)
    writer.write(a)
    writer.close()
    data = (tmp_path / "x.tlog").read_bytes()
    assert len(data) == 2 * (8 + len(a))
    t0 = struct.unpack(">Q", data[:8])[0]
    t1 = struct.unpack(">Q", data[8 + len(a) : 16 + len(a)])[0]
    assert t1 - t0 == 2_500_000  # microseconds, from the injected clock
    assert data[8 : 8 + len(a)] == a
