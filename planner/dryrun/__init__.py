"""The dry-run dive: scenario files, the software vehicle wired in, scoring against truth.

- :mod:`planner.dryrun.scenario`: scenario files (``scenario.toml``);
- :mod:`planner.dryrun.dive`: plan, start the software sub, fly it over real MAVLink, write the run folder;
- :mod:`planner.dryrun.scoring`: the judge: clearance, depth limit, heights and shadows in view from truth;
- :mod:`planner.dryrun.shadow_view`: the judge's own shadow-visibility geometry.

The one part of :mod:`planner` that imports :mod:`sim_harness` (see CONTRIBUTING.md).

The names below are imported on first use (PEP 562), so that importing one module of the
package does not load the others."""

from __future__ import annotations

from perception.lazy_exports import lazy_exports

_EXPORTS = {
    "BUILTIN_SCENARIOS": "planner.dryrun.scenario",
    "DryRun": "planner.dryrun.dive",
    "Scenario": "planner.dryrun.scenario",
    "load_scenario": "planner.dryrun.scenario",
    "make_tilt_controller": "planner.dryrun.dive",
    "run_dry_dive": "planner.dryrun.dive",
    "score_against_truth": "planner.dryrun.scoring",
}

__all__ = sorted(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
