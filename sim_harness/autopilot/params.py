"""The simulated autopilot's parameters (ArduSub names, units as ArduSub's)."""

from __future__ import annotations

from collections.abc import Iterator, Mapping

from pymavlink.dialects.v20 import ardupilotmega as mavlink

# name -> default. ArduSub semantics; the values marked (sim) are this simulator's choice.
ARDUSUB_DEFAULTS: dict[str, float] = {
    "SYSID_THISMAV": 1.0,
    "SYSID_MYGCS": 255.0,  # heartbeats from this system id keep the GCS failsafe quiet
    "FS_GCS_ENABLE": 2.0,  # 0 off, 1 warn, 2 disarm, 3 depth hold, 4 surface
    "FS_GCS_TIMEOUT": 5.0,  # s
    "FS_TERRAIN_ENAB": 0.0,  # 0 disarm, 1 hold position, 2 surface
    "FENCE_ENABLE": 0.0,  # depth limit on/off (sim: the depth limit failsafe)
    "FENCE_ALT_MIN": -100.0,  # m, negative = depth limit
    "FENCE_ACTION": 1.0,  # 0 report only, 1 surface
    "WPNAV_SPEED": 100.0,  # cm/s horizontal speed in AUTO/GUIDED (sim default)
    "WPNAV_SPEED_UP": 50.0,  # cm/s
    "WPNAV_SPEED_DN": 50.0,  # cm/s
    "WPNAV_RADIUS": 100.0,  # cm, waypoint reached radius (sim default)
    "WP_YAW_BEHAVIOR": 1.0,  # 0 never change yaw, 1 face next waypoint
    "PILOT_SPEED_UP": 50.0,  # cm/s, stick climb rate in ALT_HOLD
    "PILOT_SPEED_DN": 50.0,
    "SURFTRAK_DEPTH": -50.0,  # cm; SURFTRAK only below this depth
    "SURFACE_DEPTH": -10.0,  # cm; the depth counted as "surfaced"
    "MNT1_TYPE": 1.0,  # servo mount
    "MNT1_DEFLT_MODE": 3.0,  # RC targeting (neutral stick = default angle)
    "MNT1_PITCH_MIN": -90.0,  # deg, filled from the mount limits by the simulator
    "MNT1_PITCH_MAX": 30.0,
    "RNGFND1_TYPE": 10.0,  # MAVLink rangefinder (a Ping echosounder)
    "RNGFND1_ORIENT": 25.0,  # down
    "RNGFND1_MIN_CM": 30.0,
    "RNGFND1_MAX_CM": 5000.0,
    "SR0_RAW_SENS": 2.0,
    "SR0_EXT_STAT": 2.0,
    "SR0_RC_CHAN": 2.0,
    "SR0_RAW_CTRL": 0.0,
    "SR0_POSITION": 3.0,
    "SR0_EXTRA1": 10.0,
    "SR0_EXTRA2": 10.0,
    "SR0_EXTRA3": 3.0,
    "SR0_PARAMS": 0.0,
}


class ParamTable(Mapping[str, float]):
    """A mutable table of float parameters with a fixed set of names and order."""

    def __init__(self, overrides: Mapping[str, float] | None = None) -> None:
        self._values = dict(ARDUSUB_DEFAULTS)
        for name, value in (overrides or {}).items():
            if name not in self._values:
                raise KeyError(f"unknown parameter {name!r}")
            self._values[name] = float(value)
        self._names = list(self._values)

    def __getitem__(self, name: str) -> float:
        return self._values[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._names)

    def __len__(self) -> int:
        return len(self._names)

    def set(self, name: str, value: float) -> bool:
        """Set a known parameter; returns False for an unknown name (ArduPilot ignores it)."""
        if name not in self._values:
            return False
        self._values[name] = float(value)
        return True

    def index_of(self, name: str) -> int:
        """Index of a parameter in the table order."""
        return self._names.index(name)

    def name_at(self, index: int) -> str | None:
        """Name at an index, or None if out of range."""
        return self._names[index] if 0 <= index < len(self._names) else None

    def value_message(self, name: str, index: int = -1) -> mavlink.MAVLink_param_value_message:
        """A PARAM_VALUE message for ``name``."""
        return mavlink.MAVLink_param_value_message(
            name.encode("ascii"),
            self._values[name],
            mavlink.MAV_PARAM_TYPE_REAL32,
            len(self._names),
            index,
        )
