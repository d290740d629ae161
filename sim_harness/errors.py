"""Exceptions of the sim_harness package (narrow, subclassing built-ins)."""

from __future__ import annotations


class ClockStopped(RuntimeError):
    """The simulation clock was stopped while a thread waited on it."""


class LockstepStall(RuntimeError):
    """A lockstep participant did not yield within the stall timeout (wall seconds).

    ``participants`` names the threads that were still running.
    """

    def __init__(self, message: str, *, participants: tuple[str, ...] = ()):
        super().__init__(message)
        self.participants = participants


class SimConfigError(ValueError):
    """A simulator setting is invalid; ``key`` names the offending setting."""

    def __init__(self, message: str, *, key: str | None = None):
        super().__init__(f"{key}: {message}" if key else message)
        self.key = key


class LinkAddressError(ValueError):
    """A link address such as ``udp:127.0.0.1:14550`` could not be understood or bound."""

    def __init__(self, message: str, *, address: str):
        super().__init__(f"{address!r}: {message}")
        self.address = address
