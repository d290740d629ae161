"""shadowsurvey planner: plans, flies and reports dual-altitude sonar surveys.

Sub-packages, one idea each:

- :mod:`planner.survey`: area, sonar footprint, altitude/tilt choice, lanes, routing, the plan, mission files;
- :mod:`planner.pitch`: the pitch loop keeping shadows inside the vertical aperture;
- :mod:`planner.mission`: the executor, its safety envelope, on-board perception, the run folder;
- :mod:`planner.report`: the dive report;
- :mod:`planner.commands`: the ``shadowsurvey`` subcommands (:mod:`planner.cli` builds the parser);
- :mod:`planner.config`: the survey settings (``survey.toml``).
"""
