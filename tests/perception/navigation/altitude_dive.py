"""A simulated dive for the altitude filter tests: descent, hold, 0.1 m step up, hold.

Truth is exact at every measurement time: the commanded profile (smooth cosine ramps)
plus, optionally, a wander drawn from the filter's own process model (white acceleration
of a given PSD on depth, a random walk on the seabed depth), sampled exactly between
event times. Measurements are truth plus Gaussian noise.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from perception.navigation.altitude_filter import AltitudeFilter, UpdateResult
from perception.navigation.smoother import process_noise, transition

START_DEPTH_M = 2.0
HOLD_DEPTH_M = 4.0
DESCENT_S = 20.0
HOLD_S = 12.0
STEP_M = -0.1  # depth change: the vehicle rises 0.1 m, so altitude grows by 0.1 m
SEABED_DEPTH_M = 10.0


@dataclass(frozen=True)
class DiveTimes:
    """Key times of the dive, s."""

    step_start_s: float
    step_end_s: float
    end_s: float


def dive_times(step_duration_s: float) -> DiveTimes:
    step_start = DESCENT_S + HOLD_S
    step_end = step_start + step_duration_s
    return DiveTimes(step_start, step_end, step_end + HOLD_S)


def _smoothstep(t: np.ndarray, t0: float, duration: float) -> tuple[np.ndarray, np.ndarray]:
    s = np.clip((t - t0) / duration, 0.0, 1.0)
    inside = (t > t0) & (t < t0 + duration)
    value = 0.5 - 0.5 * np.cos(np.pi * s)
    rate = np.where(inside, 0.5 * np.pi / duration * np.sin(np.pi * s), 0.0)
    return value, rate


def profile(t: np.ndarray, step_duration_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Commanded depth (m) and vertical speed (m/s) at times ``t``."""
    times = dive_times(step_duration_s)
    d1, r1 = _smoothstep(t, 0.0, DESCENT_S)
    d2, r2 = _smoothstep(t, times.step_start_s, step_duration_s)
    depth = START_DEPTH_M + (HOLD_DEPTH_M - START_DEPTH_M) * d1 + STEP_M * d2
    speed = (HOLD_DEPTH_M - START_DEPTH_M) * r1 + STEP_M * r2
    return depth, speed


@dataclass(frozen=True)
class Dive:
    """Measurement events in time order and the truth ``[z, w, b]`` at each."""

    times_s: np.ndarray  # (n,)
    sensors: tuple[str, ...]  # "depth" or "altimeter"
    values_m: np.ndarray  # (n,)
    stds_m: np.ndarray  # (n,)
    truth: np.ndarray  # (n, 3)
    step_duration_s: float

    @property
    def key_times(self) -> DiveTimes:
        return dive_times(self.step_duration_s)

    def truth_at(self, t: float) -> np.ndarray:
        """Truth at an event time (exact) or interpolated between events."""
        return np.array([np.interp(t, self.times_s, self.truth[:, i]) for i in range(3)])


def simulate_dive(
    rng: np.random.Generator,
    *,
    accel_psd_m2_s3: float,
    seabed_walk_psd_m2_s: float,
    step_duration_s: float = 8.0,
    depth_std_m: float = 0.01,
    depth_rate_hz: float = 10.0,
    altimeter_std_m: float = 0.02,
    altimeter_rate_hz: float = 5.0,
    wander: bool = True,
) -> Dive:
    end = dive_times(step_duration_s).end_s
    depth_t = np.arange(0.0, end, 1.0 / depth_rate_hz)
    alt_t = np.arange(0.5 / altimeter_rate_hz, end, 1.0 / altimeter_rate_hz)
    times = np.concatenate([depth_t, alt_t])
    kinds = np.array(["depth"] * depth_t.size + ["altimeter"] * alt_t.size)
    order = np.argsort(times, kind="stable")
    times, kinds = times[order], kinds[order]
    n = times.size
    wander_state = np.zeros(3)
    wander_state[2] = SEABED_DEPTH_M
    truth = np.empty((n, 3))
    for i in range(n):
        if i > 0 and wander:
            dt = times[i] - times[i - 1]
            q = process_noise(dt, accel_psd_m2_s3=accel_psd_m2_s3, seabed_walk_psd_m2_s=seabed_walk_psd_m2_s)
            noise = rng.multivariate_normal(np.zeros(3), q) if dt > 0 else np.zeros(3)
            wander_state = transition(dt) @ wander_state + noise
        truth[i] = wander_state
    depth, speed = profile(times, step_duration_s)
    truth[:, 0] += depth
    truth[:, 1] += speed
    stds = np.where(kinds == "depth", depth_std_m, altimeter_std_m)
    clean = np.where(kinds == "depth", truth[:, 0], truth[:, 2] - truth[:, 0])
    values = clean + stds * rng.standard_normal(n)
    return Dive(times, tuple(str(k) for k in kinds), values, stds, truth, step_duration_s)


def in_maneuver(t: float, times: DiveTimes) -> bool:
    """True during the commanded descent and the commanded step."""
    return t <= DESCENT_S or times.step_start_s <= t <= times.step_end_s


def feed(
    flt: AltitudeFilter,
    dive: Dive,
    *,
    skip: tuple[float, float] | None = None,
    tell_maneuvers: bool = True,
) -> Iterator[tuple[int, UpdateResult]]:
    """Feed the events (except altimeter events inside ``skip``) to the filter, one at a
    time, yielding the event index and the result after each. With ``tell_maneuvers``
    the filter is told when the depth changes are commanded, as the executor does."""
    times = dive.key_times
    for i, (t, kind) in enumerate(zip(dive.times_s, dive.sensors, strict=True)):
        if tell_maneuvers:
            flt.set_maneuvering(in_maneuver(t, times))
        if kind == "depth":
            yield i, flt.update_depth(t, dive.values_m[i], dive.stds_m[i])
        elif skip is None or not (skip[0] <= t <= skip[1]):
            yield i, flt.update_altimeter(t, dive.values_m[i], dive.stds_m[i])


def run(
    flt: AltitudeFilter, dive: Dive, *, skip: tuple[float, float] | None = None, tell_maneuvers: bool = True
) -> AltitudeFilter:
    """Feed the whole dive; return the filter."""
    deque(feed(flt, dive, skip=skip, tell_maneuvers=tell_maneuvers), maxlen=0)  # drain the generator
    return flt


def nees(x: np.ndarray, p: np.ndarray, truth: np.ndarray) -> float:
    err = x - truth
    return float(err @ np.linalg.solve(p, err))


def chi2_interval(dof: int, runs: int, probability: float = 0.95) -> tuple[float, float]:
    """Two-sided bounds on the average of ``runs`` chi-square(dof) variables."""
    from scipy.stats import chi2

    tail = (1.0 - probability) / 2.0
    lo, hi = chi2.ppf([tail, 1.0 - tail], dof * runs)
    return float(lo) / runs, float(hi) / runs
