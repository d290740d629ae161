"""Height solver: the paper's Eq. 2 on Table III, exact 3D geometry, noise and uncertainty.

(Over 400 lines: the solver's known-answer and property tests in one place, each short.)
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

from perception.errors import SolverError
from perception.geometry import (
    SeabedPlane,
    ray_angles_sonar,
    seabed_hit_slant_m,
    sonar_to_ned,
)
from perception.heights.solver import (
    HeightEstimate,
    ShadowObservation,
    eq2_paper,
    height_one_frame,
    height_two_frames,
    solve_height,
    solve_height_batch,
    solve_height_sloped,
)

TABLE_III_ROWS = ["1", "1*", "1-S", "2", "2*", "2-S", "3", "3*", "3-S", "4", "4*", "4-S"]
TABLE_III_ROWS += ["5", "5*", "5-S"]
INCONSISTENT_ROW = "2-S"


def _tables(data_dir: Path) -> dict[str, Any]:
    with open(data_dir / "paper_tables.json", encoding="utf-8") as f:
        data: dict[str, Any] = json.load(f)
    return data


def _row(data_dir: Path, name: str) -> dict[str, Any]:
    rows = {r["row"]: r for r in _tables(data_dir)["table_III_rows"]}
    return rows[name]


# --- Eq. 2 on the paper's Table III ------------------------------------------------------


def test_table_iii_lists_every_row(data_dir: Path) -> None:
    tables = _tables(data_dir)
    assert [r["row"] for r in tables["table_III_rows"]] == TABLE_III_ROWS
    assert tables["delta_h_m"] == 0.1
    for r in tables["table_III_rows"]:
        # The table's own bookkeeping: Error = GT - Est. Row 4-S prints +0.141 for
        # 3.0 - 3.141 = -0.141: a sign slip in the paper (the magnitude is right).
        expected = r["gt_cm"] - r["est_cm"]
        if r["row"] == "4-S":
            expected = -expected
        assert r["err_cm"] == pytest.approx(expected, abs=1e-9)


@pytest.mark.parametrize("name", [n for n in TABLE_III_ROWS if n != INCONSISTENT_ROW])
def test_eq2_reproduces_table_iii(data_dir: Path, name: str) -> None:
    """Eq. 2 as published, R and L in pixels, dH = 0.10 m, gives the Est. column.

    Image 2 is the higher altitude (shorter shadow, L2 < L1); Eq. 2's denominator makes
    ``delta_h`` the first altitude minus the second, so with ``+0.10`` it returns ``-h``
    and the table prints ``|h|``; with ``-0.10`` (= H1 - H2) it returns ``+h``.
    """
    row = _row(data_dir, name)
    args = (row["R1"], row["L1"], row["R2"], row["L2"])
    h_cm = 100.0 * eq2_paper(*args, delta_h=-0.10)
    assert h_cm > 0
    assert 100.0 * eq2_paper(*args, delta_h=0.10) == pytest.approx(-h_cm, rel=1e-12)
    assert abs(h_cm - row["est_cm"]) <= 0.001 + 1e-9


def test_eq2_row_2s_is_inconsistent_in_the_paper(data_dir: Path) -> None:
    """Row 2-S: the printed R/L give 3.389 cm, the table prints 3.500 cm.

    The printed Est. (3.500) and Error (+0.400 = GT 3.9 - 3.500) agree with each other, so
    the slip is in the printed inputs, not in the formula or our code: Eq. 2 gives 3.389 cm
    on R1=493, L1=32, R2=514, L2=28 while the other 14 rows match to 0.001 cm. Searching
    every single-number change of the four inputs (integers 1..999) shows exactly one that
    yields 3.500 cm: R1 = 496 instead of 493, most likely a transcription slip (3 vs 6).
    """
    row = _row(data_dir, INCONSISTENT_ROW)
    printed = [row["R1"], row["L1"], row["R2"], row["L2"]]
    r1, l1, r2, l2 = printed
    h_cm = 100.0 * eq2_paper(r1, l1, r2, l2, -0.10)
    assert round(h_cm, 3) == 3.389
    assert row["est_cm"] - h_cm > 0.1  # far beyond the 0.001 cm of the other rows

    fixes = []
    for index, label in enumerate(("R1", "L1", "R2", "L2")):
        for value in range(1, 1000):
            if value == printed[index]:
                continue
            trial = list(printed)
            trial[index] = value
            try:
                est = 100.0 * abs(eq2_paper(trial[0], trial[1], trial[2], trial[3], 0.10))
            except SolverError:
                continue
            if abs(est - row["est_cm"]) <= 0.0005:
                fixes.append((label, value))
    assert fixes == [("R1", 496)]


def test_eq2_rejects_zero_denominator_and_nan() -> None:
    with pytest.raises(SolverError, match="denominator"):
        eq2_paper(100.0, 10.0, 200.0, 20.0, 0.1)  # same R/L ratio in both images
    with pytest.raises(SolverError, match="finite"):
        eq2_paper(100.0, math.nan, 200.0, 20.0, 0.1)


# --- exact 3D geometry -------------------------------------------------------------------


def _ranges_3d(
    target_ned: np.ndarray,
    sonar_ned: np.ndarray,
    seabed_depth_m: float,
    *,
    tilt: float,
    pitch: float,
    roll: float,
    heading: float,
) -> tuple[float, float]:
    """(r_top, r_end) of a target top point seen from a sonar with the given attitude.

    The top point's direction is taken into the sonar frame with the full rotation; the
    shadow end is where that same sonar ray (its azimuth and elevation) meets the flat
    seabed, from :func:`seabed_hit_slant_m` (which ignores heading).
    """
    offset = target_ned - sonar_ned
    r_top = float(np.linalg.norm(offset))
    rot = sonar_to_ned(tilt_rad=tilt, pitch_rad=pitch, roll_rad=roll, heading_rad=heading)
    az, el = ray_angles_sonar(rot.T @ offset)
    altitude = seabed_depth_m - float(sonar_ned[2])
    r_end = float(seabed_hit_slant_m(az, el, altitude_m=altitude, tilt_rad=tilt, pitch_rad=pitch, roll_rad=roll))
    return r_top, r_end


attitude = st.tuples(
    st.floats(0.0, 1.3),  # tilt
    st.floats(-0.35, 0.35),  # pitch
    st.floats(-0.35, 0.35),  # roll
    st.floats(-math.pi, math.pi),  # heading
)


@given(
    altitude1=st.floats(0.3, 20.0),
    delta_h=st.floats(0.05, 3.0),
    climb=st.booleans(),
    height_frac=st.floats(0.02, 0.8),
    distance=st.floats(0.3, 30.0),
    bearing=st.floats(-math.pi, math.pi),
    move=st.tuples(st.floats(-2.0, 2.0), st.floats(-2.0, 2.0)),
    att1=attitude,
    att2=attitude,
    att3=attitude,
)
def test_every_solver_recovers_height_from_exact_3d_rays(
    altitude1: float,
    delta_h: float,
    climb: bool,
    height_frac: float,
    distance: float,
    bearing: float,
    move: tuple[float, float],
    att1: tuple[float, float, float, float],
    att2: tuple[float, float, float, float],
    att3: tuple[float, float, float, float],
) -> None:
    dh = delta_h if climb else -delta_h
    altitude2 = altitude1 + dh
    assume(altitude2 >= 0.3)
    height = height_frac * min(altitude1, altitude2)
    assume(height >= 0.01)
    depth = altitude1  # sonar 1 at the NED origin, seabed at depth altitude1
    target = np.array([distance * math.cos(bearing), distance * math.sin(bearing), depth - height])
    sonar1 = np.zeros(3)
    sonar2 = np.array([move[0], move[1], -dh])
    sonar3 = np.array([-move[1], move[0], -dh / 2])  # a third frame half-way up
    frames = []
    for sonar, att in ((sonar1, att1), (sonar2, att2), (sonar3, att3)):
        tilt, pitch, roll, heading = att
        frames.append(_ranges_3d(target, sonar, depth, tilt=tilt, pitch=pitch, roll=roll, heading=heading))
    (t1, e1), (t2, e2), (t3, e3) = frames
    alts = (altitude1, altitude2, altitude1 + dh / 2)

    tol = 1e-9
    # The similar-triangles relation itself, whatever the attitude.
    for (t, e), alt in zip(frames, alts, strict=True):
        assert e == pytest.approx(t * alt / (alt - height), rel=1e-11)
        assert height_one_frame(t, e, alt) == pytest.approx(height, abs=tol)
    assert height_two_frames(t1, e1, t2, e2, dh) == pytest.approx(height, abs=tol)
    # Eq. 2 with R from range ZERO and L = r_end - r_top, dH = H1 - H2.
    assert eq2_paper(t1, e1 - t1, t2, e2 - t2, -dh) == pytest.approx(height, abs=tol)

    sigma = 0.003
    obs = [
        ShadowObservation(t1, e1, sigma, 0.0),
        ShadowObservation(t2, e2, sigma, dh),
        ShadowObservation(t3, e3, sigma, dh / 2),
    ]
    for subset in (obs[:2], obs):
        est = solve_height(subset)
        assert est.height_m == pytest.approx(height, abs=tol)
        assert est.ref_altitude_m == pytest.approx(altitude1, abs=1e-7)
        assert est.frames_used == len(subset)
    known = [ShadowObservation(o.r_top_m, o.r_end_m, sigma, o.delta_h_m, a) for o, a in zip(obs, alts, strict=True)]
    assert solve_height(known).height_m == pytest.approx(height, abs=tol)

    positions = np.stack([sonar1, sonar2, sonar3])
    flat = SeabedPlane.horizontal(depth)
    assert solve_height_sloped(obs, positions, flat).height_m == pytest.approx(height, abs=tol)
    orientation_only = SeabedPlane((0.0, 0.0, -1.0))
    sloped = solve_height_sloped(obs, positions, orientation_only)
    assert sloped.height_m == pytest.approx(height, abs=tol)


def test_measuring_from_the_window_start_is_the_papers_error() -> None:
    """R from the bottom of the image (window start) instead of range zero: wrong height.

    A tank-like case: sonar 0.5 m and 0.6 m above the floor, a 3.9 cm target 0.6 m away,
    window starting at 0.4 m.
    """
    height, h1, h2, ground = 0.039, 0.5, 0.6, 0.6
    t1, t2 = math.hypot(ground, h1 - height), math.hypot(ground, h2 - height)
    e1, e2 = t1 * h1 / (h1 - height), t2 * h2 / (h2 - height)
    exact = eq2_paper(t1, e1 - t1, t2, e2 - t2, h1 - h2)
    assert exact == pytest.approx(height, rel=1e-12)
    window_start = 0.4
    wrong = eq2_paper(t1 - window_start, e1 - t1, t2 - window_start, e2 - t2, h1 - h2)
    assert abs(wrong - height) > 0.2 * height


# --- noise: error shrinks with frames, reported std matches the spread -------------------


def _noisy_trials(
    rng: np.random.Generator,
    n_trials: int,
    delta_h: np.ndarray,
    *,
    ref_altitude: float,
    height: float,
    ground_m: float,
    sigma_r: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Ranges of one target seen from altitudes ``ref + dH_i`` with Gaussian range noise."""
    altitude = ref_altitude + delta_h
    r_top = np.hypot(ground_m, altitude - height)
    r_end = r_top * altitude / (altitude - height)
    shape = (n_trials, delta_h.size)
    return r_top + rng.normal(0.0, sigma_r, shape), r_end + rng.normal(0.0, sigma_r, shape)


