"""Altitude filter: exactness against a batch solution, gating, resets, bad input, queries."""

from __future__ import annotations

import math

import numpy as np
import pytest
from filterpy.kalman import KalmanFilter

from perception.errors import MeasurementError, OutsideWindowError
from perception.navigation.altitude_filter import AltitudeFilter, AltitudeFilterConfig
from perception.navigation.pressure import pressure_from_depth_pa
from perception.navigation.smoother import process_noise, transition
from tests.perception.navigation.altitude_dive import run, simulate_dive

ALT = np.array([-1.0, 0.0, 1.0])


def batch_posterior(
    config: AltitudeFilterConfig,
    measurements: list[tuple[float, str, float, float]],
    extra_times: list[float],
    extra_noise: dict[float, np.ndarray] | None = None,
) -> tuple[dict[float, int], np.ndarray, np.ndarray]:
    """Joint Gaussian posterior of the states at all times, by information-form least squares.

    Independent of the filter: builds the full prior (process model) and measurement
    information matrices and inverts once. ``extra_noise`` adds process noise on the
    interval that ends at a given time (a reset).
    """
    extra_noise = extra_noise or {}
    times = sorted({m[0] for m in measurements} | set(extra_times))
    index = {t: i for i, t in enumerate(times)}
    n = len(times)
    d = 3 if config.seabed_rate_psd_m2_s3 is None else 4
    info = np.zeros((d * n, d * n))
    eta = np.zeros(d * n)
    stds = [config.initial_depth_std_m, config.initial_speed_std_m_s, config.initial_seabed_std_m]
    stds += [config.initial_seabed_rate_std_m_s] if d == 4 else []
    info[:d, :d] += np.linalg.inv(np.diag(stds) ** 2)
    for i in range(n - 1):
        dt = times[i + 1] - times[i]
        q = process_noise(
            dt,
            accel_psd_m2_s3=config.accel_psd_m2_s3,
            seabed_walk_psd_m2_s=config.seabed_walk_psd_m2_s,
            seabed_rate_psd_m2_s3=config.seabed_rate_psd_m2_s3,
        )
        q = q + extra_noise.get(times[i + 1], np.zeros((d, d)))
        a = np.zeros((d, d * n))
        a[:, d * i : d * i + d] = -transition(dt, d)
        a[:, d * i + d : d * i + 2 * d] = np.eye(d)
        info += a.T @ np.linalg.inv(q) @ a
    for t, kind, z, std in measurements:
        h = np.zeros(d * n)
        i = index[t]
        if kind == "depth":
            h[d * i] = 1.0
        else:
            h[d * i : d * i + 3] = ALT
        info += np.outer(h, h) / std**2
        eta += h * z / std**2
    cov = np.linalg.inv(info)
    return index, cov @ eta, cov


def _alt_rows(index: dict[float, int], times: list[float], d: int) -> list[np.ndarray]:
    rows = []
    for t in times:
        g = np.zeros(d * len(index))
        g[d * index[t] : d * index[t] + 3] = ALT
        rows.append(g)
    return rows


