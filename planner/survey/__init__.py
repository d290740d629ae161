"""Survey planning: area, sonar footprint, altitude/tilt choice, lanes, routing, the plan and its mission files.

The names below are imported on first use (PEP 562), so that importing one module of the
package does not load the others."""

from __future__ import annotations

from perception.lazy_exports import lazy_exports

_EXPORTS = {
    "AltitudeChoice": "planner.survey.altitudes",
    "LaneRun": "planner.survey.plan",
    "MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW": "planner.survey.mission_files",
    "MAV_CMD_NAV_WAYPOINT": "planner.survey.mission_files",
    "PlanSummary": "planner.survey.plan",
    "PlanWaypoint": "planner.survey.plan",
    "Router": "planner.survey.routing",
    "SurveyArea": "planner.survey.area",
    "SurveyPass": "planner.survey.plan",
    "SurveyPlan": "planner.survey.plan",
    "area_from_geojson": "planner.survey.area",
    "area_to_geojson": "planner.survey.area",
    "choose_altitudes": "planner.survey.altitudes",
    "choose_heading": "planner.survey.lawnmower",
    "constraint_values": "planner.survey.altitudes",
    "exact_footprint_body": "planner.survey.footprint",
    "footprint": "planner.survey.footprint",
    "free_region": "planner.survey.lawnmower",
    "lane_pieces": "planner.survey.lawnmower",
    "load_area": "planner.survey.area",
    "load_plan": "planner.survey.plan",
    "mission_items": "planner.survey.mission_files",
    "plan_geojson": "planner.survey.mission_files",
    "plan_survey": "planner.survey.lawnmower",
    "plot_plan": "planner.survey.plot",
    "qgc_plan": "planner.survey.mission_files",
    "seen_mask": "planner.survey.footprint",
    "segments_cross": "planner.survey.routing",
    "shadow_length_m": "planner.survey.altitudes",
    "shadow_slope": "planner.survey.altitudes",
    "summary_text": "planner.survey.mission_files",
    "swept_polygon": "planner.survey.footprint",
    "waypoints_text": "planner.survey.mission_files",
    "write_outputs": "planner.survey.mission_files",
}

__all__ = sorted(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
