"""The executor's side of the pitch loop: what the sonar shows -> the MPC -> a tilt.

Each control step the shadows measured in the newest frame (slant ranges from range
zero, beam azimuth, the frame's altitude, tilt and pitch) become the loop's target model
(:func:`planner.pitch_loop.shadow_from_measurement`); targets already mapped with a
height that lie ahead but are not in the newest frame are fed forward from their seabed
positions (:func:`planner.pitch_loop.shadow_from_ned`), so the beam is ready for them
before they appear, and targets seen in the last ``memory_frames`` frames but lost in the
newest one (a shadow slipping out of the band) stay served from their last position.
The MPC (:class:`planner.pitch_loop.PitchLoop`) is built once per
pass, with the pass's planned tilt as the nominal (it keeps the mosaic's coverage).
"""

from __future__ import annotations

import math

from planner.config import Settings
from planner.onboard import OnboardPerception
from planner.pitch_loop import (
    MountLimits,
    PitchCommand,
    PitchLoop,
    PitchLoopConfig,
    PitchState,
    TrackedShadow,
    shadow_from_measurement,
    shadow_from_ned,
)
from planner.survey_plan import SurveyPass, SurveyPlan

#: The mount the executor assumes (ArduSub's MNT1_PITCH limits and a typical servo rate).
DEFAULT_MOUNT = MountLimits(min_tilt_rad=0.0, max_tilt_rad=math.radians(80.0), max_rate_rad_s=math.radians(20.0))


class ShadowPitchLoop:
    """Adapter from on-board perception to :class:`~planner.pitch_loop.PitchLoop`.

    Parameters
    ----------
    plan : SurveyPlan
    settings : Settings
        The sonar's aperture and window come from here.
    mount : MountLimits, optional
    """

    def __init__(self, plan: SurveyPlan, settings: Settings, *, mount: MountLimits = DEFAULT_MOUNT,
                 memory_frames: int = 30):
        self.mount = mount
        self.memory_frames = memory_frames
        sonar = settings.sonar
        self._loops: dict[str, PitchLoop] = {}
        for pass_ in plan.passes:
            config = PitchLoopConfig(
                nominal_tilt_rad=pass_.tilt_rad,
                elevation_aperture_rad=sonar.elevation_aperture_rad,
                fan_width_rad=sonar.fan_width_rad,
                window_m=(sonar.window_start_m, sonar.window_end_m),
            )
            self._loops[pass_.name] = PitchLoop(config, mount)
        self.last_command: PitchCommand | None = None
        self.steps = 0

    def _shadows(self, onboard: OnboardPerception, altitude_m: float) -> list[TrackedShadow]:
        shadows: list[TrackedShadow] = []
        seen: set[int] = set()
        result = onboard.last_frame_result
        nav = onboard.nav
        if result is not None and nav is not None:
            for target_id, m in zip(result.target_ids, result.measurements, strict=True):
                if m.truncated or not (math.isfinite(m.r_top_m) and math.isfinite(m.r_end_m)):
                    continue
                try:
                    shadows.append(shadow_from_measurement(
                        target_id, top_slant_m=m.r_top_m, end_slant_m=m.r_end_m, azimuth_rad=m.azimuth_rad,
                        altitude_m=result.altitude_m, tilt_rad=nav.tilt_rad if math.isfinite(nav.tilt_rad) else 0.0,
                        pitch_rad=nav.pitch_rad if math.isfinite(nav.pitch_rad) else 0.0,
                    ))
                    seen.add(target_id)
                except ValueError:
                    continue
        if nav is not None and math.isfinite(nav.north_m):
            newest = onboard.heights.n_frames - 1
            for t in onboard.targets():
                if t.target_id in seen or not t.detections:
                    continue
                last = t.detections[-1]
                recent = newest - last.frame_index <= self.memory_frames
                if not (last.has_position and (recent or t.height_m is not None)):
                    continue
                shadows.append(shadow_from_ned(t.target_id, target_ned_m=(last.north_m, last.east_m),
                                               sonar_ned_m=(nav.north_m, nav.east_m), heading_rad=nav.heading_rad,
                                               height_m=t.height_m))
        del altitude_m
        return shadows

    def tilt_command(self, *, now_s: float, pass_: SurveyPass, onboard: OnboardPerception,
                     current_tilt_rad: float, speed_m_s: float) -> tuple[float, float]:
        """(tilt to command, smallest angular margin of a served shadow, NaN if none)."""
        altitude, _ = onboard.altitude(now_s)
        nav = onboard.nav
        if not math.isfinite(altitude) or nav is None:
            return pass_.tilt_rad, math.nan
        current = current_tilt_rad if math.isfinite(current_tilt_rad) else pass_.tilt_rad
        state = PitchState(altitude_m=altitude,
                           vehicle_pitch_rad=nav.pitch_rad if math.isfinite(nav.pitch_rad) else 0.0,
                           speed_m_s=speed_m_s, current_tilt_rad=self.mount.clip(current))
        command = self._loops[pass_.name].step(state, self._shadows(onboard, altitude))
        self.last_command = command
        self.steps += 1
        margins = [min(m.far_margin_rad, m.near_margin_rad) for m in command.margins]
        return command.tilt_rad, min(margins) if margins else math.nan
