"""Frames blended into the mosaic by footprint motion (perception.mapping.look_spacing):
how many, what they stand for, and that the mosaic they make is the one every frame makes."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from perception.geometry import insonified_band
from perception.mapping.builder import MosaicBuilder
from perception.mapping.look_spacing import LookSpacing
from perception.mapping.mosaic import MosaicConfig
from perception.sonar_io.beams import aris3000_128
from tests.perception.heights.synth_seabed import render, texture

RES_M = 0.01
RANGES_M = np.linspace(0.7, 3.0, 400)
AZIMUTH_RAD = np.asarray(aris3000_128().azimuth_rad)
ALTITUDE_M = 1.0
TILT_RAD = math.radians(25.0)


def _band_length_m() -> float:
    band = insonified_band(ALTITUDE_M, depression_rad=TILT_RAD, elevation_aperture_rad=math.radians(14.0),
                           window_m=(float(RANGES_M[0]), float(RANGES_M[-1])))
    return band.far_ground_m - band.near_ground_m


def _frame(tex: np.ndarray | None, north_m: float, *, heading_rad: float = 0.0, east_m: float = 3.0):
    tex = tex if tex is not None else np.full((8, 8), 100.0, dtype=np.float32)
    return render(tex, res_m=RES_M, north_m=north_m, east_m=east_m, altitude_m=ALTITUDE_M, heading_rad=heading_rad,
                  tilt_rad=TILT_RAD, range_m=RANGES_M, azimuth_rad=AZIMUTH_RAD)


@pytest.fixture(scope="module")
def seabed() -> np.ndarray:
    return texture(np.random.default_rng(11), 1000, blur_cells=2.0)


def test_a_lane_is_blended_every_band_length_over_looks():
    """Along a straight lane at 2 cm a ping, with a band L m long on the ground, a frame is
    blended every L / looks of travel (rounded up to whole pings), standing for the pings
    since the last one; the counts add up to the pings."""
    looks = 20
    spacing_m = _band_length_m() / looks
    step_m = 0.02
    spacing = LookSpacing(looks)
    counts = [spacing.offer(_frame(None, 1.0 + k * step_m), altitude_m=ALTITUDE_M) for k in range(200)]
    blended = [k for k, c in enumerate(counts) if c]
    per_blend = math.ceil(spacing_m / step_m - 1e-9)
    assert counts[0] == 1
    assert all(b - a == per_blend for a, b in zip(blended, blended[1:], strict=False))
    assert all(counts[b] == per_blend for b in blended[1:])
    assert sum(counts) == blended[-1] + 1  # the pings after the last blended one are pending


def test_turning_in_place_counts_as_motion_and_an_interruption_restarts():
    """Rotating on the spot moves the far end of the band: a turn of (L / looks) / far range
    blends a frame; after :meth:`interrupt` the next frame is blended and stands for itself."""
    looks = 20
    band = insonified_band(ALTITUDE_M, depression_rad=TILT_RAD, elevation_aperture_rad=math.radians(14.0),
                           window_m=(float(RANGES_M[0]), float(RANGES_M[-1])))
    turn_rad = (band.far_ground_m - band.near_ground_m) / looks / band.far_ground_m
    spacing = LookSpacing(looks)
    assert spacing.offer(_frame(None, 2.0), altitude_m=ALTITUDE_M) == 1
    assert spacing.offer(_frame(None, 2.0, heading_rad=0.6 * turn_rad), altitude_m=ALTITUDE_M) == 0
    assert spacing.offer(_frame(None, 2.0, heading_rad=1.01 * turn_rad), altitude_m=ALTITUDE_M) == 2
    assert spacing.offer(_frame(None, 2.0, heading_rad=1.2 * turn_rad), altitude_m=ALTITUDE_M) == 0
    spacing.interrupt()
    assert spacing.offer(_frame(None, 2.0, heading_rad=1.2 * turn_rad), altitude_m=ALTITUDE_M) == 1


def test_a_frame_without_a_pose_is_blended_alone():
    frame = _frame(None, 2.0).with_fields(heading_rad=math.nan)
    spacing = LookSpacing(10)
    assert spacing.offer(frame, altitude_m=ALTITUDE_M) == 1
    assert spacing.offer(frame, altitude_m=ALTITUDE_M) == 1
    with pytest.raises(ValueError, match="looks"):
        LookSpacing(0)


@settings(max_examples=60, deadline=None)
@given(steps=st.lists(st.tuples(st.floats(0.0, 0.2), st.floats(-0.1, 0.1), st.booleans()), min_size=1,
                      max_size=60),
       looks=st.integers(1, 80))
def test_every_frame_is_counted_once(steps, looks):
    """Whatever the motion, each offered frame is counted by exactly one blended frame (or
    is still pending, or was dropped by an interruption), and a blended frame counts at
    least itself."""
    spacing = LookSpacing(looks)
    north, heading, pending = 1.0, 0.0, 0
    for k, (advance_m, turn_rad, interrupted) in enumerate(steps):
        if interrupted:
            spacing.interrupt()
            pending = 0
        north, heading = north + advance_m, heading + turn_rad
        count = spacing.offer(_frame(None, north, heading_rad=heading), altitude_m=ALTITUDE_M)
        pending += 1
        if k == 0 or interrupted:
            assert count == 1
        if count:
            assert count == pending
            pending = 0


def test_the_mosaic_of_the_blended_frames_is_the_mosaic_of_every_frame(seabed):
    """Two lanes over a textured seabed, every ping blended against about 12 per cell (their
    weights times the pings they stand for): the same seabed, the same accumulated weight."""
    cfg = MosaicConfig(resolution_m=RES_M)
    every, some = MosaicBuilder(cfg, None), MosaicBuilder(cfg, None)
    spacing = LookSpacing(12)
    blended = 0
    for lane, (east_m, heading) in enumerate(((3.0, 0.0), (3.6, math.pi))):
        if lane:
            spacing.interrupt()
        for k in range(150):
            north = 3.0 + 0.02 * k if heading == 0.0 else 9.0 - 0.02 * k
            frame = _frame(seabed, north, heading_rad=heading, east_m=east_m)
            every.add_frame(frame, altitude_m=ALTITUDE_M)
            count = spacing.offer(frame, altitude_m=ALTITUDE_M)
            if count:
                blended += 1
                some.add_frame(frame, altitude_m=ALTITUDE_M, weight_scale=float(count))
    assert blended < 300 / 4
    mean_all, weight_all, r0, c0 = every.mosaic.raster()
    mean_some, weight_some = some.mosaic.window(r0, c0, *mean_all.shape)
    truth_all = seabed[r0: r0 + mean_all.shape[0], c0: c0 + mean_all.shape[1]]
    rows, cols = truth_all.shape
    mean_all, weight_all = mean_all[:rows, :cols], weight_all[:rows, :cols]
    mean_some, weight_some = mean_some[:rows, :cols], weight_some[:rows, :cols]
    inner = cv2.erode((weight_all > 0).astype(np.uint8), np.ones((41, 41), np.uint8)) > 0
    assert inner.sum() > 20000
    truth = truth_all[inner]
    for mean in (mean_all, mean_some):
        assert np.corrcoef(mean[inner], truth)[0, 1] > 0.97
    assert np.median(np.abs(mean_some[inner] - mean_all[inner])) < 2.0  # grey levels of a 40..200 texture
    ratio = weight_some[inner] / weight_all[inner]
    assert 0.85 < np.median(ratio) < 1.15
