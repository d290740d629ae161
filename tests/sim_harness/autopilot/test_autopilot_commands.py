"""Parameters, stream requests, message requests, GUIDED velocity/terrain targets, POSHOLD."""

from __future__ import annotations

import math

from sim_harness.autopilot.autopilot import Mode
from sim_harness.faults import FaultConfig
from sim_harness.simulator import VehicleConfig
from sim_harness.vehicle.dynamics import UniformCurrent
from sim_harness.vehicle.sensors import FlatSeabed
from tests.sim_harness.autopilot.gcs_peer import M, running_vehicle


def test_parameters_read_set_and_list():
    with running_vehicle() as (_sim, gcs):
        gcs.mav.param_request_read_send(1, 1, b"FS_GCS_TIMEOUT", -1)
        value = gcs.wait_for("PARAM_VALUE", 1.0)
        assert value.param_id == "FS_GCS_TIMEOUT" and value.param_value == 5.0
        gcs.mav.param_set_send(1, 1, b"FS_GCS_TIMEOUT", 2.5, M.MAV_PARAM_TYPE_REAL32)
        value = gcs.wait_for("PARAM_VALUE", 1.0)
        assert value.param_id == "FS_GCS_TIMEOUT" and value.param_value == 2.5
        gcs.mav.param_request_list_send(1, 1)
        gcs.run_for(0.1)
        names = {m.param_id for m in gcs.log if m.get_type() == "PARAM_VALUE"}
        count = next(m.param_count for m in gcs.log if m.get_type() == "PARAM_VALUE")
        assert len(names) == count and {"SYSID_MYGCS", "FS_GCS_ENABLE", "SR0_EXTRA1"} <= names


def test_a_shorter_gcs_timeout_set_by_parameter_takes_effect():
    with running_vehicle() as (sim, gcs):
        gcs.mav.param_set_send(1, 1, b"FS_GCS_TIMEOUT", 1.0, M.MAV_PARAM_TYPE_REAL32)
        assert gcs.wait_for("PARAM_VALUE", 1.0).param_value == 1.0
        assert gcs.arm().result == M.MAV_RESULT_ACCEPTED
        gcs.auto_heartbeat = False
        gcs.run_for(2.5)
        assert not sim.truth().armed


def test_request_data_stream_and_request_message():
    with running_vehicle() as (_sim, gcs):
        gcs.mav.request_data_stream_send(1, 1, M.MAV_DATA_STREAM_EXTRA1, 4, 1)
        gcs.run_for(0.5)
        msgs = gcs.run_for(5.0)
        assert 19 <= sum(m.get_type() == "ATTITUDE" for m in msgs) <= 21
        ack = gcs.command(M.MAV_CMD_REQUEST_MESSAGE, M.MAVLINK_MSG_ID_HOME_POSITION)
        assert ack.result == M.MAV_RESULT_ACCEPTED
        home = next(m for m in gcs.log if m.get_type() == "HOME_POSITION")
        assert (home.latitude, home.longitude) == (470000000, 80000000)
        gcs.command(M.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES, 1)
        version = next(m for m in gcs.log if m.get_type() == "AUTOPILOT_VERSION")
        assert version.capabilities & M.MAV_PROTOCOL_CAPABILITY_MAVLINK2
        assert version.capabilities & M.MAV_PROTOCOL_CAPABILITY_MISSION_INT


def test_guided_velocity_target_moves_then_stops_after_its_timeout():
    with running_vehicle(config=VehicleConfig(start_depth_m=3.0)) as (sim, gcs):
        gcs.set_mode(int(Mode.GUIDED))
        gcs.arm()
        velocity_only = 0b110111000111
        for _ in range(5):  # 0.5 m/s east for 5 s, refreshed every second
            gcs.mav.set_position_target_local_ned_send(
                0, 1, 1, M.MAV_FRAME_LOCAL_NED, velocity_only, 0, 0, 0, 0.0, 0.5, 0.0,
                0, 0, 0, 0, 0)
            gcs.run_for(1.0)
        moving = sim.truth()
        assert 1.5 < moving.east_m < 2.6
        gcs.run_for(10.0)  # no refresh: GUIDED stops after 3 s and holds
        stopped = sim.truth()
        gcs.run_for(5.0)
        assert abs(sim.truth().east_m - stopped.east_m) < 0.1
        assert abs(moving.depth_m - 3.0) < 0.2


