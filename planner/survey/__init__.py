"""Survey planning: area, sonar footprint, altitude/tilt choice, lanes, routing, the plan and its mission files."""

from planner.survey.altitudes import AltitudeChoice, choose_altitudes, constraint_values, shadow_length_m, shadow_slope
from planner.survey.area import (
    SurveyArea,
    area_from_geojson,
    area_to_geojson,
    load_area,
)
from planner.survey.footprint import exact_footprint_body, footprint, seen_mask, swept_polygon
from planner.survey.lawnmower import choose_heading, free_region, lane_pieces, plan_survey
from planner.survey.mission_files import (
    MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW,
    MAV_CMD_NAV_WAYPOINT,
    mission_items,
    plan_geojson,
    qgc_plan,
    summary_text,
    waypoints_text,
    write_outputs,
)
from planner.survey.plan import LaneRun, PlanSummary, PlanWaypoint, SurveyPass, SurveyPlan, load_plan
from planner.survey.plot import plot_plan
from planner.survey.routing import Router, segments_cross

__all__ = [
    "AltitudeChoice",
    "LaneRun",
    "MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW",
    "MAV_CMD_NAV_WAYPOINT",
    "PlanSummary",
    "PlanWaypoint",
    "Router",
    "SurveyArea",
    "SurveyPass",
    "SurveyPlan",
    "area_from_geojson",
    "area_to_geojson",
    "choose_altitudes",
    "choose_heading",
    "constraint_values",
    "exact_footprint_body",
    "footprint",
    "free_region",
    "lane_pieces",
    "load_area",
    "load_plan",
    "mission_items",
    "plan_geojson",
    "plan_survey",
    "plot_plan",
    "qgc_plan",
    "seen_mask",
    "segments_cross",
    "shadow_length_m",
    "shadow_slope",
    "summary_text",
    "swept_polygon",
    "waypoints_text",
    "write_outputs",
]
