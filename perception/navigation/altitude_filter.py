"""Vertical state filter: vehicle depth, vertical speed and seabed depth, with smoothing.

(Over 400 lines: one class, whose updates and smoothed queries share the stored filter
steps; its 60-line docstring states the whole model.)

The height solver needs the altitude change ``dH`` between two frame times and its
variance. This module estimates it from asynchronous depth (pressure) and altitude
(altimeter, sonar) measurements with a Kalman filter (:class:`filterpy.kalman.KalmanFilter`)
and answers queries from a Rauch-Tung-Striebel smoother over a retained window.

State ``x = [z, w, b]``:

- ``z`` depth of the vehicle's reference point, m, positive down (see
  :mod:`perception.geometry` for frames and signs);
- ``w = dz/dt`` vertical speed, m/s, positive descending;
- ``b`` depth of the seabed under the vehicle, m, positive down;
- optionally (``seabed_rate_psd_m2_s3``) ``r = db/dt``, m/s: the seabed slope times the
  ground speed, for flying over sloping ground.

Altitude is ``b - z`` (positive up from the seabed). All measurements must refer to the
same reference point (the sonar's acoustic centre is the natural one: it is the altitude
the height solver wants).

Process model, continuous white acceleration on ``z`` (power spectral density
``accel_psd_m2_s3``, or ``maneuver_accel_psd_m2_s3`` while the executor says it is
changing depth, :meth:`AltitudeFilter.set_maneuvering`) and a random walk on ``b``
(``seabed_walk_psd_m2_s``; and on ``r`` when present), discretised exactly for each
interval between measurements (:mod:`perception.navigation.smoother`).

Measurements (each optional, each at its own rate, each with its own noise):

- depth, ``H = [1, 0, 0(, 0)]``: from :meth:`AltitudeFilter.update_depth`, or from absolute
  pressure with :meth:`AltitudeFilter.update_pressure` (converted by
  :mod:`perception.navigation.pressure`);
- altitude, ``H = [-1, 0, 1(, 0)]``: :meth:`AltitudeFilter.update_altimeter` and
  :meth:`AltitudeFilter.update_sonar_altitude`.

Gating: a measurement whose normalised innovation squared ``y^2 / S`` exceeds
``chi2.ppf(gate_probability, 1)`` is rejected and counted; the state is untouched. The
first ``gate_warmup`` measurements of each sensor are not gated (from a diffuse prior the
first estimates, e.g. a speed from two depth samples, are too rough for a gate: a
rejection there starves the filter of the very data that would correct it). After
``reinit_after`` consecutive rejections of one sensor the filter believes it (the seabed
really changed under the vehicle, or the depth reference moved): it adds
``reinit_std_m**2`` of process noise to the state that sensor observes (``b`` for altitude
sensors; ``z``, with ``reinit_speed_std_m_s**2`` on ``w``, for depth sensors) and applies
the measurement. The extra noise is kept with that step, so the smoother stays exact
across the reset.

Queries (:meth:`AltitudeFilter.altitude_at`, :meth:`AltitudeFilter.depth_at`,
:meth:`AltitudeFilter.delta_altitude`, :meth:`AltitudeFilter.altitudes_at`) use the RTS
smoother (:class:`perception.navigation.smoother.WindowSmoother`) over the retained
window (``window_s`` seconds back from the latest measurement), so the answer at a
past time uses the measurements after it too. The variance of a difference comes from
the smoothed joint covariance ``Cov(x(t1), x(t2)) = G(t1 -> n1) G(n1 -> n2) ... P_s(t2)``,
the product of the smoother gains along the chain of filter steps between the two
times, not from the sum of two independent variances.

Bad input (NaN, non-positive noise or pressure, negative altitude) raises
:class:`perception.errors.MeasurementError` before anything changes. A measurement older
than the filter's latest step is counted as ``out_of_order`` and ignored."""

from __future__ import annotations

import math
from collections import deque

import numpy as np
from filterpy.kalman import KalmanFilter
from numpy.typing import ArrayLike
from scipy.stats import chi2

