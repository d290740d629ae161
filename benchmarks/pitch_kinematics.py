"""A small closed-loop kinematic simulation of one survey pass for the pitch loop (tests and
the pitch benchmark only; the product never imports it)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from perception.errors import MeasurementError
from perception.geometry import ray_angles_sonar, sonar_to_ned
from perception.geometry.mount import slew_toward
from perception.geometry.shadow import shadow_scale
from planner.errors import ConfigError
from planner.pitch.aperture import ShadowGeometry, depression_interval_rad, shadow_geometry
from planner.pitch.config import MountLimits, PitchLoopConfig
from planner.pitch.measurements import shadow_from_measurement, shadow_measurement
from planner.pitch.types import FloatArray, PitchState, TiltLaw, TrackedShadow


@dataclass(frozen=True)
class SeabedTarget:
    """A target on a flat seabed: far top edge at lane position ``(along_m, cross_m)``, m."""

    target_id: int
    along_m: float
    cross_m: float
    height_m: float
    footprint_m: float = 0.0


@dataclass(frozen=True)
class PassScenario:
    """One straight pass at constant altitude and speed over a field of targets.

    The vehicle's sonar starts at lane position 0 and advances at ``speed_m_s``; the pitch
    disturbance is ``amplitude sin(2 pi f t + phase)``. Noise levels are standard
    deviations of what the controller is given; frames come every ``frame_period_s``,
    control steps every ``PitchLoopConfig.dt_s``. Frames before ``settle_s`` are not scored.
    """

    altitude_m: float
    speed_m_s: float
    pitch_amplitude_rad: float
    pitch_frequency_hz: float
    pitch_phase_rad: float
    targets: tuple[SeabedTarget, ...]
    duration_s: float
    frame_period_s: float = 0.1
    settle_s: float = 5.0
    range_noise_m: float = 0.01
    azimuth_noise_rad: float = math.radians(0.2)
    altitude_noise_m: float = 0.01
    pitch_noise_rad: float = math.radians(0.1)
    prior_position_noise_m: float = 0.1
    tracker_gain: float = 0.3
    lookahead_m: float = 16.0


@dataclass(frozen=True)
class PassResult:
    """Truth of a simulated pass. Frame arrays have shape ``(F,)`` or ``(F, T)`` for T targets.

    ``in_range``: the target's whole shadow lies in the range window and the fan, it is in
    the tracking zone, and some tilt within the mount's limits would show it whole
    (elevation margin 0, true pitch). ``visible``: the whole shadow is inside the field
    of view (direct ray computation). ``jointly_feasible``: one tilt could show all
    in-range targets at once.
    """

    time_s: FloatArray
    tilt_rad: FloatArray
    pitch_rad: FloatArray
    command_tilt_rad: FloatArray
    in_range: NDArray[np.bool_]
    visible: NDArray[np.bool_]
    jointly_feasible: NDArray[np.bool_]
    settled: NDArray[np.bool_]
    solver_failures: int
    command_time_s: FloatArray = field(default_factory=lambda: np.zeros(0))

    @property
    def scored_frames(self) -> int:
        """Number of (frame, target) pairs scored: settled and in range."""
        return int(np.sum(self.in_range & self.settled[:, None]))

    @property
    def visible_frames(self) -> int:
        """Scored (frame, target) pairs with the whole shadow in view."""
        return int(np.sum(self.in_range & self.visible & self.settled[:, None]))

    @property
    def feasible_scored_frames(self) -> int:
        """Scored pairs in frames where one tilt could show every in-range target."""
        return int(np.sum(self.in_range & (self.settled & self.jointly_feasible)[:, None]))

    @property
    def feasible_visible_frames(self) -> int:
        """Of those, the pairs with the whole shadow in view."""
        return int(np.sum(self.in_range & self.visible & (self.settled & self.jointly_feasible)[:, None]))

    def sign_changes_per_minute(self, deadband_rad: float = math.radians(0.1)) -> float:
        """Sign changes of the commanded tilt increments per minute (settled part)."""
        settled_t = self.command_time_s >= self.time_s[self.settled][0] if np.any(self.settled) else None
        if settled_t is None:
            return 0.0
        return tilt_sign_changes(self.command_tilt_rad[settled_t], deadband_rad=deadband_rad) / max(
            (self.time_s[-1] - self.time_s[self.settled][0]) / 60.0, 1e-9)


def tilt_sign_changes(tilt_rad: ArrayLike, *, deadband_rad: float) -> int:
    """Sign changes of the increments of a tilt series, increments within the deadband ignored."""
    inc = np.diff(np.asarray(tilt_rad, dtype=np.float64))
    signs = np.sign(inc[np.abs(inc) > deadband_rad])
    return int(np.count_nonzero(signs[1:] != signs[:-1]))


def whole_shadow_visible(
    geom: ShadowGeometry, *, tilt_rad: float, pitch_rad: float, config: PitchLoopConfig, samples: int = 8
) -> NDArray[np.bool_]:
    """Truth: is each target's whole shadow inside the field of view? (direct ray computation)

    The top edge, the near foot, the seabed at the top edge's slant range and ``samples``
    seabed points from the far foot to the shadow end are turned into the sonar frame
    with :func:`perception.geometry.sonar_to_ned`; all must be within the elevation
    aperture, the fan and the range window.

    Parameters
    ----------
    geom : ShadowGeometry
        Shapes ``(T,)``: one time, T targets.
    """
    alt, h = geom.altitude_m, geom.height_m
    s = np.linspace(0.0, 1.0, samples)[None, :]
    scale = 1.0 + s * (shadow_scale(alt, h) - 1.0)[:, None]
    pts = [np.stack([geom.top_along_m, geom.top_cross_m, alt - h], axis=-1)[:, None, :],
           np.stack([geom.base_along_m, geom.base_cross_m, alt], axis=-1)[:, None, :],
           np.stack([geom.start_along_m, geom.start_cross_m, alt], axis=-1)[:, None, :],
           np.stack([geom.top_along_m[:, None] * scale, geom.top_cross_m[:, None] * scale,
                     np.broadcast_to(alt[:, None], scale.shape)], axis=-1)]
    p = np.concatenate(pts, axis=1)
    rot = sonar_to_ned(tilt_rad=tilt_rad, pitch_rad=pitch_rad)
    az, el = ray_angles_sonar(p @ rot)  # rows of p times rot = rot.T applied to each point
    rng_m = np.linalg.norm(p, axis=-1)
    w0, w1 = config.window_m
    ok = ((np.abs(el) <= config.elevation_aperture_rad / 2) & (np.abs(az) <= config.fan_width_rad / 2)
          & (rng_m >= w0) & (rng_m <= w1))
    return np.all(ok, axis=1) & (geom.top_along_m > 0)


def truth_in_range(geom: ShadowGeometry, *, pitch_rad: float, config: PitchLoopConfig,
                    limits: MountLimits) -> tuple[NDArray[np.bool_], FloatArray, FloatArray]:
    lo, hi = depression_interval_rad(geom, half_aperture_rad=config.elevation_aperture_rad / 2)
    lo_t = np.maximum(lo + pitch_rad, limits.min_tilt_rad)
    hi_t = np.minimum(hi + pitch_rad, limits.max_tilt_rad)
    w0, w1 = config.window_m
    ok = ((geom.top_along_m > 0) & (geom.end_slant_m <= w1) & (geom.near_slant_m >= w0)
          & (np.abs(geom.bearing_rad) <= config.fan_width_rad / 2)
          & (geom.base_ground_m >= config.zone_start_m(geom.altitude_m)) & (lo_t <= hi_t))
    return ok, lo_t, hi_t


def simulate_pass(
    controller: TiltLaw,
    scenario: PassScenario,
    *,
    config: PitchLoopConfig,
    limits: MountLimits,
    rng: np.random.Generator,
    score_config: PitchLoopConfig | None = None,
) -> PassResult:
    """Fly one pass in closed loop and score it against truth (pure; seeded by ``rng``).

    ``score_config`` (default ``config``) gives the tracking zone the frames are scored
    over, e.g. the plain 2-altitude zone for a loop configured with the fitted one.

    Each frame: truth scoring; every ``config.dt_s`` the controller gets the measured
    altitude, pitch and rate, the mount's tilt and the targets within ``lookahead_m``
    ahead, as a simple tracker sees them: its estimate of each target starts at the
    mapped position (noisy, no height) and is blended (gain ``tracker_gain``) with each
    noisy slant measurement (:func:`shadow_from_measurement`) taken when the whole
    shadow is in the frame (then ``measured=True``). The mount slews toward the command
    at its rate limit.
    """
    sc = scenario
    every = round(config.dt_s / sc.frame_period_s)
    if every < 1 or not math.isclose(every * sc.frame_period_s, config.dt_s, rel_tol=1e-9):
        raise ConfigError(f"dt_s ({config.dt_s!r}) must be a whole number of frame periods ({sc.frame_period_s!r})",
                          key="dt_s")
    n_frames = int(round(sc.duration_s / sc.frame_period_s))
    tgt = sc.targets
    n_t = len(tgt)
    t_x = np.array([t.along_m for t in tgt], dtype=np.float64)
    t_y = np.array([t.cross_m for t in tgt], dtype=np.float64)
    t_h = np.array([t.height_m for t in tgt], dtype=np.float64)
    t_f = np.array([t.footprint_m for t in tgt], dtype=np.float64)
    est_x = t_x + rng.normal(0.0, sc.prior_position_noise_m, n_t)  # lane coordinates
    est_y = t_y + rng.normal(0.0, sc.prior_position_noise_m, n_t)
    est_h = np.full(n_t, np.nan)
    omega = 2 * math.pi * sc.pitch_frequency_hz
    tilt = limits.clip(config.nominal_tilt_rad)
    command = tilt
    times = np.arange(n_frames) * sc.frame_period_s
    tilts, pitches = np.zeros(n_frames), np.zeros(n_frames)
    in_range = np.zeros((n_frames, n_t), dtype=bool)
    visible = np.zeros((n_frames, n_t), dtype=bool)
    joint = np.zeros(n_frames, dtype=bool)
    cmd_t: list[float] = []
    cmd_v: list[float] = []
    failures = 0
    for j, t in enumerate(times):
        pitch = sc.pitch_amplitude_rad * math.sin(omega * t + sc.pitch_phase_rad)
        rate = sc.pitch_amplitude_rad * omega * math.cos(omega * t + sc.pitch_phase_rad)
        rel_x = t_x - sc.speed_m_s * t
        geom = shadow_geometry(rel_x, t_y, t_h, t_f, sc.altitude_m)
        vis = whole_shadow_visible(geom, tilt_rad=tilt, pitch_rad=pitch, config=config)
        rng_ok, lo_t, hi_t = truth_in_range(geom, pitch_rad=pitch, config=score_config or config, limits=limits)
        tilts[j], pitches[j] = tilt, pitch
        visible[j], in_range[j] = vis, rng_ok
        joint[j] = (not rng_ok.any()) or bool(np.max(lo_t[rng_ok]) <= np.min(hi_t[rng_ok]))
        if j % every == 0:
            alt_meas = sc.altitude_m + rng.normal(0.0, sc.altitude_noise_m)
            pitch_meas = pitch + rng.normal(0.0, sc.pitch_noise_rad)
            shadows: list[TrackedShadow] = []
            for i in np.flatnonzero((rel_x > 0) & (rel_x <= sc.lookahead_m)):
                shadow: TrackedShadow | None = None
                measured = False
                if vis[i]:
                    truth = TrackedShadow(tgt[i].target_id, rel_x[i], t_y[i], t_h[i], t_f[i])
                    r_top, r_end, az = shadow_measurement(truth, altitude_m=sc.altitude_m, tilt_rad=tilt,
                                                          pitch_rad=pitch)
                    try:
                        shadow = shadow_from_measurement(
                            tgt[i].target_id, top_slant_m=r_top + rng.normal(0.0, sc.range_noise_m),
                            end_slant_m=r_end + rng.normal(0.0, sc.range_noise_m),
                            azimuth_rad=az + rng.normal(0.0, sc.azimuth_noise_rad), altitude_m=alt_meas,
                            tilt_rad=tilt, pitch_rad=pitch_meas, footprint_m=t_f[i])
                    except MeasurementError:
                        shadow = None
                    if shadow is not None and shadow.height_m is not None:
                        k = sc.tracker_gain
                        est_x[i] += k * (shadow.along_m + sc.speed_m_s * t - est_x[i])
                        est_y[i] += k * (shadow.cross_m - est_y[i])
                        est_h[i] = shadow.height_m if np.isnan(est_h[i]) else est_h[i] + k * (
                            shadow.height_m - est_h[i])
                        measured = True
                shadows.append(TrackedShadow(tgt[i].target_id, float(est_x[i] - sc.speed_m_s * t), float(est_y[i]),
                                             None if np.isnan(est_h[i]) else float(est_h[i]), t_f[i], measured))
            state = PitchState(altitude_m=alt_meas, vehicle_pitch_rad=pitch_meas,
                               pitch_rate_rad_s=rate + rng.normal(0.0, sc.pitch_noise_rad),
                               speed_m_s=sc.speed_m_s, current_tilt_rad=tilt)
            cmd = controller.step(state, shadows)
            failures += 0 if cmd.solver_ok else 1
            command = cmd.tilt_rad
            cmd_t.append(float(t))
            cmd_v.append(command)
        tilt = limits.clip(slew_toward(tilt, command, max_rate_rad_s=limits.max_rate_rad_s, dt_s=sc.frame_period_s))
    return PassResult(np.asarray(times, dtype=np.float64), tilts, pitches, np.array(cmd_v), in_range, visible,
                      joint, times >= sc.settle_s, failures, np.array(cmd_t))


def random_scenario(
    rng: np.random.Generator,
    *,
    duration_s: float = 90.0,
    speed_m_s: float = 0.5,
    altitude_range_m: tuple[float, float] = (0.5, 2.5),
    height_range_m: tuple[float, float] = (0.02, 0.40),
    spacing_range_m: tuple[float, float] = (14.0, 24.0),
    cross_max_m: float = 0.5,
    pitch_amplitude_max_rad: float = math.radians(3.0),
    pitch_frequency_range_hz: tuple[float, float] = (0.1, 0.3),
) -> PassScenario:
    """A random pass: altitude, pitch disturbance and a line of targets with random
    spacing along the lane, cross-track offsets and heights (seeded by ``rng``)."""
    alt = float(rng.uniform(*altitude_range_m))
    targets: list[SeabedTarget] = []
    x = float(rng.uniform(4.0, 12.0))
    end = speed_m_s * duration_s + 14.0
    while x < end:
        h = float(min(rng.uniform(*height_range_m), 0.8 * alt))
        targets.append(SeabedTarget(len(targets), x, float(rng.uniform(-cross_max_m, cross_max_m)), h))
        x += float(rng.uniform(*spacing_range_m))
    return PassScenario(
        altitude_m=alt, speed_m_s=speed_m_s,
        pitch_amplitude_rad=float(rng.uniform(0.5, 1.0) * pitch_amplitude_max_rad),
        pitch_frequency_hz=float(rng.uniform(*pitch_frequency_range_hz)),
        pitch_phase_rad=float(rng.uniform(0.0, 2 * math.pi)), targets=tuple(targets), duration_s=duration_s)
