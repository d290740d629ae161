"""A "go here" mission item as ArduSub 4.5 flies it: ``Sub::do_guided`` (ArduSub/commands_logic.cpp).

A MISSION_ITEM(_INT) with current 2 (a ground station's "go to location") reaches
``GCS_MAVLINK_Sub::handle_guided_request`` from ``GCS_MAVLINK::handle_mission_item``
(:mod:`sim_harness.autopilot.mission`), decoded as an upload's item would be. Sources:
the Sub-4.5 branch point 3926e06508.

- Only in GUIDED (AUTO's NAV_GUIDED, the other case ``do_guided`` takes, is not simulated).
- NAV_WAYPOINT: ``ModeGuided::guided_set_destination(Location)`` -> ``wp_nav.
  set_wp_destination_loc``: the location relative to the EKF origin, refused without an
  origin (or without a home for an altitude above home). Unlike AUTO's
  ``Sub::start_command`` there is no alt-frame check: an absolute altitude is above sea
  level, one above home may lie above the surface, and one above the terrain needs the
  rangefinder (``get_terrain_offset``) and then holds that altitude.
- CONDITION_YAW: ``do_yaw`` (its angle, relative when param4 is 1, counter-clockwise when
  param3 < 0).
- Any other command: refused (MAV_MISSION_ERROR).
"""

from __future__ import annotations

from collections.abc import Callable

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sim_harness.autopilot.mission_storage import StoredItem
from sim_harness.autopilot.navigation import Navigation

M = mavlink


def do_guided(item: StoredItem, *, in_guided: bool, nav: Navigation, terrain_available: bool,
              start_leg: Callable[[float, float, float | None, float | None], None],
              set_yaw_target: Callable[[float, bool, int], None]) -> bool:
    """Fly or turn as ``item`` asks (module docstring); False when ArduSub refuses it.

    ``start_leg(north_m, east_m, depth_m or None, altitude_m or None)`` starts the GUIDED
    leg; ``set_yaw_target(yaw_deg, relative, direction)`` turns.
    """
    if not in_guided:
        return False
    if item.command == M.MAV_CMD_CONDITION_YAW:
        angle_deg, _rate, direction, relative = item.payload
        set_yaw_target(float(angle_deg), int(relative) == 1, int(direction))
        return True
    if item.command != M.MAV_CMD_NAV_WAYPOINT:
        return False
    ne = nav.ned_of(item.lat_e7 * 1e-7, item.lon_e7 * 1e-7)
    if ne is None:
        return False
    alt_m = item.alt_cm / 100.0
    if item.terrain_alt:
        if not terrain_available:
            return False
        start_leg(ne[0], ne[1], None, alt_m)
        return True
    up_m = nav.up_from_origin_m(alt_m, above_home=item.relative_alt)
    if up_m is None:
        return False
    start_leg(ne[0], ne[1], -up_m, None)
    return True
