"""ArduSubClient: the companion-computer side of a MAVLink 2 link to ArduSub 4.5.

Everything ArduSub-specific sits here: modes, arming, depth/altitude targets with their
safety checks, the sonar mount, our altimeter feed, missions with ArduPilot's home slot.
The link itself (I/O thread, clock, heartbeats, link health, COMMAND_ACK handling) is
:class:`vehicle_link.link.VehicleLink`; its threading notes apply here.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from vehicle_link import commands, mission_io, units
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
from vehicle_link.link import LinkHealth, LinkStats, VehicleLink, result_name
from vehicle_link.mission import (
    MAV_MISSION_TYPE_MISSION,
    MissionItem,
    ardupilot_wire_items,
    verify_items,
)
from vehicle_link.modes import SubMode, parse_mode
from vehicle_link.telemetry import (
    Attitude,
    GlobalPosition,
    Heartbeat,
    LocalPositionNed,
    MissionCurrent,
    Pressure,
    Rangefinder,
)

__all__ = ["AltitudeTargetResult", "ArduSubClient", "LinkHealth", "LinkStats", "result_name"]

OWN_ALTIMETER_SOURCE = "OWN_ALTIMETER"


@dataclass(frozen=True)
class AltitudeTargetResult:
    """How an altitude-above-seabed target was sent.

    ``method`` is ``"terrain_frame"`` (the firmware tracks the altitude itself) or
    ``"derived_depth"`` (a depth target computed from the measured altitude, which must
    be re-sent as the seabed changes).
    """

    method: str
    altitude_target_m: float
    depth_target_m: float | None
    measured_altitude_m: float | None
    measured_depth_m: float | None


class ArduSubClient(VehicleLink):
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
        self.send_command(commands.arm_disarm(True, force=force))
        if confirm and not self._wait_until(
            lambda: self._hb_armed() is True, self.config.state_confirm_timeout_s
        ):
            raise StateChangeTimeout("armed", self.config.state_confirm_timeout_s)

    def disarm(self, *, force: bool = False, confirm: bool = True) -> None:
        """Disarm; with ``confirm`` wait for a heartbeat showing it disarmed."""
        self.send_command(commands.arm_disarm(False, force=force))
        if confirm and not self._wait_until(
            lambda: self._hb_armed() is False, self.config.state_confirm_timeout_s
        ):
            raise StateChangeTimeout("disarmed", self.config.state_confirm_timeout_s)

    def _hb_armed(self) -> bool | None:
        record = self._store.get("Heartbeat")
        return record.armed if isinstance(record, Heartbeat) else None

    def set_mode(self, mode: SubMode | int | str, *, confirm: bool = True) -> SubMode:
        """Set an ArduSub mode by number or name (SURFTRAK = 21 included).

        With ``confirm``, waits for a heartbeat in the new mode; the sonar mount target
        (if any) is re-sent by the I/O thread when the mode change is seen.
        """
        target_mode = parse_mode(mode)
        self.send_command(commands.set_mode(target_mode))
        if confirm:

            def in_mode() -> bool:
                record = self._store.get("Heartbeat")
                return isinstance(record, Heartbeat) and record.custom_mode == int(target_mode)

            if not self._wait_until(in_mode, self.config.state_confirm_timeout_s):
                raise ModeChangeTimeout(int(target_mode), self.config.state_confirm_timeout_s)
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

    def set_altitude_target(self, altitude_m: float) -> AltitudeTargetResult:
        """Hold a height above the seabed (m).

        Checked against ``min_clearance_m`` before anything is sent. With
        ``config.terrain_frame`` and GUIDED, sends a terrain-frame target; otherwise sends
        the depth target ``depth + (altitude - altitude_target)`` from the latest altimeter
        reading (checked against the depth limit too).
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
        if self.config.terrain_frame and self.mode == SubMode.GUIDED:
            pos = self._fresh(GlobalPosition, "GLOBAL_POSITION_INT")
            self._send(
                commands.terrain_altitude_target_global_int(
                    pos.latitude_deg,
                    pos.longitude_deg,
                    altitude_m,
                    self._target(),
                    self.config.target_component,
                    self._time_boot_ms(),
                )
            )
            return AltitudeTargetResult("terrain_frame", altitude_m, None, None, None)
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

        With ``wait_ack`` (default) the COMMAND_ACK is awaited with the usual retries. A
        control loop that re-sends the tilt every cycle passes ``wait_ack=False``: the
        command goes out once and the loop is never held up by a lost ack (the next cycle
        sends it again). The tilt is remembered and re-sent after every mode change the
        heartbeat shows, because ArduSub puts the mount back to its default mode (RC
        targeting) when it leaves AUTO.
        """
        spec = self._mount_spec(tilt_rad)
        self._set_sticky_command(spec)
        if wait_ack:
            self.send_command(spec)
        else:
            self._send(commands.command_long(spec, self._target(), self.config.target_component, 0))

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

    # ---- mission -----------------------------------------------------------------------

    def _mission_kwargs(self) -> dict[str, int | float]:
        return {
            "target_system": self._target(),
            "target_component": self.config.target_component,
            "mission_type": MAV_MISSION_TYPE_MISSION,
            "item_timeout_s": self.config.mission_item_timeout_s,
            "retries": self.config.mission_retries,
        }

    def upload_mission(
        self, items: Sequence[MissionItem], *, verify: bool = True, home_slot: bool = True
    ) -> list[MissionItem]:
        """Upload a mission; return the wire list (home placeholder first when ``home_slot``).

        With ``verify`` the mission is downloaded again and compared item by item.

        Raises
        ------
        MissionError
            The vehicle refused (``.result`` holds the MAV_MISSION_RESULT).
        MissionTimeout
            The transfer stalled after every retry.
        MissionVerifyError
            The mission read back differs.
        """
        wire = ardupilot_wire_items(items) if home_slot else list(items)
        with self.mission_channel() as channel:
            mission_io.upload(channel, wire, **self._mission_kwargs())  # type: ignore[arg-type]
        if verify:
            verify_items(wire, self.download_mission(home_slot=False), skip_home=home_slot)
        return wire

    def download_mission(self, *, home_slot: bool = True) -> list[MissionItem]:
        """Download the mission; with ``home_slot`` item 0 (ArduPilot's home) is dropped."""
        with self.mission_channel() as channel:
            items = mission_io.download(channel, **self._mission_kwargs())  # type: ignore[arg-type]
        return items[1:] if home_slot and items else items

    def clear_mission(self) -> None:
        """MISSION_CLEAR_ALL, waiting for MISSION_ACK (retried on silence)."""
        with self.mission_channel() as channel:
            mission_io.clear_all(channel, **self._mission_kwargs())  # type: ignore[arg-type]

    def set_mission_current(self, seq: int) -> None:
        """Make item ``seq`` current.

        Sends MAV_CMD_DO_SET_MISSION_CURRENT (acknowledged); if the firmware answers
        UNSUPPORTED, falls back to the older MISSION_SET_CURRENT message and waits for a
        MISSION_CURRENT showing ``seq``.
        """
        try:
            self.send_command(commands.set_mission_current(seq))
            return
        except CommandRejected as exc:
            if exc.result != mavlink2.MAV_RESULT_UNSUPPORTED:
                raise
        target = self._target()
        for _ in range(self.config.command_attempts):
            self._send(
                mavlink2.MAVLink_mission_set_current_message(
                    target, self.config.target_component, seq
                )
            )
            if self._wait_until(
                lambda: (
                    isinstance(current := self._store.get("MissionCurrent"), MissionCurrent)
                    and current.seq == seq
                ),
                self.config.command_timeout_s,
            ):
                return
        raise CommandTimeout(
            mavlink2.MAVLINK_MSG_ID_MISSION_SET_CURRENT,
            "MISSION_SET_CURRENT",
            self.config.command_attempts,
            self.config.command_timeout_s,
        )

    def start_mission(self) -> None:
        """MAV_CMD_MISSION_START (ArduSub: must be armed; switches to AUTO)."""
        self.send_command(commands.mission_start())
