"""The dry-run dive: scenario files, the software vehicle wired in, scoring against truth.

- :mod:`planner.dryrun.scenario`: scenario files (``scenario.toml``);
- :mod:`planner.dryrun.dive`: plan, start the software sub, fly it over real MAVLink, write the run folder;
- :mod:`planner.dryrun.scoring`: the judge: clearance, depth limit, heights and shadows in view from truth;
- :mod:`planner.dryrun.shadow_view`: the judge's own shadow-visibility geometry.

The one part of :mod:`planner` that imports :mod:`sim_harness` (see CONTRIBUTING.md).
"""

from planner.dryrun.dive import DryRun, make_tilt_controller, run_dry_dive
from planner.dryrun.scenario import BUILTIN_SCENARIOS, Scenario, load_scenario
from planner.dryrun.scoring import score_against_truth

__all__ = ["BUILTIN_SCENARIOS", "DryRun", "Scenario", "load_scenario", "make_tilt_controller", "run_dry_dive",
           "score_against_truth"]
