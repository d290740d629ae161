"""PARAM_SET with the PARAM_VALUE echo, against the simulated ArduSub (plain MAVLink on UDP)."""

from __future__ import annotations

import pytest

from sim_harness.clock import SimClock
from sim_harness.simulator import VehicleSimulator
from vehicle_link.client import ArduSubClient
from vehicle_link.config import LinkConfig
from vehicle_link.errors import CommandTimeout


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


def test_unknown_parameter_times_out_after_bounded_retries(client):
    with pytest.raises(CommandTimeout, match="PARAM_SET NO_SUCH_PARAM"):
        client.set_parameter("NO_SUCH_PARAM", 1.0)


def test_bad_names_and_values_are_refused_before_sending(client):
    with pytest.raises(ValueError, match="1-16 characters"):
        client.set_parameter("A_NAME_LONGER_THAN_16", 1.0)
    with pytest.raises(ValueError, match="finite"):
        client.set_parameter("WPNAV_SPEED", float("nan"))