@pytest.mark.parametrize("seabed_rate_psd", [None, 1e-4])
def test_queries_equal_the_batch_posterior(rng: np.random.Generator, seabed_rate_psd: float | None) -> None:
    config = AltitudeFilterConfig(
        accel_psd_m2_s3=1e-3, seabed_walk_psd_m2_s=1e-4, initial_depth_std_m=10.0, initial_seabed_std_m=10.0,
        seabed_rate_psd_m2_s3=seabed_rate_psd,
    )
    d = 3 if seabed_rate_psd is None else 4
    flt = AltitudeFilter(config)
    measurements = []
    t = 0.0
    for _ in range(40):
        t = round(t + rng.uniform(0.05, 0.3), 6)
        if rng.random() < 0.6:
            m = (t, "depth", 5.0 + 0.01 * rng.standard_normal(), 0.01)
            flt.update_depth(t, m[2], m[3])
        else:
            m = (t, "altimeter", 3.0 + 0.02 * rng.standard_normal(), 0.02)
            flt.update_altimeter(t, m[2], m[3])
        measurements.append(m)
    mt = [m[0] for m in measurements]
    queries = [
        mt[3],  # on a step
        0.5 * (mt[10] + mt[11]),  # between steps
        0.3 * mt[10] + 0.7 * mt[11],  # a second time in the same interval
        mt[25],
        0.5 * (mt[30] + mt[31]),
        mt[-1] + 0.5,  # predicted past the last step
        mt[-1] + 0.8,
    ]
    index, mean, cov = batch_posterior(config, measurements, queries)
    rows = dict(zip(queries, _alt_rows(index, queries, d), strict=True))
    for a in queries:
        est = flt.altitude_at(a)
        assert est.mean == pytest.approx(rows[a] @ mean, abs=1e-9)
        assert est.variance == pytest.approx(rows[a] @ cov @ rows[a], rel=1e-6)
        assert flt.depth_at(a).mean == pytest.approx(mean[d * index[a]], abs=1e-9)
    for a in queries:
        for b in queries:
            if b <= a:
                continue
            g = rows[b] - rows[a]
            est = flt.delta_altitude(a, b)
            assert est.mean == pytest.approx(g @ mean, abs=1e-9)
            assert est.variance == pytest.approx(g @ cov @ g, rel=1e-6)
            back = flt.delta_altitude(b, a)
            assert back.mean == pytest.approx(-est.mean) and back.variance == pytest.approx(est.variance)
    means, joint = flt.altitudes_at(queries)
    g_all = np.array([rows[a] for a in queries])
    assert np.allclose(joint, g_all @ cov @ g_all.T, rtol=1e-6, atol=1e-15)
    assert np.allclose(means, g_all @ mean, atol=1e-9)


def test_reset_is_exact_process_noise_for_the_smoother(rng: np.random.Generator) -> None:
    config = AltitudeFilterConfig(
        accel_psd_m2_s3=1e-3, seabed_walk_psd_m2_s=1e-6, initial_depth_std_m=10.0, initial_seabed_std_m=10.0,
        reinit_after=3, reinit_std_m=2.0,
    )
    flt = AltitudeFilter(config)
    measurements = []
    resets = {}
    for k in range(60):
        t = round(0.1 * k, 6)
        z = 5.0 + 0.01 * rng.standard_normal()
        flt.update_depth(t, z, 0.01)
        measurements.append((t, "depth", z, 0.01))
        ta = round(t + 0.05, 6)
        a = (3.0 if k < 30 else 3.8) + 0.02 * rng.standard_normal()  # the seabed drops 0.8 m
        result = flt.update_altimeter(ta, a, 0.02)
        if result.accepted:
            measurements.append((ta, "altimeter", a, 0.02))
        if result.status == "reinitialised":
            extra = np.zeros((3, 3))
            extra[2, 2] = config.reinit_std_m**2
            resets[ta] = extra
    assert len(resets) == 1
    queries = [1.02, 2.97, 3.12, 3.33, 5.5]
    index, mean, cov = batch_posterior(config, measurements, queries, resets)
    rows = dict(zip(queries, _alt_rows(index, queries, 3), strict=True))
    for a in queries:
        est = flt.altitude_at(a)
        assert est.mean == pytest.approx(rows[a] @ mean, abs=1e-8)
        assert est.variance == pytest.approx(rows[a] @ cov @ rows[a], rel=1e-6)
    g = rows[5.5] - rows[1.02]
    est = flt.delta_altitude(1.02, 5.5)
    assert est.mean == pytest.approx(g @ mean, abs=1e-8)
    assert est.variance == pytest.approx(g @ cov @ g, rel=1e-6)


