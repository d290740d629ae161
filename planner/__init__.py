"""shadowsurvey: planner."""
