"""Fixtures of the pitch loop's tests."""

from __future__ import annotations

import pytest

from planner.pitch.qp import PitchLoop
from tests.planner.pitch.common import LIMITS, pitch_config


@pytest.fixture(scope="module")
def loop() -> PitchLoop:
    """A pitch loop with the shared settings."""
    return PitchLoop(pitch_config(), LIMITS)
