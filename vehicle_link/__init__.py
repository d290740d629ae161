"""shadowsurvey: vehicle_link."""
