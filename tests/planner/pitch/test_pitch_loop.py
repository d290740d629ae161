"""Tests of the pitch loop: geometry known answers, measurement round trips, the QP's
limits, dropped targets, and closed-loop figures against truth."""

from __future__ import annotations

import dataclasses
import math
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from benchmarks.pitch_kinematics import (
    random_scenario,
    simulate_pass,
    tilt_sign_changes,
    whole_shadow_visible,
)
from perception.errors import GeometryError, MeasurementError
from perception.geometry import insonified_band, ray_angles_sonar, sonar_to_ned
from planner.dryrun.shadow_view import shadow_visible_at_tilts
from planner.errors import ConfigError
from planner.pitch.aperture import (
    aperture_interval_rad,
    depression_interval_rad,
    point_elevation_rad,
    shadow_geometry,
    shadow_margins_rad,
    tracking_zone_start_m,
)
from planner.pitch.baseline import NominalTilt, nominal_tilt_for
from planner.pitch.config import MountLimits, PitchLoopConfig
from planner.pitch.control import (
    ShadowPitchLoop,
    ZoneCentredTilt,
    describe_zone,
    footprint_from_highlight_m,
    loop_config,
    merge_pieces,
)
from planner.pitch.measurements import shadow_from_measurement, shadow_from_ned, shadow_measurement
from planner.pitch.prediction import predict_pitch_rad
from planner.pitch.qp import PitchLoop
from planner.pitch.types import (
    BEFORE_WINDOW_START,
    BEHIND,
    BEYOND_MOUNT_LIMITS,
    BEYOND_WINDOW_END,
    EXTENT_EXCEEDS_APERTURE,
    OUTSIDE_FAN,
    TOO_CLOSE,
    TOO_MANY_TARGETS,
    PitchCommand,
    PitchState,
    TrackedShadow,
)

APERTURE = math.radians(14.0)
LIMITS = MountLimits(0.0, math.radians(60.0), math.radians(20.0))


def _config(**kw: object) -> PitchLoopConfig:
    kw.setdefault("nominal_tilt_rad", math.radians(15.0))
    return PitchLoopConfig(**kw)  # type: ignore[arg-type]


@pytest.fixture(scope="module")
def loop() -> PitchLoop:
    return PitchLoop(_config(), LIMITS)


def _direct_elevation(x: float, y: float, z: float, *, tilt: float, pitch: float) -> tuple[float, float]:
    """Azimuth and elevation of a level-frame point by rotating it into the sonar frame."""
    p_sonar = sonar_to_ned(tilt_rad=tilt, pitch_rad=pitch).T @ np.array([x, y, z])
    az, el = ray_angles_sonar(p_sonar)
    return float(az), float(el)


# --------------------------------------------------------------------------- settings


@pytest.mark.parametrize(
    ("kw", "key"),
    [
        ({"margin_rad": math.radians(7.0)}, "margin_rad"),
        ({"horizon_steps": 0}, "horizon_steps"),
        ({"window_m": (5.0, 2.0)}, "window_m"),
        ({"solver": "nope"}, "solver"),
        ({"dt_s": 0.0}, "dt_s"),
        ({"height_min_m": 0.5, "height_prior_m": 0.4}, "height_min_m"),
        ({"hold_start_s": 0.6, "dt_s": 0.5}, "hold_start_s"),
        ({"search_weight_factor": 1.5}, "search_weight_factor"),
        ({"nominal_tilt_rad": float("nan")}, "nominal_tilt_rad"),
    ],
)
def test_bad_config_names_the_key(kw: dict[str, object], key: str) -> None:
    with pytest.raises(ConfigError) as info:
        _config(**kw)
    assert info.value.key == key


def test_bad_limits_and_state_raise() -> None:
    with pytest.raises(ConfigError):
        MountLimits(0.5, 0.2, 1.0)
    with pytest.raises(ConfigError):
        MountLimits(0.0, 1.0, 0.0)
    with pytest.raises(GeometryError, match="altitude_m"):
        PitchState(altitude_m=0.0, vehicle_pitch_rad=0.0, speed_m_s=0.5, current_tilt_rad=0.2)
    with pytest.raises(GeometryError, match="footprint_m"):
        TrackedShadow(1, 3.0, 0.0, 0.1, footprint_m=-1.0)


