"""The mission item protocol as ArduSub 4.5 runs it (MAV_MISSION_TYPE_MISSION only).

``MissionItemProtocol`` and ``MissionItemProtocol_Waypoints``
(libraries/GCS_MAVLink/, Sub-4.5 @30257f0118); storage in
:mod:`sim_harness.autopilot.mission_storage`.

- Upload: MISSION_COUNT truncates the stored mission to the count at once (``truncate``)
  and the vehicle asks for each item with MISSION_REQUEST (msg 40, not _INT;
  ``queued_request_send``), re-asking after ``REREQUEST_INTERVAL_S`` without an answer and
  giving up with MISSION_ACK MAV_MISSION_OPERATION_CANCELLED and "Mission upload timeout"
  after ``UPLOAD_TIMEOUT_S``. Items are written in place as they arrive; any item that
  cannot be stored ends the upload with its MAV_MISSION_RESULT; the last gets ACCEPTED
  and "Flight plan received". A COUNT from another sender while an upload runs is
  DENIED, as is a download meanwhile. More than ``MAX_ITEMS`` is NO_SPACE ("Only N items
  are supported"). Items arrive as MISSION_ITEM_INT or MISSION_ITEM (float; "got
  MISSION_ITEM; GCS should send MISSION_ITEM_INT", once). An item when no upload runs
  (a sender re-sending its last item after a lost final ACK) gets MAV_MISSION_ERROR
  (``GCS_MAVLINK::handle_mission_item``, GCS_Common.cpp).
- Download: MISSION_REQUEST_LIST -> MISSION_COUNT (home included); MISSION_REQUEST_INT ->
  MISSION_ITEM_INT, MISSION_REQUEST -> MISSION_ITEM. Seq 0 is always the live home.
  ``current`` is 1 when the item's *command id* equals the current nav index (as 4.5's
  ``get_item`` compares them), autocontinue always 1.
- MISSION_CLEAR_ALL leaves only home.
- Requests, not uploads (``GCS_MAVLINK::handle_mission_item``): an item with current 2
  ("fly here now", as a ground station's "go to location") is decoded like an upload's
  item and handed to ``Sub::do_guided`` (GUIDED only: NAV_WAYPOINT flies there,
  CONDITION_YAW turns; else MAV_MISSION_ERROR); current 3 (altitude change) is ACCEPTED
  with no effect (Sub has no ``handle_change_alt_request``). Neither is stored.
"""

from __future__ import annotations

from collections.abc import Callable

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sim_harness.autopilot.mission_storage import (
    LOCATION_COMMANDS,
    StoredItem,
    _c_int,
    download_fields,
    float_item_xy,
    home_item,
    store_item,
)

REREQUEST_INTERVAL_S = 1.0
UPLOAD_TIMEOUT_S = 8.0
#: (storage bytes - 4) / 15 on the 16 KB non-copter layout (Navigator; StorageManager.cpp).
MAX_ITEMS = 655


