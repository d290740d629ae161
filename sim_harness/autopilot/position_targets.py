"""SET_POSITION_TARGET_LOCAL_NED / _GLOBAL_INT as ArduSub 4.5 takes them.

GUIDED takes a position (with depth or, in a terrain frame, height above the seabed), a
velocity, or a depth alone, and an optional yaw. ALT_HOLD takes the depth alone (z in
LOCAL_NED, or ``alt`` = -depth in a relative/global frame); other modes ignore targets.
``type_mask`` bits: 1-4 ignore x, y, z; 8-32 ignore vx, vy, vz; 1024 ignore yaw.
"""

from __future__ import annotations

import math

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sim_harness.autopilot.guidance import Mode, Targets
from sim_harness.autopilot.location import latlon_to_ned
from sim_harness.vehicle.sensors import SensorReadings

M = mavlink
IGNORE_XY = 0b011
IGNORE_Z = 0b100
IGNORE_POS = 0b111
IGNORE_VEL = 0b111000
IGNORE_YAW = 0b10000000000
OFFSET_FRAMES = frozenset(
    {M.MAV_FRAME_LOCAL_OFFSET_NED, M.MAV_FRAME_BODY_OFFSET_NED, M.MAV_FRAME_BODY_NED}
)
DEPTH_FRAMES = frozenset(
    {M.MAV_FRAME_GLOBAL, M.MAV_FRAME_GLOBAL_INT, M.MAV_FRAME_GLOBAL_RELATIVE_ALT,
     M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT}
)
TERRAIN_FRAMES = frozenset({M.MAV_FRAME_GLOBAL_TERRAIN_ALT, M.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT})


def apply_local_ned(
    msg: mavlink.MAVLink_message, mode: Mode, tg: Targets, r: SensorReadings, now_s: float
) -> bool:
    """Apply SET_POSITION_TARGET_LOCAL_NED; returns True if it changed a target."""
    if mode not in (Mode.GUIDED, Mode.ALT_HOLD):
        return False
    mask = int(msg.type_mask)
    x, y, z = msg.x, msg.y, msg.z
    if msg.coordinate_frame in OFFSET_FRAMES:
        if msg.coordinate_frame != M.MAV_FRAME_LOCAL_OFFSET_NED:  # body axes: rotate
            c, s = math.cos(r.yaw_rad), math.sin(r.yaw_rad)
            x, y = c * x - s * y, s * x + c * y
        x, y, z = r.north_m + x, r.east_m + y, r.depth_m + z
    elif msg.coordinate_frame != M.MAV_FRAME_LOCAL_NED:
        return False
    if mode == Mode.ALT_HOLD:
        if mask & IGNORE_Z:
            return False
        tg.depth_m = z
        tg.alt_m = None
        return True
    if not mask & IGNORE_POS:
        tg.hold_ne = (x, y)
        tg.depth_m = z
        tg.alt_m = None
        tg.vel = None
    elif not mask & IGNORE_VEL:
        tg.vel = (msg.vx, msg.vy, msg.vz, now_s)
    elif not mask & IGNORE_Z:
        tg.depth_m = z
        tg.alt_m = None
    else:
        return False
    if not mask & IGNORE_YAW:
        tg.yaw_rad = msg.yaw
    return True


def apply_global_int(
    msg: mavlink.MAVLink_message, mode: Mode, tg: Targets, origin: tuple[float, float],
    now_s: float,
) -> bool:
    """Apply SET_POSITION_TARGET_GLOBAL_INT; returns True if it changed a target."""
    if mode not in (Mode.GUIDED, Mode.ALT_HOLD):
        return False
    mask = int(msg.type_mask)
    frame = msg.coordinate_frame
    terrain = frame in TERRAIN_FRAMES
    if frame not in DEPTH_FRAMES and not terrain:
        return False
    if terrain and mode != Mode.GUIDED:
        return False  # ALT_HOLD takes a depth only
    if not mask & IGNORE_Z:
        if terrain:
            tg.alt_m = msg.alt
        else:
            tg.alt_m = None
            tg.depth_m = -msg.alt
    if mode == Mode.GUIDED:
        if not mask & IGNORE_XY:
            tg.hold_ne = latlon_to_ned(msg.lat_int * 1e-7, msg.lon_int * 1e-7, *origin)
            tg.vel = None
        elif not mask & IGNORE_VEL:
            tg.vel = (msg.vx, msg.vy, msg.vz, now_s)
        if not mask & IGNORE_YAW:
            tg.yaw_rad = msg.yaw
    return True
