"""vehicle_link figures: decode speed, command round trip, mission transfer, link loss.

Run: ``python -m benchmarks.bench_vehicle_link``. Uses the scripted loopback peer of the
tests (tests/vehicle_link/vl_peer.py), so it runs from the repository root.
"""

from __future__ import annotations

import platform
import statistics
import time

from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from tests.vehicle_link.vl_peer import ScriptedVehicle, make_config, wait_real
from vehicle_link.client import ArduSubClient
from vehicle_link.mission import waypoint
from vehicle_link.telemetry import Attitude, decode


def _decode_rate(n: int = 20000) -> float:
    tx = mavlink2.MAVLink(None, srcSystem=1, srcComponent=1)
    msgs = [
        mavlink2.MAVLink_attitude_message(i, 0.1, 0.2, 0.3, 0, 0, 0).pack(tx)
        if i % 2
        else mavlink2.MAVLink_global_position_int_message(i, 1, 2, 3, -4000, 0, 0, 0, 0).pack(tx)
        for i in range(n)
    ]
    blob = b"".join(msgs)
    rx = mavlink2.MAVLink(None)
    rx.robust_parsing = True
    t0 = time.perf_counter()
    parsed = rx.parse_buffer(blob) or []
    records = [decode(m, 0.0) for m in parsed]
    dt = time.perf_counter() - t0
    assert len(records) == n
    return n / dt


def _command_round_trips(client: ArduSubClient, n: int = 50) -> list[float]:
    out = []
    for i in range(n):
        t0 = time.perf_counter()
        if i % 2:
            client.disarm(confirm=False)
        else:
            client.arm(confirm=False)
        out.append((time.perf_counter() - t0) * 1000.0)
    return out


def _mission_time(client: ArduSubClient, n: int) -> float:
    items = [waypoint(47.6 + 1e-5 * i, -122.3, 5.0 + 0.1 * i) for i in range(n)]
    t0 = time.perf_counter()
    client.upload_mission(items, verify=True)
    return time.perf_counter() - t0


def _telemetry_rate(
    peer: ScriptedVehicle, client: ArduSubClient, n: int = 3000
) -> tuple[float, float]:
    """(delivered messages per second, fraction delivered) for a paced burst of ATTITUDE."""
    stamps: list[float] = []
    client.add_listener(
        lambda record: stamps.append(time.perf_counter()) if isinstance(record, Attitude) else None
    )
    t0 = time.perf_counter()
    for i in range(n):
        peer.send(mavlink2.MAVLink_attitude_message(i, 0.1, 0.2, 0.3, 0, 0, 0))
        if i % 50 == 49:
            time.sleep(0.002)  # offer ~20k msgs/s at most
    wait_real(lambda: len(stamps) >= n, 10.0)
    if not stamps:
        return 0.0, 0.0
    return len(stamps) / (stamps[-1] - t0), len(stamps) / n


def _link_loss_delay(peer: ScriptedVehicle) -> float:
    lost_at: list[float | None] = []
    client = ArduSubClient(
        make_config(peer, link_timeout_s=0.5), on_link_lost=lambda h: lost_at.append(h.silence_s)
    )
    try:
        client.connect(request_streams=False)
        peer.heartbeats = False
        wait_real(lambda: bool(lost_at), 5.0)
    finally:
        peer.heartbeats = True
        client.close()
    silence = lost_at[0] if lost_at else None
    return (silence - 0.5) * 1000.0 if silence is not None else float("nan")


def main() -> None:
    decode_rate = _decode_rate()
    peer = ScriptedVehicle()
    client = ArduSubClient(make_config(peer, command_timeout_s=1.0, mission_item_timeout_s=1.0))
    try:
        client.connect()
        rtt = _command_round_trips(client)
        m50 = _mission_time(client, 50)
        m200 = _mission_time(client, 200)
        telemetry, delivered = _telemetry_rate(peer, client)
    finally:
        client.close()
    loss_ms = _link_loss_delay(peer)
    peer.close()
    rtt.sort()
    print("## vehicle_link\n")
    print(
        f"Loopback UDP against the scripted test peer; Python {platform.python_version()}, "
        f"{platform.machine()}.\n"
    )
    print("| measure | figure |")
    print("| --- | --- |")
    print(f"| parse + decode (ATTITUDE/GLOBAL_POSITION_INT, no I/O) | {decode_rate:,.0f} msgs/s |")
    print(
        f"| telemetry through the link to a listener | {telemetry:,.0f} msgs/s "
        f"({delivered:.0%} of 3000 delivered) |"
    )
    print(
        f"| COMMAND_LONG -> COMMAND_ACK round trip | median {statistics.median(rtt):.2f} ms, "
        f"p95 {rtt[int(0.95 * len(rtt)) - 1]:.2f} ms |"
    )
    print(f"| mission upload + verify download, 50 items | {m50 * 1000:.0f} ms |")
    print(f"| mission upload + verify download, 200 items | {m200 * 1000:.0f} ms |")
    print(f"| link loss reported after the timeout | +{loss_ms:.0f} ms |")


if __name__ == "__main__":
    main()
