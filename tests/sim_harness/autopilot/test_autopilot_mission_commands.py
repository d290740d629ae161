"""Mission commands beyond waypoints as ArduSub 4.5 stores and runs them: what a Mission
Planner or QGroundControl file carries (jumps, servos, relays, cameras, conditions, RTL,
LAND), AP_Mission's DO timing and DO_JUMP's counting (AP_Mission.cpp, MissionItemProtocol_
Waypoints.cpp, ArduSub/commands_logic.cpp; sim_harness/autopilot/mission_runner.py)."""

from __future__ import annotations

import math

from hypothesis import given, settings
from hypothesis import strategies as st

from sim_harness.autopilot.autopilot import Mode
from sim_harness.autopilot.mission_storage import PAYLOAD_FIELDS, download_fields, store_item
from tests.sim_harness.autopilot.gcs_peer import M, running_vehicle, vehicle_config
from tests.sim_harness.autopilot.test_autopilot_mission import LAT0, LON0, REL, _download, _item, _upload

MISSION = M.MAV_FRAME_MISSION
#: One metre north in 1e-7 degrees.
NORTH_1M_E7 = math.degrees(1.0 / 6378137.0) * 1e7


def _do(seq: int, command: int, p=(0.0, 0.0, 0.0, 0.0), x: int = 0, y: int = 0, z: float = 0.0):
    return _item(seq, frame=MISSION, command=command, p=p, x=x, y=y, z=z)


def _stored(command: int, p=(0.0, 0.0, 0.0, 0.0), frame: int = MISSION, x: int = 0, y: int = 0, z: float = 0.0):
    item, result = store_item(command, frame, p, x, y, z)
    assert result == M.MAV_MISSION_ACCEPTED, result
    return download_fields(item)


def test_commands_of_common_mission_files_are_stored_with_their_c_types():
    """mavlink_int_to_mission_cmd keeps each command's fields in its C struct (AP_Mission.h):
    known answers of the read-back (mission_cmd_to_mavlink_int)."""
    jump = _stored(M.MAV_CMD_DO_JUMP, (2.9, -1.0, 0, 0))
    assert jump.params == (2.0, -1.0, 0.0, 0.0)  # uint16 target truncated, int16 -1 = forever
    servo = _stored(M.MAV_CMD_DO_SET_SERVO, (9.0, 1500.7, 7.0, 7.0))
    assert servo.params == (9.0, 1500.0, 0.0, 0.0)  # uint8 channel, uint16 PWM; params 3-4 dropped
    relay = _stored(M.MAV_CMD_DO_REPEAT_RELAY, (1.0, 4.0, 0.25, 9.0))
    assert relay.params == (1.0, 4.0, 0.25, 0.0)
    cam = _stored(M.MAV_CMD_DO_SET_CAM_TRIGG_DIST, (2.5, 9.0, 1.0, 9.0))
    assert cam.params == (2.5, 0.0, 1.0, 0.0)  # meters from param1, trigger from param3
    digicam = _stored(M.MAV_CMD_DO_DIGICAM_CONTROL, (1.0, 0.0, -1.0, 0.0), x=1, y=7)
    assert (digicam.params, digicam.x, digicam.y) == ((1.0, 0.0, -1.0, 0.0), 1, 7)
    assert _stored(M.MAV_CMD_CONDITION_DISTANCE, (3.25, 1, 1, 1)).params == (3.25, 0.0, 0.0, 0.0)
    assert _stored(M.MAV_CMD_DO_GRIPPER, (1.0, 300.0, 0, 0)).params == (1.0, 255.0, 0.0, 0.0)  # uint8 clamps
    # NAV_LOITER_TURNS: half a turn in 1/256 and a radius over 255 m in tens of metres.
    turns = _stored(M.MAV_CMD_NAV_LOITER_TURNS, (0.5, 0, -300.0, 1.0), frame=REL, x=LAT0, y=LON0, z=-2.0)
    assert turns.params == (0.5, 0.0, -300.0, 1.0) and turns.frame == M.MAV_FRAME_GLOBAL_RELATIVE_ALT
    # NAV_LAND keeps param1 and the direction of param4; RTL keeps nothing (no location).
    land = _stored(M.MAV_CMD_NAV_LAND, (7.0, 0, 0, -1.0), frame=REL, x=LAT0, y=LON0, z=-1.0)
    assert land.params == (7.0, 0.0, 0.0, -1.0) and (land.x, land.y) == (LAT0, LON0)
    rtl = _stored(M.MAV_CMD_NAV_RETURN_TO_LAUNCH, (1, 2, 3, 4), frame=REL, x=LAT0, y=LON0, z=-1.0)
    assert (rtl.params, rtl.x, rtl.y, rtl.z, rtl.frame) == ((0.0, 0.0, 0.0, 0.0), 0, 0, 0.0, M.MAV_FRAME_GLOBAL)


