"""A plain pymavlink ground station flies the simulated sub: heartbeat, modes, mission, telemetry."""

from __future__ import annotations

import math

from pymavlink import mavwp

from sim_harness.autopilot.autopilot import Mode
from sim_harness.vehicle.sensors import FlatSeabed
from tests.sim_harness.autopilot.gcs_peer import M, running_vehicle, vehicle_config


def test_heartbeat_is_an_ardupilot_submarine_on_mavlink2():
    with running_vehicle(FlatSeabed(20.0)) as (_sim, gcs):
        hb = gcs.wait_for("HEARTBEAT", 3.0, lambda m: m.get_srcSystem() == 1)
        assert hb is not None
        assert hb.type == M.MAV_TYPE_SUBMARINE
        assert hb.autopilot == M.MAV_AUTOPILOT_ARDUPILOTMEGA
        assert hb.custom_mode == Mode.MANUAL
        assert hb.get_msgbuf()[0] == 0xFD  # MAVLink 2 framing
        assert gcs.conn.flightmode == "MANUAL"  # mavutil decodes it as an ArduSub mode


def test_gcs_switches_modes_and_sees_them_in_the_heartbeat():
    with running_vehicle(config=vehicle_config(start_depth_m=3.0)) as (_sim, gcs):
        for mode in (Mode.STABILIZE, Mode.ALT_HOLD, Mode.POSHOLD, Mode.GUIDED, Mode.SURFTRAK):
            ack = gcs.set_mode(int(mode))
            assert ack is not None and ack.result == M.MAV_RESULT_ACCEPTED, mode
            hb = gcs.wait_for("HEARTBEAT", 2.0, lambda m, mode=mode: m.custom_mode == mode)
            assert hb is not None, mode
        gcs.conn.set_mode("ALT_HOLD")  # mavutil's own mode-name path (ArduSub mode map)
        ack = gcs.wait_for("COMMAND_ACK", 2.0, lambda m: m.command == M.MAV_CMD_DO_SET_MODE)
        assert ack is not None and ack.result == M.MAV_RESULT_ACCEPTED
        assert gcs.wait_for("HEARTBEAT", 2.0, lambda m: m.custom_mode == Mode.ALT_HOLD)
        # The legacy SET_MODE message changes the mode with no reply: Sub 4.5's
        # GCS_MAVLINK::handle_set_mode no longer sends the COMMAND_ACK (command 11) that
        # earlier versions did (removed in 3f2c82df12, 2024-02-01, before Sub-4.5 branched).
        gcs.mav.set_mode_send(1, M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, int(Mode.MANUAL))
        assert gcs.wait_for("HEARTBEAT", 2.0, lambda m: m.custom_mode == Mode.MANUAL)
        assert not [m for m in gcs.log if m.get_type() == "COMMAND_ACK" and m.command == M.MAVLINK_MSG_ID_SET_MODE]
        gcs.mav.set_mode_send(1, 0, int(Mode.GUIDED))  # without the custom-mode flag: ignored
        gcs.run_for(1.5)
        assert gcs.wait_for("HEARTBEAT", 2.0).custom_mode == Mode.MANUAL


def _waypoints(origin_lat: float, origin_lon: float) -> list:
    items = []
    for seq, (dn, de, z) in enumerate([(0, 0, 0), (8, 0, -4), (8, 6, -4), (0, 6, 3.0)]):
        lat = origin_lat + math.degrees(dn / 6378137.0)
        lon = origin_lon + math.degrees(de / (6378137.0 * math.cos(math.radians(origin_lat))))
        frame = M.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT if seq == 3 else M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
        items.append(M.MAVLink_mission_item_int_message(
            1, 1, seq, frame, M.MAV_CMD_NAV_WAYPOINT, 0, 1, 0, 0, 0, float("nan"),
            int(round(lat * 1e7)), int(round(lon * 1e7)), z, M.MAV_MISSION_TYPE_MISSION))
    return items


def _upload(gcs, items) -> int:
    gcs.mav.mission_count_send(1, 1, len(items), M.MAV_MISSION_TYPE_MISSION)
    while True:
        msg = gcs.wait_for(("MISSION_REQUEST", "MISSION_REQUEST_INT", "MISSION_ACK"), 3.0)
        assert msg is not None, "vehicle stopped asking for items"
        if msg.get_type() == "MISSION_ACK":
            return msg.type
        gcs.mav.send(items[msg.seq])


