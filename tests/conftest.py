"""Shared fixtures: the shipped test data and a seeded random generator.

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
