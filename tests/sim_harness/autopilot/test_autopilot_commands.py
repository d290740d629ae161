"""Commands and their ACK codes as ArduSub 4.5 answers them; message requests; MAVFTP."""

from __future__ import annotations

from sim_harness.autopilot.autopilot import Mode
from sim_harness.faults import FaultConfig
from sim_harness.vehicle.sensors import SensorConfig
from tests.sim_harness.autopilot.gcs_peer import M, running_vehicle, vehicle_config


def test_arm_and_disarm_codes_and_the_magic_numbers():
    """GCS_Common.cpp handle_command_component_arm_disarm: 2989 forces arming, 21196 a
    disarm; ACCEPTED when already in the state; UNSUPPORTED for param1 not 0/1."""
    cfg = vehicle_config(autopilot={"arming_fail_reason": "Leak Detected"})
    with running_vehicle(config=cfg) as (sim, gcs):
        assert gcs.command(M.MAV_CMD_COMPONENT_ARM_DISARM, 0).result == M.MAV_RESULT_ACCEPTED  # already
        assert gcs.arm().result == M.MAV_RESULT_FAILED
        assert any(m.text == "PreArm: Leak Detected" for m in gcs.log if m.get_type() == "STATUSTEXT")
        assert gcs.command(M.MAV_CMD_COMPONENT_ARM_DISARM, 1, 21196).result == M.MAV_RESULT_FAILED  # not the arm magic
        assert not sim.truth().armed
        assert gcs.arm(force=True).result == M.MAV_RESULT_ACCEPTED  # 2989
        assert gcs.arm(force=True).result == M.MAV_RESULT_ACCEPTED  # already armed
        assert gcs.command(M.MAV_CMD_COMPONENT_ARM_DISARM, 2).result == M.MAV_RESULT_UNSUPPORTED
        assert gcs.command(M.MAV_CMD_COMPONENT_ARM_DISARM, 0, 21196).result == M.MAV_RESULT_ACCEPTED
        gcs.run_for(0.1)
        assert not sim.truth().armed


def test_unknown_and_4_6_commands_are_unsupported_and_fault_refusals_denied():
    """DO_REPOSITION is 4.6 (UNSUPPORTED in 4.5, GCS_Common.cpp L5310); fault injection DENIED."""
    faults = FaultConfig(refuse_commands=frozenset({M.MAV_CMD_COMPONENT_ARM_DISARM}))
    with running_vehicle(faults=faults) as (sim, gcs):
        assert gcs.command(M.MAV_CMD_DO_REPOSITION, -1, 0, 0, 0, 47.0, 8.0, -2).result == M.MAV_RESULT_UNSUPPORTED
        assert gcs.command(M.MAV_CMD_NAV_TAKEOFF).result == M.MAV_RESULT_UNSUPPORTED
        assert gcs.arm().result == M.MAV_RESULT_DENIED
        assert not sim.truth().armed


def test_get_home_position_and_request_message():
    """GET_HOME_POSITION: FAILED without home, else HOME_POSITION + GPS_GLOBAL_ORIGIN.
    REQUEST_MESSAGE: FAILED for an id with no ap_message, ACCEPTED (and nothing sent) for
    HOME_POSITION without a home."""
    no_dvl = vehicle_config(origin=None, sensors=SensorConfig(has_position_estimate=False))
    with running_vehicle(config=no_dvl) as (_sim, gcs):
        assert gcs.command(M.MAV_CMD_GET_HOME_POSITION).result == M.MAV_RESULT_FAILED
        ack = gcs.command(M.MAV_CMD_REQUEST_MESSAGE, M.MAVLINK_MSG_ID_HOME_POSITION)
        assert ack.result == M.MAV_RESULT_ACCEPTED
        assert gcs.wait_for("HOME_POSITION", 1.0) is None
        assert gcs.command(M.MAV_CMD_REQUEST_MESSAGE, 9999).result == M.MAV_RESULT_FAILED
    with running_vehicle() as (_sim, gcs):
        assert gcs.command(M.MAV_CMD_GET_HOME_POSITION).result == M.MAV_RESULT_ACCEPTED
        home = next(m for m in gcs.log if m.get_type() == "HOME_POSITION")
        origin = next(m for m in gcs.log if m.get_type() == "GPS_GLOBAL_ORIGIN")
        assert (home.latitude, home.longitude) == (470000000, 80000000)
        assert (origin.latitude, origin.longitude) == (470000000, 80000000)
        gcs.command(M.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES, 1)
        version = next(m for m in gcs.log if m.get_type() == "AUTOPILOT_VERSION")
        assert version.capabilities & M.MAV_PROTOCOL_CAPABILITY_MISSION_INT
        assert not version.capabilities & M.MAV_PROTOCOL_CAPABILITY_COMMAND_INT  # not advertised by Sub
        assert gcs.command(M.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES, 0).result == M.MAV_RESULT_FAILED


