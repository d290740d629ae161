"""The mission as ArduSub 4.5 stores, returns and runs it (AP_Mission, MissionItemProtocol,
Sub::start_command)."""

from __future__ import annotations

import math

import numpy as np

from sim_harness.autopilot.autopilot import Mode
from sim_harness.autopilot.mission import REREQUEST_INTERVAL_S, UPLOAD_TIMEOUT_S
from sim_harness.autopilot.mission_storage import store_item
from sim_harness.vehicle.sensors import FlatSeabed
from tests.sim_harness.autopilot.gcs_peer import ORIGIN, M, running_vehicle, vehicle_config

REL = M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
LAT0, LON0 = int(ORIGIN[0] * 1e7), int(ORIGIN[1] * 1e7)


def _item(seq: int, frame: int = REL, command: int = M.MAV_CMD_NAV_WAYPOINT, p=(0.0, 0.0, 0.0, 0.0),
          x: int | None = None, y: int | None = None, z: float = -3.0):
    return M.MAVLink_mission_item_int_message(1, 1, seq, frame, command, 0, 1, *p,
                                              LAT0 + 100 * seq if x is None else x, LON0 if y is None else y, z, 0)


def _upload(gcs, items) -> int:
    gcs.mav.mission_count_send(1, 1, len(items), 0)
    while True:
        msg = gcs.wait_for(("MISSION_REQUEST", "MISSION_REQUEST_INT", "MISSION_ACK"), 2.0)
        assert msg is not None and msg.get_type() != "MISSION_REQUEST_INT"  # 4.5 asks with MISSION_REQUEST
        if msg.get_type() == "MISSION_ACK":
            return msg.type
        gcs.mav.send(items[msg.seq])


def _download(gcs) -> list:
    gcs.mav.mission_request_list_send(1, 1, 0)
    count = gcs.wait_for("MISSION_COUNT", 1.0).count
    out = []
    for seq in range(count):
        gcs.mav.mission_request_int_send(1, 1, seq, 0)
        out.append(gcs.wait_for("MISSION_ITEM_INT", 1.0, lambda m, s=seq: m.seq == s))
    return out


def test_storage_quantises_as_ap_mission():
    """mavlink_int_to_mission_cmd: alt whole cm truncated toward zero; NAV_WAYPOINT keeps
    param1 (uint16 s) only; mission_cmd_to_mavlink_int: frames 0/3/10, z = alt * 0.01f."""
    item, result = store_item(M.MAV_CMD_NAV_WAYPOINT, REL, (2.7, 1.5, 0.3, 45.0), LAT0, LON0, -5.4789)
    assert result == M.MAV_MISSION_ACCEPTED and item.alt_cm == -547 and item.p1 == 2
    # DO_CHANGE_SPEED's payload read as a Location (Sub::start_command): speed type 1 sets
    # relative_alt; the "alt" is the last byte of the speed and three of the throttle, so
    # throttle 0 reads as a positive altitude (refused) and -1 as a negative one (run).
    speed, _ = store_item(M.MAV_CMD_DO_CHANGE_SPEED, M.MAV_FRAME_MISSION, (1.0, 0.5, 0.0, 0.0), 0, 0, 0)
    assert speed.alt_frame() == ("above_home", 63)
    speed, _ = store_item(M.MAV_CMD_DO_CHANGE_SPEED, M.MAV_FRAME_MISSION, (1.0, 0.5, -1.0, 0.0), 0, 0, 0)
    assert speed.alt_frame()[0] == "above_home" and speed.alt_frame()[1] < 0
    mount, _ = store_item(M.MAV_CMD_DO_MOUNT_CONTROL, M.MAV_FRAME_MISSION, (-30.0, 0.0, 0.0, 0.0), 0, 0, 2)
    assert mount.alt_frame()[0] == "absolute" and mount.payload == (-30.0, 0.0, 0.0)  # param7 not stored
    item, _ = store_item(M.MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW, M.MAV_FRAME_MISSION, (-34.7, 0.0, 0.0, 0.0), 0, 0, 0)
    assert item.payload[:2] == (-34, 0)  # int8 whole degrees
    for bad, expected in (((math.nan, 0, 0, 0), M.MAV_MISSION_INVALID_PARAM1),
                          ((0, math.inf, 0, 0), M.MAV_MISSION_INVALID_PARAM2)):
        assert store_item(M.MAV_CMD_NAV_WAYPOINT, REL, bad, LAT0, LON0, -1.0) == (None, expected)
    assert store_item(M.MAV_CMD_NAV_WAYPOINT, REL, (0, 0, 0, math.nan), LAT0, LON0, -1.0)[1] == M.MAV_MISSION_ACCEPTED
    assert store_item(M.MAV_CMD_NAV_WAYPOINT, REL, (0, 0, 0, 0), LAT0, LON0, 9e4)[1] == M.MAV_MISSION_INVALID_PARAM7


