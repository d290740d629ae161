"""Mission protocol: the pure state machines, then full transfers against the peer."""

from __future__ import annotations

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from tests.vehicle_link.vl_peer import make_config
from vehicle_link.errors import MissionError, MissionTimeout, MissionVerifyError
from vehicle_link.mission import (
    HOME_PLACEHOLDER,
    MissionItem,
    ardupilot_wire_items,
    ardusub_stored,
    item_from_message,
    item_to_message,
    items_match,
    verify_items,
    waypoint,
)
from vehicle_link.mission_protocol import (
    MissionDownload,
    MissionUpload,
    SendAck,
    SendCount,
    SendItem,
    SendRequest,
    SendRequestList,
)


def _survey(n: int = 6) -> list[MissionItem]:
    return [
        waypoint(
            47.6 + 1e-5 * i,
            -122.3 - 2e-5 * i,
            5.0 + 0.5 * i,
            hold_s=float(i % 2),
            acceptance_radius_m=1.5,
        )
        for i in range(n)
    ]


# ---- pure state machines ------------------------------------------------------------------


def test_upload_machine_answers_requests_and_rerequests():
    items = ardupilot_wire_items(_survey(3))
    up = MissionUpload(items)
    assert up.start() == [SendCount(4)]
    assert up.on_request(0) == [SendItem(0, HOME_PLACEHOLDER)]
    assert up.on_request(1) == [SendItem(1, items[1])]
    assert up.on_request(1) == [SendItem(1, items[1])]  # re-request: same item again
    assert up.on_ack(mavlink2.MAV_MISSION_INVALID_SEQUENCE) == []  # ArduPilot's duplicate ack
    assert not up.done
    up.on_request(2)
    up.on_request(3)
    up.on_ack(mavlink2.MAV_MISSION_ACCEPTED)
    assert up.done and up.ignored_acks == 1


def test_upload_machine_ignores_stale_accept_and_fails_on_refusal():
    up = MissionUpload(ardupilot_wire_items(_survey(2)))
    up.start()
    up.on_ack(mavlink2.MAV_MISSION_ACCEPTED)  # left over from an earlier transaction
    assert not up.done
    with pytest.raises(MissionError) as info:
        up.on_ack(mavlink2.MAV_MISSION_NO_SPACE)
    assert info.value.result == mavlink2.MAV_MISSION_NO_SPACE
    with pytest.raises(MissionError):
        MissionUpload(_survey(2)).on_request(5)


def test_upload_machine_ends_unconfirmed_when_the_final_ack_was_lost():
    """The last item re-sent after a lost ACCEPTED: ArduSub 4.5, no longer receiving, answers
    MAV_MISSION_ERROR (GCS_Common.cpp GCS_MAVLINK::handle_mission_item); the upload has
    ended, to be verified by download, not failed."""
    items = _survey(1)
    up = MissionUpload(items)
    up.start()
    up.on_request(0)
    assert up.on_timeout() == [SendItem(0, items[0])]  # the ACCEPTED was lost: send the last again
    up.on_ack(mavlink2.MAV_MISSION_ERROR)
    assert up.done and up.unconfirmed
    early = MissionUpload(_survey(2))
    early.start()
    early.on_request(0)
    with pytest.raises(MissionError):  # before the end an ERROR is a refusal
        early.on_ack(mavlink2.MAV_MISSION_ERROR)


def test_upload_machine_timeouts_resend_then_give_up():
    items = _survey(2)
    up = MissionUpload(items, max_retries=2)
    up.start()
    assert up.on_timeout() == [SendCount(2)]  # count lost: announce again
    up.on_request(0)
    assert up.on_timeout() == [SendItem(0, items[0])]  # item lost: send it again
    assert up.on_timeout() == [SendItem(0, items[0])]
    with pytest.raises(MissionTimeout):
        up.on_timeout()


