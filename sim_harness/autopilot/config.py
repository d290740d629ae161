"""The simulated autopilot's settings: its EKF origin at boot, the owner's parameters, faults
of its own (:class:`AutopilotConfig`)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

from sim_harness.autopilot.params import BLUEOS_DVL_SETUP


@dataclass(frozen=True)
class AutopilotConfig:
    """Autopilot settings.

    Attributes
    ----------
    origin : (lat_deg, lon_deg, alt_m) or None
        The EKF origin at boot; None (a real sub without GPS) until SET_GPS_GLOBAL_ORIGIN
        (the DVL extension, a ground station or the companion) sets it.
    setup : mapping
        Parameters the owner has set (default :data:`~sim_harness.autopilot.params.BLUEOS_DVL_SETUP`).
    params : mapping
        Further parameter overrides (ArduSub 4.5 names).
    arming_fail_reason : str or None
        A pre-arm failure to simulate (e.g. "Leak Detected").
    sitl_build : bool
        Behave as ArduPilot's SITL build, which compiles the pilot-input failsafe out.
    """

    origin: tuple[float, float, float] | None = None
    setup: Mapping[str, float] = field(default_factory=lambda: dict(BLUEOS_DVL_SETUP))
    params: Mapping[str, float] = field(default_factory=dict)
    arming_fail_reason: str | None = None
    sitl_build: bool = False
    system_id: int = 1
    component_id: int = 1