# --------------------------------------------------------------------------- geometry


def test_on_axis_interval_known_answer() -> None:
    # A point 2 m ahead and 1 m down has depression atan(1/2); on the axis k = 1.
    lo, hi = aperture_interval_rad(2.0, 0.0, 1.0, half_aperture_rad=math.radians(6.0))
    dep = math.atan2(1.0, 2.0)
    assert float(lo) == pytest.approx(dep - math.radians(6.0), abs=1e-12)
    assert float(hi) == pytest.approx(dep + math.radians(6.0), abs=1e-12)


def test_shadow_geometry_known_answer() -> None:
    # H = 1 m, post of 0.2 m with its top 2 m ahead: r_top = sqrt(4 + 0.64), r_end = r_top / 0.8.
    g = shadow_geometry(2.0, 0.0, 0.2, 0.0, 1.0)
    r_top = math.sqrt(4.0 + 0.64)
    assert float(g.end_slant_m) == pytest.approx(r_top / 0.8, rel=1e-12)
    assert float(g.near_slant_m) == pytest.approx(r_top, rel=1e-12)
    assert float(g.base_ground_m) == pytest.approx(2.0)
    # A 0.5 m footprint moves the near foot 0.5 m closer along the line of sight.
    g2 = shadow_geometry(3.0, 4.0, 0.2, 0.5, 1.0)
    assert float(g2.base_ground_m) == pytest.approx(4.5)
    assert float(np.hypot(g2.base_along_m, g2.base_cross_m)) == pytest.approx(4.5)
    with pytest.raises(GeometryError):
        shadow_geometry(2.0, 0.0, 1.0, 0.0, 1.0)


@pytest.mark.parametrize(("altitude", "along", "height", "depression_deg"),
                         [(1.0, 3.0, 0.2, 15.0), (2.0, 8.0, 0.35, 12.0), (0.6, 2.0, 0.05, 20.0)])
def test_margins_match_insonified_band(altitude: float, along: float, height: float, depression_deg: float) -> None:
    """On the beam axis the angular margins are the band's slant edges seen as depressions:
    the far one at the shadow end, the near one at the shadow's start (the seabed at the top
    edge's slant range, which the image shows as the first shadowed sample)."""
    d = math.radians(depression_deg)
    g = shadow_geometry(along, 0.0, height, 0.0, altitude)
    far, near = shadow_margins_rad(g, depression_rad=d, elevation_aperture_rad=APERTURE)
    band = insonified_band(altitude, depression_rad=d, elevation_aperture_rad=APERTURE)
    r_end = float(g.end_slant_m)
    r_start = math.hypot(along, altitude - height)
    assert r_start < math.hypot(along, altitude)  # nearer than the far foot
    assert float(far) == pytest.approx(math.asin(altitude / r_end) - math.asin(altitude / band.far_slant_m), abs=1e-12)
    assert float(near) == pytest.approx(math.asin(altitude / band.near_slant_m) - math.asin(altitude / r_start),
                                        abs=1e-12)
    assert (float(far) >= 0) == (r_end <= band.far_slant_m)
    assert (float(near) >= 0) == band.contains_slant(r_start)


@settings(max_examples=200, deadline=None)
@given(x=st.floats(0.3, 15.0), y=st.floats(-4.0, 4.0), z=st.floats(0.1, 3.0),
       tilt=st.floats(-0.3, 1.2), pitch=st.floats(-0.2, 0.2))
def test_closed_form_elevation_matches_direct_rays(x: float, y: float, z: float, tilt: float, pitch: float) -> None:
    _, el = _direct_elevation(x, y, z, tilt=tilt, pitch=pitch)
    assert float(point_elevation_rad(x, y, z, depression_rad=tilt - pitch)) == pytest.approx(el, abs=1e-9)