def test_set_message_interval_for_what_a_sub_streams():
    """set_message_interval: EXTENDED_SYS_STATE is mapped (vtol and landed state UNDEFINED on
    a sub); POSITION_TARGET_* are mapped but Sub never sends them; an unmapped id is DENIED
    with "No ap_message for mavlink id (N)"."""
    with running_vehicle() as (_sim, gcs):
        ack = gcs.command(M.MAV_CMD_SET_MESSAGE_INTERVAL, M.MAVLINK_MSG_ID_EXTENDED_SYS_STATE, 200_000)
        assert ack.result == M.MAV_RESULT_ACCEPTED
        states = [m for m in gcs.run_for(2.0) if m.get_type() == "EXTENDED_SYS_STATE"]
        assert 9 <= len(states) <= 11 and states[0].landed_state == M.MAV_LANDED_STATE_UNDEFINED
        ack = gcs.command(M.MAV_CMD_SET_MESSAGE_INTERVAL, M.MAVLINK_MSG_ID_POSITION_TARGET_LOCAL_NED, 100_000)
        assert ack.result == M.MAV_RESULT_ACCEPTED
        assert not any(m.get_type() == "POSITION_TARGET_LOCAL_NED" for m in gcs.run_for(1.0))
        assert gcs.command(M.MAV_CMD_SET_MESSAGE_INTERVAL, 9999, 100_000).result == M.MAV_RESULT_DENIED
        assert any(m.text == "No ap_message for mavlink id (9999)" for m in gcs.log if m.get_type() == "STATUSTEXT")


def test_request_data_stream_sets_the_stream_rates():
    with running_vehicle() as (_sim, gcs):
        gcs.mav.request_data_stream_send(1, 1, M.MAV_DATA_STREAM_EXTRA1, 4, 1)
        gcs.run_for(0.5)
        msgs = gcs.run_for(5.0)
        assert 19 <= sum(m.get_type() == "ATTITUDE" for m in msgs) <= 21
        assert gcs.param("SR0_EXTRA1").param_value == 4.0


def test_mavftp_requests_are_refused_at_once():
    """No file server: a NAK (seq + 1, same session, opcode Nack, req_opcode, FileNotFound)
    makes MAVProxy fall back to PARAM_REQUEST_LIST without its 11 s of retries."""
    with running_vehicle() as (_sim, gcs):
        request = bytearray(251)
        request[0:2] = (41).to_bytes(2, "little")
        request[2], request[3] = 7, 4  # session 7, OpenFileRO
        gcs.mav.file_transfer_protocol_send(0, 1, 1, list(request))
        nak = gcs.wait_for("FILE_TRANSFER_PROTOCOL", 1.0)
        payload = bytes(nak.payload)
        assert (nak.target_system, nak.target_component) == (255, 190)
        assert int.from_bytes(payload[0:2], "little") == 42
        assert (payload[2], payload[3], payload[4], payload[5], payload[12]) == (7, 129, 1, 4, 10)


def test_mission_start_needs_arming_and_nav_commands_switch_mode():
    """handle_MAV_CMD_MISSION_START: armed and AUTO, else FAILED; NAV_LOITER_UNLIM ->
    POSHOLD, NAV_LAND -> SURFACE (GCS_Mavlink.cpp)."""
    with running_vehicle(config=vehicle_config(start_depth_m=2.0)) as (_sim, gcs):
        assert gcs.command(M.MAV_CMD_MISSION_START, 0, 0).result == M.MAV_RESULT_FAILED
        assert gcs.command(M.MAV_CMD_NAV_LOITER_UNLIM).result == M.MAV_RESULT_ACCEPTED
        assert gcs.wait_for("HEARTBEAT", 2.0, lambda m: m.custom_mode == Mode.POSHOLD)
        assert gcs.command(M.MAV_CMD_NAV_LAND).result == M.MAV_RESULT_ACCEPTED
        assert gcs.wait_for("HEARTBEAT", 2.0, lambda m: m.custom_mode == Mode.SURFACE)
        assert gcs.command(M.MAV_CMD_CONDITION_YAW, 400, 0, 0, 0).result == M.MAV_RESULT_DENIED


def test_latency_delays_the_command_ack():
    faults = FaultConfig(latency_s=0.4)
    with running_vehicle(faults=faults) as (sim, gcs):
        t0 = sim.clock.now_s()
        ack = gcs.command(M.MAV_CMD_REQUEST_MESSAGE, M.MAVLINK_MSG_ID_HOME_POSITION)
        assert ack is not None
        assert sim.clock.now_s() - t0 >= 0.8  # 0.4 s each way


def test_flight_termination_disarms_only_above_one_half():
    """GCS_MAVLINK_Sub::handle_flight_termination: param1 > 0.5 disarms at once (ACCEPTED);
    any other value is FAILED and changes nothing."""
    with running_vehicle() as (sim, gcs):
        assert gcs.arm().result == M.MAV_RESULT_ACCEPTED
        assert gcs.command(M.MAV_CMD_DO_FLIGHTTERMINATION, 0.0).result == M.MAV_RESULT_FAILED
        assert gcs.command(M.MAV_CMD_DO_FLIGHTTERMINATION, 0.5).result == M.MAV_RESULT_FAILED
        assert sim.truth().armed
        assert gcs.command(M.MAV_CMD_DO_FLIGHTTERMINATION, 1.0).result == M.MAV_RESULT_ACCEPTED
        assert not sim.truth().armed