def test_upload_and_readback_over_mavlink():
    items = [_item(0, frame=M.MAV_FRAME_GLOBAL, z=0.0),
             _item(1, p=(3.0, 1.5, 0.0, 90.0), z=-2.345),
             _item(2, frame=M.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT, z=1.255),
             _item(3, frame=M.MAV_FRAME_GLOBAL_INT, z=10.0)]
    with running_vehicle() as (_sim, gcs):
        assert _upload(gcs, items) == M.MAV_MISSION_ACCEPTED
        assert any(m.text == "Flight plan received" for m in gcs.log if m.get_type() == "STATUSTEXT")
        home, one, two, three = _download(gcs)
        assert (home.frame, home.x, home.y, home.z) == (M.MAV_FRAME_GLOBAL, LAT0, LON0, 0.0)  # the live home
        assert (one.frame, one.param1, one.param2, one.param4) == (M.MAV_FRAME_GLOBAL_RELATIVE_ALT, 3.0, 0.0, 0.0)
        assert one.z == float(np.float32(-234) * np.float32(0.01))
        assert (two.frame, round(two.z, 4)) == (M.MAV_FRAME_GLOBAL_TERRAIN_ALT, 1.25)
        assert three.frame == M.MAV_FRAME_GLOBAL and all(m.autocontinue == 1 for m in (one, two, three))


def test_upload_rerequests_times_out_and_refuses_what_it_cannot_store():
    """queued_request_send re-asks after 1 s; 8 s of silence: OPERATION_CANCELLED; an item
    outside an upload: ERROR."""
    with running_vehicle() as (_sim, gcs):
        gcs.mav.mission_count_send(1, 1, 3, 0)
        assert gcs.wait_for("MISSION_REQUEST", 1.0).seq == 0
        again = gcs.wait_for("MISSION_REQUEST", REREQUEST_INTERVAL_S + 0.5)
        assert again is not None and again.seq == 0
        gcs.mav.send(_item(0))
        assert gcs.wait_for("MISSION_REQUEST", 1.0).seq == 1
        ack = gcs.wait_for("MISSION_ACK", UPLOAD_TIMEOUT_S + 1.0)
        assert ack is not None and ack.type == M.MAV_MISSION_OPERATION_CANCELLED
        for bad, expected in ((_item(1, frame=M.MAV_FRAME_LOCAL_NED), M.MAV_MISSION_UNSUPPORTED_FRAME),
                              (_item(1, command=31000), M.MAV_MISSION_UNSUPPORTED)):
            gcs.mav.mission_count_send(1, 1, 2, 0)
            assert gcs.wait_for("MISSION_REQUEST", 1.0).seq == 0
            gcs.mav.send(_item(0))
            assert gcs.wait_for("MISSION_REQUEST", 1.0).seq == 1
            gcs.mav.send(bad)
            assert gcs.wait_for("MISSION_ACK", 1.0).type == expected
        gcs.mav.mission_count_send(1, 1, 1, M.MAV_MISSION_TYPE_FENCE)
        assert gcs.wait_for("MISSION_ACK", 1.0).type == M.MAV_MISSION_UNSUPPORTED
        # An item with no upload running (GCS_MAVLINK::handle_mission_item): MAV_MISSION_ERROR.
        gcs.mav.send(_item(1))
        assert gcs.wait_for("MISSION_ACK", 1.0).type == M.MAV_MISSION_ERROR


