"""The software ROV's body: dynamics, sensors and its low-level control laws."""

from sim_harness.vehicle.dynamics import (
    AttitudeDisturbance,
    MountMechanics,
    RovParams,
    UniformCurrent,
    derivative,
    slew_tilt,
    step_rk4,
)
from sim_harness.vehicle.sensors import FlatSeabed, SeabedWorld, SensorConfig, SensorReadings, SensorSuite, SlopedSeabed

__all__ = [
    "AttitudeDisturbance",
    "FlatSeabed",
    "MountMechanics",
    "RovParams",
    "SeabedWorld",
    "SensorConfig",
    "SensorReadings",
    "SensorSuite",
    "SlopedSeabed",
    "UniformCurrent",
    "derivative",
    "slew_tilt",
    "step_rk4",
]
