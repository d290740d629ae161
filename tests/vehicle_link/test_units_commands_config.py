"""Unit conversions (property tests), message builders, settings validation."""

from __future__ import annotations

import math
from typing import Any

import pytest
from hypothesis import given
from hypothesis import strategies as st
from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from vehicle_link import commands, units
from vehicle_link.clock import ScaledClock, WallClock
from vehicle_link.config import AltimeterFeed, LinkConfig
from vehicle_link.errors import ConfigError
from vehicle_link.modes import SubMode, mode_name, parse_mode
from vehicle_link.signing import key_from_hex, key_from_passphrase

angles = st.floats(-math.pi, math.pi, allow_nan=False)


@given(st.floats(-90.0, 90.0))
def test_dege7_round_trip_within_half_a_unit(lat_deg):
    assert abs(units.dege7_to_deg(units.deg_to_dege7(lat_deg)) - lat_deg) <= 0.5e-7 + 1e-12


@given(angles, st.floats(-1.5, 1.5), angles)
def test_quaternion_euler_round_trip(roll, pitch, yaw):
    q = units.euler_rad_to_quaternion_wxyz(roll, pitch, yaw)
    assert math.isclose(sum(c * c for c in q), 1.0, rel_tol=1e-9)
    r2, p2, y2 = units.quaternion_wxyz_to_euler_rad(q)
    assert p2 == pytest.approx(pitch, abs=1e-7)
    assert math.remainder(r2 - roll, 2 * math.pi) == pytest.approx(0.0, abs=1e-6)
    assert math.remainder(y2 - yaw, 2 * math.pi) == pytest.approx(0.0, abs=1e-6)


@given(st.floats(0.0, 100.0), st.floats(-1.2, 1.2), st.floats(-1.2, 1.2))
def test_tilted_range_never_exceeds_slant_range(range_m, roll, pitch):
    h = units.altitude_m_from_range_m(range_m, roll, pitch)
    assert 0.0 <= h <= range_m + 1e-12
    # the beam's vertical component: range * (body z axis . world down)
    assert h == pytest.approx(range_m * math.cos(roll) * math.cos(pitch))


@given(st.floats(-math.pi / 2, math.pi / 2))
def test_tilt_and_mount_pitch_are_opposite(tilt_rad):
    pitch_deg = units.mount_pitch_deg_from_tilt_rad(tilt_rad)
    assert units.tilt_rad_from_mount_pitch_rad(math.radians(pitch_deg)) == pytest.approx(tilt_rad)


def test_known_conversions():
    assert units.cdeg_to_rad(18000) == pytest.approx(math.pi)
    assert (
        units.mm_to_m(1500) == 1.5
        and units.cm_to_m(250) == 2.5
        and units.hpa_to_pa(1013.25) == 101325.0
    )
    assert units.depth_m_from_relative_alt_mm(-7000) == 7.0
    assert units.s_to_us(0.2) == 200000
    # 1 bar of water column in fresh water is ~10.2 m
    assert units.depth_m_from_pressure_pa(201325.0, water_density_kg_m3=1000.0) == pytest.approx(
        10.197, abs=1e-3
    )
    with pytest.raises(ValueError):
        units.quaternion_wxyz_to_euler_rad((0.0, 0.0, 0.0, 0.0))


def test_mode_table_matches_ardusub_and_extends_pymavlink():
    from pymavlink import mavutil

    for number, name in mavutil.mode_mapping_sub.items():
        assert SubMode(number).name == name
    assert SubMode.SURFTRAK == 21 and SubMode.MOTOR_DETECT == 20
    assert 21 not in mavutil.mode_mapping_sub
    assert parse_mode("depth hold") == SubMode.ALT_HOLD and parse_mode(21) == SubMode.SURFTRAK
    assert mode_name(4) == "GUIDED"
    with pytest.raises(ValueError, match="unknown ArduSub mode"):
        parse_mode("LOITER")
    with pytest.raises(ValueError):
        parse_mode(5)


def test_command_builders():
    spec = commands.message_interval(mavlink2.MAVLINK_MSG_ID_ATTITUDE, 0.05)
    assert spec.params[:2] == (30.0, 50000.0) and spec.name == "MAV_CMD_SET_MESSAGE_INTERVAL"
    assert commands.message_interval(30, None).params[1] == 0.0
    assert commands.message_interval(30, 0.0).params[1] == -1.0
    mount = commands.mount_control(math.radians(20.0))
    assert (
        mount.command == 205 and mount.params[0] == pytest.approx(-20.0) and mount.params[6] == 2.0
    )
    legacy = commands.mount_control(math.radians(20.0), centidegrees=True)
    assert legacy.params[0] == -2000.0  # pre-4.3 firmware multiplies by 0.01
    gm = commands.gimbal_manager_pitchyaw(math.radians(20.0))
    assert gm.command == 1000 and math.isnan(gm.params[2]) and math.isnan(gm.params[3])
    assert commands.set_mode(SubMode.SURFTRAK).params[:2] == (1.0, 21.0)
    with pytest.raises(ValueError):
        commands.set_mission_current(-1)
    msg = commands.command_long(commands.arm_disarm(True), 1, 1, confirmation=2)
    wire = msg.pack(mavlink2.MAVLink(None, srcSystem=1, srcComponent=191))
    assert wire[0] == 0xFD  # MAVLink 2 magic
    back = mavlink2.MAVLink(None).parse_char(wire)
    assert (back.command, back.confirmation, back.param1) == (400, 2, 1.0)


def test_distance_sensor_builder_marks_out_of_range():
    msg = commands.distance_sensor(60.0, 0.3, 50.0, 1)
    assert msg.current_distance == msg.max_distance + 1
    with pytest.raises(ValueError):
        commands.distance_sensor(math.nan, 0.3, 50.0, 1)
    with pytest.raises(ValueError):
        commands.distance_sensor(1.0, 5.0, 1.0, 1)


@pytest.mark.parametrize(
    "bad, field",
    [
        (dict(connection=""), "connection"),
        (dict(link_timeout_s=0.5, heartbeat_period_s=1.0), "link_timeout_s"),
        (dict(command_attempts=0), "command_attempts"),
        (dict(command_timeout_s=-1.0), "command_timeout_s"),
        (dict(source_component=300), "source_component"),
        (dict(signing_key=b"short"), "signing key"),
        (dict(mount_protocol="servo"), "mount_protocol"),
        (dict(max_depth_m=0.0), "max_depth_m"),
        (dict(message_intervals_s=(("ATTITUDE", 0.0),)), "message_intervals_s"),
    ],
)
def test_config_rejects_bad_settings_by_name(bad, field):
    settings: dict[str, Any] = dict(connection="udpin:127.0.0.1:14770")
    settings.update(bad)
    with pytest.raises(ConfigError, match=field):
        LinkConfig(**settings)


def test_altimeter_feed_and_keys_validated():
    with pytest.raises(ConfigError):
        AltimeterFeed(5.0, 1.0)
    assert len(key_from_passphrase("x")) == 32
    assert key_from_hex("ab" * 32) == bytes([0xAB]) * 32
    with pytest.raises(ConfigError):
        key_from_hex("zz")


def test_clocks_advance():
    wall = WallClock()
    t0 = wall.now_s()
    wall.sleep_s(0.01)
    assert wall.now_s() > t0
    fast = ScaledClock(50.0)
    t0 = fast.now_s()
    fast.sleep_s(0.5)  # 10 ms of real time
    assert fast.now_s() - t0 >= 0.5
    with pytest.raises(ConfigError):
        ScaledClock(0.0)
