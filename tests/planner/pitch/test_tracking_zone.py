"""Tests of the tracking zone: known answers, bad input, its fit in the aperture, and the
targets it holds."""

from __future__ import annotations

import dataclasses
import math
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from perception.errors import GeometryError
from planner.pitch.aperture import (
    depression_interval_rad,
    shadow_geometry,
    tracking_zone_start_m,
)
from planner.pitch.baseline import NominalTilt
from planner.pitch.control import (
    ZoneCentredTilt,
    describe_zone,
    loop_config,
)
from planner.pitch.qp import PitchLoop
from planner.pitch.types import (
    TOO_CLOSE,
    PitchState,
    TrackedShadow,
)
from tests.planner.pitch.common import APERTURE, LIMITS, pitch_config

# --------------------------------------------------------------------------- tracking zone


def _zone_span_rad(alt: float, start: float, window_end: float, height: float) -> float:
    """Depression span, rad: shadow start of a ``height`` target at ``start`` to the window's end
    (a shadow starting under the sonar, nearer than the altitude, is at 90 deg)."""
    steep = math.asin(min(1.0, alt / math.hypot(start, alt - height)))
    return steep - math.asin(alt / window_end)


def test_tracking_zone_known_answers() -> None:
    """0.5 m altitude, window end 3 m, 14 deg aperture, 0.75 deg margins, the seabed alone:
    the window's end is at asin(0.5/3) = 9.594 deg of depression, so the zone may reach
    9.594 + 12.5 = 22.094 deg, the seabed 0.5 / tan(22.094 deg) = 1.2317 m ahead (2.46
    altitudes, beyond the 2-altitude limit)."""
    kw: dict[str, Any] = {"window_end_m": 3.0, "elevation_aperture_rad": APERTURE,
                          "margin_rad": math.radians(0.75)}
    assert float(tracking_zone_start_m(0.5, **kw)) == pytest.approx(1.23172, abs=1e-4)
    # A 20 cm target's shadow starts nearer than its top edge (at the top edge's slant range):
    # hypot(x0, 0.3) = 0.5 / sin(22.094 deg) = 1.32939 m, so x0 = 1.29509 m.
    assert float(tracking_zone_start_m(0.5, height_m=0.2, **kw)) == pytest.approx(1.29509, abs=1e-4)
    # At 1 m the window's end is at 19.47 deg; the fit needs only 1.41 m: 2 altitudes win.
    assert float(tracking_zone_start_m(1.0, **kw)) == pytest.approx(2.0)
    # The plain zone, and a window that never reaches the seabed.
    assert float(tracking_zone_start_m(0.5, fit_aperture=False, **kw)) == pytest.approx(1.0)
    assert math.isinf(float(tracking_zone_start_m(3.5, **kw)))
    # Vectorised over altitudes (the loop's horizon).
    both = tracking_zone_start_m(np.array([0.5, 1.0]), **kw)
    assert both.shape == (2,) and both[1] == pytest.approx(2.0)


def test_tracking_zone_rejects_bad_input() -> None:
    kw: dict[str, Any] = {"window_end_m": 3.0, "elevation_aperture_rad": APERTURE}
    with pytest.raises(GeometryError, match="altitude_m"):
        tracking_zone_start_m(0.0, margin_rad=0.01, **kw)
    with pytest.raises(GeometryError, match="margin_rad"):
        tracking_zone_start_m(0.5, margin_rad=APERTURE / 2, **kw)
    with pytest.raises(GeometryError, match="height_m"):
        tracking_zone_start_m(0.5, margin_rad=0.01, height_m=math.nan, **kw)


@settings(max_examples=150, deadline=None)
@given(alt=st.floats(0.2, 3.0), window_end=st.floats(1.0, 15.0), aperture_deg=st.floats(6.0, 30.0),
       margin_frac=st.floats(0.0, 0.45), ratio=st.floats(0.0, 4.0), height_frac=st.floats(0.0, 0.9))
def test_tracking_zone_fits_the_aperture(alt: float, window_end: float, aperture_deg: float, margin_frac: float,
                                         ratio: float, height_frac: float) -> None:
    """The zone starts at least ``ratio`` altitudes ahead, and from its start to the window's
    end it spans at most the aperture less both margins; where the fit binds, exactly that
    (the zone is as long as it can be)."""
    if window_end <= alt * 1.01:
        return
    aperture = math.radians(aperture_deg)
    margin = margin_frac * aperture
    height = height_frac * alt
    start = float(tracking_zone_start_m(alt, window_end_m=window_end, elevation_aperture_rad=aperture,
                                        margin_rad=margin, min_over_altitude=ratio, height_m=height))
    assert start >= ratio * alt - 1e-12
    span = _zone_span_rad(alt, start, window_end, height)
    assert span <= aperture - 2 * margin + 1e-9
    if start > ratio * alt + 1e-9:
        assert span == pytest.approx(aperture - 2 * margin, abs=1e-9)


