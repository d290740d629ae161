"""Link health, connection strings, MAVLink 2 on the wire, signing, garbage input."""

from __future__ import annotations

import socket
import threading

import numpy as np
import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from tests.vehicle_link.vl_peer import ManualClock, make_config, wait_real
from vehicle_link.clock import ScaledClock
from vehicle_link.errors import HeartbeatTimeout
from vehicle_link.signing import key_from_passphrase
from vehicle_link.telemetry import Attitude

KEY = key_from_passphrase("shadowsurvey test key")


def test_link_loss_and_recovery_reported_once_each(peer, client_factory):
    events: list[str] = []
    lost, restored = threading.Event(), threading.Event()

    def on_lost(health):
        events.append("lost")
        lost.set()

    def on_restored(health):
        events.append("restored")
        restored.set()

    client = client_factory(
        make_config(peer, link_timeout_s=1.0), on_link_lost=on_lost, on_link_restored=on_restored
    )
    client.connect()
    assert client.link_health().up is True
    peer.heartbeats = False
    assert lost.wait(5.0)
    assert client.link_health().up is False
    # silence continues for several more timeouts: still reported only once
    first_loss_at = client.link_health().last_heartbeat_s
    assert wait_real(lambda: client.link_health().silence_s > 2 * client.config.link_timeout_s)
    assert events == ["lost"]
    peer.heartbeats = True
    assert restored.wait(5.0)
    assert wait_real(lambda: client.link_health().last_heartbeat_s > first_loss_at + 0.5)
    assert events == ["lost", "restored"]
    health = client.link_health()
    assert (health.up, health.losses, health.restorations) == (True, 1, 1)


def test_link_loss_is_measured_on_the_injected_clock(peer, client_factory):
    clock = ManualClock()
    lost = threading.Event()
    client = client_factory(
        make_config(peer, link_timeout_s=5.0), clock=clock, on_link_lost=lambda h: lost.set()
    )
    client.open()
    assert wait_real(lambda: client.link_health().up is True)
    peer.heartbeats = False
    # real time passes but the injected clock does not: no loss
    assert not lost.wait(0.5)
    assert client.link_health().up is True
    clock.advance(5.5)
    assert lost.wait(5.0)
    assert client.link_health().silence_s == pytest.approx(5.5, abs=0.01)


def test_heartbeat_timeout_when_no_vehicle(client_factory):
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.bind(("127.0.0.1", 0))  # a silent port
    try:
        from vehicle_link.config import LinkConfig

        client = client_factory(
            LinkConfig(
                connection=f"udpout:127.0.0.1:{sock.getsockname()[1]}", connect_timeout_s=20.0
            ),
            clock=ScaledClock(100.0),
        )
        with pytest.raises(HeartbeatTimeout) as info:
            client.connect()
        assert info.value.timeout_s == 20.0
    finally:
        sock.close()


def test_non_submarine_heartbeats_are_not_a_vehicle(peer_factory, client_factory):
    peer = peer_factory(mav_type=mavlink2.MAV_TYPE_QUADROTOR)
    client = client_factory(make_config(peer, connect_timeout_s=0.5))
    with pytest.raises(HeartbeatTimeout):
        client.connect()
    assert client.target_system is None


def test_udpin_connection_string(peer_factory, client_factory):
    probe = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    probe.bind(("127.0.0.1", 0))
    port = probe.getsockname()[1]
    probe.close()
    from vehicle_link.config import LinkConfig

    client = client_factory(
        LinkConfig(
            connection=f"udpin:127.0.0.1:{port}", connect_timeout_s=3.0, message_intervals_s=()
        )
    )
    client.open()
    peer = peer_factory(client_udp_port=port)
    client.connect()
    client.arm()
    assert peer.armed


def test_tcp_connection_string(peer_factory, client_factory):
    peer = peer_factory(transport="tcp")
    from vehicle_link.config import LinkConfig

    client = client_factory(
        LinkConfig(
            connection=f"tcp:127.0.0.1:{peer.port}", connect_timeout_s=3.0, command_timeout_s=0.5
        )
    )
    client.connect()
    client.arm()
    assert peer.armed


def test_serial_connection_string(peer_factory, client_factory):
    pytest.importorskip("serial", reason="serial links need pyserial")
    from vehicle_link.config import LinkConfig

    peer = peer_factory(transport="pty")
    client = client_factory(
        LinkConfig(
            connection=peer.pty_name, baud=115200, connect_timeout_s=3.0, message_intervals_s=()
        )
    )
    client.connect()
    client.arm()
    assert peer.armed and client.armed is True


def test_everything_we_send_is_mavlink2(peer, client):
    client.arm()
    client.disarm()
    assert wait_real(lambda: len(peer.raw_in) >= 5)
    assert all(datagram[0] == 0xFD for datagram in list(peer.raw_in))


def test_signed_link_accepts_signed_traffic_and_signs_ours(peer_factory, client_factory):
    peer = peer_factory(signing_key=KEY)
    client = client_factory(make_config(peer, signing_key=KEY))
    client.connect()
    client.arm()
    assert peer.armed
    received = list(peer.received)
    assert received and all(m.get_signed() for m in received)
    assert client.stats().signature_rejects == 0


def test_signed_client_rejects_unsigned_vehicle(peer, client_factory):
    client = client_factory(make_config(peer, signing_key=KEY, connect_timeout_s=0.6))
    with pytest.raises(HeartbeatTimeout):
        client.connect()
    assert client.stats().signature_rejects > 0
    assert client.latest(Attitude) is None


