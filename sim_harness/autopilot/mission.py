"""The mission item protocol as ArduPilot runs it (MAV_MISSION_TYPE_MISSION only).

Upload: MISSION_COUNT -> the vehicle asks for each item with MISSION_REQUEST, re-asks
after ``REREQUEST_INTERVAL_S`` without an answer, gives up with MISSION_ACK
MAV_MISSION_OPERATION_CANCELLED after ``UPLOAD_TIMEOUT_S`` of silence, and answers the
last item with MISSION_ACK MAV_MISSION_ACCEPTED (or the first error). Items arrive as
MISSION_ITEM_INT or MISSION_ITEM. Item 0 is home: whatever is uploaded there, the vehicle
keeps its own home and reports it on download.

Download: MISSION_REQUEST_LIST -> MISSION_COUNT; MISSION_REQUEST_INT -> MISSION_ITEM_INT,
MISSION_REQUEST -> MISSION_ITEM. MISSION_CLEAR_ALL leaves only home.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

from pymavlink.dialects.v20 import ardupilotmega as mavlink

REREQUEST_INTERVAL_S = 1.0
UPLOAD_TIMEOUT_S = 8.0
MAX_ITEMS = 700

NAV_COMMANDS = frozenset(
    {
        mavlink.MAV_CMD_NAV_WAYPOINT,
        mavlink.MAV_CMD_NAV_LOITER_UNLIM,
        mavlink.MAV_CMD_NAV_LOITER_TIME,
        mavlink.MAV_CMD_NAV_DELAY,
    }
)
DO_COMMANDS = frozenset(
    {
        mavlink.MAV_CMD_DO_CHANGE_SPEED,
        mavlink.MAV_CMD_DO_MOUNT_CONTROL,
        mavlink.MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW,
        mavlink.MAV_CMD_CONDITION_DELAY,
    }
)
#: Frames accepted for navigation items (depth: relative/global; altitude: terrain).
NAV_FRAMES = frozenset(
    {
        mavlink.MAV_FRAME_GLOBAL,
        mavlink.MAV_FRAME_GLOBAL_INT,
        mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT,
        mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
        mavlink.MAV_FRAME_GLOBAL_TERRAIN_ALT,
        mavlink.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT,
    }
)
TERRAIN_FRAMES = frozenset(
    {mavlink.MAV_FRAME_GLOBAL_TERRAIN_ALT, mavlink.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT}
)


@dataclass(frozen=True)
class MissionItem:
    """One stored mission item; ``lat_e7``/``lon_e7`` in 1e-7 degrees, ``z`` as sent."""

    seq: int
    frame: int
    command: int
    param1: float
    param2: float
    param3: float
    param4: float
    lat_e7: int
    lon_e7: int
    z: float
    autocontinue: int = 1

    @property
    def is_terrain(self) -> bool:
        """True if ``z`` is an altitude above the seabed (terrain frame)."""
        return self.frame in TERRAIN_FRAMES


def item_from_message(msg: mavlink.MAVLink_message) -> MissionItem:
    """Convert MISSION_ITEM(_INT) to a MissionItem (MISSION_ITEM lat/lon are degrees)."""
    if msg.get_type() == "MISSION_ITEM_INT":
        lat, lon = int(msg.x), int(msg.y)
    else:
        lat, lon = int(round(msg.x * 1e7)), int(round(msg.y * 1e7))
    return MissionItem(
        int(msg.seq), int(msg.frame), int(msg.command), float(msg.param1), float(msg.param2),
        float(msg.param3), float(msg.param4), lat, lon, float(msg.z), int(msg.autocontinue),
    )


def validate_item(item: MissionItem) -> int:
    """MAV_MISSION_RESULT for an uploaded item (ACCEPTED if it can be stored)."""
    if item.command in NAV_COMMANDS:
        if item.frame not in NAV_FRAMES:
            return int(mavlink.MAV_MISSION_UNSUPPORTED_FRAME)
        if not -90e7 <= item.lat_e7 <= 90e7 or not -180e7 <= item.lon_e7 <= 180e7:
            return int(mavlink.MAV_MISSION_INVALID_PARAM5_X)
        return int(mavlink.MAV_MISSION_ACCEPTED)
    if item.command in DO_COMMANDS:
        return int(mavlink.MAV_MISSION_ACCEPTED)
    return int(mavlink.MAV_MISSION_UNSUPPORTED)


class MissionProtocol:
    """Upload/download state machine; ``items`` holds the accepted mission (0 = home)."""

    def __init__(self, home: Callable[[], MissionItem], on_new_mission: Callable[[], None]) -> None:
        self._home = home
        self._on_new_mission = on_new_mission
        self.items: list[MissionItem] = [home()]
        self._upload: list[MissionItem] | None = None
        self._upload_count = 0
        self._upload_peer = (0, 0)
        self._last_request_s = 0.0
        self._last_receive_s = 0.0

    @property
    def uploading(self) -> bool:
        """True while an upload is in progress."""
        return self._upload is not None

    def _ack(self, result: int) -> mavlink.MAVLink_message:
        sys_id, comp_id = self._upload_peer
        return mavlink.MAVLink_mission_ack_message(
            sys_id, comp_id, result, mavlink.MAV_MISSION_TYPE_MISSION
        )

    def _request(self, now_s: float) -> mavlink.MAVLink_message:
        assert self._upload is not None
        self._last_request_s = now_s
        sys_id, comp_id = self._upload_peer
        return mavlink.MAVLink_mission_request_message(
            sys_id, comp_id, len(self._upload), mavlink.MAV_MISSION_TYPE_MISSION
        )

    def handle(self, msg: mavlink.MAVLink_message, now_s: float) -> list[mavlink.MAVLink_message]:
        """Handle one mission-protocol message; returns the replies."""
        kind = msg.get_type()
        peer = (msg.get_srcSystem(), msg.get_srcComponent())
        mission_type = getattr(msg, "mission_type", mavlink.MAV_MISSION_TYPE_MISSION)
        if kind != "MISSION_ACK" and mission_type != mavlink.MAV_MISSION_TYPE_MISSION:
            return [
                mavlink.MAVLink_mission_ack_message(
                    peer[0], peer[1], mavlink.MAV_MISSION_UNSUPPORTED, mission_type
                )
            ]
        if kind == "MISSION_COUNT":
            self._upload_peer = peer
            if msg.count == 0:
                self._upload = None
                self.items = [self._home()]
                self._on_new_mission()
                return [self._ack(mavlink.MAV_MISSION_ACCEPTED)]
            if msg.count > MAX_ITEMS:
                self._upload = None
                return [self._ack(mavlink.MAV_MISSION_NO_SPACE)]
            self._upload = []
            self._upload_count = int(msg.count)
            self._last_receive_s = now_s
            return [self._request(now_s)]
        if kind in ("MISSION_ITEM_INT", "MISSION_ITEM"):
            return self._handle_item(msg, peer, now_s)
        if kind == "MISSION_REQUEST_LIST":
            return [
                mavlink.MAVLink_mission_count_message(
                    peer[0], peer[1], len(self.items), mavlink.MAV_MISSION_TYPE_MISSION
                )
            ]
        if kind in ("MISSION_REQUEST_INT", "MISSION_REQUEST"):
            return [self._item_reply(msg.seq, peer, as_int=kind == "MISSION_REQUEST_INT")]
        if kind == "MISSION_CLEAR_ALL":
            self._upload = None
            self.items = [self._home()]
            self._on_new_mission()
            return [
                mavlink.MAVLink_mission_ack_message(
                    peer[0], peer[1], mavlink.MAV_MISSION_ACCEPTED, mavlink.MAV_MISSION_TYPE_MISSION
                )
            ]
        return []

    def _handle_item(
        self, msg: mavlink.MAVLink_message, peer: tuple[int, int], now_s: float
    ) -> list[mavlink.MAVLink_message]:
        if self._upload is None or peer != self._upload_peer:
            return []  # not uploading: ArduPilot ignores stray items
        if msg.seq != len(self._upload):
            return [self._request(now_s)]  # out of order: ask again for the one we need
        self._last_receive_s = now_s
        item = item_from_message(msg)
        if item.seq == 0:
            item = self._home()  # item 0 is home; the vehicle keeps its own
        else:
            result = validate_item(item)
            if result != mavlink.MAV_MISSION_ACCEPTED:
                self._upload = None
                return [self._ack(result)]
        self._upload.append(item)
        if len(self._upload) < self._upload_count:
            return [self._request(now_s)]
        self.items = self._upload
        self._upload = None
        self._on_new_mission()
        return [self._ack(mavlink.MAV_MISSION_ACCEPTED)]

    def _item_reply(
        self, seq: int, peer: tuple[int, int], *, as_int: bool
    ) -> mavlink.MAVLink_message:
        if not 0 <= seq < len(self.items):
            return mavlink.MAVLink_mission_ack_message(
                peer[0], peer[1], mavlink.MAV_MISSION_INVALID_SEQUENCE,
                mavlink.MAV_MISSION_TYPE_MISSION,
            )
        item = self._home() if seq == 0 else self.items[seq]
        item = replace(item, seq=seq)
        if as_int:
            return mavlink.MAVLink_mission_item_int_message(
                peer[0], peer[1], seq, item.frame, item.command, 0, item.autocontinue,
                item.param1, item.param2, item.param3, item.param4, item.lat_e7, item.lon_e7,
                item.z, mavlink.MAV_MISSION_TYPE_MISSION,
            )
        return mavlink.MAVLink_mission_item_message(
            peer[0], peer[1], seq, item.frame, item.command, 0, item.autocontinue,
            item.param1, item.param2, item.param3, item.param4, item.lat_e7 * 1e-7,
            item.lon_e7 * 1e-7, item.z, mavlink.MAV_MISSION_TYPE_MISSION,
        )

    def update(self, now_s: float) -> list[mavlink.MAVLink_message]:
        """Re-requests and the upload timeout; call every step."""
        if self._upload is None:
            return []
        if now_s - self._last_receive_s > UPLOAD_TIMEOUT_S:
            self._upload = None
            return [self._ack(mavlink.MAV_MISSION_OPERATION_CANCELLED)]
        if now_s - self._last_request_s >= REREQUEST_INTERVAL_S:
            return [self._request(now_s)]
        return []
