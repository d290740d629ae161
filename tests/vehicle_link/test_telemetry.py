"""Telemetry decoding: known answers per message, and the same through the socket."""

from __future__ import annotations

import math
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from tests.vehicle_link.vl_peer import wait_real
from vehicle_link import units
from vehicle_link.telemetry import (
    TELEMETRY_MESSAGE_TYPES,
    Attitude,
    GlobalPosition,
    Heartbeat,
    LocalPositionNed,
    MissionCurrent,
    MissionItemReached,
    MountStatus,
    ParamValue,
    Pressure,
    Rangefinder,
    StatusText,
    SysStatus,
    TelemetryRecord,
    store_key,
)
from vehicle_link.telemetry import decode as decode_record
from vehicle_link.transport import parse_bytes

_MAV = mavlink2.MAVLink(None, srcSystem=1, srcComponent=1)


def decode(msg: Any, time_s: float) -> Any:
    """The record, typed loosely so each test can read its own fields."""
    return decode_record(msg, time_s)


def _wire(msg):
    """Pack and parse again, as the link would."""
    parser = mavlink2.MAVLink(None)
    return parser.parse_char(msg.pack(_MAV))


def test_heartbeat_mode_and_armed():
    hb = decode(_wire(mavlink2.MAVLink_heartbeat_message(12, 3, 128 | 1, 21, 4, 3)), 5.0)
    assert isinstance(hb, Heartbeat)
    assert (hb.armed, hb.custom_mode, hb.mode_name, hb.time_s) == (True, 21, "SURFTRAK", 5.0)
    hb = decode(_wire(mavlink2.MAVLink_heartbeat_message(12, 3, 1, 99, 3, 3)), 0.0)
    assert hb.armed is False and hb.mode_name == "MODE(99)"


def test_global_position_depth_and_units():
    rec = decode(
        _wire(
            mavlink2.MAVLink_global_position_int_message(
                2500, 476062095, -1223320708, 95000, -12345, 150, -20, 30, 27000
            )
        ),
        1.0,
    )
    assert isinstance(rec, GlobalPosition)
    assert rec.latitude_deg == pytest.approx(47.6062095)
    assert rec.longitude_deg == pytest.approx(-122.3320708)
    assert rec.depth_m == pytest.approx(12.345)
    assert rec.altitude_msl_m == pytest.approx(95.0)
    assert (rec.velocity_north_m_s, rec.velocity_east_m_s, rec.velocity_down_m_s) == pytest.approx(
        (1.5, -0.2, 0.3)
    )
    assert rec.heading_rad == pytest.approx(math.radians(270.0))
    assert rec.time_boot_s == pytest.approx(2.5)
    unknown = decode(
        _wire(mavlink2.MAVLink_global_position_int_message(0, 0, 0, 0, 0, 0, 0, 0, 65535)), 0
    )
    assert unknown.heading_rad is None


def test_attitude_and_local_position():
    att = decode(
        _wire(mavlink2.MAVLink_attitude_message(100, 0.1, -0.2, 3.0, 0.01, 0.02, -0.03)), 2.0
    )
    assert isinstance(att, Attitude)
    assert (att.roll_rad, att.pitch_rad, att.yaw_rad) == pytest.approx((0.1, -0.2, 3.0))
    assert att.yaw_rate_rad_s == pytest.approx(-0.03)
    loc = decode(
        _wire(mavlink2.MAVLink_local_position_ned_message(100, 1.0, 2.0, 7.5, 0.1, 0.2, 0.3)), 2.0
    )
    assert isinstance(loc, LocalPositionNed) and loc.down_m == pytest.approx(7.5)


def test_pressure_instances_in_pascal_and_hydrostatic_depth():
    # Bar30 at 10 m in seawater: 101325 + 1025 * 9.80665 * 10 Pa
    p_pa = 101325.0 + 1025.0 * 9.80665 * 10.0
    rec = decode(_wire(mavlink2.MAVLink_scaled_pressure2_message(10, p_pa / 100.0, 0.0, 1850)), 0)
    assert isinstance(rec, Pressure) and rec.instance == 2 and store_key(rec) == "Pressure2"
    assert rec.press_abs_pa == pytest.approx(p_pa, rel=1e-6)
    assert rec.temperature_degc == pytest.approx(18.5)
    assert units.depth_m_from_pressure_pa(rec.press_abs_pa) == pytest.approx(10.0, abs=1e-3)
    rec1 = decode(_wire(mavlink2.MAVLink_scaled_pressure_message(10, 1013.25, 0.0, 2500)), 0)
    assert rec1.instance == 1 and store_key(rec1) == "Pressure1"