# ARIS-like: 2000 samples over a 5 m window, so one sample is 2.5 mm.
SAMPLE_M = 5.0 / 2000
# Frames are added in this order: the extremes first, then ever finer in between.
DH_ORDER = np.array([0.0, 0.8, 0.4, 0.2, 0.6, 0.1, 0.7, 0.3, 0.5, 0.05, 0.75, 0.15, 0.65, 0.25])
DH_ORDER = np.concatenate([DH_ORDER, [0.45, 0.35]])


def test_n_frame_error_shrinks_and_std_matches_spread(rng: np.random.Generator) -> None:
    n_trials, height, ref = 1000, 0.3, 2.0
    # One set of noisy ranges for all 16 frames; N frames use the first N (nested sets).
    r_top, r_end = _noisy_trials(
        rng, n_trials, DH_ORDER, ref_altitude=ref, height=height, ground_m=3.0, sigma_r=SAMPLE_M
    )
    rms_errors = []
    for n in (2, 4, 8, 16):
        est = solve_height_batch(r_top[:, :n], r_end[:, :n], DH_ORDER[:n], sigma_r_m=SAMPLE_M)
        err = est.height_m - height
        spread = float(np.std(err))
        reported = float(np.sqrt(np.mean(est.height_std_m**2)))
        assert 0.8 <= reported / spread <= 1.2, (n, reported, spread)
        ref_spread = float(np.std(est.ref_altitude_m - ref))
        ref_reported = float(np.sqrt(np.mean(est.ref_altitude_std_m**2)))
        assert 0.8 <= ref_reported / ref_spread <= 1.2, (n, ref_reported, ref_spread)
        assert abs(float(np.mean(err))) < 0.5 * spread  # no gross bias
        rms_errors.append(float(np.sqrt(np.mean(err**2))))
    assert all(b < a for a, b in zip(rms_errors, rms_errors[1:], strict=False)), rms_errors
    assert rms_errors[-1] < 0.7 * rms_errors[0], rms_errors


