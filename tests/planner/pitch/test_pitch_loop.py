"""Tests of the pitch loop's QP (limits, dropped targets) and closed-loop figures against
truth."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from benchmarks.pitch_kinematics import (
    random_scenario,
    simulate_pass,
    tilt_sign_changes,
)
from planner.pitch.baseline import NominalTilt, nominal_tilt_for
from planner.pitch.config import MountLimits, PitchLoopConfig
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
    PitchState,
    TrackedShadow,
)
from tests.planner.pitch.common import LIMITS, pitch_config

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
    cfg = pitch_config(nominal_tilt_rad=math.radians(30.0),
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
    cfg = pitch_config(window_m=(0.7, 30.0), zone_fits_aperture=False)  # the plain zone: 2 altitudes
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
    cfg = pitch_config(window_m=(3.0, 12.0), max_targets=2, zone_fits_aperture=False)
    lp = PitchLoop(cfg, MountLimits(0.0, math.radians(10.0), math.radians(20.0)))
    state = PitchState(altitude_m=1.0, vehicle_pitch_rad=0.0, speed_m_s=0.0, current_tilt_rad=math.radians(5.0))
    cmd = lp.step(state, [TrackedShadow("far", 20.0, 0.0, 0.1), TrackedShadow("near", 2.5, 0.0, 0.05)])
    reasons = {d.target_id: d.reason for d in cmd.dropped}
    # 2.5 m ahead at 1 m: slant 2.7 m < window start 3 m - lead; its depression needs > 10 deg tilt.
    assert reasons["far"] == BEYOND_WINDOW_END
    assert reasons["near"] == BEFORE_WINDOW_START
    assert lp.step(state, [TrackedShadow("steep", 2.8, 0.0, 0.05)]).dropped[0].reason == BEYOND_MOUNT_LIMITS
    lp3 = PitchLoop(pitch_config(max_targets=2, zone_fits_aperture=False), LIMITS)
    three = [TrackedShadow(i, 8.0 + i, 0.0, 0.1) for i in range(3)]
    cmd3 = lp3.step(dataclasses.replace(state, current_tilt_rad=0.1), three)
    assert [(d.target_id, d.reason) for d in cmd3.dropped] == [(2, TOO_MANY_TARGETS)]


@pytest.mark.parametrize("factor", [0.02, 1.0])
def test_lead_band_target_yields_to_target_in_range(factor: float) -> None:
    """A target leaving the tracking zone (inside the lead band only) that conflicts with
    one properly in range does not pull the beam off it, unless the lead weighs as much."""
    lp = PitchLoop(pitch_config(lead_weight_factor=factor, zone_fits_aperture=False), LIMITS)  # zone: 2 altitudes
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
    cfg = pitch_config(nominal_tilt_rad=math.radians(18.0))
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
    plain = pitch_config(zone_fits_aperture=fits)
    return pitch_config(nominal_tilt_rad=nominal_tilt_for(altitude_m, plain), zone_fits_aperture=fits)


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



@settings(max_examples=25, deadline=None)
@given(states=st.lists(st.tuples(st.floats(0.5, 3.0), st.floats(-0.08, 0.08), st.floats(0.0, 1.5),
                                 st.floats(-0.3, 1.4), st.lists(shadow_st, max_size=6)), min_size=2, max_size=4))
def test_buffered_solve_is_a_plain_casadi_call(states: list) -> None:
    """The loop solves its QP on arrays casadi reads in place (``PitchLoop._solve``): each
    step's solution must be casadi's ordinary call on the same problem, and nothing of one
    step may stay in the next (a fresh loop gives the same command)."""
    import casadi as ca

    cfg = pitch_config(horizon_steps=6, max_targets=3)
    kept = PitchLoop(cfg, LIMITS)
    solve = kept._solve
    problems: list[tuple] = []

    def recorded(qp, *problem: np.ndarray) -> tuple[np.ndarray, bool]:
        problems.append((qp, *(np.array(p) for p in problem)))
        return solve(qp, *problem)

    kept._solve = recorded  # type: ignore[method-assign]
    for alt, pitch, speed, tilt, shadows in states + states[:1]:
        state = PitchState(altitude_m=alt, vehicle_pitch_rad=pitch, speed_m_s=speed, current_tilt_rad=tilt)
        cmd = kept.step(state, shadows)
        assert repr(cmd) == repr(PitchLoop(cfg, LIMITS).step(state, shadows))  # repr: NaN margins compare
        qp, hess_nz, g, lba, uba, lbx, ubx = problems[-1]
        plain = qp.solver(h=ca.DM(qp.hess_sp, hess_nz), g=g, a=qp.a_dm, lba=lba, uba=uba, lbx=lbx, ubx=ubx)
        x, ok = solve(qp, hess_nz, g, lba, uba, lbx, ubx)
        assert ok == bool(qp.solver.stats()["success"])
        assert np.array_equal(x, np.asarray(plain["x"]).ravel())


@settings(max_examples=40, deadline=None)
@given(states=st.lists(st.tuples(st.floats(0.5, 3.0), st.floats(-0.08, 0.08), st.floats(0.0, 1.5),
                                 st.floats(-0.3, 1.4), st.lists(shadow_st, max_size=6)), min_size=1, max_size=4))
def test_a_qp_sized_to_the_targets_served_gives_the_full_qps_command(states: list) -> None:
    """The loop solves a QP with one slot per target served (none, most of a field survey):
    an empty slot would only add slacks no constraint reaches, held at zero by their cost,
    so the QP with every slot must command the same tilt and plan (to the solver's
    rounding), and say so as often."""
    cfg = pitch_config(horizon_steps=8, max_targets=4)
    sized, full = PitchLoop(cfg, LIMITS), PitchLoop(cfg, LIMITS)
    full._slots = lambda n_served: cfg.max_targets  # type: ignore[method-assign]
    for alt, pitch, speed, tilt, shadows in states:
        state = PitchState(altitude_m=alt, vehicle_pitch_rad=pitch, speed_m_s=speed, current_tilt_rad=tilt)
        a, b = sized.step(state, shadows), full.step(state, shadows)
        assert a.solver_ok == b.solver_ok
        assert a.tilt_rad == pytest.approx(b.tilt_rad, abs=1e-9)
        assert a.planned_tilt_rad == pytest.approx(b.planned_tilt_rad, abs=1e-8)
        assert a.slack_rad == pytest.approx(b.slack_rad, abs=1e-9)
        assert a.dropped == b.dropped
    assert max(sized._qps) <= cfg.max_targets and set(full._qps) == {cfg.max_targets}
