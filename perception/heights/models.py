"""Models the height pipeline uses besides Eq. 2: the seabed-onset altitude of a frame,
grouping frames by altitude, the echo slope before a shadow start (rounded tops), and an
inverse-variance mean that owns up to scatter.

Split from :mod:`perception.heights.pipeline`, which re-exports what it used to define.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from perception.errors import GeometryError, SeabedNotFoundError
from perception.navigation.seabed_start import sonar_altitude
from perception.shadows.measurement.measure import ShadowMeasurement
from perception.shadows.segmentation.segment import as_levels
from perception.sonar_io.frame import SonarFrame

if TYPE_CHECKING:
    from perception.heights.config import HeightsConfig


@dataclass(frozen=True)
class OnsetAltitude:
    """One frame's altitude from where the insonified seabed starts.

    Attributes
    ----------
    frame_index : int
    altitude_m : float
        The frame's altitude above the seabed, m.
    delta_h_m : float
        The frame's altitude minus the first frame's (from the depth gauge), m.
    noise_std_m : float
        1-sigma of the onset range noise, as altitude, m (independent between frames).
    common_std_m : float
        1-sigma of the tilt/attitude and beam-edge model errors, m (common to all frames).
    """

    frame_index: int
    altitude_m: float
    delta_h_m: float
    noise_std_m: float
    common_std_m: float


def onset_altitude(
    frame: SonarFrame, *, frame_index: int, delta_h_m: float, config: HeightsConfig
) -> OnsetAltitude | None:
    """The frame's altitude from its seabed onset, or None when the frame has none.

    Parameters
    ----------
    frame : SonarFrame
        Must carry ``tilt_rad`` and ``vehicle_pitch_rad`` (else None).
    frame_index : int
    delta_h_m : float
        The frame's altitude change from the first frame, m.
    config : HeightsConfig
        Its ``onset_angle_std_rad`` and ``onset_model_relative_std``.
    """
    try:
        found = sonar_altitude(
            frame,
            angle_std_rad=config.onset_angle_std_rad,
            model_relative_std=config.onset_model_relative_std,
        )
    except (SeabedNotFoundError, GeometryError):
        return None
    altitude = found.altitude_m
    if not (math.isfinite(altitude) and altitude > 0):
        return None
    # The same split of the error as sonar_altitude's: range noise vs common terms.
    steepest = min(found.depression_rad + frame.elevation_aperture_rad / 2.0, math.pi / 2)
    cot = math.cos(steepest) / max(math.sin(steepest), 1e-12)
    common_rel = math.hypot(cot * config.onset_angle_std_rad, config.onset_model_relative_std)
    noise_rel = found.start.slant_std_m / found.start.slant_m
    return OnsetAltitude(frame_index, altitude, delta_h_m, altitude * noise_rel, altitude * common_rel)


def inverse_variance_mean(values: NDArray[np.float64], sigmas: NDArray[np.float64]) -> tuple[float, float]:
    """Inverse-variance mean of independent estimates and its 1-sigma, widened by their
    scatter when it exceeds the sigmas (reduced chi-square > 1)."""
    w = 1.0 / np.maximum(sigmas, 1e-9) ** 2
    mean = float(np.sum(w * values) / np.sum(w))
    chi2 = float(np.sum(w * (values - mean) ** 2)) / (values.size - 1) if values.size > 1 else 1.0
    return mean, math.sqrt(max(1.0, chi2) / float(np.sum(w)))


def altitude_groups(altitudes_m: NDArray[np.float64], *, gap_fraction: float = 0.1) -> list[NDArray[np.intp]]:
    """Indices of the frames taken at one altitude, group by group (ascending altitude).

    Frames whose altitudes (or altitude changes) lie within ``gap_fraction`` of the whole
    spread of each other -- consecutive sorted values closer than that -- are one group.

    Parameters
    ----------
    altitudes_m : ndarray, shape (N,)
        Altitudes or altitude changes, m, finite.
    gap_fraction : float
        Smallest gap, as a fraction of ``ptp(altitudes_m)``, that starts a new group.
    """
    values = np.asarray(altitudes_m, dtype=np.float64)
    if values.size == 0:
        return []
    order = np.argsort(values, kind="stable")
    spread = float(np.ptp(values))
    if spread <= 0:
        return [order]
    cuts = np.flatnonzero(np.diff(values[order]) > gap_fraction * spread) + 1
    return [np.asarray(g, dtype=np.intp) for g in np.split(order, cuts)]


def top_echo_slope_db_per_m(
    image: NDArray[np.generic],
    measurement: ShadowMeasurement,
    *,
    range_m: NDArray[np.float64],
    window_m: tuple[float, float] = (0.006, 0.020),
    uint8_db_range: float | None = 80.0,
) -> float:
    """Slope of the echo just before a shadow's start, dB per metre of range.

    In each measured beam, the samples from ``window_m[1]`` to ``window_m[0]`` before
    that beam's shadow start; one least-squares line of their dB against range over all
    the beams. Near zero for a sharp far top edge (the top echoes at one incidence up to
    the edge), negative for a rounded top (the echo fades towards the grazing point).

    Parameters
    ----------
    image : ndarray, shape (n_samples, n_beams), uint8, uint16, float32 or float64
        The frame's echo (not modified); uint8 is ``uint8_db_range`` dB over 0-255, any
        other dtype linear power (:func:`perception.shadows.segmentation.segment.as_levels`).
    measurement : ShadowMeasurement
        Its ``columns`` and ``r_top_per_beam_m``.
    range_m : ndarray, shape (n_samples,)
        Slant range of each row, m.
    window_m : (float, float)
        Nearest and farthest distance before the shadow start, m.
    uint8_db_range : float or None

    Returns
    -------
    float
        dB/m; NaN when fewer than 4 samples fall in the windows or they span no range, or
        the measurement lacks per-beam edges for its columns.
    """
    near, far = window_m
    if len(measurement.columns) != len(measurement.r_top_per_beam_m):
        return math.nan  # per-beam edges not kept for these beams
    xs: list[NDArray[np.float64]] = []
    values: list[NDArray[np.generic]] = []
    for col, top in zip(measurement.columns, measurement.r_top_per_beam_m, strict=True):
        i0, i1 = np.searchsorted(range_m, [top - far, top - near])
        if i1 > i0:
            xs.append(range_m[i0:i1] - top)
            values.append(np.asarray(image[i0:i1, col]))
    if not xs:
        return math.nan
    x = np.concatenate(xs)
    if x.size < 4 or not np.ptp(x) > 0:
        return math.nan
    levels, db_per_level = as_levels(np.concatenate(values)[:, None], uint8_db_range=uint8_db_range)
    db = np.asarray(levels, dtype=np.float64)[:, 0] * db_per_level
    xc = x - x.mean()
    return float(np.sum(xc * (db - db.mean())) / np.sum(xc * xc))
