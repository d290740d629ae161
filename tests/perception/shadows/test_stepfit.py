"""The blurred-step fit: known answers on noise-free steps, unbiased under speckle."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.special import ndtr

from perception.shadows.measurement.stepfit import fit_steps


def _steps(x0: np.ndarray, blur: float, sign: float, m: int, low: float = 0.02, high: float = 1.0) -> np.ndarray:
    x = np.arange(m)
    return low + (high - low) * ndtr(sign * (x0[:, None] - x[None, :]) / blur)


@given(offset=st.floats(-1.5, 1.5), blur=st.floats(0.4, 2.5), sign=st.sampled_from([1.0, -1.0]),
       m=st.sampled_from([21, 41, 61]))
@settings(max_examples=60, deadline=None, derandomize=True)
def test_noise_free_steps_are_found_to_a_few_hundredths_of_a_sample(offset: float, blur: float, sign: float,
                                                               m: int) -> None:
    centre = (m - 1) / 2 + 0.5
    x0 = np.array([centre + offset])
    fit = fit_steps(_steps(x0, blur, sign, m), np.ones((1, m)), edge0=centre, sign=sign)
    assert fit.ok[0]
    assert fit.edge[0] == pytest.approx(x0[0], abs=0.05 + 0.01 * blur)
    assert fit.low[0] == pytest.approx(0.02, abs=0.01) and fit.high[0] == pytest.approx(1.0, rel=0.02)


def test_a_step_of_the_other_sign_is_not_taken() -> None:
    m, centre = 21, 10.5
    rise = _steps(np.array([centre]), 1.0, -1.0, m)
    assert not fit_steps(rise, np.ones((1, m)), edge0=centre, sign=1.0).ok[0]


def test_windows_are_respected() -> None:
    # The profile beyond the window (weight 0) holds a second, stronger step: ignored.
    m, centre = 41, 20.5
    y = _steps(np.array([centre + 0.3]), 1.0, 1.0, m)
    y[0, 32:] = 5.0
    w = np.ones((1, m))
    w[0, 30:] = 0.0
    fit = fit_steps(y, w, edge0=centre, sign=1.0)
    assert fit.ok[0] and fit.edge[0] == pytest.approx(centre + 0.3, abs=0.03)


@pytest.mark.parametrize(("looks", "blur"), [(10.0, 1.0), (30.0, 2.0)])
def test_speckled_steps_are_unbiased_and_their_spread_is_reported(looks: float, blur: float) -> None:
    rng = np.random.default_rng(5)
    m, n = 31, 600
    centre = 15.5
    x0 = centre + rng.uniform(-1.0, 1.0, n)
    sign = np.where(rng.random(n) < 0.5, 1.0, -1.0)
    x = np.arange(m)
    mean = 0.02 + 0.98 * ndtr(sign[:, None] * (x0[:, None] - x[None, :]) / blur)
    y = mean * rng.gamma(looks, 1.0 / looks, (n, m))
    fit = fit_steps(y, np.ones((n, m)), edge0=centre, sign=sign)
    assert fit.ok.mean() > 0.97
    error = (fit.edge - x0)[fit.ok]
    spread = 1.4826 * np.median(np.abs(error - np.median(error)))
    assert abs(np.median(error)) < 0.25 * spread + 0.02
    # The reported 1-sigma is the errors' spread (within a factor of 1.5 either way).
    assert 1 / 1.5 < np.median(fit.edge_std[fit.ok]) / spread < 1.5
