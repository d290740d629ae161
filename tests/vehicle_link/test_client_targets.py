"""Targets and the mount against the scripted peer: depth, altitude and position-velocity
targets with their limits, the mount tilt, the altimeter feed."""

from __future__ import annotations

import math

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from tests.vehicle_link.vl_peer import make_config, wait_real
from vehicle_link import commands
from vehicle_link.config import AltimeterFeed
from vehicle_link.errors import (
    CommandRejected,
    ModeError,
    NotConfigured,
    SafetyLimitError,
)
from vehicle_link.modes import SubMode
from vehicle_link.telemetry import (
    Attitude,
    GlobalPosition,
    LocalPositionNed,
    Rangefinder,
)


def _sync(peer, client):
    """Barrier: an acknowledged command; UDP on loopback keeps order, so everything the
    client sent before it has reached the peer once it is acknowledged."""
    client.send_command(commands.message_interval(mavlink2.MAVLINK_MSG_ID_SYS_STATUS, 1.0))


def test_depth_target_in_alt_hold_uses_z_only_mask(peer, client):
    client.set_mode(SubMode.ALT_HOLD)
    client.set_depth_target(12.5)
    _sync(peer, client)
    (msg,) = peer.of_type("SET_POSITION_TARGET_GLOBAL_INT")
    assert msg.alt == pytest.approx(-12.5)
    mask = msg.type_mask
    # ArduSub reads z when Z_IGNORE is clear; x, y, velocity, acceleration, yaw all ignored
    assert not mask & commands.TYPE_MASK_Z_IGNORE
    for bit in (1, 2, 8, 16, 32, 64, 128, 256, 1024, 2048):
        assert mask & bit
    assert not mask & commands.TYPE_MASK_FORCE_SET


def test_depth_target_in_guided_keeps_horizontal_position(peer, client):
    client.set_mode(SubMode.GUIDED)
    peer.send(mavlink2.MAVLink_local_position_ned_message(1000, 3.0, -4.0, 6.0, 0, 0, 0))
    assert wait_real(lambda: client.latest(LocalPositionNed) is not None)
    client.set_depth_target(8.0)
    _sync(peer, client)
    (msg,) = peer.of_type("SET_POSITION_TARGET_LOCAL_NED")
    assert (msg.x, msg.y, msg.z) == pytest.approx((3.0, -4.0, 8.0))
    assert msg.coordinate_frame == mavlink2.MAV_FRAME_LOCAL_NED
    assert msg.type_mask == commands.TYPE_MASK_POSITION


def test_depth_target_refused_in_manual_and_beyond_limit_before_sending(peer, client_factory):
    client = client_factory(make_config(peer, max_depth_m=20.0))
    client.connect()
    with pytest.raises(ModeError):
        client.set_depth_target(5.0)
    client.set_mode(SubMode.ALT_HOLD)
    with pytest.raises(SafetyLimitError) as info:
        client.set_depth_target(20.5)
    assert info.value.limit == 20.0 and info.value.quantity == "depth_m"
    with pytest.raises(SafetyLimitError):
        client.set_depth_target(-1.0)
    with pytest.raises(SafetyLimitError):
        client.set_depth_target(math.nan)
    _sync(peer, client)
    assert peer.of_type("SET_POSITION_TARGET_GLOBAL_INT") == []


def _feed_altitude_telemetry(peer, client, *, range_cm=500, pitch_rad=0.2, depth_mm=10000):
    peer.send(
        mavlink2.MAVLink_distance_sensor_message(
            1000, 20, 5000, range_cm, mavlink2.MAV_DISTANCE_SENSOR_ULTRASOUND, 0, 25, 0
        )
    )
    peer.send(mavlink2.MAVLink_attitude_message(1000, 0.0, pitch_rad, 0.0, 0, 0, 0))
    peer.send(
        mavlink2.MAVLink_global_position_int_message(
            1000, int(47.1 * 1e7), int(-122.2 * 1e7), -depth_mm, -depth_mm, 0, 0, 0, 9000
        )
    )
    assert wait_real(
        lambda: all(
            client.latest(k, key) is not None
            for k, key in (
                (Attitude, None),
                (GlobalPosition, None),
                (Rangefinder, "Rangefinder:DISTANCE_SENSOR:0"),
            )
        )
    )


def test_altitude_target_derives_depth_from_tilted_altimeter(peer, client_factory):
    client = client_factory(make_config(peer, min_clearance_m=1.0, max_depth_m=30.0))
    client.connect()
    client.set_mode(SubMode.ALT_HOLD)
    _feed_altitude_telemetry(peer, client)
    result = client.set_altitude_target(3.0)
    measured = 5.0 * math.cos(0.2)  # vertical height under a 0.2 rad pitch
    assert result.method == "derived_depth"
    assert result.measured_altitude_m == pytest.approx(measured)
    assert result.depth_target_m == pytest.approx(10.0 + measured - 3.0)
    _sync(peer, client)
    (msg,) = peer.of_type("SET_POSITION_TARGET_GLOBAL_INT")
    assert msg.alt == pytest.approx(-(10.0 + measured - 3.0), abs=1e-4)


