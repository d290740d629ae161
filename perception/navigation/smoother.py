"""The altitude filter's process model, its stored steps and the smoother over them.

State ``x = [z, w, b]``: vehicle depth (m, positive down), vertical speed (m/s, positive
descending), seabed depth (m, positive down); with a seabed-rate model a fourth state
``r = db/dt`` (m/s: the seabed slope times the vehicle's ground speed, for a vehicle
flying over sloping ground). See :mod:`perception.navigation.altitude_filter`.

:class:`WindowSmoother` is a Rauch-Tung-Striebel smoother over the retained filter steps.
It answers at any time inside the window, also between steps (a "virtual" step: predict
from the step before, then smooth with the gain to the step after) and a little past the
last step (prediction). Cross-covariances of two times come from the backward Markov
form of the smoothed chain: ``x(t_i) = G_i x(t_{i+1}) + e_i`` with ``e_i`` independent
of everything later, so ``Cov(x(t1), x(t2)) = G(t1 -> n1) G(n1 -> n2) ... P_s(t2)``.
"""

from __future__ import annotations

import bisect
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]

#: Times closer than this are the same filter step, s.
SAME_TIME_S = 1e-9


def transition(dt_s: float, n_states: int = 3) -> FloatArray:
    """State transition over ``dt_s`` seconds, shape (n_states, n_states), 3 or 4 states."""
    f = np.eye(n_states)
    f[0, 1] = dt_s
    if n_states == 4:
        f[2, 3] = dt_s
    return f


def process_noise(
    dt_s: float,
    *,
    accel_psd_m2_s3: float,
    seabed_walk_psd_m2_s: float,
    seabed_rate_psd_m2_s3: float | None = None,
) -> FloatArray:
    """Exact discrete process noise over ``dt_s`` seconds, SI units.

    White acceleration of PSD ``accel_psd_m2_s3`` on depth, a random walk of PSD
    ``seabed_walk_psd_m2_s`` on the seabed depth and, when ``seabed_rate_psd_m2_s3`` is
    given (4 states), a random walk of that PSD on the seabed rate. Exact
    discretisation, so intervals compose: ``Q(a + b) = F(b) Q(a) F(b)^T + Q(b)``.
    Shape (3, 3), or (4, 4) with a seabed rate.
    """
    n = 3 if seabed_rate_psd_m2_s3 is None else 4
    out = np.zeros((n, n))
    q = accel_psd_m2_s3
    out[:2, :2] = [[q * dt_s**3 / 3.0, q * dt_s**2 / 2.0], [q * dt_s**2 / 2.0, q * dt_s]]
    out[2, 2] = seabed_walk_psd_m2_s * dt_s
    if seabed_rate_psd_m2_s3 is not None:
        r = seabed_rate_psd_m2_s3
        out[2:, 2:] += [[r * dt_s**3 / 3.0, r * dt_s**2 / 2.0], [r * dt_s**2 / 2.0, r * dt_s]]
    return out


@dataclass(frozen=True)
class VerticalModel:
    """The process model's fixed part: the seabed noise and hence the number of states."""

    seabed_walk_psd_m2_s: float
    seabed_rate_psd_m2_s3: float | None = None

    @property
    def n_states(self) -> int:
        """3 (``[z, w, b]``) or 4 (``[z, w, b, db/dt]``)."""
        return 3 if self.seabed_rate_psd_m2_s3 is None else 4

    @property
    def depth_row(self) -> FloatArray:
        """Depth as a linear function of the state, shape (n_states,)."""
        row = np.zeros(self.n_states)
        row[0] = 1.0
        return row

    @property
    def altitude_row(self) -> FloatArray:
        """Altitude ``b - z`` as a linear function of the state, shape (n_states,)."""
        row = np.zeros(self.n_states)
        row[0], row[2] = -1.0, 1.0
        return row

    def transition(self, dt_s: float) -> FloatArray:
        """State transition over ``dt_s``."""
        return transition(dt_s, self.n_states)

    def noise(self, dt_s: float, accel_psd_m2_s3: float) -> FloatArray:
        """Process noise over ``dt_s`` with the given acceleration PSD."""
        return process_noise(
            dt_s,
            accel_psd_m2_s3=accel_psd_m2_s3,
            seabed_walk_psd_m2_s=self.seabed_walk_psd_m2_s,
            seabed_rate_psd_m2_s3=self.seabed_rate_psd_m2_s3,
        )


