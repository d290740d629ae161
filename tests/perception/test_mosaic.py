"""Mosaic projection, tiling, blending and drift correction against a forward model."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from perception.beams import aris3000_128
from perception.errors import GeometryError
from perception.geometry import insonified_band
from perception.mosaic import (
    MosaicConfig,
    TiledMosaic,
    placement_from_frame,
    project_frame,
)
from perception.mosaic_builder import MosaicBuilder
from perception.registration import RegistrationConfig, measure_shift
from tests.perception.synth_seabed import render, texture

RES_M = 0.01
RANGES_M = np.linspace(0.7, 3.0, 600)
AZIMUTH_RAD = np.asarray(aris3000_128().azimuth_rad)


@pytest.fixture(scope="module")
def seabed() -> np.ndarray:
    return texture(np.random.default_rng(7), 1000, blur_cells=2.0)


def _frame(tex: np.ndarray, **pose: float):
    defaults = dict(altitude_m=1.0, heading_rad=0.0, tilt_rad=math.radians(25))
    defaults.update(pose)
    return render(tex, res_m=RES_M, range_m=RANGES_M, azimuth_rad=AZIMUTH_RAD, **defaults)


def _compare(mosaic: TiledMosaic, tex: np.ndarray) -> tuple[float, float, int]:
    mean, weight, row0, col0 = mosaic.raster()
    truth = tex[row0 : row0 + mean.shape[0], col0 : col0 + mean.shape[1]]
    # Cells at the footprint's rim blend with the zero border of the polar image: drop them.
    inner = cv2.erode((weight > 0).astype(np.uint8), np.ones((5, 5), np.uint8)) > 0
    covered = inner[: truth.shape[0], : truth.shape[1]]
    got = mean[: truth.shape[0], : truth.shape[1]][covered]
    want = truth[covered]
    return float(np.corrcoef(got, want)[0, 1]), float(np.mean(np.abs(got - want))), int(covered.sum())


@settings(max_examples=12, deadline=None)
@given(
    heading=st.floats(-math.pi, math.pi),
    tilt_deg=st.floats(15, 40),
    altitude=st.floats(0.5, 1.5),
)
def test_projection_reproduces_the_seabed(seabed, heading, tilt_deg, altitude):
    """A frame projected back onto the grid reproduces the seabed it was rendered from."""
    frame = _frame(seabed, north_m=5.0, east_m=5.0, heading_rad=heading, altitude_m=altitude,
                   tilt_rad=math.radians(tilt_deg))
    placement = placement_from_frame(frame)
    assert placement.altitude_m == pytest.approx(altitude)
    mosaic = TiledMosaic(MosaicConfig(resolution_m=RES_M, tile_cells=64))
    projected = project_frame(frame, placement, config=mosaic.config)
    band = insonified_band(altitude, depression_rad=math.radians(tilt_deg),
                           elevation_aperture_rad=frame.elevation_aperture_rad, window_m=frame.window_m)
    if band.far_slant_m - band.near_slant_m < 0.05:  # (almost) no seabed inside the window
        assert projected is None or np.count_nonzero(projected.weight) < 2000
        return
    assert projected is not None
    mosaic.add(projected)
    corr, mae, n = _compare(mosaic, seabed)
    assert n > 100
    assert corr > 0.97
    assert mae < 6.0  # grey levels on a 40..200 texture


def test_bright_point_lands_where_it_lies(seabed):
    """A 2x2-cell reflector appears in the mosaic within one cell of its true place."""
    tex = np.full_like(seabed, 60.0)
    tex[420:422, 530:532] = 250.0  # centre at north 4.21 m, east 5.31 m
    builder = MosaicBuilder(MosaicConfig(resolution_m=RES_M))
    for k, heading in enumerate(np.linspace(-0.4, 0.4, 9)):
        builder.add_frame(_frame(tex, north_m=2.2 + 0.05 * k, east_m=5.3, heading_rad=float(heading)))
    mean, weight, row0, col0 = builder.mosaic.raster()
    bright = np.where(weight > 0.2, mean, 0) > 150
    rows, cols = np.nonzero(bright)
    north = (rows.mean() + row0 + 0.5) * RES_M
    east = (cols.mean() + col0 + 0.5) * RES_M
    assert math.hypot(north - 4.21, east - 5.31) < 0.01


def test_exclude_mask_keeps_samples_out_of_the_average(seabed):
    frame = _frame(seabed, north_m=5.0, east_m=5.0)
    mask = np.zeros(frame.image.shape, dtype=bool)
    mask[400:500, :] = True
    cfg = MosaicConfig(resolution_m=RES_M)
    full = project_frame(frame, placement_from_frame(frame), config=cfg)
    masked = project_frame(frame, placement_from_frame(frame), config=cfg, exclude_mask=mask)
    assert full is not None and masked is not None
    lost = (full.weight > 0) & (masked.weight == 0)
    # The masked rows cover ranges 2.24-2.62 m: the cells lost lie in that range band.
    n_idx, e_idx = np.nonzero(lost)
    north = (n_idx + full.row0 + 0.5) * RES_M - 5.0
    east = (e_idx + full.col0 + 0.5) * RES_M - 5.0
    slant = np.sqrt(north**2 + east**2 + 1.0)
    assert lost.sum() > 500
    assert slant.min() > RANGES_M[399] - 0.02 and slant.max() < RANGES_M[500] + 0.02
    assert np.all(masked.intensity[masked.weight == 0] == 0)


def test_missing_pose_is_named():
    frame = render(np.zeros((10, 10)), res_m=RES_M, north_m=0, east_m=0, altitude_m=1.0, heading_rad=0.0,
                   tilt_rad=0.4, range_m=RANGES_M, azimuth_rad=AZIMUTH_RAD)
    with pytest.raises(GeometryError, match="heading_deg"):
        placement_from_frame(frame.with_fields(heading_rad=math.nan))
    with pytest.raises(GeometryError, match="altitude"):
        project_frame(frame, placement_from_frame(frame, altitude_m=-1.0), config=MosaicConfig())


def test_tiles_window_matches_raster_and_cost_stays_local(seabed):
    mosaic = TiledMosaic(MosaicConfig(resolution_m=RES_M, tile_cells=32))
    touched = []
    for k in range(12):
        frame = _frame(seabed, north_m=1.5 + 0.5 * k, east_m=5.0)
        projected = project_frame(frame, placement_from_frame(frame), config=mosaic.config)
        assert projected is not None
        before = mosaic.tile_count
        mosaic.add(projected)
        touched.append(mosaic.tile_count - before)
    mean, weight, row0, col0 = mosaic.raster()
    sub_mean, sub_weight = mosaic.window(row0 + 37, col0 + 11, 90, 70)
    np.testing.assert_array_equal(sub_weight, weight[37:127, 11:81])
    np.testing.assert_allclose(sub_mean, mean[37:127, 11:81])
    # Moving along, each frame creates only the tiles its footprint newly reaches.
    assert max(touched[1:]) <= math.ceil(1.2 / (32 * RES_M)) * math.ceil(1.8 / (32 * RES_M))


@pytest.mark.parametrize("offset", [(0.01, 0.0), (0.0, -0.03), (0.05, -0.05), (-0.12, 0.04)])
def test_phase_correlation_measures_known_offsets(seabed, offset):
    builder = MosaicBuilder(MosaicConfig(resolution_m=RES_M))
    for k in range(16):
        builder.add_frame(_frame(seabed, north_m=3.0 + 0.05 * k, east_m=5.0))
    frame = _frame(seabed, north_m=3.3, east_m=5.0, heading_rad=0.3, nav_offset_m=offset)
    projected = project_frame(frame, placement_from_frame(frame), config=builder.mosaic.config)
    assert projected is not None
    result = measure_shift(projected, builder.mosaic, config=RegistrationConfig())
    assert result.accepted
    assert result.shift_north_m == pytest.approx(-offset[0], abs=0.004)
    assert result.shift_east_m == pytest.approx(-offset[1], abs=0.004)


def test_registration_refuses_shifts_beyond_the_prior(seabed):
    builder = MosaicBuilder(MosaicConfig(resolution_m=RES_M))
    for k in range(16):
        builder.add_frame(_frame(seabed, north_m=3.0 + 0.05 * k, east_m=5.0))
    frame = _frame(seabed, north_m=3.3, east_m=5.0, nav_offset_m=(0.0, 0.3))
    projected = project_frame(frame, placement_from_frame(frame), config=builder.mosaic.config)
    assert projected is not None
    result = measure_shift(projected, builder.mosaic, config=RegistrationConfig(max_shift_m=0.15))
    assert not result.accepted
    assert result.reason in ("shift beyond prior", "weak correlation")


def test_no_overlap_is_not_registered(seabed):
    builder = MosaicBuilder(MosaicConfig(resolution_m=RES_M), RegistrationConfig(every_n_frames=1))
    builder.add_frame(_frame(seabed, north_m=2.0, east_m=2.0))
    added = builder.add_frame(_frame(seabed, north_m=7.0, east_m=7.0))
    assert added.registration is not None and not added.registration.accepted
    assert added.registration.reason == "overlap too small"


def _reflector_positions(builder: MosaicBuilder, spots: list[tuple[float, float]]) -> list[float]:
    mean, weight, row0, col0 = builder.mosaic.raster()
    errors = []
    for north, east in spots:
        r = int(round(north / RES_M - 0.5)) - row0
        c = int(round(east / RES_M - 0.5)) - col0
        win = np.where(weight[r - 20 : r + 21, c - 20 : c + 21] > 0.2, mean[r - 20 : r + 21, c - 20 : c + 21], 0)
        bright = win > 0.5 * win.max()
        rows, cols = np.nonzero(bright)
        w = win[bright]
        n_est = (np.sum(rows * w) / w.sum() + r - 20 + row0 + 0.5) * RES_M
        e_est = (np.sum(cols * w) / w.sum() + c - 20 + col0 + 0.5) * RES_M
        errors.append(math.hypot(n_est - north, e_est - east))
    return errors


@pytest.mark.slow
def test_drift_of_ten_centimetres_is_brought_back(seabed):
    """Two overlapping lanes; the navigation drifts 1 cm along the first lane, then jumps to
    6 cm over the turn (as a DVL does when it loses bottom lock) and reaches 10 cm by the end
    of the second. Reflectors seen from both lanes land within 3 cm with registration, and
    at least twice as close as without."""
    tex = seabed * 0.6
    spots = [(4.0, 5.0), (5.5, 5.05), (6.5, 4.95)]
    for n, e in spots:
        tex[int(n / RES_M) - 1 : int(n / RES_M) + 1, int(e / RES_M) - 1 : int(e / RES_M) + 1] = 255.0
    poses = [(1.5 + 0.05 * k, 4.6, 0.0) for k in range(80)]  # north along east 4.6
    poses += [(8.5 - 0.05 * k, 5.4, math.pi) for k in range(80)]  # back south along east 5.4

    def drift_m(k: int) -> float:
        return 0.01 * k / 79 if k < 80 else 0.06 + 0.04 * (k - 80) / 79

    results = {}
    for reg in (None, RegistrationConfig()):
        builder = MosaicBuilder(MosaicConfig(resolution_m=RES_M), reg)
        for k, (n, e, heading) in enumerate(poses):
            builder.add_frame(_frame(tex, north_m=n, east_m=e, heading_rad=heading,
                                     nav_offset_m=(drift_m(k) * 0.8, -drift_m(k) * 0.6)))
        results[reg is not None] = _reflector_positions(builder, spots)
        if reg is not None:
            assert builder.drift is not None and builder.drift.accepted > 10
    assert max(results[True]) <= 0.03
    assert max(results[True]) < 0.5 * max(results[False])
