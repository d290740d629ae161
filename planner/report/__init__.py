"""The dive report: reading a run folder back, figures, heights against truth, the map picture."""

from planner.report.data import Event, RunFolderError, load_run
from planner.report.height_score import match_targets, score_heights
from planner.report.map_plot import render_map_png
from planner.report.markdown import DEFAULT_MATCH_RADIUS_M, FIGURE_DIR, REPORT_NAME, generate_report
from planner.report.timeline import state_at, state_spans

__all__ = [
    "DEFAULT_MATCH_RADIUS_M",
    "Event",
    "FIGURE_DIR",
    "REPORT_NAME",
    "RunFolderError",
    "generate_report",
    "load_run",
    "match_targets",
    "render_map_png",
    "score_heights",
    "state_at",
    "state_spans",
]
