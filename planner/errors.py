"""Exceptions of the planner package."""

from __future__ import annotations


class UsageError(ValueError):
    """Bad input on the command line or in a settings file; the CLI exits 2."""


class ConfigError(ValueError):
    """A settings file or value is invalid; ``key`` names the offending setting."""

    def __init__(self, message: str, *, key: str | None = None, path: str | None = None):
        where = f"{path}: " if path else ""
        what = f"{key}: " if key else ""
        super().__init__(f"{where}{what}{message}")
        self.key = key
        self.path = path


class InfeasibleError(ValueError):
    """No choice satisfies the constraints; ``reason`` says which one fails."""

    def __init__(self, reason: str):
        super().__init__(reason)
        self.reason = reason
