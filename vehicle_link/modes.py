"""ArduSub flight-mode numbers (HEARTBEAT.custom_mode), from ArduSub/mode.h.

pymavlink's ``mode_mapping_sub`` stops at MANUAL = 19: it lacks MOTOR_DETECT = 20 and
SURFTRAK = 21 (SURFTRAK exists from ArduSub 4.5 on). This table is the one to use.
"""

from __future__ import annotations

import enum


class SubMode(enum.IntEnum):
    """ArduSub ``Mode::Number`` (ArduSub 4.5)."""

    STABILIZE = 0
    ACRO = 1
    ALT_HOLD = 2
    AUTO = 3
    GUIDED = 4
    CIRCLE = 7
    SURFACE = 9
    POSHOLD = 16
    MANUAL = 19
    MOTOR_DETECT = 20
    SURFTRAK = 21


def mode_name(custom_mode: int) -> str:
    """Name of an ArduSub mode number, or ``"MODE(n)"`` for an unknown number."""
    try:
        return SubMode(custom_mode).name
    except ValueError:
        return f"MODE({custom_mode})"


def parse_mode(mode: str | int) -> SubMode:
    """A SubMode from its name (case-insensitive, ``DEPTH_HOLD`` accepted) or number.

    Raises
    ------
    ValueError
        If the name or number is not an ArduSub mode.
    """
    if isinstance(mode, SubMode):
        return mode
    if isinstance(mode, int):
        try:
            return SubMode(mode)
        except ValueError:
            raise ValueError(
                f"{mode} is not an ArduSub mode number; known: "
                f"{', '.join(f'{m.name}={m.value}' for m in SubMode)}"
            ) from None
    key = str(mode).strip().upper().replace(" ", "_")
    aliases = {"DEPTH_HOLD": "ALT_HOLD", "POSITION_HOLD": "POSHOLD", "SURFACE_TRACKING": "SURFTRAK"}
    key = aliases.get(key, key)
    try:
        return SubMode[key]
    except KeyError:
        raise ValueError(
            f"unknown ArduSub mode {mode!r}; known: {', '.join(m.name for m in SubMode)}"
        ) from None


# Modes in which ArduSub 4.5 accepts a depth target (SET_POSITION_TARGET_GLOBAL_INT z only
# in ALT_HOLD; full position targets in GUIDED).
DEPTH_TARGET_MODES = (SubMode.ALT_HOLD, SubMode.GUIDED)
