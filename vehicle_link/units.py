"""Every unit conversion of vehicle_link, in one place, each named by its units.

Conventions (architecture.md): SI and radians inside. Depth is positive down from the
surface; altitude is positive up from the seabed; sonar tilt is positive when the sonar
points down (depression). MAVLink mounts use the opposite sign: a gimbal *pitch* is
positive nose-up, so ``tilt = -pitch``.

ArduSub reports GLOBAL_POSITION_INT.relative_alt (mm) as the altitude above the EKF
origin, which sits at the water surface (the depth sensor is zeroed there), so depth is
``-relative_alt``.
"""

from __future__ import annotations

import math

STANDARD_GRAVITY_M_S2 = 9.80665
SEAWATER_DENSITY_KG_M3 = 1025.0
FRESHWATER_DENSITY_KG_M3 = 997.0
STANDARD_ATMOSPHERE_PA = 101325.0

_DEG_E7 = 1.0e7
# 10 microsecond ticks since 2015-01-01 (MAVLink 2 signing timestamp epoch).
SIGNING_EPOCH_UNIX_S = 1420070400


def cdeg_to_rad(value_cdeg: float) -> float:
    """Centidegrees to radians."""
    return math.radians(value_cdeg / 100.0)


def rad_to_cdeg(value_rad: float) -> float:
    """Radians to centidegrees."""
    return math.degrees(value_rad) * 100.0


def deg_to_rad(value_deg: float) -> float:
    """Degrees to radians."""
    return math.radians(value_deg)


def rad_to_deg(value_rad: float) -> float:
    """Radians to degrees."""
    return math.degrees(value_rad)


def mm_to_m(value_mm: float) -> float:
    """Millimetres to metres."""
    return value_mm / 1000.0


def m_to_mm(value_m: float) -> float:
    """Metres to millimetres."""
    return value_m * 1000.0


def cm_to_m(value_cm: float) -> float:
    """Centimetres to metres."""
    return value_cm / 100.0


def m_to_cm(value_m: float) -> float:
    """Metres to centimetres."""
    return value_m * 100.0


def cm_s_to_m_s(value_cm_s: float) -> float:
    """Centimetres per second to metres per second."""
    return value_cm_s / 100.0


def hpa_to_pa(value_hpa: float) -> float:
    """Hectopascals (millibar) to pascals."""
    return value_hpa * 100.0


def cdegc_to_degc(value_cdegc: float) -> float:
    """Centidegrees Celsius to degrees Celsius."""
    return value_cdegc / 100.0


def mv_to_v(value_mv: float) -> float:
    """Millivolts to volts."""
    return value_mv / 1000.0


def ca_to_a(value_ca: float) -> float:
    """Centiamperes to amperes."""
    return value_ca / 100.0


def ms_to_s(value_ms: float) -> float:
    """Milliseconds to seconds."""
    return value_ms / 1000.0


def s_to_us(value_s: float) -> int:
    """Seconds to whole microseconds (rounded)."""
    return int(round(value_s * 1.0e6))


def dege7_to_deg(value_dege7: int) -> float:
    """Degrees * 1e7 (MAVLink ``lat``/``lon`` int32) to degrees."""
    return value_dege7 / _DEG_E7


def deg_to_dege7(value_deg: float) -> int:
    """Degrees to degrees * 1e7, rounded to the nearest integer as MAVLink expects."""
    return int(round(value_deg * _DEG_E7))


def depth_m_from_relative_alt_mm(relative_alt_mm: float) -> float:
    """Depth below the surface from GLOBAL_POSITION_INT.relative_alt (mm, up positive)."""
    return -relative_alt_mm / 1000.0


def depth_m_to_alt_m(depth_m: float) -> float:
    """Depth (down positive) to the altitude-above-origin MAVLink uses (up positive)."""
    return -depth_m


def depth_m_from_pressure_pa(
    press_abs_pa: float,
    surface_pressure_pa: float = STANDARD_ATMOSPHERE_PA,
    water_density_kg_m3: float = SEAWATER_DENSITY_KG_M3,
    gravity_m_s2: float = STANDARD_GRAVITY_M_S2,
) -> float:
    """Hydrostatic depth from absolute pressure: (p - p_surface) / (rho g).

    Parameters
    ----------
    press_abs_pa : float
        Absolute pressure at the sensor, Pa.
    surface_pressure_pa : float
        Pressure at the water surface, Pa (ArduSub calibrates it at boot).
    water_density_kg_m3 : float
        Water density, kg/m^3 (ArduSub's ``BARO_SPEC_GRAV`` times 1000 kg/m^3).
    gravity_m_s2 : float
        Gravity, m/s^2.
    """
    return (press_abs_pa - surface_pressure_pa) / (water_density_kg_m3 * gravity_m_s2)


def tilt_rad_from_mount_pitch_rad(pitch_rad: float) -> float:
    """Sonar tilt (down positive) from a MAVLink mount pitch (up positive)."""
    return -pitch_rad


def mount_pitch_deg_from_tilt_rad(tilt_rad: float) -> float:
    """MAVLink mount pitch in degrees (up positive) for a sonar tilt (down positive)."""
    return -math.degrees(tilt_rad)


def altitude_m_from_range_m(range_m: float, roll_rad: float = 0.0, pitch_rad: float = 0.0) -> float:
    """Vertical height above a flat seabed from a body-down rangefinder's slant range.

    A downward (body z) beam tilted by roll and pitch travels ``h / (cos(roll) cos(pitch))``
    to a horizontal seabed, so ``h = range * cos(roll) * cos(pitch)``.
    """
    return range_m * math.cos(roll_rad) * math.cos(pitch_rad)


def quaternion_wxyz_to_euler_rad(
    q_wxyz: tuple[float, float, float, float],
) -> tuple[float, float, float]:
    """Unit quaternion (w, x, y, z) to (roll, pitch, yaw) in radians, aerospace ZYX order."""
    w, x, y, z = q_wxyz
    norm = math.sqrt(w * w + x * x + y * y + z * z)
    if norm == 0.0 or not math.isfinite(norm):
        raise ValueError(f"quaternion {q_wxyz!r} has no direction (norm {norm})")
    w, x, y, z = w / norm, x / norm, y / norm, z / norm
    roll = math.atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
    sin_pitch = max(-1.0, min(1.0, 2.0 * (w * y - z * x)))
    pitch = math.asin(sin_pitch)
    yaw = math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
    return roll, pitch, yaw


def euler_rad_to_quaternion_wxyz(
    roll_rad: float, pitch_rad: float, yaw_rad: float
) -> tuple[float, float, float, float]:
    """(roll, pitch, yaw) in radians, ZYX order, to a unit quaternion (w, x, y, z)."""
    cr, sr = math.cos(roll_rad / 2.0), math.sin(roll_rad / 2.0)
    cp, sp = math.cos(pitch_rad / 2.0), math.sin(pitch_rad / 2.0)
    cy, sy = math.cos(yaw_rad / 2.0), math.sin(yaw_rad / 2.0)
    return (
        cr * cp * cy + sr * sp * sy,
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
    )
