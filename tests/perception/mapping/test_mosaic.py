"""Mosaic projection, tiling, blending and drift correction against a forward model."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from perception.errors import GeometryError
from perception.geometry import insonified_band
from perception.mapping.builder import MosaicBuilder, masks_from_shadows
from perception.mapping.mosaic import MosaicConfig, TiledMosaic, placement_from_frame
from perception.mapping.projection import project_frame
from perception.mapping.registration import DriftEstimator, RegistrationConfig, RegistrationResult, measure_shift
from perception.shadows.measurement.measure import ShadowMeasurement
from perception.sonar_io.beams import aris3000_128
from tests.perception.heights.synth_seabed import render, texture

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


def _measurement(columns, tops, ends, *, highlight_m, width, azimuth_rad=0.0, truncated=False):
    return ShadowMeasurement(
        azimuth_rad=azimuth_rad, r_top_m=float(np.median(tops)) if tops else math.nan,
        r_end_m=float(np.median(ends)) if ends else math.nan, sigma_r_m=0.005, highlight_range_m=highlight_m,
        columns=tuple(columns), r_top_per_beam_m=tuple(tops), r_end_per_beam_m=tuple(ends), truncated=truncated,
        reason="cut" if truncated else None, overlap=0.5, shadow_width_beams=width,
    )


def test_masks_from_shadows_cover_the_measured_boxes():
    ranges = 0.70 + 0.01 * np.arange(231)  # 0.70 .. 3.00 m, 1 cm rows
    azimuth = np.linspace(-0.2, 0.2, 21)
    measured = _measurement((8, 9, 10), (2.00, 2.01, 2.00), (2.40, 2.41, 2.39), highlight_m=1.90, width=5)
    cut = _measurement((), (), (), highlight_m=2.80, width=2, azimuth_rad=float(azimuth[17]), truncated=True)
    masks = masks_from_shadows([measured, cut], range_m=ranges, n_beams=21, beam_azimuth_rad=azimuth, pad_m=0.02)
    rows, cols = np.nonzero(masks.shadow)
    # measured: beams 8-10 widened to the shadow's 5 beams (7-11), plus one either side
    first = cols <= 12
    assert set(cols[first]) == set(range(6, 13))
    assert ranges[rows[first]].min() == pytest.approx(1.98) and ranges[rows[first]].max() == pytest.approx(2.43)
    # truncated, no beam located: 2 beams from beam 17 (17-18), plus one either side, from
    # its highlight to the window's end
    assert set(cols[~first]) == set(range(16, 20))
    assert ranges[rows[~first]].min() == pytest.approx(2.78) and rows[~first].max() == 230
    # the target mask adds the highlight's stretch in front of the shadow
    t_rows, t_cols = np.nonzero(masks.target[:, 6:13])
    assert ranges[t_rows].min() == pytest.approx(1.88) and np.all(masks.target[masks.shadow])
    # without azimuths a measurement that located no beam cannot be placed
    alone = masks_from_shadows([cut], range_m=ranges, n_beams=21)
    assert not alone.shadow.any()
    with pytest.raises(ValueError, match="increasing"):
        masks_from_shadows([], range_m=ranges[::-1], n_beams=21)


def test_a_measured_shadow_is_masked_only_if_it_is_dark():
    """A real shadow falls to the noise floor; a dark patch of seabed paired by chance does not."""
    ranges = 0.70 + 0.01 * np.arange(231)
    image = np.full((231, 21), 130, dtype=np.uint8)
    image[130:170, 8:11] = 20  # 35 dB down: a shadow, rows 2.00-2.39 m
    image[130:170, 15:18] = 110  # 6 dB down: seabed texture
    shadow = _measurement((8, 9, 10), (2.00,) * 3, (2.39,) * 3, highlight_m=1.95, width=3)
    patch = _measurement((15, 16, 17), (2.00,) * 3, (2.39,) * 3, highlight_m=1.95, width=3)
    masks = masks_from_shadows([shadow, patch], range_m=ranges, n_beams=21, image=image, pad_m=0.02)
    assert not masks.shadow[:, 13:].any() and not masks.target[:, 13:].any()
    rows, cols = np.nonzero(masks.shadow)
    assert set(cols) == set(range(7, 12))
    assert ranges[rows].min() == pytest.approx(1.98) and ranges[rows].max() == pytest.approx(2.41)
    # without the image both count
    assert masks_from_shadows([shadow, patch], range_m=ranges, n_beams=21).shadow[:, 13:].any()


def test_unreliable_cells_are_blended_but_not_registered(seabed):
    frame = _frame(seabed, north_m=5.0, east_m=5.0)
    cfg = MosaicConfig(resolution_m=RES_M)
    mask = np.zeros(frame.image.shape, dtype=bool)
    mask[300:350, 40:80] = True
    plain = project_frame(frame, placement_from_frame(frame), config=cfg)
    marked = project_frame(frame, placement_from_frame(frame), config=cfg, unreliable_mask=mask)
    assert plain is not None and marked is not None
    np.testing.assert_array_equal(plain.weight, marked.weight)
    np.testing.assert_array_equal(plain.reliable, plain.weight > 0)
    lost = plain.reliable & ~marked.reliable
    assert lost.sum() > 300
    n_idx, e_idx = np.nonzero(lost)
    slant = np.sqrt(((n_idx + marked.row0 + 0.5) * RES_M - 5.0) ** 2
                    + ((e_idx + marked.col0 + 0.5) * RES_M - 5.0) ** 2 + 1.0)
    assert slant.min() > RANGES_M[299] - 0.02 and slant.max() < RANGES_M[350] + 0.02


def test_drift_filter_weighs_matches_by_their_uncertainty():
    cfg = RegistrationConfig(initial_drift_std_m=0.02, drift_walk_m=0.01, measurement_std_m=0.015,
                             drift_floor_m=0.05, drift_per_m=0.02)
    est = DriftEstimator(cfg)
    match = RegistrationResult(True, 0.04, -0.03, 0.5, 0.8, "accepted")
    # after 5 m the drift's variance is 0.02^2 + 0.01^2 * 5 = 9e-4: gain 9e-4 / (9e-4 + 2.25e-4) = 0.8
    assert est.update(match, travelled_m=5.0).accepted
    assert est.north_m == pytest.approx(0.8 * 0.04) and est.east_m == pytest.approx(-0.8 * 0.03)
    assert est.std_m == pytest.approx(math.sqrt(9e-4 * 0.2))
    # a second identical match right away counts less (the estimate is already good)
    est.update(match, travelled_m=5.0)
    assert 0.032 < est.north_m < 0.032 + 0.8 * 0.04
    # the prior: 0.05 + 0.02 * 5 = 0.15 m of drift is the most the navigation allows here
    far = RegistrationResult(True, 0.15, 0.0, 0.5, 0.8, "accepted")
    refused = est.update(far, travelled_m=5.0)
    assert not refused.accepted and refused.reason == "drift beyond prior"
    assert est.rejected == 1 and est.accepted == 2


def test_a_seabed_the_correlation_cannot_hold_is_registered_less_often():
    est = DriftEstimator(RegistrationConfig(every_n_frames=3, backoff_after_refusals=60, backoff_factor=4))
    weak = RegistrationResult(False, 0.0, 0.0, 0.06, 0.5, "weak correlation")
    for i in range(59):
        est.update(weak, travelled_m=0.1 * i)
    assert est.interval_frames == 3  # 59 refusals in a row (the paper-targets dive's longest is 45)
    est.update(weak, travelled_m=6.0)
    assert est.interval_frames == 12
    assert est.update(RegistrationResult(True, 0.01, 0.0, 0.5, 0.8, "accepted"), travelled_m=6.1).accepted
    assert est.interval_frames == 3 and est.refused_in_a_row == 0


def test_registration_config_is_checked():
    with pytest.raises(ValueError, match="measurement_std_m"):
        RegistrationConfig(measurement_std_m=0.0)
    with pytest.raises(ValueError, match="stack_frames"):
        RegistrationConfig(stack_frames=40, reference_lag_frames=30)
    with pytest.raises(ValueError, match="min_ncc"):
        RegistrationConfig(min_ncc=1.5)


@pytest.mark.slow
def test_speckle_alone_is_never_registered():
    """Every ping draws a new random seabed (no persistent texture): nothing may match."""
    rng = np.random.default_rng(11)
    builder = MosaicBuilder(MosaicConfig(resolution_m=RES_M), RegistrationConfig(every_n_frames=1))
    for k in range(70):
        tex = texture(rng, 1000, blur_cells=1.0)
        heading = 0.0 if k < 35 else math.pi
        north = 2.0 + 0.05 * k if k < 35 else 7.5 - 0.05 * (k - 35)
        builder.add_frame(_frame(tex, north_m=north, east_m=5.0 + (0.0 if k < 35 else 0.3), heading_rad=heading))
    assert builder.drift is not None
    assert builder.drift.accepted == 0
    assert builder.drift.north_m == 0.0 and builder.drift.east_m == 0.0


@pytest.mark.slow
def test_speckle_fools_registration_without_its_quality_test():
    """The same pings with the quality tests off: speckle peaks are taken as drift."""
    rng = np.random.default_rng(11)
    loose = RegistrationConfig(every_n_frames=1, min_response=0.0, min_ncc=-1.0, min_ncc_gain=0.0,
                               half_agreement_m=0.0, outlier_sigmas=0.0)
    builder = MosaicBuilder(MosaicConfig(resolution_m=RES_M), loose)
    for k in range(70):
        tex = texture(rng, 1000, blur_cells=1.0)
        heading = 0.0 if k < 35 else math.pi
        north = 2.0 + 0.05 * k if k < 35 else 7.5 - 0.05 * (k - 35)
        builder.add_frame(_frame(tex, north_m=north, east_m=5.0 + (0.0 if k < 35 else 0.3), heading_rad=heading))
    assert builder.drift is not None and builder.drift.accepted > 5
    assert math.hypot(builder.drift.north_m, builder.drift.east_m) > 0.05
