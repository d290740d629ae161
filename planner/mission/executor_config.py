"""How the executor flies and when it gives up (:class:`ExecutorConfig`), and what a dive
did (:class:`DiveResult`)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

from planner.mission.safety import SafetyLimits

SafeAction = Literal["hold", "surface"]
Topside = Literal["required", "absent"]


@dataclass(frozen=True)
class ExecutorConfig:
    """How the executor flies and when it gives up.

    Attributes
    ----------
    safety : SafetyLimits
        Clearance and depth limit, applied to every depth target.
    control_period_s : float
        Period of the control loop (telemetry, frames, pitch loop, setpoints), s. Every
        period a GUIDED position + velocity setpoint goes out (ArduSub's Guided_PosVel:
        it never restarts an S-curve, and 3 s after the last one the vehicle stops and
        holds on its own).
    acceptance_radius_m : float
        A waypoint counts as reached within this horizontal distance, m.
    settle_tolerance_m, settle_time_s, settle_timeout_s : float
        The altitude counts as settled when the filter's altitude stays within the
        tolerance of the target for ``settle_time_s``; past the timeout the dive aborts.
    waypoint_timeout_margin : float
        A leg may take this many times its length at ``speed_m_s`` (plus 30 s).
    speed_m_s : float
        Along-track speed of the setpoint, m/s (and the pitch loop's prediction).
    accel_m_s2 : float
        The horizontal setpoint's acceleration and braking along a leg, m/s^2 (default
        1.0: ArduSub 4.5's own WPNAV_ACCEL, 100 cm/s^2, so the setpoint asks no more than
        the vehicle's position controller would do itself).
    vertical_accel_m_s2 : float
        The depth setpoint's acceleration and braking, m/s^2 (gentle: near the seabed).
    lead_limit_m : float
        The setpoint never runs further ahead of the vehicle than this along the leg, m.
    vertical_speed_m_s : float
        The depth setpoint moves toward its target at most this fast (descents, altitude
        changes), m/s.
    ascent_speed_m_s : float
        Ascent rate of the "surface" safe action (ALT_HOLD with depth targets), m/s.
    link_lost_action, finish_action, abort_action : "hold" or "surface"
        What to command when the link is lost (once it is back), at the end of the
        survey, and on any other abort (Ctrl-C included). "surface" is ALT_HOLD with a
        controlled ascent by depth targets: it needs no position (ArduSub 4.5 refuses
        SURFACE without one). "hold" holds the position in GUIDED, or the depth in
        ALT_HOLD without a position.
    telemetry_stale_s : float
        Depth or navigation older than this aborts the dive, s.
    altimeter_timeout_s : float
        No accepted altimeter reading for this long aborts the dive, s.
    navigation_lost_s : float
        The vehicle's EKF without a horizontal position this long aborts the dive
        ("navigation_lost"), s.
    link_restore_wait_s : float
        After a link loss, how long to wait for the link before giving up commanding, s.
    preflight_timeout_s : float
        Time allowed for the sensors to report healthy before arming, s.
    topside : "required" or "absent"
        "required" (a real dive): arming needs the topside ground station's heartbeat
        and its joystick's MANUAL_CONTROL (as system SYSID_MYGCS), so the pilot can take
        over. "absent": a bench test or a dry run without a topside (documented in
        docs/flying-a-real-sub.md): the vehicle's pilot-input failsafe has then latched
        (it acted once, at boot) and its GCS failsafe has never seen a GCS.
    set_ekf_origin : bool
        If the vehicle has no EKF origin, give it the plan's (SET_GPS_GLOBAL_ORIGIN, as
        the BlueOS DVL extension does). Right only when the EKF's local zero is at the
        plan's origin (the vehicle started there, as in a dry run); otherwise set the
        vehicle's position in the DVL extension and leave this off: the executor then
        flies the plan about the vehicle's origin.
    max_origin_offset_m : float
        A vehicle whose EKF origin lies further than this from the plan's refuses to fly
        (the plan is for another site), m.
    upload_mission : bool
        Upload and verify the plan as an AUTO mission in PREFLIGHT (it stays on the
        vehicle for the pilot; the executor flies GUIDED).
    max_seabed_std_m : float
        No new depth target is derived from a seabed estimate less certain than this (m,
        1-sigma); the vehicle keeps its last one meanwhile.
    slope_lead_s : float
        Over a rising seabed the depth target is taken where the seabed will be this long
        ahead along the setpoint's velocity (:mod:`planner.mission.seabed_slope`), s; 0
        follows the estimate under the vehicle. The default is the lag measured against
        the simulator: the vehicle trailed a 2 deg slope by about 3 s.
    heading_tolerance_rad, turn_timeout_s : float
        At each lane start the vehicle turns in place until its heading is this close to
        the lane's (a forward-looking sonar must face along the lane), or the time is up.
    command_retries : int
        How many times a command (mode, arming, mission upload) that got no answer is
        sent again, each time with the link's own bounded retries; a refusal is never
        retried.
    """

    safety: SafetyLimits
    control_period_s: float = 0.2
    acceptance_radius_m: float = 0.25
    settle_tolerance_m: float = 0.03
    settle_time_s: float = 3.0
    settle_timeout_s: float = 90.0
    waypoint_timeout_margin: float = 3.0
    speed_m_s: float = 0.25
    accel_m_s2: float = 1.0
    vertical_accel_m_s2: float = 0.25
    lead_limit_m: float = 1.0
    vertical_speed_m_s: float = 0.5
    ascent_speed_m_s: float = 0.3
    link_lost_action: SafeAction = "surface"
    finish_action: SafeAction = "surface"
    abort_action: SafeAction = "hold"
    telemetry_stale_s: float = 3.0
    altimeter_timeout_s: float = 6.0
    navigation_lost_s: float = 1.0
    link_restore_wait_s: float = 30.0
    preflight_timeout_s: float = 30.0
    topside: Topside = "required"
    set_ekf_origin: bool = False
    max_origin_offset_m: float = 2000.0
    upload_mission: bool = True
    command_retries: int = 3
    heading_tolerance_rad: float = math.radians(5.0)
    max_seabed_std_m: float = 0.3
    turn_timeout_s: float = 30.0
    slope_lead_s: float = 3.0

    def __post_init__(self) -> None:
        for name in ("control_period_s", "acceptance_radius_m", "settle_tolerance_m", "speed_m_s", "accel_m_s2",
                     "vertical_accel_m_s2",
                     "lead_limit_m", "vertical_speed_m_s", "ascent_speed_m_s", "telemetry_stale_s",
                     "altimeter_timeout_s", "navigation_lost_s"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"ExecutorConfig.{name} must be > 0, got {value!r}")
        for name in ("link_lost_action", "finish_action", "abort_action"):
            if getattr(self, name) not in ("hold", "surface"):
                raise ValueError(f"ExecutorConfig.{name} must be 'hold' or 'surface', got {getattr(self, name)!r}")
        if self.topside not in ("required", "absent"):
            raise ValueError(f"ExecutorConfig.topside must be 'required' or 'absent', got {self.topside!r}")
        if not (math.isfinite(self.slope_lead_s) and 0.0 <= self.slope_lead_s <= 30.0):
            raise ValueError(f"ExecutorConfig.slope_lead_s must be in [0, 30] s, got {self.slope_lead_s!r}")


@dataclass
class DiveResult:
    """What the dive did (the summary's raw material)."""

    status: str = "running"
    reason: str = ""
    message: str = ""
    state: str = "CONNECT"
    states: list[tuple[float, str]] = field(default_factory=list)
    start_s: float = math.nan
    end_s: float = math.nan
    min_clearance_seen_m: float = math.inf
    depth_limit_violations: int = 0
    commands_clamped: int = 0
    safe_action: str | None = None
    waypoints_reached: int = 0
    mount_frame: str | None = None
    origin_offset_m: tuple[float, float] = (0.0, 0.0)
    preflight: list[str] = field(default_factory=list)
