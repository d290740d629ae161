"""PARAM_SET with the PARAM_VALUE echo, against the simulated ArduSub (plain MAVLink on UDP)."""

from __future__ import annotations

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from sim_harness.clock import SimClock
from sim_harness.simulator import VehicleSimulator
from vehicle_link.client import ArduSubClient
from vehicle_link.config import LinkConfig
from vehicle_link.errors import CommandRejected, CommandTimeout


@pytest.fixture
def client():
    clock = SimClock()
    sim = VehicleSimulator(clock=clock, listen="udp:127.0.0.1:0")
    host, port = sim.address
    sim.start()
    try:
        with clock.participant("test"):
            link = ArduSubClient(LinkConfig(f"udpout:{host}:{port}", command_timeout_s=1.0, command_attempts=2),
                                 clock=clock)
            link.connect()
            try:
                yield link
            finally:
                link.close()
    finally:
        sim.stop()


def test_parameter_set_is_confirmed_by_the_echo(client):
    assert client.set_parameter("WPNAV_SPEED", 40.0) == pytest.approx(40.0)
    assert client.set_parameter("FS_GCS_ENABLE", 4) == pytest.approx(4.0)
    assert client.get_parameter("FS_GCS_ENABLE").value == pytest.approx(4.0)


def test_a_clamped_echo_is_a_refusal(client):
    """FS_GCS_ENABLE is an AP_Int8: ArduSub stores 300 as 127 and echoes 127. The echo
    differs from the value asked for, so the set is refused (DENIED), and the vehicle
    holds the clamped value."""
    with pytest.raises(CommandRejected) as info:
        client.set_parameter("FS_GCS_ENABLE", 300)
    assert info.value.result == mavlink2.MAV_RESULT_DENIED
    assert "FS_GCS_ENABLE" in str(info.value)
    held = client.get_parameter("FS_GCS_ENABLE")
    assert held.value == pytest.approx(127.0)
    assert held.param_type == mavlink2.MAV_PARAM_TYPE_INT8


def test_unknown_parameter_times_out_after_bounded_retries(client):
    with pytest.raises(CommandTimeout, match="PARAM_SET NO_SUCH_PARAM"):
        client.set_parameter("NO_SUCH_PARAM", 1.0)


def test_bad_names_and_values_are_refused_before_sending(client):
    with pytest.raises(ValueError, match="1-16 characters"):
        client.set_parameter("A_NAME_LONGER_THAN_16", 1.0)
    with pytest.raises(ValueError, match="finite"):
        client.set_parameter("WPNAV_SPEED", float("nan"))
