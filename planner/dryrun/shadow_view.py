"""The judge's geometry: from the simulator's per-beam truth, which tilts show a target's
whole shadow (and the seabed at the window's end) inside the vertical aperture."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from perception.geometry import rot_x, rot_y


def shadow_visible_at_tilts(
    beam_azimuth_rad: np.ndarray,
    start_slant_m: np.ndarray,
    end_slant_m: np.ndarray,
    *,
    altitude_m: float,
    pitch_rad: float,
    roll_rad: float,
    tilt_rad: np.ndarray,
    elevation_aperture_rad: float,
) -> np.ndarray:
    """Truth side: for each tilt, is a target's whole shadow on insonified seabed?

    The simulator's definition (``sim_harness.sonar.truth``, ``in_band``), evaluated at other
    tilts: on every beam the target's shadow covers, the seabed at the shadow's start
    and end slant ranges lies inside the vertical aperture. A seabed point at slant ``r``
    on a beam of azimuth ``az`` has the elevation ``e`` (nearest the beam axis) with
    ``r (A cos e + B sin e) = H``, ``(A, B)`` from the sonar-to-level rotation's third
    row. The per-beam ranges are the frame's (the beam planes move little with the tilt).

    Parameters
    ----------
    beam_azimuth_rad, start_slant_m, end_slant_m : ndarray, shape (n_beams,)
        The shadow's beams (sonar frame, rad) and slant ranges, m.
    altitude_m, pitch_rad, roll_rad : float
        The sonar's altitude (m) and the vehicle's attitude (rad) at the frame.
    tilt_rad : ndarray, shape (n_tilts,)
        Tilts to try, rad (positive down).

    Returns
    -------
    ndarray of bool, shape (n_tilts,)
    """
    tilts = np.asarray(tilt_rad, dtype=np.float64)
    attitude_row = (rot_y(pitch_rad) @ rot_x(roll_rad))[2]
    # third row of attitude @ rot_y(-tilt), for every tilt: shape (n_tilts, 3)
    c, s = np.cos(-tilts), np.sin(-tilts)
    row = np.stack([attitude_row[0] * c - attitude_row[2] * s, np.full_like(c, attitude_row[1]),
                    attitude_row[0] * s + attitude_row[2] * c], axis=-1)
    az = np.asarray(beam_azimuth_rad, dtype=np.float64)[None, :]
    a = row[:, 0:1] * np.cos(az) + row[:, 1:2] * np.sin(az)
    b = np.broadcast_to(row[:, 2:3], a.shape)
    amp = np.hypot(a, b)
    phi = np.arctan2(b, a)
    half = elevation_aperture_rad / 2.0
    ok = np.ones(tilts.shape, dtype=bool)
    for slant in (start_slant_m, end_slant_m):
        ratio = altitude_m / (np.asarray(slant, dtype=np.float64)[None, :] * amp)
        spread = np.arccos(np.clip(ratio, -1.0, 1.0))
        e1 = np.mod(phi - spread + math.pi, 2 * math.pi) - math.pi
        e2 = np.mod(phi + spread + math.pi, 2 * math.pi) - math.pi
        e = np.where(np.abs(e1) <= np.abs(e2), e1, e2)
        ok &= np.all((ratio <= 1.0) & (np.abs(e) <= half), axis=1)
    return ok


def tilts_near(tilt_grid: np.ndarray, start_slant_m: np.ndarray, end_slant_m: np.ndarray, *, altitude_m: float,
               pitch_rad: float, roll_rad: float, aperture_rad: float) -> np.ndarray:
    """The tilts of ``tilt_grid`` (rad) that can show any of the shadow (slant ranges from
    its start to its end): those whose beam axis lies within the half aperture of the
    shadow's depressions, widened by the attitude and 3 deg for the fan's curvature; a
    tilt outside shows none of it."""
    near_dep = math.asin(min(1.0, altitude_m / max(float(np.min(start_slant_m)), altitude_m)))
    far_dep = math.asin(min(1.0, altitude_m / max(float(np.max(end_slant_m)), altitude_m)))
    slack = aperture_rad / 2 + abs(pitch_rad) + abs(roll_rad) + math.radians(3.0)
    return (tilt_grid >= near_dep - slack) & (tilt_grid <= far_dep + slack)


def holdable_tilts(beam_azimuth_rad: np.ndarray, start_slant_m: np.ndarray, end_slant_m: np.ndarray, *,
                   altitude_m: float, pitch_rad: float, roll_rad: float, tilt_grid: np.ndarray,
                   aperture_rad: float, window_end_m: float) -> np.ndarray:
    """For each tilt of ``tilt_grid``: do the shadow and the seabed at the window's end
    (``window_end_m`` on the shadow's beams) both lie inside ``aperture_rad``? Computed
    only at the tilts that can show the shadow (:func:`tilts_near`)."""
    near = tilts_near(tilt_grid, start_slant_m, end_slant_m, altitude_m=altitude_m, pitch_rad=pitch_rad,
                      roll_rad=roll_rad, aperture_rad=aperture_rad)
    out = np.zeros(tilt_grid.shape, dtype=bool)
    if not near.any():
        return out
    far_end = np.full(np.shape(beam_azimuth_rad), window_end_m)
    tilts = tilt_grid[near]
    out[near] = shadow_visible_at_tilts(
        beam_azimuth_rad, start_slant_m, end_slant_m, altitude_m=altitude_m, pitch_rad=pitch_rad,
        roll_rad=roll_rad, tilt_rad=tilts, elevation_aperture_rad=aperture_rad,
    ) & shadow_visible_at_tilts(
        beam_azimuth_rad, far_end, far_end, altitude_m=altitude_m, pitch_rad=pitch_rad, roll_rad=roll_rad,
        tilt_rad=tilts, elevation_aperture_rad=aperture_rad,
    )
    return out


def visible_tilts(tt: Any, azimuths: np.ndarray, tilt_grid: np.ndarray, *, altitude_m: float, pitch_rad: float,
                   roll_rad: float, aperture_rad: float) -> np.ndarray:
    """For each tilt of ``tilt_grid`` (rad), does it show the truth target ``tt``'s whole shadow?

    Only tilts whose beam axis is within the aperture (and a few degrees for the attitude
    and the fan's curvature) of the shadow can show it; the others are not computed.
    """
    near = tilts_near(tilt_grid, np.asarray(tt.shadow_start_m), np.asarray(tt.shadow_end_m), altitude_m=altitude_m,
                      pitch_rad=pitch_rad, roll_rad=roll_rad, aperture_rad=aperture_rad)
    visible = np.zeros(tilt_grid.shape, dtype=bool)
    visible[near] = shadow_visible_at_tilts(
        azimuths[np.asarray(tt.beams, dtype=int)], np.asarray(tt.shadow_start_m), np.asarray(tt.shadow_end_m),
        altitude_m=altitude_m, pitch_rad=pitch_rad, roll_rad=roll_rad, tilt_rad=tilt_grid[near],
        elevation_aperture_rad=aperture_rad)
    return visible
