"""Placing the sonar in a scene: poses from altitudes, and a tilt that frames the shadows.

Conventions of :mod:`perception.geometry`: depression of the beam axis below the horizontal
= ``tilt - pitch`` for a forward-looking sonar; altitude positive up from the seabed.
"""

from __future__ import annotations

import math

import numpy as np

from sim_harness.sonar.renderer import SonarConfig, SonarPose
from sim_harness.sonar.scene import Scene
from sim_harness.world.errors import PoseError
from sim_harness.world.world import World


def choose_tilt_rad(
    world: World,
    *,
    north_m: float,
    east_m: float,
    altitude_m: float,
    heading_rad: float,
    pitch_rad: float,
    config: SonarConfig,
) -> float:
    """A mount tilt that puts the targets in view and their whole shadows in the band.

    Targets count when their centre lies inside the fan's azimuths and their slant range
    inside the window. The beam axis is aimed half-way between the steepest ray to a
    target's near foot and the shallowest ray over a target's far top edge (which is where
    its shadow ends, on a flat seabed). Without targets in view the axis is aimed at the
    middle of the range window.

    Raises
    ------
    PoseError
        For a non-positive altitude.
    """
    if not (math.isfinite(altitude_m) and altitude_m > 0):
        raise PoseError(f"altitude must be finite and > 0 m, got {altitude_m!r}", field="altitude_m")
    az = np.asarray(config.beam_azimuth_rad)
    fan_lo, fan_hi = float(az[0]), float(az[-1])
    steepest, shallowest = -math.inf, math.inf
    for placed in world.placed:
        corners = placed.corners_ned
        dn = corners[:, 0] - north_m
        de = corners[:, 1] - east_m
        fwd = dn * math.cos(heading_rad) + de * math.sin(heading_rad)
        side = -dn * math.sin(heading_rad) + de * math.cos(heading_rad)
        if np.any(fwd <= 0):
            continue
        centre_az = math.atan2(float(side.mean()), float(fwd.mean()))
        ground = np.hypot(fwd, side)
        if not fan_lo <= centre_az <= fan_hi:
            continue
        if math.hypot(float(ground.max()), altitude_m) > config.window_end_m:
            continue
        h = placed.spec.height_m
        steepest = max(steepest, math.atan2(altitude_m, float(ground.min())))
        shallowest = min(shallowest, math.atan2(max(altitude_m - h, 1e-3), float(ground.max())))
    if math.isinf(steepest):
        r_mid = config.window_start_m + 0.5 * config.window_length_m
        depression = math.asin(min(1.0, altitude_m / r_mid))
    else:
        depression = 0.5 * (steepest + shallowest)
    return depression + pitch_rad


def scene_pose(
    scene: Scene,
    altitude_m: float,
    config: SonarConfig,
    *,
    north_m: float | None = None,
    east_m: float | None = None,
    heading_rad: float | None = None,
    tilt_rad: float | None = None,
) -> SonarPose:
    """The pose at ``altitude_m`` above the seabed, from the scene's viewpoint by default.

    ``tilt_rad`` None: the viewpoint's tilt when it has one, else :func:`choose_tilt_rad`.
    """
    vp = scene.viewpoint
    n = vp.north_m if north_m is None else north_m
    e = vp.east_m if east_m is None else east_m
    heading = vp.heading_rad if heading_rad is None else heading_rad
    if not (math.isfinite(altitude_m) and altitude_m > 0):
        raise PoseError(f"altitude must be finite and > 0 m, got {altitude_m!r}", field="altitude_m")
    depth = scene.world.seabed_depth_m(n, e) - altitude_m
    if depth < 0:
        raise PoseError(
            f"altitude {altitude_m} m puts the sonar above the water surface (seabed at "
            f"{scene.world.seabed_depth_m(n, e):.3f} m)",
            field="altitude_m",
        )
    if tilt_rad is None:
        tilt_rad = vp.tilt_rad
    if tilt_rad is None or math.isnan(tilt_rad):
        tilt_rad = choose_tilt_rad(
            scene.world, north_m=n, east_m=e, altitude_m=altitude_m, heading_rad=heading,
            pitch_rad=vp.pitch_rad, config=config,
        )
    return SonarPose(n, e, depth, heading, vp.pitch_rad, vp.roll_rad, tilt_rad)
