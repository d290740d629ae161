"""ArduSubClient: the companion-computer side of a MAVLink 2 link to ArduSub 4.5.

Everything ArduSub-specific sits here: modes, arming (the force magics 2989 / 21196),
depth, position and position+velocity targets with their safety checks, the sonar mount
and the frame its angles are in, the EKF origin and home, our altimeter feed. Missions
are :class:`vehicle_link.missions.MissionLink`, the request protocols
:class:`vehicle_link.link.VehicleLink`, the I/O :class:`vehicle_link.link_core.LinkCore`
(its threading notes apply here).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from vehicle_link import commands, units
from vehicle_link.dialect import mavlink2
from vehicle_link.errors import (
    CommandRejected,
    CommandTimeout,
    ModeChangeTimeout,
    ModeError,
    NotConfigured,
    SafetyLimitError,
    StaleTelemetry,
    StateChangeTimeout,
)
from vehicle_link.link import LinkHealth, LinkStats, result_name
from vehicle_link.missions import MissionLink
from vehicle_link.modes import SubMode, parse_mode
from vehicle_link.telemetry import (
    Attitude,
    GlobalOrigin,
    GlobalPosition,
    Heartbeat,
    HomePosition,
    LocalPositionNed,
    Pressure,
    Rangefinder,
)

__all__ = ["AltitudeTargetResult", "ArduSubClient", "LinkHealth", "LinkStats", "MOUNT_FRAMES", "result_name"]

OWN_ALTIMETER_SOURCE = "OWN_ALTIMETER"
#: The frame each ArduSub mount type's angles are in (AP_Mount.cpp ``init``): type 1, a
#: servo, is stabilised by the autopilot (earth frame: it takes the vehicle's pitch out);
#: type 7, brushless PWM, outputs the angle as it is (body frame on a plain tilt servo).
MOUNT_FRAMES = {1: "earth", 7: "body"}


@dataclass(frozen=True)
class AltitudeTargetResult:
    """How an altitude-above-seabed target was sent.

    ``method`` is ``"derived_depth"``: a depth target computed from the measured altitude,
    to be re-sent as the seabed changes (ArduSub 4.5 drops terrain-frame GUIDED targets:
    it has no terrain database on a sub).
    """

    method: str
    altitude_target_m: float
    depth_target_m: float | None
    measured_altitude_m: float | None
    measured_depth_m: float | None


class ArduSubClient(MissionLink):
    """MAVLink 2 client for ArduSub 4.5 on the companion computer.

    Same constructor as :class:`~vehicle_link.link.VehicleLink`:
    ``ArduSubClient(config, *, clock=None, threaded=True, on_link_lost=None,
    on_link_restored=None)``.
    """

    def current_depth_m(self) -> float:
        """Latest depth (m, down positive).

        From the newest GLOBAL_POSITION_INT or LOCAL_POSITION_NED; if neither is fresh, from
        SCALED_PRESSURE2 (the external depth sensor) with the configured water density and
        surface pressure.
        """
        now = self._clock.now_s()
        max_age = self.config.telemetry_max_age_s
        candidates = [
            r
            for r in (self.latest(GlobalPosition), self.latest(LocalPositionNed))
            if r is not None and now - r.time_s <= max_age
        ]
        if candidates:
            newest = max(candidates, key=lambda r: r.time_s)
            return newest.depth_m if isinstance(newest, GlobalPosition) else newest.down_m
        pressure = self.latest(Pressure, "Pressure2")
        if pressure is not None and now - pressure.time_s <= max_age:
            return units.depth_m_from_pressure_pa(
                pressure.press_abs_pa,
                self.config.surface_pressure_pa,
                self.config.water_density_kg_m3,
            )
        raise StaleTelemetry(
            "depth (GLOBAL_POSITION_INT / LOCAL_POSITION_NED / SCALED_PRESSURE2)", None, max_age
        )

    def current_altitude_m(self) -> float:
        """Latest height above the seabed (m): newest downward range, tilt-corrected.

        Uses the vehicle's DISTANCE_SENSOR/RANGEFINDER or our own fed altimeter, whichever
        is newest, corrected by the latest ATTITUDE roll and pitch when fresh.
        """
        with self._cond:
            ranges = [
                r
                for r in self._store.values()
                if isinstance(r, Rangefinder) and r.is_downward and r.in_range
            ]
        if not ranges:
            raise StaleTelemetry("downward rangefinder", None, self.config.telemetry_max_age_s)
        newest = max(ranges, key=lambda r: r.time_s)
        now = self._clock.now_s()
        if now - newest.time_s > self.config.telemetry_max_age_s:
            raise StaleTelemetry(
                "downward rangefinder", now - newest.time_s, self.config.telemetry_max_age_s
            )
        attitude = self.latest(Attitude)
        if attitude is not None and now - attitude.time_s <= self.config.telemetry_max_age_s:
            return units.altitude_m_from_range_m(
                newest.distance_m, attitude.roll_rad, attitude.pitch_rad
            )
        return newest.distance_m

    def arm(self, *, force: bool = False, confirm: bool = True) -> None:
        """Arm; with ``confirm`` wait for a heartbeat showing it armed."""
        self._command_with_effect(commands.arm_disarm(True, force=force), lambda: self._hb_armed() is True,
                                  "armed", confirm)

    def disarm(self, *, force: bool = False, confirm: bool = True) -> None:
        """Disarm; with ``confirm`` wait for a heartbeat showing it disarmed."""
        self._command_with_effect(commands.arm_disarm(False, force=force), lambda: self._hb_armed() is False,
                                  "disarmed", confirm)

    def _hb_armed(self) -> bool | None:
        record = self._store.get("Heartbeat")
        return record.armed if isinstance(record, Heartbeat) else None

    def _command_with_effect(self, spec: commands.CommandSpec, done: Callable[[], bool], what: str,
                             confirm: bool) -> None:
        """Send ``spec`` and, with ``confirm``, wait for a heartbeat showing ``done``. An
        unanswered command whose effect a heartbeat shows counts as done (its ACK was lost:
        on a lossy tether the heartbeat is the better witness)."""
        timeout_s = self.config.state_confirm_timeout_s
        try:
            self.send_command(spec)
        except CommandTimeout:
            if not self._wait_until(done, timeout_s):
                raise
            return
        if confirm and not self._wait_until(done, timeout_s):
            raise StateChangeTimeout(what, timeout_s)

    def set_mode(self, mode: SubMode | int | str, *, confirm: bool = True) -> SubMode:
        """Set an ArduSub mode by number or name (SURFTRAK = 21 included).

        With ``confirm``, waits for a heartbeat in the new mode (ArduSub 4.5 sends one at
        once on a mode change). Nothing is re-sent on the link's own initiative.
        """
        target_mode = parse_mode(mode)

        def in_mode() -> bool:
            record = self._store.get("Heartbeat")
            return isinstance(record, Heartbeat) and record.custom_mode == int(target_mode)

        try:
            self._command_with_effect(commands.set_mode(target_mode), in_mode, "mode", confirm)
        except StateChangeTimeout as exc:
            raise ModeChangeTimeout(int(target_mode), exc.timeout_s) from exc
        return target_mode

    def _check_depth(self, depth_m: float) -> None:
        if not depth_m >= 0.0:  # also catches NaN
            raise SafetyLimitError("depth_m", depth_m, 0.0, "depth target above the surface or NaN")
        limit = self.config.max_depth_m
        if limit is not None and depth_m > limit:
            raise SafetyLimitError("depth_m", depth_m, limit, "deeper than the depth limit")

    def set_depth_target(self, depth_m: float) -> None:
        """Hold a depth (m, down positive) in ALT_HOLD or GUIDED; checked against the depth
        limit before anything is sent. Not acknowledged by ArduSub: re-send as needed.

        In GUIDED the horizontal target is the latest LOCAL_POSITION_NED.
        """
        self._check_depth(depth_m)
        mode = self.mode
        if mode == SubMode.ALT_HOLD:
            self._send(
                commands.depth_target_global_int(
                    depth_m, self._target(), self.config.target_component, self._time_boot_ms()
                )
            )
        elif mode == SubMode.GUIDED:
            local = self._fresh(LocalPositionNed, "LOCAL_POSITION_NED")
            self._send(
                commands.position_target_local_ned(
                    local.north_m,
                    local.east_m,
                    depth_m,
                    self._target(),
                    self.config.target_component,
                    self._time_boot_ms(),
                )
            )
        else:
            raise ModeError("a depth target", mode, ("ALT_HOLD", "GUIDED"))

    def goto_local_ned(
        self, north_m: float, east_m: float, depth_m: float, *, yaw_rad: float | None = None
    ) -> None:
        """GUIDED position target about the EKF origin (NED metres, depth down positive)."""
        self._check_depth(depth_m)
        if self.mode != SubMode.GUIDED:
            raise ModeError("a position target", self.mode, ("GUIDED",))
        self._send(
            commands.position_target_local_ned(
                north_m,
                east_m,
                depth_m,
                self._target(),
                self.config.target_component,
                self._time_boot_ms(),
                yaw_rad=yaw_rad,
            )
        )

    def goto_posvel(self, north_m: float, east_m: float, depth_m: float, vel_north_m_s: float,
                    vel_east_m_s: float, vel_down_m_s: float = 0.0, *, yaw_rad: float | None = None) -> None:
        """GUIDED position + velocity target (Guided_PosVel, NED about the EKF origin).

        ArduSub moves the position on by the velocity and, 3 s after the last one, zeroes
        the velocity and holds where it got to: stream these along a path and the vehicle
        stops on its own when the stream does.
        """
        self._check_depth(depth_m)
        if self.mode != SubMode.GUIDED:
            raise ModeError("a position target", self.mode, ("GUIDED",))
        for name, value in (("vel_north_m_s", vel_north_m_s), ("vel_east_m_s", vel_east_m_s),
                            ("vel_down_m_s", vel_down_m_s)):
            if not math.isfinite(value):
                raise SafetyLimitError(name, value, 0.0, "velocity is not finite")
        self._send(commands.position_velocity_target_local_ned(
            north_m, east_m, depth_m, vel_north_m_s, vel_east_m_s, vel_down_m_s, self._target(),
            self.config.target_component, self._time_boot_ms(), yaw_rad=yaw_rad))

    def set_altitude_target(self, altitude_m: float) -> AltitudeTargetResult:
        """Hold a height above the seabed (m).

        Checked against ``min_clearance_m`` before anything is sent; sends the depth target
        ``depth + (altitude - altitude_target)`` from the latest altimeter reading (checked
        against the depth limit too).
        """
        clearance = self.config.min_clearance_m
        if not altitude_m >= 0.0:
            raise SafetyLimitError(
                "altitude_m", altitude_m, 0.0, "altitude target below the seabed or NaN"
            )
        if clearance is not None and altitude_m < clearance:
            raise SafetyLimitError(
                "altitude_m", altitude_m, clearance, "below the minimum clearance"
            )
        measured_alt = self.current_altitude_m()
        depth_now = self.current_depth_m()
        depth_target = depth_now + (measured_alt - altitude_m)
        self.set_depth_target(depth_target)
        return AltitudeTargetResult(
            "derived_depth", altitude_m, depth_target, measured_alt, depth_now
        )

    def _mount_spec(self, tilt_rad: float) -> commands.CommandSpec:
        if self.config.mount_protocol == "gimbal_manager":
            return commands.gimbal_manager_pitchyaw(tilt_rad)
        return commands.mount_control(
            tilt_rad, centidegrees=self.config.mount_protocol == "mount_control_centidegrees"
        )

    def set_mount_tilt(self, tilt_rad: float, *, wait_ack: bool = True) -> None:
        """Point the sonar mount ``tilt_rad`` down.

        The angle is in the frame of the vehicle's mount (:meth:`mount_frame`): earth
        frame for ArduSub's default stabilised servo mount. With ``wait_ack`` (default) the
        COMMAND_ACK is awaited with the usual retries; a control loop that re-sends the tilt
        every cycle passes ``wait_ack=False`` (sent once; the next cycle sends it again).
        Nothing is re-sent on the link's own initiative: after a mode change ArduSub 4.5
        puts the mount into RC targeting, which holds the last angle (``Sub::exit_mode``).
        """
        spec = self._mount_spec(tilt_rad)
        if wait_ack:
            self.send_command(spec)
        else:
            self._send(commands.command_long(spec, self._target(), self.config.target_component, 0))

    def mount_frame(self) -> str | None:
        """"earth" or "body": the frame the mount's angles are in, from MNT1_TYPE
        (:data:`MOUNT_FRAMES`); None for a type with no known frame (0: no mount)."""
        return MOUNT_FRAMES.get(int(self.get_parameter("MNT1_TYPE").value))

    def ekf_origin(self, *, timeout_s: float | None = None) -> GlobalOrigin | None:
        """The EKF origin (REQUEST_MESSAGE GPS_GLOBAL_ORIGIN); None if the vehicle has none
        (it acknowledges and sends nothing)."""
        start = self._clock.now_s()
        self.request_message(mavlink2.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN)
        found = self.wait_for_record(lambda r: isinstance(r, GlobalOrigin) and r.time_s >= start,
                                     self.config.command_timeout_s if timeout_s is None else timeout_s)
        return found if isinstance(found, GlobalOrigin) else None

    def set_ekf_origin(self, latitude_deg: float, longitude_deg: float, altitude_m: float = 0.0, *,
                       timeout_s: float | None = None) -> GlobalOrigin:
        """SET_GPS_GLOBAL_ORIGIN (as the BlueOS DVL extension does, altitude 0 = the surface),
        confirmed by GPS_GLOBAL_ORIGIN. ArduSub ignores it when it already has an origin:
        the origin returned is the vehicle's, whatever was asked.

        Raises
        ------
        CommandTimeout
            No GPS_GLOBAL_ORIGIN after the bounded retries.
        """
        timeout = self.config.command_timeout_s if timeout_s is None else timeout_s
        for _ in range(self.config.command_attempts):
            start = self._clock.now_s()
            self._send(commands.set_gps_global_origin(latitude_deg, longitude_deg, altitude_m, self._target()))
            found = self.wait_for_record(lambda r, t=start: isinstance(r, GlobalOrigin) and r.time_s >= t, timeout)
            if isinstance(found, GlobalOrigin):
                return found
            existing = self.ekf_origin(timeout_s=timeout)
            if existing is not None:
                return existing
        raise CommandTimeout(mavlink2.MAVLINK_MSG_ID_SET_GPS_GLOBAL_ORIGIN, "SET_GPS_GLOBAL_ORIGIN",
                             self.config.command_attempts, timeout)

    def home_position(self, *, timeout_s: float | None = None) -> HomePosition | None:
        """Home (MAV_CMD_GET_HOME_POSITION); None when ArduSub has none yet (FAILED)."""
        start = self._clock.now_s()
        try:
            self.send_command(commands.get_home_position())
        except CommandRejected:
            return None
        found = self.wait_for_record(lambda r: isinstance(r, HomePosition) and r.time_s >= start,
                                     self.config.command_timeout_s if timeout_s is None else timeout_s)
        return found if isinstance(found, HomePosition) else None

    def send_altimeter_range(
        self, range_m: float, *, signal_quality_pct: int | None = None
    ) -> None:
        """Send our altimeter reading as DISTANCE_SENSOR (needs ``config.altimeter``).

        The reading is also stored locally as a Rangefinder record (source ``OWN_ALTIMETER``)
        so altitude targets can use it.
        """
        feed = self.config.altimeter
        if feed is None:
            raise NotConfigured("send_altimeter_range needs LinkConfig.altimeter")
        self._send(
            commands.distance_sensor(
                range_m,
                feed.min_range_m,
                feed.max_range_m,
                self._time_boot_ms(),
                sensor_id=feed.sensor_id,
                signal_quality_pct=signal_quality_pct,
            )
        )
        self._publish(
            Rangefinder(
                self._clock.now_s(),
                OWN_ALTIMETER_SOURCE,
                feed.sensor_id,
                range_m,
                feed.min_range_m,
                feed.max_range_m,
                25,
                signal_quality_pct,
                feed.min_range_m <= range_m <= feed.max_range_m,
            )
        )