def test_guided_terrain_frame_target_holds_height_above_seabed():
    with running_vehicle(FlatSeabed(18.0), config=VehicleConfig(start_depth_m=3.0)) as (sim, gcs):
        gcs.set_mode(int(Mode.GUIDED))
        gcs.arm()
        pos_only = 0b110111111000
        gcs.mav.set_position_target_global_int_send(
            0, 1, 1, M.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT, pos_only, 470000000, 80000000, 5.0,
            0, 0, 0, 0, 0, 0, 0, 0)
        gcs.run_for(40.0)
        assert abs(sim.truth().altitude_m - 5.0) < 0.25


def test_poshold_holds_against_a_current_that_moves_a_disarmed_sub():
    current = UniformCurrent(north_m_s=0.2)
    cfg = VehicleConfig(start_depth_m=4.0)
    with running_vehicle(config=cfg, current=current) as (sim, gcs):
        gcs.run_for(20.0)
        assert sim.truth().north_m > 2.0  # drifting with the water
        gcs.set_mode(int(Mode.POSHOLD))
        gcs.arm()
        gcs.run_for(10.0)
        held = sim.truth()
        gcs.run_for(30.0)
        t = sim.truth()
        assert math.hypot(t.north_m - held.north_m, t.east_m - held.east_m) < 0.5


def test_latency_delays_the_command_ack():
    faults = FaultConfig(latency_s=0.4)
    with running_vehicle(faults=faults) as (sim, gcs):
        t0 = sim.clock.now_s()
        ack = gcs.command(M.MAV_CMD_REQUEST_MESSAGE, M.MAVLINK_MSG_ID_HOME_POSITION)
        assert ack is not None
        assert sim.clock.now_s() - t0 >= 0.8  # 0.4 s each way


def test_mission_start_refused_when_disarmed_and_float_mission_items_round_trip():
    with running_vehicle(config=VehicleConfig(start_depth_m=2.0)) as (_sim, gcs):
        items = [M.MAVLink_mission_item_message(
            1, 1, seq, M.MAV_FRAME_GLOBAL_RELATIVE_ALT, M.MAV_CMD_NAV_WAYPOINT, 0, 1,
            2.0, 0, 0, 0, 47.0 + 1e-5 * seq, 8.0 + 2e-5 * seq, -2.5, 0) for seq in range(3)]
        gcs.mav.mission_count_send(1, 1, 3, 0)
        for _ in items:
            gcs.mav.send(items[gcs.wait_for("MISSION_REQUEST", 1.0).seq])
        assert gcs.wait_for("MISSION_ACK", 1.0).type == M.MAV_MISSION_ACCEPTED
        gcs.mav.mission_request_send(1, 1, 2, 0)
        back = gcs.wait_for("MISSION_ITEM", 1.0)
        assert back.seq == 2 and back.z == -2.5
        # MISSION_ITEM carries float32 degrees: one float32 step at 47 deg is 3.8e-6.
        assert abs(back.x - (47.0 + 2e-5)) < 4e-6 and abs(back.y - (8.0 + 4e-5)) < 1e-6
        gcs.mav.mission_request_send(1, 1, 7, 0)
        assert gcs.wait_for("MISSION_ACK", 1.0).type == M.MAV_MISSION_INVALID_SEQUENCE
        assert gcs.command(M.MAV_CMD_MISSION_START, 0, 0).result == M.MAV_RESULT_FAILED
        assert gcs.arm().result == M.MAV_RESULT_ACCEPTED
        assert gcs.command(M.MAV_CMD_MISSION_START, 0, 0).result == M.MAV_RESULT_ACCEPTED
        hb = gcs.wait_for("HEARTBEAT", 2.0, lambda m: m.custom_mode == Mode.AUTO)
        assert hb.base_mode & M.MAV_MODE_FLAG_AUTO_ENABLED
        current = gcs.wait_for("MISSION_CURRENT", 2.0)
        assert current.seq == 1 and current.mission_state == M.MISSION_STATE_ACTIVE