def test_download_machine_requests_in_order_and_skips_duplicates():
    items = _survey(3)
    down = MissionDownload(max_retries=1)
    assert down.start() == [SendRequestList()]
    assert down.on_timeout() == [SendRequestList()]
    assert down.on_count(3) == [SendRequest(0)]
    assert down.on_item(0, items[0]) == [SendRequest(1)]
    assert down.on_item(0, items[0]) == []  # duplicate
    assert down.on_item(2, items[2]) == []  # out of order
    assert down.on_timeout() == [SendRequest(1)]
    assert down.on_item(1, items[1]) == [SendRequest(2)]
    assert down.on_item(2, items[2]) == [SendAck(mavlink2.MAV_MISSION_ACCEPTED)]
    assert down.done and down.received == items and down.duplicates == 2


def test_download_machine_empty_mission_and_refusal():
    down = MissionDownload()
    down.start()
    assert down.on_count(0) == [SendAck(mavlink2.MAV_MISSION_ACCEPTED)] and down.done
    down = MissionDownload()
    down.start()
    with pytest.raises(MissionError):
        down.on_ack(mavlink2.MAV_MISSION_DENIED)


def test_item_message_round_trip_keeps_1e7_degree_precision():
    item = waypoint(47.6062095, -122.3320708, 12.25, hold_s=3.0, acceptance_radius_m=2.0)
    seq, back = item_from_message(item_to_message(item, 7, 1, 1))
    assert seq == 7 and items_match(item, back)
    assert back.depth_m == pytest.approx(12.25)
    moved = waypoint(47.6062097, -122.3320708, 12.25, hold_s=3.0, acceptance_radius_m=2.0)
    assert not items_match(item, moved)  # 2e-7 deg (~2 cm) is a real difference


def test_verify_reports_first_difference_and_skips_home():
    wire = ardupilot_wire_items(_survey(3))
    real_home = MissionItem(mavlink2.MAV_CMD_NAV_WAYPOINT, 0, 47.0, -122.0, 10.0)
    verify_items(wire, [real_home, *wire[1:]])
    changed = [real_home, wire[1], waypoint(0.0, 0.0, 1.0), wire[3]]
    with pytest.raises(MissionVerifyError) as info:
        verify_items(wire, changed)
    assert info.value.index == 2
    with pytest.raises(MissionVerifyError) as info:
        verify_items(wire, wire[:2])
    assert info.value.index == -1


def test_waypoint_rejects_bad_input():
    with pytest.raises(ValueError):
        waypoint(91.0, 0.0, 1.0)
    with pytest.raises(ValueError):
        waypoint(0.0, 0.0, -1.0)


# ---- against the scripted peer --------------------------------------------------------------


@pytest.mark.parametrize("use_request_int", [False, True])
def test_upload_verify_download_clear(peer, client, use_request_int):
    peer.use_request_int = use_request_int
    items = _survey(6)
    wire = client.upload_mission(items)  # verify=True downloads it again
    assert len(peer.mission) == 7 and len(wire) == 7
    got = client.download_mission()
    assert all(items_match(a, b) for a, b in zip(items, got, strict=True)) and len(got) == 6
    client.clear_mission()
    assert peer.mission == [] and client.download_mission() == []


def test_upload_with_dropped_and_duplicated_items_and_spurious_acks(peer, client):
    peer.drop_item_once = {2, 5}  # lost on the way: the peer re-requests them
    peer.duplicate_requests = True  # every request twice: duplicates + INVALID_SEQUENCE acks
    items = _survey(6)
    client.upload_mission(items)
    assert all(
        items_match(a, b)
        for a, b in zip(
            ardupilot_wire_items(items)[1:],
            [item_from_message(m)[1] for m in peer.mission[1:]],
            strict=True,
        )
    )
    sent_seqs = [m.seq for m in peer.of_type("MISSION_ITEM_INT")]
    assert sent_seqs.count(2) >= 2 and sent_seqs.count(5) >= 2  # resent after the drops


