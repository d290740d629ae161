"""Shadows for the loop from what perception measured or from the map (NED positions)."""

from __future__ import annotations

import math

import numpy as np

from perception.errors import GeometryError, MeasurementError
from perception.geometry import ray_angles_sonar, sonar_to_ned
from planner.pitch.types import TrackedShadow


def shadow_from_measurement(
    target_id: int | str,
    *,
    top_slant_m: float,
    end_slant_m: float,
    azimuth_rad: float,
    altitude_m: float,
    tilt_rad: float,
    pitch_rad: float,
    footprint_m: float = 0.0,
) -> TrackedShadow:
    """A measured shadow (slant ranges from range ZERO) as the loop's target model.

    ``h = H (r_end - r_top) / r_end``; the shadow end's ray has depression
    ``asin(H / r_end)``; with the beam azimuth and the pose of the frame that fixes its
    elevation (the root inside the aperture), hence the ray's level-frame direction, and
    the top edge lies on it at ``r_top`` (so ``g_top = sqrt(r_top^2 - (H - h)^2)``).

    Parameters
    ----------
    top_slant_m, end_slant_m : float
        Slant ranges of the target's top edge and of the shadow end, m.
    azimuth_rad : float
        Beam azimuth of the shadow in the sonar frame, rad (positive to starboard).
    altitude_m, tilt_rad, pitch_rad : float
        Sonar altitude (m), mount tilt and vehicle pitch (rad) when the frame was taken.

    Raises
    ------
    MeasurementError
        For ranges that are not finite, an end not beyond the top or nearer than the
        altitude, or a pose for which no ray of that beam meets the seabed there.
    """
    r_top, r_end, alt = float(top_slant_m), float(end_slant_m), float(altitude_m)
    if not all(math.isfinite(v) for v in (r_top, r_end, alt, azimuth_rad, tilt_rad, pitch_rad)):
        raise MeasurementError("non-finite shadow measurement or pose", sensor="sonar")
    if not (alt > 0 and 0 < r_top < r_end and r_end >= alt):
        raise MeasurementError(
            f"need 0 < top ({r_top!r} m) < end ({r_end!r} m) and end >= altitude ({alt!r} m)", sensor="sonar")
    h = alt * (r_end - r_top) / r_end
    d = tilt_rad - pitch_rad
    a_coef, b_coef = math.sin(d) * math.cos(azimuth_rad), math.cos(d)
    amp = math.hypot(a_coef, b_coef)
    ratio = (alt / r_end) / amp
    if ratio > 1.0 + 1e-12:
        raise MeasurementError(
            f"no ray of beam azimuth {azimuth_rad!r} rad reaches the seabed at {r_end!r} m with this pose",
            sensor="sonar")
    phi = math.atan2(b_coef, a_coef)
    spread = math.acos(min(1.0, ratio))
    roots = [phi - spread, phi + spread]
    roots = [math.atan2(math.sin(r), math.cos(r)) for r in roots]
    e = min(roots, key=abs)
    u = sonar_to_ned(tilt_rad=tilt_rad, pitch_rad=pitch_rad) @ np.array(
        [math.cos(e) * math.cos(azimuth_rad), math.cos(e) * math.sin(azimuth_rad), math.sin(e)])
    return TrackedShadow(target_id, float(r_top * u[0]), float(r_top * u[1]), h, footprint_m, True)


def shadow_measurement(
    shadow: TrackedShadow, *, altitude_m: float, tilt_rad: float, pitch_rad: float
) -> tuple[float, float, float]:
    """Forward model: what the sonar measures of a target, ``(r_top_m, r_end_m, azimuth_rad)``.

    A direct ray computation with :func:`perception.geometry.sonar_to_ned`
    (the inverse of :func:`shadow_from_measurement`; ``height_m`` must be set).
    """
    if shadow.height_m is None:
        raise GeometryError(f"target {shadow.target_id!r}: height_m is needed for a measurement")
    depth = altitude_m - shadow.height_m
    if depth <= 0:
        raise GeometryError(f"target {shadow.target_id!r} is as tall as the altitude or taller")
    p = np.array([shadow.along_m, shadow.cross_m, depth])
    r_top = float(np.linalg.norm(p))
    p_sonar = sonar_to_ned(tilt_rad=tilt_rad, pitch_rad=pitch_rad).T @ p
    az, _ = ray_angles_sonar(p_sonar)
    return r_top, r_top * altitude_m / depth, float(az)


def shadow_from_ned(
    target_id: int | str,
    *,
    target_ned_m: tuple[float, float],
    sonar_ned_m: tuple[float, float],
    heading_rad: float,
    height_m: float | None = None,
    footprint_m: float = 0.0,
) -> TrackedShadow:
    """A mapped target (far top edge at north/east ``target_ned_m``) in the level frame.

    For targets known from a previous pass but not in the current frame
    (``measured=False``).
    """
    dn, de = target_ned_m[0] - sonar_ned_m[0], target_ned_m[1] - sonar_ned_m[1]
    c, s = math.cos(heading_rad), math.sin(heading_rad)
    return TrackedShadow(target_id, dn * c + de * s, -dn * s + de * c, height_m, footprint_m, False)
