"""Flight modes and guidance: what each ArduSub 4.5 mode does with its targets and the sticks.

:class:`Guidance` turns the mode, the :class:`Targets`, the pilot's channels and the
sensor readings (estimates, never truth) into body thrust, using the loops of
:mod:`sim_harness.vehicle.control`. Sources (Sub-4.5 @30257f0118): ``ArduSub/mode_*.cpp``.

- MANUAL / STABILIZE / ACRO: the sticks drive the thrusters (STABILIZE holds heading).
- ALT_HOLD and SURFTRAK (``mode_althold.cpp``, ``mode_surftrak.cpp``): forward, lateral
  and yaw from the sticks; the climb stick moves the depth target at up to
  PILOT_SPEED_UP / PILOT_SPEED_DN (0 = UP); neutral holds it. SURFTRAK holds the range
  it captured below SURFTRAK_DEPTH.
- POSHOLD: holds position; the sticks move it.
- GUIDED (``mode_guided.cpp``): position legs, position+velocity or velocity targets
  (:mod:`sim_harness.autopilot.wpnav`); the pilot's yaw stick takes the heading, the
  other sticks are ignored; never a mode change.
- AUTO: the mission's legs, heading toward the next waypoint (WP_YAW_BEHAVIOR).
- SURFACE (``mode_surface.cpp``): climbs at WPNAV_SPEED_UP (at most the pilot's climb
  speed); the autopilot switches to ALT_HOLD at the surface.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from enum import IntEnum

from sim_harness.autopilot.pilot import Sticks
from sim_harness.autopilot.wpnav import Leg, LegLimits, PosVel, Velocity, stopping_point
from sim_harness.vehicle import control
from sim_harness.vehicle.dynamics import RovParams
from sim_harness.vehicle.sensors import SensorReadings

STICK_DEADBAND = 0.05  # fraction of full throw on the climb stick (THR_DZ stand-in)
FACE_WAYPOINT_MIN_DISTANCE_M = 2.0  # closer than this AUTO keeps its heading
POSITION_GAIN_1_S = 0.8  # target point -> velocity correction


class Mode(IntEnum):
    """ArduSub flight mode numbers (HEARTBEAT custom_mode, ``ArduSub/mode.h``)."""

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


#: Names as ``Mode::name()`` returns them (the STATUSTEXTs use these).
MODE_NAMES = {Mode.STABILIZE: "STABILIZE", Mode.ACRO: "ACRO", Mode.ALT_HOLD: "ALT_HOLD", Mode.AUTO: "AUTO",
              Mode.GUIDED: "GUIDED", Mode.CIRCLE: "CIRCLE", Mode.SURFACE: "SURFACE", Mode.POSHOLD: "POSHOLD",
              Mode.MANUAL: "MANUAL", Mode.MOTOR_DETECT: "MOTORDETECT", Mode.SURFTRAK: "SURFTRAK"}
SIMULATED_MODES = frozenset(
    {Mode.MANUAL, Mode.STABILIZE, Mode.ACRO, Mode.ALT_HOLD, Mode.AUTO, Mode.GUIDED,
     Mode.POSHOLD, Mode.SURFACE, Mode.SURFTRAK}
)
#: ``requires_GPS()`` true in 4.5 (mode.h): GUIDED, AUTO, CIRCLE and SURFACE. POSHOLD is
#: false, but its ``init`` fails without a position.
REQUIRES_POSITION = frozenset({Mode.AUTO, Mode.GUIDED, Mode.CIRCLE, Mode.SURFACE})
INIT_NEEDS_POSITION = frozenset({Mode.POSHOLD})
MANUAL_THROTTLE = frozenset({Mode.MANUAL, Mode.STABILIZE, Mode.ACRO})
DEPTH_STICK_MODES = frozenset({Mode.ALT_HOLD, Mode.SURFTRAK, Mode.POSHOLD})


class GuidedSubmode(IntEnum):
    """``sub.guided_mode`` (ArduSub/defines.h GuidedMode)."""

    WP = 0
    VELOCITY = 1
    POSVEL = 2


@dataclass
class Targets:
    """What the vehicle is holding or going to (local NED about the EKF origin).

    ``alt_m`` (height above the seabed, from the rangefinder) overrides ``depth_m`` while
    the rangefinder has a reading (AUTO terrain-frame items, SURFTRAK).
    """

    submode: GuidedSubmode = GuidedSubmode.WP
    leg: Leg | None = None
    posvel: PosVel | None = None
    velocity: Velocity | None = None
    hold_ne: tuple[float, float] | None = None
    depth_m: float | None = None
    alt_m: float | None = None
    yaw_rad: float | None = None
    #: The waypoint controller's horizontal speed when DO_CHANGE_SPEED set one, m/s
    #: (``AC_WPNav::set_speed_xy``); None: WPNAV_SPEED. The parameter itself never changes;
    #: ``wp_and_spline_init`` (GUIDED's position control start, AUTO's entry, and every
    #: step while disarmed in either) goes back to it.
    speed_m_s: float | None = None

    def hold_here(self, r: SensorReadings, *, position_ok: bool) -> None:
        """Hold the current estimated position, depth and heading (mode entry)."""
        self.submode = GuidedSubmode.WP
        self.leg = None
        self.posvel = None
        self.velocity = None
        self.alt_m = None
        self.yaw_rad = r.yaw_rad
        self.depth_m = r.depth_m
        self.hold_ne = (r.north_m, r.east_m) if position_ok else None

    def pos_control_start(self, r: SensorReadings, accel_m_s2: float) -> None:
        """``ModeGuided::guided_pos_control_start``: a leg to the stopping point
        (``wp_and_spline_init``: back to WPNAV_SPEED)."""
        self.submode = GuidedSubmode.WP
        self.speed_m_s = None
        stop = stopping_point(r.north_m, r.east_m, r.vel_north_m_s, r.vel_east_m_s, accel_m_s2)
        self.leg = Leg(stop, stop)
        self.posvel = self.velocity = None
        self.hold_ne = None

    def set_destination(self, north_m: float, east_m: float, depth_m: float | None, r: SensorReadings,
                        accel_m_s2: float) -> None:
        """``guided_set_destination`` -> ``AC_WPNav::set_wp_destination`` (see wpnav)."""
        if self.submode != GuidedSubmode.WP or self.leg is None:
            self.pos_control_start(r, accel_m_s2)
        assert self.leg is not None
        if self.leg.reached:
            origin = self.leg.destination
        else:  # interrupted: wp_and_spline_init() restarts from the stopping point, at rest
            origin = stopping_point(r.north_m, r.east_m, r.vel_north_m_s, r.vel_east_m_s, accel_m_s2)
        self.leg = Leg(origin, (north_m, east_m))
        if depth_m is not None:
            self.depth_m = depth_m
            self.alt_m = None

    def set_posvel(self, target: PosVel) -> None:
        """``guided_set_destination_posvel``."""
        self.submode = GuidedSubmode.POSVEL
        self.posvel = target
        self.leg = self.velocity = None
        self.hold_ne = None
        self.depth_m = target.depth_m
        self.alt_m = None

    def set_velocity(self, target: Velocity) -> None:
        """``guided_set_velocity``."""
        self.submode = GuidedSubmode.VELOCITY
        self.velocity = target
        self.leg = self.posvel = None
        self.hold_ne = None


@dataclass(frozen=True)
class NavStatus:
    """Progress towards the current target, for NAV_CONTROLLER_OUTPUT and the mission."""

    bearing_deg: float = 0.0
    distance_m: float = 0.0
    vertical_error_m: float = 0.0  # depth error, or height error when tracking the seabed
    leg_reached: bool = False  # the S-curve has finished (AC_WPNav reached_destination)


class Guidance:
    """The per-mode control law (see the module docstring).

    Parameters
    ----------
    rov
        Vehicle parameters (gains scale with mass and drag).
    params
        The autopilot's parameter table, read live.
    on_text
        Called with a message for the operator (sent as STATUSTEXT by the autopilot).
    """

    def __init__(self, rov: RovParams, params: Mapping[str, float], on_text: Callable[[str], None]) -> None:
        self._rov = rov
        self._params = params
        self._on_text = on_text
        self._integ = control.Integrators()
        self.nav = NavStatus()

    def reset(self) -> None:
        """Forget the loop integrators (on a mode change or arming)."""
        self._integ.reset()

    def leg_limits(self, tg: Targets | None = None) -> LegLimits:
        """WPNAV_SPEED (cm/s) or the speed DO_CHANGE_SPEED set (``tg.speed_m_s``),
        WPNAV_ACCEL (cm/s/s), WPNAV_JERK (m/s/s/s)."""
        p = self._params
        return LegLimits(self._speed_m_s(tg), p["WPNAV_ACCEL"] / 100.0, p["WPNAV_JERK"])

    def _speed_m_s(self, tg: Targets | None) -> float:
        if tg is not None and tg.speed_m_s is not None:
            return tg.speed_m_s
        return self._params["WPNAV_SPEED"] / 100.0

    def _pilot_speeds_m_s(self) -> tuple[float, float]:
        up = self._params["PILOT_SPEED_UP"] / 100.0
        down = self._params["PILOT_SPEED_DN"] / 100.0  # ``Sub::get_pilot_speed_dn``: 0 = UP
        return up, (down if down > 0 else up)

    def thrust(self, mode: Mode, tg: Targets, sticks: Sticks, r: SensorReadings, now_s: float,
               dt_s: float) -> tuple[float, float, float, float]:
        """Body thrust (surge N, sway N, heave N down, yaw N m) for one step."""
        p = self._rov
        surge = sticks.forward * p.max_surge_n
        sway = sticks.lateral * p.max_sway_n
        if mode in MANUAL_THROTTLE:
            heave = -sticks.climb * p.max_heave_n
            if mode == Mode.MANUAL or sticks.yaw != 0.0 or tg.yaw_rad is None:
                tg.yaw_rad = r.yaw_rad
                return (surge, sway, heave, sticks.yaw * p.max_yaw_nm)
            return (surge, sway, heave, control.yaw_moment(tg.yaw_rad, r.yaw_rad, r.yaw_rate_rad_s, p))
        heave = self._vertical(mode, tg, sticks, r, now_s, dt_s)
        vel_des, bearing, dist, reached = self._horizontal(mode, tg, sticks, r, now_s, dt_s)
        if vel_des is not None:
            surge, sway = control.horizontal_force(
                vel_des, (r.vel_north_m_s, r.vel_east_m_s), r.yaw_rad, p, self._integ, dt_s)
        if tg.alt_m is not None and r.altitude_m is not None:
            vertical_error = r.altitude_m - tg.alt_m
        else:
            vertical_error = (tg.depth_m if tg.depth_m is not None else r.depth_m) - r.depth_m
        self.nav = NavStatus(math.degrees(bearing), dist, vertical_error, reached)
        if sticks.yaw != 0.0:
            # The pilot's yaw stick: a rate, in every mode (GUIDED/AUTO: AUTO_YAW_HOLD).
            tg.yaw_rad = r.yaw_rad
            yaw = control.yaw_moment_for_rate(sticks.yaw * control.YAW_RATE_MAX_RAD_S, r.yaw_rate_rad_s, p)
        else:
            if tg.yaw_rad is None:
                tg.yaw_rad = r.yaw_rad
            yaw = control.yaw_moment(tg.yaw_rad, r.yaw_rad, r.yaw_rate_rad_s, p)
        return (surge, sway, heave, yaw)

    def _vertical(self, mode: Mode, tg: Targets, sticks: Sticks, r: SensorReadings, now_s: float,
                  dt_s: float) -> float:
        p, prm = self._rov, self._params
        up_m_s, down_m_s = prm["WPNAV_SPEED_UP"] / 100.0, prm["WPNAV_SPEED_DN"] / 100.0
        climb_ff = 0.0
        if mode == Mode.SURFACE:
            pilot_up, _ = self._pilot_speeds_m_s()
            rate = min(max(up_m_s, 0.01), pilot_up)
            return control.heave_for_rate(-rate, r.vel_down_m_s, p, self._integ, dt_s)
        if mode in DEPTH_STICK_MODES:
            up_m_s, down_m_s = self._pilot_speeds_m_s()
            if abs(sticks.climb) > STICK_DEADBAND:
                tg.depth_m = r.depth_m
                if mode == Mode.SURFTRAK:
                    tg.alt_m = None  # re-captured when the pilot lets go
                speed = up_m_s if sticks.climb > 0 else down_m_s
                return control.heave_for_rate(-sticks.climb * speed, r.vel_down_m_s, p, self._integ, dt_s)
        if mode == Mode.SURFTRAK:
            self._surftrak_capture(tg, r)
        if mode == Mode.GUIDED and tg.submode == GuidedSubmode.POSVEL and tg.posvel is not None:
            tg.depth_m = tg.posvel.depth_m
            climb_ff = tg.posvel.vel_down_m_s
        elif mode == Mode.GUIDED and tg.submode == GuidedSubmode.VELOCITY and tg.velocity is not None:
            w = tg.velocity.current(now_s)[2]
            tg.depth_m = r.depth_m
            return control.heave_for_rate(w, r.vel_down_m_s, p, self._integ, dt_s)
        if tg.alt_m is not None and r.altitude_m is not None:
            tg.depth_m = r.depth_m + (r.altitude_m - tg.alt_m)
        if tg.depth_m is None:
            tg.depth_m = r.depth_m
        w_des = min(max(climb_ff + control.DEPTH_GAIN_1_S * (tg.depth_m - r.depth_m), -up_m_s), down_m_s)
        return control.heave_for_rate(w_des, r.vel_down_m_s, p, self._integ, dt_s)

    def _horizontal(self, mode: Mode, tg: Targets, sticks: Sticks, r: SensorReadings, now_s: float,
                    dt_s: float) -> tuple[tuple[float, float] | None, float, float, bool]:
        """(desired NED velocity or None for stick thrust, bearing rad, distance m, leg done)."""
        if mode == Mode.POSHOLD and (sticks.forward or sticks.lateral):
            tg.hold_ne = (r.north_m, r.east_m)  # the pilot moves it; hold where released
            return None, 0.0, 0.0, False
        if mode not in (Mode.GUIDED, Mode.AUTO, Mode.POSHOLD):
            return None, 0.0, 0.0, False
        max_speed = self._speed_m_s(tg)
        if mode == Mode.GUIDED and tg.submode == GuidedSubmode.VELOCITY and tg.velocity is not None:
            vn, ve, _ = tg.velocity.current(now_s)
            return (vn, ve), 0.0, 0.0, False
        if mode == Mode.GUIDED and tg.submode == GuidedSubmode.POSVEL and tg.posvel is not None:
            pv = tg.posvel
            pv.advance(now_s, dt_s)
            return self._track((pv.north_m, pv.east_m), (pv.vel_north_m_s, pv.vel_east_m_s), r,
                               max(max_speed, math.hypot(pv.vel_north_m_s, pv.vel_east_m_s))) + (False,)
        if tg.leg is not None:
            leg = tg.leg
            leg.advance(dt_s, self.leg_limits(tg))
            vel, bearing, _ = self._track(leg.point(), leg.velocity(), r, max_speed)
            dn, de = leg.destination[0] - r.north_m, leg.destination[1] - r.east_m
            dist = math.hypot(dn, de)
            if (mode == Mode.AUTO and self._params["WP_YAW_BEHAVIOR"] >= 1
                    and dist > FACE_WAYPOINT_MIN_DISTANCE_M):
                tg.yaw_rad = math.atan2(de, dn)
            return vel, math.atan2(de, dn), dist, leg.reached
        if tg.hold_ne is None:
            return None, 0.0, 0.0, False
        return self._track(tg.hold_ne, (0.0, 0.0), r, max_speed) + (True,)

    @staticmethod
    def _track(point: tuple[float, float], vel_ff: tuple[float, float], r: SensorReadings,
               max_speed_m_s: float) -> tuple[tuple[float, float], float, float]:
        """Position controller: feed-forward plus a correction toward the target point."""
        dn, de = point[0] - r.north_m, point[1] - r.east_m
        vn = vel_ff[0] + POSITION_GAIN_1_S * dn
        ve = vel_ff[1] + POSITION_GAIN_1_S * de
        speed = math.hypot(vn, ve)
        if speed > max_speed_m_s > 0:
            vn, ve = vn * max_speed_m_s / speed, ve * max_speed_m_s / speed
        return (vn, ve), math.atan2(de, dn), math.hypot(dn, de)

    def _surftrak_capture(self, tg: Targets, r: SensorReadings) -> None:
        below = r.depth_m > -self._params["SURFTRAK_DEPTH"] / 100.0
        if tg.alt_m is None and r.altitude_m is not None and below:
            tg.alt_m = r.altitude_m
            self._on_text(f"rangefinder target is {r.altitude_m:.2f} m")