from perception.errors import MeasurementError, OutsideWindowError
from perception.navigation.filter_config import (
    SENSORS,
    AltitudeFilterConfig,
    Estimate,
    FloatArray,
    SensorCounters,
    UpdateResult,
    finite_measurement,
    positive_std,
)
from perception.navigation.pressure import (
    depth_from_pressure_m,
    pascals_per_metre,
    surface_pressure_from_samples_pa,
)
from perception.navigation.smoother import SAME_TIME_S, FilterStep, VerticalModel, WindowSmoother


class AltitudeFilter:
    """Depth, vertical speed and seabed depth from asynchronous measurements.

    Parameters
    ----------
    config : AltitudeFilterConfig, optional
        Settings; defaults when omitted.

    Notes
    -----
    Times are seconds on any fixed epoch (the caller's injected clock, or message
    timestamps); measurements must arrive in time order (older ones are counted as
    ``out_of_order`` and dropped). Not thread-safe: feed it from one thread.
    """

    def __init__(self, config: AltitudeFilterConfig | None = None):
        self.config = config if config is not None else AltitudeFilterConfig()
        c = self.config
        self._gate = float(chi2.ppf(c.gate_probability, 1))
        self._model = VerticalModel(c.seabed_walk_psd_m2_s, c.seabed_rate_psd_m2_s3)
        self._kf = KalmanFilter(dim_x=self._model.n_states, dim_z=1)
        self._steps: deque[FilterStep] = deque(maxlen=c.max_steps)
        self._counters = {name: SensorCounters() for name in SENSORS}
        self._consecutive = dict.fromkeys(SENSORS, 0)
        self._surface_pressure_pa = c.surface_pressure_pa
        self._surface_samples: list[float] = []
        self._rho_g = pascals_per_metre(specific_gravity=c.specific_gravity, gravity_m_s2=c.gravity_m_s2)
        self._smoothed: WindowSmoother | None = None
        self._accel_psd = c.accel_psd_m2_s3
        self._rate_released = False

    def set_maneuvering(self, maneuvering: bool) -> None:
        """Say whether the vehicle is now changing depth on purpose.

        From the next measurement on, the process noise uses
        ``maneuver_accel_psd_m2_s3`` (True) or ``accel_psd_m2_s3`` (False). The mission
        executor calls it when it commands a depth change and again when the vehicle has
        settled. The noise used is kept with each step, so smoothing stays exact.
        """
        c = self.config
        self._accel_psd = c.maneuver_accel_psd_m2_s3 if maneuvering else c.accel_psd_m2_s3

    def release_seabed_rate(self) -> None:
        """Say that the ground track has just changed (a new lane, a turn, a stop): the
        seabed's rate under the vehicle (slope times ground speed) is no longer what it
        was. At the next measurement the four-state model's ``db/dt`` gets
        ``initial_seabed_rate_std_m_s**2`` of process noise (kept with that step, as a
        reset's), so it is learnt again from the altimeter instead of gated against; the
        three-state model has no rate and ignores this."""
        self._rate_released = self._model.n_states == 4

    @property
    def model(self) -> VerticalModel:
        """The process model (number of states, measurement rows)."""
        return self._model

    # ------------------------------------------------------------------ properties
    @property
    def gate_threshold(self) -> float:
        """The chi-square (1 dof) bound on the normalised innovation squared."""
        return self._gate

    @property
    def surface_pressure_pa(self) -> float | None:
        """The surface pressure in use, Pa (``None`` until calibrated)."""
        return self._surface_pressure_pa

    @property
    def last_time_s(self) -> float:
        """Time of the latest filter step, s (NaN before any measurement)."""
        return self._steps[-1].time_s if self._steps else math.nan

    @property
    def window_bounds_s(self) -> tuple[float, float]:
        """(earliest, latest) time a query can ask for, s (NaN, NaN when empty)."""
        if not self._steps:
            return (math.nan, math.nan)
        return (self._steps[0].time_s, self._steps[-1].time_s + self.config.max_extrapolation_s)

    @property
    def counters(self) -> dict[str, SensorCounters]:
        """Per-sensor counters (a copy), keyed by the names in :data:`SENSORS`."""
        return {k: SensorCounters(**vars(v)) for k, v in self._counters.items()}

    def filtered_state(self) -> tuple[FloatArray, FloatArray]:
        """Latest filtered mean (n,) and covariance (n, n) of the state (copies; n = 3 or 4)."""
        if not self._steps:
            raise OutsideWindowError(math.nan, math.nan, math.nan)
        s = self._steps[-1]
        return s.x.copy(), s.p.copy()

    # ------------------------------------------------------------------ updates
    def update_depth(self, time_s: float, depth_m: float, std_m: float) -> UpdateResult:
        """A depth measurement (e.g. ``GLOBAL_POSITION_INT`` depth), m, positive down.

        Parameters
        ----------
        time_s : float
            Measurement time, s.
        depth_m : float
            Depth of the reference point below the surface, m (may be slightly negative
            at the surface).
        std_m : float
            Its noise standard deviation, m (> 0).
        """
        return self._update("depth", time_s, depth_m, std_m, altitude=False)

    def update_pressure(self, time_s: float, absolute_pressure_pa: float, std_pa: float) -> UpdateResult:
        """An absolute pressure measurement, Pa (``SCALED_PRESSURE2.press_abs`` is hPa:
        multiply by 100 first).

        Converted to depth with the surface pressure and the configured specific
        gravity. With ``surface_pressure_pa=None`` in the config, the first
        ``surface_samples`` samples calibrate the surface pressure (status
        ``"calibration"``) and are not used as depth measurements.

        Parameters
        ----------
        time_s : float
            Measurement time, s.
        absolute_pressure_pa : float
            Absolute pressure, Pa (> 0).
        std_pa : float
            Its noise standard deviation, Pa (> 0).
        """
        t = finite_measurement(time_s, "time", "pressure")
        p = finite_measurement(absolute_pressure_pa, "absolute pressure", "pressure")
        if p <= 0:
            raise MeasurementError(f"absolute pressure must be > 0 Pa, got {p!r}", sensor="pressure", value=p)
        s = positive_std(std_pa, "pressure")
        if self._surface_pressure_pa is None:
            self._surface_samples.append(p)
            self._counters["pressure"].calibration += 1
            if len(self._surface_samples) >= self.config.surface_samples:
                self._surface_pressure_pa = surface_pressure_from_samples_pa(self._surface_samples)
            return UpdateResult("calibration")
        depth = float(
            depth_from_pressure_m(
                p,
                surface_pressure_pa=self._surface_pressure_pa,
                specific_gravity=self.config.specific_gravity,
                gravity_m_s2=self.config.gravity_m_s2,
            )
        )
        return self._update("pressure", t, depth, s / self._rho_g, altitude=False)

    def update_altimeter(
        self,
        time_s: float,
        altitude_m: float,
        std_m: float,
        signal_quality: int | None = None,
        *,
        min_distance_m: float | None = None,
        max_distance_m: float | None = None,
    ) -> UpdateResult:
        """An altimeter reading (``DISTANCE_SENSOR``/``RANGEFINDER`` after cm -> m).

        Parameters
        ----------
        time_s : float
            Measurement time, s.
        altitude_m : float
            Height of the reference point above the seabed, m (>= 0).
        std_m : float
            Noise standard deviation, m (> 0).
        signal_quality : int, optional
            MAVLink signal quality, percent: 0 unknown, 1 invalid, 100 perfect.
        min_distance_m, max_distance_m : float, optional
            The sensor's valid span; readings outside it are rejected as
            ``out_of_range`` (a reading at the maximum means "no bottom").
        """
        t = finite_measurement(time_s, "time", "altimeter")
        a = finite_measurement(altitude_m, "altitude", "altimeter")
        positive_std(std_m, "altimeter")
        if a < 0:
            raise MeasurementError(f"altitude must be >= 0 m, got {a!r}", sensor="altimeter", value=a)
        if signal_quality is not None:
            if not (isinstance(signal_quality, int | np.integer) and 0 <= signal_quality <= 100):
                raise MeasurementError(
                    f"signal quality must be an integer 0..100, got {signal_quality!r}",
                    sensor="altimeter",
                    value=signal_quality,
                )
            if signal_quality == 1 or (signal_quality >= 2 and signal_quality < self.config.min_signal_quality):
                self._counters["altimeter"].low_quality += 1
                return UpdateResult("low_quality")
        if (min_distance_m is not None and a < min_distance_m) or (
            max_distance_m is not None and a >= max_distance_m
        ):
            self._counters["altimeter"].out_of_range += 1
            return UpdateResult("out_of_range")
        return self._altitude("altimeter", t, a, std_m)

    def update_sonar_altitude(self, time_s: float, altitude_m: float, std_m: float) -> UpdateResult:
        """Altitude measured from a sonar frame (see :mod:`perception.navigation.seabed_start`), m."""
        t = finite_measurement(time_s, "time", "sonar")
        a = finite_measurement(altitude_m, "altitude", "sonar")
        return self._altitude("sonar", t, a, std_m)

    def _altitude(self, sensor: str, time_s: float, altitude_m: float, std_m: float) -> UpdateResult:
        if altitude_m < 0:
            raise MeasurementError(f"altitude must be >= 0 m, got {altitude_m!r}", sensor=sensor, value=altitude_m)
        return self._update(sensor, time_s, altitude_m, std_m, altitude=True)

    def _update(self, sensor: str, time_s: float, z_m: float, std_m: float, *, altitude: bool) -> UpdateResult:
        t = finite_measurement(time_s, "time", sensor)
        z = finite_measurement(z_m, "measurement", sensor)
        r = positive_std(std_m, sensor) ** 2
        counters = self._counters[sensor]
        c = self.config
        kf = self._kf
        model = self._model
        n = model.n_states
        h = (model.altitude_row if altitude else model.depth_row).reshape(1, n)
        if not self._steps:
            # The prior, at the first measurement's time; that measurement updates it.
            x0 = np.zeros(n)
            stds = [c.initial_depth_std_m, c.initial_speed_std_m_s, c.initial_seabed_std_m]
            if n == 4:
                stds.append(c.initial_seabed_rate_std_m_s)
            p0 = np.diag(stds) ** 2
            self._steps.append(FilterStep(t, x0, p0, self._accel_psd, x0, p0, np.zeros((n, n))))
        last = self._steps[-1]
        if t < last.time_s - SAME_TIME_S:
            counters.out_of_order += 1
            return UpdateResult("out_of_order")
        dt = max(t - last.time_s, 0.0)
        # A second measurement at the same time updates that step again (no prediction).
        same_step = dt <= SAME_TIME_S
        f = model.transition(dt)
        kf.x, kf.P = last.x.reshape(n, 1).copy(), last.p.copy()
        if not same_step:
            kf.predict(F=f, Q=model.noise(dt, self._accel_psd))
        q_extra = None
        if self._rate_released:
            # The rate's release (release_seabed_rate): process noise at this time, a step
            # of its own (the flag stays up until a step keeps it: a gated measurement does not).
            q_extra = np.zeros((n, n))
            q_extra[3, 3] = c.initial_seabed_rate_std_m_s**2
            kf.P = kf.P + q_extra
            same_step = False
        x_prior, p_prior = kf.x.reshape(n).copy(), kf.P.copy()
        innovation = z - float((h @ kf.x)[0, 0])
        s = float((h @ kf.P @ h.T)[0, 0]) + r
        nis = innovation * innovation / s
        status = "accepted"
        warming_up = counters.accepted + counters.reinitialised < c.gate_warmup
        if nis > self._gate and not warming_up:
            self._consecutive[sensor] += 1
            if self._consecutive[sensor] < c.reinit_after:
                counters.gated += 1
                return UpdateResult("gated", nis)
            reset = np.zeros((n, n))
            if altitude:  # the seabed depth
                reset[2, 2] = c.reinit_std_m**2
            else:  # the vehicle depth and speed
                reset[0, 0] = c.reinit_std_m**2
                reset[1, 1] = c.reinit_speed_std_m_s**2
            kf.P = kf.P + reset
            q_extra = reset if q_extra is None else q_extra + reset
            p_prior = kf.P.copy()
            # A reset is process noise at this time: a step of its own (zero interval)
            # when the step at this time already holds a measurement.
            same_step = False
            status = "reinitialised"
            counters.reinitialised += 1
        else:
            counters.accepted += 1
        self._consecutive[sensor] = 0
        self._rate_released = False
        kf.update(np.array([[z]]), R=np.array([[r]]), H=h)
        x_new = kf.x.reshape(n).copy()
        p_new = 0.5 * (kf.P + kf.P.T)
        if same_step:
            last.x, last.p = x_new, p_new
        else:
            gain = last.p @ f.T @ np.linalg.inv(p_prior)
            self._steps.append(FilterStep(t, x_new, p_new, self._accel_psd, x_prior, p_prior, gain, q_extra))
            self._prune()
        self._smoothed = None
        return UpdateResult(status, nis)

    def _prune(self) -> None:
        horizon = self._steps[-1].time_s - self.config.window_s
        while len(self._steps) > 2 and self._steps[1].time_s <= horizon:
            self._steps.popleft()

    # ------------------------------------------------------------------ queries
    def _smooth(self) -> WindowSmoother:
        if self._smoothed is None:
            self._smoothed = WindowSmoother(
                self._steps,  # not copied: every change of the steps drops the smoother
                model=self._model,
                current_accel_psd=self._accel_psd,
            )
        return self._smoothed

    def _check_time(self, time_s: float) -> float:
        t = float(time_s)
        start, end = self.window_bounds_s
        if not self._steps or not (math.isfinite(t) and start - SAME_TIME_S <= t <= end + SAME_TIME_S):
            raise OutsideWindowError(t, start, end)
        return t

    def state_at(self, time_s: float) -> tuple[FloatArray, FloatArray]:
        """Smoothed mean (n,) and covariance (n, n) of the state at a time in the window.

        Raises
        ------
        OutsideWindowError
            When ``time_s`` is before the retained window or more than
            ``max_extrapolation_s`` past the latest step.
        """
        t = self._check_time(time_s)
        _, x, p = self._smooth().node(t)
        return x.copy(), p.copy()

    def altitude_at(self, time_s: float) -> Estimate:
        """Smoothed altitude above the seabed at ``time_s``: mean (m) and variance (m^2)."""
        x, p = self.state_at(time_s)
        a = self._model.altitude_row
        return Estimate(float(a @ x), float(a @ p @ a))

    def depth_at(self, time_s: float) -> Estimate:
        """Smoothed depth at ``time_s``: mean (m, positive down) and variance (m^2)."""
        x, p = self.state_at(time_s)
        return Estimate(float(x[0]), float(p[0, 0]))

    def altitudes_at(self, times_s: ArrayLike) -> tuple[FloatArray, FloatArray]:
        """Joint smoothed altitudes at several times.

        Parameters
        ----------
        times_s : array_like, shape (n,)
            Times inside the window, s, any order.

        Returns
        -------
        mean : ndarray, shape (n,)
            Altitudes, m.
        cov : ndarray, shape (n, n)
            Their joint covariance, m^2.
        """
        times = np.asarray(times_s, dtype=np.float64).ravel()
        for t in times:
            self._check_time(float(t))
        sm = self._smooth()
        row = self._model.altitude_row
        n = times.size
        mean = np.empty(n)
        cov = np.empty((n, n))
        for i in range(n):
            _, x, p = sm.node(float(times[i]))
            mean[i] = row @ x
            cov[i, i] = row @ p @ row
            for j in range(i + 1, n):
                early, late = (i, j) if times[i] <= times[j] else (j, i)
                cross = sm.cross(float(times[early]), float(times[late]))
                cov[i, j] = cov[j, i] = row @ cross @ row
        return mean, cov

    def _delta(self, t1: float, t2: float, h: FloatArray) -> Estimate:
        a = self._check_time(t1)
        b = self._check_time(t2)
        sm = self._smooth()
        sign = 1.0
        if b < a:
            a, b, sign = b, a, -1.0
        _, x1, p1 = sm.node(a)
        _, x2, p2 = sm.node(b)
        cross = sm.cross(a, b)
        var = float(h @ p1 @ h + h @ p2 @ h - 2.0 * (h @ cross @ h))
        return Estimate(sign * float(h @ (x2 - x1)), max(var, 0.0))

    def delta_altitude(self, t1_s: float, t2_s: float) -> Estimate:
        """``altitude(t2) - altitude(t1)`` (positive when the vehicle rose) and its variance.

        The variance is ``Var(a1) + Var(a2) - 2 Cov(a1, a2)`` from the smoothed joint
        covariance.
        """
        return self._delta(t1_s, t2_s, self._model.altitude_row)

    def delta_depth(self, t1_s: float, t2_s: float) -> Estimate:
        """``depth(t2) - depth(t1)`` (positive when the vehicle descended) and its variance."""
        return self._delta(t1_s, t2_s, self._model.depth_row)