def test_correlated_altitude_errors_are_propagated(rng: np.random.Generator) -> None:
    """dH from a drifting altitude estimate: a random walk, so the dH_i errors correlate.

    With the joint covariance the reported std matches the spread; with only its diagonal
    or with no altitude errors at all, the solver claims a precision the data lack.
    """
    n_trials, height, ref, n = 1000, 0.25, 3.0, 6
    delta_h = np.linspace(0.0, 1.0, n)
    step_std = 0.02
    index = np.arange(n)
    cov = step_std**2 * np.minimum(index[:, None], index[None, :])  # random walk from frame 0
    r_top, r_end = _noisy_trials(
        rng, n_trials, delta_h, ref_altitude=ref, height=height, ground_m=4.0, sigma_r=SAMPLE_M
    )
    walk = np.cumsum(rng.normal(0.0, step_std, (n_trials, n - 1)), axis=1)
    measured_dh = delta_h + np.concatenate([np.zeros((n_trials, 1)), walk], axis=1)

    def reported_over_spread(cov_arg: np.ndarray | None) -> float:
        est = solve_height_batch(r_top, r_end, measured_dh, sigma_r_m=SAMPLE_M, delta_h_cov_m2=cov_arg)
        spread = float(np.std(est.height_m - height))
        return float(np.sqrt(np.mean(est.height_std_m**2))) / spread

    assert 0.8 <= reported_over_spread(cov) <= 1.2
    assert reported_over_spread(np.diag(cov)) < 0.9
    assert reported_over_spread(None) < 0.75


