"""One frame's part of the height pipeline: its shadows measured, and made into tracker detections.

Segmentation (:mod:`perception.shadows.segmentation.segment`), the targets from shadows and
highlights (:mod:`perception.shadows.pairing.pair`), their edges
(:mod:`perception.shadows.measurement.measure`), then each measurement placed on the seabed
with the frame's pose (:mod:`perception.tracking.detection`).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from perception.heights.config import HeightsConfig
from perception.heights.models import top_echo_slope_db_per_m
from perception.shadows.measurement.measure import ShadowMeasurement, measure_pairs
from perception.shadows.pairing.pair import pair_regions
from perception.shadows.segmentation.segment import segment
from perception.sonar_io.frame import SonarFrame
from perception.tracking.detection import Detection, seabed_centre, seabed_position

#: A shadow that starts at the band's near edge without an echo before it is a target's
#: (before the band) when the seabed after it stands this far above it, dB.
NEAR_SHADOW_DEPTH_DB = 10.0
#: ... and lies within this fraction of the half fan from its centre.
NEAR_SHADOW_FAN_FRACTION = 0.6


def detect_shadows(
    image: NDArray[np.generic],
    *,
    range_m: NDArray[np.float64],
    beam_azimuth_rad: NDArray[np.float64],
    config: HeightsConfig | None = None,
) -> tuple[ShadowMeasurement, ...]:
    """Segment, pair and measure one polar image.

    Parameters
    ----------
    image : ndarray, shape (n_samples, n_beams), uint8, uint16 or float32
        Echo intensity (not modified).
    range_m : ndarray, shape (n_samples,)
        Slant range of each row from range zero, m (sets the physical scales).
    beam_azimuth_rad : ndarray, shape (n_beams,)
        Beam azimuths, rad.
    config : HeightsConfig, optional

    Returns
    -------
    tuple of ShadowMeasurement
        One per target, cut ones included (flagged). A shadow without an echo before it that
        an edge of the band (other than the near one) or of the window cuts is taken for that
        edge (the dark beyond the aperture) and left out.
    """
    cfg = config or HeightsConfig()
    seg = segment(image, range_m=range_m, config=cfg.segmentation)
    pairs = pair_regions(seg, config=cfg.pairing)
    found = measure_pairs(seg, pairs, range_m=range_m, beam_azimuth_rad=beam_azimuth_rad, config=cfg.measure)
    # A shadow without an echo before it, cut by an edge, is taken for that edge (the dark
    # beyond it) -- unless cut by the band's near edge only, deep (NEAR_SHADOW_DEPTH_DB
    # below the seabed after it) and away from the fan's sides (where the band's curved near
    # edge is least sure and the aperture's own roll-off leaves dark stretches inside it):
    # the cast shadow of a target before the band, itself not insonified, kept without a
    # height (the mosaic leaves it out).
    half_fan = float(np.maximum.reduce(np.abs(beam_azimuth_rad))) if len(beam_azimuth_rad) else 0.0
    return tuple(m for m in found if m.has_highlight or not m.truncated
                 or (m.cut_by == ("band_near",) and m.depth_db >= NEAR_SHADOW_DEPTH_DB
                     and abs(m.azimuth_rad) <= NEAR_SHADOW_FAN_FRACTION * half_fan))


def frame_detections(
    frame: SonarFrame,
    measurements: tuple[ShadowMeasurement, ...],
    *,
    frame_index: int,
    altitude_m: float,
    delta_h_m: float,
    config: HeightsConfig,
) -> list[Detection]:
    """The tracker's detections of one frame's measurements (seabed places from its pose)."""
    out = []
    depression = frame.tilt_rad - (frame.vehicle_pitch_rad if frame.known("vehicle_pitch_rad") else 0.0)
    for m in measurements:
        north, east = seabed_position(m, altitude_m=altitude_m, north_m=frame.north_m, east_m=frame.east_m,
                                      heading_rad=frame.heading_rad)
        centre = seabed_centre(m, altitude_m=altitude_m, north_m=frame.north_m, east_m=frame.east_m,
                               heading_rad=frame.heading_rad, config=config.tracking)
        slope = math.nan
        if config.rounded_targets:
            slope = top_echo_slope_db_per_m(frame.image, m, range_m=frame.range_m, window_m=config.rounded_window_m,
                                            uint8_db_range=config.segmentation.uint8_db_range)
        out.append(Detection(
            frame_index=frame_index, measurement=m, altitude_m=altitude_m, delta_h_m=delta_h_m, north_m=north,
            east_m=east, centre_north_m=centre.north_m, centre_east_m=centre.east_m, gate_m=centre.gate_m,
            height_guess_m=centre.height_guess_m, top_slope_db_per_m=slope, depression_rad=depression,
            sonar_north_m=frame.north_m, sonar_east_m=frame.east_m, heading_rad=frame.heading_rad,
        ))
    return out