def test_mission_upload_download_and_auto_flight():
    world = FlatSeabed(15.0)
    with running_vehicle(world, config=vehicle_config(start_depth_m=2.0)) as (sim, gcs):
        items = _waypoints(47.0, 8.0)
        assert _upload(gcs, items) == M.MAV_MISSION_ACCEPTED
        # Download with pymavlink's own mission loader conventions.
        gcs.mav.mission_request_list_send(1, 1, M.MAV_MISSION_TYPE_MISSION)
        count = gcs.wait_for("MISSION_COUNT", 2.0)
        assert count is not None and count.count == len(items)
        loader = mavwp.MAVWPLoader()
        for seq in range(count.count):
            gcs.mav.mission_request_int_send(1, 1, seq, M.MAV_MISSION_TYPE_MISSION)
            item = gcs.wait_for("MISSION_ITEM_INT", 2.0, lambda m, seq=seq: m.seq == seq)
            assert item is not None
            loader.add(item)
        gcs.mav.mission_ack_send(1, 1, M.MAV_MISSION_ACCEPTED, M.MAV_MISSION_TYPE_MISSION)
        home = loader.wp(0)
        assert (home.x, home.y) == (470000000, 80000000)  # item 0 is home
        # ArduSub 4.5 (AP_Mission::mission_cmd_to_mavlink_int) sends the frames back without
        # _INT: relative-alt 6 as 3, terrain 11 as 10.
        for seq in (1, 2, 3):
            got, sent = loader.wp(seq), items[seq]
            frame = {M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT: M.MAV_FRAME_GLOBAL_RELATIVE_ALT,
                     M.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT: M.MAV_FRAME_GLOBAL_TERRAIN_ALT}[sent.frame]
            assert (got.x, got.y, got.z, got.frame) == (sent.x, sent.y, sent.z, frame)

        assert gcs.arm().result == M.MAV_RESULT_ACCEPTED
        assert gcs.set_mode(int(Mode.AUTO)).result == M.MAV_RESULT_ACCEPTED
        reached = []
        msgs = gcs.run_for(120.0)
        reached = [m.seq for m in msgs if m.get_type() == "MISSION_ITEM_REACHED"]
        assert reached == [1, 2, 3]
        truth = sim.truth()
        # Last item: 3 m above the seabed at (0, 6).
        assert math.hypot(truth.north_m - 0.0, truth.east_m - 6.0) < 1.5
        assert abs(truth.altitude_m - 3.0) < 0.5
        current = [m for m in msgs if m.get_type() == "MISSION_CURRENT"]
        assert current and current[-1].seq == 3
        assert current[-1].mission_state == M.MISSION_STATE_COMPLETE


def test_telemetry_at_default_rates_and_set_message_interval():
    with running_vehicle(config=vehicle_config(start_depth_m=4.0)) as (sim, gcs):
        gcs.pump()
        msgs = gcs.run_for(10.0)
        att = [m for m in msgs if m.get_type() == "ATTITUDE"]
        pos = [m for m in msgs if m.get_type() == "GLOBAL_POSITION_INT"]
        assert 95 <= len(att) <= 105  # SR0_EXTRA1 = 10 Hz
        assert 28 <= len(pos) <= 32  # SR0_POSITION = 3 Hz
        # Depth as negative altitude; disarmed and positively buoyant, the sub rises.
        assert abs(pos[-1].relative_alt / 1000.0 + sim.truth().depth_m) < 0.15
        assert sim.truth().depth_m < 3.5
        ack = gcs.command(M.MAV_CMD_SET_MESSAGE_INTERVAL, M.MAVLINK_MSG_ID_ATTITUDE, 500_000)
        assert ack.result == M.MAV_RESULT_ACCEPTED
        gcs.run_for(0.5)
        msgs = gcs.run_for(10.0)
        assert 19 <= sum(m.get_type() == "ATTITUDE" for m in msgs) <= 21  # now 2 Hz
        ack = gcs.command(M.MAV_CMD_SET_MESSAGE_INTERVAL, M.MAVLINK_MSG_ID_ATTITUDE, -1)
        gcs.run_for(0.5)
        assert not any(m.get_type() == "ATTITUDE" for m in gcs.run_for(3.0))
        ack = gcs.command(M.MAV_CMD_SET_MESSAGE_INTERVAL, 9999, 100_000)
        assert ack.result == M.MAV_RESULT_DENIED  # no such message: as ArduPilot


def test_the_same_over_tcp():
    with running_vehicle(listen="tcp:127.0.0.1:0", config=vehicle_config(start_depth_m=2)) as (
        _sim, gcs,
    ):
        hb = gcs.wait_for("HEARTBEAT", 2.0)
        assert hb.type == M.MAV_TYPE_SUBMARINE and hb.get_msgbuf()[0] == 0xFD
        assert gcs.set_mode(int(Mode.ALT_HOLD)).result == M.MAV_RESULT_ACCEPTED
        assert _upload(gcs, _waypoints(47.0, 8.0)) == M.MAV_MISSION_ACCEPTED
        msgs = gcs.run_for(2.0)
        assert 18 <= sum(m.get_type() == "ATTITUDE" for m in msgs) <= 22