@settings(max_examples=200, deadline=None)
@given(x=st.floats(0.3, 15.0), y=st.floats(-3.0, 3.0), z=st.floats(0.1, 3.0), half_deg=st.floats(1.0, 10.0))
def test_interval_ends_put_the_point_on_the_aperture_edges(x: float, y: float, z: float, half_deg: float) -> None:
    half = math.radians(half_deg)
    lo, hi = aperture_interval_rad(x, y, z, half_aperture_rad=half)
    rho = math.hypot(x, z)
    if math.sin(half) * math.hypot(rho, y) / rho >= 1.0:
        return  # the whole half-space qualifies; the ends are not aperture edges
    _, el_lo = _direct_elevation(x, y, z, tilt=float(lo), pitch=0.0)
    _, el_hi = _direct_elevation(x, y, z, tilt=float(hi), pitch=0.0)
    assert el_lo == pytest.approx(half, abs=1e-9)  # beam raised: the point at the steep edge
    assert el_hi == pytest.approx(-half, abs=1e-9)
    _, el_mid = _direct_elevation(x, y, z, tilt=0.5 * float(lo + hi), pitch=0.0)
    assert abs(el_mid) < half


@settings(max_examples=150, deadline=None)
@given(x=st.floats(1.0, 10.0), y=st.floats(-1.0, 1.0), h=st.floats(0.02, 0.4), alt=st.floats(0.5, 2.5),
       pitch=st.floats(-0.06, 0.06), off=st.floats(-0.8, 0.8))
def test_measurement_round_trip(x: float, y: float, h: float, alt: float, pitch: float, off: float) -> None:
    if h >= 0.9 * alt:
        return
    # Point the beam at the shadow end so the measured ray is inside the aperture.
    tilt = math.atan2(alt - h, x) + pitch + off * APERTURE / 2
    truth = TrackedShadow(7, x, y, h)
    r_top, r_end, az = shadow_measurement(truth, altitude_m=alt, tilt_rad=tilt, pitch_rad=pitch)
    back = shadow_from_measurement(7, top_slant_m=r_top, end_slant_m=r_end, azimuth_rad=az, altitude_m=alt,
                                   tilt_rad=tilt, pitch_rad=pitch)
    assert back.measured
    assert back.height_m == pytest.approx(h, abs=1e-9)
    assert back.along_m == pytest.approx(x, abs=1e-7)
    assert back.cross_m == pytest.approx(y, abs=1e-7)
    # The lead's formula: g_top = sqrt(r_top^2 - (H - h)^2).
    assert math.hypot(back.along_m, back.cross_m) == pytest.approx(math.sqrt(r_top**2 - (alt - h) ** 2), abs=1e-7)


def test_bad_measurements_raise() -> None:
    kw = {"azimuth_rad": 0.0, "altitude_m": 1.0, "tilt_rad": 0.3, "pitch_rad": 0.0}
    with pytest.raises(MeasurementError, match="top"):
        shadow_from_measurement(1, top_slant_m=3.0, end_slant_m=2.0, **kw)
    with pytest.raises(MeasurementError, match="altitude"):
        shadow_from_measurement(1, top_slant_m=0.5, end_slant_m=0.8, **kw)
    with pytest.raises(MeasurementError, match="non-finite"):
        shadow_from_measurement(1, top_slant_m=float("nan"), end_slant_m=2.0, **kw)


def test_shadow_from_ned_known_answer() -> None:
    # Heading east: a target 3 m east and 1 m south of the sonar is 3 m ahead, 1 m to starboard.
    s = shadow_from_ned(4, target_ned_m=(9.0, 23.0), sonar_ned_m=(10.0, 20.0), heading_rad=math.pi / 2)
    assert (s.along_m, s.cross_m) == (pytest.approx(3.0), pytest.approx(1.0))
    assert not s.measured and s.height_m is None


def test_pitch_prediction() -> None:
    cfg = _config(horizon_steps=4, dt_s=0.5, pitch_rate_time_s=1.0)
    state = PitchState(altitude_m=1.0, vehicle_pitch_rad=0.02, pitch_rate_rad_s=0.1, speed_m_s=0.5,
                       current_tilt_rad=0.2)
    t = np.arange(5) * 0.5
    np.testing.assert_allclose(predict_pitch_rad(state, cfg), 0.02 + 0.1 * (1 - np.exp(-t)), atol=1e-15)
    given_pitch = dataclasses.replace(state, predicted_pitch_rad=(0.1, 0.2, 0.3, 0.4))
    np.testing.assert_allclose(predict_pitch_rad(given_pitch, cfg), [0.02, 0.1, 0.2, 0.3, 0.4])
    with pytest.raises(GeometryError, match="4 values"):
        predict_pitch_rad(dataclasses.replace(state, predicted_pitch_rad=(0.1,)), cfg)


