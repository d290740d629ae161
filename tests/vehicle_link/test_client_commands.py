"""Commands against the scripted peer: success, refusal, timeout, retries, mode, targets."""

from __future__ import annotations

import math
import threading

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from tests.vehicle_link.vl_peer import make_config, wait_real
from vehicle_link import commands
from vehicle_link.client import ArduSubClient
from vehicle_link.config import AltimeterFeed
from vehicle_link.errors import (
    CommandRejected,
    CommandTimeout,
    ModeChangeTimeout,
    ModeError,
    NotConfigured,
    SafetyLimitError,
    StaleTelemetry,
    StateChangeTimeout,
)
from vehicle_link.modes import SubMode
from vehicle_link.telemetry import (
    Attitude,
    GlobalPosition,
    Heartbeat,
    LocalPositionNed,
    Pressure,
    Rangefinder,
    StatusText,
)


def test_connect_locks_onto_submarine_and_requests_streams(peer, client):
    assert client.target_system == 1
    assert client.mode == SubMode.MANUAL and client.armed is False
    intervals = peer.commands(mavlink2.MAV_CMD_SET_MESSAGE_INTERVAL)
    assert [(m.param1, m.param2) for m in intervals] == [
        (mavlink2.MAVLINK_MSG_ID_ATTITUDE, 100000.0)
    ]
    # our heartbeat: onboard computer, component 191
    assert wait_real(lambda: len(peer.of_type("HEARTBEAT")) >= 2)
    hb = peer.of_type("HEARTBEAT")[0]
    assert hb.get_srcComponent() == 191 and hb.type == mavlink2.MAV_TYPE_ONBOARD_CONTROLLER


def test_arm_and_disarm_succeed_and_are_confirmed_by_heartbeat(peer, client):
    client.arm()
    assert peer.armed and client.armed is True
    client.disarm()
    assert not peer.armed and client.armed is False
    sent = peer.commands(mavlink2.MAV_CMD_COMPONENT_ARM_DISARM)
    assert [m.param1 for m in sent] == [1.0, 0.0]
    assert all(m.param2 == 0.0 for m in sent)


def test_arm_accepted_but_never_shown_armed_times_out(peer, client):
    peer.apply_arming = False  # ack ACCEPTED, heartbeat keeps saying disarmed
    with pytest.raises(StateChangeTimeout) as info:
        client.arm()
    assert info.value.what == "armed" and isinstance(info.value, TimeoutError)
    client.arm(confirm=False)  # without confirmation the ack is enough
    assert client.armed is False


def test_force_arm_and_disarm_send_ardupilots_magic_numbers(peer, client):
    """GCS.h: magic_force_arm_value 2989, magic_force_disarm_value 21196."""
    client.arm(force=True)
    assert peer.commands(mavlink2.MAV_CMD_COMPONENT_ARM_DISARM)[-1].param2 == 2989.0
    client.disarm(force=True)
    assert peer.commands(mavlink2.MAV_CMD_COMPONENT_ARM_DISARM)[-1].param2 == 21196.0


def test_refusal_raises_typed_error_with_mav_result(peer, client):
    peer.command_script[mavlink2.MAV_CMD_COMPONENT_ARM_DISARM] = [mavlink2.MAV_RESULT_DENIED]
    with pytest.raises(CommandRejected) as info:
        client.arm()
    assert info.value.result == mavlink2.MAV_RESULT_DENIED
    assert info.value.command == mavlink2.MAV_CMD_COMPONENT_ARM_DISARM
    assert "MAV_RESULT_DENIED" in str(info.value)
    assert not peer.armed
    assert len(peer.commands(mavlink2.MAV_CMD_COMPONENT_ARM_DISARM)) == 1  # no retry on refusal


def test_timeout_after_bounded_retries_with_confirmation_counter(peer, client):
    peer.command_script[mavlink2.MAV_CMD_COMPONENT_ARM_DISARM] = [None, None, None]
    with pytest.raises(CommandTimeout) as info:
        client.arm()
    assert info.value.attempts == 3
    sent = peer.commands(mavlink2.MAV_CMD_COMPONENT_ARM_DISARM)
    assert [m.confirmation for m in sent] == [0, 1, 2]
    assert isinstance(info.value, TimeoutError)


def test_lost_ack_is_retried_and_succeeds(peer, client):
    peer.command_script[mavlink2.MAV_CMD_COMPONENT_ARM_DISARM] = [None]
    client.arm()
    assert [m.confirmation for m in peer.commands(mavlink2.MAV_CMD_COMPONENT_ARM_DISARM)] == [0, 1]
    assert peer.armed