def test_upload_survives_lost_count(peer, client):
    peer.drop_count_once = True
    client.upload_mission(_survey(2))
    assert len(peer.of_type("MISSION_COUNT")) >= 2 and len(peer.mission) == 3


def test_download_survives_lost_item(peer, client):
    client.upload_mission(_survey(4), verify=False)
    peer.drop_download_once = {3}
    got = client.download_mission()
    assert all(items_match(a, b) for a, b in zip(_survey(4), got, strict=True))
    requests = [m.seq for m in peer.of_type("MISSION_REQUEST_INT")]
    assert requests.count(3) >= 2


def test_upload_refused_carries_mission_result(peer, client):
    peer.mission_refusal = mavlink2.MAV_MISSION_NO_SPACE
    with pytest.raises(MissionError) as info:
        client.upload_mission(_survey(2))
    assert info.value.result == mavlink2.MAV_MISSION_NO_SPACE


def test_upload_to_silent_vehicle_times_out(peer_factory, client_factory):
    peer = peer_factory()
    client = client_factory(make_config(peer, mission_retries=2, mission_item_timeout_s=0.2))
    client.connect()
    peer.answer_counts = False  # never answers MISSION_COUNT
    with pytest.raises(MissionTimeout):
        client.upload_mission(_survey(2))
    assert len(peer.of_type("MISSION_COUNT")) == 3  # first + 2 retries


def test_verification_catches_a_vehicle_that_alters_items(peer, client):
    def corrupting(msg):
        if msg.seq == 2:
            msg.z = msg.z - 1.0  # the vehicle stores another depth

    peer.alter_item = corrupting
    with pytest.raises(MissionVerifyError) as info:
        client.upload_mission(_survey(3))
    assert info.value.index == 2


def test_verification_compares_what_ardusub_stores():
    """AP_Mission keeps alt in whole cm, the frame family (3 for 6, 10 for 11) and, for a
    NAV_WAYPOINT on a sub, param1 only: such a readback verifies; a real move does not."""
    sent = waypoint(47.6062095, -122.3320708, 5.4789, hold_s=2.0, acceptance_radius_m=0.25)
    back = MissionItem(mavlink2.MAV_CMD_NAV_WAYPOINT, mavlink2.MAV_FRAME_GLOBAL_RELATIVE_ALT,
                       sent.latitude_deg, sent.longitude_deg, -5.47, 2.0, 0.0, 0.0, 0.0)
    assert items_match(sent, back)
    assert ardusub_stored(sent).alt_cm == -547 and ardusub_stored(sent).params == (2.0,)
    terrain = MissionItem(mavlink2.MAV_CMD_NAV_WAYPOINT, mavlink2.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT, 47.6, -122.3, 1.2)
    assert items_match(terrain, MissionItem(mavlink2.MAV_CMD_NAV_WAYPOINT, mavlink2.MAV_FRAME_GLOBAL_TERRAIN_ALT,
                                            47.6, -122.3, 1.2))
    assert not items_match(terrain, MissionItem(mavlink2.MAV_CMD_NAV_WAYPOINT, mavlink2.MAV_FRAME_GLOBAL_RELATIVE_ALT,
                                                47.6, -122.3, 1.2))
    assert not items_match(sent, MissionItem(mavlink2.MAV_CMD_NAV_WAYPOINT, mavlink2.MAV_FRAME_GLOBAL_RELATIVE_ALT,
                                             sent.latitude_deg, sent.longitude_deg, -5.46, 2.0))  # a cm off


def test_upload_verifies_against_an_ardusub_readback(peer, client):
    peer.ardusub_readback = True
    items = [waypoint(47.6 + 1e-5 * i, -122.3, 5.0 + 0.0123 * i, hold_s=1.0, acceptance_radius_m=0.25)
             for i in range(5)]
    client.upload_mission(items)  # raises MissionVerifyError if the comparison were strict
    got = client.download_mission()
    assert [g.frame for g in got] == [mavlink2.MAV_FRAME_GLOBAL_RELATIVE_ALT] * 5
