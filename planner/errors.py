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


class OutputFolderError(FileExistsError):
    """An output folder cannot be written without overwriting something; the message names it."""


class InfeasibleError(ValueError):
    """No choice satisfies the constraints; ``reason`` says which one fails."""

    def __init__(self, reason: str):
        super().__init__(reason)
        self.reason = reason


class AreaError(ValueError):
    """The survey area file is invalid; ``path`` names the file."""

    def __init__(self, message: str, *, path: str | None = None):
        super().__init__(f"{path}: {message}" if path else message)
        self.path = path


class SafetyViolation(RuntimeError):
    """A command would leave the safety envelope; it was not sent. ``reason`` is a short code."""

    def __init__(self, message: str, *, reason: str):
        super().__init__(message)
        self.reason = reason


class MissionAborted(RuntimeError):
    """The executor aborted the dive; ``reason`` says why and ``state`` where."""

    def __init__(self, message: str, *, reason: str, state: str):
        super().__init__(message)
        self.reason = reason
        self.state = state
