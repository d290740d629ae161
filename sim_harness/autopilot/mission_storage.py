"""How AP_Mission stores a mission item, and what it sends back: ArduSub 4.5's quantisation.

``AP_Mission::mavlink_int_to_mission_cmd`` and ``mission_cmd_to_mavlink_int``
(libraries/AP_Mission/AP_Mission.cpp, Sub-4.5 @30257f0118; the conversions read again at the
branch point 3926e06508), for the commands a sub's mission files carry:

- **Location commands** keep lat/lon as int32 1e-7 degrees and the altitude in whole
  centimetres, ``packet.z * 100.0f`` truncated toward zero into a signed 24-bit field
  (``PackedLocation``); |z| >= 83 000 m or NaN is ``MAV_MISSION_INVALID_PARAM7``. Frames
  0, 2 and 5 are stored absolute, 3 and 6 relative to home, 10 and 11 above terrain
  (relative + terrain); any other frame is ``MAV_MISSION_UNSUPPORTED_FRAME``. On download
  the frame is 0 (absolute), 3 (relative) or 10 (terrain), never the ``_INT`` frames,
  and z is ``alt * 0.01f``.
- **Parameters kept** (the rest read back as 0): NAV_WAYPOINT, NAV_TAKEOFF,
  NAV_SPLINE_WAYPOINT, NAV_GUIDED_ENABLE, DO_SET_HOME and DO_SET_ROI param1 (uint16;
  the acceptance radius in param2 is dropped on a sub); NAV_LAND param1 and the sign of
  param4; NAV_LOITER_TIME param1, the sign of param3 and param4 > 0; NAV_LOITER_UNLIM the
  radius in param3 (signed by direction); NAV_LOITER_TURNS the turns (1/256 below one)
  and the radius (tens of metres above 255 m) in one uint16; NAV_RETURN_TO_LAUNCH
  nothing (not stored in a location: it reads back lat = lon = z = 0, frame 0). The
  payload commands (``PAYLOAD_FIELDS``: jumps and tags, conditions, speed, servos,
  relays, cameras, gripper, aux functions, mount and gimbal) keep each field in its C
  type, truncated toward zero and clamped (``_c_int``) or as float32; DO_MOUNT_CONTROL's
  mount mode in param7 is *not* stored. Commands AP_Mission does not know
  (DO_SET_ROI_LOCATION and DO_SET_ROI_NONE among them: those are COMMAND_LONG/INT only)
  are ``MAV_MISSION_UNSUPPORTED``, which ends the upload.
- A DO_JUMP to item 0, or beyond both the mission stored and the upload's last item, is
  ``MAV_MISSION_ERROR`` (``MissionItemProtocol_Waypoints::append_item``, in
  :mod:`sim_harness.autopilot.mission`).
- NaN or infinite param1-4 is ``MAV_MISSION_INVALID_PARAMn`` (``sanity_check_params``),
  except a NaN param4 of NAV_WAYPOINT, LAND and TAKEOFF, checked before anything else;
  then command 0 or 1 is ``MAV_MISSION_INVALID``.
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
#: Commands stored with a location (``AP_Mission::stored_in_location``) that a sub may
#: carry, with what is kept of param1 in ``p1`` (uint16) where anything is.
LOCATION_COMMANDS = frozenset({
    M.MAV_CMD_NAV_WAYPOINT, M.MAV_CMD_NAV_LOITER_UNLIM, M.MAV_CMD_NAV_LOITER_TURNS, M.MAV_CMD_NAV_LOITER_TIME,
    M.MAV_CMD_NAV_LAND, M.MAV_CMD_NAV_TAKEOFF, M.MAV_CMD_NAV_SPLINE_WAYPOINT,
    M.MAV_CMD_NAV_GUIDED_ENABLE, M.MAV_CMD_DO_SET_HOME, M.MAV_CMD_DO_LAND_START, M.MAV_CMD_DO_SET_ROI,
})
#: Commands stored as a packed payload in place of the location: per command the struct
#: (AP_Mission.h ``Content``) as (source, C type) per field, the source a param index
#: (0-3) or ``x``/``y``/``z``; ``mission_cmd_to_mavlink_int`` reads each field back into
#: the place it came from.
PAYLOAD_FIELDS: dict[int, tuple[tuple[int | str, str], ...]] = {
    M.MAV_CMD_NAV_DELAY: ((0, "f"), (1, "b"), (2, "b"), (3, "b")),
    M.MAV_CMD_CONDITION_DELAY: ((0, "f"),),
    M.MAV_CMD_CONDITION_DISTANCE: ((0, "f"),),
    M.MAV_CMD_CONDITION_YAW: ((0, "f"), (1, "f"), (2, "b"), (3, "B")),
    M.MAV_CMD_DO_JUMP: ((0, "H"), (1, "h")),
    M.MAV_CMD_DO_JUMP_TAG: ((0, "H"), (1, "h")),
    M.MAV_CMD_JUMP_TAG: ((0, "H"),),
    M.MAV_CMD_DO_CHANGE_SPEED: ((0, "B"), (1, "f"), (2, "f")),
    M.MAV_CMD_DO_SET_RELAY: ((0, "B"), (1, "B")),
    M.MAV_CMD_DO_REPEAT_RELAY: ((0, "B"), (1, "h"), (2, "f")),
    M.MAV_CMD_DO_SET_SERVO: ((0, "B"), (1, "H")),
    M.MAV_CMD_DO_REPEAT_SERVO: ((0, "B"), (1, "H"), (2, "h"), (3, "f")),
    M.MAV_CMD_DO_DIGICAM_CONFIGURE: ((0, "B"), (1, "H"), (2, "B"), (3, "H"), ("x", "B"), ("y", "B"), ("z", "f")),
    M.MAV_CMD_DO_DIGICAM_CONTROL: ((0, "B"), (1, "B"), (2, "b"), (3, "B"), ("x", "B"), ("y", "B")),
    M.MAV_CMD_DO_MOUNT_CONTROL: ((0, "f"), (1, "f"), (2, "f")),
    M.MAV_CMD_DO_SET_CAM_TRIGG_DIST: ((0, "f"), (2, "B")),
    M.MAV_CMD_DO_AUX_FUNCTION: ((0, "H"), (1, "B")),
    M.MAV_CMD_DO_GRIPPER: ((0, "B"), (1, "B")),
    M.MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW: ((0, "b"), (1, "h"), (2, "b"), (3, "b"), ("x", "B"), ("z", "B")),
    M.MAV_CMD_IMAGE_START_CAPTURE: ((0, "B"), (1, "f"), (2, "H"), (3, "H")),
    M.MAV_CMD_VIDEO_START_CAPTURE: ((0, "B"),),
    M.MAV_CMD_VIDEO_STOP_CAPTURE: ((0, "B"),),
}
#: Commands stored with param1 in ``p1`` alone (no location, no payload).
P1_COMMANDS = frozenset({M.MAV_CMD_DO_SET_RESUME_REPEAT_DIST, M.MAV_CMD_IMAGE_STOP_CAPTURE})
PAYLOAD_COMMANDS = frozenset(PAYLOAD_FIELDS)
#: ``AP_Mission::is_nav_cmd``: ids below MAV_CMD_NAV_LAST (95) and NAV_SET_YAW_SPEED,
#: NAV_SCRIPT_TIME, NAV_ATTITUDE_TIME; of the commands stored here, these.
NAV_COMMANDS = frozenset({
    M.MAV_CMD_NAV_WAYPOINT, M.MAV_CMD_NAV_LOITER_UNLIM, M.MAV_CMD_NAV_LOITER_TURNS, M.MAV_CMD_NAV_LOITER_TIME,
    M.MAV_CMD_NAV_DELAY, M.MAV_CMD_NAV_RETURN_TO_LAUNCH, M.MAV_CMD_NAV_LAND, M.MAV_CMD_NAV_TAKEOFF,
    M.MAV_CMD_NAV_SPLINE_WAYPOINT, M.MAV_CMD_NAV_GUIDED_ENABLE,
})
_ABSOLUTE = frozenset({M.MAV_FRAME_GLOBAL, M.MAV_FRAME_GLOBAL_INT, M.MAV_FRAME_MISSION})
_RELATIVE = frozenset({M.MAV_FRAME_GLOBAL_RELATIVE_ALT, M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT})
_TERRAIN = frozenset({M.MAV_FRAME_GLOBAL_TERRAIN_ALT, M.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT})
_NAN_PARAM4_OK = frozenset({M.MAV_CMD_NAV_WAYPOINT, M.MAV_CMD_NAV_LAND, M.MAV_CMD_NAV_TAKEOFF})
_C_RANGES = {"b": (-128, 127), "B": (0, 255), "h": (-32768, 32767), "H": (0, 65535)}


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
    turns_bits: int = 0

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
        fields = PAYLOAD_FIELDS.get(self.command)
        raw = struct.pack("<" + "".join(f for _, f in fields), *self.payload) if fields else b""
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
    for k, value in enumerate(params):  # sanity_check_params comes first
        if not math.isfinite(value) and not (k == 3 and math.isnan(value) and command in _NAN_PARAM4_OK):
            return None, int(M.MAV_MISSION_INVALID_PARAM1 + k)
    if command in (0, 1):
        return None, int(M.MAV_MISSION_INVALID)
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
        if command in (M.MAV_CMD_NAV_WAYPOINT, M.MAV_CMD_NAV_TAKEOFF, M.MAV_CMD_NAV_SPLINE_WAYPOINT,
                       M.MAV_CMD_NAV_GUIDED_ENABLE, M.MAV_CMD_DO_SET_HOME, M.MAV_CMD_DO_SET_ROI):
            item = _with(item, p1=_c_int(p1, 0, 65535))
        elif command == M.MAV_CMD_NAV_LAND:  # the direction only when param4 is a number
            item = _with(item, p1=_c_int(p1, 0, 65535), loiter_ccw=not math.isnan(p4) and p4 < 0)
        elif command == M.MAV_CMD_NAV_LOITER_TIME:
            item = _with(item, p1=_c_int(p1, 0, 65535), loiter_ccw=p3 < 0, loiter_xtrack=p4 > 0)
        elif command == M.MAV_CMD_NAV_LOITER_UNLIM:
            item = _with(item, p1=_c_int(abs(p3), 0, 65535), loiter_ccw=p3 < 0)
        elif command == M.MAV_CMD_NAV_LOITER_TURNS:
            item = _with(item, p1=_loiter_turns_p1(p1, p3), loiter_ccw=p3 < 0, loiter_xtrack=p4 > 0,
                         turns_bits=_loiter_turns_bits(p1, p3))
        return item, int(M.MAV_MISSION_ACCEPTED)
    if command == M.MAV_CMD_NAV_RETURN_TO_LAUNCH:
        return StoredItem(command), int(M.MAV_MISSION_ACCEPTED)  # nothing kept: not stored in a location
    if command in P1_COMMANDS:
        return StoredItem(command, p1=_c_int(p1, 0, 65535)), int(M.MAV_MISSION_ACCEPTED)
    fields = PAYLOAD_FIELDS.get(command)
    if fields is None:
        return None, int(M.MAV_MISSION_UNSUPPORTED)
    source = {0: p1, 1: p2, 2: p3, 3: p4, "x": float(x), "y": float(y), "z": z}
    payload = tuple(_float32(source[where]) if kind == "f" else _c_int(source[where], *_C_RANGES[kind])
                    for where, kind in fields)
    return StoredItem(command, payload=payload), int(M.MAV_MISSION_ACCEPTED)


def _loiter_turns_bits(p1: float, p3: float) -> int:
    """``type_specific_bits`` of NAV_LOITER_TURNS: bit 0 radius in tens of metres (|param3|
    > 255), bit 1 a fraction of a turn in 1/256 (0 < param1 < 1)."""
    return int(abs(p3) > 255) | int(0 < p1 < 1) << 1


def _loiter_turns_p1(p1: float, p3: float) -> int:
    """NAV_LOITER_TURNS' p1: the turns in the low byte, the radius (m) in the high byte."""
    turns = p1 * 256.0 if 0 < p1 < 1 else p1
    radius = abs(p3) if abs(p3) <= 255 else min(255.0, abs(p3) * 0.1)
    return _c_int(min(255.0, turns), 0, 255) | _c_int(radius, 0, 255) << 8


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
    if c in (M.MAV_CMD_NAV_WAYPOINT, M.MAV_CMD_NAV_TAKEOFF, M.MAV_CMD_NAV_SPLINE_WAYPOINT,
             M.MAV_CMD_NAV_GUIDED_ENABLE, M.MAV_CMD_DO_SET_HOME, M.MAV_CMD_DO_SET_ROI) or c in P1_COMMANDS:
        params[0] = float(item.p1)
    elif c == M.MAV_CMD_NAV_LAND:
        params[0] = float(item.p1)
        params[3] = -1.0 if item.loiter_ccw else 1.0
    elif c == M.MAV_CMD_NAV_LOITER_TIME:
        params[0] = float(item.p1)
        params[2] = -1.0 if item.loiter_ccw else 1.0
        params[3] = float(item.loiter_xtrack)
    elif c == M.MAV_CMD_NAV_LOITER_UNLIM:
        params[2] = -float(item.p1) if item.loiter_ccw else float(item.p1)
    elif c == M.MAV_CMD_NAV_LOITER_TURNS:
        params[0] = float(item.p1 & 0xFF) / (256.0 if item.turns_bits & 2 else 1.0)
        radius = float(item.p1 >> 8) * (-1.0 if item.loiter_ccw else 1.0)
        params[2] = radius * (10.0 if item.turns_bits & 1 else 1.0)
        params[3] = float(item.loiter_xtrack)
    elif c in PAYLOAD_FIELDS:
        slots: dict[int | str, float] = {}
        for (where, _), value in zip(PAYLOAD_FIELDS[c], item.payload, strict=True):
            slots[where] = float(value)
        params = [slots.get(k, 0.0) for k in range(4)]
        x, y, z = int(slots.get("x", 0)), int(slots.get("y", 0)), slots.get("z", 0.0)
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
