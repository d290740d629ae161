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
    (-1.018, 0.1, math.nan),  # far above (the whole-loop dive's lossy-link case): unknown
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