def test_solve_height_matches_the_batch_solver(rng: np.random.Generator) -> None:
    delta_h = DH_ORDER[:5]
    r_top, r_end = _noisy_trials(rng, 5, delta_h, ref_altitude=2.0, height=0.3, ground_m=3.0, sigma_r=SAMPLE_M)
    cov = np.full(5, 0.002**2)
    batch = solve_height_batch(r_top, r_end, delta_h, sigma_r_m=SAMPLE_M, delta_h_cov_m2=cov)
    for k in range(5):
        obs = [
            ShadowObservation(float(t), float(e), SAMPLE_M, float(d))
            for t, e, d in zip(r_top[k], r_end[k], delta_h, strict=True)
        ]
        one = solve_height(obs, delta_h_cov_m2=cov)
        # Re-weighting stops once H0 moves < 1e-9 relative; the batch stops when all have.
        assert one.height_m == pytest.approx(batch.height_m[k], rel=1e-8)
        assert one.height_std_m == pytest.approx(batch.height_std_m[k], rel=1e-8)
        assert one.residual_rms_m > 0  # 5 noisy frames never fit exactly


def test_known_altitude_std_matches_spread(rng: np.random.Generator) -> None:
    n_trials, height, altitude, altitude_std = 1000, 0.3, 2.0, 0.01
    r_top, r_end = _noisy_trials(
        rng,
        n_trials,
        np.zeros(1),
        ref_altitude=altitude,
        height=height,
        ground_m=3.0,
        sigma_r=SAMPLE_M,
    )
    measured_alt = altitude + rng.normal(0.0, altitude_std, n_trials)
    estimates = [
        solve_height(
            [ShadowObservation(float(t), float(e), SAMPLE_M, 0.0, float(a))],
            altitude_std_m=altitude_std,
        )
        for t, e, a in zip(r_top[:, 0], r_end[:, 0], measured_alt, strict=True)
    ]
    heights = np.array([e.height_m for e in estimates])
    reported = np.array([e.height_std_m for e in estimates])
    spread = float(np.std(heights - height))
    assert 0.8 <= float(np.sqrt(np.mean(reported**2))) / spread <= 1.2