def test_commands_ap_mission_does_not_know_are_unsupported():
    """The default of mavlink_int_to_mission_cmd's switch: DO_SET_ROI_LOCATION, DO_SET_ROI_NONE
    and unknown ids are MAV_MISSION_UNSUPPORTED (the ROI commands only as COMMAND_LONG/INT)."""
    for command in (M.MAV_CMD_DO_SET_ROI_LOCATION, M.MAV_CMD_DO_SET_ROI_NONE, 31999):
        assert store_item(command, MISSION, (0.0, 0.0, 0.0, 0.0), 0, 0, 0.0) == (None, M.MAV_MISSION_UNSUPPORTED)
    # sanity_check_params before the command's own check: a NaN param1 of command 0 is PARAM1.
    assert store_item(0, MISSION, (math.nan, 0.0, 0.0, 0.0), 0, 0, 0.0) == (None, M.MAV_MISSION_INVALID_PARAM1)
    assert store_item(0, MISSION, (0.0, 0.0, 0.0, 0.0), 0, 0, 0.0) == (None, M.MAV_MISSION_INVALID)


@settings(max_examples=200, deadline=None)
@given(st.sampled_from(sorted(PAYLOAD_FIELDS)),
       st.tuples(*[st.floats(-1e5, 1e5, allow_nan=False)] * 4),
       st.integers(-2**31, 2**31 - 1), st.integers(-2**31, 2**31 - 1), st.floats(-1e5, 1e5, allow_nan=False))
def test_a_downloaded_item_uploads_to_the_same_storage(command, params, x, y, z):
    """What the vehicle sends back is what it keeps: uploading the downloaded item again
    stores the same bytes, for every payload command and any finite values."""
    item, result = store_item(command, MISSION, params, x, y, z)
    assert result == M.MAV_MISSION_ACCEPTED
    back = download_fields(item)
    again, result = store_item(command, MISSION, back.params, back.x, back.y, back.z)
    assert result == M.MAV_MISSION_ACCEPTED
    assert again == item and again.content_bytes() == item.content_bytes()


def test_mission_planner_items_upload_and_bad_jumps_are_refused():
    """A file with a jump, a servo, a relay and a camera trigger uploads (we refused every one
    of them with UNSUPPORTED before, ending the upload); a DO_JUMP to item 0 or beyond the
    mission is MAV_MISSION_ERROR (MissionItemProtocol_Waypoints::append_item)."""
    items = [_item(0, frame=M.MAV_FRAME_GLOBAL, z=0.0), _item(1, z=-2.0),
             _do(2, M.MAV_CMD_DO_SET_SERVO, (9.0, 1900.0, 0, 0)), _do(3, M.MAV_CMD_DO_SET_RELAY, (0.0, 1.0, 0, 0)),
             _do(4, M.MAV_CMD_DO_DIGICAM_CONTROL, (0, 0, 0, 0), x=1), _do(5, M.MAV_CMD_DO_JUMP, (1.0, 2.0, 0, 0)),
             _item(6, z=-2.0)]
    with running_vehicle() as (_sim, gcs):
        assert _upload(gcs, items) == M.MAV_MISSION_ACCEPTED
        back = _download(gcs)
        assert [m.command for m in back[1:]] == [m.command for m in items[1:]]
        assert (back[2].param1, back[2].param2, back[5].param1, back[5].param2) == (9.0, 1900.0, 1.0, 2.0)
        for target in (0.0, 7.0):
            bad = list(items)
            bad[5] = _do(5, M.MAV_CMD_DO_JUMP, (target, 2.0, 0, 0))
            assert _upload(gcs, bad) == M.MAV_MISSION_ERROR
        last = list(items)
        last[5] = _do(5, M.MAV_CMD_DO_JUMP, (6.0, 2.0, 0, 0))  # the upload's last item: fine
        assert _upload(gcs, last) == M.MAV_MISSION_ACCEPTED


