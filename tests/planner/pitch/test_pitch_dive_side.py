"""Tests of the pitch loop's dive-side pieces: shadow starts, footprints, the search band,
conflicts between targets, the mount model, the tilts a shadow can be held at."""

from __future__ import annotations

import dataclasses
import math
from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from benchmarks.pitch_kinematics import (
    whole_shadow_visible,
)
from planner.dryrun.shadow_view import shadow_visible_at_tilts
from planner.pitch.aperture import (
    depression_interval_rad,
    shadow_geometry,
)
from planner.pitch.config import MountLimits
from planner.pitch.control import (
    ShadowPitchLoop,
    footprint_from_highlight_m,
    merge_pieces,
)
from planner.pitch.qp import PitchLoop
from planner.pitch.types import (
    PitchCommand,
    PitchState,
    TrackedShadow,
)
from tests.planner.pitch.common import APERTURE, LIMITS, pitch_config

# --------------------------------------------------------------------------- dive-side pieces


def test_shadow_start_point_is_the_seabed_at_the_top_slant_range() -> None:
    g = shadow_geometry(3.0, 4.0, 0.3, 0.0, 1.2)
    r_top = math.sqrt(25.0 + 0.9**2)
    start = np.hypot(float(g.start_along_m), float(g.start_cross_m))
    assert math.hypot(start, 1.2) == pytest.approx(r_top, rel=1e-12)  # same slant, on the seabed
    assert float(g.start_cross_m) / float(g.start_along_m) == pytest.approx(4.0 / 3.0)  # same bearing
    assert start < 5.0  # nearer than the far foot


@settings(max_examples=80, deadline=None)
@given(along=st.floats(1.0, 10.0), height=st.floats(0.0, 0.4), foot=st.floats(0.0, 0.5), alt=st.floats(0.6, 2.5))
def test_footprint_only_tightens_the_interval(along: float, height: float, foot: float, alt: float) -> None:
    if height >= 0.9 * alt:
        return
    g = shadow_geometry(along, 0.2, height, foot, alt)
    lo, hi = depression_interval_rad(g, half_aperture_rad=APERTURE / 2)
    lo_s, hi_s = depression_interval_rad(g, half_aperture_rad=APERTURE / 2, include_base=False)
    assert float(lo) >= float(lo_s) - 1e-12 and float(hi) <= float(hi_s) + 1e-12
    if foot == 0.0:  # a post: its far foot lies between the shadow's start and end
        assert float(lo) == pytest.approx(float(lo_s), abs=1e-12)


def test_search_band_keeps_the_window_end_in_view() -> None:
    """With nothing tracked the beam's shallow edge (less the margin) sits on the seabed at
    the window's last range: a target entering the window is seen whole at once."""
    cfg = pitch_config(window_m=(0.7, 3.0), nominal_tilt_rad=math.radians(22.0), search_weight_factor=0.1,
                       height_prior_m=0.2, dt_s=0.2, horizon_steps=10)
    lp = PitchLoop(cfg, LIMITS)
    alt, pitch = 0.5, math.radians(1.0)
    state = PitchState(altitude_m=alt, vehicle_pitch_rad=pitch, speed_m_s=0.5, current_tilt_rad=math.radians(22.0))
    for _ in range(20):
        state = dataclasses.replace(state, current_tilt_rad=lp.step(state, []).tilt_rad)
    hi = math.asin(alt / 3.0) + APERTURE / 2 - cfg.margin_rad
    assert state.current_tilt_rad - pitch == pytest.approx(hi, abs=math.radians(0.05))
    # A target entering the window end: its whole shadow is in view at that tilt.
    h = 0.15
    r_top = 3.0 * (alt - h) / alt
    x = math.sqrt(r_top**2 - (alt - h) ** 2)
    g = shadow_geometry(np.array([x]), 0.0, h, 0.0, alt)
    assert bool(whole_shadow_visible(g, tilt_rad=state.current_tilt_rad, pitch_rad=pitch,
                                     config=dataclasses.replace(cfg, window_m=(0.7, 3.01)))[0])
    # Off by default: the plain loop goes to the nominal (test_no_targets_goes_to_nominal).
    assert pitch_config().search_weight_factor == 0.0


def test_search_band_yields_to_a_tracked_target() -> None:
    cfg = pitch_config(window_m=(0.7, 3.0), search_weight_factor=0.1, height_prior_m=0.2, dt_s=0.2)
    lp = PitchLoop(cfg, LIMITS)
    state = PitchState(altitude_m=0.5, vehicle_pitch_rad=0.0, speed_m_s=0.0, current_tilt_rad=math.radians(15.0))
    near = [TrackedShadow(1, 1.3, 0.0, 0.04, measured=True)]  # needs a steep beam
    for _ in range(15):
        cmd = lp.step(state, near)
        state = dataclasses.replace(state, current_tilt_rad=cmd.tilt_rad)
    (m,) = cmd.margins
    assert m.near_margin_rad >= cfg.margin_rad - 1e-6