def test_in_progress_then_accepted(peer, client):
    peer.command_script[mavlink2.MAV_CMD_DO_SET_MISSION_CURRENT] = [mavlink2.MAV_RESULT_IN_PROGRESS]
    # the peer sends IN_PROGRESS once: not a success, so the client waits on, hears nothing
    # more, and re-sends (confirmation 1); that retry gets ACCEPTED
    client.set_mission_current(3)
    sent = peer.commands(mavlink2.MAV_CMD_DO_SET_MISSION_CURRENT)
    assert [m.confirmation for m in sent] == [0, 1]
    assert [m.param1 for m in sent] == [3.0, 3.0]


def test_in_progress_then_accepted_without_a_resend(peer, client):
    """IN_PROGRESS extends the wait: the ACCEPTED that follows it (inside the command
    timeout) completes the command, with no re-send, and not before it arrives."""
    cmd = mavlink2.MAV_CMD_DO_SET_MISSION_CURRENT
    peer.command_script[cmd] = [None]  # the scripted answer stays silent; this hook acks
    accepted = threading.Event()

    def ack(msg, result: int) -> None:
        if result == mavlink2.MAV_RESULT_ACCEPTED:
            accepted.set()
        peer.send(mavlink2.MAVLink_command_ack_message(cmd, result, 0, 0, msg.get_srcSystem(),
                                                       msg.get_srcComponent()))

    def on_command(msg) -> None:
        if msg.command == cmd:
            ack(msg, mavlink2.MAV_RESULT_IN_PROGRESS)
            timer = threading.Timer(0.3, ack, args=(msg, mavlink2.MAV_RESULT_ACCEPTED))
            timer.daemon = True
            timer.start()

    peer.on_message["COMMAND_LONG"] = on_command
    client.set_mission_current(4)
    assert accepted.is_set()  # it returned on the ACCEPTED, not on IN_PROGRESS
    sent = peer.commands(cmd)
    assert [(m.confirmation, m.param1) for m in sent] == [(0, 4.0)]


@pytest.mark.parametrize("mode", [SubMode.SURFTRAK, SubMode.ALT_HOLD, SubMode.GUIDED])
def test_set_mode_by_ardusub_number_including_surftrak(peer, client, mode):
    assert client.set_mode(mode.name) == mode
    cmd = peer.commands(mavlink2.MAV_CMD_DO_SET_MODE)[-1]
    assert cmd.param1 == mavlink2.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
    assert cmd.param2 == float(mode.value)
    assert client.mode == mode.value == peer.custom_mode


def test_set_mode_refused_and_unconfirmed(peer, client):
    peer.command_script[mavlink2.MAV_CMD_DO_SET_MODE] = [mavlink2.MAV_RESULT_FAILED]
    with pytest.raises(CommandRejected) as info:
        client.set_mode(SubMode.GUIDED)
    assert info.value.result == mavlink2.MAV_RESULT_FAILED
    peer.apply_mode_changes = False
    with pytest.raises(ModeChangeTimeout):
        client.set_mode(SubMode.GUIDED)


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


def test_start_mission_and_refusal(peer, client):
    client.start_mission()
    assert peer.commands(mavlink2.MAV_CMD_MISSION_START)[-1].param1 == 0.0
    peer.command_script[mavlink2.MAV_CMD_MISSION_START] = [mavlink2.MAV_RESULT_FAILED]
    with pytest.raises(CommandRejected):
        client.start_mission()


def test_unthreaded_client_pumps_while_waiting(peer, client_factory):
    client: ArduSubClient = client_factory(make_config(peer), threaded=False)
    client.connect()
    client.arm()
    assert peer.armed
    with pytest.raises(RuntimeError):
        client_factory(make_config(peer)).pump()


def test_set_mission_current_falls_back_to_message_on_old_firmware(peer, client):
    from vehicle_link.telemetry import MissionCurrent

    peer.command_script[mavlink2.MAV_CMD_DO_SET_MISSION_CURRENT] = [mavlink2.MAV_RESULT_UNSUPPORTED]
    peer.on_message["MISSION_SET_CURRENT"] = lambda msg: peer.send(
        mavlink2.MAVLink_mission_current_message(msg.seq, 5, 2, 0)
    )
    client.set_mission_current(4)
    assert [m.seq for m in peer.of_type("MISSION_SET_CURRENT")] == [4]
    assert client.latest(MissionCurrent).seq == 4


def test_command_timeouts_run_on_the_injected_clock(peer, client_factory):
    # 20 s per attempt on a clock running 200x faster than real time
    from vehicle_link.clock import ScaledClock

    client = client_factory(
        make_config(
            peer,
            command_timeout_s=20.0,
            link_timeout_s=200.0,
            heartbeat_period_s=1.0,
            connect_timeout_s=600.0,
        ),
        clock=ScaledClock(200.0),
    )
    client.connect()
    peer.command_script[mavlink2.MAV_CMD_COMPONENT_ARM_DISARM] = [None, None, None]
    with pytest.raises(CommandTimeout) as info:
        client.arm()
    assert info.value.timeout_s == 20.0 and info.value.attempts == 3
    assert len(peer.commands(mavlink2.MAV_CMD_COMPONENT_ARM_DISARM)) == 3


