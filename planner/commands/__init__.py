"""Subcommands of the ``shadowsurvey`` command line, one module each.

Each module exposes ``register(subparsers)``; :mod:`planner.cli` discovers them.
"""
