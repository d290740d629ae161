"""Flight modes and guidance: what each ArduSub mode does with its targets and the sticks.

:class:`Guidance` turns the mode, the :class:`Targets`, the pilot's MANUAL_CONTROL input
and the sensor readings (estimates, never truth) into body thrust, using the loops of
:mod:`sim_harness.vehicle.control`. It mutates ``Targets`` the way ArduSub's modes do (capture the
current depth or heading when the pilot lets go of a stick, follow the seabed in SURFTRAK,
face the next waypoint in AUTO).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from enum import IntEnum

from sim_harness.vehicle import control
from sim_harness.vehicle.dynamics import RovParams
from sim_harness.vehicle.sensors import SensorReadings

PILOT_INPUT_TIMEOUT_S = 3.0  # MANUAL_CONTROL older than this counts as neutral sticks
GUIDED_VELOCITY_TIMEOUT_S = 3.0  # a velocity target older than this stops the vehicle
STICK_DEADBAND = 0.05  # fraction of full throw on the climb stick
FACE_WAYPOINT_MIN_DISTANCE_M = 2.0  # closer than this AUTO keeps its heading


class Mode(IntEnum):
    """ArduSub flight mode numbers (HEARTBEAT custom_mode)."""

    STABILIZE = 0
    ACRO = 1
    ALT_HOLD = 2
    AUTO = 3
    GUIDED = 4
    CIRCLE = 7
    SURFACE = 9
    POSHOLD = 16
    MANUAL = 19
    MOTOR_DETECT = 20
    SURFTRAK = 21


SUPPORTED_MODES = frozenset(
    {Mode.MANUAL, Mode.STABILIZE, Mode.ACRO, Mode.ALT_HOLD, Mode.AUTO, Mode.GUIDED,
     Mode.POSHOLD, Mode.SURFACE, Mode.SURFTRAK}
)
REQUIRES_POSITION = frozenset({Mode.AUTO, Mode.GUIDED, Mode.POSHOLD, Mode.CIRCLE})
MANUAL_THROTTLE = frozenset({Mode.MANUAL, Mode.STABILIZE, Mode.ACRO})
DEPTH_STICK_MODES = frozenset({Mode.ALT_HOLD, Mode.SURFTRAK, Mode.POSHOLD})
POSITION_MODES = frozenset({Mode.GUIDED, Mode.AUTO, Mode.POSHOLD})


@dataclass
class Targets:
    """What the vehicle is holding or going to (local NED, metres, radians).

    ``alt_m`` (height above the seabed, from the rangefinder) overrides ``depth_m`` while
    the rangefinder has a reading. ``vel`` is (vn, ve, vd, time_s set) for GUIDED velocity.
    """

    hold_ne: tuple[float, float] | None = None
    vel: tuple[float, float, float, float] | None = None
    depth_m: float | None = None
    alt_m: float | None = None
    yaw_rad: float | None = None
    speed_m_s: float = 1.0

    def hold_here(self, r: SensorReadings) -> None:
        """Hold the current estimated position, depth and heading."""
        self.vel = None
        self.alt_m = None
        self.yaw_rad = r.yaw_rad
        self.depth_m = r.depth_m
        self.hold_ne = (r.north_m, r.east_m) if r.position_ok else None


@dataclass(frozen=True)
class PilotInput:
    """MANUAL_CONTROL sticks: x, y, r in [-1000, 1000], z in [0, 1000] (500 = neutral)."""

    x: float = 0.0
    y: float = 0.0
    z: float = 500.0
    r: float = 0.0
    time_s: float = -math.inf


@dataclass(frozen=True)
class NavStatus:
    """Progress towards the current target, for NAV_CONTROLLER_OUTPUT and the mission."""

    bearing_deg: float = 0.0
    distance_m: float = 0.0
    vertical_error_m: float = 0.0  # depth error, or height error when tracking the seabed


class Guidance:
    """The per-mode control law (see the module docstring).

    Parameters
    ----------
    rov
        Vehicle parameters (gains scale with mass and drag).
    params
        The autopilot's parameter table (speeds, SURFTRAK_DEPTH, WP_YAW_BEHAVIOR), read live.
    on_text
        Called with a message for the operator (sent as STATUSTEXT by the autopilot).
    """

    def __init__(
        self, rov: RovParams, params: Mapping[str, float], on_text: Callable[[str], None]
    ) -> None:
        self._rov = rov
        self._params = params
        self._on_text = on_text
        self._integ = control.Integrators()
        self.nav = NavStatus()

    def reset(self) -> None:
        """Forget the loop integrators (on a mode change or arming)."""
        self._integ.reset()

    def thrust(
        self, mode: Mode, tg: Targets, pilot: PilotInput, r: SensorReadings, now_s: float,
        dt_s: float,
    ) -> tuple[float, float, float, float]:
        """Body thrust (surge N, sway N, heave N down, yaw N m) for one step."""
        p = self._rov
        sticks = pilot if now_s - pilot.time_s <= PILOT_INPUT_TIMEOUT_S else PilotInput()
        surge = sticks.x / 1000.0 * p.max_surge_n
        sway = sticks.y / 1000.0 * p.max_sway_n
        climb_stick = (sticks.z - 500.0) / 500.0  # +1 = full up
        if mode in MANUAL_THROTTLE:
            heave = -climb_stick * p.max_heave_n
            if mode == Mode.MANUAL or sticks.r != 0.0 or tg.yaw_rad is None:
                tg.yaw_rad = r.yaw_rad
                return (surge, sway, heave, sticks.r / 1000.0 * p.max_yaw_nm)
            return (surge, sway, heave,
                    control.yaw_moment(tg.yaw_rad, r.yaw_rad, r.yaw_rate_rad_s, p))
        heave = self._vertical(mode, tg, climb_stick, r, dt_s)
        vel_des, bearing, dist = self._horizontal(mode, tg, sticks, r, now_s)
        if vel_des is not None:
            surge, sway = control.horizontal_force(
                vel_des, (r.vel_north_m_s, r.vel_east_m_s), r.yaw_rad, p, self._integ, dt_s)
        if tg.alt_m is not None and r.altitude_m is not None:
            vertical_error = r.altitude_m - tg.alt_m
        else:
            vertical_error = (tg.depth_m if tg.depth_m is not None else r.depth_m) - r.depth_m
        self.nav = NavStatus(math.degrees(bearing), dist, vertical_error)
        if sticks.r != 0.0 and mode not in (Mode.GUIDED, Mode.AUTO):
            tg.yaw_rad = r.yaw_rad
            yaw = control.yaw_moment_for_rate(sticks.r / 1000.0 * control.YAW_RATE_MAX_RAD_S,
                                              r.yaw_rate_rad_s, p)
        else:
            if tg.yaw_rad is None:
                tg.yaw_rad = r.yaw_rad
            yaw = control.yaw_moment(tg.yaw_rad, r.yaw_rad, r.yaw_rate_rad_s, p)
        return (surge, sway, heave, yaw)

    def _vertical(
        self, mode: Mode, tg: Targets, climb_stick: float, r: SensorReadings, dt_s: float
    ) -> float:
        p, prm = self._rov, self._params
        if mode == Mode.SURFACE:
            tg.alt_m = None
            tg.depth_m = 0.0
        if mode in DEPTH_STICK_MODES and abs(climb_stick) > STICK_DEADBAND:
            speed = prm["PILOT_SPEED_UP"] if climb_stick > 0 else prm["PILOT_SPEED_DN"]
            tg.depth_m = r.depth_m
            if mode == Mode.SURFTRAK:
                tg.alt_m = None  # re-captured when the pilot lets go
            return control.heave_for_rate(-climb_stick * speed / 100.0, r.vel_down_m_s, p,
                                          self._integ, dt_s)
        if mode == Mode.SURFTRAK:
            self._surftrak_capture(tg, r)
        if tg.alt_m is not None and r.altitude_m is not None:
            tg.depth_m = r.depth_m + (r.altitude_m - tg.alt_m)
        if tg.depth_m is None:
            tg.depth_m = r.depth_m
        return control.heave_force(
            tg.depth_m, r.depth_m, r.vel_down_m_s, p, self._integ, dt_s,
            max_down_m_s=prm["WPNAV_SPEED_DN"] / 100.0, max_up_m_s=prm["WPNAV_SPEED_UP"] / 100.0)

    def _horizontal(
        self, mode: Mode, tg: Targets, sticks: PilotInput, r: SensorReadings, now_s: float
    ) -> tuple[tuple[float, float] | None, float, float]:
        """(desired NED velocity or None for stick thrust, bearing rad, distance m)."""
        if mode == Mode.GUIDED and tg.vel is not None:
            if now_s - tg.vel[3] > GUIDED_VELOCITY_TIMEOUT_S:
                tg.vel = None
                tg.hold_ne = (r.north_m, r.east_m)
            else:
                return (tg.vel[0], tg.vel[1]), 0.0, 0.0
        if mode == Mode.POSHOLD and (sticks.x or sticks.y):
            tg.hold_ne = (r.north_m, r.east_m)  # the pilot moves it; hold where released
            return None, 0.0, 0.0
        if mode not in POSITION_MODES or tg.hold_ne is None:
            return None, 0.0, 0.0
        vn, ve, dist = control.velocity_toward(r.north_m, r.east_m, *tg.hold_ne, tg.speed_m_s)
        bearing = math.atan2(tg.hold_ne[1] - r.east_m, tg.hold_ne[0] - r.north_m)
        if (mode == Mode.AUTO and self._params["WP_YAW_BEHAVIOR"] >= 1
                and dist > FACE_WAYPOINT_MIN_DISTANCE_M):
            tg.yaw_rad = bearing
        return (vn, ve), bearing, dist

    def _surftrak_capture(self, tg: Targets, r: SensorReadings) -> None:
        below = r.depth_m > -self._params["SURFTRAK_DEPTH"] / 100.0
        if tg.alt_m is None and r.altitude_m is not None and below:
            tg.alt_m = r.altitude_m
            self._on_text(f"rangefinder target is {r.altitude_m:.2f} m")