def test_signed_client_rejects_wrong_key(peer_factory, client_factory):
    peer = peer_factory(signing_key=key_from_passphrase("another key"))
    client = client_factory(make_config(peer, signing_key=KEY, connect_timeout_s=0.6))
    with pytest.raises(HeartbeatTimeout):
        client.connect()
    assert client.stats().signature_rejects > 0


def test_unsigned_injection_ignored_on_signed_link(peer_factory, client_factory):
    peer = peer_factory(signing_key=KEY)
    client = client_factory(make_config(peer, signing_key=KEY))
    client.connect()
    intruder = mavlink2.MAVLink(None, srcSystem=1, srcComponent=1)
    fake = mavlink2.MAVLink_attitude_message(5, 1.0, 1.0, 1.0, 0, 0, 0).pack(intruder)
    peer.send_raw(fake)
    peer.send(mavlink2.MAVLink_attitude_message(6, 0.1, 0.2, 0.3, 0, 0, 0))
    assert wait_real(lambda: client.latest(Attitude) is not None)
    assert client.latest(Attitude).roll_rad == pytest.approx(0.1)
    assert client.stats().signature_rejects >= 1


def test_garbage_and_malformed_bytes_are_ignored(peer, client, rng: np.random.Generator):
    good = mavlink2.MAVLink_attitude_message(10, 0.25, -0.5, 1.0, 0, 0, 0)
    packed = good.pack(mavlink2.MAVLink(None, srcSystem=1, srcComponent=1))
    corrupted = bytearray(packed)
    corrupted[12] ^= 0xFF  # payload byte: CRC now fails
    for _ in range(20):
        peer.send_raw(
            rng.integers(0, 256, size=int(rng.integers(1, 300)), dtype=np.uint8).tobytes()
        )
    peer.send_raw(bytes(corrupted))
    peer.send_raw(packed[:7] + bytes(64))  # truncated frame, then zeros
    peer.send_raw(b"\xfd\xff" + bytes(300))  # header claiming a 255-byte payload, then zeros
    # an unknown message id with a valid frame shape
    peer.send_raw(bytes([0xFD, 1, 0, 0, 0, 1, 1, 0x39, 0x30, 0x00, 0x42, 0x00, 0x00]))
    peer.send(good)
    assert wait_real(
        lambda: (
            client.latest(Attitude) is not None
            and client.latest(Attitude).time_boot_s == pytest.approx(0.010)
        )
    )
    record = client.latest(Attitude)
    assert (record.roll_rad, record.pitch_rad, record.yaw_rad) == pytest.approx((0.25, -0.5, 1.0))
    assert client.stats().bad_data > 0
    client.arm()  # the link still works
    assert peer.armed


def test_the_io_thread_holds_a_lockstep_clock_before_open_returns():
    """In lockstep the I/O thread must be a participant before the caller goes on: else the
    simulator moves time on without it and the first replies arrive a scheduler-dependent
    number of steps late. The clock here
    lets the thread register only after a pause, which the old code raced past."""
    import socket
    import time
    from contextlib import contextmanager

    from sim_harness.clock import SimClock
    from vehicle_link.client import ArduSubClient
    from vehicle_link.config import LinkConfig

    class SlowToJoin(SimClock):
        # A lockstep clock without pollers, so the link runs its I/O thread (a SimClock's
        # pollers take the pass into the simulator's thread:
        # test_the_io_pass_is_a_lockstep_clocks_poller_before_open_returns).
        add_poller = None

        @contextmanager
        def participant(self, name=None):
            time.sleep(0.2)  # a thread that is slow to get the interpreter
            with super().participant(name) as clock:
                yield clock

    clock = SlowToJoin()
    peer = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    peer.bind(("127.0.0.1", 0))
    try:
        link = ArduSubClient(LinkConfig(f"udpout:127.0.0.1:{peer.getsockname()[1]}"), clock=clock)
        link.open()  # what connect() does first, before it waits on the clock for a heartbeat
        try:
            names = [p.name for p in clock._participants.values()]
            assert "vehicle_link-io" in names
        finally:
            link.close()
    finally:
        peer.close()
        clock.stop()


def test_the_io_pass_is_a_lockstep_clocks_poller_before_open_returns():
    """On a SimClock the I/O pass is a poller of the clock, registered before open()
    returns, with the I/O thread's period; a callback in that pass is refused a blocking
    command as it would be on the I/O thread; close() removes it."""
    import socket

    from sim_harness.clock import SimClock
    from vehicle_link.client import ArduSubClient
    from vehicle_link.config import LinkConfig

    clock = SimClock()
    peer = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    peer.bind(("127.0.0.1", 0))
    try:
        link = ArduSubClient(LinkConfig(f"udpout:127.0.0.1:{peer.getsockname()[1]}"), clock=clock)
        link.open()
        try:
            assert [p.name for p in clock._pollers] == ["vehicle_link-io"]
            assert clock._pollers[0].period_s == link.config.io_poll_s
            assert not clock._participants  # no thread of its own
            assert not link.in_io_pass()
            link._io._pass_thread = threading.get_ident()  # as inside the poller's pass
            with pytest.raises(RuntimeError, match="I/O thread"):
                link.arm()
            link._io._pass_thread = None
        finally:
            link.close()
        assert clock._pollers == []
    finally:
        peer.close()
        clock.stop()
