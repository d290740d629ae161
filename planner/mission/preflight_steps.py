"""PREFLIGHT, step by step, against the vehicle (the judgement itself is :mod:`planner.mission.preflight`).

1. Wait until the altimeter gives valid readings and SYS_STATUS shows every present and
   enabled sensor healthy.
2. The EKF origin: read it (REQUEST_MESSAGE GPS_GLOBAL_ORIGIN); without one, give it the
   plan's (SET_GPS_GLOBAL_ORIGIN, altitude 0 at the surface, as the BlueOS DVL extension
   does); with one, fly the plan about it (the plan's origin offset in the vehicle's EKF
   frame), refusing one further than ``max_origin_offset_m``.
3. Read SYSID_MYGCS, FS_GCS_ENABLE, FS_PILOT_INPUT, FS_PILOT_TIMEOUT and MNT1_TYPE (the
   executor reads parameters; it never sets one), look for the topside's HEARTBEAT and
   joystick (system SYSID_MYGCS) and the vehicle's status. On hardware ArduSub's
   pilot-input failsafe fires FS_PILOT_TIMEOUT after boot without a joystick: the step
   waits that long for it (or for the joystick) so the judgement sees the latched state.
4. Judge (:func:`planner.mission.preflight.judge`); refuse with the reason, or go on.
5. Upload the plan as an AUTO mission in ArduSub 4.5's frames and verify it by download.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from perception.geodesy import LocalOrigin
from planner.errors import MissionAborted
from planner.mission.executor_config import ExecutorConfig
from planner.mission.onboard import OnboardPerception
from planner.mission.preflight import MAV_STATE_CRITICAL, PreflightFacts, PreflightReport, judge
from planner.mission.run_folder import RunFolder
from planner.mission.vehicle import Vehicle
from planner.survey.mission_files import mission_items
from planner.survey.plan import SurveyPlan
from vehicle_link.mission import MissionItem
from vehicle_link.telemetry import EkfStatus, Heartbeat, SysStatus

#: How recent the topside's heartbeat and joystick must be at arming, s.
TOPSIDE_HEARTBEAT_AGE_S, TOPSIDE_JOYSTICK_AGE_S = 3.0, 1.0


@dataclass(frozen=True)
class PreflightOutcome:
    """What PREFLIGHT found: the judgement, the mount's frame, the EKF origin, the offset."""

    report: PreflightReport
    mount_frame: str
    map_origin: LocalOrigin
    offset_m: tuple[float, float]  # the plan's origin in the vehicle's EKF frame (north, east)