def _fly(items, until_seq: int, timeout_s: float = 120.0):
    """Upload ``items``, arm, AUTO; run until MISSION_ITEM_REACHED of ``until_seq``; return
    (simulator, gcs)."""
    ctx = running_vehicle(config=vehicle_config(start_depth_m=2.0))
    sim, gcs = ctx.__enter__()
    try:
        assert _upload(gcs, items) == M.MAV_MISSION_ACCEPTED
        assert gcs.arm().result == M.MAV_RESULT_ACCEPTED
        assert gcs.set_mode(int(Mode.AUTO)).result == M.MAV_RESULT_ACCEPTED
        assert gcs.wait_for("MISSION_ITEM_REACHED", timeout_s, lambda m: m.seq == until_seq) is not None
    except BaseException:
        ctx.__exit__(None, None, None)
        raise
    return ctx, sim, gcs


def _north(seq: int, metres: float, depth_m: float = 2.0):
    return _item(seq, x=LAT0 + int(round(metres * NORTH_1M_E7)), z=-depth_m)


def test_do_jump_repeats_the_legs_its_count_and_says_so():
    """get_next_cmd: a DO_JUMP with count 2 sends the mission back twice (the first jump
    recorded silently, the second "Mission: 3 Jump 2/2"), then on to the next item."""
    items = [_item(0, frame=M.MAV_FRAME_GLOBAL, z=0.0), _north(1, 0.0), _north(2, 3.0),
             _do(3, M.MAV_CMD_DO_JUMP, (1.0, 2.0, 0, 0)), _north(4, 6.0)]
    ctx, _sim, gcs = _fly(items, until_seq=4)
    try:
        navs = [m.seq for m in gcs.log if m.get_type() == "MISSION_ITEM_REACHED"]
        assert navs == [1, 2, 1, 2, 1, 2, 4]
        texts = [m.text for m in gcs.log if m.get_type() == "STATUSTEXT"]
        assert [t for t in texts if "Jump" in t] == ["Mission: 3 Jump 2/2"]
    finally:
        ctx.__exit__(None, None, None)


def test_do_items_after_a_waypoint_act_on_the_way_to_the_next():
    """advance_current_nav_cmd: the DO items after nav item N start when N completes, with
    N + 1 (one at a time); so the camera tilt after WP 1 is still the default until WP 1 is
    reached. A CONDITION_DISTANCE refused by the alt-frame check never completes and holds
    the DO items behind it back for the rest of the leg."""
    items = [_item(0, frame=M.MAV_FRAME_GLOBAL, z=0.0), _north(1, 3.0),
             _do(2, M.MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW, (-40.0, 0, 0, 0)), _north(3, 6.0),
             _do(4, M.MAV_CMD_CONDITION_DISTANCE, (1.0, 0, 0, 0)),
             _do(5, M.MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW, (-10.0, 0, 0, 0)), _north(6, 9.0)]
    with running_vehicle(config=vehicle_config(start_depth_m=2.0)) as (sim, gcs):
        default_deg = math.degrees(sim.autopilot.mount.pitch_rad)
        assert _upload(gcs, items) == M.MAV_MISSION_ACCEPTED
        assert gcs.arm().result == M.MAV_RESULT_ACCEPTED
        assert gcs.set_mode(int(Mode.AUTO)).result == M.MAV_RESULT_ACCEPTED
        gcs.run_for(2.0)
        assert abs(math.degrees(sim.autopilot.mount.pitch_rad) - default_deg) < 1e-6  # still on the way to WP 1
        assert gcs.wait_for("MISSION_ITEM_REACHED", 60.0, lambda m: m.seq == 1) is not None
        gcs.run_for(1.0)
        assert abs(math.degrees(sim.autopilot.mount.pitch_rad) + 40.0) < 1e-6
        assert gcs.wait_for("MISSION_ITEM_REACHED", 60.0, lambda m: m.seq == 6) is not None
        assert abs(math.degrees(sim.autopilot.mount.pitch_rad) + 40.0) < 1e-6  # item 5 never ran
        texts = [m.text for m in gcs.log if m.get_type() == "STATUSTEXT"]
        assert "Mission: 4 CondDist" in texts and "Mission: 5 GimbalPitchYaw" not in texts


