"""Mission items and the upload/download state machines of the MAVLink mission protocol.

Pure: items, their wire form and what ArduSub stores of them; the transfer state
machines are :mod:`vehicle_link.mission_protocol`.

ArduPilot specifics handled here:

* Item 0 of an ArduPilot mission is the home position. ``ardupilot_wire_items`` puts a
  home placeholder at 0 before the caller's items; ``verify_items`` skips it because the
  vehicle overwrites it with its real home.
* ArduPilot re-requests an item it has not received after about 1 s, so the same item can
  be requested twice; ArduSub 4.5 asks with MISSION_REQUEST (not _INT,
  ``MissionItemProtocol::queued_request_send``); both are answered with MISSION_ITEM_INT,
  which keeps 1e-7 degree precision (MISSION_ITEM's float32 would not).
* Verification compares what ArduSub *stores* (:func:`ardusub_stored`): the frame family
  (it returns 3, never 6, and 10, never 11), whole centimetres of altitude, and only the
  parameters it keeps (a NAV_WAYPOINT's acceptance radius is dropped on a sub).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from vehicle_link import units
from vehicle_link.dialect import mavlink2
from vehicle_link.errors import MissionVerifyError

MAV_MISSION_TYPE_MISSION = 0
MAV_MISSION_ACCEPTED = mavlink2.MAV_MISSION_ACCEPTED
MAV_MISSION_INVALID_SEQUENCE = mavlink2.MAV_MISSION_INVALID_SEQUENCE

# Frames whose x/y are latitude/longitude (int32 degE7 in MISSION_ITEM_INT).
_GLOBAL_FRAMES = frozenset(
    {
        mavlink2.MAV_FRAME_GLOBAL,
        mavlink2.MAV_FRAME_GLOBAL_RELATIVE_ALT,
        mavlink2.MAV_FRAME_GLOBAL_INT,
        mavlink2.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
        mavlink2.MAV_FRAME_GLOBAL_TERRAIN_ALT,
        mavlink2.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT,
    }
)


def mission_result_name(result: int) -> str:
    """Name of a MAV_MISSION_RESULT."""
    entry = mavlink2.enums["MAV_MISSION_RESULT"].get(result)
    return entry.name if entry is not None else f"MAV_MISSION_RESULT({result})"


@dataclass(frozen=True)
class MissionItem:
    """One mission item, degrees and metres at the edge as MAVLink defines them.

    ``altitude_m`` is MAVLink's z: metres up from the frame's reference (for ArduSub's
    MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, up from the surface, so ``-depth``).
    """

    command: int
    frame: int = mavlink2.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
    latitude_deg: float = 0.0
    longitude_deg: float = 0.0
    altitude_m: float = 0.0
    param1: float = 0.0
    param2: float = 0.0
    param3: float = 0.0
    param4: float = 0.0
    autocontinue: bool = True

    @property
    def depth_m(self) -> float:
        """Depth of the item (positive down), for frames relative to the surface."""
        return -self.altitude_m


def waypoint(
    latitude_deg: float,
    longitude_deg: float,
    depth_m: float,
    *,
    hold_s: float = 0.0,
    acceptance_radius_m: float = 0.0,
) -> MissionItem:
    """A NAV_WAYPOINT at a depth below the surface (MAV_FRAME_GLOBAL_RELATIVE_ALT_INT)."""
    if not (-90.0 <= latitude_deg <= 90.0 and -180.0 <= longitude_deg <= 180.0):
        raise ValueError(f"waypoint lat/lon out of range: {latitude_deg}, {longitude_deg}")
    if depth_m < 0.0:
        raise ValueError(f"waypoint depth must be >= 0 m (below the surface), got {depth_m}")
    return MissionItem(
        mavlink2.MAV_CMD_NAV_WAYPOINT,
        mavlink2.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
        latitude_deg,
        longitude_deg,
        units.depth_m_to_alt_m(depth_m),
        param1=hold_s,
        param2=acceptance_radius_m,
    )


HOME_PLACEHOLDER = MissionItem(mavlink2.MAV_CMD_NAV_WAYPOINT, mavlink2.MAV_FRAME_GLOBAL)


def ardupilot_wire_items(items: Sequence[MissionItem]) -> list[MissionItem]:
    """The list to upload to ArduPilot: a home placeholder at seq 0, then ``items``."""
    return [HOME_PLACEHOLDER, *items]


def item_to_message(
    item: MissionItem,
    seq: int,
    target_system: int,
    target_component: int,
    mission_type: int = MAV_MISSION_TYPE_MISSION,
) -> mavlink2.MAVLink_mission_item_int_message:
    """MISSION_ITEM_INT for ``item`` at ``seq``."""
    if item.frame in _GLOBAL_FRAMES:
        x = units.deg_to_dege7(item.latitude_deg)
        y = units.deg_to_dege7(item.longitude_deg)
    else:  # local frames carry metres * 1e4 in x/y of MISSION_ITEM_INT
        x = int(round(item.latitude_deg * 1.0e4))
        y = int(round(item.longitude_deg * 1.0e4))
    return mavlink2.MAVLink_mission_item_int_message(
        target_system,
        target_component,
        seq,
        item.frame,
        item.command,
        0,
        1 if item.autocontinue else 0,
        item.param1,
        item.param2,
        item.param3,
        item.param4,
        x,
        y,
        item.altitude_m,
        mission_type,
    )


def item_from_message(msg: Any) -> tuple[int, MissionItem]:
    """(seq, MissionItem) from a MISSION_ITEM_INT or a MISSION_ITEM."""
    is_int = msg.get_type() == "MISSION_ITEM_INT"
    frame = int(msg.frame)
    if is_int and frame in _GLOBAL_FRAMES:
        lat, lon = units.dege7_to_deg(msg.x), units.dege7_to_deg(msg.y)
    elif is_int:
        lat, lon = msg.x / 1.0e4, msg.y / 1.0e4
    else:
        lat, lon = float(msg.x), float(msg.y)
    item = MissionItem(
        int(msg.command),
        frame,
        lat,
        lon,
        float(msg.z),
        float(msg.param1),
        float(msg.param2),
        float(msg.param3),
        float(msg.param4),
        bool(msg.autocontinue),
    )
    return int(msg.seq), item


#: Frame families AP_Mission stores (``mavlink_int_to_mission_cmd``) and returns
#: (``mission_cmd_to_mavlink_int``): 0/2/5 absolute -> 0, 3/6 relative -> 3, 10/11
#: terrain -> 10. The _INT frames are never returned.
_FRAME_FAMILY = {
    mavlink2.MAV_FRAME_GLOBAL: mavlink2.MAV_FRAME_GLOBAL,
    mavlink2.MAV_FRAME_GLOBAL_INT: mavlink2.MAV_FRAME_GLOBAL,
    mavlink2.MAV_FRAME_MISSION: mavlink2.MAV_FRAME_GLOBAL,
    mavlink2.MAV_FRAME_GLOBAL_RELATIVE_ALT: mavlink2.MAV_FRAME_GLOBAL_RELATIVE_ALT,
    mavlink2.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT: mavlink2.MAV_FRAME_GLOBAL_RELATIVE_ALT,
    mavlink2.MAV_FRAME_GLOBAL_TERRAIN_ALT: mavlink2.MAV_FRAME_GLOBAL_TERRAIN_ALT,
    mavlink2.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT: mavlink2.MAV_FRAME_GLOBAL_TERRAIN_ALT,
}


@dataclass(frozen=True)
class StoredItem:
    """What ArduSub 4.5's AP_Mission keeps of an item: the comparison key of verification.

    Location commands: the frame family, lat/lon in int32 1e-7 degrees and the altitude
    in whole centimetres (``packet.z * 100.0f`` truncated toward zero). Parameters: only
    those AP_Mission stores for the command on a sub, converted as it converts them
    (NAV_WAYPOINT: param1 only, as a uint16 of whole seconds; the acceptance radius in
    param2 is dropped). Other commands keep params 1-4 as float32. ``autocontinue`` is
    not stored (always returned as 1).
    """

    command: int
    frame: int
    lat_e7: int
    lon_e7: int
    alt_cm: int
    params: tuple[float, ...]


def _f32(value: float) -> float:
    return float(np.float32(value))


def _c_int(value: float, lo: int, hi: int) -> int:
    """C float-to-integer conversion: truncation toward zero, clamped; NaN -> 0."""
    if not math.isfinite(value):
        return 0
    return int(min(max(math.trunc(value), lo), hi))


def ardusub_stored(item: MissionItem, *, downloaded: bool = False) -> StoredItem:
    """``item`` as ArduSub 4.5 stores it (libraries/AP_Mission/AP_Mission.cpp
    ``mavlink_int_to_mission_cmd``): apply it to what was sent, and with ``downloaded`` to
    what was read back, then compare. A download carries ``alt_cm * 0.01f``
    (``mission_cmd_to_mavlink_int``), which is not always above the whole centimetre (99
    cm comes back as 0.98999995 m), so a downloaded altitude is rounded, not truncated."""
    p1, p2, p3, p4 = item.param1, item.param2, item.param3, item.param4
    command = item.command
    if item.frame in _FRAME_FAMILY:
        cm = float(np.float32(item.altitude_m) * np.float32(100.0))
        alt_cm = int(round(cm)) if downloaded and math.isfinite(cm) else _c_int(cm, -(2**31), 2**31 - 1)
        lat, lon = units.deg_to_dege7(item.latitude_deg), units.deg_to_dege7(item.longitude_deg)
        frame = _FRAME_FAMILY[item.frame]
    else:
        alt_cm, lat, lon, frame = 0, 0, 0, item.frame
    if command == mavlink2.MAV_CMD_NAV_WAYPOINT:
        params: tuple[float, ...] = (float(_c_int(p1, 0, 65535)),)
    elif command == mavlink2.MAV_CMD_NAV_LOITER_TIME:
        params = (float(_c_int(p1, 0, 65535)), -1.0 if p3 < 0 else 1.0, float(p4 > 0))
    elif command == mavlink2.MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW:
        # int8 pitch, int16 yaw, int8 rates: whole degrees (AP_Mission.h gimbal_manager_pitchyaw_Command)
        params = (float(_c_int(p1, -128, 127)), float(_c_int(p2, -32768, 32767)), float(_c_int(p3, -128, 127)),
                  float(_c_int(p4, -128, 127)))
        lat, lon, alt_cm, frame = 0, 0, 0, 0  # flags in x and the gimbal id in z, none here
    else:
        params = (_f32(p1), _f32(p2), _f32(p3), _f32(p4))
    return StoredItem(command, frame, lat, lon, alt_cm, params)


def items_match(sent: MissionItem, got: MissionItem) -> bool:
    """True if ``got`` (read back) is what ArduSub stores of ``sent`` (see :func:`ardusub_stored`)."""
    a, b = ardusub_stored(sent), ardusub_stored(got, downloaded=True)
    def key(x: StoredItem) -> tuple[int, ...]:
        return (x.command, x.frame, x.lat_e7, x.lon_e7, x.alt_cm)

    same_place = key(a) == key(b)
    return same_place and len(a.params) == len(b.params) and all(
        x == y or (math.isnan(x) and math.isnan(y)) for x, y in zip(a.params, b.params, strict=True))


def verify_items(
    sent: Sequence[MissionItem], got: Sequence[MissionItem], *, skip_home: bool = True
) -> None:
    """Raise MissionVerifyError unless ``got`` holds what ArduSub stores of ``sent`` (wire
    lists, home at 0: skipped, the vehicle reports its own home there)."""
    if len(sent) != len(got):
        raise MissionVerifyError(f"vehicle holds {len(got)} items, {len(sent)} were uploaded", -1)
    for seq, (a, b) in enumerate(zip(sent, got, strict=True)):
        if skip_home and seq == 0:
            continue
        if not items_match(a, b):
            raise MissionVerifyError(
                f"item {seq} differs after upload: sent {ardusub_stored(a)}, read back "
                f"{ardusub_stored(b, downloaded=True)}", seq
            )