def test_altitude_target_below_clearance_or_too_deep_is_refused_before_sending(
    peer, client_factory
):
    client = client_factory(make_config(peer, min_clearance_m=1.0, max_depth_m=11.0))
    client.connect()
    client.set_mode(SubMode.ALT_HOLD)
    _feed_altitude_telemetry(peer, client)
    with pytest.raises(SafetyLimitError) as info:
        client.set_altitude_target(0.5)
    assert info.value.quantity == "altitude_m" and info.value.limit == 1.0
    with pytest.raises(SafetyLimitError) as info:
        client.set_altitude_target(2.0)  # would need depth 12.9 m > 11 m
    assert info.value.quantity == "depth_m"
    _sync(peer, client)
    assert peer.of_type("SET_POSITION_TARGET_GLOBAL_INT") == []


def test_posvel_target_uses_position_velocity_and_ignores_acceleration(peer, client):
    """ArduSub 4.5 acts on a LOCAL_NED target only with the accel bits set; position and
    velocity both used -> Guided_PosVel (GCS_Mavlink.cpp SET_POSITION_TARGET_LOCAL_NED)."""
    client.set_mode(SubMode.GUIDED)
    client.goto_posvel(3.0, 4.0, 5.0, 0.2, -0.1, 0.05, yaw_rad=1.0)
    _sync(peer, client)
    (msg,) = peer.of_type("SET_POSITION_TARGET_LOCAL_NED")
    assert (msg.x, msg.y, msg.z) == (3.0, 4.0, 5.0)
    assert (msg.vx, msg.vy, msg.vz) == pytest.approx((0.2, -0.1, 0.05))
    mask = msg.type_mask
    assert not mask & 0b111 and not mask & 0b111000 and mask & 0b111000000 == 0b111000000
    assert not mask & commands.TYPE_MASK_YAW_IGNORE and msg.yaw == pytest.approx(1.0)
    with pytest.raises(SafetyLimitError):
        client.goto_posvel(3.0, 4.0, -1.0, 0.0, 0.0)  # above the surface


@pytest.mark.parametrize("protocol", ["mount_control", "gimbal_manager"])
def test_mount_tilt_is_sent_once_and_never_resent_on_a_mode_change(peer, client_factory, protocol):
    """ArduSub 4.5 puts the mount into RC targeting on a mode change, which holds the
    angle; the link does not re-send (after a pilot's mode change the companion must not
    command anything)."""
    client = client_factory(make_config(peer, mount_protocol=protocol))
    client.connect()
    command = (
        mavlink2.MAV_CMD_DO_MOUNT_CONTROL
        if protocol == "mount_control"
        else mavlink2.MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW
    )
    client.set_mount_tilt(math.radians(30.0))
    (first,) = peer.commands(command)
    assert first.param1 == pytest.approx(-30.0)  # MAVLink pitch is up positive
    if protocol == "mount_control":
        assert first.param7 == mavlink2.MAV_MOUNT_MODE_MAVLINK_TARGETING
    else:
        assert first.param2 == 0.0  # pitch and yaw both given (4.5 refuses a NaN yaw)
    client.set_mode(SubMode.ALT_HOLD)
    assert client.mode == SubMode.ALT_HOLD
    peer.custom_mode = SubMode.MANUAL  # a mode change made elsewhere (pilot, failsafe)
    # counted only once the client has heard the change (the peer's next heartbeat), and
    # after a barrier, so anything the client sent on hearing it has reached the peer
    assert wait_real(lambda: client.mode == SubMode.MANUAL)
    _sync(peer, client)
    assert len(peer.commands(command)) == 1


def test_mount_tilt_without_waiting_for_the_ack(peer, client):
    """A control loop's tilt goes out once and returns, even if never acknowledged (with
    ``wait_ack`` the same silence raises CommandTimeout after the retries)."""
    peer.command_script[mavlink2.MAV_CMD_DO_MOUNT_CONTROL] = [None, None, None]
    client.set_mount_tilt(math.radians(20.0), wait_ack=False)
    _sync(peer, client)
    (sent,) = peer.commands(mavlink2.MAV_CMD_DO_MOUNT_CONTROL)
    assert sent.param1 == pytest.approx(-20.0) and sent.confirmation == 0


def test_mount_refusal_is_typed(peer, client):
    peer.command_script[mavlink2.MAV_CMD_DO_MOUNT_CONTROL] = [mavlink2.MAV_RESULT_UNSUPPORTED]
    with pytest.raises(CommandRejected) as info:
        client.set_mount_tilt(0.3)
    assert info.value.result == mavlink2.MAV_RESULT_UNSUPPORTED


def test_altimeter_feed_sends_downward_distance_sensor(peer, client_factory):
    client = client_factory(make_config(peer, altimeter=AltimeterFeed(0.5, 30.0, 3)))
    client.connect()
    client.send_altimeter_range(4.23, signal_quality_pct=80)
    _sync(peer, client)
    (msg,) = peer.of_type("DISTANCE_SENSOR")
    assert (msg.current_distance, msg.min_distance, msg.max_distance) == (423, 50, 3000)
    assert msg.orientation == mavlink2.MAV_SENSOR_ROTATION_PITCH_270
    assert msg.id == 3 and msg.signal_quality == 80
    assert client.current_altitude_m() == pytest.approx(4.23)


def test_altimeter_feed_needs_configuration(client):
    with pytest.raises(NotConfigured):
        client.send_altimeter_range(3.0)
