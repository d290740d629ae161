"""SET_POSITION_TARGET_LOCAL_NED / _GLOBAL_INT as ArduSub 4.5 takes them.

``GCS_MAVLINK_Sub::handle_message`` (ArduSub/GCS_Mavlink.cpp, Sub-4.5 @30257f0118). There
is no acknowledgement: anything refused is dropped silently.

- LOCAL_NED is acted on only in GUIDED (AUTO's NAV_GUIDED is not simulated), in frames
  LOCAL_NED, LOCAL_OFFSET_NED, BODY_NED, BODY_OFFSET_NED and BODY_FRD; BODY_* rotate by
  the heading, and every frame but LOCAL_NED is an offset from the current position.
- GLOBAL_INT is acted on in GUIDED and ALT_HOLD. In ALT_HOLD, unless z is ignored, ``alt``
  becomes the depth target above the EKF origin (``set_pos_target_z_cm(alt*100)``; frame
  and lat/lon ignored) and nothing else happens. In GUIDED the frame maps through
  ``mavlink_coordinate_frame_to_location_alt_frame`` (0/5 absolute, 3/6 above home,
  10/11 above terrain) and ``get_vector_from_origin_NEU`` needs the EKF origin (and home
  for relative frames); a terrain frame needs the terrain database, which Sub does not
  use (TERRAIN_ENABLE 0), so terrain-frame targets are dropped. Yaw is ignored.
- ``type_mask``: *any* of bits 0-2 set ignores the position, any of 3-5 the velocity,
  any of 6-8 the acceleration; the target is used only with the acceleration ignored:
  position + velocity -> posvel, velocity alone -> velocity, position alone -> position
  (a leg, :mod:`sim_harness.autopilot.wpnav`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sim_harness.autopilot.guidance import Mode, Targets
from sim_harness.autopilot.navigation import Navigation
from sim_harness.autopilot.wpnav import PosVel, Velocity
from sim_harness.vehicle.sensors import SensorReadings

M = mavlink
POS_IGNORE = 0b111
Z_IGNORE = 0b100
VEL_IGNORE = 0b111 << 3
ACC_IGNORE = 0b111 << 6
YAW_IGNORE = 1 << 10
LOCAL_FRAMES = frozenset({M.MAV_FRAME_LOCAL_NED, M.MAV_FRAME_LOCAL_OFFSET_NED, M.MAV_FRAME_BODY_NED,
                          M.MAV_FRAME_BODY_OFFSET_NED, M.MAV_FRAME_BODY_FRD})
BODY_FRAMES = frozenset({M.MAV_FRAME_BODY_NED, M.MAV_FRAME_BODY_OFFSET_NED, M.MAV_FRAME_BODY_FRD})
ABSOLUTE_FRAMES = frozenset({M.MAV_FRAME_GLOBAL, M.MAV_FRAME_GLOBAL_INT})
RELATIVE_FRAMES = frozenset({M.MAV_FRAME_GLOBAL_RELATIVE_ALT, M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT})
TERRAIN_FRAMES = frozenset({M.MAV_FRAME_GLOBAL_TERRAIN_ALT, M.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT})


@dataclass(frozen=True)
class TargetContext:
    """What the handlers need besides the message: mode, readings, time, navigation."""

    mode: Mode
    readings: SensorReadings
    now_s: float
    navigation: Navigation
    accel_m_s2: float  # WPNAV_ACCEL, for the stopping point of an interrupted leg


def _dispatch(pos: tuple[float, float, float] | None, vel: tuple[float, float, float] | None, mask: int,
              tg: Targets, ctx: TargetContext) -> bool:
    acc_ignore = bool(mask & ACC_IGNORE)
    if not acc_ignore:
        return False
    if pos is not None and vel is not None:
        tg.set_posvel(PosVel(pos[0], pos[1], pos[2], vel[0], vel[1], vel[2], ctx.now_s))
    elif pos is None and vel is not None:
        tg.set_velocity(Velocity(vel[0], vel[1], vel[2], ctx.now_s))
    elif pos is not None and vel is None:
        tg.set_destination(pos[0], pos[1], pos[2], ctx.readings, ctx.accel_m_s2)
    else:
        return False
    return True


def apply_local_ned(msg: mavlink.MAVLink_message, tg: Targets, ctx: TargetContext) -> bool:
    """SET_POSITION_TARGET_LOCAL_NED; True if it changed a target."""
    if ctx.mode != Mode.GUIDED or msg.coordinate_frame not in LOCAL_FRAMES:
        return False
    r = ctx.readings
    frame, mask = int(msg.coordinate_frame), int(msg.type_mask)
    c, s = math.cos(r.yaw_rad), math.sin(r.yaw_rad)
    pos = vel = None
    if not mask & POS_IGNORE:
        x, y, z = float(msg.x), float(msg.y), float(msg.z)
        if frame in BODY_FRAMES:
            x, y = c * x - s * y, s * x + c * y
        if frame != M.MAV_FRAME_LOCAL_NED:
            x, y, z = x + r.north_m, y + r.east_m, z + r.depth_m
        pos = (x, y, z)
    if not mask & VEL_IGNORE:
        vx, vy = float(msg.vx), float(msg.vy)
        if frame in BODY_FRAMES:
            vx, vy = c * vx - s * vy, s * vx + c * vy
        vel = (vx, vy, float(msg.vz))
    if not _dispatch(pos, vel, mask, tg, ctx):
        return False
    if not mask & YAW_IGNORE:  # guided_set_yaw_state: look at the heading (relative in BODY_OFFSET_NED)
        yaw = float(msg.yaw)
        tg.yaw_rad = r.yaw_rad + yaw if frame == M.MAV_FRAME_BODY_OFFSET_NED else yaw
    return True


def apply_global_int(msg: mavlink.MAVLink_message, tg: Targets, ctx: TargetContext) -> bool:
    """SET_POSITION_TARGET_GLOBAL_INT; True if it changed a target."""
    mask = int(msg.type_mask)
    if ctx.mode == Mode.ALT_HOLD:
        if mask & Z_IGNORE:
            return False
        tg.depth_m = -float(msg.alt)  # above the EKF origin, at the surface: -depth
        tg.alt_m = None
        return True
    if ctx.mode != Mode.GUIDED:
        return False
    nav = ctx.navigation
    pos = vel = None
    if not mask & POS_IGNORE:
        lat, lon = msg.lat_int * 1e-7, msg.lon_int * 1e-7
        if not (-90.0 <= lat <= 90.0 and -180.0 <= lon <= 180.0):
            return False
        frame = int(msg.coordinate_frame)
        ne = nav.ned_of(lat, lon)
        if ne is None or nav.origin is None:
            return False  # no EKF origin: get_vector_from_origin_NEU fails
        if frame not in ABSOLUTE_FRAMES and frame not in RELATIVE_FRAMES:
            return False  # terrain frames (no terrain database on a sub) and anything else
        up_m = nav.up_from_origin_m(float(msg.alt), above_home=frame in RELATIVE_FRAMES)
        if up_m is None:
            return False
        pos = (ne[0], ne[1], -up_m)
    if not mask & VEL_IGNORE:
        vel = (float(msg.vx), float(msg.vy), float(msg.vz))
    return _dispatch(pos, vel, mask, tg, ctx)