def test_distance_sensor_and_rangefinder():
    rec = decode(
        _wire(
            mavlink2.MAVLink_distance_sensor_message(
                10, 30, 5000, 1234, 1, 2, 25, 0, signal_quality=90
            )
        ),
        0,
    )
    assert isinstance(rec, Rangefinder)
    assert (rec.distance_m, rec.min_distance_m, rec.max_distance_m) == pytest.approx(
        (12.34, 0.3, 50.0)
    )
    assert rec.is_downward and rec.in_range and rec.signal_quality_pct == 90
    assert store_key(rec) == "Rangefinder:DISTANCE_SENSOR:2"
    far = decode(_wire(mavlink2.MAVLink_distance_sensor_message(10, 30, 5000, 5001, 1, 2, 0, 0)), 0)
    assert not far.in_range and not far.is_downward and far.signal_quality_pct is None
    ap = decode(_wire(mavlink2.MAVLink_rangefinder_message(3.25, 0.5)), 0)
    assert ap.source == "RANGEFINDER" and ap.distance_m == pytest.approx(3.25) and ap.is_downward


def test_mount_status_and_gimbal_attitude_give_tilt_down_positive():
    ms = decode(_wire(mavlink2.MAVLink_mount_status_message(1, 1, -3000, 0, 1000)), 0)
    assert isinstance(ms, MountStatus)
    assert ms.tilt_rad == pytest.approx(math.radians(30.0))
    assert ms.yaw_rad == pytest.approx(math.radians(10.0))
    q = units.euler_rad_to_quaternion_wxyz(0.0, math.radians(-45.0), 0.0)
    gs = decode(
        _wire(mavlink2.MAVLink_gimbal_device_attitude_status_message(1, 1, 10, 0, q, 0, 0, 0, 0)), 0
    )
    assert gs.source == "GIMBAL_DEVICE_ATTITUDE_STATUS"
    assert gs.tilt_rad == pytest.approx(math.radians(45.0), abs=1e-6)


def test_mission_status_text_and_sys_status():
    mc = decode(_wire(mavlink2.MAVLink_mission_current_message(4, 9, 3, 1)), 1.0)
    assert isinstance(mc, MissionCurrent) and (mc.seq, mc.total, mc.mission_state) == (4, 9, 3)
    reached = decode(_wire(mavlink2.MAVLink_mission_item_reached_message(4)), 1.0)
    assert isinstance(reached, MissionItemReached) and reached.seq == 4
    st = decode(_wire(mavlink2.MAVLink_statustext_message(4, b"Leak Detected")), 1.0)
    assert isinstance(st, StatusText) and st.text == "Leak Detected" and st.severity == 4
    ss = decode(
        _wire(
            mavlink2.MAVLink_sys_status_message(7, 7, 5, 250, 15800, 1234, -1, 25, 0, 0, 0, 0, 0)
        ),
        1.0,
    )
    assert isinstance(ss, SysStatus)
    assert ss.voltage_battery_v == pytest.approx(15.8) and ss.current_battery_a == pytest.approx(
        12.34
    )
    assert ss.battery_remaining_pct is None and ss.load_pct == pytest.approx(25.0)
    assert ss.drop_rate_comm_pct == pytest.approx(0.25)


def test_non_telemetry_messages_decode_to_none():
    assert decode(_wire(mavlink2.MAVLink_command_ack_message(400, 0)), 0) is None
    assert len(TELEMETRY_MESSAGE_TYPES) == 18


def test_param_value_is_a_record_keyed_by_name():
    record = decode(_wire(mavlink2.MAVLink_param_value_message(b"WPNAV_SPEED", 50.0, 9, 300, 120)), 2.5)
    assert record == ParamValue(time_s=2.5, name="WPNAV_SPEED", value=50.0, index=120, count=300, param_type=9)
    assert store_key(record) == "ParamValue:WPNAV_SPEED"


