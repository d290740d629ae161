"""Narrow exceptions of vehicle_link; each subclasses a built-in so callers can catch broadly.

Every exception carries public attributes the caller can read (the MAV_CMD, the
MAV_RESULT, the limit that was broken) instead of only a message.
"""

from __future__ import annotations


class VehicleLinkError(Exception):
    """Base class of every vehicle_link error (catch this to catch them all)."""


class ConfigError(VehicleLinkError, ValueError):
    """A setting is invalid (bad connection string, negative timeout, bad key...)."""


class HeartbeatTimeout(VehicleLinkError, TimeoutError):
    """No heartbeat from a MAV_TYPE_SUBMARINE vehicle within the allowed time.

    Attributes
    ----------
    timeout_s : float
        The time waited, on the injected clock.
    """

    def __init__(self, timeout_s: float) -> None:
        super().__init__(f"no ArduSub (MAV_TYPE_SUBMARINE) heartbeat within {timeout_s:g} s")
        self.timeout_s = timeout_s


class CommandRejected(VehicleLinkError, RuntimeError):
    """The vehicle answered a COMMAND_LONG with a MAV_RESULT other than ACCEPTED.

    Attributes
    ----------
    command : int
        MAV_CMD number of the refused command.
    result : int
        MAV_RESULT the vehicle sent (e.g. 2 = DENIED, 4 = FAILED, 3 = UNSUPPORTED).
    result_name : str
        Name of the MAV_RESULT.
    """

    def __init__(self, command: int, result: int, result_name: str, command_name: str) -> None:
        super().__init__(
            f"{command_name} ({command}) refused by the vehicle: {result_name} ({result})"
        )
        self.command = command
        self.result = result
        self.result_name = result_name
        self.command_name = command_name


class CommandTimeout(VehicleLinkError, TimeoutError):
    """No COMMAND_ACK after every allowed attempt.

    Attributes
    ----------
    command : int
        MAV_CMD number.
    attempts : int
        How many times the command was sent.
    """

    def __init__(self, command: int, command_name: str, attempts: int, timeout_s: float) -> None:
        super().__init__(
            f"no COMMAND_ACK for {command_name} ({command}) after {attempts} attempt(s) "
            f"of {timeout_s:g} s each"
        )
        self.command = command
        self.command_name = command_name
        self.attempts = attempts
        self.timeout_s = timeout_s


class StateChangeTimeout(VehicleLinkError, TimeoutError):
    """A command was accepted but no heartbeat showed the new state in time.

    Attributes
    ----------
    what : str
        The state waited for (``"armed"``, ``"disarmed"``, ``"mode 21"``).
    timeout_s : float
        The time waited, on the injected clock.
    """

    def __init__(self, what: str, timeout_s: float) -> None:
        super().__init__(f"vehicle heartbeat did not show {what} within {timeout_s:g} s")
        self.what = what
        self.timeout_s = timeout_s


class ModeChangeTimeout(StateChangeTimeout):
    """The mode command was accepted but no heartbeat showed the new mode in time."""

    def __init__(self, mode: int, timeout_s: float) -> None:
        super().__init__(f"mode {mode}", timeout_s)
        self.mode = mode


class LinkLost(VehicleLinkError, ConnectionError):
    """The vehicle's heartbeat is missing: the link is down (raised by calls that need it)."""


class SafetyLimitError(VehicleLinkError, ValueError):
    """A target breaks a configured safety limit; raised BEFORE anything is sent.

    Attributes
    ----------
    quantity : str
        What was limited (``"depth_m"`` or ``"altitude_m"``).
    value : float
        The requested value, SI units.
    limit : float
        The configured limit it breaks, SI units.
    """

    def __init__(self, quantity: str, value: float, limit: float, reason: str) -> None:
        super().__init__(f"{quantity}={value:g} refused: {reason} (limit {limit:g})")
        self.quantity = quantity
        self.value = value
        self.limit = limit


class ModeError(VehicleLinkError, RuntimeError):
    """The requested action is not possible in the vehicle's current mode."""

    def __init__(self, action: str, mode: int | None, allowed: tuple[str, ...]) -> None:
        super().__init__(f"{action} needs mode {' or '.join(allowed)}; vehicle is in mode {mode}")
        self.action = action
        self.mode = mode
        self.allowed = allowed


class StaleTelemetry(VehicleLinkError, LookupError):
    """A needed telemetry record is missing or older than allowed."""

    def __init__(self, what: str, age_s: float | None, max_age_s: float) -> None:
        have = "never received" if age_s is None else f"{age_s:.2f} s old"
        super().__init__(f"{what} is {have}; need one at most {max_age_s:g} s old")
        self.what = what
        self.age_s = age_s
        self.max_age_s = max_age_s


class MissionError(VehicleLinkError, RuntimeError):
    """A mission transfer failed.

    Attributes
    ----------
    result : int or None
        MAV_MISSION_RESULT sent by the vehicle, or None for a local failure (timeout).
    """

    def __init__(self, message: str, result: int | None = None) -> None:
        super().__init__(message)
        self.result = result


class MissionTimeout(MissionError, TimeoutError):
    """A mission transfer step got no answer after every retry."""


class MissionVerifyError(MissionError, ValueError):
    """The mission read back from the vehicle differs from the one uploaded.

    Attributes
    ----------
    index : int
        Sequence number of the first differing item (or -1 for a count mismatch).
    """

    def __init__(self, message: str, index: int) -> None:
        super().__init__(message)
        self.index = index


class NotConfigured(VehicleLinkError, RuntimeError):
    """A feature was used without its configuration (e.g. altimeter feed)."""
