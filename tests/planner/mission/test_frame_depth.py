"""The depth the companion stamps on a frame: never above the surface, never a crash."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from perception.sonar_io.frame import SonarFrame
from planner.mission.frame_depth import frame_depth_m


@pytest.mark.parametrize(("mean", "std", "expected"), [
    (12.3, 0.05, 12.3),  # below the surface: as estimated
    (0.0, 0.05, 0.0),
    (-0.05, 0.03, 0.0),  # above by less than 3 sigma: the surface
    (-1.018, 0.1, math.nan),  # far above the surface for its sigma: unknown
    (-1.018, 70.7, math.nan),  # the whole-loop dive's case: the prior split by a first altimeter reading
    (5.0, 2.0, math.nan),  # the filter cannot say within a metre
    (-0.2, math.nan, math.nan),
    (math.nan, 0.1, math.nan),
])
def test_known_answers(mean: float, std: float, expected: float) -> None:
    got = frame_depth_m(mean, std)
    assert (math.isnan(got) and math.isnan(expected)) or got == expected


@given(st.one_of(st.just(math.nan), st.floats(-50.0, 11_000.0)), st.one_of(st.just(math.nan), st.floats(0.0, 10.0)))
def test_a_stamped_frame_always_validates(mean: float, std: float) -> None:
    """Whatever the filter says, the frame takes the depth (FrameFormatError would end a dive)."""
    depth = frame_depth_m(mean, std)
    assert math.isnan(depth) or depth >= 0.0
    frame = SonarFrame(image=np.zeros((8, 4), dtype=np.uint8), range_m=np.linspace(1.0, 2.0, 8),
                       beam_azimuth_rad=np.linspace(-0.2, 0.2, 4), elevation_aperture_rad=math.radians(14.0),
                       timestamp_s=0.0)
    assert frame.with_fields(sonar_depth_m=depth).known("sonar_depth_m") == (not math.isnan(depth))


def test_before_any_depth_reading_the_filter_gives_no_frame_depth() -> None:
    """The altitude filter's first measurement an altimeter reading (the depth stream lost or
    late): its prior puts the depth at minus half the altitude, 70 m uncertain; the frame
    says it does not know rather than carry that."""
    from perception.navigation.altitude_filter import AltitudeFilter

    f = AltitudeFilter()
    f.update_altimeter(10.0, 2.04, 0.05)
    mean, variance = f.depth_at(10.0)
    assert mean == pytest.approx(-1.02, abs=0.01) and math.sqrt(variance) > 50.0
    assert math.isnan(frame_depth_m(mean, math.sqrt(variance)))
    f.update_depth(10.2, 3.0, 0.02)
    mean, variance = f.depth_at(10.2)
    assert frame_depth_m(mean, math.sqrt(variance)) == pytest.approx(3.0, abs=0.05)


def test_the_companion_has_no_depth_before_its_first_depth_reading() -> None:
    """OnboardPerception.depth: NaN while the filter knows only an altimeter reading (what the
    safe actions then do without a depth: surface rather than hold -1 m), the reading's
    depth once it arrives."""
    from planner.mission.onboard import OnboardConfig, OnboardPerception
    from vehicle_link.telemetry import GlobalPosition, Rangefinder

    onboard = OnboardPerception(OnboardConfig())
    try:
        onboard.listener(Rangefinder(10.0, "DISTANCE_SENSOR", 0, 2.04, 0.2, 50.0, 25, 100, True))
        onboard.drain()
        depth, std = onboard.depth(10.0)
        assert math.isnan(depth) and std > 50.0
        onboard.listener(GlobalPosition(10.2, 10.2, 43.0, 5.0, -3.0, 3.0, 0.0, 0.0, 0.0, 0.0))
        onboard.drain()
        assert onboard.depth(10.2)[0] == pytest.approx(3.0, abs=0.05)
    finally:
        onboard.close()
