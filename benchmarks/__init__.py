"""Speed and accuracy benchmarks of shadowsurvey.

Each ``benchmarks/bench_<area>.py`` has a ``main()`` that prints a Markdown section of
figures; ``python -m benchmarks [name ...]`` runs them (see ``__main__``). Figures are
recorded in ``benchmarks/README.md`` with the machine they were taken on.
"""