def test_auto_runs_only_the_alt_frames_sub_accepts_and_skips_ineffective_do_items():
    """Sub::start_command: relative alt <= 0 or terrain alt >= 0, else "Bad alt frame" (the
    4.1 text "BAD NAV AltFrame" is gone); DO_CHANGE_SPEED / DO_MOUNT_CONTROL / CONDITION_DELAY
    fail the same check through their packed payload; DO_GIMBAL_MANAGER_PITCHYAW is run
    by AP_Mission itself."""
    items = [
        _item(0, frame=M.MAV_FRAME_GLOBAL, z=0.0),
        _item(1, frame=M.MAV_FRAME_GLOBAL_INT, z=-3.0),  # absolute: "Bad alt frame", skipped
        _item(2, z=3.0),  # relative above the surface: refused
        _item(3, frame=M.MAV_FRAME_MISSION, command=M.MAV_CMD_DO_CHANGE_SPEED, p=(1.0, 0.5, 0.0, 0.0), x=0, y=0, z=0),
        _item(4, frame=M.MAV_FRAME_MISSION, command=M.MAV_CMD_DO_MOUNT_CONTROL, p=(-45.0, 0, 0, 0), x=0, y=0, z=2),
        _item(5, frame=M.MAV_FRAME_MISSION, command=M.MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW, p=(-30.4, 0, 0, 0),
              x=0, y=0, z=0),
        _item(6, x=0, y=0, z=-2.0, p=(2.0, 0, 0, 0)),  # here, 2 m deep, 2 s hold
    ]
    with running_vehicle(config=vehicle_config(start_depth_m=2.0)) as (sim, gcs):
        assert _upload(gcs, items) == M.MAV_MISSION_ACCEPTED
        assert gcs.arm().result == M.MAV_RESULT_ACCEPTED
        assert gcs.set_mode(int(Mode.AUTO)).result == M.MAV_RESULT_ACCEPTED
        assert gcs.wait_for("MISSION_ITEM_REACHED", 20.0, lambda m: m.seq == 6) is not None
        # Sub's verify_command_callback reports the DO items Sub verifies (3, 4) as well as
        # the waypoint; AP_Mission's own DO_GIMBAL_MANAGER_PITCHYAW (5) is not reported.
        assert [m.seq for m in gcs.log if m.get_type() == "MISSION_ITEM_REACHED"] == [3, 4, 6]
        texts = [m.text for m in gcs.log if m.get_type() == "STATUSTEXT"]
        # AP_Mission::start_command announces every command it starts, refused ones too.
        assert [t for t in texts if t.startswith("Mission: ")] == [
            "Mission: 1 WP", "Mission: 2 WP", "Mission: 3 ChangeSpeed", "Mission: 6 WP", "Mission: 4 MountControl",
            "Mission: 5 GimbalPitchYaw"]
        assert texts.count("Bad alt frame") == 2  # item 1 and DO_MOUNT_CONTROL
        assert texts.count("Alt above home must be negative") == 2  # item 2 and DO_CHANGE_SPEED
        assert "Reached command #6" in texts
        assert sim.autopilot.params["WPNAV_SPEED"] == 100.0  # DO_CHANGE_SPEED had no effect
        assert abs(math.degrees(sim.autopilot.mount.pitch_rad) + 30.0) < 1e-6  # int8: -30, not -45
        hb = gcs.wait_for("HEARTBEAT", 2.0)
        assert hb.custom_mode == Mode.AUTO  # mission end: loiter in AUTO