def test_smoothed_states_equal_filterpy_rts_smoother(rng: np.random.Generator) -> None:
    """On a regular grid, the queries equal filterpy's own batch filter + RTS smoother."""
    config = AltitudeFilterConfig(accel_psd_m2_s3=1e-4, seabed_walk_psd_m2_s=1e-5)
    dt = 0.1
    n = 80
    kf = KalmanFilter(dim_x=3, dim_z=2)
    kf.x = np.zeros((3, 1))
    kf.P = np.diag([config.initial_depth_std_m, config.initial_speed_std_m_s, config.initial_seabed_std_m]) ** 2
    kf.F = transition(dt)
    kf.Q = process_noise(dt, accel_psd_m2_s3=config.accel_psd_m2_s3, seabed_walk_psd_m2_s=config.seabed_walk_psd_m2_s)
    kf.H = np.array([[1.0, 0.0, 0.0], [-1.0, 0.0, 1.0]])
    kf.R = np.diag([0.01**2, 0.02**2])
    zs = np.column_stack([5.0 + 0.01 * rng.standard_normal(n), 3.0 + 0.02 * rng.standard_normal(n)])
    flt = AltitudeFilter(config)
    for k in range(n):
        flt.update_depth(k * dt, zs[k, 0], 0.01)
        flt.update_altimeter(k * dt, zs[k, 1], 0.02)
    # filterpy predicts before its first update; ours starts at the first measurement,
    # so give filterpy the first step without a prediction.
    kf.update(zs[0].reshape(2, 1))
    means, covs = [kf.x.copy()], [kf.P.copy()]
    rest, rest_p, _, _ = kf.batch_filter(zs[1:].reshape(n - 1, 2, 1))
    xs = np.concatenate([np.array(means), rest])
    ps = np.concatenate([np.array(covs), rest_p])
    smoothed_x, smoothed_p, _, _ = kf.rts_smoother(xs, ps)
    for k in (0, 17, 40, 79):
        x, p = flt.state_at(k * dt)
        assert np.allclose(x, smoothed_x[k].ravel(), atol=1e-9)
        assert np.allclose(p, smoothed_p[k], rtol=1e-6, atol=1e-14)


def test_seabed_rate_state_follows_a_sloping_seabed() -> None:
    """Flying level over ground that deepens 2 cm/s: a random-walk seabed lags (and its
    gate then rejects good readings); the seabed-rate state follows, consistently."""

    def normalised_errors(config: AltitudeFilterConfig) -> tuple[np.ndarray, AltitudeFilter]:
        g = np.random.default_rng(4)
        flt = AltitudeFilter(config)
        errors = []
        for k in range(600):
            t = 0.1 * k
            flt.update_depth(t, 5.0 + 0.01 * g.standard_normal(), 0.01)
            if k % 2:
                flt.update_altimeter(t, 5.0 + 0.02 * t + 0.02 * g.standard_normal(), 0.02)
            if t > 20.0:
                x, p = flt.filtered_state()
                row = flt.model.altitude_row
                errors.append((row @ x - (5.0 + 0.02 * t)) / math.sqrt(row @ p @ row))
        return np.array(errors), flt

    walk, walk_filter = normalised_errors(AltitudeFilterConfig())
    rate, rate_filter = normalised_errors(AltitudeFilterConfig(seabed_rate_psd_m2_s3=1e-6))
    assert np.max(np.abs(walk)) > 5.0 and walk_filter.counters["altimeter"].gated > 10
    assert np.max(np.abs(rate)) < 3.5 and rate_filter.counters["altimeter"].gated <= 2
    assert 0.6 < np.mean(rate**2) < 1.5  # NEES of the altitude, about 1
    x, _ = rate_filter.filtered_state()
    assert x.shape == (4,) and x[3] == pytest.approx(0.02, abs=0.003)


def test_a_released_seabed_rate_is_learnt_again_after_a_turn() -> None:
    """Up a 2 cm/s rise, a 5 s turn in place (no change), then back down it: released at
    each change of track, the rate is learnt again with no reading gated and no reset;
    not released, the old rate is carried into the turn: readings are gated and the
    altitude is off by half as much again."""

    def fly(release: bool) -> tuple[AltitudeFilter, float]:
        g = np.random.default_rng(11)
        flt = AltitudeFilter(AltitudeFilterConfig(seabed_rate_psd_m2_s3=1e-6, initial_seabed_rate_std_m_s=0.03))
        seabed, worst = 8.0, 0.0
        for k in range(700):
            t = 0.1 * k
            rate = -0.02 if t < 30.0 else (0.0 if t < 35.0 else 0.02)  # seabed depth change, m/s
            if release and k in (300, 350):
                flt.release_seabed_rate()
            seabed += 0.1 * rate
            flt.update_depth(t, 5.0 + 0.01 * g.standard_normal(), 0.01)
            if k % 2:
                flt.update_altimeter(t, seabed - 5.0 + 0.02 * g.standard_normal(), 0.02)
            if t > 20.0:
                worst = max(worst, abs(flt.altitude_at(t).mean - (seabed - 5.0)))
        return flt, worst

    released, worst_released = fly(True)
    carried, worst_carried = fly(False)
    assert released.counters["altimeter"].gated == 0 and released.counters["altimeter"].reinitialised == 0
    assert worst_released < 0.03  # m, against 2 cm of altimeter noise
    assert carried.counters["altimeter"].gated >= 2
    assert worst_carried > 1.4 * worst_released
    # The three-state model has no rate to release: nothing changes.
    plain = AltitudeFilter(AltitudeFilterConfig())
    plain.release_seabed_rate()
    plain.update_depth(0.0, 5.0, 0.01)
    assert plain.filtered_state()[0].shape == (3,)