def test_config_zone_uses_the_loop_margin_and_the_tall_prior() -> None:
    """The loop's zone: margin plus the pitch envelope over one step at each edge, the
    tall height prior; without the near band a target between 2 altitudes and the zone
    start is too close (with it, see the near-band tests, it is served)."""
    cfg = pitch_config(window_m=(0.7, 3.0), dt_s=0.2, height_prior_m=0.2, near_weight_factor=0.0)
    assert cfg.zone_margin_rad == pytest.approx(cfg.margin_rad + 0.5 * cfg.pitch_accel_max_rad_s2 * 0.04)
    start = float(cfg.zone_start_m(0.5))
    want = float(tracking_zone_start_m(0.5, window_end_m=3.0, elevation_aperture_rad=cfg.elevation_aperture_rad,
                                       margin_rad=cfg.zone_margin_rad, height_m=0.2))
    assert start == pytest.approx(want) and start > 1.0
    assert _zone_span_rad(0.5, start, 3.0, 0.2) == pytest.approx(cfg.elevation_aperture_rad - 2 * cfg.zone_margin_rad)
    lp = PitchLoop(cfg, LIMITS)
    state = PitchState(altitude_m=0.5, vehicle_pitch_rad=0.0, speed_m_s=0.0, current_tilt_rad=math.radians(18.0))
    inside = TrackedShadow("inside", start + 0.05, 0.0, 0.04, measured=True)
    gap = TrackedShadow("gap", 1.0 + 0.5 * (start - 1.0 - cfg.zone_lead_m), 0.0, 0.04, measured=True)
    assert 1.0 < gap.along_m < start - cfg.zone_lead_m  # the premise: 2 altitudes < it < zone start - lead
    cmd = lp.step(state, [inside, gap])
    assert {d.target_id: d.reason for d in cmd.dropped} == {"gap": TOO_CLOSE}
    assert [m.target_id for m in cmd.margins] == ["inside"]
    # Over the plain zone the same target is served, and so it is in the near band.
    plain = PitchLoop(dataclasses.replace(cfg, zone_fits_aperture=False), LIMITS)
    assert {m.target_id for m in plain.step(state, [inside, gap]).margins} == {"inside", "gap"}
    banded = PitchLoop(dataclasses.replace(cfg, near_weight_factor=0.25), LIMITS)
    assert float(banded.config.near_start_m(0.5)) == pytest.approx(1.0)  # 2 altitudes
    assert {m.target_id for m in banded.step(state, [inside, gap]).margins} == {"inside", "gap"}
    assert not banded.step(state, [inside, gap]).dropped


def _settle(lp: PitchLoop, state: PitchState, shadows: list[TrackedShadow], steps: int = 10):
    for _ in range(steps):
        cmd = lp.step(state, shadows)
        state = dataclasses.replace(state, current_tilt_rad=cmd.tilt_rad)
    return cmd


def test_near_band_target_is_followed_when_it_costs_nothing() -> None:
    """Alone, a target nearer than the fitted zone (but beyond 2 altitudes) keeps its whole
    shadow in view with the band on; with the band off it is dropped and the beam stays
    at the nominal tilt, which (here) cuts its shadow."""
    cfg = pitch_config(window_m=(0.7, 3.0), dt_s=0.2, height_prior_m=0.2, nominal_tilt_rad=math.radians(12.0),
                       zone_lead_m=0.1)
    start = float(cfg.zone_start_m(0.5))
    near = TrackedShadow("near", 1.1, 0.0, 0.05, measured=True)
    assert 1.0 < near.along_m < start - cfg.zone_lead_m
    state = PitchState(altitude_m=0.5, vehicle_pitch_rad=0.0, speed_m_s=0.0, current_tilt_rad=math.radians(12.0))
    on = _settle(PitchLoop(cfg, LIMITS), state, [near])
    assert [m.target_id for m in on.margins] == ["near"] and on.margins[0].inside
    off_cfg = dataclasses.replace(cfg, near_weight_factor=0.0)
    off = _settle(PitchLoop(off_cfg, LIMITS), state, [near])
    assert [d.reason for d in off.dropped] == [TOO_CLOSE]
    assert off.tilt_rad == pytest.approx(math.radians(12.0), abs=1e-3)
    seen_off = NominalTilt(dataclasses.replace(off_cfg, zone_fits_aperture=False), LIMITS).step(
        dataclasses.replace(state, current_tilt_rad=off.tilt_rad), [near])
    assert not seen_off.margins[0].inside  # the tilt that serves the zone cuts the near shadow