def test_disarm_resets_the_mission_and_auto_then_starts_at_item_1():
    """AP_Arming_Sub::disarm calls sub.mission.reset(): after a disarm, AUTO starts the
    mission again at item 1; without one it resumes where it was (AP_Mission::start_or_resume)."""
    items = [_item(0, frame=M.MAV_FRAME_GLOBAL, z=0.0),
             _item(1, x=LAT0, z=-2.0, p=(1.0, 0.0, 0.0, 0.0)),  # here, 2 m deep, 1 s hold
             _item(2, x=LAT0 + 900, z=-2.0)]  # 10 m north
    for disarm in (False, True):
        with running_vehicle(config=vehicle_config(start_depth_m=2.0)) as (sim, gcs):
            assert _upload(gcs, items) == M.MAV_MISSION_ACCEPTED
            assert gcs.arm().result == M.MAV_RESULT_ACCEPTED
            assert gcs.set_mode(int(Mode.AUTO)).result == M.MAV_RESULT_ACCEPTED
            assert gcs.wait_for("MISSION_ITEM_REACHED", 20.0, lambda m: m.seq == 1) is not None
            assert gcs.set_mode(int(Mode.GUIDED)).result == M.MAV_RESULT_ACCEPTED  # item 2 not reached
            if disarm:
                assert gcs.command(M.MAV_CMD_COMPONENT_ARM_DISARM, 0, 0).result == M.MAV_RESULT_ACCEPTED
                assert not sim.truth().armed
                assert gcs.arm().result == M.MAV_RESULT_ACCEPTED
            assert gcs.set_mode(int(Mode.AUTO)).result == M.MAV_RESULT_ACCEPTED
            current = gcs.wait_for("MISSION_CURRENT", 2.0)
            assert current is not None and current.seq == (1 if disarm else 2)


def _go_here(gcs, item, current: int = 2) -> int:
    """Send ``item`` as a "guided" request (current 2) or an altitude change (current 3): the
    MISSION_ACK's type."""
    item.current = current
    gcs.mav.send(item)
    ack = gcs.wait_for("MISSION_ACK", 2.0)
    assert ack is not None
    return ack.type


def test_go_here_items_fly_in_guided_and_are_refused_elsewhere():
    """GCS_MAVLINK::handle_mission_item: current 2 is ``handle_guided_request`` ->
    ``Sub::do_guided``: only in GUIDED, NAV_WAYPOINT flies to the place, CONDITION_YAW turns,
    any other command MAV_MISSION_ERROR; the item is decoded as an upload's would be (its
    refusal is the answer); current 3 is ACCEPTED with no effect; nothing is stored."""
    north = LAT0 + int(round(math.degrees(10.0 / 6378137.0) * 1e7))  # 10 m north
    with running_vehicle(config=vehicle_config(start_depth_m=2.0)) as (sim, gcs):
        stored = len(_download(gcs))
        assert gcs.arm().result == M.MAV_RESULT_ACCEPTED
        assert gcs.set_mode(int(Mode.ALT_HOLD)).result == M.MAV_RESULT_ACCEPTED
        assert _go_here(gcs, _item(0, x=north, z=-3.0)) == M.MAV_MISSION_ERROR  # not GUIDED
        assert gcs.set_mode(int(Mode.GUIDED)).result == M.MAV_RESULT_ACCEPTED
        change_speed = _item(0, frame=M.MAV_FRAME_MISSION, command=M.MAV_CMD_DO_CHANGE_SPEED, p=(1.0, 0.5, 0, 0),
                             x=0, y=0, z=0)
        assert _go_here(gcs, change_speed) == M.MAV_MISSION_ERROR  # do_guided rejects it
        assert _go_here(gcs, _item(0, x=north, z=-3.0, p=(math.nan, 0, 0, 0))) == M.MAV_MISSION_INVALID_PARAM1
        assert _go_here(gcs, _item(0, x=north, z=-3.0), current=3) == M.MAV_MISSION_ACCEPTED
        gcs.run_for(5.0)
        assert abs(sim.truth().north_m) < 0.5  # the altitude change did nothing
        assert _go_here(gcs, _item(0, x=north, z=-3.0)) == M.MAV_MISSION_ACCEPTED
        gcs.run_for(40.0)
        t = sim.truth()
        assert abs(t.north_m - 10.0) < 0.5 and abs(t.east_m) < 0.5 and abs(t.depth_m - 3.0) < 0.3
        yaw = _item(0, frame=M.MAV_FRAME_MISSION, command=M.MAV_CMD_CONDITION_YAW, p=(90.0, 0, 0, 0), x=0, y=0, z=0)
        assert _go_here(gcs, yaw) == M.MAV_MISSION_ACCEPTED
        gcs.run_for(15.0)
        assert abs(math.degrees(sim.truth().yaw_rad) - 90.0) < 3.0
        # The float form is converted first and taken the same way (the float-item warning is
        # sent on the upload path only, after the requests are answered).
        back = M.MAVLink_mission_item_message(1, 1, 0, REL, M.MAV_CMD_NAV_WAYPOINT, 2, 1, 0, 0, 0, 0,
                                               LAT0 * 1e-7, LON0 * 1e-7, -3.0, 0)
        gcs.mav.send(back)
        assert gcs.wait_for("MISSION_ACK", 2.0).type == M.MAV_MISSION_ACCEPTED
        gcs.run_for(40.0)
        assert abs(sim.truth().north_m) < 0.5
        assert len(_download(gcs)) == stored


