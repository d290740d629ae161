"""shadowsurvey: perception."""