def test_near_band_target_yields_to_a_target_in_the_zone() -> None:
    """In a conflict (no tilt shows both), the near-band target gives way: the target in
    the fitted zone keeps its full margin."""
    cfg = pitch_config(window_m=(0.7, 4.0), dt_s=0.2, height_prior_m=0.2)
    start = float(cfg.zone_start_m(0.5))
    far = TrackedShadow("far", 3.5, 0.0, 0.05, measured=True)
    near = TrackedShadow("near", 1.02, 0.0, 0.05, measured=True)
    assert far.along_m > start and 1.0 < near.along_m < start
    state = PitchState(altitude_m=0.5, vehicle_pitch_rad=0.0, speed_m_s=0.0, current_tilt_rad=math.radians(15.0))
    cmd = _settle(PitchLoop(cfg, LIMITS), state, [far, near])
    margin = {m.target_id: min(m.far_margin_rad, m.near_margin_rad) for m in cmd.margins}
    assert set(margin) == {"far", "near"}
    assert margin["near"] < 0.0  # the premise: they conflict
    assert margin["far"] >= cfg.margin_rad - 1e-6


def test_targets_in_the_fitted_zone_never_conflict() -> None:
    """Any two short targets in the fitted zone (level, on the axis): one tilt shows both
    shadows with the loop's margins (their intervals of depression intersect)."""
    cfg = pitch_config(window_m=(0.7, 3.0), dt_s=0.2, height_prior_m=0.2)
    alt = 0.5
    start = float(cfg.zone_start_m(alt))
    half = cfg.elevation_aperture_rad / 2 - cfg.zone_margin_rad
    along = np.linspace(start, 2.9, 40)
    for height in (0.02, 0.1, 0.2):
        g = shadow_geometry(along, 0.0, height, 0.0, alt)
        ok = g.end_slant_m <= 3.0
        lo, hi = depression_interval_rad(g, half_aperture_rad=half, include_base=False)
        assert ok.sum() >= 5
        assert float(np.max(lo[ok])) <= float(np.min(hi[ok])) + 1e-9


def _dive_settings() -> SimpleNamespace:
    return SimpleNamespace(site=SimpleNamespace(target_height_min_m=0.02, target_height_max_m=0.2),
                           sonar=SimpleNamespace(elevation_aperture_rad=APERTURE, fan_width_rad=math.radians(30.0),
                                                 window_start_m=0.7, window_end_m=3.0))


def test_zone_centred_tilt_and_zone_description() -> None:
    """The dives' zone at 0.5 m (window end 3 m, margin 0.75 + 0.24 deg, 20 cm prior):
    D = 9.594 + 14 - 1.98 = 21.614 deg, hypot(x0, 0.3) = 0.5 / sin D = 1.35744 m, so x0 =
    1.3239 m; the fixed baseline points the beam axis at its middle in depression."""
    settings_ = _dive_settings()
    pass_ = SimpleNamespace(name="p1", altitude_m=0.5, tilt_rad=math.radians(12.0))
    fixed = ZoneCentredTilt(SimpleNamespace(passes=(pass_,)), settings_)  # type: ignore[arg-type]
    zone = fixed.tracking_zone(pass_)  # type: ignore[arg-type]
    assert zone["start_m"] == pytest.approx(1.3239, abs=1e-4)
    assert zone["min_start_m"] == pytest.approx(1.0)
    assert zone["margin_deg"] == pytest.approx(0.75 + 0.5 * 12.0 * 0.2**2)  # deg: 0.5 a dt^2, a = 12 deg/s^2
    assert zone["depression_span_deg"] == pytest.approx(14.0 - 2 * zone["margin_deg"], abs=1e-9)
    mid = 0.5 * (math.asin(0.5 / 3.0) + math.atan2(0.5, zone["start_m"]))
    tilt, margin = fixed.tilt_command(now_s=0.0, pass_=pass_, onboard=None, current_tilt_rad=0.0,  # type: ignore[arg-type]
                                      speed_m_s=0.5)
    assert tilt == pytest.approx(mid) and math.degrees(mid) == pytest.approx(zone["centre_depression_deg"])
    assert math.isnan(margin)
    # The loop's zone for the same pass is the same zone.
    loop_zone = describe_zone(loop_config(settings_, nominal_tilt_rad=pass_.tilt_rad), 0.5)  # type: ignore[arg-type]
    assert loop_zone == zone