# --- sloped seabed -----------------------------------------------------------------------


def _plane_normal(slope: float, direction: float) -> np.ndarray:
    return np.array(
        [
            math.sin(slope) * math.cos(direction),
            math.sin(slope) * math.sin(direction),
            -math.cos(slope),
        ]
    )


def _on_plane(plane_point: np.ndarray, normal: np.ndarray, north: float, east: float) -> np.ndarray:
    """The point of the plane at a horizontal position (NED)."""
    down = plane_point[2] - (normal[0] * (north - plane_point[0]) + normal[1] * (east - plane_point[1])) / normal[2]
    return np.array([north, east, down])


def _sloped_ranges(
    plane_point: np.ndarray, normal: np.ndarray, top: np.ndarray, sonar: np.ndarray
) -> tuple[float, float]:
    """(r_top, r_end): distance to the top point and to where its ray meets the plane."""
    offset = top - sonar
    r_top = float(np.linalg.norm(offset))
    direction = offset / r_top
    r_end = float(-np.dot(normal, sonar - plane_point) / np.dot(normal, direction))
    return r_top, r_end


def _plane(normal: np.ndarray, point: np.ndarray | None) -> SeabedPlane:
    n = (float(normal[0]), float(normal[1]), float(normal[2]))
    if point is None:
        return SeabedPlane(n)
    return SeabedPlane(n, (float(point[0]), float(point[1]), float(point[2])))


@given(
    slope=st.floats(0.0, 0.5),
    direction=st.floats(-math.pi, math.pi),
    height=st.floats(0.02, 1.5),
    perp=st.lists(st.floats(2.0, 20.0), min_size=2, max_size=4, unique=True),
    offsets=st.lists(st.tuples(st.floats(-15.0, 15.0), st.floats(-15.0, 15.0)), min_size=4, max_size=4),
)
def test_sloped_solver_recovers_perpendicular_height(
    slope: float,
    direction: float,
    height: float,
    perp: list[float],
    offsets: list[tuple[float, float]],
) -> None:
    assume(max(perp) - min(perp) >= 0.05)
    normal = _plane_normal(slope, direction)
    plane_point = np.array([1.0, 2.0, 30.0])
    top = _on_plane(plane_point, normal, 3.0, 1.0) + height * normal
    sonars = []
    obs = []
    for distance, (dx, dy) in zip(perp, offsets, strict=False):
        sonar = _on_plane(plane_point, normal, 3.0 + dx, 1.0 + dy) + distance * normal
        sonars.append(sonar)
        r_top, r_end = _sloped_ranges(plane_point, normal, top, sonar)
        obs.append(ShadowObservation(r_top, r_end, 0.003))
    positions = np.stack(sonars)
    est = solve_height_sloped(obs, positions, _plane(normal, plane_point))
    assert est.height_m == pytest.approx(height, abs=1e-9)
    assert est.ref_altitude_m == pytest.approx(perp[0], abs=1e-9)
    relative = solve_height_sloped(obs, positions, _plane(normal, None))
    assert relative.height_m == pytest.approx(height, abs=1e-9)
    assert relative.ref_altitude_m == pytest.approx(perp[0], abs=1e-7)


