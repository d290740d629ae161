"""Monte Carlo consistency of the altitude filter on a simulated dive.

Dive: descent 2 -> 4 m, hold, 0.1 m step up over 8 s, hold; seabed at 10 m. Depth 1 cm
at 10 Hz, altimeter 2 cm at 5 Hz. The vehicle's uncommanded wander and the seabed are
drawn from the filter's own process model; the executor tells the filter when it
commands the descent and the step (``set_maneuvering``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest
from scipy.stats import chi2

from perception.navigation.altitude_filter import AltitudeFilter, AltitudeFilterConfig
from tests.perception.navigation.altitude_dive import chi2_interval, feed, in_maneuver, nees, simulate_dive

RUNS = 40
HOLD_PSD = 1e-5
MANEUVER_PSD = 3e-4
SEABED_PSD = 1e-8
CONFIG = AltitudeFilterConfig(
    accel_psd_m2_s3=HOLD_PSD, maneuver_accel_psd_m2_s3=MANEUVER_PSD, seabed_walk_psd_m2_s=SEABED_PSD
)
SETTLE_S = 5.0  # the diffuse prior needs a few seconds before NEES means anything
# The run-averaged NEES/NIS at one time lies in its 95 % interval with probability 0.95.
# Errors are correlated in time (the seabed estimate most of all), so the averages at
# neighbouring times move together and the fraction of times inside the interval
# scatters between seeds (0.80-0.97 over 16 seeds tried for the NEES); the mean over
# the times is a time average of such averages, so it stays inside the same interval.
# The fractions below flag gross inconsistency (a filter off by 2x in variance has almost
# no time inside), the means test the level.
MIN_FRACTION_NEES = 0.7
MIN_FRACTION_NIS = 0.85


@dataclass
class MonteCarlo:
    times_s: np.ndarray  # event times (same in every run)
    sensors: tuple[str, ...]
    hold: np.ndarray  # bool per event: not in a commanded maneuver, after settling
    maneuver: np.ndarray
    filtered_nees: np.ndarray  # (runs, events)
    nis: np.ndarray  # (runs, events)
    smoothed_nees: np.ndarray  # (runs, grid)
    dh_error_m: np.ndarray  # (runs,)
    dh_var_m2: np.ndarray
    dh_independent_var_m2: np.ndarray


@pytest.fixture(scope="module")
def monte_carlo() -> MonteCarlo:
    rng = np.random.default_rng(20261123)
    fn, ni, sn, err, var, ind = [], [], [], [], [], []
    dive = None
    for _ in range(RUNS):
        dive = simulate_dive(rng, accel_psd_m2_s3=HOLD_PSD, seabed_walk_psd_m2_s=SEABED_PSD)
        flt = AltitudeFilter(CONFIG)
        run_nees = np.full(dive.times_s.size, np.nan)
        run_nis = np.full(dive.times_s.size, np.nan)
        for i, result in feed(flt, dive):
            # about 0.3 % of good measurements fall outside the 99.7 % gate
            assert result.status in ("accepted", "gated")
            x, p = flt.filtered_state()
            run_nees[i] = nees(x, p, dive.truth[i])
            run_nis[i] = result.nis
        key = dive.key_times
        grid = np.arange(SETTLE_S, key.end_s, 1.0)
        sn.append([nees(*flt.state_at(t), dive.truth_at(t)) for t in grid])
        t1, t2 = key.step_start_s - 5.0, key.step_end_s + 5.0
        estimate = flt.delta_altitude(t1, t2)
        truth1, truth2 = dive.truth_at(t1), dive.truth_at(t2)
        err.append(estimate.mean - ((truth2[2] - truth2[0]) - (truth1[2] - truth1[0])))
        var.append(estimate.variance)
        ind.append(flt.altitude_at(t1).variance + flt.altitude_at(t2).variance)
        fn.append(run_nees)
        ni.append(run_nis)
    assert dive is not None
    key = dive.key_times
    man = np.array([in_maneuver(t, key) for t in dive.times_s])
    settled = dive.times_s > SETTLE_S
    return MonteCarlo(
        dive.times_s, dive.sensors, ~man & settled, man & settled, np.array(fn), np.array(ni),
        np.array(sn), np.array(err), np.array(var), np.array(ind),
    )


@pytest.mark.slow
def test_filtered_nees_within_95_percent_bounds_while_holding(monte_carlo: MonteCarlo) -> None:
    lo, hi = chi2_interval(3, RUNS)
    avg = monte_carlo.filtered_nees.mean(axis=0)[monte_carlo.hold]
    inside = (avg > lo) & (avg < hi)
    assert inside.mean() >= MIN_FRACTION_NEES, f"only {inside.mean():.2f} of hold times inside [{lo:.2f}, {hi:.2f}]"
    assert lo < avg.mean() < hi


@pytest.mark.slow
def test_filtered_nees_never_optimistic_during_commanded_maneuvers(monte_carlo: MonteCarlo) -> None:
    # A deterministic manoeuvre is not white noise: the filter may be conservative there,
    # but it must not claim more precision than it has.
    _, hi = chi2_interval(3, RUNS)
    avg = monte_carlo.filtered_nees.mean(axis=0)[monte_carlo.maneuver]
    assert (avg > hi).mean() <= 0.05, f"max average NEES {avg.max():.2f} > {hi:.2f}"


@pytest.mark.slow
@pytest.mark.parametrize("sensor", ["depth", "altimeter"])
def test_nis_within_95_percent_bounds(monte_carlo: MonteCarlo, sensor: str) -> None:
    lo, hi = chi2_interval(1, RUNS)
    mine = np.array([s == sensor for s in monte_carlo.sensors]) & monte_carlo.hold
    avg = monte_carlo.nis.mean(axis=0)[mine]
    inside = (avg > lo) & (avg < hi)
    assert inside.mean() >= MIN_FRACTION_NIS, f"{sensor}: only {inside.mean():.2f} of times inside [{lo:.2f}, {hi:.2f}]"
    assert lo < avg.mean() < hi


@pytest.mark.slow
def test_smoothed_nees_not_optimistic(monte_carlo: MonteCarlo) -> None:
    _, hi = chi2_interval(3, RUNS)
    avg = monte_carlo.smoothed_nees.mean(axis=0)
    assert (avg > hi).mean() <= 1.0 - MIN_FRACTION_NEES
    assert avg.mean() < hi


@pytest.mark.slow
def test_dh_across_step_has_std_below_3_mm(monte_carlo: MonteCarlo) -> None:
    reported_std = np.sqrt(monte_carlo.dh_var_m2)
    assert np.all(reported_std <= 0.003), f"reported dH std up to {reported_std.max() * 1e3:.2f} mm"
    # The Monte Carlo spread must not reject "true std <= 3 mm" at the 1 % level (the RMS
    # of RUNS errors scatters by about 1 / sqrt(2 RUNS) around the true std).
    empirical_std = float(np.sqrt(np.mean(monte_carlo.dh_error_m**2)))
    limit = 0.003 * float(np.sqrt(chi2.ppf(0.99, RUNS) / RUNS))
    assert empirical_std <= limit, f"Monte Carlo dH error RMS {empirical_std * 1e3:.2f} mm > {limit * 1e3:.2f} mm"


@pytest.mark.slow
def test_dh_variance_uses_the_joint_covariance(monte_carlo: MonteCarlo) -> None:
    # Positive correlation of the two altitudes (shared seabed, smoothing) makes the
    # joint variance smaller than the independent sum ...
    assert np.all(monte_carlo.dh_var_m2 < 0.9 * monte_carlo.dh_independent_var_m2)
    # ... and the Monte Carlo spread agrees with it (99 % chi-square interval on the
    # ratio of the mean squared error to the reported variance).
    ratio = np.mean(monte_carlo.dh_error_m**2 / monte_carlo.dh_var_m2)
    lo, hi = chi2.ppf([0.005, 0.995], RUNS) / RUNS
    assert lo < ratio < hi, f"MSE / reported variance = {ratio:.2f} outside [{lo:.2f}, {hi:.2f}]"
    bias = abs(float(np.mean(monte_carlo.dh_error_m)))
    assert bias < 3.0 * float(np.sqrt(np.mean(monte_carlo.dh_var_m2) / RUNS))
