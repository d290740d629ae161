"""The pitch loop's prediction against the simulator's own vehicle model.

The loop predicts with a kinematic model of its own (:mod:`planner.pitch.prediction`):
the measured pitch rate extrapolated, the vehicle advancing along its heading at the
measured speed. The simulator moves the vehicle with its dynamics
(:func:`sim_harness.vehicle.dynamics.step_rk4`) and pitches it with waves, trim and the
surge thrust's reaction through a lag (:class:`sim_harness.vehicle.dynamics.AttitudeDisturbance`).
These tests fly the simulator's model and check the loop's prediction against it with the
loop's own estimates (the rate and speed from the last 0.4 s, as
:class:`planner.pitch.control.ShadowPitchLoop` measures them):

- over the first step, the one the loop commits to (it re-plans every step), the pitch
  error stays inside the envelope the QP keeps for it (``pitch_envelope_rad``);
- the along-track advance over that step within what the loop's elevation margin
  absorbs, and within the loop's lead band
  (``zone_lead_m``) over the whole 2 s horizon.
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from perception.navigation.history import NavSample
from planner.pitch.config import PitchLoopConfig
from planner.pitch.control import ShadowPitchLoop
from planner.pitch.prediction import predict_pitch_rad
from planner.pitch.types import PitchState
from sim_harness.vehicle.dynamics import AttitudeDisturbance, RovParams, step_rk4

DT_S = 0.02  # the simulator's physics step
CONTROL_S = 0.2  # the executor's control period: the loop's step
WINDOW_S = 0.4  # ShadowPitchLoop.motion_window_s (checked against the loop below)
SURVEY_SPEED_M_S = 0.25
#: Surge thrust that holds the survey speed in the simulator's water, N; the speed loop's
#: gain and its thrust limit either way (it brakes with reverse thrust, as the position
#: controller does; a survey never asks for more than a quarter of full thrust).
CRUISE_N = 2.0
SPEED_GAIN_N_PER_M_S = 40.0
MAX_SURVEY_THRUST_N = 10.0
#: Altitude of the check, m (as in the envelope test): the margin in metres scales with it.
ALTITUDE_M = 1.0

DISTURBANCES = {
    "default waves": AttitudeDisturbance(),
    "trim and swell": AttitudeDisturbance(pitch_bias_rad=math.radians(-3.0), pitch_amplitude_rad=math.radians(3.0),
                                          pitch_period_s=8.0, roll_amplitude_rad=math.radians(3.0)),
}


def _fly(disturbance: AttitudeDisturbance, speed_cmd_m_s: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Times, pitch (rad) and along-track position (m) of the simulator's vehicle, heading
    north, its surge thrust set by a speed loop (as the autopilot's position controller
    does) to follow ``speed_cmd_m_s`` (one value per physics step)."""
    params = RovParams()
    x = (0.0, 0.0, 10.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    lagged = rate = 0.0
    t = np.arange(speed_cmd_m_s.size) * DT_S
    pitch = np.empty(t.size)
    north = np.empty(t.size)
    for k, v_cmd in enumerate(speed_cmd_m_s):
        thrust = min(max(CRUISE_N * v_cmd / 0.25 + SPEED_GAIN_N_PER_M_S * (v_cmd - x[4]), -MAX_SURVEY_THRUST_N),
                     MAX_SURVEY_THRUST_N)
        pitch[k] = disturbance.attitude(float(t[k]), lagged, rate)[0]
        north[k] = x[0]
        x = step_rk4(x, (thrust, 0.0, 0.0, 0.0), (0.0, 0.0, 0.0), DT_S, params)
        new = disturbance.lagged_surge_n(lagged, thrust, DT_S)
        rate, lagged = (new - lagged) / DT_S, new
    return t, pitch, north


def _profile(seconds: float) -> np.ndarray:
    """Commanded speed as a survey asks for it: cruise, a stop (a lane's end), cruise
    again, half speed, m/s."""
    n = int(seconds / DT_S)
    out = np.full(n, SURVEY_SPEED_M_S)
    out[int(0.3 * n): int(0.4 * n)] = 0.0
    out[int(0.7 * n):] = 0.5 * SURVEY_SPEED_M_S
    return out


@pytest.mark.parametrize("name", sorted(DISTURBANCES))
def test_first_step_pitch_error_stays_in_the_loops_envelope(name: str) -> None:
    config = PitchLoopConfig(nominal_tilt_rad=0.4, dt_s=CONTROL_S, horizon_steps=10)
    t, pitch, _ = _fly(DISTURBANCES[name], _profile(60.0))
    lag = int(round(WINDOW_S / DT_S))
    step = int(round(CONTROL_S / DT_S))
    errors = []
    for k in range(lag, t.size - config.horizon_steps * step, step):
        rate = (pitch[k] - pitch[k - lag]) / WINDOW_S
        state = PitchState(altitude_m=1.0, vehicle_pitch_rad=float(pitch[k]), speed_m_s=0.25, current_tilt_rad=0.4,
                           pitch_rate_rad_s=float(rate))
        predicted = predict_pitch_rad(state, config)
        errors.append(abs(predicted[1] - pitch[k + step]))
    worst = max(errors)
    assert worst <= config.pitch_envelope_rad, (math.degrees(worst), math.degrees(config.pitch_envelope_rad))


def _loop() -> ShadowPitchLoop:
    """The executor's adapter with its default motion window and lead, no passes."""
    settings = SimpleNamespace(site=SimpleNamespace(target_height_min_m=0.02, target_height_max_m=0.2),
                               sonar=SimpleNamespace())
    return ShadowPitchLoop(SimpleNamespace(passes=()), settings)  # type: ignore[arg-type]


def _onboard(t: np.ndarray, north: np.ndarray, k: int) -> SimpleNamespace:
    """On-board navigation at step ``k`` of a flight heading north: the newest sample and
    the samples before it (positions at the physics step, as if reported every step)."""
    def sample(i: int) -> NavSample:
        return NavSample(float(t[i]), float(north[i]), 0.0, 0.0, 0.0, 0.0, 0.4)

    def nav_at(time_s: float) -> NavSample | None:
        i = int(round(time_s / DT_S))
        return sample(i) if 0 <= i <= k else None

    return SimpleNamespace(nav=sample(k), nav_at=nav_at)


def test_along_track_advance_over_the_horizon() -> None:
    """The loop moves the shadows back at the measured speed, led toward the commanded one;
    the vehicle's dynamics accelerate and brake: through the stop and the restart the
    difference over the step the loop commits to moves the nearest held shadow by less
    than the loop's elevation margin, and it stays within the loop's
    lead band (``zone_lead_m``, which covers prediction errors) over the 2 s horizon of
    one leg."""
    horizon_s = 2.0
    config = PitchLoopConfig(nominal_tilt_rad=0.4, dt_s=CONTROL_S, horizon_steps=10)
    loop = _loop()
    assert loop.motion_window_s == pytest.approx(WINDOW_S)
    command = _profile(60.0)
    t, _, north = _fly(AttitudeDisturbance(), command)
    lag = int(round(WINDOW_S / DT_S))
    ahead = int(round(horizon_s / DT_S))
    step = int(round(CONTROL_S / DT_S))
    worst = first = 0.0
    for k in range(lag, t.size - ahead, 5):
        cmd = float(command[k])
        speed, _ = loop._motion(_onboard(t, north, k), cmd)  # type: ignore[arg-type]
        first = max(first, abs(north[k] + speed * CONTROL_S - north[k + step]))
        # Over the horizon only while the leg's commanded speed holds (the executor gives
        # the loop the current leg's speed; a new leg is a new command).
        if np.all(command[k:k + ahead + 1] == cmd):
            worst = max(worst, abs(north[k] + speed * horizon_s - north[k + ahead]))
    # The nearest held shadow: the near band's start (min_ground_range_over_altitude
    # altitudes along). A seabed point at ground range x seen from altitude h is at
    # atan(h / x) below the horizontal; moving it by dx turns it by h / (x^2 + h^2) dx.
    x = float(config.near_start_m(ALTITUDE_M))
    assert x == pytest.approx(2.0 * ALTITUDE_M)
    margin_m = config.margin_rad * (x**2 + ALTITUDE_M**2) / ALTITUDE_M  # 0.065 m at 1 m altitude
    assert first <= margin_m, (first, margin_m)
    assert worst <= config.zone_lead_m, (worst, config.zone_lead_m)
