"""Geometry of the sonar, its mount and the seabed: frames and signs, slant and ground range,
the insonified band, the shadow relation, the mount's slew and frames.

- :mod:`perception.geometry.sonar`: frames and signs (the one place they are written down),
  slant/ground range, ray depression, the insonified band, rotations, seabed planes;
- :mod:`perception.geometry.shadow`: ``r_end = r_top H / (H - h)`` and the height clamp;
- :mod:`perception.geometry.mount`: the mount's slew and its body and earth frames.
"""

from perception.geometry.mount import body_from_earth_tilt_rad, earth_from_body_tilt_rad, slew_toward
from perception.geometry.shadow import (
    MAX_HEIGHT_OVER_ALTITUDE,
    clamp_height_m,
    height_from_shadow_m,
    shadow_end_slant_m,
    shadow_scale,
)
from perception.geometry.sonar import (
    FloatArray,
    SeabedBand,
    SeabedPlane,
    altitude_from_band_start,
    ground_to_slant,
    insonified_band,
    ray_angles_sonar,
    ray_depression_of_angles_rad,
    ray_depression_rad,
    ray_direction_sonar,
    rot_x,
    rot_y,
    rot_z,
    seabed_hit_slant_m,
    slant_for_depression,
    slant_to_ground,
    sonar_to_ned,
)

__all__ = [
    "FloatArray",
    "MAX_HEIGHT_OVER_ALTITUDE",
    "SeabedBand",
    "SeabedPlane",
    "altitude_from_band_start",
    "body_from_earth_tilt_rad",
    "clamp_height_m",
    "earth_from_body_tilt_rad",
    "ground_to_slant",
    "height_from_shadow_m",
    "insonified_band",
    "ray_angles_sonar",
    "ray_depression_of_angles_rad",
    "ray_depression_rad",
    "ray_direction_sonar",
    "rot_x",
    "rot_y",
    "rot_z",
    "seabed_hit_slant_m",
    "shadow_end_slant_m",
    "shadow_scale",
    "slant_for_depression",
    "slant_to_ground",
    "slew_toward",
    "sonar_to_ned",
]