def test_truth_visibility_agrees_with_the_band() -> None:
    """The direct-ray truth check against the closed-form interval, on the beam axis."""
    cfg = _config(window_m=(0.5, 30.0))
    g = shadow_geometry(np.array([4.0]), np.array([0.0]), np.array([0.2]), np.array([0.0]), 1.0)
    lo, hi = depression_interval_rad(g, half_aperture_rad=APERTURE / 2)
    for d, expect in [(0.5 * float(lo[0] + hi[0]), True), (float(lo[0]) - 0.01, False), (float(hi[0]) + 0.01, False)]:
        assert bool(whole_shadow_visible(g, tilt_rad=d + 0.03, pitch_rad=0.03, config=cfg)[0]) is expect


# --------------------------------------------------------------------------- the QP


shadow_st = st.builds(
    TrackedShadow,
    target_id=st.integers(0, 1000),
    along_m=st.floats(-2.0, 16.0),
    cross_m=st.floats(-2.0, 2.0),
    height_m=st.one_of(st.none(), st.floats(0.0, 0.45)),
    footprint_m=st.floats(0.0, 1.0),
    measured=st.booleans(),
)


@settings(max_examples=60, deadline=None)
@given(alt=st.floats(0.5, 3.0), pitch=st.floats(-0.08, 0.08), rate=st.floats(-0.2, 0.2),
       speed=st.floats(0.0, 1.5), tilt=st.floats(-0.3, 1.4), shadows=st.lists(shadow_st, max_size=7))
def test_command_respects_rate_and_angle_limits(loop: PitchLoop, alt: float, pitch: float, rate: float,
                                                speed: float, tilt: float, shadows: list[TrackedShadow]) -> None:
    state = PitchState(altitude_m=alt, vehicle_pitch_rad=pitch, pitch_rate_rad_s=rate, speed_m_s=speed,
                       current_tilt_rad=tilt)
    cmd = loop.step(state, shadows)
    step_max = LIMITS.max_rate_rad_s * loop.config.dt_s
    start = LIMITS.clip(tilt)
    assert LIMITS.min_tilt_rad <= cmd.tilt_rad <= LIMITS.max_tilt_rad
    assert abs(cmd.tilt_rad - start) <= step_max + 1e-12
    plan = np.array(cmd.planned_tilt_rad)
    assert np.all((plan >= LIMITS.min_tilt_rad) & (plan <= LIMITS.max_tilt_rad))
    assert np.all(np.abs(np.diff(plan)) <= step_max + 1e-6)
    ids = [m.target_id for m in cmd.margins] + [d.target_id for d in cmd.dropped]
    assert sorted(ids, key=str) == sorted((s.target_id for s in shadows), key=str)
    assert cmd.solver_ok and math.isfinite(cmd.slack_rad) and cmd.slack_rad >= 0
    assert all(math.isfinite(m.far_margin_rad) and math.isfinite(m.near_margin_rad) for m in cmd.margins)


def test_no_targets_goes_to_nominal(loop: PitchLoop) -> None:
    state = PitchState(altitude_m=1.0, vehicle_pitch_rad=0.0, speed_m_s=0.5, current_tilt_rad=math.radians(30.0))
    tilts = []
    for _ in range(30):  # 15 s
        cmd = loop.step(state, [])
        tilts.append(cmd.tilt_rad)
        state = dataclasses.replace(state, current_tilt_rad=cmd.tilt_rad)
    assert np.all(np.diff(tilts) < 0)  # monotone toward the nominal, no overshoot
    assert tilts[-1] == pytest.approx(loop.config.nominal_tilt_rad, abs=math.radians(0.05))