@dataclass
class FilterStep:
    """One filter step: the filtered estimate at ``time_s`` and how it follows the previous.

    ``x``/``p`` are the filtered mean (n,) and covariance (n, n); ``x_prior``/``p_prior``
    the prediction from the previous step (``p_prior`` including any reset noise
    ``q_extra``); ``gain_prev`` the RTS gain of the previous step,
    ``P_prev F^T inv(p_prior)``; ``accel_psd`` the acceleration PSD used over the
    interval ending here, m^2/s^3.
    """

    time_s: float
    x: FloatArray
    p: FloatArray
    accel_psd: float
    x_prior: FloatArray
    p_prior: FloatArray
    gain_prev: FloatArray
    q_extra: FloatArray | None = None  # reset noise added at this step, (n, n)


def _time_of(step: FilterStep) -> float:
    return step.time_s


class _Times:
    """The steps' times, read through the steps (no copy: the filter's own deque of steps
    is handed over as it is, and copying 120 s of steps at every filter step was most of
    the smoother's cost)."""

    def __init__(self, steps: Sequence[FilterStep]):
        self._steps = steps

    def __getitem__(self, k: int) -> float:
        return self._steps[k].time_s

    def __len__(self) -> int:
        return len(self._steps)


class WindowSmoother:
    """RTS smoother over a list of :class:`FilterStep`, run backwards on demand.

    The gains were computed by the forward filter (they depend on filtered quantities
    only), so the backward pass is a few 3 x 3 products per step and goes only as far
    back as a query needs. Valid until the filter's next step.

    Parameters
    ----------
    steps : sequence of FilterStep
        In time order (equal times allowed: a reset step after a measurement step); not
        copied, so not to be changed while the smoother is in use.
    model : VerticalModel
        The filter's process model.
    current_accel_psd : float
        The acceleration PSD the filter would use past its last step.
    """

    def __init__(self, steps: Sequence[FilterStep], *, model: VerticalModel, current_accel_psd: float):
        self.steps = steps
        self.times = _Times(steps)
        self.model = model
        self._current_psd = current_accel_psd
        n = len(steps)
        self._x: list[FloatArray] = [steps[-1].x] * n
        self._p: list[FloatArray] = [steps[-1].p] * n
        self._lowest = n - 1
        #: Answers of :meth:`node` by time (a control cycle asks the same time for the
        #: altitude, the depth and the frame's stamp); valid as long as the smoother.
        self._nodes: dict[float, tuple[int, FloatArray, FloatArray]] = {}

    # ------------------------------------------------------------------ stored steps
    def _extend(self, k: int) -> None:
        for j in range(self._lowest - 1, k - 1, -1):
            nxt = self.steps[j + 1]
            g = nxt.gain_prev
            self._x[j] = self.steps[j].x + g @ (self._x[j + 1] - nxt.x_prior)
            p = self.steps[j].p + g @ (self._p[j + 1] - nxt.p_prior) @ g.T
            self._p[j] = 0.5 * (p + p.T)
        self._lowest = min(self._lowest, k)

    def x(self, k: int) -> FloatArray:
        """Smoothed mean at step ``k``, shape (n,)."""
        if k < self._lowest:
            self._extend(k)
        return self._x[k]

    def p(self, k: int) -> FloatArray:
        """Smoothed covariance at step ``k``, shape (n, n)."""
        if k < self._lowest:
            self._extend(k)
        return self._p[k]

    # ------------------------------------------------------------------ any time
    def _q(self, dt_s: float, k: int) -> FloatArray:
        """Process noise over ``dt_s`` inside the interval after step ``k``."""
        psd = self.steps[k + 1].accel_psd if k + 1 < len(self.steps) else self._current_psd
        return self.model.noise(dt_s, psd)

    def _filtered_at(self, k: int, dt_s: float) -> tuple[FloatArray, FloatArray]:
        """Filtered mean and covariance ``dt_s`` after step ``k`` (no measurement between)."""
        step = self.steps[k]
        f = self.model.transition(dt_s)
        return f @ step.x, f @ step.p @ f.T + self._q(dt_s, k)

    def _prior(self, k: int, t_from: float, xf: FloatArray, pf: FloatArray, t_to: float) -> tuple[
        FloatArray, FloatArray, FloatArray
    ]:
        """Prediction from ``t_from`` (filtered ``xf``, ``pf``) to ``t_to``, both inside the
        interval after step ``k`` (``t_to`` may be step ``k + 1`` itself, whose reset noise
        then counts), and the smoother gain between them: (x_prior, p_prior, gain)."""
        dt = t_to - t_from
        f = self.model.transition(dt)
        p_prior = f @ pf @ f.T + self._q(dt, k)
        extra = self.steps[k + 1].q_extra if k + 1 < len(self.steps) else None
        if extra is not None and t_to >= self.times[k + 1] - SAME_TIME_S:
            p_prior = p_prior + extra
        return f @ xf, p_prior, pf @ f.T @ np.linalg.inv(p_prior)

    def node(self, t: float) -> tuple[int, FloatArray, FloatArray]:
        """Smoothed mean (n,) and covariance (n, n) at ``t``, and the index of the last
        step at or before ``t``. The caller keeps ``t`` inside the window (and does not
        modify the arrays: a second question at ``t`` gets the same ones)."""
        known = self._nodes.get(t)
        if known is not None:
            return known
        answer = self._node(t)
        if len(self._nodes) < 64:
            self._nodes[t] = answer
        return answer

    def _node(self, t: float) -> tuple[int, FloatArray, FloatArray]:
        k = max(bisect.bisect_right(self.steps, t + SAME_TIME_S, key=_time_of) - 1, 0)
        dt = t - float(self.times[k])
        if dt <= SAME_TIME_S:
            return k, self.x(k), self.p(k)
        xf, pf = self._filtered_at(k, dt)
        if k == len(self.times) - 1:  # prediction past the latest step
            return k, xf, pf
        x_prior, p_prior, gain = self._prior(k, t, xf, pf, float(self.times[k + 1]))
        x = xf + gain @ (self.x(k + 1) - x_prior)
        p = pf + gain @ (self.p(k + 1) - p_prior) @ gain.T
        return k, x, 0.5 * (p + p.T)

    def cross(self, t1: float, t2: float) -> FloatArray:
        """Smoothed ``Cov(x(t1), x(t2))`` for ``t1 <= t2``, shape (n, n).

        Walks the chain t1 -> next step -> ... -> the step at or before t2 -> t2 and
        multiplies the backward gains: ``Cov = G_1 G_2 ... G_m P_s(t2)``. Past the latest
        step, ``x(t2) = F x(t_last) + noise`` instead.
        """
        k1, _, p1 = self.node(t1)
        k2, _, p2 = self.node(t2)
        if t2 - t1 <= SAME_TIME_S:
            return p1
        last = len(self.times) - 1
        d1 = t1 - float(self.times[k1])
        on_step_1 = d1 <= SAME_TIME_S
        step1 = self.steps[k1]
        xf1, pf1 = (step1.x, step1.p) if on_step_1 else self._filtered_at(k1, d1)
        if k1 == k2:
            # Same interval: no measurement between t1 and t2.
            if k1 == last:
                return p1 @ self.model.transition(t2 - t1).T
            return self._prior(k1, t1, xf1, pf1, t2)[2] @ p2
        gain = np.eye(self.model.n_states)
        first = k1
        if not on_step_1:
            gain = self._prior(k1, t1, xf1, pf1, float(self.times[k1 + 1]))[2]
            first = k1 + 1
        for j in range(first, k2):
            gain = gain @ self.steps[j + 1].gain_prev
        d2 = t2 - float(self.times[k2])
        if d2 <= SAME_TIME_S:
            return gain @ p2
        if k2 == last:
            return gain @ self.p(k2) @ self.model.transition(d2).T
        step2 = self.steps[k2]
        return gain @ self._prior(k2, float(self.times[k2]), step2.x, step2.p, t2)[2] @ p2
