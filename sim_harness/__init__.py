"""shadowsurvey: sim_harness."""