def test_coverage_band_is_soft_and_yields_to_targets() -> None:
    cfg = _config(nominal_tilt_rad=math.radians(30.0),
                  coverage_depression_rad=(math.radians(10.0), math.radians(20.0)))
    lp = PitchLoop(cfg, LIMITS)
    state = PitchState(altitude_m=1.0, vehicle_pitch_rad=math.radians(2.0), speed_m_s=0.0,
                       current_tilt_rad=math.radians(30.0))
    for _ in range(10):
        state = dataclasses.replace(state, current_tilt_rad=lp.step(state, []).tilt_rad)
    # The band's steep edge (20 deg depression) plus the 2 deg pitch: 22 deg of tilt.
    assert state.current_tilt_rad == pytest.approx(math.radians(22.0), abs=1e-6)
    # A target 1.2 m ahead at 0.5 m altitude needs a depression beyond the band: it wins.
    near = [TrackedShadow(1, 1.2, 0.0, 0.05, measured=True)]
    low = dataclasses.replace(state, altitude_m=0.5)
    for _ in range(10):
        cmd = lp.step(low, near)
        low = dataclasses.replace(low, current_tilt_rad=cmd.tilt_rad)
    assert cmd.slack_rad == pytest.approx(0.0, abs=1e-7)
    assert cmd.tilt_rad - low.vehicle_pitch_rad > math.radians(20.0)


@pytest.mark.parametrize(("along", "cross", "pitch"), [(4.5, 0.0, 0.0), (6.0, 0.8, 0.04), (5.0, -0.3, -0.05)])
def test_solution_keeps_numpy_margins(loop: PitchLoop, along: float, cross: float, pitch: float) -> None:
    """The casadi QP and the numpy margin model agree: with no slack used, the numpy
    margins of the commanded tilt are at least the configured margin plus the envelope."""
    cfg = loop.config
    state = PitchState(altitude_m=1.0, vehicle_pitch_rad=pitch, speed_m_s=0.5, current_tilt_rad=math.radians(5.0))
    shadows = [TrackedShadow(1, along, cross, 0.2, measured=True)]
    for _ in range(6):  # let the rate limit bring the beam there
        cmd = loop.step(state, shadows)
        state = dataclasses.replace(state, current_tilt_rad=cmd.tilt_rad)
    cmd = loop.step(state, shadows)
    assert cmd.slack_rad == pytest.approx(0.0, abs=1e-7)
    (m,) = cmd.margins
    want = cfg.margin_rad + (loop.envelope_rad if cross == 0.0 else 0.0)
    assert min(m.far_margin_rad, m.near_margin_rad) >= want - 1e-6
    assert m.inside and m.constrained


def test_drops_unservable_targets_with_reasons() -> None:
    cfg = _config(window_m=(0.7, 30.0), zone_fits_aperture=False)  # the plain zone: 2 altitudes
    lp = PitchLoop(cfg, LIMITS)
    state = PitchState(altitude_m=2.0, vehicle_pitch_rad=0.0, speed_m_s=0.0, current_tilt_rad=math.radians(15.0))
    shadows = [
        TrackedShadow("behind", -1.0, 0.0, 0.1),
        TrackedShadow("fan", 3.0, 3.0, 0.1),
        TrackedShadow("close", 2.0, 0.0, 0.1),  # 1 altitude ahead < 2 altitudes
        # A 1.4 m target 4.6 m ahead at 2 m: the shadow spans ~16 deg of the 14 deg aperture.
        TrackedShadow("extent", 4.6, 0.0, 1.4),
        TrackedShadow("ok", 8.0, 0.0, 0.2),
    ]
    cmd = lp.step(state, shadows)
    reasons = {d.target_id: d.reason for d in cmd.dropped}
    assert reasons == {"behind": BEHIND, "fan": OUTSIDE_FAN, "close": TOO_CLOSE, "extent": EXTENT_EXCEEDS_APERTURE}
    assert [m.target_id for m in cmd.margins] == ["ok"]
    # Dropped targets do not drag the beam: the same command as with the served one alone.
    alone = lp.step(state, [shadows[-1]])
    assert cmd.tilt_rad == pytest.approx(alone.tilt_rad, abs=1e-9)


