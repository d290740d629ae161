"""The dive report: reading a run folder back, figures, heights against truth, the map picture.

The names below are imported on first use (PEP 562), so that importing one module of the
package does not load the others."""

from __future__ import annotations

from perception.lazy_exports import lazy_exports

_EXPORTS = {
    "DEFAULT_MATCH_RADIUS_M": "planner.report.markdown",
    "Event": "planner.report.data",
    "FIGURE_DIR": "planner.report.markdown",
    "REPORT_NAME": "planner.report.markdown",
    "RunFolderError": "planner.report.data",
    "generate_report": "planner.report.markdown",
    "load_run": "planner.report.data",
    "match_targets": "planner.report.height_score",
    "render_map_png": "planner.report.map_plot",
    "score_heights": "planner.report.height_score",
    "state_at": "planner.report.timeline",
    "state_spans": "planner.report.timeline",
}

__all__ = sorted(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