def test_terrain_item_follows_the_seabed_by_the_rangefinder():
    world = FlatSeabed(15.0)
    north = ORIGIN[0] + math.degrees(10.0 / 6378137.0)
    items = [_item(0, frame=M.MAV_FRAME_GLOBAL, z=0.0),
             _item(1, frame=M.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT, x=int(round(north * 1e7)), z=4.0)]
    with running_vehicle(world, config=vehicle_config(start_depth_m=2.0)) as (sim, gcs):
        assert _upload(gcs, items) == M.MAV_MISSION_ACCEPTED
        assert gcs.arm().result == M.MAV_RESULT_ACCEPTED
        assert gcs.command(M.MAV_CMD_MISSION_START, 0, 0).result == M.MAV_RESULT_ACCEPTED
        assert gcs.wait_for("MISSION_ITEM_REACHED", 60.0) is not None
        t = sim.truth()
        assert abs(t.altitude_m - 4.0) < 0.3 and abs(t.north_m - 10.0) < 2.0
    no_rangefinder = vehicle_config(start_depth_m=2.0, params={"RNGFND1_TYPE": 0})
    with running_vehicle(world, config=no_rangefinder) as (sim, gcs):
        assert _upload(gcs, items) == M.MAV_MISSION_ACCEPTED
        assert gcs.arm().result == M.MAV_RESULT_ACCEPTED
        assert gcs.set_mode(int(Mode.AUTO)).result == M.MAV_RESULT_ACCEPTED
        gcs.run_for(1.0)
        texts = [m.text for m in gcs.log if m.get_type() == "STATUSTEXT"]
        assert "Terrain data (rangefinder) not available" in texts
        assert not sim.truth().armed  # FS_TERRAIN_ENAB 0: disarm


def test_float_mission_items_are_converted_in_float32_with_a_warning():
    with running_vehicle() as (_sim, gcs):
        items = [M.MAVLink_mission_item_message(1, 1, seq, M.MAV_FRAME_GLOBAL_RELATIVE_ALT, M.MAV_CMD_NAV_WAYPOINT,
                                                0, 1, 2.0, 0, 0, 0, 47.0 + 1e-5 * seq, 8.0 + 2e-5 * seq, -2.5, 0)
                 for seq in range(3)]
        assert _upload(gcs, items) == M.MAV_MISSION_ACCEPTED
        assert any("GCS should send MISSION_ITEM_INT" in m.text for m in gcs.log if m.get_type() == "STATUSTEXT")
        gcs.mav.mission_request_send(1, 1, 2, 0)
        back = gcs.wait_for("MISSION_ITEM", 1.0)
        assert back.seq == 2 and back.z == -2.5
        assert abs(back.x - (47.0 + 2e-5)) < 4e-6 and abs(back.y - (8.0 + 4e-5)) < 1e-6
        gcs.mav.mission_request_send(1, 1, 7, 0)
        assert gcs.wait_for("MISSION_ACK", 1.0).type == M.MAV_MISSION_INVALID_SEQUENCE
