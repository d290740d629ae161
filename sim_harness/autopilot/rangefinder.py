"""The downward rangefinder as ArduSub 4.5 uses it (ArduSub/sensors.cpp).

``Sub::init_rangefinder``: enabled once, at boot, when RNGFND1_TYPE is set and
RNGFND1_ORIENT is 25 (pitch 270, down) - changing either needs a reboot.
``Sub::read_rangefinder``: a reading counts as healthy only after
``RANGEFINDER_HEALTH_MAX`` (3) good ones in a row, within RNGFND1_MIN_CM..RNGFND1_MAX_CM
(``AP_RangeFinder_MAVLink`` clips to the tighter of the parameters and the sensor's own
limits; the simulated DVL reports 0..50 m).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace

from sim_harness.vehicle.sensors import SensorReadings

RANGEFINDER_HEALTH_COUNT = 3  # ArduSub/sensors.cpp RANGEFINDER_HEALTH_MAX


class Rangefinder:
    """Whether the rangefinder is enabled, and which readings the autopilot trusts."""

    def __init__(self, params: Mapping[str, float]) -> None:
        self.enabled = int(params["RNGFND1_TYPE"]) != 0 and int(params["RNGFND1_ORIENT"]) == 25
        self._good = 0

    def filter(self, r: SensorReadings, params: Mapping[str, float]) -> SensorReadings:
        """``r`` with ``altitude_m`` None unless the autopilot would use the reading."""
        alt = r.altitude_m
        lo, hi = params["RNGFND1_MIN_CM"] / 100.0, params["RNGFND1_MAX_CM"] / 100.0
        good = self.enabled and alt is not None and lo <= alt <= hi
        self._good = self._good + 1 if good else 0
        if self._good >= RANGEFINDER_HEALTH_COUNT or alt is None:
            return r
        return replace(r, altitude_m=None)
