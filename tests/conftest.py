"""Shared fixtures: the shipped test data and a seeded random generator; hypothesis profiles.

Hypothesis runs derandomized by default (profile ``repeatable``): every run of the
suite, CI's included, tries the same examples, so a landing never hangs on a new random
draw. To explore, run with ``HYPOTHESIS_PROFILE=explore`` (random, more examples) and turn
every counterexample it finds into a known-answer test.

The whole test session speaks MAVLink 2: pymavlink's ``mavutil`` picks its dialect module
when first imported and some of its helpers (``mavwp``) re-read the MAVLINK20 variable
later, so the variable is set here, before any test module imports pymavlink, and never
changed afterwards.
"""

from __future__ import annotations

import os

os.environ["MAVLINK20"] = "1"

from pathlib import Path

import numpy as np
import pytest
from hypothesis import settings

settings.register_profile("repeatable", derandomize=True, database=None)
settings.register_profile("explore", max_examples=500, database=None)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "repeatable"))

REPO_ROOT = Path(__file__).resolve().parent.parent
DATA_DIR = REPO_ROOT / "tests" / "data"


@pytest.fixture(scope="session")
def data_dir() -> Path:
    """Path of ``tests/data``: the real ARIS sample and the paper's tables (see its README)."""
    return DATA_DIR


@pytest.fixture
def rng() -> np.random.Generator:
    """A seeded generator, so every test is repeatable."""
    return np.random.default_rng(20261123)