def test_records_arrive_timestamped_through_the_link(peer, client):
    sent = [
        mavlink2.MAVLink_attitude_message(1, 0.1, 0.2, 0.3, 0, 0, 0),
        mavlink2.MAVLink_scaled_pressure2_message(1, 1100.0, 0.0, 1500),
        mavlink2.MAVLink_statustext_message(6, b"hello"),
        mavlink2.MAVLink_mission_item_reached_message(2),
    ]
    seen: list[Any] = []
    client.add_listener(seen.append)
    for msg in sent:
        peer.send(msg)
    assert wait_real(lambda: client.latest(MissionItemReached) is not None)
    snapshot = client.telemetry()
    assert {"Attitude", "Pressure2", "StatusText", "MissionItemReached", "Heartbeat"} <= set(
        snapshot
    )
    assert client.latest(Pressure, "Pressure2").press_abs_pa == pytest.approx(110000.0)
    assert client.latest(StatusText).text == "hello"
    assert all(r.time_s > 0 for r in snapshot.values())
    assert any(isinstance(r, StatusText) for r in seen)


def test_gimbal_status_without_attitude_decodes_to_none():
    nan_q = [math.nan] * 4
    msg = _wire(
        mavlink2.MAVLink_gimbal_device_attitude_status_message(1, 1, 10, 0, nan_q, 0, 0, 0, 0)
    )
    assert decode(msg, 0.0) is None
    zero = _wire(
        mavlink2.MAVLink_gimbal_device_attitude_status_message(1, 1, 10, 0, [0.0] * 4, 0, 0, 0, 0)
    )
    assert decode(zero, 0.0) is None


_INT_RANGES = {"int8_t": (-(2**7), 2**7 - 1), "uint8_t": (0, 2**8 - 1), "int16_t": (-(2**15), 2**15 - 1),
               "uint16_t": (0, 2**16 - 1), "int32_t": (-(2**31), 2**31 - 1), "uint32_t": (0, 2**32 - 1),
               "int64_t": (-(2**63), 2**63 - 1), "uint64_t": (0, 2**64 - 1)}
_MESSAGE_CLASSES = {cls.msgname: cls for cls in mavlink2.mavlink_map.values()}


def _field_values(fieldtype: str, length: int) -> st.SearchStrategy[Any]:
    """Any value the wire can carry for one field (NaN and infinities included)."""
    if fieldtype == "char":
        return st.text(st.characters(min_codepoint=32, max_codepoint=126), max_size=length).map(str.encode)
    if fieldtype in ("float", "double"):
        # The values a decoder must survive, as often as any other.
        special = st.sampled_from([math.nan, math.inf, -math.inf, 0.0, -0.0])
        one: st.SearchStrategy[Any] = st.one_of(special, st.floats(width=32 if fieldtype == "float" else 64))
    else:
        low, high = _INT_RANGES[fieldtype]
        one = st.integers(low, high)
    return st.lists(one, min_size=length, max_size=length) if length else one


@st.composite
def _telemetry_frames(draw: st.DrawFn) -> tuple[str, bytes]:
    """A valid-CRC frame of a telemetry type with arbitrary field values."""
    name = draw(st.sampled_from(TELEMETRY_MESSAGE_TYPES))
    cls = _MESSAGE_CLASSES[name]
    # Types in the constructor's order; array lengths in the wire's.
    length = dict(zip(cls.ordered_fieldnames, cls.array_lengths, strict=True))
    values = [draw(_field_values(t, length[f])) for f, t in zip(cls.fieldnames, cls.fieldtypes, strict=True)]
    return name, cls(*values).pack(_MAV)


@settings(max_examples=300, deadline=None)
@given(st.binary(max_size=600), _telemetry_frames(), st.binary(max_size=100))
def test_any_valid_telemetry_frame_in_garbage_decodes_without_raising(garbage, frame, tail):
    """Arbitrary field values (NaN, infinities, out-of-range enums, unterminated text) in a
    frame of every telemetry type: after at most one maximal frame of padding the parser is
    back in sync and finds it, and ``decode`` gives a record or None, never an exception."""
    name, data = frame
    mav = mavlink2.MAVLink(None)
    mav.robust_parsing = True
    parse_bytes(mav, garbage)
    msgs = [m for m in parse_bytes(mav, bytes(300) + data + tail) if m.get_type() != "BAD_DATA"]
    assert name in [m.get_type() for m in msgs]
    for m in msgs:
        record = decode(m, 0.0)
        assert record is None or isinstance(record, TelemetryRecord)
