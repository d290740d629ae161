"""The loop's prediction over its horizon: vehicle pitch, altitude and each shadow's
interval of admissible depressions; which targets can be served at all."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from perception.errors import GeometryError
from perception.geometry.shadow import clamp_height_m
from planner.pitch.aperture import (
    ShadowGeometry,
    depression_interval_rad,
    shadow_and_whole_intervals_rad,
    shadow_geometry,
)
from planner.pitch.config import MountLimits, PitchLoopConfig
from planner.pitch.types import (
    BEFORE_WINDOW_START,
    BEHIND,
    BEYOND_MOUNT_LIMITS,
    BEYOND_WINDOW_END,
    EXTENT_EXCEEDS_APERTURE,
    OUTSIDE_FAN,
    TOO_CLOSE,
    FloatArray,
    PitchState,
    TrackedShadow,
)


@dataclass(frozen=True)
class HorizonPrediction:
    """Predicted pitch, altitude and target geometry at the ends of the horizon's steps.

    ``pitch_rad`` and ``altitude_m`` have shape ``(N + 1,)`` (index 0 = now); the
    geometry arrays have shape ``(n_targets, N + 1)``. ``geometry`` uses the height
    estimates or the tall prior (aperture constraints), ``range_geometry`` the
    estimates or the short prior (range window check).
    """

    time_s: FloatArray
    pitch_rad: FloatArray
    altitude_m: FloatArray
    geometry: ShadowGeometry
    range_geometry: ShadowGeometry


def predict_pitch_rad(state: PitchState, config: PitchLoopConfig) -> FloatArray:
    """Pitch at ``t_k = k dt``, ``k = 0..N``: the caller's prediction, or the measured rate
    extrapolated with time constant ``pitch_rate_time_s`` (rad, shape ``(N + 1,)``)."""
    n = config.horizon_steps
    if state.predicted_pitch_rad is not None:
        if len(state.predicted_pitch_rad) != n:
            raise GeometryError(f"predicted_pitch_rad must hold {n} values, got {len(state.predicted_pitch_rad)}")
        return np.concatenate([[state.vehicle_pitch_rad], np.asarray(state.predicted_pitch_rad, dtype=np.float64)])
    t = np.arange(n + 1) * config.dt_s
    tau = config.pitch_rate_time_s
    return state.vehicle_pitch_rad + state.pitch_rate_rad_s * tau * (1.0 - np.exp(-t / tau))


def predict_horizon(state: PitchState, shadows: Sequence[TrackedShadow], config: PitchLoopConfig) -> HorizonPrediction:
    """The kinematic model: the vehicle advances along its heading at ``speed_m_s`` and
    climbs at ``climb_rate_m_s``; targets stay put on the seabed."""
    n = config.horizon_steps
    t = np.arange(n + 1) * config.dt_s
    alt = state.altitude_m + state.climb_rate_m_s * t
    if np.any(alt <= 0):
        raise GeometryError("the predicted altitude reaches the seabed within the horizon")
    along = np.array([[s.along_m] for s in shadows]).reshape(-1, 1) - state.speed_m_s * t
    cross = np.array([[s.cross_m] for s in shadows]).reshape(-1, 1)
    foot = np.array([[s.footprint_m] for s in shadows]).reshape(-1, 1)
    geoms = []
    for prior in (config.height_prior_m, config.height_min_m):
        height = np.array([[prior if s.height_m is None else s.height_m] for s in shadows]).reshape(-1, 1)
        height = clamp_height_m(height, alt.min())  # a height up to the altitude: clamp
        geoms.append(shadow_geometry(along, cross, height, foot, alt))
    return HorizonPrediction(np.asarray(t, dtype=np.float64), predict_pitch_rad(state, config),
                             np.asarray(alt, dtype=np.float64), geoms[0], geoms[1])


def serviceability(pred: HorizonPrediction, config: PitchLoopConfig, limits: MountLimits,
                    envelope_rad: float) -> tuple[FloatArray, FloatArray, NDArray[np.object_], NDArray[np.bool_],
                                                  FloatArray, NDArray[np.bool_]]:
    """Tilt bounds ``(L, U)`` per (target, step), the reason each is not served ('' if
    served), whether it is within the window and zone proper (not only the lead band), ``L``
    for the shadow alone (without the target's footprint), and whether it is within the
    window and the near band (``PitchLoopConfig.near_weight_factor``).

    ``L > U`` where the margins and the envelope leave no room but the bare aperture
    does: such a target is still served and the QP centres it. It is dropped only when
    no tilt within the mount's limits fits it even without margins (short height prior).
    """
    g, gr = pred.geometry, pred.range_geometry
    lead = config.zone_lead_m
    (lo, hi), (lo_s, _) = shadow_and_whole_intervals_rad(
        g, half_aperture_rad=config.elevation_aperture_rad / 2 - config.margin_rad)
    low_t = lo + pred.pitch_rad + envelope_rad
    up_t = hi + pred.pitch_rad - envelope_rad
    low_shadow = lo_s + pred.pitch_rad + envelope_rad
    lo0, hi0 = depression_interval_rad(gr, half_aperture_rad=config.elevation_aperture_rad / 2)
    w0, w1 = config.window_m
    zone_start = config.zone_start_m(pred.altitude_m)
    near_start = config.near_start_m(pred.altitude_m)
    reason = np.full(lo.shape, "", dtype=object)
    checks = [
        (hi0 < lo0, EXTENT_EXCEEDS_APERTURE),
        ((lo0 + pred.pitch_rad > limits.max_tilt_rad) | (hi0 + pred.pitch_rad < limits.min_tilt_rad),
         BEYOND_MOUNT_LIMITS),
        (g.top_along_m < near_start - lead, TOO_CLOSE),
        (g.near_slant_m < w0 - lead, BEFORE_WINDOW_START),
        (gr.end_slant_m > w1 + lead, BEYOND_WINDOW_END),
        (np.abs(g.bearing_rad) > config.fan_width_rad / 2, OUTSIDE_FAN),
        (g.top_along_m <= 0, BEHIND),
    ]
    for bad, why in checks:  # the last one that applies wins: the most basic reason
        reason[bad] = why
    window = (g.near_slant_m >= w0) & (g.end_slant_m <= w1)
    core = (g.top_along_m >= zone_start) & window
    near = (g.top_along_m >= near_start) & (g.top_along_m < zone_start) & window
    return low_t, up_t, reason, core, low_shadow, near


def search_band_rad(pred: HorizonPrediction, config: PitchLoopConfig) -> tuple[FloatArray, FloatArray] | None:
    """Depressions that keep the far end of the range window in view, rad, shape ``(N + 1,)``
    each (see ``PitchLoopConfig.search_weight_factor``); None when turned off.

    ``hi = asin(H / w1) + a/2 - m`` puts the seabed at the window's last slant range
    ``w1`` on the shallow edge less the margin; ``lo = asin(H / r) - (a/2 - m)`` with
    ``r = w1 (H - h) / H`` (``h`` the tall prior) puts the start of the shadow of a target
    whose shadow ends at ``w1`` on the steep edge; ``lo`` is capped at ``hi``. Where the
    window ends above the seabed (``w1 <= H``) the band is unbounded.
    """
    if config.search_weight_factor <= 0.0:
        return None
    alt = pred.altitude_m
    w1 = config.window_m[1]
    half = config.elevation_aperture_rad / 2 - config.margin_rad
    h = clamp_height_m(config.height_prior_m, alt)
    reach = w1 > alt
    with np.errstate(divide="ignore", invalid="ignore"):
        hi = np.where(reach, np.arcsin(np.minimum(1.0, alt / w1)) + half, np.inf)
        r_start = w1 * (alt - h) / alt
        lo = np.where(reach, np.arcsin(np.minimum(1.0, alt / r_start)) - half, -np.inf)
    return np.minimum(lo, hi), hi
