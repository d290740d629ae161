"""How AP_Mission stores a mission item, and what it sends back: ArduSub 4.5's quantisation.

``AP_Mission::mavlink_int_to_mission_cmd`` and ``mission_cmd_to_mavlink_int``
(libraries/AP_Mission/AP_Mission.cpp, Sub-4.5 @30257f0118), for the commands simulated:

- **Location commands** keep lat/lon as int32 1e-7 degrees and the altitude in whole
  centimetres, ``packet.z * 100.0f`` truncated toward zero into a signed 24-bit field
  (``PackedLocation``); |z| >= 83 000 m or NaN is ``MAV_MISSION_INVALID_PARAM7``. Frames
  0, 2 and 5 are stored absolute, 3 and 6 relative to home, 10 and 11 above terrain
  (relative + terrain); any other frame is ``MAV_MISSION_UNSUPPORTED_FRAME``. On download
  the frame is 0 (absolute), 3 (relative) or 10 (terrain), never the ``_INT`` frames,
  and z is ``alt * 0.01f``.
- **Parameters kept** (the rest read back as 0): NAV_WAYPOINT param1 (hold time, uint16
  seconds; the acceptance radius in param2 is dropped on a sub); NAV_LOITER_TIME param1,
  the sign of param3 and param4 > 0; NAV_LOITER_UNLIM the radius in param3 (signed by
  direction); NAV_DELAY params 1-4 (float, int8, int8, int8); CONDITION_DELAY param1;
  CONDITION_YAW params 1-4; DO_CHANGE_SPEED params 1-3 (uint8, float, float);
  DO_MOUNT_CONTROL params 1-3 (the mount mode in param7 is *not* stored);
  DO_GIMBAL_MANAGER_PITCHYAW as int8 pitch, int16 yaw, int8 rates (whole degrees),
  uint8 flags from x and the gimbal id from z.
- NaN or infinite param1-4 is ``MAV_MISSION_INVALID_PARAMn`` (``sanity_check_params``),
  except a NaN param4 of NAV_WAYPOINT, LAND and TAKEOFF. Command 0 or 1 is
  ``MAV_MISSION_INVALID``; a command AP_Mission does not know is
  ``MAV_MISSION_UNSUPPORTED``.
- MISSION_ITEM (float lat/lon) is converted with ``x * 1.0e7f`` in float32
  (``convert_MISSION_ITEM_to_MISSION_ITEM_INT``), losing precision.
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass

import numpy as np
from pymavlink.dialects.v20 import ardupilotmega as mavlink

M = mavlink
ALT_LIMIT_M = 83000.0
#: Commands stored with a location (``AP_Mission::stored_in_location``), of those simulated.
LOCATION_COMMANDS = frozenset({
    M.MAV_CMD_NAV_WAYPOINT, M.MAV_CMD_NAV_LOITER_UNLIM, M.MAV_CMD_NAV_LOITER_TIME,
    M.MAV_CMD_NAV_RETURN_TO_LAUNCH, M.MAV_CMD_NAV_LAND, M.MAV_CMD_NAV_TAKEOFF, M.MAV_CMD_DO_SET_ROI,
})
#: Commands stored as a packed payload in place of the location (simulated subset).
PAYLOAD_COMMANDS = frozenset({
    M.MAV_CMD_NAV_DELAY, M.MAV_CMD_CONDITION_DELAY, M.MAV_CMD_CONDITION_YAW, M.MAV_CMD_DO_CHANGE_SPEED,
    M.MAV_CMD_DO_MOUNT_CONTROL, M.MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW,
})
NAV_COMMANDS = frozenset({
    M.MAV_CMD_NAV_WAYPOINT, M.MAV_CMD_NAV_LOITER_UNLIM, M.MAV_CMD_NAV_LOITER_TIME, M.MAV_CMD_NAV_DELAY,
    M.MAV_CMD_NAV_RETURN_TO_LAUNCH, M.MAV_CMD_NAV_LAND, M.MAV_CMD_NAV_TAKEOFF,
})
_ABSOLUTE = frozenset({M.MAV_FRAME_GLOBAL, M.MAV_FRAME_GLOBAL_INT, M.MAV_FRAME_MISSION})
_RELATIVE = frozenset({M.MAV_FRAME_GLOBAL_RELATIVE_ALT, M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT})
_TERRAIN = frozenset({M.MAV_FRAME_GLOBAL_TERRAIN_ALT, M.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT})
_NAN_PARAM4_OK = frozenset({M.MAV_CMD_NAV_WAYPOINT, M.MAV_CMD_NAV_LAND, M.MAV_CMD_NAV_TAKEOFF})
#: struct layouts of the packed payloads (AP_Mission.h), for Sub's alt-frame check.
_PAYLOAD_LAYOUT = {
    M.MAV_CMD_NAV_DELAY: "<fbbb", M.MAV_CMD_CONDITION_DELAY: "<f", M.MAV_CMD_CONDITION_YAW: "<ffbB",
    M.MAV_CMD_DO_CHANGE_SPEED: "<Bff", M.MAV_CMD_DO_MOUNT_CONTROL: "<fff",
    M.MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW: "<bhbbBB",
}


@dataclass(frozen=True)
class StoredItem:
    """One mission command as AP_Mission holds it.

    ``relative_alt``/``terrain_alt`` are the Location flags (location commands), ``alt_cm``
    the altitude in whole cm, ``p1`` the uint16 parameter, ``payload`` the stored values of
    a payload command in its struct's field order.
    """

    command: int
    lat_e7: int = 0
    lon_e7: int = 0
    alt_cm: int = 0
    relative_alt: bool = False
    terrain_alt: bool = False
    loiter_ccw: bool = False
    loiter_xtrack: bool = False
    p1: int = 0
    payload: tuple[float, ...] = ()

    @property
    def has_location(self) -> bool:
        """True for a command stored with a location."""
        return self.command in LOCATION_COMMANDS

    def content_bytes(self) -> bytes:
        """The 16 bytes of ``cmd.content`` (Location, or the packed payload then zeros)."""
        if self.has_location:
            flags = (int(self.relative_alt) | int(self.loiter_ccw) << 1 | int(self.terrain_alt) << 2
                     | int(self.loiter_xtrack) << 4)
            return struct.pack("<B3xiii", flags, self.alt_cm, self.lat_e7, self.lon_e7)
        layout = _PAYLOAD_LAYOUT.get(self.command)
        raw = struct.pack(layout, *self.payload) if layout else b""
        return raw.ljust(16, b"\x00")

    def alt_frame(self) -> tuple[str, int]:
        """(``Location::get_alt_frame()``, alt in cm) of ``cmd.content.location``: for a
        payload command, what its bytes read as (Sub checks every command this way)."""
        content = self.content_bytes()
        flags = content[0]
        alt_cm = struct.unpack_from("<i", content, 4)[0]
        if flags & 0b100:
            return "above_terrain", alt_cm
        if flags & 0b1000:
            return "above_origin", alt_cm
        if flags & 0b1:
            return "above_home", alt_cm
        return "absolute", alt_cm


def _c_int(value: float, lo: int, hi: int) -> int:
    """A C float-to-integer conversion: truncation toward zero, clamped (NaN -> 0, as ARM's VCVT)."""
    if not math.isfinite(value):
        return 0
    return int(min(max(math.trunc(value), lo), hi))


def _float32(value: float) -> float:
    return float(np.float32(value))


def store_item(command: int, frame: int, params: tuple[float, float, float, float], x: int, y: int,
               z: float) -> tuple[StoredItem | None, int]:
    """``mavlink_int_to_mission_cmd``: (stored item or None, MAV_MISSION_RESULT)."""
    if command in (0, 1):
        return None, int(M.MAV_MISSION_INVALID)
    for k, value in enumerate(params):
        if not math.isfinite(value) and not (k == 3 and math.isnan(value) and command in _NAN_PARAM4_OK):
            return None, int(M.MAV_MISSION_INVALID_PARAM1 + k)
    p1, p2, p3, p4 = params
    if command in LOCATION_COMMANDS:
        if not -900000000 <= x <= 900000000:
            return None, int(M.MAV_MISSION_INVALID_PARAM5_X)
        if not -1800000000 <= y <= 1800000000:
            return None, int(M.MAV_MISSION_INVALID_PARAM6_Y)
        if not math.isfinite(z) or abs(z) >= ALT_LIMIT_M:
            return None, int(M.MAV_MISSION_INVALID_PARAM7)
        if frame in _ABSOLUTE:
            relative = terrain = False
        elif frame in _RELATIVE:
            relative, terrain = True, False
        elif frame in _TERRAIN:
            relative = terrain = True  # AP_TERRAIN_AVAILABLE: Linux (Navigator) builds
        else:
            return None, int(M.MAV_MISSION_UNSUPPORTED_FRAME)
        alt_cm = _c_int(float(np.float32(z) * np.float32(100.0)), -(2**31), 2**31 - 1)
        item = StoredItem(command, int(x), int(y), alt_cm, relative, terrain)
        if command == M.MAV_CMD_NAV_WAYPOINT:
            item = _with(item, p1=_c_int(p1, 0, 65535))
        elif command == M.MAV_CMD_NAV_LOITER_TIME:
            item = _with(item, p1=_c_int(p1, 0, 65535), loiter_ccw=p3 < 0, loiter_xtrack=p4 > 0)
        elif command == M.MAV_CMD_NAV_LOITER_UNLIM:
            item = _with(item, p1=_c_int(abs(p3), 0, 65535), loiter_ccw=p3 < 0)
        elif command == M.MAV_CMD_DO_SET_ROI:
            item = _with(item, p1=_c_int(p1, 0, 65535))
        return item, int(M.MAV_MISSION_ACCEPTED)
    if command == M.MAV_CMD_NAV_DELAY:
        payload: tuple[float, ...] = (_float32(p1), _c_int(p2, -128, 127), _c_int(p3, -128, 127),
                                      _c_int(p4, -128, 127))
    elif command == M.MAV_CMD_CONDITION_DELAY:
        payload = (_float32(p1),)
    elif command == M.MAV_CMD_CONDITION_YAW:
        payload = (_float32(p1), _float32(p2), _c_int(p3, -128, 127), _c_int(p4, 0, 255))
    elif command == M.MAV_CMD_DO_CHANGE_SPEED:
        payload = (_c_int(p1, 0, 255), _float32(p2), _float32(p3))
    elif command == M.MAV_CMD_DO_MOUNT_CONTROL:
        payload = (_float32(p1), _float32(p2), _float32(p3))
    elif command == M.MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW:
        payload = (_c_int(p1, -128, 127), _c_int(p2, -32768, 32767), _c_int(p3, -128, 127),
                   _c_int(p4, -128, 127), int(x) & 0xFF, _c_int(z, 0, 255))
    else:
        return None, int(M.MAV_MISSION_UNSUPPORTED)
    return StoredItem(command, payload=payload), int(M.MAV_MISSION_ACCEPTED)


def _with(item: StoredItem, **changes: object) -> StoredItem:
    from dataclasses import replace

    return replace(item, **changes)  # type: ignore[arg-type]


def float_item_xy(lat_deg: float, lon_deg: float) -> tuple[int, int]:
    """MISSION_ITEM lat/lon to int32 1e-7 degrees as ArduPilot converts them (float32 math)."""
    lat = np.float32(lat_deg) * np.float32(1.0e7)
    lon = np.float32(lon_deg) * np.float32(1.0e7)
    return _c_int(float(lat), -(2**31), 2**31 - 1), _c_int(float(lon), -(2**31), 2**31 - 1)


@dataclass(frozen=True)
class ItemFields:
    """What ``mission_cmd_to_mavlink_int`` fills in: frame, params 1-4, x, y, z."""

    frame: int
    params: tuple[float, float, float, float]
    x: int
    y: int
    z: float


def download_fields(item: StoredItem) -> ItemFields:
    """``mission_cmd_to_mavlink_int`` for a stored item."""
    params = [0.0, 0.0, 0.0, 0.0]
    x = y = 0
    z = 0.0
    frame = M.MAV_FRAME_GLOBAL
    c = item.command
    if c == M.MAV_CMD_NAV_WAYPOINT or c == M.MAV_CMD_DO_SET_ROI:
        params[0] = float(item.p1)
    elif c == M.MAV_CMD_NAV_LOITER_TIME:
        params[0] = float(item.p1)
        params[2] = -1.0 if item.loiter_ccw else 1.0
        params[3] = float(item.loiter_xtrack)
    elif c == M.MAV_CMD_NAV_LOITER_UNLIM:
        params[2] = -float(item.p1) if item.loiter_ccw else float(item.p1)
    elif c in (M.MAV_CMD_NAV_DELAY, M.MAV_CMD_CONDITION_YAW):
        params = [float(v) for v in item.payload]
    elif c == M.MAV_CMD_CONDITION_DELAY:
        params[0] = float(item.payload[0])
    elif c in (M.MAV_CMD_DO_CHANGE_SPEED, M.MAV_CMD_DO_MOUNT_CONTROL):
        params[0:3] = [float(v) for v in item.payload]
    elif c == M.MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW:
        params = [float(v) for v in item.payload[:4]]
        x, z = int(item.payload[4]), float(item.payload[5])
    if item.has_location:
        x, y = item.lat_e7, item.lon_e7
        z = float(np.float32(item.alt_cm) * np.float32(0.01))
        frame = M.MAV_FRAME_GLOBAL_RELATIVE_ALT if item.relative_alt else M.MAV_FRAME_GLOBAL
        if item.terrain_alt:
            frame = M.MAV_FRAME_GLOBAL_TERRAIN_ALT
    return ItemFields(frame, (params[0], params[1], params[2], params[3]), x, y, z)


def home_item(home: tuple[float, float, float] | None) -> StoredItem:
    """Seq 0 on download: the live AHRS home as an absolute NAV_WAYPOINT (lat/lon/alt 0
    without a home; ``AP_Mission::read_cmd_from_storage``)."""
    if home is None:
        return StoredItem(M.MAV_CMD_NAV_WAYPOINT)
    lat, lon, alt_m = home
    return StoredItem(M.MAV_CMD_NAV_WAYPOINT, int(round(lat * 1e7)), int(round(lon * 1e7)),
                      int(round(alt_m * 100.0)))
