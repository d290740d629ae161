"""The simulated autopilot's parameters: ArduSub 4.5 names, storage types and defaults.

Each parameter is declared as ArduSub 4.5 declares it (AP_Int8, AP_Int16, AP_Int32 or
AP_Float) with the firmware's default, so a ground station reads the same PARAM_VALUE
type and value as from a real sub. Sources (ArduPilot Sub-4.5 @30257f0118):
``ArduSub/Parameters.cpp`` (GSCALAR table), ``ArduSub/Parameters.h`` (Sub defaults table:
ARMING_CHECK 448, MNT1_TYPE 1, WPNAV_SPEED 100, PILOT_SPEED_UP 100),
``ArduSub/GCS_Mavlink.cpp`` (SRn_* stream rates), ``libraries/AC_WPNav/AC_WPNav.cpp``,
``libraries/AP_Mount/AP_Mount_Params.cpp``, ``libraries/AP_RangeFinder/AP_RangeFinder_Params.cpp``
(4.5: RNGFND1_MIN_CM / RNGFND1_MAX_CM, int16 cm; 4.6 renames them), ``libraries/AC_Fence``.
4.5 has no FS_GCS_TIMEOUT (the 2.5 s GCS timeout is fixed, ``ArduSub/defines.h``) and no
PILOT_SPEED; both are 4.6.

:data:`BLUEOS_DVL_SETUP` is not firmware: it is what a BlueROV2 owner with the BlueOS DVL
extension and a tilt servo has set (the extension's ``setup_params``/``load_params``, the
rangefinder for the DVL's altitude), and what the simulator boots with by default.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping
from dataclasses import dataclass

from pymavlink.dialects.v20 import ardupilotmega as mavlink

INT8 = mavlink.MAV_PARAM_TYPE_INT8
INT16 = mavlink.MAV_PARAM_TYPE_INT16
INT32 = mavlink.MAV_PARAM_TYPE_INT32
REAL32 = mavlink.MAV_PARAM_TYPE_REAL32
_RANGES = {INT8: (-128, 127), INT16: (-32768, 32767), INT32: (-(2**31), 2**31 - 1)}


@dataclass(frozen=True)
class ParamSpec:
    """One ArduSub parameter: MAV_PARAM_TYPE as stored (INT8/16/32 or REAL32) and default."""

    param_type: int
    default: float


def _p(param_type: int, default: float) -> ParamSpec:
    return ParamSpec(param_type, float(default))


#: name -> spec, in the order PARAM_REQUEST_LIST sends them.
ARDUSUB_4_5: dict[str, ParamSpec] = {
    # ArduSub/Parameters.cpp
    "SYSID_THISMAV": _p(INT16, 1),
    "SYSID_MYGCS": _p(INT16, 255),
    "FS_GCS_ENABLE": _p(INT8, 2),  # 0 off, 1 warn, 2 disarm, 3 depth hold, 4 surface
    "FS_PILOT_INPUT": _p(INT8, 2),  # 0 off, 1 warn, 2 disarm
    "FS_PILOT_TIMEOUT": _p(REAL32, 3.0),  # s
    "FS_TERRAIN_ENAB": _p(INT8, 0),  # 0 disarm, 1 hold, 2 surface
    "FS_EKF_ACTION": _p(INT8, 0),
    "FS_EKF_THRESH": _p(REAL32, 0.8),
    "FS_LEAK_ENABLE": _p(INT8, 1),
    "FS_CRASH_CHECK": _p(INT8, 0),
    "WP_YAW_BEHAVIOR": _p(INT8, 4),  # WP_YAW_BEHAVIOR_CORRECT_XTRACK (ArduSub/config.h)
    "PILOT_SPEED_UP": _p(INT16, 100),  # cm/s (Sub defaults table)
    "PILOT_SPEED_DN": _p(INT16, 0),  # cm/s, 0 = PILOT_SPEED_UP
    "PILOT_ACCEL_Z": _p(INT16, 100),  # cm/s/s
    "SURFACE_DEPTH": _p(REAL32, -10.0),  # cm
    "SURFTRAK_DEPTH": _p(REAL32, -50.0),  # cm
    "RNGFND_SQ_MIN": _p(INT8, 90),  # %
    "JS_GAIN_DEFAULT": _p(REAL32, 0.5),
    "JS_THR_GAIN": _p(REAL32, 1.0),
    "ORIGIN_LAT": _p(REAL32, 0.0),  # backup EKF origin, applied at arming (ParametersG2)
    "ORIGIN_LON": _p(REAL32, 0.0),
    "ORIGIN_ALT": _p(REAL32, 0.0),
    "ARMING_CHECK": _p(INT32, 448),  # RC | VOLTAGE | BATTERY (Sub defaults table)
    # AC_WPNav
    "WPNAV_SPEED": _p(REAL32, 100.0),  # cm/s (Sub defaults table)
    "WPNAV_RADIUS": _p(REAL32, 200.0),  # cm
    "WPNAV_SPEED_UP": _p(REAL32, 250.0),  # cm/s
    "WPNAV_SPEED_DN": _p(REAL32, 150.0),  # cm/s
    "WPNAV_ACCEL": _p(REAL32, 250.0),  # cm/s/s
    "WPNAV_JERK": _p(REAL32, 1.0),  # m/s/s/s
    "WPNAV_RFND_USE": _p(INT8, 1),
    # AC_Fence (ArduSub/fence.cpp only logs a breach in 4.5)
    "FENCE_ENABLE": _p(INT8, 0),
    "FENCE_TYPE": _p(INT8, 7),  # ALT_MAX | CIRCLE | POLYGON
    "FENCE_ACTION": _p(INT8, 1),
    "FENCE_ALT_MAX": _p(REAL32, 100.0),  # m
    "FENCE_ALT_MIN": _p(REAL32, -10.0),  # m (FENCE_TYPE bit 8 = ALT_MIN: the depth limit)
    "FENCE_RADIUS": _p(REAL32, 300.0),  # m
    # AP_Mount_Params (Sub defaults table: type 1 servo, RC targeting, 30 deg/s)
    "MNT1_TYPE": _p(INT8, 1),  # 1 servo (stabilised by the autopilot), 7 brushless PWM (not)
    "MNT1_DEFLT_MODE": _p(INT8, 3),  # MAV_MOUNT_MODE_RC_TARGETING
    "MNT1_RC_RATE": _p(INT16, 30),  # deg/s
    "MNT1_PITCH_MIN": _p(INT16, -90),  # deg, up positive
    "MNT1_PITCH_MAX": _p(INT16, 20),
    # AP_RangeFinder_Params (4.5 names)
    "RNGFND1_TYPE": _p(INT8, 0),  # 10 = MAVLink
    "RNGFND1_ORIENT": _p(INT8, 25),  # ROTATION_PITCH_270, down
    "RNGFND1_MIN_CM": _p(INT16, 20),
    "RNGFND1_MAX_CM": _p(INT16, 700),
    # AP_Terrain (Sub: off), AP_AHRS / EKF3 sources, visual odometry
    "TERRAIN_ENABLE": _p(INT8, 0),
    "AHRS_EKF_TYPE": _p(INT8, 3),
    "EK3_SRC1_POSXY": _p(INT8, 3),  # 3 GPS, 6 ExtNav
    "EK3_SRC1_VELXY": _p(INT8, 3),
    "EK3_SRC1_POSZ": _p(INT8, 1),  # baro
    "VISO_TYPE": _p(INT8, 0),
    # ArduSub/GCS_Mavlink.cpp stream rates (Hz), the same for every SRn
    "SR0_RAW_SENS": _p(INT16, 2),
    "SR0_EXT_STAT": _p(INT16, 2),
    "SR0_RC_CHAN": _p(INT16, 2),
    "SR0_POSITION": _p(INT16, 3),
    "SR0_EXTRA1": _p(INT16, 10),
    "SR0_EXTRA2": _p(INT16, 10),
    "SR0_EXTRA3": _p(INT16, 3),
    "SR0_PARAMS": _p(INT16, 0),
}

#: A BlueROV2 as its owner sets it up with the BlueOS DVL extension (Water Linked A50):
#: ``dvl-a50/dvl.py`` ``setup_params`` (EKF3, visual odometry, the DVL as rangefinder) and
#: ``load_params("dvl")`` (ExtNav position and velocity, baro height), with the DVL's
#: 50 m range as the rangefinder's maximum.
BLUEOS_DVL_SETUP: dict[str, float] = {
    "AHRS_EKF_TYPE": 3.0,
    "EK3_SRC1_POSXY": 6.0,
    "EK3_SRC1_VELXY": 6.0,
    "EK3_SRC1_POSZ": 1.0,
    "VISO_TYPE": 1.0,
    "RNGFND1_TYPE": 10.0,
    "RNGFND1_MAX_CM": 5000.0,
}


def stored_value(param_type: int, value: float) -> float:
    """``value`` as the parameter stores it (ArduSub 4.5 ``AP_Param::set_float``).

    Integer types add 0.01 away from zero, clamp to the type's range and truncate toward
    zero (so 2.999 stores 3, 2.5 stores 2); floats go through float32.
    """
    if param_type in _RANGES:
        lo, hi = _RANGES[param_type]
        nudged = value + (0.01 if value >= 0 else -0.01)
        return float(math.trunc(min(max(nudged, lo), hi)))
    return float(_float32(value))


def _float32(value: float) -> float:
    import struct

    return struct.unpack("<f", struct.pack("<f", value))[0]


class ParamTable(Mapping[str, float]):
    """The live parameter values: fixed names and order, each with its ArduSub type."""

    def __init__(self, overrides: Mapping[str, float] | None = None) -> None:
        self._specs = ARDUSUB_4_5
        self._values = {name: spec.default for name, spec in self._specs.items()}
        for name, value in (overrides or {}).items():
            if name not in self._values:
                raise KeyError(f"unknown parameter {name!r} (ArduSub 4.5 names only)")
            self._values[name] = stored_value(self._specs[name].param_type, float(value))
        self._names = list(self._values)

    def __getitem__(self, name: str) -> float:
        return self._values[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._names)

    def __len__(self) -> int:
        return len(self._names)

    def param_type(self, name: str) -> int:
        """MAV_PARAM_TYPE of a parameter as ArduSub stores it."""
        return self._specs[name].param_type

    def set(self, name: str, value: float) -> bool:
        """Set a known parameter (converted to its type); False for an unknown name or a
        value that is not finite (ArduSub 4.5 ``GCS_MAVLINK::handle_param_set`` ignores
        both, with no reply)."""
        if name not in self._values or not math.isfinite(value):
            return False
        self._values[name] = stored_value(self._specs[name].param_type, float(value))
        return True

    def index_of(self, name: str) -> int:
        """Index of a parameter in the table order."""
        return self._names.index(name)

    def name_at(self, index: int) -> str | None:
        """Name at an index, or None if out of range."""
        return self._names[index] if 0 <= index < len(self._names) else None

    def value_message(self, name: str, index: int) -> mavlink.MAVLink_param_value_message:
        """PARAM_VALUE for ``name`` typed as ArduSub types it (``GCS_MAVLINK::mav_param_type``:
        AP_Int8 -> INT8, AP_Int16 -> INT16, AP_Int32 -> INT32, else REAL32); ``index`` -1
        (sent as 65535) is the echo of a PARAM_SET (``GCS::send_parameter_value``)."""
        return mavlink.MAVLink_param_value_message(
            name.encode("ascii"), self._values[name], self._specs[name].param_type, len(self._names),
            index & 0xFFFF,
        )