def _settle(lp: PitchLoop, state: PitchState, shadows: list[TrackedShadow], steps: int = 15) -> PitchCommand:
    for _ in range(steps):
        cmd = lp.step(state, shadows)
        state = dataclasses.replace(state, current_tilt_rad=cmd.tilt_rad)
    return cmd


def test_in_a_true_conflict_the_nearer_target_yields() -> None:
    """No tilt shows both shadows (bare): the farther one keeps its margins, the nearer
    one (about to leave the tracking zone) gives way, instead of both being lost."""
    # The plain zone (2 altitudes): the zone that fits the aperture leaves no such pair in range.
    lp = PitchLoop(pitch_config(window_m=(0.7, 3.0), dt_s=0.2, zone_fits_aperture=False), LIMITS)
    state = PitchState(altitude_m=0.5, vehicle_pitch_rad=0.0, speed_m_s=0.0, current_tilt_rad=math.radians(18.0))
    near, far = TrackedShadow("near", 1.05, 0.0, 0.04, measured=True), TrackedShadow("far", 2.5, 0.0, 0.04,
                                                                                      measured=True)
    g = shadow_geometry(np.array([1.05, 2.5]), 0.0, 0.04, 0.0, 0.5)
    lo, hi = depression_interval_rad(g, half_aperture_rad=APERTURE / 2, include_base=False)
    assert lo[0] > hi[1]  # the premise: no common tilt
    cmd = _settle(lp, state, [near, far])
    margins = {m.target_id: min(m.far_margin_rad, m.near_margin_rad) for m in cmd.margins}
    assert margins["far"] >= lp.config.margin_rad - 1e-6
    assert margins["near"] < 0


def test_a_guess_never_displaces_a_measured_shadow() -> None:
    """A remembered track with no height (tall prior) farther ahead conflicts with a
    measured one: the measured shadow keeps its margins."""
    cfg = pitch_config(window_m=(0.7, 3.0), dt_s=0.2, height_prior_m=0.2, zone_fits_aperture=False)
    lp = PitchLoop(cfg, LIMITS)
    state = PitchState(altitude_m=0.5, vehicle_pitch_rad=0.0, speed_m_s=0.0, current_tilt_rad=math.radians(20.0))
    seen = TrackedShadow("seen", 1.1, 0.0, 0.04, measured=True)
    guess = TrackedShadow("guess", 1.9, 0.0, None, measured=False)
    cmd = _settle(lp, state, [seen, guess])
    margins = {m.target_id: min(m.far_margin_rad, m.near_margin_rad) for m in cmd.margins}
    assert margins["seen"] >= cfg.margin_rad - 1e-6
    assert margins["guess"] < 0


def test_a_footprint_gives_way_to_another_shadow() -> None:
    """The footprint (near part of a target) is kept in the beam only where it costs no
    other shadow: here it would, so both shadows stay whole."""
    cfg = pitch_config(window_m=(0.7, 3.0), dt_s=0.2)
    lp = PitchLoop(cfg, LIMITS)
    state = PitchState(altitude_m=0.5, vehicle_pitch_rad=0.0, speed_m_s=0.0, current_tilt_rad=math.radians(16.0))
    wide = TrackedShadow("wide", 1.6, 0.0, 0.04, footprint_m=0.4, measured=True)
    far = TrackedShadow("far", 2.45, 0.0, 0.03, measured=True)
    cmd = _settle(lp, state, [wide, far])
    g = shadow_geometry(np.array([1.6, 2.45]), 0.0, np.array([0.04, 0.03]), 0.0, 0.5)
    vis = whole_shadow_visible(g, tilt_rad=cmd.tilt_rad, pitch_rad=0.0, config=cfg)
    assert vis.all()
    alone = _settle(PitchLoop(cfg, LIMITS), state, [wide])
    (m,) = alone.margins  # alone, the footprint is kept whole too
    assert m.near_margin_rad >= cfg.margin_rad - 1e-6


def _adapter(**kw: object) -> ShadowPitchLoop:
    """The executor's adapter with no passes (only its own bookkeeping is exercised)."""
    settings = SimpleNamespace(site=SimpleNamespace(target_height_min_m=0.02, target_height_max_m=0.2),
                               sonar=SimpleNamespace())
    return ShadowPitchLoop(SimpleNamespace(passes=()), settings, **kw)  # type: ignore[arg-type]


def test_mount_model_slews_at_the_rate_limit() -> None:
    loop = _adapter(mount=MountLimits(0.0, 1.0, 0.2))
    assert math.isnan(loop.mount_tilt_at(0.0))
    loop.record_command(0.0, 0.1)
    loop.record_command(1.0, 0.5)  # 0.4 rad away at 0.2 rad/s: 2 s
    loop.record_command(2.0, 0.3)  # asked back before it got there
    assert loop.mount_tilt_at(0.5) == pytest.approx(0.1)
    assert loop.mount_tilt_at(1.5) == pytest.approx(0.2)
    assert loop.mount_tilt_at(2.0) == pytest.approx(0.3)
    assert loop.mount_tilt_at(3.0) == pytest.approx(0.3)


