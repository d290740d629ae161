"""Sonar altitude from the frame itself: where the insonified seabed starts in range.

A forward-looking sonar tilted down sees nothing (water) at short range and then the
seabed, from the slant range at which the steepest ray of its vertical aperture meets it
(:func:`perception.geometry.altitude_from_band_start`). Finding that onset in the image
gives the sonar's altitude, independent of the altimeter.

Method: average the image rows over the beams near the boresight, smooth the profile
lightly along range, take the dark (water) level from a low percentile of the profile and
the bright (seabed) level from the median of the rows above a first guess, and find the
first row from which the profile stays above the half-way level; linear interpolation
between that row and the previous one gives the sub-sample slant range. A symmetric
smoothing window does not move the half-way point of a step, and averaging beams whose
onsets differ slightly puts it at their mean onset range, which is what the altitude
conversion uses.

Frames and signs: :mod:`perception.geometry` and :mod:`perception.sonar_io.frame`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from perception.errors import GeometryError, SeabedNotFoundError
from perception.geometry import sonar_to_ned
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


def find_seabed_start(
    frame: SonarFrame,
    *,
    max_abs_azimuth_rad: float = math.radians(8.0),
    smooth_rows: int = 5,
    min_contrast: float = 4.0,
    min_water_rows: int = 5,
) -> SeabedStart:
    """Find the slant range at which the insonified seabed starts.

    Parameters
    ----------
    frame : SonarFrame
        Any image dtype; not modified.
    max_abs_azimuth_rad : float
        Beams within this azimuth of the boresight are averaged (at least the one
        nearest the boresight is always used).
    smooth_rows : int
        Length of the moving average along range, rows (>= 1).
    min_contrast : float
        Least (seabed - water) level difference, in units of the water-level noise.
    min_water_rows : int
        Least number of water rows before the onset.

    Raises
    ------
    SeabedNotFoundError
        When the frame has no dark-then-bright onset: the seabed already fills the first
        rows (the window starts inside the band), or there is no contrast.
    """
    if smooth_rows < 1 or min_water_rows < 1:
        raise ValueError("smooth_rows and min_water_rows must be >= 1")
    az = frame.beam_azimuth_rad
    beams = np.flatnonzero(np.abs(az) <= max_abs_azimuth_rad)
    if beams.size == 0:
        beams = np.array([int(np.argmin(np.abs(az)))])
    profile = np.asarray(frame.image[:, beams], dtype=np.float64).mean(axis=1)
    smooth = _smooth(profile, smooth_rows)
    # Water level: a low percentile. Seabed level: the median of the rows above a first
    # half-way guess (the band may fill only a small part of the window).
    lo = float(np.percentile(smooth, 5.0))
    bright = smooth[smooth >= 0.5 * (lo + float(smooth.max()))]
    hi = float(np.median(bright))
    threshold = 0.5 * (lo + hi)
    above = smooth >= threshold
    # first row from which the profile stays above the threshold for smooth_rows rows
    run = np.convolve(above.astype(np.int64), np.ones(smooth_rows, dtype=np.int64), mode="valid")
    starts = np.flatnonzero(run == smooth_rows)
    if starts.size == 0:
        raise SeabedNotFoundError("no seabed onset: the range profile never rises and stays above half-way")
    i = int(starts[0])
    if i < min_water_rows:
        raise SeabedNotFoundError(
            f"the seabed already fills row {i} of the window (starts at {frame.range_m[0]:.2f} m): "
            "no water before the onset, so its range cannot be measured"
        )
    water = smooth[: max(i - smooth_rows, 2)]
    noise = float(np.std(water)) if water.size >= 2 else 0.0
    contrast = (hi - lo) / max(noise, 1e-12 * max(abs(hi), 1.0))
    if contrast < min_contrast:
        raise SeabedNotFoundError(f"seabed contrast {contrast:.1f} is below {min_contrast}")
    r = frame.range_m
    s0, s1 = float(smooth[i - 1]), float(smooth[i])
    frac = (threshold - s0) / (s1 - s0) if s1 > s0 else 0.5
    frac = min(max(frac, 0.0), 1.0)
    dr = float(r[i] - r[i - 1])
    slant = float(r[i - 1] + frac * dr)
    slope = max((s1 - s0) / dr, 1e-12)
    slant_std = math.sqrt((noise / slope) ** 2 + dr**2 / 12.0)
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
    smooth_rows: int = 5,
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
    max_abs_azimuth_rad, smooth_rows, min_contrast
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
    start = find_seabed_start(
        frame, max_abs_azimuth_rad=max_abs_azimuth_rad, smooth_rows=smooth_rows, min_contrast=min_contrast
    )
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