def _hover(flt: AltitudeFilter, rng: np.random.Generator, t0: float, t1: float, *, depth: float = 5.0,
           seabed: float = 8.0, spikes: dict[float, tuple[str, float]] | None = None,
           altimeter_gap: tuple[float, float] | None = None) -> dict[str, list[str]]:
    """Hover at a fixed depth over a flat seabed; depth 10 Hz/1 cm, altimeter 5 Hz/2 cm."""
    statuses: dict[str, list[str]] = {"depth": [], "altimeter": []}
    spikes = spikes or {}
    for k in range(int(round((t1 - t0) * 10))):
        t = round(t0 + 0.1 * k, 9)
        z = depth + 0.01 * rng.standard_normal()
        if t in spikes and spikes[t][0] == "depth":
            z += spikes[t][1]
        statuses["depth"].append(flt.update_depth(t, z, 0.01).status)
        if k % 2 == 1 and not (altimeter_gap and altimeter_gap[0] <= t <= altimeter_gap[1]):
            a = seabed - depth + 0.02 * rng.standard_normal()
            if t in spikes and spikes[t][0] == "altimeter":
                a += spikes[t][1]
            statuses["altimeter"].append(flt.update_altimeter(t, a, 0.02).status)
    return statuses


def test_spikes_are_rejected_and_counted(rng: np.random.Generator) -> None:
    seed = int(rng.integers(1 << 30))
    clean = AltitudeFilter()
    _hover(clean, np.random.default_rng(seed), 0.0, 20.0, seabed=15.0)
    spiky = AltitudeFilter()
    statuses = _hover(
        spiky, np.random.default_rng(seed), 0.0, 20.0, seabed=15.0,
        spikes={12.0: ("depth", 1.0), 14.1: ("altimeter", 5.0), 16.3: ("altimeter", -5.0)},
    )
    counters = spiky.counters
    assert counters["depth"].gated >= 1 and counters["altimeter"].gated >= 2
    assert "gated" in statuses["depth"] and statuses["altimeter"].count("gated") >= 2
    for t in (12.0, 14.1, 16.3, 19.9):
        assert spiky.altitude_at(t).mean == pytest.approx(clean.altitude_at(t).mean, abs=2e-3)
        assert spiky.depth_at(t).mean == pytest.approx(5.0, abs=0.01)


def test_altimeter_dropout_widens_variance_and_keeps_truth_within_3_sigma(rng: np.random.Generator) -> None:
    flt = AltitudeFilter(AltitudeFilterConfig(seabed_walk_psd_m2_s=1e-4))
    before = None
    for k in range(int(30 / 0.1)):
        t = round(0.1 * k, 9)
        flt.update_depth(t, 5.0 + 0.01 * rng.standard_normal(), 0.01)
        if k % 2 == 1 and not (20.0 <= t <= 23.0):
            flt.update_altimeter(t, 3.0 + 0.02 * rng.standard_normal(), 0.02)
        if t == 19.9:
            _, p = flt.filtered_state()
            before = ALT @ p @ ALT
        if 20.0 <= t <= 23.0:
            x, p = flt.filtered_state()
            var = ALT @ p @ ALT
            assert before is not None and var > before
            assert abs(ALT @ x - 3.0) <= 3.0 * math.sqrt(var)
    _, p = flt.filtered_state()
    assert before is not None and ALT @ p @ ALT < 1.5 * before  # and recovers after


