"""Soak runs (``python -m pytest -m soak``, about 5 minutes on 2 cores): the shipped default
dive, and the compact dive over several vehicle seeds, checked against the truth.

Not in the default run: they repeat what the whole-loop tests check, over longer and more
varied dives, to catch what only shows up now and then.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from planner.dryrun.dive import run_dry_dive
from planner.dryrun.scenario import load_scenario

SITE = Path(__file__).parent / "data" / "compact"


@pytest.mark.soak
def test_default_scenario_dive(tmp_path):
    """The README's main job: completes, every target measured, the limits held."""
    dry = run_dry_dive(load_scenario("paper-targets"), tmp_path / "run")
    assert dry.summary["status"] == "completed", dry.summary["reason"]
    assert dry.summary["depth_limit_violations"] == 0
    assert dry.summary["min_clearance_m"] >= 0.5  # the lowest allowed altitude: 0.3 m over 0.2 m
    assert dry.summary["n_matched"] == dry.summary["n_truth_targets"]
    boxes = [t for t in dry.summary["heights_vs_truth"] if t["matched"] and not t["id"].startswith("S")]
    assert max(abs(t["error_m"]) for t in boxes) <= 0.005  # boxes and the cylinder, within 5 mm
    assert dry.summary["shadow_in_fov_ratio"] >= 0.9


@pytest.mark.soak
@pytest.mark.parametrize("seed", [11, 12, 13, 14, 15])
def test_compact_dive_over_seeds(tmp_path, seed):
    dry = run_dry_dive(load_scenario(SITE, seed=seed), tmp_path / "run")
    assert dry.summary["status"] == "completed", dry.summary["reason"]
    assert dry.summary["min_clearance_m"] >= 0.5  # the lowest allowed altitude: 0.3 m over 0.2 m
    scored = [t for t in dry.summary["heights_vs_truth"] if t["matched"]]
    assert len(scored) >= 4
    assert sum(abs(t["error_m"]) for t in scored) / len(scored) <= 0.002
