"""The autopilot's navigation state: EKF origin, home, and whether it has a position.

ArduSub 4.5 (Sub-4.5 @30257f0118), as a BlueROV2 with the BlueOS DVL extension runs it:

- **Position.** ``Sub::position_ok`` (ArduSub/system.cpp): with visual odometry enabled
  (VISO_TYPE, which the DVL extension sets) a relative position from the DVL is enough
  (``optflow_position_ok``: ``horiz_pos_rel``); otherwise an absolute one is needed, i.e.
  an EKF origin (``ekf_position_ok``: ``horiz_pos_abs``). The DVL's bottom lock stands
  for the EKF's aiding here; EKF3's own fusion timeouts are not modelled: the flags drop
  with the lock.
- **EKF origin.** Unset at boot (no GPS). SET_GPS_GLOBAL_ORIGIN sets it once and is
  ignored afterwards (``GCS_MAVLINK::set_ekf_origin``, GCS_Common.cpp); the DVL extension
  sends it when its user sets the vehicle's position. At arming, with no origin, the
  backup ORIGIN_LAT/LON/ALT parameters are used if set (``Sub::ensure_ekf_origin``,
  ArduSub.cpp).
- **Home.** Set automatically, once, when the EKF has an origin and a location
  (``Sub::update_home_from_EKF``, commands.cpp), at the water surface
  (``set_home_to_current_location``: ``alt -= baro altitude``); never moved afterwards.
- Without an origin there is no global position: GLOBAL_POSITION_INT carries lat/lon 0
  (``send_global_position_int`` sends the last known location, none yet).

Altitudes are AMSL metres; the EKF's local z = 0 is at the water surface (the depth
sensor is zeroed there), so a vehicle at depth ``d`` is at ``origin_alt - d`` AMSL.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from sim_harness.autopilot.location import latlon_to_ned, ned_to_latlon
from sim_harness.vehicle.sensors import SensorReadings


@dataclass(frozen=True)
class GeoPoint:
    """A WGS84 point: degrees, metres AMSL."""

    lat_deg: float
    lon_deg: float
    alt_m: float


class Navigation:
    """EKF origin and home; what the vehicle can say about where it is."""

    def __init__(self, origin: GeoPoint | None = None) -> None:
        self.origin: GeoPoint | None = origin
        self.home: GeoPoint | None = None

    def position_ok(self, r: SensorReadings | None, params: Mapping[str, float]) -> bool:
        """``Sub::position_ok`` (ArduSub/system.cpp): relative position with visual odometry
        enabled, else an absolute one (needs the EKF origin)."""
        if r is None or not r.position_ok:
            return False
        return int(params["VISO_TYPE"]) != 0 or self.origin is not None

    def set_origin(self, point: GeoPoint) -> bool:
        """SET_GPS_GLOBAL_ORIGIN (``GCS_MAVLINK::set_ekf_origin``): True if it took effect
        (an invalid point, or an origin already set, is ignored)."""
        if self.origin is not None:
            return False
        if not (-90.0 <= point.lat_deg <= 90.0 and -180.0 <= point.lon_deg <= 180.0):
            return False
        self.origin = point
        return True

    def backup_origin(self, params: Mapping[str, float]) -> GeoPoint | None:
        """ORIGIN_LAT/LON/ALT if both lat and lon are non-zero (``Sub::ensure_ekf_origin``)."""
        lat, lon = params["ORIGIN_LAT"], params["ORIGIN_LON"]
        if lat == 0.0 or lon == 0.0:
            return None
        return GeoPoint(lat, lon, params["ORIGIN_ALT"])

    def update_home(self, r: SensorReadings | None, params: Mapping[str, float]) -> bool:
        """``Sub::update_home_from_EKF``: set home once the EKF has an origin and a
        location; True on the step it is set."""
        if self.home is not None or self.origin is None or not self.position_ok(r, params):
            return False
        assert r is not None
        here = self.location(r)
        assert here is not None
        self.home = GeoPoint(here.lat_deg, here.lon_deg, self.origin.alt_m)  # at the surface
        return True

    def location(self, r: SensorReadings) -> GeoPoint | None:
        """The vehicle's estimated location (``ahrs.get_location``); None without an origin."""
        if self.origin is None:
            return None
        lat, lon = ned_to_latlon(r.north_m, r.east_m, self.origin.lat_deg, self.origin.lon_deg)
        return GeoPoint(lat, lon, self.origin.alt_m - r.depth_m)

    def ned_of(self, lat_deg: float, lon_deg: float) -> tuple[float, float] | None:
        """(north, east) m of a point about the EKF origin
        (``Location::get_vector_from_origin_NEU``); None without an origin."""
        if self.origin is None:
            return None
        return latlon_to_ned(lat_deg, lon_deg, self.origin.lat_deg, self.origin.lon_deg)

    def up_from_origin_m(self, alt_m: float, *, above_home: bool) -> float | None:
        """Height above the EKF origin of an altitude above sea level or above home
        (``Location::get_alt_cm(ABOVE_ORIGIN)``); None without an origin, or without a home
        for one above home."""
        if self.origin is None:
            return None
        if not above_home:
            return alt_m - self.origin.alt_m
        if self.home is None:
            return None
        return alt_m + self.home.alt_m - self.origin.alt_m

    def home_depth_offset_m(self) -> float:
        """Depth of home below the EKF origin's altitude (0: both at the surface)."""
        if self.origin is None or self.home is None:
            return 0.0
        return self.origin.alt_m - self.home.alt_m