def test_footprint_from_the_highlight() -> None:
    # Top edge at slant 2.5 m, nearest echo 0.1 m nearer, altitude 1.5 m: ground 2 m, 0.1 * 2.5 / 2.
    assert footprint_from_highlight_m(2.5, 2.4, 1.5) == pytest.approx(0.125)
    assert footprint_from_highlight_m(2.5, 2.6, 1.5) == 0.0
    assert footprint_from_highlight_m(2.5, float("nan"), 1.5) == 0.0
    assert footprint_from_highlight_m(3.0, 1.0, 1.5, max_m=0.5) == 0.5


def test_pieces_of_one_target_merge_into_one_covering_shadow() -> None:
    pieces = [TrackedShadow(1, 2.00, 0.00, 0.10, 0.05, True), TrackedShadow(2, 2.10, 0.05, 0.12, 0.0, True),
              TrackedShadow(3, 1.95, -0.05, None, 0.0, True), TrackedShadow(4, 3.5, 0.0, 0.03, 0.0, True)]
    merged = merge_pieces(pieces, radius_m=0.15)
    assert [s.target_id for s in merged] == [2, 4]
    first = merged[0]
    assert (first.along_m, first.cross_m, first.height_m) == (2.10, 0.05, 0.12)
    assert first.footprint_m == pytest.approx(0.15)  # reaches piece 3's near foot (and piece 1's)
    assert merge_pieces(pieces[:1], radius_m=0.15) == pieces[:1]


@settings(max_examples=40, deadline=None)
@given(alt=st.floats(0.4, 2.0), near=st.floats(1.0, 5.0), length=st.floats(0.05, 1.0),
       pitch=st.floats(-0.05, 0.05))
def test_truth_visibility_over_tilts_matches_the_band(alt: float, near: float, length: float, pitch: float) -> None:
    """The scorer's per-tilt check on the central beam (no roll): the shadow is in view
    exactly for depressions within half the aperture of both ends' depressions."""
    start, end = math.hypot(near, alt), math.hypot(near + length, alt)
    tilts = np.radians(np.arange(0.0, 80.0, 0.25))
    vis = shadow_visible_at_tilts(np.array([0.0]), np.array([start]), np.array([end]), altitude_m=alt,
                                  pitch_rad=pitch, roll_rad=0.0, tilt_rad=tilts, elevation_aperture_rad=APERTURE)
    d_start, d_end = math.asin(alt / start), math.asin(alt / end)
    dep = tilts - pitch
    expect = (dep >= d_start - APERTURE / 2) & (dep <= d_end + APERTURE / 2)
    edge = (np.abs(dep - (d_start - APERTURE / 2)) < 1e-9) | (np.abs(dep - (d_end + APERTURE / 2)) < 1e-9)
    assert np.array_equal(vis[~edge], expect[~edge])


@settings(max_examples=60, deadline=None)
@given(alt=st.floats(0.4, 3.0), near=st.floats(0.5, 6.0), length=st.floats(0.02, 2.0),
       pitch=st.floats(-0.08, 0.08), roll=st.floats(-0.08, 0.08), az0=st.floats(-0.25, 0.2),
       n_beams=st.integers(1, 12), window_end=st.floats(2.0, 9.0))
def test_holdable_tilts_are_those_of_the_whole_grid(alt, near, length, pitch, roll, az0, n_beams, window_end):
    """The scorer computes the holdable tilts only near the shadow (:func:`tilts_near`); over
    the whole mount range the answer is the same: no tilt it skips shows the shadow."""
    from planner.dryrun.shadow_view import holdable_tilts

    beams = az0 + np.arange(n_beams) * math.radians(0.25)
    start = np.full(n_beams, math.hypot(near, alt))
    end = np.full(n_beams, math.hypot(near + length, alt))
    grid = np.arange(0.0, math.radians(60.0) + 1e-9, math.radians(0.1))
    narrow = APERTURE - 2.0 * math.radians(2.25)
    full = shadow_visible_at_tilts(beams, start, end, altitude_m=alt, pitch_rad=pitch, roll_rad=roll, tilt_rad=grid,
                                   elevation_aperture_rad=narrow) & shadow_visible_at_tilts(
        beams, np.full(n_beams, window_end), np.full(n_beams, window_end), altitude_m=alt, pitch_rad=pitch,
        roll_rad=roll, tilt_rad=grid, elevation_aperture_rad=narrow)
    got = holdable_tilts(beams, start, end, altitude_m=alt, pitch_rad=pitch, roll_rad=roll, tilt_grid=grid,
                         aperture_rad=narrow, window_end_m=window_end)
    assert np.array_equal(got, full)
