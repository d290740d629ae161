"""A small forward model for mosaic tests: a textured flat seabed seen by a sonar.

Independent of perception.mapping.mosaic (which maps backwards, mosaic cell -> sonar): here each
polar sample is traced forwards to the seabed by solving for the elevation inside the
vertical aperture at which its beam meets the seabed at its slant range.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from perception.geometry import sonar_to_ned
from perception.sonar_io.frame import SonarFrame


def texture(rng: np.random.Generator, size_cells: int, *, blur_cells: float = 2.0) -> np.ndarray:
    """A persistent seabed reflectivity map (rows north, cols east), values ~ 40..200."""
    noise = rng.random((size_cells, size_cells)).astype(np.float32)
    smooth = cv2.GaussianBlur(noise, (0, 0), blur_cells)
    smooth = (smooth - smooth.min()) / (np.ptp(smooth) + 1e-9)
    return 40.0 + 160.0 * smooth


def seabed_points(
    *, range_m: np.ndarray, azimuth_rad: np.ndarray, aperture_rad: float, altitude_m: float,
    tilt_rad: float, heading_rad: float, pitch_rad: float = 0.0, roll_rad: float = 0.0,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(north, east, valid) of each polar sample's seabed point relative to the sonar."""
    rot = sonar_to_ned(tilt_rad=tilt_rad, pitch_rad=pitch_rad, roll_rad=roll_rad, heading_rad=heading_rad)
    r = range_m[:, None]
    a = azimuth_rad[None, :]
    # down component of direction (cos e cos a, cos e sin a, sin e): A cos e + B sin e = H / r
    big_a = np.cos(a) * rot[2, 0] + np.sin(a) * rot[2, 1]
    big_b = np.full_like(big_a, rot[2, 2])
    amp = np.hypot(big_a, big_b)
    phi = np.arctan2(big_b, big_a)
    ratio = altitude_m / (r * amp)
    ok = ratio <= 1.0
    delta = np.arccos(np.clip(ratio, -1.0, 1.0))
    e1 = phi - delta
    e2 = phi + delta
    half = aperture_rad / 2
    e = np.where(np.abs(e1) <= half, e1, e2)
    ok &= np.abs(e) <= half
    d = np.stack([np.cos(e) * np.cos(a) * np.ones_like(r), np.cos(e) * np.sin(a) * np.ones_like(r),
                  np.sin(e) * np.ones_like(a)], axis=-1)
    ned = d @ rot.T * r[..., None]
    return ned[..., 0], ned[..., 1], ok


def render(
    tex: np.ndarray, *, res_m: float, north_m: float, east_m: float, altitude_m: float, heading_rad: float,
    tilt_rad: float, range_m: np.ndarray, azimuth_rad: np.ndarray, aperture_rad: float = math.radians(14),
    timestamp_s: float = 0.0, nav_offset_m: tuple[float, float] = (0.0, 0.0),
) -> SonarFrame:
    """A frame of the textured seabed (texture cell (0, 0) at north = east = 0).

    ``nav_offset_m`` is added to the position the frame REPORTS (navigation error).
    """
    n, e, ok = seabed_points(range_m=range_m, azimuth_rad=azimuth_rad, aperture_rad=aperture_rad,
                             altitude_m=altitude_m, tilt_rad=tilt_rad, heading_rad=heading_rad)
    rows = ((n + north_m) / res_m - 0.5).astype(np.float32)
    cols = ((e + east_m) / res_m - 0.5).astype(np.float32)
    img = cv2.remap(tex.astype(np.float32), cols, rows, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=0)
    img[~ok] = 0
    return SonarFrame(
        image=np.clip(img, 0, 255).astype(np.uint8), range_m=range_m, beam_azimuth_rad=azimuth_rad,
        elevation_aperture_rad=aperture_rad, timestamp_s=timestamp_s, altitude_m=altitude_m,
        sonar_depth_m=5.0, tilt_rad=tilt_rad, heading_rad=heading_rad, vehicle_pitch_rad=0.0,
        vehicle_roll_rad=0.0, north_m=north_m + nav_offset_m[0], east_m=east_m + nav_offset_m[1],
    )
