"""The vehicle's vertical state: pressure depth, sonar altitude, the altitude filter that supplies dH.

Public names are imported on first use (:mod:`perception.lazy_exports`): the height
pipeline reads the seabed's start (:mod:`perception.navigation.seabed_start`) without
loading the altitude filter, whose filterpy pulls in scipy.stats (about 1 s at start-up
in every process that measures heights: the map process, ``shadowsurvey heights``).
"""

from perception.lazy_exports import lazy_exports

_EXPORTS = {
    "AltitudeFilter": "perception.navigation.altitude_filter",
    "AltitudeFilterConfig": "perception.navigation.altitude_filter",
    "UpdateResult": "perception.navigation.altitude_filter",
    "ARDUSUB_GRAVITY_M_S2": "perception.navigation.pressure",
    "PA_PER_HPA": "perception.navigation.pressure",
    "SEA_WATER_SPECIFIC_GRAVITY": "perception.navigation.pressure",
    "STANDARD_ATMOSPHERE_PA": "perception.navigation.pressure",
    "depth_from_pressure_m": "perception.navigation.pressure",
    "pascals_per_metre": "perception.navigation.pressure",
    "pressure_from_depth_pa": "perception.navigation.pressure",
    "surface_pressure_from_samples_pa": "perception.navigation.pressure",
    "find_seabed_start": "perception.navigation.seabed_start",
    "sonar_altitude": "perception.navigation.seabed_start",
    "steepest_down_component": "perception.navigation.seabed_start",
    "process_noise": "perception.navigation.smoother",
    "transition": "perception.navigation.smoother",
}
__all__ = sorted(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