def test_drops_window_mount_and_surplus_targets() -> None:
    cfg = _config(window_m=(3.0, 12.0), max_targets=2, zone_fits_aperture=False)
    lp = PitchLoop(cfg, MountLimits(0.0, math.radians(10.0), math.radians(20.0)))
    state = PitchState(altitude_m=1.0, vehicle_pitch_rad=0.0, speed_m_s=0.0, current_tilt_rad=math.radians(5.0))
    cmd = lp.step(state, [TrackedShadow("far", 20.0, 0.0, 0.1), TrackedShadow("near", 2.5, 0.0, 0.05)])
    reasons = {d.target_id: d.reason for d in cmd.dropped}
    # 2.5 m ahead at 1 m: slant 2.7 m < window start 3 m - lead; its depression needs > 10 deg tilt.
    assert reasons["far"] == BEYOND_WINDOW_END
    assert reasons["near"] == BEFORE_WINDOW_START
    assert lp.step(state, [TrackedShadow("steep", 2.8, 0.0, 0.05)]).dropped[0].reason == BEYOND_MOUNT_LIMITS
    lp3 = PitchLoop(_config(max_targets=2, zone_fits_aperture=False), LIMITS)
    three = [TrackedShadow(i, 8.0 + i, 0.0, 0.1) for i in range(3)]
    cmd3 = lp3.step(dataclasses.replace(state, current_tilt_rad=0.1), three)
    assert [(d.target_id, d.reason) for d in cmd3.dropped] == [(2, TOO_MANY_TARGETS)]


@pytest.mark.parametrize("factor", [0.02, 1.0])
def test_lead_band_target_yields_to_target_in_range(factor: float) -> None:
    """A target leaving the tracking zone (inside the lead band only) that conflicts with
    one properly in range does not pull the beam off it, unless the lead weighs as much."""
    lp = PitchLoop(_config(lead_weight_factor=factor, zone_fits_aperture=False), LIMITS)  # zone: 2 altitudes
    state = PitchState(altitude_m=1.0, vehicle_pitch_rad=0.0, speed_m_s=0.0, current_tilt_rad=math.radians(15.0))
    in_range = TrackedShadow("in", 9.0, 0.0, 0.1, measured=True)
    leaving = TrackedShadow("leaving", 1.85, 0.0, 0.1, measured=True)  # 1.85 altitudes < 2, within the lead
    for _ in range(8):
        cmd = lp.step(state, [in_range, leaving])
        state = dataclasses.replace(state, current_tilt_rad=cmd.tilt_rad)
    margin = {m.target_id: min(m.far_margin_rad, m.near_margin_rad) for m in cmd.margins}
    assert set(margin) == {"in", "leaving"}
    if factor < 1.0:
        assert margin["in"] >= lp.config.margin_rad - 1e-6
    else:  # equal weights split the conflict: both lose their margins
        assert margin["in"] < lp.config.margin_rad and margin["leaving"] < lp.config.margin_rad


def test_fixed_tilt_baseline() -> None:
    cfg = _config(nominal_tilt_rad=math.radians(18.0))
    base = NominalTilt(cfg, LIMITS)
    state = PitchState(altitude_m=1.0, vehicle_pitch_rad=0.05, speed_m_s=0.5, current_tilt_rad=math.radians(18.0))
    cmd = base.step(state, [TrackedShadow(1, 4.0, 0.0, 0.1)])
    assert cmd.tilt_rad == pytest.approx(math.radians(18.0))
    assert cmd.tilt_deg == pytest.approx(18.0)
    assert len(cmd.margins) == 1
    # Far from nominal it slews at the rate limit, like the mount would.
    far = base.step(dataclasses.replace(state, current_tilt_rad=math.radians(40.0)), [])
    assert far.tilt_rad == pytest.approx(math.radians(40.0) - LIMITS.max_rate_rad_s * cfg.dt_s)


def test_sign_changes_counter() -> None:
    assert tilt_sign_changes([0, 1, 2, 1, 2, 2, 3], deadband_rad=0.5) == 2
    assert tilt_sign_changes([0, 0.1, 0.0, 0.1, 0.0], deadband_rad=0.5) == 0


# --------------------------------------------------------------------------- closed loop


def _pass_config(altitude_m: float, *, fits: bool = True) -> PitchLoopConfig:
    plain = _config(zone_fits_aperture=fits)
    return _config(nominal_tilt_rad=nominal_tilt_for(altitude_m, plain), zone_fits_aperture=fits)