def test_nav_land_surfaces_and_rtl_is_refused_by_subs_alt_frame_check():
    """do_surface: NAV_LAND with no place goes straight up and completes at the surface.
    NAV_RETURN_TO_LAUNCH keeps no location (stored_in_location), so Sub's check reads the
    absolute frame: "Bad alt frame", skipped."""
    items = [_item(0, frame=M.MAV_FRAME_GLOBAL, z=0.0), _north(1, 2.0),
             _item(2, command=M.MAV_CMD_NAV_RETURN_TO_LAUNCH, x=0, y=0, z=0.0),
             _item(3, command=M.MAV_CMD_NAV_LAND, x=0, y=0, z=0.0)]
    ctx, sim, gcs = _fly(items, until_seq=3)
    try:
        radius_m = sim.autopilot.params["WPNAV_RADIUS"] / 100.0
        truth = sim.truth()
        # Up from 2 m: done once the S-curve is at the surface and the vehicle within reach
        # (verify_surface: reached_wp_destination), where it was.
        assert truth.depth_m <= radius_m and truth.heave_m_s < 0.0 and abs(truth.north_m - 2.0) < 0.5
        texts = [m.text for m in gcs.log if m.get_type() == "STATUSTEXT"]
        assert "Mission: 2 RTL" in texts and "Bad alt frame" in texts
        assert [m.seq for m in gcs.log if m.get_type() == "MISSION_ITEM_REACHED"] == [1, 3]
    finally:
        ctx.__exit__(None, None, None)


def test_float_items_keep_x_and_y_that_are_no_place():
    """convert_MISSION_ITEM_to_MISSION_ITEM_INT scales x/y by 1e7 only for commands with a
    location; a camera command's shooting flag in x passes straight, both ways (we scaled
    it to 1e7 and clamped it to 255 before)."""
    lat = LAT0 * 1e-7
    items = [M.MAVLink_mission_item_message(1, 1, 0, M.MAV_FRAME_GLOBAL, 16, 0, 1, 0, 0, 0, 0, lat, LON0 * 1e-7, 0, 0),
             M.MAVLink_mission_item_message(1, 1, 1, REL, 16, 0, 1, 0, 0, 0, 0, lat, LON0 * 1e-7, -2.0, 0),
             M.MAVLink_mission_item_message(1, 1, 2, MISSION, M.MAV_CMD_DO_DIGICAM_CONTROL, 0, 1, 1, 0, 0, 0,
                                            1.0, 3.0, 0, 0)]
    with running_vehicle() as (sim, gcs):
        assert _upload(gcs, items) == M.MAV_MISSION_ACCEPTED
        stored = sim.autopilot.mission.items[2]
        assert stored.payload[4:6] == (1, 3)  # shooting_cmd and cmd_id
        gcs.mav.mission_request_send(1, 1, 2, 0)  # the float form back
        back = gcs.wait_for("MISSION_ITEM", 1.0, lambda m: m.seq == 2)
        assert (back.x, back.y) == (1.0, 3.0)
        gcs.mav.mission_request_send(1, 1, 1, 0)
        wp = gcs.wait_for("MISSION_ITEM", 1.0, lambda m: m.seq == 1)
        assert abs(wp.x - lat) < 2e-6  # a place: degrees


def test_a_jump_forever_over_refused_items_ends_the_mission():
    """advance_current_nav_cmd gives up after 255 tries: a DO_JUMP repeating forever over a
    waypoint Sub refuses (absolute frame) completes the mission instead of hanging."""
    items = [_item(0, frame=M.MAV_FRAME_GLOBAL, z=0.0), _item(1, frame=M.MAV_FRAME_GLOBAL_INT, z=-3.0),
             _do(2, M.MAV_CMD_DO_JUMP, (1.0, -1.0, 0, 0))]
    with running_vehicle(config=vehicle_config(start_depth_m=2.0)) as (sim, gcs):
        assert _upload(gcs, items) == M.MAV_MISSION_ACCEPTED
        assert gcs.arm().result == M.MAV_RESULT_ACCEPTED
        gcs.set_mode(int(Mode.AUTO))  # its ACK may drown in the 510 texts of the search
        gcs.run_for(1.0)
        assert sim.autopilot.runner.state == M.MISSION_STATE_COMPLETE
        assert sim.truth().mode == Mode.AUTO  # the mission's end: loiter in AUTO