def test_gate_warmup_lets_a_rough_start_converge() -> None:
    """Two depth samples 0.1 s apart with noise in opposite directions give a speed that
    is 3 sigma off; gating from the start rejects the samples that would correct it."""

    def statuses(warmup: int) -> list[str]:
        flt = AltitudeFilter(AltitudeFilterConfig(gate_warmup=warmup))
        out = [flt.update_depth(0.0, 4.98, 0.01).status, flt.update_depth(0.1, 5.03, 0.01).status]
        out += [flt.update_depth(0.1 * k, 5.0, 0.01).status for k in range(2, 30)]
        return out

    cold = statuses(0)
    assert "gated" in cold[:5] and "reinitialised" in cold
    warm = statuses(10)
    assert warm == ["accepted"] * 30


def test_sustained_seabed_change_is_believed_after_k_rejections(rng: np.random.Generator) -> None:
    config = AltitudeFilterConfig(reinit_after=5)
    flt = AltitudeFilter(config)
    _hover(flt, rng, 0.0, 20.0, seabed=8.0)
    statuses = _hover(flt, rng, 20.0, 30.0, seabed=7.0)  # a 1 m ledge under the vehicle
    alt = statuses["altimeter"]
    assert alt[:4] == ["gated"] * 4 and alt[4] == "reinitialised"
    assert flt.counters["altimeter"].reinitialised == 1
    assert flt.altitude_at(29.9).mean == pytest.approx(2.0, abs=0.01)
    # The history before the change is still the old seabed, and the smoother did not
    # smear the ledge backwards.
    assert flt.altitude_at(15.0).mean == pytest.approx(3.0, abs=0.01)
    # Across the reset dH is the ledge, with a variance that reflects it.
    dh = flt.delta_altitude(15.0, 29.0)
    assert dh.mean == pytest.approx(-1.0, abs=0.02)


def test_maneuver_flag_keeps_a_fast_step_consistent(rng: np.random.Generator) -> None:
    def errors(tell: bool) -> float:
        g = np.random.default_rng(7)
        dive = simulate_dive(g, accel_psd_m2_s3=1e-5, seabed_walk_psd_m2_s=1e-8, step_duration_s=2.0, wander=False)
        flt = run(AltitudeFilter(AltitudeFilterConfig(seabed_walk_psd_m2_s=1e-8)), dive, tell_maneuvers=tell)
        key = dive.key_times
        worst = 0.0
        for t in np.arange(key.step_start_s, key.step_end_s + 2.0, 0.1):
            x, p = flt.state_at(t)
            worst = max(worst, abs(x[0] - dive.truth_at(t)[0]) / math.sqrt(p[0, 0]))
        return worst

    assert errors(False) > 4.0  # the hold model cannot follow a 2 s step
    assert errors(True) < 3.5


@pytest.mark.parametrize(
    ("call", "args"),
    [
        ("update_depth", (1.0, math.nan, 0.01)),
        ("update_depth", (math.nan, 5.0, 0.01)),
        ("update_depth", (1.0, 5.0, 0.0)),
        ("update_depth", (1.0, 5.0, -0.01)),
        ("update_depth", (1.0, 5.0, math.inf)),
        ("update_pressure", (1.0, -5.0, 10.0)),
        ("update_pressure", (1.0, 0.0, 10.0)),
        ("update_pressure", (1.0, math.nan, 10.0)),
        ("update_altimeter", (1.0, -0.5, 0.02)),
        ("update_altimeter", (1.0, math.inf, 0.02)),
        ("update_altimeter", (1.0, 3.0, 0.0)),
        ("update_sonar_altitude", (1.0, -1.0, 0.05)),
        ("update_sonar_altitude", (1.0, math.nan, 0.05)),
    ],
)
def test_bad_input_raises_and_leaves_the_state_alone(
    rng: np.random.Generator, call: str, args: tuple[float, float, float]
) -> None:
    flt = AltitudeFilter(AltitudeFilterConfig(surface_pressure_pa=101_325.0))
    _hover(flt, rng, 0.0, 0.9)
    x, p = flt.filtered_state()
    counters = flt.counters
    with pytest.raises(MeasurementError) as info:
        getattr(flt, call)(*args)
    assert info.value.sensor in ("depth", "pressure", "altimeter", "sonar")
    x2, p2 = flt.filtered_state()
    assert np.array_equal(x, x2) and np.array_equal(p, p2)
    assert flt.counters == counters


