"""SYS_STATUS sensor bits as ArduSub 4.5 reports them.

``GCS::update_sensor_status_flags`` (libraries/GCS_MAVLink/GCS.cpp) then
``GCS_Sub::update_vehicle_sensor_status_flags`` (ArduSub/GCS_Sub.cpp), Sub-4.5 @30257f0118:

- gyro, accel, compass, AHRS, motor outputs (BRD_SAFETY_DEFLT 0), battery: present,
  enabled, healthy; rate control, attitude stabilisation, yaw position: always all three.
- Z_ALTITUDE_CONTROL and XY_POSITION_CONTROL: present always; enabled and healthy only
  in ALT_HOLD, AUTO, GUIDED, CIRCLE, SURFACE and POSHOLD (not SURFTRAK).
- ABSOLUTE_PRESSURE: present and enabled with a depth sensor; healthy only while the
  *depth* sensor is (Sub clears the generic barometer health).
- PREARM_CHECK: present; enabled when ARMING_CHECK != 0; healthy when armed or the
  pre-arm checks pass (evaluated at 1 Hz).
- GEOFENCE: present when FENCE_TYPE has ALT_MAX, CIRCLE or ALT_MIN (``AC_Fence::present``;
  a polygon counts only with points, none here) - so present by default (FENCE_TYPE 7)
  even with FENCE_ENABLE 0; enabled with FENCE_ENABLE and an action other than
  report-only; healthy while nothing is breached.
- LASER_POSITION: present and enabled when a downward rangefinder was configured at
  boot (``rangefinder_state.enabled``); healthy while it has data.
- VISION_POSITION: present and enabled with visual odometry (VISO_TYPE, the DVL);
  healthy while it delivers (the DVL's bottom lock).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from pymavlink.dialects.v20 import ardupilotmega as mavlink

M = mavlink
_ALWAYS = (M.MAV_SYS_STATUS_SENSOR_3D_GYRO | M.MAV_SYS_STATUS_SENSOR_3D_ACCEL | M.MAV_SYS_STATUS_SENSOR_3D_MAG
           | M.MAV_SYS_STATUS_AHRS | M.MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS | M.MAV_SYS_STATUS_SENSOR_BATTERY
           | M.MAV_SYS_STATUS_SENSOR_ANGULAR_RATE_CONTROL | M.MAV_SYS_STATUS_SENSOR_ATTITUDE_STABILIZATION
           | M.MAV_SYS_STATUS_SENSOR_YAW_POSITION)
_POSITION_CONTROL = M.MAV_SYS_STATUS_SENSOR_Z_ALTITUDE_CONTROL | M.MAV_SYS_STATUS_SENSOR_XY_POSITION_CONTROL
#: ALT_HOLD, AUTO, GUIDED, CIRCLE, SURFACE, POSHOLD
POSITION_CONTROL_MODES = frozenset({2, 3, 4, 7, 9, 16})
_FENCE_PRESENT_TYPES = 1 | 2 | 8  # ALT_MAX, CIRCLE, ALT_MIN


@dataclass(frozen=True)
class SensorFlags:
    """(present, enabled, health) bit masks of SYS_STATUS."""

    present: int
    enabled: int
    health: int


@dataclass(frozen=True)
class SensorState:
    """What the bits are computed from."""

    mode: int
    armed: bool
    prearm_ok: bool
    depth_sensor_healthy: bool
    rangefinder_enabled: bool
    rangefinder_has_data: bool
    vision_healthy: bool
    fence_breached: bool


def sensor_flags(state: SensorState, params: Mapping[str, float]) -> SensorFlags:
    """SYS_STATUS onboard_control_sensors_present / _enabled / _health."""
    present = enabled = health = _ALWAYS
    present |= _POSITION_CONTROL
    if state.mode in POSITION_CONTROL_MODES:
        enabled |= _POSITION_CONTROL
        health |= _POSITION_CONTROL
    present |= M.MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE
    enabled |= M.MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE
    if state.depth_sensor_healthy:
        health |= M.MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE
    present |= M.MAV_SYS_STATUS_PREARM_CHECK
    if int(params["ARMING_CHECK"]) != 0:
        enabled |= M.MAV_SYS_STATUS_PREARM_CHECK
    if state.armed or state.prearm_ok:
        health |= M.MAV_SYS_STATUS_PREARM_CHECK
    if int(params["FENCE_TYPE"]) & _FENCE_PRESENT_TYPES:
        present |= M.MAV_SYS_STATUS_GEOFENCE
    if int(params["FENCE_ENABLE"]) and int(params["FENCE_ACTION"]) != 0:
        enabled |= M.MAV_SYS_STATUS_GEOFENCE
    if not state.fence_breached:
        health |= M.MAV_SYS_STATUS_GEOFENCE
    if state.rangefinder_enabled:
        present |= M.MAV_SYS_STATUS_SENSOR_LASER_POSITION
        enabled |= M.MAV_SYS_STATUS_SENSOR_LASER_POSITION
        if state.rangefinder_has_data:
            health |= M.MAV_SYS_STATUS_SENSOR_LASER_POSITION
    if int(params["VISO_TYPE"]) != 0:
        present |= M.MAV_SYS_STATUS_SENSOR_VISION_POSITION
        enabled |= M.MAV_SYS_STATUS_SENSOR_VISION_POSITION
        if state.vision_healthy:
            health |= M.MAV_SYS_STATUS_SENSOR_VISION_POSITION
    return SensorFlags(present, enabled, health)
