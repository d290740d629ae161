"""Where a shadow starts (far top edge or near foot) and the ends' triangulation, on exact
geometry of a box seen from two and three altitudes."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from perception.heights.near_foot import EndFrame, check_start, end_triangulation


def _frame(g_near: float, g_far: float, h: float, altitude: float, sigma: float = 2e-4) -> EndFrame:
    """The shadow of a box (ground near foot ``g_near``, far top edge ``g_far``, height h)."""
    r_top = math.hypot(g_far, altitude - h)
    r_foot = math.hypot(g_near, altitude)
    r_end = math.hypot(g_far * altitude / (altitude - h), altitude)
    return EndFrame(r_start_m=max(r_top, r_foot), r_end_m=r_end, sigma_r_m=sigma, altitude_m=altitude)


def _eq2(f: EndFrame) -> tuple[float, float]:
    return f.altitude_m * (f.r_end_m - f.r_start_m) / f.r_end_m, 1e-4


@given(g_far=st.floats(0.8, 3.0), h=st.floats(0.02, 0.2), altitude=st.floats(0.4, 1.5), dh=st.floats(0.05, 0.3))
@settings(max_examples=60, deadline=None, derandomize=True)
def test_the_ends_give_the_height_and_the_far_edge(g_far: float, h: float, altitude: float, dh: float) -> None:
    frames = [_frame(g_far - 0.1, g_far, h, a) for a in (altitude, altitude + dh, altitude + 2 * dh)]
    fit = end_triangulation(frames)
    assert fit is not None
    assert fit.height_m == pytest.approx(h, abs=1e-6) and fit.g_far_m == pytest.approx(g_far, abs=1e-6)
    assert fit.chi2 == pytest.approx(0.0, abs=1e-6)


def test_one_altitude_determines_nothing() -> None:
    frames = [_frame(1.0, 1.1, 0.05, 0.5), _frame(1.0, 1.1, 0.05, 0.5)]
    assert end_triangulation(frames) is None


def test_a_long_low_target_starts_at_its_far_top_edge() -> None:
    frames = [_frame(1.0, 1.2, 0.03, a) for a in (0.5, 0.6)]
    assert all(math.hypot(1.2, f.altitude_m - 0.03) == pytest.approx(f.r_start_m) for f in frames)
    check = check_start(frames, [_eq2(f) for f in frames])
    assert check is not None and not check.use_ends and check.label == "far top edge"


def test_a_short_tall_target_starts_at_its_near_foot() -> None:
    # 2 cm long along the beam and 15 cm tall at 1 m: the far top edge lies in the layover.
    frames = [_frame(1.0, 1.02, 0.15, a) for a in (0.5, 0.6)]
    assert all(f.r_start_m == pytest.approx(math.hypot(1.0, f.altitude_m)) for f in frames)
    eq2 = [_eq2(f) for f in frames]
    assert all(h < 0.15 - 0.005 for h, _ in eq2)  # Eq. 2 reads low
    check = check_start(frames, eq2)
    assert check is not None and check.use_ends and check.label == "near foot"
    assert check.fit.height_m == pytest.approx(0.15, abs=1e-4)