def test_bad_signal_quality_raises_and_invalid_quality_is_counted() -> None:
    flt = AltitudeFilter(AltitudeFilterConfig(min_signal_quality=30))
    flt.update_depth(0.0, 5.0, 0.01)
    with pytest.raises(MeasurementError):
        flt.update_altimeter(0.1, 3.0, 0.02, signal_quality=101)
    assert flt.update_altimeter(0.1, 3.0, 0.02, signal_quality=1).status == "low_quality"
    assert flt.update_altimeter(0.2, 3.0, 0.02, signal_quality=20).status == "low_quality"
    assert flt.update_altimeter(0.3, 3.0, 0.02, signal_quality=0).accepted  # unknown
    assert flt.update_altimeter(0.4, 3.0, 0.02, signal_quality=90).accepted
    assert flt.update_altimeter(0.5, 50.0, 0.02, max_distance_m=50.0).status == "out_of_range"
    c = flt.counters["altimeter"]
    assert (c.low_quality, c.out_of_range, c.accepted) == (2, 1, 2)


def test_out_of_order_measurements_are_counted_not_used() -> None:
    flt = AltitudeFilter()
    flt.update_depth(1.0, 5.0, 0.01)
    flt.update_depth(2.0, 5.0, 0.01)
    x, p = flt.filtered_state()
    result = flt.update_depth(1.5, 9.0, 0.01)
    assert result.status == "out_of_order" and not result.accepted
    assert flt.counters["depth"].out_of_order == 1
    x2, p2 = flt.filtered_state()
    assert np.array_equal(x, x2) and np.array_equal(p, p2)
    # the same time again is a second update of that step, not out of order
    assert flt.update_altimeter(2.0, 3.0, 0.02).accepted


def test_queries_outside_the_window_raise() -> None:
    flt = AltitudeFilter(AltitudeFilterConfig(window_s=10.0, max_extrapolation_s=0.5))
    with pytest.raises(OutsideWindowError):
        flt.altitude_at(0.0)  # no data yet
    for k in range(300):
        flt.update_depth(0.1 * k, 5.0, 0.01)
        if k % 2:
            flt.update_altimeter(0.1 * k, 3.0, 0.02)
    start, end = flt.window_bounds_s
    assert 29.9 - 10.0 - 0.1 - 1e-9 <= start <= 29.9 - 10.0 + 1e-9  # bounded memory: 10 s kept
    assert end == pytest.approx(29.9 + 0.5)
    flt.altitude_at(start)
    flt.altitude_at(30.3)
    for bad in (start - 0.01, 30.5, math.nan):
        with pytest.raises(OutsideWindowError) as info:
            flt.altitude_at(bad)
        assert info.value.window_start_s == start
    with pytest.raises(OutsideWindowError):
        flt.delta_altitude(5.0, 25.0)


def test_pressure_updates_calibrate_the_surface_then_give_depth(rng: np.random.Generator) -> None:
    config = AltitudeFilterConfig(surface_pressure_pa=None, surface_samples=5, specific_gravity=1.024)
    flt = AltitudeFilter(config)
    surface = 101_000.0
    for k in range(5):
        assert flt.update_pressure(0.1 * k, surface + rng.normal(0.0, 5.0), 5.0).status == "calibration"
    assert flt.surface_pressure_pa == pytest.approx(surface, abs=10.0)
    p = float(pressure_from_depth_pa(12.0, surface_pressure_pa=surface, specific_gravity=1.024))
    for k in range(5, 50):
        assert flt.update_pressure(0.1 * k, p, 5.0).accepted
    assert flt.depth_at(4.9).mean == pytest.approx(12.0, abs=0.002)
    assert flt.counters["pressure"].calibration == 5


def test_config_rejects_nonsense() -> None:
    with pytest.raises(ValueError, match="accel_psd"):
        AltitudeFilterConfig(accel_psd_m2_s3=-1.0)
    with pytest.raises(ValueError, match="gate_probability"):
        AltitudeFilterConfig(gate_probability=1.0)
    with pytest.raises(ValueError):
        AltitudeFilterConfig(specific_gravity=3.0)
