"""An ArduSub-like autopilot: modes, arming, commands, mount, failsafes, telemetry.

No sockets here: :meth:`Autopilot.handle` takes a decoded MAVLink message and returns the
replies; :meth:`Autopilot.update` runs one control step on sensor readings (estimates,
never truth) and returns thrust, the mount target and messages to send. What each mode
does is in :mod:`sim_harness.autopilot.guidance`, AUTO's mission in :mod:`sim_harness.autopilot.mission_runner`,
position targets in :mod:`sim_harness.autopilot.position_targets`.

ArduSub behaviours modelled (ArduSub 4.5): mode numbers (``Mode``); GUIDED, AUTO and
POSHOLD refused without a position estimate ("Mode change failed: X requires position");
AUTO refused with no mission items; COMMAND_ACK FAILED for a refused mode or failed arming
(with a "PreArm: ..." STATUSTEXT), UNSUPPORTED for unknown commands, DENIED for commands
refused by fault injection and for SET_MESSAGE_INTERVAL on unknown messages; SET_MODE
answered with COMMAND_ACK command=11; MISSION_START needs the vehicle armed. The mount
returns to its default angle on every mode change. Failsafes: GCS heartbeat from
SYSID_MYGCS (FS_GCS_ENABLE, FS_GCS_TIMEOUT), depth limit (FENCE_ENABLE, FENCE_ALT_MIN,
FENCE_ACTION), terrain (FS_TERRAIN_ENAB: rangefinder lost for ``TERRAIN_TIMEOUT_S`` while
following a terrain-frame target in AUTO or GUIDED).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sim_harness.autopilot.guidance import (
    REQUIRES_POSITION,
    SUPPORTED_MODES,
    Guidance,
    Mode,
    PilotInput,
    Targets,
)
from sim_harness.autopilot.mission import MissionItem, MissionProtocol
from sim_harness.autopilot.mission_runner import MissionHooks, MissionRunner
from sim_harness.autopilot.params import ParamTable
from sim_harness.autopilot.position_targets import apply_global_int, apply_local_ned
from sim_harness.autopilot.telemetry import (
    BUILDABLE_IDS,
    DATA_STREAM_PARAMS,
    STREAMS,
    TelemetryScheduler,
    TelemetrySnapshot,
    build_message,
)
from sim_harness.faults import FaultConfig
from sim_harness.vehicle.dynamics import MountMechanics, RovParams
from sim_harness.vehicle.sensors import SensorReadings

__all__ = ["Autopilot", "AutopilotConfig", "Mode"]

M = mavlink
TERRAIN_TIMEOUT_S = 1.0
FORCE_ARM_MAGIC = 21196.0
FENCE_HYSTERESIS_M = 0.5


@dataclass(frozen=True)
class AutopilotConfig:
    """Autopilot settings: EKF origin, parameter overrides, arming problems to simulate."""

    origin_lat_deg: float = 47.0
    origin_lon_deg: float = 8.0
    params: dict[str, float] = field(default_factory=dict)
    arming_fail_reason: str | None = None  # e.g. "Leak Detected": arming refused with it
    system_id: int = 1
    component_id: int = 1


class Autopilot:
    """The simulated flight controller."""

    def __init__(
        self, config: AutopilotConfig, rov: RovParams, mount: MountMechanics, faults: FaultConfig
    ) -> None:
        self.cfg = config
        self.rov = rov
        self.mount_limits = mount
        self.faults = faults
        overrides = {"MNT1_PITCH_MIN": -math.degrees(mount.max_tilt_rad),
                     "MNT1_PITCH_MAX": -math.degrees(mount.min_tilt_rad)}
        overrides.update(config.params)
        self.params = ParamTable(overrides)
        self.telemetry = TelemetryScheduler({n: self.params[n] for n in STREAMS})
        self.mode = Mode.MANUAL
        self.armed = False
        self.origin = (config.origin_lat_deg, config.origin_lon_deg)
        self._outbox: list[mavlink.MAVLink_message | None] = []
        self.targets = Targets(speed_m_s=self.params["WPNAV_SPEED"] / 100.0)
        self.guidance = Guidance(rov, self.params,
                                 lambda text: self.statustext(M.MAV_SEVERITY_INFO, text))
        self.mission = MissionProtocol(self._home_item, self._on_new_mission)
        self.runner = MissionRunner(self.mission, self.targets, MissionHooks(
            origin=lambda: self.origin,
            do_command=self._do_command,
            announce_current=lambda: self._outbox.append(
                self._snapshot_message(M.MAVLINK_MSG_ID_MISSION_CURRENT)),
            emit=lambda msg: self._outbox.append(msg),
            text=self.statustext,
        ))
        self._pilot = PilotInput()
        self.mount_target_rad = mount.default_tilt_rad
        self._mount_rate_rad_s: float | None = None
        self._last_gcs_hb_s: float | None = None
        self.failsafe_gcs = False
        self.failsafe_terrain = False
        self._terrain_lost_since: float | None = None
        self._fence_breached = False
        self._last_readings: SensorReadings | None = None
        self._thrust = (0.0, 0.0, 0.0, 0.0)
        self._tilt_rad = mount.default_tilt_rad

    # ------------------------------------------------------------------ helpers
    def statustext(self, severity: int, text: str) -> None:
        """Queue a STATUSTEXT (truncated to 50 characters, as MAVLink)."""
        self._outbox.append(mavlink.MAVLink_statustext_message(severity, text[:50].encode(), 0, 0))

    def _home_item(self) -> MissionItem:
        lat, lon = self.origin
        return MissionItem(0, M.MAV_FRAME_GLOBAL, M.MAV_CMD_NAV_WAYPOINT, 0, 0, 0, 0,
                           int(round(lat * 1e7)), int(round(lon * 1e7)), 0.0)

    def _on_new_mission(self) -> None:
        self.runner.reset()
        if self.mode == Mode.AUTO and not self.runner.has_items:
            self.set_mode(Mode.ALT_HOLD, reason="mission cleared")

    def _ack(self, command: int, result: int, msg: mavlink.MAVLink_message
             ) -> mavlink.MAVLink_message:
        return mavlink.MAVLink_command_ack_message(
            command, result, 0, 0, msg.get_srcSystem(), msg.get_srcComponent()
        )

    def _position_ok(self) -> bool:
        return self._last_readings is not None and self._last_readings.position_ok

    def _drain(self) -> list[mavlink.MAVLink_message]:
        out, self._outbox = self._outbox, []
        return [m for m in out if m is not None]

    # ------------------------------------------------------------------ modes
    def set_mode(self, mode: int, *, reason: str = "GCS") -> bool:
        """Change mode as ArduSub's Sub::set_mode does; False (with a STATUSTEXT) if refused."""
        if mode == self.mode:
            return True
        try:
            new = Mode(mode)
        except ValueError:
            self.statustext(M.MAV_SEVERITY_WARNING, f"No such mode {mode}")
            return False
        if new not in SUPPORTED_MODES:
            self.statustext(M.MAV_SEVERITY_WARNING, f"Flight mode change failed {new.name}")
            return False
        if new in REQUIRES_POSITION and not self._position_ok():
            self.statustext(M.MAV_SEVERITY_WARNING,
                            f"Mode change failed: {new.name} requires position")
            return False
        if new == Mode.AUTO and not self.runner.has_items:
            self.statustext(M.MAV_SEVERITY_WARNING, "Flight mode change failed AUTO")
            return False
        if self.mode == Mode.AUTO:
            self.runner.pause()
        self.mode = new
        # ArduSub 4.5 exit_mode(): the mount goes back to its default on any mode change
        # (before the new mode's mission items run).
        self.mount_target_rad = self.mount_limits.default_tilt_rad
        self._mount_rate_rad_s = None
        self._enter_mode(new)
        self._outbox.append(self._snapshot_message(M.MAVLINK_MSG_ID_HEARTBEAT))
        return True

    def _enter_mode(self, mode: Mode) -> None:
        self._terrain_lost_since = None
        self.guidance.reset()
        r = self._last_readings
        if r is None:
            return
        self.targets.hold_here(r)
        if mode == Mode.AUTO:
            self.runner.begin(r)

    # ------------------------------------------------------------------ arming
    def arm(self, *, force: bool) -> bool:
        """Arm after the pre-arm checks (skipped when forced); False with a PreArm text."""
        if self.armed:
            return True
        if not force:
            reason = self.cfg.arming_fail_reason
            if reason is None and self.mode in REQUIRES_POSITION and not self._position_ok():
                reason = "Mode requires position"
            if reason is not None:
                self.statustext(M.MAV_SEVERITY_CRITICAL, f"PreArm: {reason}")
                return False
        self.armed = True
        self._enter_mode(self.mode)
        self.statustext(M.MAV_SEVERITY_INFO, "Arming motors")
        return True

    def disarm(self, reason: str = "GCS") -> None:
        """Disarm (always allowed)."""
        if self.armed:
            self.armed = False
            self.statustext(M.MAV_SEVERITY_INFO, f"Disarming motors ({reason})")

    def set_guided_target(
        self, north_m: float, east_m: float, depth_m: float, yaw_rad: float | None = None
    ) -> bool:
        """Give GUIDED a position target directly (unit tests and benchmarks only).

        Controllers use SET_POSITION_TARGET_* over MAVLink, which lands in the same state.
        Returns False (target ignored) unless the mode is GUIDED.
        """
        if self.mode != Mode.GUIDED:
            return False
        tg = self.targets
        tg.hold_ne, tg.depth_m, tg.alt_m, tg.vel = (north_m, east_m), depth_m, None, None
        if yaw_rad is not None:
            tg.yaw_rad = yaw_rad
        return True

    # ------------------------------------------------------------------ messages
    def handle(self, msg: mavlink.MAVLink_message, now_s: float) -> list[mavlink.MAVLink_message]:
        """Handle one received message; returns replies (and anything queued meanwhile)."""
        kind = msg.get_type()
        target = getattr(msg, "target_system", None)
        if target not in (None, 0, self.cfg.system_id):
            return []
        out: list[mavlink.MAVLink_message] = []
        r = self._last_readings
        if kind == "HEARTBEAT":
            if msg.get_srcSystem() == int(self.params["SYSID_MYGCS"]):
                self._last_gcs_hb_s = now_s
                if self.failsafe_gcs:
                    self.failsafe_gcs = False
                    self.statustext(M.MAV_SEVERITY_INFO, "GCS heartbeat restored")
        elif kind == "COMMAND_LONG":
            params = (msg.param1, msg.param2, msg.param3, msg.param4, msg.param5, msg.param6,
                      msg.param7)
            out.append(self._ack(msg.command, self._command(msg.command, params, now_s), msg))
        elif kind == "COMMAND_INT":
            params = (msg.param1, msg.param2, msg.param3, msg.param4, float(msg.x),
                      float(msg.y), msg.z)
            out.append(self._ack(msg.command, self._command(msg.command, params, now_s), msg))
        elif kind == "SET_MODE":
            ok = bool(msg.base_mode & M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED) and self.set_mode(
                msg.custom_mode)
            result = M.MAV_RESULT_ACCEPTED if ok else M.MAV_RESULT_FAILED
            out.append(self._ack(M.MAVLINK_MSG_ID_SET_MODE, result, msg))
        elif kind == "MANUAL_CONTROL":
            self._pilot = PilotInput(msg.x, msg.y, msg.z, msg.r, now_s)
        elif kind == "SET_POSITION_TARGET_LOCAL_NED":
            if r is not None:
                apply_local_ned(msg, self.mode, self.targets, r, now_s)
        elif kind == "SET_POSITION_TARGET_GLOBAL_INT":
            if r is not None:
                apply_global_int(msg, self.mode, self.targets, self.origin, now_s)
        elif kind == "REQUEST_DATA_STREAM":
            self._request_data_stream(msg, now_s)
        elif kind == "MISSION_SET_CURRENT":
            if 1 <= msg.seq < len(self.mission.items):
                self.runner.index = int(msg.seq)
                if self.mode == Mode.AUTO:
                    self.runner.start(self.runner.index, r)
            self._outbox.append(self._snapshot_message(M.MAVLINK_MSG_ID_MISSION_CURRENT))
        elif kind.startswith("MISSION_"):
            out.extend(self.mission.handle(msg, now_s))
        elif kind in ("PARAM_REQUEST_LIST", "PARAM_REQUEST_READ", "PARAM_SET"):
            out.extend(self._param_message(msg, now_s))
        elif kind == "GIMBAL_MANAGER_SET_PITCHYAW":
            self._gimbal_pitch(math.degrees(msg.pitch), math.degrees(msg.pitch_rate))
        elif kind == "SET_GPS_GLOBAL_ORIGIN":
            if not self.armed:
                self.origin = (msg.latitude * 1e-7, msg.longitude * 1e-7)
                out.append(mavlink.MAVLink_gps_global_origin_message(
                    msg.latitude, msg.longitude, msg.altitude, int(now_s * 1e6)))
        # Texts raised while handling go first, as ArduPilot sends them before the ACK.
        return self._drain() + out

    def _command(self, command: int, p: tuple[float, ...], now_s: float) -> int:
        if command in self.faults.refuse_commands:
            return M.MAV_RESULT_DENIED
        if command == M.MAV_CMD_COMPONENT_ARM_DISARM:
            if p[0] == 1.0:
                return M.MAV_RESULT_ACCEPTED if self.arm(force=p[1] == FORCE_ARM_MAGIC) else (
                    M.MAV_RESULT_FAILED)
            if p[0] == 0.0:
                self.disarm()
                return M.MAV_RESULT_ACCEPTED
            return M.MAV_RESULT_DENIED
        if command == M.MAV_CMD_DO_SET_MODE:
            if not int(p[0]) & M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
                return M.MAV_RESULT_FAILED
            return M.MAV_RESULT_ACCEPTED if self.set_mode(int(p[1])) else M.MAV_RESULT_FAILED
        if command == M.MAV_CMD_DO_MOUNT_CONTROL:
            self._mount_control(p[0], int(p[6]))
            return M.MAV_RESULT_ACCEPTED
        if command == M.MAV_CMD_DO_MOUNT_CONFIGURE:
            return M.MAV_RESULT_ACCEPTED
        if command == M.MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW:
            self._gimbal_pitch(p[0], p[2])
            return M.MAV_RESULT_ACCEPTED
        if command == M.MAV_CMD_SET_MESSAGE_INTERVAL:
            msg_id = int(p[0])
            if msg_id not in BUILDABLE_IDS:
                return M.MAV_RESULT_DENIED
            self.telemetry.set_interval(msg_id, p[1], now_s=now_s)
            return M.MAV_RESULT_ACCEPTED
        if command == M.MAV_CMD_REQUEST_MESSAGE:
            msg_id = int(p[0])
            reply = self._snapshot_message(msg_id) if msg_id in BUILDABLE_IDS else None
            if reply is None:
                return M.MAV_RESULT_DENIED
            self._outbox.append(reply)
            return M.MAV_RESULT_ACCEPTED
        if command == M.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES:
            reply = self._snapshot_message(M.MAVLINK_MSG_ID_AUTOPILOT_VERSION)
            if reply is not None:
                self._outbox.append(reply)
            return M.MAV_RESULT_ACCEPTED
        if command == M.MAV_CMD_MISSION_START:
            if self.armed and self.runner.has_items and self.set_mode(Mode.AUTO):
                if p[0] >= 1:
                    self.runner.index = min(int(p[0]), len(self.mission.items) - 1)
                    self.runner.begin(self._last_readings)
                return M.MAV_RESULT_ACCEPTED
            return M.MAV_RESULT_FAILED
        if command == M.MAV_CMD_DO_CHANGE_SPEED:
            if p[1] > 0.0:
                self.targets.speed_m_s = p[1]
                return M.MAV_RESULT_ACCEPTED
            return M.MAV_RESULT_FAILED
        return M.MAV_RESULT_UNSUPPORTED

    def _mount_control(self, pitch_deg: float, mount_mode: int) -> None:
        if mount_mode == M.MAV_MOUNT_MODE_MAVLINK_TARGETING:
            self.mount_target_rad = self.mount_limits.clamp(-math.radians(pitch_deg))
            self._mount_rate_rad_s = None
        elif mount_mode in (M.MAV_MOUNT_MODE_RETRACT, M.MAV_MOUNT_MODE_NEUTRAL,
                            M.MAV_MOUNT_MODE_RC_TARGETING):
            self.mount_target_rad = self.mount_limits.default_tilt_rad
            self._mount_rate_rad_s = None

    def _gimbal_pitch(self, pitch_deg: float, pitch_rate_deg_s: float) -> None:
        if math.isfinite(pitch_deg):
            self.mount_target_rad = self.mount_limits.clamp(-math.radians(pitch_deg))
            self._mount_rate_rad_s = None
        elif math.isfinite(pitch_rate_deg_s):
            self._mount_rate_rad_s = -math.radians(pitch_rate_deg_s)

    def _request_data_stream(self, msg: mavlink.MAVLink_message, now_s: float) -> None:
        rate = float(msg.req_message_rate) if msg.start_stop == 1 else 0.0
        if msg.req_stream_id == M.MAV_DATA_STREAM_ALL:
            names = list(STREAMS)
        elif msg.req_stream_id in DATA_STREAM_PARAMS:
            names = [DATA_STREAM_PARAMS[msg.req_stream_id]]
        else:
            return
        for name in names:
            self.params.set(name, rate)
            self.telemetry.set_stream_rate(name, rate, now_s=now_s)

    def _param_message(self, msg: mavlink.MAVLink_message, now_s: float) -> list[mavlink.MAVLink_message]:
        kind = msg.get_type()
        if kind == "PARAM_REQUEST_LIST":
            return [self.params.value_message(n, i) for i, n in enumerate(self.params)]
        if kind == "PARAM_REQUEST_READ":
            name = (msg.param_id if msg.param_index < 0 else self.params.name_at(msg.param_index))
            if not name or name not in self.params:
                return []
            return [self.params.value_message(name, self.params.index_of(name))]
        name = msg.param_id
        if not self.params.set(name, msg.param_value):
            return []
        if name in STREAMS:
            self.telemetry.set_stream_rate(name, self.params[name], now_s=now_s)
        if name == "WPNAV_SPEED":
            self.targets.speed_m_s = self.params[name] / 100.0
        return [self.params.value_message(name, self.params.index_of(name))]

    def _do_command(self, item: MissionItem) -> None:
        if item.command == M.MAV_CMD_DO_CHANGE_SPEED and item.param2 > 0.0:
            self.targets.speed_m_s = item.param2
        elif item.command == M.MAV_CMD_DO_MOUNT_CONTROL:
            self._mount_control(item.param1, int(item.z) or M.MAV_MOUNT_MODE_MAVLINK_TARGETING)
        elif item.command == M.MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW:
            self._gimbal_pitch(item.param1, item.param3)

    # ------------------------------------------------------------------ control loop
    def update(
        self, now_s: float, dt_s: float, r: SensorReadings, tilt_rad: float
    ) -> tuple[tuple[float, float, float, float], float, list[mavlink.MAVLink_message]]:
        """One control step: returns (thrust (4,), mount target tilt rad, messages to send)."""
        first = self._last_readings is None
        self._last_readings = r
        self._tilt_rad = tilt_rad
        if first:
            self._enter_mode(self.mode)
        self._failsafes(now_s, r)
        if self._mount_rate_rad_s is not None:
            self.mount_target_rad = self.mount_limits.clamp(
                self.mount_target_rad + self._mount_rate_rad_s * dt_s)
        if self.armed:
            self._thrust = self.guidance.thrust(self.mode, self.targets, self._pilot, r, now_s,
                                                dt_s)
            if self.mode == Mode.AUTO:
                self.runner.update(r, self.guidance.nav, now_s,
                                   self.params["WPNAV_RADIUS"] / 100.0)
        else:
            self._thrust = (0.0, 0.0, 0.0, 0.0)
        out = self._drain()
        out.extend(self.mission.update(now_s))
        due = self.telemetry.due(now_s)
        snap = self.snapshot(now_s) if due else None
        for msg_id in due:
            assert snap is not None
            msg = build_message(msg_id, snap)
            if msg is not None:
                out.append(msg)
        return self._thrust, self.mount_target_rad, out

    # ------------------------------------------------------------------ failsafes
    def _failsafes(self, now_s: float, r: SensorReadings) -> None:
        p = self.params
        action = int(p["FS_GCS_ENABLE"])
        if (action and self.armed and not self.failsafe_gcs and self._last_gcs_hb_s is not None
                and now_s - self._last_gcs_hb_s > p["FS_GCS_TIMEOUT"]):
            self.failsafe_gcs = True
            self.statustext(M.MAV_SEVERITY_CRITICAL, "Lost GCS heartbeat: failsafe")
            if action == 2:
                self.disarm("GCS failsafe")
            elif action == 3:
                self.set_mode(Mode.ALT_HOLD, reason="GCS failsafe")
            elif action == 4:
                self.set_mode(Mode.SURFACE, reason="GCS failsafe")
        if p["FENCE_ENABLE"] and self.armed:
            limit_m = -p["FENCE_ALT_MIN"]
            if r.depth_m > limit_m and not self._fence_breached:
                self._fence_breached = True
                self.statustext(M.MAV_SEVERITY_CRITICAL, f"Depth limit {limit_m:.1f} m breached")
                if int(p["FENCE_ACTION"]) != 0:
                    self.set_mode(Mode.SURFACE, reason="depth limit")
            elif r.depth_m < limit_m - FENCE_HYSTERESIS_M:
                self._fence_breached = False
        uses_terrain = self.targets.alt_m is not None and self.mode in (Mode.AUTO, Mode.GUIDED)
        if uses_terrain and self.armed and r.altitude_m is None:
            if self._terrain_lost_since is None:
                self._terrain_lost_since = now_s
            elif now_s - self._terrain_lost_since > TERRAIN_TIMEOUT_S and not self.failsafe_terrain:
                self.failsafe_terrain = True
                self.statustext(M.MAV_SEVERITY_CRITICAL, "Terrain data lost: failsafe")
                act = int(p["FS_TERRAIN_ENAB"])
                if act == 1:
                    if not self.set_mode(Mode.POSHOLD, reason="terrain failsafe"):
                        self.set_mode(Mode.ALT_HOLD, reason="terrain failsafe")
                elif act == 2:
                    self.set_mode(Mode.SURFACE, reason="terrain failsafe")
                else:
                    self.disarm("terrain failsafe")
        else:
            self._terrain_lost_since = None
            if r.altitude_m is not None:
                self.failsafe_terrain = False

    # ------------------------------------------------------------------ telemetry
    def base_mode(self) -> int:
        """HEARTBEAT base_mode flags as ArduSub derives them."""
        flags = M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
        if self.mode not in (Mode.MANUAL, Mode.ACRO):
            flags |= M.MAV_MODE_FLAG_STABILIZE_ENABLED
        if self.mode in (Mode.GUIDED, Mode.AUTO):
            flags |= M.MAV_MODE_FLAG_GUIDED_ENABLED
        if self.mode == Mode.AUTO:
            flags |= M.MAV_MODE_FLAG_AUTO_ENABLED
        flags |= M.MAV_MODE_FLAG_MANUAL_INPUT_ENABLED
        if self.armed:
            flags |= M.MAV_MODE_FLAG_SAFETY_ARMED
        return flags

    def snapshot(self, now_s: float) -> TelemetrySnapshot:
        """What telemetry reports now."""
        r = self._last_readings
        assert r is not None, "update() must run before telemetry"
        failsafe = self.failsafe_gcs or self.failsafe_terrain
        status = M.MAV_STATE_CRITICAL if failsafe else (
            M.MAV_STATE_ACTIVE if self.armed else M.MAV_STATE_STANDBY)
        p = self.rov
        lim = (p.max_surge_n, p.max_sway_n, p.max_heave_n, p.max_yaw_nm)
        norm = [max(-1.0, min(1.0, t / m)) for t, m in zip(self._thrust, lim, strict=True)]
        return TelemetrySnapshot(
            time_s=now_s, readings=r, custom_mode=int(self.mode), armed=self.armed,
            system_status=status, base_mode=self.base_mode(),
            mission_seq=self.runner.index, mission_total=len(self.mission.items),
            mission_state=self.runner.state,
            thrust_norm=(norm[0], norm[1], norm[2], norm[3]), tilt_rad=self._tilt_rad,
            origin_lat_deg=self.origin[0], origin_lon_deg=self.origin[1],
            nav_bearing_deg=self.guidance.nav.bearing_deg,
            nav_distance_m=self.guidance.nav.distance_m,
            nav_alt_error_m=self.guidance.nav.vertical_error_m,
            target_yaw_rad=self.targets.yaw_rad if self.targets.yaw_rad is not None else r.yaw_rad,
            rangefinder_min_m=self.params["RNGFND1_MIN_CM"] / 100.0,
            rangefinder_max_m=self.params["RNGFND1_MAX_CM"] / 100.0, failsafe=failsafe,
        )

    def _snapshot_message(self, msg_id: int) -> mavlink.MAVLink_message | None:
        if self._last_readings is None:
            return None
        return build_message(msg_id, self.snapshot(self._last_readings.time_s))