@pytest.mark.slow
@pytest.mark.parametrize("fits", [True, False])
def test_closed_loop_keeps_shadows_in_view(rng: np.random.Generator, fits: bool) -> None:
    """Seeded random passes (0.5-2.5 m, heights 2-40 cm, pitch +-3 deg at 0.1-0.3 Hz, one
    target at a time in the tracking zone): >= 99 % of in-range frames see the whole
    shadow after settling; tilt changes stay bounded. Over the zone that fits the
    aperture, a fixed tilt centring it loses shadows only to the pitch; over the plain
    2-altitude zone (wider than the aperture) it does much worse."""
    totals = {"mpc": [0, 0], "fixed": [0, 0]}
    for _ in range(4):
        sc = random_scenario(rng, duration_s=60.0)
        cfg = _pass_config(sc.altitude_m, fits=fits)
        seed = int(rng.integers(1 << 31))
        for name, ctl in (("mpc", PitchLoop(cfg, LIMITS)), ("fixed", NominalTilt(cfg, LIMITS))):
            res = simulate_pass(ctl, sc, config=cfg, limits=LIMITS, rng=np.random.default_rng(seed))
            assert res.solver_failures == 0
            totals[name][0] += res.scored_frames
            totals[name][1] += res.visible_frames
            if name == "mpc":
                # No limit cycle: at most the disturbance's two reversals per period plus two per
                # target passing (down while following it, back up for the next).
                minutes = (res.time_s[-1] - sc.settle_s) / 60.0
                bound = 2 * sc.pitch_frequency_hz * 60.0 + 2 * len(sc.targets) / minutes
                assert res.sign_changes_per_minute() <= bound
    mpc = totals["mpc"][1] / totals["mpc"][0]
    fixed = totals["fixed"][1] / totals["fixed"][0]
    assert totals["mpc"][0] > 400
    assert mpc >= 0.99
    if not fits:
        assert fixed < 0.85


@pytest.mark.slow
def test_no_limit_cycle_without_disturbance(rng: np.random.Generator) -> None:
    """Without pitch disturbance and noise the tilt reverses at most twice per target."""
    sc = random_scenario(rng, duration_s=60.0)
    quiet = dataclasses.replace(sc, pitch_amplitude_rad=0.0, range_noise_m=0.0, azimuth_noise_rad=0.0,
                                altitude_noise_m=0.0, pitch_noise_rad=0.0, prior_position_noise_m=0.0)
    cfg = _pass_config(sc.altitude_m)
    res = simulate_pass(PitchLoop(cfg, LIMITS), quiet, config=cfg, limits=LIMITS, rng=rng)
    passed = sum(1 for t in sc.targets if t.along_m < quiet.speed_m_s * quiet.duration_s)
    assert tilt_sign_changes(res.command_tilt_rad, deadband_rad=math.radians(0.05)) <= 2 * max(passed, 1)
    assert res.visible_frames == res.scored_frames


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
    cfg = _config(window_m=(0.7, 3.0), nominal_tilt_rad=math.radians(22.0), search_weight_factor=0.1,
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
    assert _config().search_weight_factor == 0.0


def test_search_band_yields_to_a_tracked_target() -> None:
    cfg = _config(window_m=(0.7, 3.0), search_weight_factor=0.1, height_prior_m=0.2, dt_s=0.2)
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
    lp = PitchLoop(_config(window_m=(0.7, 3.0), dt_s=0.2, zone_fits_aperture=False), LIMITS)
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
    cfg = _config(window_m=(0.7, 3.0), dt_s=0.2, height_prior_m=0.2, zone_fits_aperture=False)
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
    cfg = _config(window_m=(0.7, 3.0), dt_s=0.2)
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
    cfg = _config(window_m=(0.7, 3.0), dt_s=0.2, height_prior_m=0.2, near_weight_factor=0.0)
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
    cfg = _config(window_m=(0.7, 3.0), dt_s=0.2, height_prior_m=0.2, nominal_tilt_rad=math.radians(12.0),
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
    cfg = _config(window_m=(0.7, 4.0), dt_s=0.2, height_prior_m=0.2)
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
    cfg = _config(window_m=(0.7, 3.0), dt_s=0.2, height_prior_m=0.2)
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
    cfg = _config(window_m=(0.7, 4.0), dt_s=0.2, height_prior_m=0.4)
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
    base = _config(window_m=(0.7, 4.0), dt_s=0.2, height_prior_m=0.2, nominal_tilt_rad=math.radians(12.0),
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

    cfg = _config(window_m=(0.5, window_end))
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