def test_flat_solver_on_a_slope_is_wrong_and_the_sloped_one_is_not() -> None:
    """On a 10 deg slope, the vertical altitude in the flat formula gives a wrong height."""
    normal = _plane_normal(math.radians(10.0), 0.0)
    plane_point = np.zeros(3)
    top = 0.3 * normal  # a 0.3 m target standing at the plane point
    sonar = _on_plane(plane_point, normal, -4.0, 0.0) + 2.5 * normal
    r_top, r_end = _sloped_ranges(plane_point, normal, top, sonar)
    vertical_altitude = float(_on_plane(plane_point, normal, sonar[0], sonar[1])[2] - sonar[2])
    flat = height_one_frame(r_top, r_end, vertical_altitude)
    plane = _plane(normal, plane_point)
    sloped = solve_height_sloped([ShadowObservation(r_top, r_end, 0.003)], sonar[None, :], plane)
    assert float(plane.height_above_m(sonar)) == pytest.approx(2.5, abs=1e-12)
    assert sloped.height_m == pytest.approx(0.3, abs=1e-9)
    assert abs(flat - 0.3) > 0.003


# --- bad input ---------------------------------------------------------------------------


def test_solver_errors_name_the_problem() -> None:
    good = ShadowObservation(5.0, 5.5, 0.003, 0.0)
    with pytest.raises(SolverError, match="no shadow observations"):
        solve_height([])
    with pytest.raises(SolverError, match=">= 2 frames"):
        solve_height([good])
    with pytest.raises(SolverError, match="same delta_h_m"):
        solve_height([good, ShadowObservation(5.1, 5.6, 0.003, 0.0)])
    with pytest.raises(SolverError, match="r_end > r_top"):
        solve_height([good, ShadowObservation(5.6, 5.5, 0.003, 0.5)])
    with pytest.raises(SolverError, match="finite"):
        solve_height([good, ShadowObservation(math.nan, 5.5, 0.003, 0.5)])
    with pytest.raises(SolverError, match="sigma_r_m"):
        solve_height([good, ShadowObservation(5.1, 5.6, 0.0, 0.5)])
    with pytest.raises(SolverError, match="delta_h_cov_m2"):
        solve_height([good, ShadowObservation(5.1, 5.6, 0.003, 0.5)], delta_h_cov_m2=np.eye(3))
    with pytest.raises(SolverError, match="altitude"):
        height_one_frame(5.0, 5.5, -1.0)
    with pytest.raises(SolverError, match="same range ratio"):
        height_two_frames(5.0, 5.5, 10.0, 11.0, 0.5)
    with pytest.raises(SolverError, match="shape"):
        solve_height_sloped([good], np.zeros((2, 3)), SeabedPlane.horizontal(10.0))


def test_one_frame_accepts_arrays_and_returns_float_for_scalars() -> None:
    h = height_one_frame(np.array([4.0, 6.0]), np.array([5.0, 8.0]), 2.0)
    np.testing.assert_allclose(h, [0.4, 0.5])
    scalar = height_one_frame(4.0, 5.0, 2.0)
    assert isinstance(scalar, float) and scalar == pytest.approx(0.4)


def test_estimate_is_a_frozen_record() -> None:
    est = solve_height([ShadowObservation(4.0, 5.0, 0.003, 0.0, 2.0)])
    assert isinstance(est, HeightEstimate)
    assert est.height_m == pytest.approx(0.4)
    assert est.residual_rms_m == 0.0
    with pytest.raises(AttributeError):
        est.height_m = 1.0  # type: ignore[misc]