class MissionProtocol:
    """Upload/download state machine; ``items`` holds the stored mission (0 = home slot)."""

    def __init__(self, home: Callable[[], tuple[float, float, float] | None],
                 on_new_mission: Callable[[], None], text: Callable[[int, str], None],
                 current_nav_index: Callable[[], int],
                 guided_request: Callable[[StoredItem], bool] = lambda item: False) -> None:
        self._home = home
        self._guided_request = guided_request
        self._on_new_mission = on_new_mission
        self._text = text
        self._current_nav_index = current_nav_index
        self.items: list[StoredItem] = [home_item(None)]
        self._receiving = False
        self._upload_count = 0
        self._next_seq = 0
        self._upload_peer = (0, 0)
        self._last_request_s = 0.0
        self._last_receive_s = 0.0
        self._warned_float = False

    @property
    def uploading(self) -> bool:
        """True while an upload is in progress."""
        return self._receiving

    def _ack(self, peer: tuple[int, int], result: int) -> mavlink.MAVLink_message:
        return mavlink.MAVLink_mission_ack_message(peer[0], peer[1], result, mavlink.MAV_MISSION_TYPE_MISSION)

    def _request(self, now_s: float) -> mavlink.MAVLink_message:
        self._last_request_s = now_s
        sys_id, comp_id = self._upload_peer
        return mavlink.MAVLink_mission_request_message(sys_id, comp_id, self._next_seq,
                                                       mavlink.MAV_MISSION_TYPE_MISSION)

    def handle(self, msg: mavlink.MAVLink_message, now_s: float) -> list[mavlink.MAVLink_message]:
        """Handle one mission-protocol message; returns the replies."""
        kind = msg.get_type()
        peer = (msg.get_srcSystem(), msg.get_srcComponent())
        mission_type = getattr(msg, "mission_type", mavlink.MAV_MISSION_TYPE_MISSION)
        if kind != "MISSION_ACK" and mission_type != mavlink.MAV_MISSION_TYPE_MISSION:
            return [mavlink.MAVLink_mission_ack_message(peer[0], peer[1], mavlink.MAV_MISSION_UNSUPPORTED,
                                                        mission_type)]
        if kind == "MISSION_COUNT":
            return self._count(msg, peer, now_s)
        if kind in ("MISSION_ITEM_INT", "MISSION_ITEM"):
            return self._handle_item(msg, peer, now_s)
        if kind in ("MISSION_REQUEST_LIST", "MISSION_REQUEST_INT", "MISSION_REQUEST") and self._receiving:
            return [self._ack(peer, mavlink.MAV_MISSION_DENIED)]
        if kind == "MISSION_REQUEST_LIST":
            return [mavlink.MAVLink_mission_count_message(peer[0], peer[1], len(self.items),
                                                          mavlink.MAV_MISSION_TYPE_MISSION)]
        if kind in ("MISSION_REQUEST_INT", "MISSION_REQUEST"):
            return [self._item_reply(int(msg.seq), peer, as_int=kind == "MISSION_REQUEST_INT")]
        if kind == "MISSION_CLEAR_ALL":
            self._receiving = False
            self.items = [self.items[0]]
            self._on_new_mission()
            return [self._ack(peer, mavlink.MAV_MISSION_ACCEPTED)]
        return []

    def _count(self, msg: mavlink.MAVLink_message, peer: tuple[int, int],
               now_s: float) -> list[mavlink.MAVLink_message]:
        if self._receiving and peer != self._upload_peer:
            return [self._ack(peer, mavlink.MAV_MISSION_DENIED)]
        count = int(msg.count)
        if count > MAX_ITEMS:
            self._text(mavlink.MAV_SEVERITY_WARNING, f"Only {MAX_ITEMS} items are supported")
            return [self._ack(peer, mavlink.MAV_MISSION_NO_SPACE)]
        self._upload_peer = peer
        del self.items[max(count, 1):]  # truncate(count); the home slot stays
        if count == 0:
            self._receiving = False
            self._on_new_mission()
            return [self._ack(peer, mavlink.MAV_MISSION_ACCEPTED)]
        self._receiving = True
        self._upload_count = count
        self._next_seq = 0
        self._last_receive_s = now_s
        return [self._request(now_s)]

    def _handle_item(self, msg: mavlink.MAVLink_message, peer: tuple[int, int],
                     now_s: float) -> list[mavlink.MAVLink_message]:
        # ArduSub 4.5 GCS_Common.cpp GCS_MAVLINK::handle_mission_item: the float form is
        # converted first; current 2 and 3 are requests, not parts of an upload.
        as_int = msg.get_type() == "MISSION_ITEM_INT"
        if as_int:
            x, y = int(msg.x), int(msg.y)
        elif int(msg.command) in LOCATION_COMMANDS:  # convert_MISSION_ITEM_to_MISSION_ITEM_INT
            x, y = float_item_xy(float(msg.x), float(msg.y))
        else:  # x and y that are no place pass straight through (a C float-to-int32)
            x, y = (_c_int(float(msg.x), -(2**31), 2**31 - 1), _c_int(float(msg.y), -(2**31), 2**31 - 1))
        if int(msg.current) in (2, 3):
            return [self._request_item(msg, x, y, peer)]
        if not as_int and not self._warned_float:  # MissionItemProtocol::send_mission_item_warning
            self._warned_float = True
            self._text(mavlink.MAV_SEVERITY_WARNING, "got MISSION_ITEM; GCS should send MISSION_ITEM_INT")
        if not self._receiving:
            return [self._ack(peer, mavlink.MAV_MISSION_ERROR)]
        if peer != self._upload_peer:
            return [self._ack(peer, mavlink.MAV_MISSION_DENIED)]
        if int(msg.seq) != self._next_seq:
            return [self._ack(peer, mavlink.MAV_MISSION_INVALID_SEQUENCE)]
        self._last_receive_s = now_s
        item, result = store_item(int(msg.command), int(msg.frame),
                                  (float(msg.param1), float(msg.param2), float(msg.param3), float(msg.param4)),
                                  x, y, float(msg.z))
        if item is not None and item.command == mavlink.MAV_CMD_DO_JUMP:
            # MissionItemProtocol_Waypoints::append_item / replace_item: a jump to item 0, or
            # beyond both the mission stored and the upload's last item, is an error.
            target = int(item.payload[0])
            if target == 0 or (target >= len(self.items) and target > self._upload_count - 1):
                item, result = None, int(mavlink.MAV_MISSION_ERROR)
        if item is None:
            self._receiving = False
            return [self._ack(peer, result)]
        seq = self._next_seq
        if seq < len(self.items):
            self.items[seq] = item
        else:
            self.items.append(item)
        self._next_seq += 1
        if self._next_seq < self._upload_count:
            return [self._request(now_s)]
        self._receiving = False
        self._on_new_mission()
        self._text(mavlink.MAV_SEVERITY_INFO, "Flight plan received")
        return [self._ack(peer, mavlink.MAV_MISSION_ACCEPTED)]

    def _request_item(self, msg: mavlink.MAVLink_message, x: int, y: int,
                      peer: tuple[int, int]) -> mavlink.MAVLink_message:
        """A "guided" item (current 2: fly there now) or an altitude change (current 3):
        decoded as an upload's item would be (``mavlink_int_to_mission_cmd``: its refusal is
        the answer), then current 2 goes to ``handle_guided_request`` (``Sub::do_guided``:
        ACCEPTED or MAV_MISSION_ERROR) and current 3 is ACCEPTED with no effect (Sub has no
        ``handle_change_alt_request``). Nothing is stored."""
        item, result = store_item(int(msg.command), int(msg.frame),
                                  (float(msg.param1), float(msg.param2), float(msg.param3), float(msg.param4)),
                                  x, y, float(msg.z))
        if item is not None and int(msg.current) == 2:
            result = mavlink.MAV_MISSION_ACCEPTED if self._guided_request(item) else mavlink.MAV_MISSION_ERROR
        return self._ack(peer, result)

    def _item_reply(self, seq: int, peer: tuple[int, int], *, as_int: bool) -> mavlink.MAVLink_message:
        if not 0 <= seq < len(self.items):
            return self._ack(peer, mavlink.MAV_MISSION_INVALID_SEQUENCE)
        item = home_item(self._home()) if seq == 0 else self.items[seq]
        f = download_fields(item)
        current = 1 if item.command == self._current_nav_index() else 0
        if as_int:
            return mavlink.MAVLink_mission_item_int_message(
                peer[0], peer[1], seq, f.frame, item.command, current, 1, *f.params, f.x, f.y, f.z,
                mavlink.MAV_MISSION_TYPE_MISSION)
        # convert_MISSION_ITEM_INT_to_MISSION_ITEM: degrees for a place, x and y as they are else
        x, y = (f.x * 1e-7, f.y * 1e-7) if item.has_location else (float(f.x), float(f.y))
        return mavlink.MAVLink_mission_item_message(
            peer[0], peer[1], seq, f.frame, item.command, current, 1, *f.params, x, y, f.z,
            mavlink.MAV_MISSION_TYPE_MISSION)

    def update(self, now_s: float) -> list[mavlink.MAVLink_message]:
        """Re-requests and the upload timeout; call every step."""
        if not self._receiving:
            return []
        if now_s - self._last_receive_s > UPLOAD_TIMEOUT_S:
            self._receiving = False
            self._text(mavlink.MAV_SEVERITY_WARNING, "Mission upload timeout")
            return [self._ack(self._upload_peer, mavlink.MAV_MISSION_OPERATION_CANCELLED)]
        if now_s - self._last_request_s >= REREQUEST_INTERVAL_S:
            return [self._request(now_s)]
        return []
