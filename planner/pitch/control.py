"""The executor's side of the pitch loop: what the sonar shows -> the MPC -> a tilt.

Each control step the shadows measured in the newest frame (slant ranges from range
zero, beam azimuth, the frame's altitude, tilt and pitch) become the loop's target model
(:func:`planner.pitch.measurements.shadow_from_measurement`). A shadow cut by an edge of the
field of view (truncated: no height from it) still places its target: its shadow is at
least as long as seen (and as long as the track's height or the site's smallest height
make it), so the beam moves toward the cut edge and the next frame shows more; this is
how a target entering at the far end of the window or the side of the fan is picked up
before the tracker has a height for it. Targets already mapped with a
height that lie ahead but are not in the newest frame are fed forward from their seabed
positions (:func:`planner.pitch.measurements.shadow_from_ned`), so the beam is ready for them
before they appear, and targets seen in the last ``memory_frames`` frames but lost in the
newest one (a shadow slipping out of the band) stay served from their last position.
The MPC (:class:`planner.pitch.qp.PitchLoop`) is built once per
pass, with the pass's planned tilt as the nominal (it keeps the mosaic's coverage), the
site's tallest and smallest expected target heights as the height priors of targets not
measured yet, and the search band on (``search_weight_factor``): with no tracked target
in range the beam keeps the far end of the range window in view, so a target entering
it is seen whole at once rather than when the tracker first catches it.

Mount frame (:meth:`ShadowPitchLoop.set_mount_frame`, from MNT1_TYPE): the loop's tilt is
in the frame the mount takes. ArduSub's default servo mount is stabilised (the autopilot
subtracts the vehicle's pitch, ``AP_Mount_Servo::update_angle_outputs``), so for it the
loop commands the earth-frame depression and models the vehicle as level (the pitch is
not added a second time); a frame's body-frame tilt is then the commanded angle plus the
pitch at the ping. An unstabilised mount ("body") gets body-frame tilts, the vehicle's
pitch and pitch rate in the prediction.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import replace

from perception.geometry.mount import slew_toward
from perception.geometry.shadow import clamp_height_m, shadow_end_slant_m
from perception.mapping.map_process import TrackedTarget
from perception.mapping.survey_map import SAME_TARGET_RADIUS_M
from planner.config import Settings
from planner.mission.onboard import OnboardPerception
from planner.pitch.baseline import nominal_tilt_for
from planner.pitch.config import MountLimits, PitchLoopConfig
from planner.pitch.measurements import shadow_from_measurement, shadow_from_ned
from planner.pitch.qp import PitchLoop
from planner.pitch.reach import beyond_reach
from planner.pitch.types import PitchCommand, PitchState, TrackedShadow
from planner.survey.plan import SurveyPass, SurveyPlan

#: The mount the executor assumes (ArduSub's MNT1_PITCH limits and a typical servo rate).
DEFAULT_MOUNT = MountLimits(min_tilt_rad=0.0, max_tilt_rad=math.radians(80.0), max_rate_rad_s=math.radians(20.0))


class ShadowPitchLoop:
    """Adapter from on-board perception to :class:`~planner.pitch.qp.PitchLoop`.

    Parameters
    ----------
    plan : SurveyPlan
    settings : Settings
        The sonar's aperture and window come from here.
    mount : MountLimits, optional
    """

    def __init__(self, plan: SurveyPlan, settings: Settings, *, mount: MountLimits = DEFAULT_MOUNT,
                 memory_frames: int = 30, search_weight_factor: float = 0.1, control_period_s: float = 0.2,
                 horizon_s: float = 2.0, motion_window_s: float = 0.4,
                 accel_lead_m_s: float = 0.35, targets_refresh_s: float = 0.5, hold_start_s: float = 0.1):
        self.mount = mount
        self.targets_refresh_s = targets_refresh_s
        self._targets_cache: tuple[float, list[TrackedTarget]] | None = None
        self.accel_lead_m_s = accel_lead_m_s
        self.motion_window_s = motion_window_s
        self.memory_frames = memory_frames
        self.height_min_m = min(settings.site.target_height_min_m, settings.site.target_height_max_m)
        self._loops: dict[str, PitchLoop] = {}
        for pass_ in plan.passes:
            config = loop_config(settings, nominal_tilt_rad=pass_.tilt_rad, search_weight_factor=search_weight_factor,
                                 control_period_s=control_period_s, horizon_s=horizon_s, hold_start_s=hold_start_s)
            self._loops[pass_.name] = PitchLoop(config, mount)
        self.last_command: PitchCommand | None = None
        self.mount_frame = "body"
        self.steps = 0
        self._commands: deque[tuple[float, float]] = deque()  # (time_s, tilt_rad) this loop asked for
        self._history_s = 5.0

    def set_mount_frame(self, frame: str) -> None:
        """"earth" (a stabilised mount: tilts are earth-frame) or "body" (see the module docstring)."""
        if frame not in ("earth", "body"):
            raise ValueError(f"mount frame must be 'earth' or 'body', got {frame!r}")
        self.mount_frame = frame

    def mount_tilt_at(self, time_s: float) -> float:
        """The mount's tilt at ``time_s`` (rad) from the commands this loop gave: each one
        slewed to at the mount's rate limit from the time it was given; NaN before any.

        The mount's own angle report comes every 0.5 s by default and late: during a slew
        it is several degrees off, and the frames' shadows would be placed with it.
        """
        tilt = math.nan
        items = list(self._commands)
        for k, (t_k, cmd) in enumerate(items):
            if t_k > time_s:
                break
            if math.isnan(tilt):
                tilt = cmd
                continue
            until = min(items[k + 1][0], time_s) if k + 1 < len(items) else time_s
            tilt = slew_toward(tilt, cmd, max_rate_rad_s=self.mount.max_rate_rad_s, dt_s=until - t_k)
        return tilt

    def record_command(self, time_s: float, tilt_rad: float) -> None:
        """Note a tilt asked of the mount at ``time_s`` (for :meth:`mount_tilt_at`)."""
        self._commands.append((time_s, tilt_rad))
        while len(self._commands) > 2 and self._commands[1][0] < time_s - self._history_s:
            self._commands.popleft()

    def _shadows(self, onboard: OnboardPerception, now_s: float, speed_m_s: float,
                 config: PitchLoopConfig | None = None) -> list[TrackedShadow]:
        """The targets ahead in the level frame at ``now_s`` (the vehicle has moved on
        ``speed_m_s`` times the age of the frame or the navigation sample they come from).

        With the loop's ``config``, remembered tracks that no step of its horizon could
        serve are left out before they are placed (:func:`beyond_reach`): a field dive
        remembers hundreds, and placing each every step made the step's cost grow with the
        dive."""
        shadows: list[TrackedShadow] = []
        seen: set[int] = set()
        result = onboard.last_frame
        nav = onboard.nav
        if result is not None and nav is not None:
            heights = {t.target_id: t.height_m for t in self._tracked(onboard, now_s)} if any(
                m.truncated for m in result.measurements) else {}
            alt = result.altitude_m
            frame_age_s = min(max(now_s - result.timestamp_s, 0.0), 1.0)
            frame_tilt = self.mount_tilt_at(result.timestamp_s)
            if not math.isfinite(frame_tilt):
                frame_tilt = nav.tilt_rad if math.isfinite(nav.tilt_rad) else 0.0
            for target_id, m in zip(result.target_ids, result.measurements, strict=True):
                r_end = m.r_end_m
                if not math.isfinite(m.r_top_m):
                    continue
                if m.truncated:
                    # The shadow is at least this long: as seen, as the track's height makes it, and
                    # as the smallest expected target makes it.
                    known = heights.get(target_id)
                    longest = [r_end if math.isfinite(r_end) else 0.0]
                    for h in (known, self.height_min_m):
                        if h is not None and math.isfinite(h) and 0.0 <= h < alt:
                            longest.append(shadow_end_slant_m(m.r_top_m, alt, h))
                    r_end = max(longest)
                if not math.isfinite(r_end):
                    continue
                frame_nav = onboard.nav_at(result.timestamp_s) or nav
                frame_pitch = frame_nav.pitch_rad if math.isfinite(frame_nav.pitch_rad) else 0.0
                # The measurement's geometry needs the body-frame tilt at the ping: a
                # stabilised mount held the earth-frame angle, so add the pitch (once).
                body_tilt = frame_tilt + frame_pitch if self.mount_frame == "earth" else frame_tilt
                footprint = footprint_from_highlight_m(m.r_top_m, m.highlight_range_m, alt)
                try:
                    seen_then = shadow_from_measurement(
                        target_id, top_slant_m=m.r_top_m, end_slant_m=r_end, azimuth_rad=m.azimuth_rad,
                        altitude_m=result.altitude_m, tilt_rad=body_tilt, pitch_rad=frame_pitch,
                        footprint_m=footprint,
                    )
                except ValueError:
                    continue
                shadows.append(replace(seen_then, along_m=seen_then.along_m - speed_m_s * frame_age_s))
                seen.add(target_id)
        shadows = merge_pieces(shadows, radius_m=SAME_TARGET_RADIUS_M)
        if nav is not None and math.isfinite(nav.north_m):
            newest = onboard.frames_measured - 1
            nav_age_s = min(max(now_s - nav.time_s, 0.0), 1.0)
            # Tracks with a height first: of two tracks on one spot, the one that knows more stays.
            for t in sorted(self._tracked(onboard, now_s), key=lambda t: t.height_m is None):
                if t.target_id in seen:
                    continue
                recent = newest - t.last_frame_index <= self.memory_frames
                if not (t.has_position and (recent or t.height_m is not None)):
                    continue
                remembered = shadow_from_ned(t.target_id, target_ned_m=(t.last_north_m, t.last_east_m),
                                             sonar_ned_m=(nav.north_m, nav.east_m), heading_rad=nav.heading_rad,
                                             height_m=t.height_m)
                remembered = replace(remembered, along_m=remembered.along_m - speed_m_s * nav_age_s)
                if config is not None and beyond_reach(remembered, config, speed_m_s=speed_m_s):
                    continue
                # A remembered track where a measured or another remembered shadow already is
                # is a second track of that target (the tracker split it): it must not count twice.
                if any(math.hypot(remembered.along_m - s.along_m, remembered.cross_m - s.cross_m)
                       < SAME_TARGET_RADIUS_M for s in shadows):
                    continue
                shadows.append(remembered)
        return shadows

    def _tracked(self, onboard: OnboardPerception, now_s: float) -> list[TrackedTarget]:
        """Perception's targets, solved again at most every ``targets_refresh_s``: solving
        every track's height is the costliest part of a control step, and the loop only
        reads seabed positions (fixed) and heights (which settle over many frames)."""
        if self._targets_cache is None or now_s - self._targets_cache[0] >= self.targets_refresh_s \
                or now_s < self._targets_cache[0]:
            self._targets_cache = (now_s, list(onboard.tracked_targets()))
        return self._targets_cache[1]

    def _motion(self, onboard: OnboardPerception, speed_m_s: float) -> tuple[float, float]:
        """(speed along the heading, m/s; pitch rate, rad/s) from the navigation history
        (the last ``motion_window_s`` of positions and attitude).

        ``speed_m_s`` is the speed the vehicle is asked to fly: the measured speed lags
        (a window of positions reported late), so while the vehicle is below it the
        prediction takes ``accel_lead_m_s`` more, up to it, and while above it (braking
        for a waypoint) as much less, down to it; without a history, it
        (``tests/planner/pitch/test_prediction_vs_simulator.py`` checks this against the
        simulator's dynamics)."""
        nav = onboard.nav
        if nav is None:
            return speed_m_s, 0.0
        before = onboard.nav_at(nav.time_s - self.motion_window_s)
        if before is None or nav.time_s - before.time_s < 0.5 * self.motion_window_s:
            return speed_m_s, 0.0
        dt = nav.time_s - before.time_s
        speed = speed_m_s
        if all(math.isfinite(v) for v in (nav.north_m, nav.east_m, before.north_m, before.east_m, nav.heading_rad)):
            speed = max(0.0, ((nav.north_m - before.north_m) * math.cos(nav.heading_rad)
                              + (nav.east_m - before.east_m) * math.sin(nav.heading_rad)) / dt)
            # The measured speed lags the vehicle either way: ahead of the commanded speed
            # by up to the lead (accelerating or braking), never past it.
            speed = min(speed_m_s, speed + self.accel_lead_m_s) if speed < speed_m_s \
                else max(speed_m_s, speed - self.accel_lead_m_s)
        rate = (nav.pitch_rad - before.pitch_rad) / dt if math.isfinite(nav.pitch_rad - before.pitch_rad) else 0.0
        return speed, rate

    def tracking_zone(self, pass_: SurveyPass) -> dict[str, float]:
        """The pass's tracking zone at its planned altitude (:func:`describe_zone`)."""
        return describe_zone(self._loops[pass_.name].config, pass_.altitude_m)

    def tilt_command(self, *, now_s: float, pass_: SurveyPass, onboard: OnboardPerception,
                     current_tilt_rad: float, speed_m_s: float) -> tuple[float, float]:
        """(tilt to command, smallest angular margin of a served shadow, NaN if none)."""
        altitude, _ = onboard.altitude(now_s)
        nav = onboard.nav
        if not (math.isfinite(altitude) and altitude > 0.0) or nav is None:  # no (sane) altitude: the plan's tilt
            self.record_command(now_s, pass_.tilt_rad)
            return pass_.tilt_rad, math.nan
        current = current_tilt_rad if math.isfinite(current_tilt_rad) else pass_.tilt_rad
        if not self._commands:
            self.record_command(now_s - self._history_s, current)  # where the mount was put before the loop
        speed, pitch_rate = self._motion(onboard, speed_m_s)
        pitch = nav.pitch_rad if math.isfinite(nav.pitch_rad) else 0.0
        if self.mount_frame == "earth":
            pitch = pitch_rate = 0.0  # the stabilised mount takes the pitch out: the loop sees a level vehicle
        pitch_age_s = min(max(now_s - nav.time_s, 0.0), 0.5)
        state = PitchState(altitude_m=altitude, vehicle_pitch_rad=pitch + pitch_rate * pitch_age_s,
                           pitch_rate_rad_s=pitch_rate, speed_m_s=speed, current_tilt_rad=self.mount.clip(current))
        loop = self._loops[pass_.name]
        command = loop.step(state, self._shadows(onboard, now_s, speed, loop.config))
        self.last_command = command
        self.record_command(now_s, command.tilt_rad)
        self.steps += 1
        margins = [min(m.far_margin_rad, m.near_margin_rad) for m in command.margins]
        return command.tilt_rad, min(margins) if margins else math.nan


def loop_config(settings: Settings, *, nominal_tilt_rad: float, search_weight_factor: float = 0.1,
                control_period_s: float = 0.2, horizon_s: float = 2.0, hold_start_s: float = 0.1) -> PitchLoopConfig:
    """The pitch loop's settings for a pass with the planned tilt ``nominal_tilt_rad`` (rad):
    the sonar's aperture, fan and window, the site's target heights as the height priors.

    The loop's step is the executor's control period (s): the tilt is held one period, not
    longer, so each step's interval need only suit the geometry over that period. The
    dry run's scorer builds its tracking zone from the same settings.
    """
    sonar = settings.sonar
    steps = max(1, min(100, round(horizon_s / control_period_s)))
    return PitchLoopConfig(
        nominal_tilt_rad=nominal_tilt_rad,
        elevation_aperture_rad=sonar.elevation_aperture_rad,
        fan_width_rad=sonar.fan_width_rad,
        window_m=(sonar.window_start_m, sonar.window_end_m),
        height_prior_m=settings.site.target_height_max_m,
        height_min_m=min(settings.site.target_height_min_m, settings.site.target_height_max_m),
        search_weight_factor=search_weight_factor,
        dt_s=control_period_s,
        horizon_steps=steps,
        hold_start_s=min(hold_start_s, control_period_s),
    )


def describe_zone(config: PitchLoopConfig, altitude_m: float) -> dict[str, float]:
    """The tracking zone at ``altitude_m`` (m) for logs and summary.json.

    Keys: ``altitude_m``; ``start_m`` (:meth:`PitchLoopConfig.zone_start_m`, ground range
    ahead of a target's far top edge) and ``start_over_altitude``; ``min_start_m`` (the
    plain ``min_ground_range_over_altitude`` altitudes); ``end_ground_m`` (the seabed at
    the window's end); ``margin_deg`` (per aperture edge: margin plus pitch envelope);
    ``height_m`` (the tallest target it is sized for); ``depression_span_deg`` (from the
    start of the shadow of such a target at the zone's start to the window's end) and
    ``aperture_deg``; ``centre_depression_deg`` (the fixed tilt that centres it, level).
    """
    w1 = float(config.window_m[1])
    start = float(config.zone_start_m(altitude_m))
    h = float(clamp_height_m(config.height_prior_m, altitude_m))
    shallow = math.asin(min(1.0, altitude_m / w1))
    steep = math.asin(min(1.0, altitude_m / math.hypot(start, altitude_m - h))) if math.isfinite(start) else math.nan
    return {
        "altitude_m": altitude_m,
        "start_m": start,
        "start_over_altitude": start / altitude_m,
        "min_start_m": config.min_ground_range_over_altitude * altitude_m,
        "end_ground_m": math.sqrt(max(w1**2 - altitude_m**2, 0.0)),
        "margin_deg": math.degrees(config.zone_margin_rad),
        "height_m": h,
        "depression_span_deg": math.degrees(steep - shallow),
        "aperture_deg": math.degrees(config.elevation_aperture_rad),
        "centre_depression_deg": math.degrees(nominal_tilt_for(altitude_m, config)),
    }


class ZoneCentredTilt:
    """The fixed-tilt baseline over the same tracking zone: each pass holds the tilt that
    centres the zone at its planned altitude (:func:`planner.pitch.baseline.nominal_tilt_for`,
    level vehicle), so the comparison with the loop is over the same targets."""

    def __init__(self, plan: SurveyPlan, settings: Settings):
        self._configs = {p.name: loop_config(settings, nominal_tilt_rad=p.tilt_rad) for p in plan.passes}
        self._tilts = {p.name: DEFAULT_MOUNT.clip(nominal_tilt_for(p.altitude_m, self._configs[p.name]))
                       for p in plan.passes}

    def set_mount_frame(self, frame: str) -> None:
        """The zone-centred tilt is a depression below the horizontal: an earth-frame
        angle, right as it is for a stabilised mount and for a level vehicle otherwise."""
        del frame

    def tracking_zone(self, pass_: SurveyPass) -> dict[str, float]:
        """The pass's tracking zone at its planned altitude (:func:`describe_zone`)."""
        return describe_zone(self._configs[pass_.name], pass_.altitude_m)

    def tilt_command(self, *, now_s: float, pass_: SurveyPass, onboard: OnboardPerception,
                     current_tilt_rad: float, speed_m_s: float) -> tuple[float, float]:
        """(the pass's zone-centred tilt, NaN: no margins are tracked)."""
        del now_s, onboard, current_tilt_rad, speed_m_s
        return self._tilts[pass_.name], math.nan


def footprint_from_highlight_m(top_slant_m: float, highlight_slant_m: float, altitude_m: float, *,
                               max_m: float = 0.5) -> float:
    """Horizontal extent of a target from its nearest echo to its far top edge, m.

    The highlight starts at the target's nearest point and the shadow at its far top
    edge; their slant difference, turned horizontal (``d ground = d slant * r / g``), is
    kept in the beam too: on the outer beams of a wide target the shadow starts behind
    its near corners, not its far edge (0 when unknown, at most ``max_m``).
    """
    if not (math.isfinite(top_slant_m) and math.isfinite(highlight_slant_m)) or highlight_slant_m >= top_slant_m:
        return 0.0
    ground = math.sqrt(max(top_slant_m**2 - altitude_m**2, 0.0))
    if ground <= 0.0:
        return 0.0
    return min((top_slant_m - highlight_slant_m) * top_slant_m / ground, max_m)


def merge_pieces(shadows: list[TrackedShadow], *, radius_m: float) -> list[TrackedShadow]:
    """Shadows whose far top edges lie within ``radius_m`` of each other (level frame) are
    pieces of one target (segmentation split it): one shadow covering them all.

    The merged shadow has the farthest piece's top edge, the tallest height and a
    footprint reaching the nearest piece's near foot, so keeping it whole keeps every
    piece whole; it counts once in the loop instead of once per piece. Order is kept
    (by each group's first piece).
    """
    groups: list[list[TrackedShadow]] = []
    for s in shadows:
        for g in groups:
            if any(math.hypot(s.along_m - o.along_m, s.cross_m - o.cross_m) < radius_m for o in g):
                g.append(s)
                break
        else:
            groups.append([s])
    out = []
    for g in groups:
        if len(g) == 1:
            out.append(g[0])
            continue
        far = max(g, key=lambda s: s.along_m)
        heights = [s.height_m for s in g if s.height_m is not None]
        reach = max(far.along_m - s.along_m + s.footprint_m for s in g)
        out.append(TrackedShadow(far.target_id, far.along_m, far.cross_m, max(heights) if heights else None,
                                 max(reach, 0.0), any(s.measured for s in g)))
    return out