def test_depth_falls_back_to_the_external_pressure_sensor(peer, client_factory):
    client = client_factory(
        make_config(peer, water_density_kg_m3=1000.0, surface_pressure_pa=100000.0)
    )
    client.connect()
    with pytest.raises(StaleTelemetry):
        client.current_depth_m()
    # 5 m of fresh water: 100000 + 1000 * 9.80665 * 5 Pa, sent in hPa
    peer.send(
        mavlink2.MAVLink_scaled_pressure2_message(1, (100000.0 + 49033.25) / 100.0, 0.0, 1500)
    )
    assert wait_real(lambda: client.latest(Pressure, "Pressure2") is not None)
    assert client.current_depth_m() == pytest.approx(5.0, abs=1e-3)


def test_callbacks_cannot_block_the_io_thread(peer, client_factory):
    errors: list[BaseException] = []

    def listener(record):
        if isinstance(record, StatusText):
            try:
                client.arm()
            except RuntimeError as exc:
                errors.append(exc)

    client = client_factory(make_config(peer))
    client.connect()
    client.add_listener(listener)
    peer.send(mavlink2.MAVLink_statustext_message(6, b"go"))
    assert wait_real(lambda: bool(errors))
    assert "I/O thread" in str(errors[0])
    assert not peer.armed


def test_topside_heartbeats_and_joystick_are_recorded_as_peers(peer, client):
    """The companion sees the topside's HEARTBEAT (system 255) and MANUAL_CONTROL through
    the router, and BlueOS's services (system 1, component 194): kept apart from the
    vehicle's own heartbeat."""
    topside = mavlink2.MAVLink(None, srcSystem=255, srcComponent=190)
    blueos = mavlink2.MAVLink(None, srcSystem=1, srcComponent=194)
    peer.send_raw(mavlink2.MAVLink_heartbeat_message(mavlink2.MAV_TYPE_GCS, 8, 0, 0, 4, 3).pack(topside))
    peer.send_raw(mavlink2.MAVLink_manual_control_message(1, 0, 0, 500, 0, 0).pack(topside))
    peer.send_raw(mavlink2.MAVLink_heartbeat_message(mavlink2.MAV_TYPE_ONBOARD_CONTROLLER, 8, 0, 0, 4, 3).pack(blueos))
    assert wait_real(lambda: len(client.peers("HEARTBEAT", 10.0)) == 2)
    assert {(p.system_id, p.component_id) for p in client.peers("HEARTBEAT", 10.0)} == {(255, 190), (1, 194)}
    (pilot,) = client.peers("MANUAL_CONTROL", 10.0)
    assert pilot.system_id == 255
    assert client.latest(Heartbeat).component_id == 1 and client.latest(Heartbeat).mav_type == 12


def test_typed_parameter_read_mount_frame_and_ekf_origin(peer, client):
    params = {"MNT1_TYPE": (1.0, mavlink2.MAV_PARAM_TYPE_INT8)}
    origin: list[tuple[int, int]] = []

    def param_read(msg):
        value, ptype = params[msg.param_id]
        peer.send(mavlink2.MAVLink_param_value_message(msg.param_id.encode(), value, ptype, 900, 7))

    def set_origin(msg):
        if not origin:
            origin.append((msg.latitude, msg.longitude))
        peer.send(mavlink2.MAVLink_gps_global_origin_message(*origin[0], 0, 0))

    peer.on_message["PARAM_REQUEST_READ"] = param_read
    peer.on_message["SET_GPS_GLOBAL_ORIGIN"] = set_origin
    record = client.get_parameter("MNT1_TYPE")
    assert (record.value, record.param_type) == (1.0, mavlink2.MAV_PARAM_TYPE_INT8)
    assert client.mount_frame() == "earth"
    params["MNT1_TYPE"] = (7.0, mavlink2.MAV_PARAM_TYPE_INT8)
    assert client.mount_frame() == "body"
    assert client.ekf_origin(timeout_s=0.3) is None  # the peer sends nothing: no origin
    got = client.set_ekf_origin(43.295, 5.36)
    assert (got.latitude_deg, got.longitude_deg) == (43.295, 5.36)
    again = client.set_ekf_origin(47.0, 8.0)  # ignored by the vehicle: its origin comes back
    assert (again.latitude_deg, again.longitude_deg) == (43.295, 5.36)
