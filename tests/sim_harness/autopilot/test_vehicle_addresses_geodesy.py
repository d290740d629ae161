"""Link address parsing and ArduPilot's own NED <-> lat/lon arithmetic (property tests)."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from perception.geodesy import LocalOrigin
from sim_harness.autopilot.location import latlon_to_ned, ned_to_latlon
from sim_harness.autopilot.mavlink_endpoint import LinkAddress, open_transport
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


def test_one_arc_minute_north_is_arduPilots_sphere():
    # Location.h: LOCATION_SCALING_FACTOR = 0.011131884502145034 m per 1e-7 deg, so one
    # arc-minute is 1855.31 m whatever the latitude (the ellipsoid says 1853.3 m at 47 N).
    north, east = latlon_to_ned(47.0 + 1.0 / 60.0, 8.0, 47.0, 8.0)
    assert north == pytest.approx(1855.314, abs=1e-3)
    assert east == 0.0


@pytest.mark.parametrize("lat0", [0.0, 43.2951, 60.0])
def test_arduPilot_and_the_product_disagree_only_by_the_sphere_at_1_km(lat0):
    """The simulator reports what ArduSub reports (its flat earth); the product's pymap3d
    reads it back within the sphere-vs-ellipsoid difference: under 0.7 % at 1 km."""
    origin = LocalOrigin(lat0, 5.0)
    for north, east in ((1000.0, 0.0), (0.0, 1000.0), (707.1, 707.1)):
        lat, lon = ned_to_latlon(north, east, lat0, 5.0)
        n2, e2 = origin.to_local(lat, lon)
        assert math.hypot(float(n2) - north, float(e2) - east) < 7.0  # m over 1 km
        # and ArduPilot's own round trip is exact
        n3, e3 = latlon_to_ned(lat, lon, lat0, 5.0)
        assert n3 == pytest.approx(north, abs=1e-6) and e3 == pytest.approx(east, abs=1e-6)


@given(st.floats(-1000, 1000), st.floats(-1000, 1000), st.floats(-70, 70), st.floats(-179, 179))
def test_product_geodesy_round_trip_at_1_km(north_m, east_m, lat0, lon0):
    origin = LocalOrigin(lat0, lon0)
    lat, lon = origin.to_lat_lon(north_m, east_m)
    n2, e2 = origin.to_local(lat, lon)
    # Points go on the ellipsoid (height 0) and the tangent plane curves away: 12 um at 1 km.
    assert float(n2) == pytest.approx(north_m, abs=5e-5)
    assert float(e2) == pytest.approx(east_m, abs=5e-5)