def test_near_band_target_yields_to_a_far_target_the_prior_puts_past_the_window() -> None:
    """A far target seen without a height yet: the tall prior puts its shadow end past the
    window (lead band only, weighed little), though its true shadow is in range. A target
    in the near band that conflicts with it still gives way, so the beam stays on it."""
    cfg = pitch_config(window_m=(0.7, 4.0), dt_s=0.2, height_prior_m=0.4)
    far = TrackedShadow("far", 3.3, 0.0, None, measured=True)  # 3.3 * 0.5 / 0.1 = 16.5 m with the prior
    near = TrackedShadow("near", 1.02, 0.0, 0.05, measured=True)
    assert far.along_m > float(cfg.zone_start_m(0.5)) and 1.0 < near.along_m < float(cfg.zone_start_m(0.5))
    state = PitchState(altitude_m=0.5, vehicle_pitch_rad=0.0, speed_m_s=0.0, current_tilt_rad=math.radians(15.0))
    cmd = _settle(PitchLoop(cfg, LIMITS), state, [far, near])
    # judge the far target's shadow with its true height (5 cm): seen whole
    true_far = dataclasses.replace(far, height_m=0.05)
    judged = NominalTilt(dataclasses.replace(cfg, nominal_tilt_rad=cmd.tilt_rad), LIMITS).step(
        dataclasses.replace(state, current_tilt_rad=cmd.tilt_rad), [true_far, near])
    margin = {m.target_id: min(m.far_margin_rad, m.near_margin_rad) for m in judged.margins}
    assert margin["near"] < 0.0  # the premise: they conflict
    assert margin["far"] >= 0.0


def test_near_band_gives_way_to_the_watch_on_the_window_end() -> None:
    """With the search band on (the dives' setting), a lone near-band target is followed
    only as far as the window's far end stays in the bare aperture: an untracked target
    entering the window there is still seen. Without the search band it is followed."""
    base = pitch_config(window_m=(0.7, 4.0), dt_s=0.2, height_prior_m=0.2, nominal_tilt_rad=math.radians(12.0),
                        zone_lead_m=0.1)
    near = TrackedShadow("near", 1.02, 0.0, 0.05, measured=True)
    assert 1.0 < near.along_m < float(base.zone_start_m(0.5)) - base.zone_lead_m
    state = PitchState(altitude_m=0.5, vehicle_pitch_rad=0.0, speed_m_s=0.0, current_tilt_rad=math.radians(12.0))
    far_end_limit = math.asin(0.5 / 4.0) + base.elevation_aperture_rad / 2  # axis depression, bare aperture
    followed = _settle(PitchLoop(base, LIMITS), state, [near], steps=15)
    assert followed.margins[0].inside and followed.tilt_rad > far_end_limit
    watching = _settle(PitchLoop(dataclasses.replace(base, search_weight_factor=0.1), LIMITS), state, [near],
                       steps=15)
    assert watching.tilt_rad <= far_end_limit + 1e-3


@settings(max_examples=200, deadline=None)
@given(
    targets=st.lists(st.tuples(st.floats(-20.0, 30.0), st.floats(-15.0, 15.0),
                               st.one_of(st.none(), st.floats(0.0, 0.4))), min_size=1, max_size=12),
    altitude=st.floats(0.4, 3.0), speed=st.floats(0.0, 1.0), tilt_deg=st.floats(0.0, 60.0),
    window_end=st.floats(2.0, 15.0),
)
def test_tracks_beyond_reach_are_never_served(targets, altitude, speed, tilt_deg, window_end):
    """The tracks the pitch loop leaves out before placing them (behind the sonar, or past the
    window's end for the whole horizon) are ones the selection would have dropped: the served
    targets are the same with and without them."""
    from planner.pitch.reach import beyond_reach
    from planner.pitch.selection import select_shadows

    cfg = pitch_config(window_m=(0.5, window_end))
    state = PitchState(altitude_m=altitude, vehicle_pitch_rad=0.0, speed_m_s=speed,
                       current_tilt_rad=math.radians(tilt_deg))
    shadows = [TrackedShadow(i, a, c, h, 0.0, False) for i, (a, c, h) in enumerate(targets)]
    kept = [s for s in shadows if not beyond_reach(s, cfg, speed_m_s=speed)]
    try:
        served_all = select_shadows(state, shadows, cfg, LIMITS, 0.0)[0]
    except GeometryError:
        return
    served_kept = select_shadows(state, kept, cfg, LIMITS, 0.0)[0]
    assert [shadows[i].target_id for i, _ in served_all] == [kept[i].target_id for i, _ in served_kept]
    far = TrackedShadow("far", window_end + 2.0 + speed * cfg.horizon_steps * cfg.dt_s, 0.0, None, 0.0, False)
    behind = TrackedShadow("behind", -1.5, 0.0, None, 0.0, False)
    assert beyond_reach(far, cfg, speed_m_s=speed) and beyond_reach(behind, cfg, speed_m_s=speed)
