"""Link address parsing and the flat-earth NED <-> lat/lon conversion (property tests)."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from sim_harness.autopilot.mavlink_endpoint import LinkAddress, open_transport
from sim_harness.autopilot.telemetry import latlon_to_ned, ned_to_latlon
from sim_harness.errors import LinkAddressError

hosts = st.from_regex(r"[a-z0-9][a-z0-9.\-]{0,20}", fullmatch=True)


@given(st.sampled_from(["udp", "tcp", "UDP", "udpin", "tcpin"]), hosts,
       st.integers(0, 65535))
def test_address_round_trip(kind, host, port):
    addr = LinkAddress.parse(f"{kind}:{host}:{port}")
    assert addr.kind in ("udp", "tcp") and addr.host == host and addr.port == port
    assert LinkAddress.parse(str(addr)) == addr


@pytest.mark.parametrize("text, why", [
    ("udp:127.0.0.1", "expected KIND:HOST:PORT"),
    ("serial:ttyS0:57600", "kind must be udp or tcp"),
    ("udp:127.0.0.1:port", "is not a number"),
    ("tcp:127.0.0.1:70000", "out of range"),
    ("udp::14550", "host is empty"),
])
def test_bad_addresses_are_refused_with_the_reason(text, why):
    with pytest.raises(LinkAddressError, match=why):
        LinkAddress.parse(text)


def test_binding_a_port_in_use_names_the_address():
    first = open_transport("udp:127.0.0.1:0")
    try:
        port = first.bound_address[1]
        with pytest.raises(LinkAddressError, match=f"udp:127.0.0.1:{port}"):
            open_transport(f"udp:127.0.0.1:{port}")
    finally:
        first.close()


@given(st.floats(-2000, 2000), st.floats(-2000, 2000), st.floats(-70, 70), st.floats(-179, 179))
def test_ned_latlon_round_trip(north_m, east_m, lat0, lon0):
    lat, lon = ned_to_latlon(north_m, east_m, lat0, lon0)
    n2, e2 = latlon_to_ned(lat, lon, lat0, lon0)
    assert n2 == pytest.approx(north_m, abs=1e-6)
    assert e2 == pytest.approx(east_m, abs=1e-6)


def test_one_arc_minute_north_is_a_nautical_mile_on_this_sphere():
    north, east = latlon_to_ned(47.0 + 1.0 / 60.0, 8.0, 47.0, 8.0)
    assert north == pytest.approx(1855.3, abs=0.5)  # 6378137 m sphere
    assert east == 0.0
