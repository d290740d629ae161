"""Latitude/longitude <-> the EKF's local NED metres, as ArduPilot itself converts them.

ArduSub 4.5 turns its EKF position (metres north/east of the EKF origin) into the
latitude and longitude it reports (GLOBAL_POSITION_INT, HOME_POSITION, mission items)
with ArduPilot's flat-earth ``Location`` arithmetic, not with an ellipsoid: a sphere of
the equatorial radius scaled by ``LOCATION_SCALING_FACTOR`` (1e-7 degree to metres) and
the longitude shrunk by ``cos(latitude)`` at the middle of the step
(ArduSub 4.5: libraries/AP_Common/Location.cpp ``Location::offset`` and
``Location::get_distance_NE``; libraries/AP_Common/Location.h ``LOCATION_SCALING_FACTOR``;
libraries/AP_Math/location.cpp ``longitude_scale``). The simulator reports what a real
sub reports, so it uses the same arithmetic here.

The product itself converts with pymap3d on the WGS84 ellipsoid (:mod:`perception.geodesy`).
The two differ by the sphere's shape: about 0.17 % of a north-south distance at 43 deg
latitude (17 cm over 100 m); the product flies local NED targets (no conversion), so the
difference shows only in latitudes and longitudes the vehicle reports or is given.
"""

from __future__ import annotations

import math

#: 1e-7 degree of latitude in metres on ArduPilot's sphere (Location.h).
LOCATION_SCALING_FACTOR_M = 0.011131884502145034
#: Its inverse, 1e-7 degree per metre (Location.h).
LOCATION_SCALING_FACTOR_INV = 89.83204953368922


def longitude_scale(lat_deg: float) -> float:
    """``cos(lat)``, never below 0.01 (AP_Math/location.cpp ``longitude_scale``)."""
    return max(math.cos(math.radians(lat_deg)), 0.01)


def ned_to_latlon(north_m: float, east_m: float, origin_lat_deg: float, origin_lon_deg: float) -> tuple[float, float]:
    """(lat_deg, lon_deg) of a point ``north_m``, ``east_m`` from the origin (``Location::offset``)."""
    dlat_e7 = north_m * LOCATION_SCALING_FACTOR_INV
    lat_deg = origin_lat_deg + dlat_e7 * 1e-7
    dlng_e7 = east_m * LOCATION_SCALING_FACTOR_INV / longitude_scale(origin_lat_deg + 0.5 * dlat_e7 * 1e-7)
    lon_deg = (origin_lon_deg + dlng_e7 * 1e-7 + 180.0) % 360.0 - 180.0
    return lat_deg, lon_deg


def latlon_to_ned(lat_deg: float, lon_deg: float, origin_lat_deg: float, origin_lon_deg: float) -> tuple[float, float]:
    """(north_m, east_m) of a point from the origin (``Location::get_distance_NE``)."""
    north = (lat_deg - origin_lat_deg) * 1e7 * LOCATION_SCALING_FACTOR_M
    dlon = (lon_deg - origin_lon_deg + 180.0) % 360.0 - 180.0
    east = dlon * 1e7 * LOCATION_SCALING_FACTOR_M * longitude_scale(0.5 * (lat_deg + origin_lat_deg))
    return north, east
