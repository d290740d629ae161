"""Commands against the scripted peer: success, refusal, timeout, retries, mode, targets."""

from __future__ import annotations

import threading

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from tests.vehicle_link.vl_peer import make_config, wait_real
from vehicle_link.client import ArduSubClient
from vehicle_link.errors import (
    CommandRejected,
    CommandTimeout,
    ModeChangeTimeout,
    StaleTelemetry,
    StateChangeTimeout,
)
from vehicle_link.modes import SubMode
from vehicle_link.telemetry import (
    Heartbeat,
    Pressure,
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
