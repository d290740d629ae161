"""Which shadows a step serves, and how the nearer one yields when no tilt shows them all."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from planner.pitch.aperture import ShadowGeometry, depression_interval_rad, shadow_margins_rad
from planner.pitch.config import MountLimits, PitchLoopConfig
from planner.pitch.prediction import HorizonPrediction, predict_horizon, search_band_rad, serviceability
from planner.pitch.types import TOO_MANY_TARGETS, DroppedShadow, FloatArray, PitchState, ShadowMargin, TrackedShadow


def select_shadows(state: PitchState, shadows: Sequence[TrackedShadow], cfg: PitchLoopConfig, lim: MountLimits,
            envelope_rad: float) -> tuple[list[tuple[int, bool]], list[DroppedShadow], FloatArray, FloatArray,
                                          FloatArray, HorizonPrediction]:
    """Targets to serve (index, served at step 1), those dropped, tilt bounds, slack weight
    factors (1 within range proper, ``near_weight_factor`` in the near band,
    ``lead_weight_factor`` in the lead band), prediction."""
    pred = predict_horizon(state, shadows, cfg)
    if not shadows:
        empty = np.zeros((0, cfg.horizon_steps + 1))
        return [], [], empty, empty, empty, pred
    low, up, reason, core, low_shadow, near = serviceability(pred, cfg, lim, envelope_rad)
    ok = reason == ""
    core = core & ok
    near = near & ok
    low = np.where(ok, low, np.nan)
    low_shadow = np.where(ok, low_shadow, np.nan)
    up = np.where(ok, up, np.nan)
    # The mount reaches each command quickly and holds it through the step while the
    # target moves: tilt_k must suit the geometry at both ends of step k (at the ends
    # where the target is served: it may enter or leave during the step).
    ok[:, 1:] = ok[:, 1:] | ok[:, :-1]
    core[:, 1:] = core[:, 1:] | core[:, :-1]
    near[:, 1:] = (near[:, 1:] | near[:, :-1]) & ~core[:, 1:]
    near_factor = max(cfg.near_weight_factor, cfg.lead_weight_factor)
    factor = np.where(core, 1.0, np.where(near, near_factor, cfg.lead_weight_factor))
    w = min(max(cfg.hold_start_s / cfg.dt_s, 0.0), 1.0)
    low[:, 1:] = np.fmax(low[:, 1:], held_from(low, w))
    low_shadow[:, 1:] = np.fmax(low_shadow[:, 1:], held_from(low_shadow, w))
    up[:, 1:] = np.fmin(up[:, 1:], held_from(up, w))
    dropped: list[DroppedShadow] = []
    candidates: list[tuple[float, int]] = []
    for i, s in enumerate(shadows):
        if ok[i, 1:].any():
            candidates.append((float(pred.geometry.top_along_m[i, 0]), i))
        else:
            dropped.append(DroppedShadow(s.target_id, str(reason[i, 1])))
    candidates.sort()
    served = [(i, bool(ok[i, 1])) for _, i in candidates[: cfg.max_targets]]
    dropped += [DroppedShadow(shadows[i].target_id, TOO_MANY_TARGETS) for _, i in candidates[cfg.max_targets:]]
    firm = np.array([s.measured or s.height_m is not None for s in shadows])
    sides = None
    watch = None
    if cfg.near_weight_factor > 0.0 and cfg.zone_fits_aperture:
        nearer = ok & (pred.geometry.top_along_m < cfg.zone_start_m(pred.altitude_m))
        sides = (ok & ~nearer, nearer)
        search = search_band_rad(pred, cfg)
        if search is not None:  # the window's far end in the bare aperture, as tilts
            watch = (search[0] - cfg.margin_rad + pred.pitch_rad, search[1] + cfg.margin_rad + pred.pitch_rad)
    yield_in_conflicts(pred, [i for i, _ in served], core & ok, factor, cfg, firm, sides, watch)
    footprints_yield(low, low_shadow, up, factor, [i for i, _ in served])
    return served, dropped, low, up, factor, pred


def footprints_yield(low: FloatArray, low_shadow: FloatArray, up: FloatArray, factor: FloatArray,
                      idx: list[int]) -> None:
    """A target's footprint (its near part, nearer than its shadow) is kept in the beam
    only where that costs no other fully weighted target's shadow: where its bound with
    the footprint lies beyond another's opposite bound, its shadow's own bound is used
    (``low`` is changed in place; arrays of shape ``(n_targets, N + 1)``)."""
    if len(idx) < 2:
        return
    for k in range(1, low.shape[1]):
        active = [i for i in idx if factor[i, k] >= 1.0 and np.isfinite(low[i, k])]
        for i in active:
            others = [float(up[j, k]) for j in active if j != i]
            if others and low[i, k] > min(others):
                low[i, k] = low_shadow[i, k]


def held_from(bound: FloatArray, fraction: float) -> FloatArray:
    """A bound at the first instant each step's tilt acts on a frame: ``fraction`` of the
    way from the step's start to its end (linear), shape ``(n, N)`` from ``(n, N + 1)``;
    NaN where the bound is NaN at the start (not served then)."""
    start, end = bound[:, :-1], bound[:, 1:]
    return np.where(np.isnan(start), np.nan, start + fraction * np.nan_to_num(end - start))


def yield_in_conflicts(pred: HorizonPrediction, idx: list[int], core: NDArray[np.bool_], factor: FloatArray,
                        cfg: PitchLoopConfig, firm: NDArray[np.bool_],
                        sides: tuple[NDArray[np.bool_], NDArray[np.bool_]] | None = None,
                        watch: tuple[FloatArray, FloatArray] | None = None) -> None:
    """Where no tilt shows several targets in range whole at once, the nearer ones yield.

    Per step, the targets within range proper are taken from the farthest to the nearest;
    one whose bare shadow interval (no margin, no envelope, no footprint) misses the
    common interval of those taken before it, at both ends of the step, gets
    ``lead_weight_factor`` (``factor`` is changed in place, shape ``(n_targets, N + 1)``).
    Without this the QP would split the violation and lose both; and the nearer target is
    the one about to leave the tracking zone, seen whole on its way in, while the farther
    one stays in range longer (keeping the nearer would cost the farther one as many
    frames plus the slew back to it). Targets seen in this frame or with a height come
    before those known only from memory with no height (``firm``, shape ``(n_targets,)``):
    a guess with the tall height prior never displaces a shadow actually seen.

    With the near band on, ``sides = (farther, nearer)`` (served targets at or beyond the
    zone's start, and nearer than it; each ``(n_targets, N + 1)``): a second pass takes
    every farther target (in range proper or only in the lead band: its shadow may well
    be in range while the tall prior says otherwise) before the nearer ones, and a nearer
    one that misses them (here with the loop's margin, ``zone_margin_rad``, at both
    aperture edges) gets ``lead_weight_factor * near_weight_factor``, below any farther
    target's weight: the near band never takes the beam, or its margin, from the zone.
    With ``watch`` (tilt bounds per step, shape ``(N + 1,)`` each: the search band widened
    to the bare aperture) the farther side starts from it: a nearer target is also given
    up where following it would take the window's far end out of the aperture, so that a
    target entering the window, not tracked yet, is still seen (and then tracked).
    """
    if len(idx) < (1 if watch is not None else 2):
        return
    lo, hi = depression_interval_rad(pred.geometry, half_aperture_rad=cfg.elevation_aperture_rad / 2,
                                     include_base=False)
    lo = lo + pred.pitch_rad
    hi = hi + pred.pitch_rad
    w = min(max(cfg.hold_start_s / cfg.dt_s, 0.0), 1.0)
    bare = ((held_from(lo, w), held_from(hi, w), -1), (lo, hi, 0))
    along = pred.geometry.top_along_m

    def misfits(order: list[int], k: int, ends: tuple = bare, watched: bool = False) -> set[int]:
        """Targets of ``order`` (taken in turn) that miss the common interval of those
        before them (and of ``watch`` when ``watched``) at both ends of step ``k``: a
        conflict only when there is one at both."""
        yielding: set[int] | None = None
        for lo_j, hi_j, shift in ends:
            common_lo, common_hi = -math.inf, math.inf
            if watched and watch is not None:
                common_lo, common_hi = float(watch[0][k + shift]), float(watch[1][k + shift])
            here: set[int] = set()
            for i in order:
                new_lo, new_hi = max(common_lo, float(lo_j[i, k + shift])), min(common_hi, float(hi_j[i, k + shift]))
                if new_lo <= new_hi:
                    common_lo, common_hi = new_lo, new_hi
                else:
                    here.add(i)
            yielding = here if yielding is None else yielding & here
        return yielding or set()

    near_yield = cfg.lead_weight_factor * cfg.near_weight_factor
    if sides is not None:  # the near band must not cost a farther target even its margin
        lo_m, hi_m = depression_interval_rad(pred.geometry, half_aperture_rad=cfg.elevation_aperture_rad / 2
                                             - cfg.zone_margin_rad, include_base=False)
        lo_m, hi_m = lo_m + pred.pitch_rad, hi_m + pred.pitch_rad
        with_margin = ((held_from(lo_m, w), held_from(hi_m, w), -1), (lo_m, hi_m, 0))
    for k in range(1, lo.shape[1]):
        def key(i: int, k: int = k) -> tuple[bool, float]:
            return (not firm[i], -float(along[i, k]))

        for i in misfits(sorted((i for i in idx if core[i, k]), key=key), k):
            factor[i, k] = min(factor[i, k], cfg.lead_weight_factor)
        if sides is not None:
            nearer = sorted((i for i in idx if sides[1][i, k]), key=key)
            if nearer:
                farther = sorted((i for i in idx if sides[0][i, k]), key=key)
                for i in misfits(farther + nearer, k, with_margin, watched=True) & set(nearer):
                    factor[i, k] = min(factor[i, k], near_yield)


def served_margins(pred: HorizonPrediction, shadows: Sequence[TrackedShadow], served: list[tuple[int, bool]],
             tilt_rad: float, cfg: PitchLoopConfig) -> tuple[ShadowMargin, ...]:
    if not served:
        return ()
    idx = [i for i, _ in served]
    g = pred.geometry
    sub = ShadowGeometry(*(np.asarray(getattr(g, f))[idx, 1] for f in ShadowGeometry.__dataclass_fields__))
    far, near = shadow_margins_rad(sub, depression_rad=tilt_rad - pred.pitch_rad[1],
                                   elevation_aperture_rad=cfg.elevation_aperture_rad)
    w0, w1 = cfg.window_m
    return tuple(
        ShadowMargin(shadows[i].target_id, float(far[j]), float(near[j]), float(w1 - sub.end_slant_m[j]),
                     float(sub.near_slant_m[j] - w0), now)
        for j, (i, now) in enumerate(served)
    )
