"""The vehicle's vertical state: pressure depth, sonar altitude, the altitude filter that supplies dH."""

from perception.navigation.altitude_filter import AltitudeFilter, AltitudeFilterConfig, UpdateResult
from perception.navigation.pressure import (
    ARDUSUB_GRAVITY_M_S2,
    PA_PER_HPA,
    SEA_WATER_SPECIFIC_GRAVITY,
    STANDARD_ATMOSPHERE_PA,
    depth_from_pressure_m,
    pascals_per_metre,
    pressure_from_depth_pa,
    surface_pressure_from_samples_pa,
)
from perception.navigation.seabed_start import find_seabed_start, sonar_altitude, steepest_down_component
from perception.navigation.smoother import process_noise, transition

__all__ = [
    "ARDUSUB_GRAVITY_M_S2",
    "AltitudeFilter",
    "AltitudeFilterConfig",
    "PA_PER_HPA",
    "SEA_WATER_SPECIFIC_GRAVITY",
    "STANDARD_ATMOSPHERE_PA",
    "UpdateResult",
    "depth_from_pressure_m",
    "find_seabed_start",
    "pascals_per_metre",
    "pressure_from_depth_pa",
    "process_noise",
    "sonar_altitude",
    "steepest_down_component",
    "surface_pressure_from_samples_pa",
    "transition",
]
