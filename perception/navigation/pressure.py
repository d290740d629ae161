"""Depth from absolute pressure, hydrostatic, as ArduSub's water barometer does it.

``depth_m = (absolute_pressure_pa - surface_pressure_pa) / (rho_kg_m3 * gravity_m_s2)``
with ``rho_kg_m3 = 1000 * specific_gravity`` (ArduSub's ``BARO_SPEC_GRAV``: 1.0 fresh
water, 1.024 sea water). Depth is positive down (see :mod:`perception.geometry`).

Units: pascals here. MAVLink's ``SCALED_PRESSURE2.press_abs`` is in hPa on the wire
(1 hPa = 100 Pa); vehicle_link converts it before it reaches this module.

ArduSub itself (``AP_Baro::update``, water sensors) divides by a rounded 9800 Pa/m per
unit specific gravity, not by ``1000 * 9.80665``; the depth it reports in
``GLOBAL_POSITION_INT`` is therefore 0.07 % larger than the one computed here with the
default gravity. Pass ``gravity_m_s2=ARDUSUB_GRAVITY_M_S2`` to match it exactly.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from perception.errors import MeasurementError

#: Standard gravity, m/s^2.
STANDARD_GRAVITY_M_S2 = 9.80665
#: The gravity implied by ArduSub's 9800 Pa per metre of fresh water, m/s^2.
ARDUSUB_GRAVITY_M_S2 = 9.8
#: Specific gravity of fresh water (ArduSub ``BARO_SPEC_GRAV`` default).
FRESH_WATER_SPECIFIC_GRAVITY = 1.0
#: Specific gravity of sea water as ArduSub documents it.
SEA_WATER_SPECIFIC_GRAVITY = 1.024
#: Standard sea-level atmospheric pressure, Pa.
STANDARD_ATMOSPHERE_PA = 101_325.0
#: Pascals per hectopascal (``SCALED_PRESSURE*.press_abs`` is in hPa).
PA_PER_HPA = 100.0


def _check_fluid(specific_gravity: float, gravity_m_s2: float) -> float:
    sg = float(specific_gravity)
    g = float(gravity_m_s2)
    if not (math.isfinite(sg) and 0.5 <= sg <= 1.5):
        raise MeasurementError(
            f"specific gravity must be in [0.5, 1.5] (fresh 1.0, sea 1.024), got {specific_gravity!r}",
            sensor="pressure",
            value=specific_gravity,
        )
    if not (math.isfinite(g) and g > 0):
        raise MeasurementError(
            f"gravity must be finite and > 0 m/s^2, got {gravity_m_s2!r}",
            sensor="pressure",
            value=gravity_m_s2,
        )
    return 1000.0 * sg * g


def pascals_per_metre(
    *, specific_gravity: float = FRESH_WATER_SPECIFIC_GRAVITY, gravity_m_s2: float = STANDARD_GRAVITY_M_S2
) -> float:
    """Hydrostatic pressure gradient ``rho * g``, Pa/m."""
    return _check_fluid(specific_gravity, gravity_m_s2)


def depth_from_pressure_m(
    absolute_pressure_pa: ArrayLike,
    *,
    surface_pressure_pa: float = STANDARD_ATMOSPHERE_PA,
    specific_gravity: float = FRESH_WATER_SPECIFIC_GRAVITY,
    gravity_m_s2: float = STANDARD_GRAVITY_M_S2,
) -> np.ndarray:
    """Depth below the surface from absolute pressure.

    Parameters
    ----------
    absolute_pressure_pa : array_like
        Absolute pressure, Pa (> 0, finite), any shape.
    surface_pressure_pa : float
        Absolute pressure at the water surface, Pa (> 0).
    specific_gravity : float
        Fluid density over 1000 kg/m^3 (fresh 1.0, sea 1.024).
    gravity_m_s2 : float
        Gravity, m/s^2.

    Returns
    -------
    ndarray
        Depth, m, positive down, same shape as the input (a 0-d array for a scalar).

    Raises
    ------
    MeasurementError
        For a non-finite or non-positive pressure, or an implausible fluid.
    """
    rho_g = _check_fluid(specific_gravity, gravity_m_s2)
    p0 = float(surface_pressure_pa)
    if not (math.isfinite(p0) and p0 > 0):
        raise MeasurementError(
            f"surface pressure must be finite and > 0 Pa, got {surface_pressure_pa!r}",
            sensor="pressure",
            value=surface_pressure_pa,
        )
    p = np.asarray(absolute_pressure_pa, dtype=np.float64)
    if not np.all(np.isfinite(p)):
        raise MeasurementError("absolute pressure must be finite (got NaN or inf)", sensor="pressure")
    if np.any(p <= 0):
        raise MeasurementError(
            f"absolute pressure must be > 0 Pa, got minimum {float(np.min(p))!r}",
            sensor="pressure",
            value=float(np.min(p)),
        )
    return (p - p0) / rho_g


def pressure_from_depth_pa(
    depth_m: ArrayLike,
    *,
    surface_pressure_pa: float = STANDARD_ATMOSPHERE_PA,
    specific_gravity: float = FRESH_WATER_SPECIFIC_GRAVITY,
    gravity_m_s2: float = STANDARD_GRAVITY_M_S2,
) -> np.ndarray:
    """Absolute pressure at a depth, Pa: the inverse of :func:`depth_from_pressure_m`."""
    rho_g = _check_fluid(specific_gravity, gravity_m_s2)
    d = np.asarray(depth_m, dtype=np.float64)
    if not np.all(np.isfinite(d)):
        raise MeasurementError("depth must be finite", sensor="depth")
    return float(surface_pressure_pa) + d * rho_g


def surface_pressure_from_samples_pa(absolute_pressure_pa: ArrayLike) -> float:
    """Surface pressure from samples taken at the surface: their median, Pa.

    Raises
    ------
    MeasurementError
        For no samples, or any non-finite or non-positive sample.
    """
    p = np.asarray(absolute_pressure_pa, dtype=np.float64).ravel()
    if p.size == 0:
        raise MeasurementError("no surface pressure samples", sensor="pressure")
    if not np.all(np.isfinite(p)) or np.any(p <= 0):
        raise MeasurementError("surface pressure samples must be finite and > 0 Pa", sensor="pressure")
    return float(np.median(p))
