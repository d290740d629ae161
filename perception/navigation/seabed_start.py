"""Sonar altitude from the frame itself: where the insonified seabed starts in range.

A forward-looking sonar tilted down sees nothing (water) at short range and then the
seabed, from the slant range at which the steepest ray of its vertical aperture meets it
(:func:`perception.geometry.altitude_from_band_start`). Finding that onset in the image
gives the sonar's altitude, independent of the altimeter.

Method: average the echo power of the rows over the beams near the boresight, smooth the
profile lightly along range, take the dark (water) level from a low percentile and the
seabed's level from the median just after a first guess of the onset, and find the first
row from which the profile stays within 3 dB of that level (the aperture's -3 dB edge,
whether the beam's pattern ends sharply or rolls off); linear interpolation between that
row and the previous one gives the sub-sample slant range. Averaging beams whose onsets
differ slightly puts it at their mean onset range, which is what the altitude conversion
uses.

Frames and signs: :mod:`perception.geometry` and :mod:`perception.sonar_io.frame`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from perception.errors import GeometryError, SeabedNotFoundError
from perception.geometry import sonar_to_ned
from perception.shadows.segmentation.levels import as_levels
from perception.sonar_io.frame import SonarFrame

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class SeabedStart:
    """Where the insonified seabed starts in a frame.

    Attributes
    ----------
    slant_m : float
        Slant range of the onset (half-way between water and seabed levels), m.
    slant_std_m : float
        Its standard deviation from profile noise and sampling, m.
    beam_indices : ndarray of int, shape (n_used,)
        Beams averaged.
    contrast : float
        (seabed level - water level) / water-level noise of the smoothed profile.
    """

    slant_m: float
    slant_std_m: float
    beam_indices: NDArray[np.intp]
    contrast: float


@dataclass(frozen=True)
class SonarAltitude:
    """Sonar altitude above a flat seabed from the seabed onset in one frame.

    ``altitude_m`` refers to the sonar's acoustic centre; ``std_m`` combines the onset
    range noise, the attitude uncertainty and a relative model error (the beam's soft
    elevation edge). ``timestamp_s`` is the frame's.
    """

    timestamp_s: float
    altitude_m: float
    std_m: float
    start: SeabedStart
    depression_rad: float


def _smooth(profile: FloatArray, rows: int) -> FloatArray:
    if rows <= 1:
        return profile.copy()
    half = rows // 2
    padded = np.pad(profile, (half, rows - 1 - half), mode="edge")
    return np.convolve(padded, np.ones(rows) / rows, mode="valid")



def _require_water(row: int, dr: float, min_water_m: float, window_start_m: float) -> None:
    """Refuse an onset at ``row`` with less than ``min_water_m`` of water before it."""
    if row * dr < min_water_m or row < 2:
        raise SeabedNotFoundError(
            f"the seabed already fills row {row} of the window (starts at {window_start_m:.2f} m): "
            "no water before the onset, so its range cannot be measured"
        )

def find_seabed_start(
    frame: SonarFrame,
    *,
    max_abs_azimuth_rad: float = math.radians(8.0),
    smooth_m: float = 0.01,
    plateau_m: float = 0.05,
    edge_db: float = 3.0,
    min_contrast: float = 4.0,
    min_water_m: float = 0.01,
) -> SeabedStart:
    """Find the slant range at which the insonified seabed starts.

    The profile is the echo POWER (the frame's dtype read as :func:`as_levels` does, then
    back to linear) averaged over the beams near the boresight and smoothed over
    ``smooth_m`` of range. The onset is where it first comes within ``edge_db`` of the
    seabed's level just after it (the median over ``plateau_m`` past a first guess): the
    aperture's -3 dB edge, wherever the beam's pattern rolls off (a soft edge, or none).

    Parameters
    ----------
    frame : SonarFrame
        Any image dtype; not modified.
    max_abs_azimuth_rad : float
        Beams within this azimuth of the boresight are averaged (at least the one
        nearest the boresight is always used).
    smooth_m, plateau_m : float
        Range smoothing of the profile, and range of the seabed level after the onset, m.
    edge_db : float
        The onset lies this far below the seabed's level, dB of power.
    min_contrast : float
        Least (seabed - water) level difference, in units of the water-level noise.
    min_water_m : float
        Least range of water before the onset, m.

    Raises
    ------
    SeabedNotFoundError
        When the frame has no dark-then-bright onset: the seabed already fills the first
        rows (the window starts inside the band), or there is no contrast.
    """
    az = frame.beam_azimuth_rad
    beams = np.flatnonzero(np.abs(az) <= max_abs_azimuth_rad)
    if beams.size == 0:
        beams = np.array([int(np.argmin(np.abs(az)))])
    r = frame.range_m
    dr = frame.range_resolution_m
    levels, db_per_level = as_levels(np.asarray(frame.image)[:, beams])
    power = np.power(10.0, np.asarray(levels, dtype=np.float64) * (db_per_level / 10.0))
    profile = power.mean(axis=1)
    rows = max(1, int(round(smooth_m / dr)))
    smooth = _smooth(profile, rows)
    lo = float(np.percentile(smooth, 5.0))
    hi0 = float(smooth.max())
    if not hi0 > lo:
        raise SeabedNotFoundError("no seabed onset: the range profile is flat")
    # First guess: where the profile first rises past the geometric mean of water and seabed.
    guess_rows = np.flatnonzero(smooth >= math.sqrt(max(lo, 1e-300) * hi0))
    if guess_rows.size == 0:
        raise SeabedNotFoundError("no seabed onset: the range profile never rises")
    g = int(guess_rows[0])
    _require_water(g, dr, min_water_m, float(frame.range_m[0]))
    span = max(2, int(round(plateau_m / dr)))
    after = smooth[g : g + span]
    if after.size < max(2 * rows, 4):
        raise SeabedNotFoundError("the seabed onset lies at the window's far end: no seabed after it to compare with")
    plateau = float(np.median(after))
    threshold = plateau * 10.0 ** (-edge_db / 10.0)
    if not threshold > lo:
        raise SeabedNotFoundError("seabed contrast too low for its onset")
    above = smooth >= threshold
    run = np.convolve(above.astype(np.int64), np.ones(rows, dtype=np.int64), mode="valid")
    starts = np.flatnonzero(run == rows)
    if starts.size == 0:
        raise SeabedNotFoundError("no seabed onset: the range profile never rises and stays near the seabed level")
    i = int(starts[0])
    _require_water(i, dr, min_water_m, float(frame.range_m[0]))
    water = smooth[: max(i - rows, 2)]
    noise = float(np.std(water)) if water.size >= 2 else 0.0
    contrast = (plateau - lo) / max(noise, 1e-12 * max(abs(plateau), 1.0))
    if contrast < min_contrast:
        raise SeabedNotFoundError(f"seabed contrast {contrast:.1f} is below {min_contrast}")
    s0, s1 = float(smooth[i - 1]), float(smooth[i])
    frac = (threshold - s0) / (s1 - s0) if s1 > s0 else 0.5
    frac = min(max(frac, 0.0), 1.0)
    step = float(r[i] - r[i - 1])
    slant = float(r[i - 1] + frac * step)
    slope = max((s1 - s0) / step, 1e-300)
    slant_std = math.sqrt((noise / slope) ** 2 + step**2 / 12.0)
    return SeabedStart(slant, slant_std, beams, float(contrast))


def steepest_down_component(
    azimuth_rad: FloatArray, *, elevation_aperture_rad: float, tilt_rad: float, pitch_rad: float, roll_rad: float
) -> FloatArray:
    """Largest downward (NED z) component of any ray of each beam, shape like ``azimuth_rad``.

    A ray at azimuth ``a`` and elevation ``e`` has down component
    ``A cos e + B sin e`` (``A``, ``B`` from the sonar attitude); the maximum over
    ``|e| <= aperture / 2`` is ``hypot(A, B)`` when ``atan2(B, A)`` lies inside, else the
    larger end value. For a flat seabed at height ``H`` that beam's seabed starts at
    slant ``H / down``.
    """
    down_row = sonar_to_ned(tilt_rad=tilt_rad, pitch_rad=pitch_rad, roll_rad=roll_rad)[2]
    a = np.asarray(azimuth_rad, dtype=np.float64)
    coef_cos = np.cos(a) * down_row[0] + np.sin(a) * down_row[1]
    coef_sin = np.full_like(a, down_row[2])
    half = elevation_aperture_rad / 2.0
    peak = np.arctan2(coef_sin, coef_cos)
    ends = np.maximum(coef_cos * math.cos(half) + coef_sin * math.sin(half),
                      coef_cos * math.cos(half) - coef_sin * math.sin(half))
    return np.where(np.abs(peak) <= half, np.hypot(coef_cos, coef_sin), ends)


def _angle(value: float | None, frame_value: float, name: str) -> float:
    v = frame_value if value is None else float(value)
    if not math.isfinite(v):
        raise GeometryError(f"{name} is unknown: the frame does not carry it and none was given")
    return v


def sonar_altitude(
    frame: SonarFrame,
    *,
    tilt_rad: float | None = None,
    pitch_rad: float | None = None,
    roll_rad: float | None = None,
    angle_std_rad: float = math.radians(0.5),
    model_relative_std: float = 0.01,
    max_abs_azimuth_rad: float = math.radians(8.0),
    min_contrast: float = 4.0,
) -> SonarAltitude:
    """Altitude of the sonar above a flat seabed from where the seabed starts in the frame.

    Parameters
    ----------
    frame : SonarFrame
        The ping.
    tilt_rad, pitch_rad, roll_rad : float, optional
        Mount tilt (positive down), vehicle pitch (positive nose up) and roll; default to
        the frame's fields. Tilt and pitch must be known; an unknown roll counts as 0.
    angle_std_rad : float
        Standard deviation of the steepest ray's depression (tilt and attitude), rad.
    model_relative_std : float
        Relative error of the flat-seabed, sharp-beam-edge model.
    max_abs_azimuth_rad, min_contrast
        Passed to :func:`find_seabed_start`.

    Returns
    -------
    SonarAltitude
        Feed ``altitude_m``/``std_m`` to ``AltitudeFilter.update_sonar_altitude`` at
        ``timestamp_s``.

    Raises
    ------
    SeabedNotFoundError
        No onset in the frame.
    GeometryError
        Unknown tilt or pitch, or a beam that never looks down.
    """
    tilt = _angle(tilt_rad, frame.tilt_rad, "tilt")
    pitch = _angle(pitch_rad, frame.vehicle_pitch_rad, "vehicle pitch")
    roll = 0.0 if roll_rad is None and not frame.known("vehicle_roll_rad") else _angle(
        roll_rad, frame.vehicle_roll_rad, "vehicle roll"
    )
    start = find_seabed_start(frame, max_abs_azimuth_rad=max_abs_azimuth_rad, min_contrast=min_contrast)
    down = steepest_down_component(
        frame.beam_azimuth_rad[start.beam_indices],
        elevation_aperture_rad=frame.elevation_aperture_rad,
        tilt_rad=tilt,
        pitch_rad=pitch,
        roll_rad=roll,
    )
    if np.any(down <= 0):
        raise GeometryError("some averaged beams never look down: no seabed onset to convert")
    altitude = start.slant_m / float(np.mean(1.0 / down))
    depression = tilt - pitch
    steepest = min(depression + frame.elevation_aperture_rad / 2.0, math.pi / 2)
    cot = math.cos(steepest) / max(math.sin(steepest), 1e-12)
    rel = math.sqrt((start.slant_std_m / start.slant_m) ** 2 + (cot * angle_std_rad) ** 2 + model_relative_std**2)
    return SonarAltitude(frame.timestamp_s, altitude, altitude * rel, start, depression)
