"""What the simulated ArduSub 4.5 reports: the telemetry snapshot, HEARTBEAT base_mode and
system_status.

- ``base_mode`` (ArduSub/GCS_Mavlink.cpp ``GCS_MAVLINK_Sub::base_mode``): CUSTOM_MODE |
  STABILIZE | MANUAL_INPUT always, GUIDED in AUTO, GUIDED, CIRCLE and POSHOLD (not
  SURFACE, ALT_HOLD or SURFTRAK), SAFETY_ARMED when armed.
- ``system_status`` (``GCS_MAVLINK_Sub::vehicle_system_status``): CRITICAL while a
  failsafe is latched (4.5: pilot input, battery, GCS, EKF, terrain), else ACTIVE armed
  and STANDBY disarmed.
"""

from __future__ import annotations

from typing import Protocol

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sim_harness.autopilot.failsafes import Failsafes
from sim_harness.autopilot.guidance import Guidance, Mode, Targets
from sim_harness.autopilot.mission import MissionProtocol
from sim_harness.autopilot.mission_runner import MissionRunner
from sim_harness.autopilot.mount import Mount
from sim_harness.autopilot.navigation import Navigation
from sim_harness.autopilot.params import ParamTable
from sim_harness.autopilot.rangefinder import Rangefinder
from sim_harness.autopilot.sensor_status import SensorState, sensor_flags
from sim_harness.autopilot.telemetry import TelemetrySnapshot
from sim_harness.vehicle.dynamics import RovParams
from sim_harness.vehicle.sensors import SensorReadings

M = mavlink
GUIDED_BASE_MODES = frozenset({Mode.AUTO, Mode.GUIDED, Mode.CIRCLE, Mode.POSHOLD})


def base_mode(mode: int, armed: bool) -> int:
    """HEARTBEAT base_mode (``GCS_MAVLINK_Sub::base_mode``): CUSTOM | STABILIZE |
    MANUAL_INPUT always, GUIDED in AUTO/GUIDED/CIRCLE/POSHOLD, SAFETY_ARMED when armed."""
    flags = (M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | M.MAV_MODE_FLAG_STABILIZE_ENABLED
             | M.MAV_MODE_FLAG_MANUAL_INPUT_ENABLED)
    if mode in GUIDED_BASE_MODES:
        flags |= M.MAV_MODE_FLAG_GUIDED_ENABLED
    if armed:
        flags |= M.MAV_MODE_FLAG_SAFETY_ARMED
    return flags


def system_status(failsafe_latched: bool, armed: bool) -> int:
    """``GCS_MAVLINK_Sub::vehicle_system_status``: CRITICAL while a failsafe is latched."""
    if failsafe_latched:
        return M.MAV_STATE_CRITICAL
    return M.MAV_STATE_ACTIVE if armed else M.MAV_STATE_STANDBY


class StatusSource(Protocol):
    """The autopilot's parts its telemetry reports (read only; the autopilot is one)."""

    @property
    def readings(self) -> SensorReadings | None: ...
    @property
    def rov(self) -> RovParams: ...
    @property
    def thrust(self) -> tuple[float, float, float, float]: ...
    @property
    def navigation(self) -> Navigation: ...
    @property
    def mode(self) -> Mode: ...
    @property
    def armed(self) -> bool: ...
    @property
    def rangefinder(self) -> Rangefinder: ...
    @property
    def failsafes(self) -> Failsafes: ...
    @property
    def params(self) -> ParamTable: ...
    @property
    def runner(self) -> MissionRunner: ...
    @property
    def mission(self) -> MissionProtocol: ...
    @property
    def servo_tilt_rad(self) -> float: ...
    @property
    def guidance(self) -> Guidance: ...
    @property
    def targets(self) -> Targets: ...
    @property
    def mount(self) -> Mount: ...

    def prearm_failure(self) -> str | None: ...

    def home_tuple(self) -> tuple[float, float, float] | None: ...

    def position_ok(self) -> bool: ...


def snapshot(ap: StatusSource, now_s: float) -> TelemetrySnapshot:
    """What the telemetry of autopilot ``ap`` reports now."""
    r = ap.readings
    assert r is not None, "update() must run before telemetry"
    p = ap.rov
    lim = (p.max_surge_n, p.max_sway_n, p.max_heave_n, p.max_yaw_nm)
    norm = [max(-1.0, min(1.0, t / m)) for t, m in zip(ap.thrust, lim, strict=True)]
    nav = ap.navigation
    origin = None if nav.origin is None else (nav.origin.lat_deg, nav.origin.lon_deg, nav.origin.alt_m)
    sensors = sensor_flags(SensorState(
        mode=int(ap.mode), armed=ap.armed, prearm_ok=ap.prearm_failure() is None,
        depth_sensor_healthy=True, rangefinder_enabled=ap.rangefinder.enabled,
        rangefinder_has_data=r.altitude_m is not None,
        vision_healthy=r.position_ok, fence_breached=ap.failsafes.fence_breaches != 0), ap.params)
    return TelemetrySnapshot(
        time_s=now_s, readings=r, custom_mode=int(ap.mode), armed=ap.armed,
        system_status=system_status(ap.failsafes.any_triggered, ap.armed), base_mode=base_mode(ap.mode, ap.armed),
        mission_seq=ap.runner.index, mission_total=len(ap.mission.items),
        mission_state=ap.runner.state,
        thrust_norm=(norm[0], norm[1], norm[2], norm[3]), servo_tilt_rad=ap.servo_tilt_rad,
        origin=origin, home=ap.home_tuple(),
        nav_bearing_deg=ap.guidance.nav.bearing_deg, nav_distance_m=ap.guidance.nav.distance_m,
        nav_alt_error_m=ap.guidance.nav.vertical_error_m,
        target_yaw_rad=ap.targets.yaw_rad if ap.targets.yaw_rad is not None else r.yaw_rad,
        rangefinder_min_m=ap.params["RNGFND1_MIN_CM"] / 100.0,
        rangefinder_max_m=ap.params["RNGFND1_MAX_CM"] / 100.0,
        rangefinder_enabled=ap.rangefinder.enabled, sensors=sensors, position_ok=ap.position_ok(),
        mount_status=ap.mount.status_message(int(now_s * 1000.0) & 0xFFFFFFFF) if ap.mount.present else None,
    )