class PreflightSteps:
    """The steps of the module docstring; ``command`` runs a vehicle call with the
    executor's retries, ``cycle`` waits one control period (taking telemetry), ``abort``
    builds the MissionAborted to raise."""

    def __init__(self, client: Vehicle, clock: Any, onboard: OnboardPerception, config: ExecutorConfig,
                 run: RunFolder, plan: SurveyPlan, *, command: Callable[[str, Callable[[], Any]], Any],
                 cycle: Callable[[], None], abort: Callable[[str, str], MissionAborted]) -> None:
        self._client, self._clock, self._onboard = client, clock, onboard
        self._cfg, self._run, self._plan = config, run, plan
        self._command, self._cycle, self._abort = command, cycle, abort

    def run(self) -> PreflightOutcome:
        """Steps 1-5; raises the executor's MissionAborted with the reason on a refusal."""
        cfg = self._cfg
        self._wait_for_sensors()
        origin, offset = self._origin()
        facts = self._facts()
        report = judge(facts, topside_required=cfg.topside == "required")
        for line in report.lines():
            self._run.event(self._clock.now_s(), "preflight", line)
        if not report.ok:
            raise self._abort("preflight_refused", f"arming refused: {report.refusal}")
        if cfg.upload_mission:
            items = [link_item(it) for it in mission_items(self._plan)]
            self._command(f"mission upload ({len(items)} items, verified)", lambda: self._client.upload_mission(items))
        return PreflightOutcome(report, facts.mount_frame or "earth", origin, offset)

    def _wait_for_sensors(self) -> None:
        cfg = self._cfg
        deadline = self._clock.now_s() + cfg.preflight_timeout_s
        while True:
            self._cycle()
            now = self._clock.now_s()
            alt, _ = self._onboard.altitude(now)
            status = self._client.latest(SysStatus)
            healthy = status is None or (status.sensors_present & status.sensors_enabled & ~status.sensors_health) == 0
            if now - self._onboard.status().last_altimeter_s < cfg.altimeter_timeout_s and math.isfinite(alt) \
                    and healthy:
                return
            if now > deadline:
                why = "altimeter not valid" if not math.isfinite(alt) else "sensors unhealthy"
                raise self._abort("preflight_failed", f"preflight: {why} after {cfg.preflight_timeout_s:.0f} s")

    def _origin(self) -> tuple[LocalOrigin, tuple[float, float]]:
        cfg, plan = self._cfg, self._plan
        origin = self._command("read the EKF origin", self._client.ekf_origin)
        if origin is None and cfg.set_ekf_origin:
            origin = self._command("set the EKF origin to the plan's",
                                   lambda: self._client.set_ekf_origin(plan.origin_lat_deg, plan.origin_lon_deg, 0.0))
        if origin is None:
            raise self._abort("preflight_refused", "the vehicle has no EKF origin (set it in the BlueOS DVL "
                              "extension, or let the executor set it)")
        vehicle_origin = LocalOrigin(origin.latitude_deg, origin.longitude_deg)
        north, east = vehicle_origin.to_local(plan.origin_lat_deg, plan.origin_lon_deg)
        offset = (float(north), float(east))
        distance = math.hypot(*offset)
        if distance > cfg.max_origin_offset_m:
            raise self._abort("preflight_refused", f"the vehicle's EKF origin is {distance:.0f} m from the plan's: "
                              "the plan is for another site")
        self._run.event(self._clock.now_s(), "info",
                        f"EKF origin {origin.latitude_deg:.7f}, {origin.longitude_deg:.7f}; the plan's origin is at "
                        f"({offset[0]:.2f}, {offset[1]:.2f}) m in it")
        return vehicle_origin, offset

    def _param(self, name: str) -> float:
        return float(self._command(f"read {name}", lambda: self._client.get_parameter(name)).value)

    def _status(self) -> int:
        hb = self._client.latest(Heartbeat)
        return -1 if hb is None else hb.system_status

    def _facts(self) -> PreflightFacts:
        client = self._client
        my_gcs = int(self._param("SYSID_MYGCS"))
        fs_pilot = int(self._param("FS_PILOT_INPUT"))
        fs_timeout = self._param("FS_PILOT_TIMEOUT")
        fs_gcs = int(self._param("FS_GCS_ENABLE"))
        mount_frame = self._command("read the mount type (MNT1_TYPE)", client.mount_frame)

        def heard(kind: str, age_s: float) -> bool:
            return any(p.system_id == my_gcs for p in client.peers(kind, age_s))

        wait_until = self._clock.now_s() + (fs_timeout + 1.0 if fs_pilot else 0.0)
        while not heard("MANUAL_CONTROL", TOPSIDE_JOYSTICK_AGE_S) and self._status() != MAV_STATE_CRITICAL \
                and self._clock.now_s() < wait_until:
            self._cycle()
        ekf = client.latest(EkfStatus)
        hb = client.latest(Heartbeat)
        return PreflightFacts(
            our_system_id=int(client.config.source_system), vehicle_system_id=hb.system_id if hb else 1,
            sysid_my_gcs=my_gcs, fs_gcs_enable=fs_gcs, fs_pilot_input=fs_pilot, fs_pilot_timeout_s=fs_timeout,
            topside_heartbeat=heard("HEARTBEAT", TOPSIDE_HEARTBEAT_AGE_S),
            topside_joystick=heard("MANUAL_CONTROL", TOPSIDE_JOYSTICK_AGE_S), system_status=self._status(),
            position_ok=ekf is not None and ekf.horizontal_position_ok, mount_frame=mount_frame)


def link_item(item: Any) -> MissionItem:
    """A :class:`planner.survey.mission_files.MissionItem` as vehicle_link uploads it."""
    p = item.params
    return MissionItem(item.command, item.frame, p[4], p[5], p[6], p[0], p[1], p[2], p[3], item.autocontinue)
