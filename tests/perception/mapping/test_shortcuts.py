"""The map's shortcuts change no answer: the projection's per-geometry cache, its blocks cut
to the fan, the frame read once for two projections, the seabed cells kept per blended
frame, the moved frame, the shared blurs of the registration, the heights layer drawn
target by target. Each is held bit for bit to the plain computation it replaced."""

from __future__ import annotations

import math
from dataclasses import fields

import cv2
import numpy as np
import pytest

from perception.geometry import ray_direction_sonar, sonar_to_ned
from perception.mapping import projection, registration
from perception.mapping.builder import MosaicBuilder, _SeabedCells, _stack
from perception.mapping.heights_layer import MappedTarget, height_raster
from perception.mapping.mosaic import MosaicConfig, ProjectedFrame, SonarPlacement, TiledMosaic, placement_from_frame
from perception.mapping.projection import axes_of, frame_samples, project_frame, project_samples
from perception.mapping.registration import RegistrationConfig
from perception.mapping.survey_map import moved_frame
from perception.sonar_io.beams import aris3000_128
from perception.sonar_io.frame import SonarFrame
from tests.perception.heights.synth_seabed import render, texture

RES_M = 0.01
AZIMUTH_RAD = np.asarray(aris3000_128().azimuth_rad)


def _reference_projection(frame: SonarFrame, placement: SonarPlacement, config: MosaicConfig,
                          exclude_mask: np.ndarray | None = None,
                          unreliable_mask: np.ndarray | None = None) -> ProjectedFrame | None:
    """The projection as it was computed per frame before its shortcuts (kept verbatim)."""
    rot = sonar_to_ned(tilt_rad=placement.tilt_rad, pitch_rad=placement.pitch_rad, roll_rad=placement.roll_rad,
                       heading_rad=placement.heading_rad)
    half = frame.elevation_aperture_rad / 2.0
    az = np.linspace(frame.beam_azimuth_rad[0], frame.beam_azimuth_rad[-1], 24)
    el = np.linspace(-half, half, 24)
    dirs = ray_direction_sonar(az[:, None], el[None, :]).reshape(-1, 3) @ rot.T
    r0, r1 = frame.window_m
    hits = dirs[:, 2] > 1e-9
    if not np.any(hits):
        return None
    t = np.clip(placement.altitude_m / dirs[hits, 2], r0, r1)
    pts = dirs[hits] * t[:, None]
    pad = 2.0 * (r1 - r0) / frame.n_samples + 0.02
    res = config.resolution_m
    row0 = math.floor((float(pts[:, 0].min()) + placement.north_m - pad) / res)
    row1 = math.ceil((float(pts[:, 0].max()) + placement.north_m + pad) / res)
    col0 = math.floor((float(pts[:, 1].min()) + placement.east_m - pad) / res)
    col1 = math.ceil((float(pts[:, 1].max()) + placement.east_m + pad) / res)
    north = ((np.arange(row0, row1, dtype=np.float64) + 0.5) * res - placement.north_m).astype(np.float32)
    east = ((np.arange(col0, col1, dtype=np.float64) + 0.5) * res - placement.east_m).astype(np.float32)
    down = placement.altitude_m
    rt = rot.T.astype(np.float32)
    f32 = np.float32
    vx = rt[0, 0] * north[:, None] + (rt[0, 1] * east + f32(rt[0, 2] * down))[None, :]
    vy = rt[1, 0] * north[:, None] + (rt[1, 1] * east + f32(rt[1, 2] * down))[None, :]
    vz = rt[2, 0] * north[:, None] + (rt[2, 1] * east + f32(rt[2, 2] * down))[None, :]
    horiz = np.sqrt(vx * vx + vy * vy)
    rng = np.sqrt(horiz * horiz + vz * vz)
    azimuth = np.arctan2(vy, vx)
    ranges = np.asarray(frame.range_m, dtype=np.float64)
    beams = np.asarray(frame.beam_azimuth_rad, dtype=np.float32)
    step = (ranges[-1] - ranges[0]) / (ranges.size - 1)
    if np.allclose(np.diff(ranges), step, rtol=1e-6, atol=0.0):
        map_row = (rng - f32(ranges[0])) * f32(1.0 / step)
        map_row[(map_row < 0) | (map_row > ranges.size - 1)] = -1.0
    else:
        map_row = np.interp(rng.ravel(), ranges, np.arange(ranges.size, dtype=np.float64), left=-1,
                            right=-1).reshape(rng.shape).astype(np.float32)
    map_col = np.interp(azimuth.ravel(), beams, np.arange(beams.size, dtype=np.float32), left=-1, right=-1)
    map_col = map_col.reshape(rng.shape).astype(np.float32)
    image = np.asarray(frame.image, dtype=np.float32)
    intensity = cv2.remap(image, map_col, map_row, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=0)
    half_fan = max(abs(float(beams[0])), abs(float(beams[-1])))
    e_frac = np.abs(np.arctan(vz / np.maximum(horiz, f32(1e-9)))) * f32(1.0 / half)
    inside = (map_row >= 0) & (map_col >= 0) & (e_frac <= 1.0)
    sin_grazing = f32(down) / np.maximum(rng, f32(1e-6))
    inside &= sin_grazing >= math.sin(config.min_grazing_rad)
    weight = np.zeros(rng.shape, dtype=np.float32)
    w = sin_grazing
    if config.beam_taper_power:
        e_taper = np.maximum(np.cos(np.minimum(e_frac, f32(1.0)) * f32(math.pi / 2)), f32(1e-3))
        w = w * projection._power(e_taper, config.beam_taper_power)
    if config.fan_taper_power:
        a_frac = np.minimum(np.abs(azimuth) * f32(1.0 / (half_fan * 1.05)), f32(1.0))
        a_taper = np.maximum(np.cos(a_frac * f32(math.pi / 2)), f32(1e-3))
        w = w * projection._power(a_taper, config.fan_taper_power)
    weight[inside] = w[inside]
    unreliable = None
    if exclude_mask is not None or unreliable_mask is not None:
        codes = np.zeros(frame.image.shape, dtype=np.uint8)
        if exclude_mask is not None:
            codes[exclude_mask] = 1
        if unreliable_mask is not None:
            codes[unreliable_mask] |= 2
        cell_codes = cv2.remap(codes, map_col, map_row, cv2.INTER_NEAREST, borderMode=cv2.BORDER_CONSTANT,
                               borderValue=0)
        weight[(cell_codes & 1) > 0] = 0.0
        unreliable = (cell_codes & 2) > 0
    intensity[weight == 0] = 0.0
    if not np.any(weight > 0):
        return None
    reliable = weight > 0
    if unreliable is not None:
        reliable &= ~unreliable
    return ProjectedFrame(row0, col0, intensity, weight, reliable)


def _same(a: ProjectedFrame | None, b: ProjectedFrame | None) -> None:
    assert (a is None) == (b is None)
    if a is None or b is None:
        return
    assert (a.row0, a.col0) == (b.row0, b.col0)
    for name in ("intensity", "weight", "reliable"):
        x, y = getattr(a, name), getattr(b, name)
        assert x.dtype == y.dtype and x.shape == y.shape
        assert np.array_equal(x.view(np.uint8), y.view(np.uint8)), name  # bit for bit, signs of zero too


@pytest.fixture(scope="module")
def seabed() -> np.ndarray:
    return texture(np.random.default_rng(3), 1200, blur_cells=2.0)


def _frames(tex: np.ndarray) -> list[SonarFrame]:
    even = np.linspace(0.7, 3.0, 500)
    uneven = 0.7 + 2.3 * np.linspace(0.0, 1.0, 400) ** 1.3  # a table that is not evenly spaced
    out = []
    for k, (ranges, alt, tilt_deg, heading) in enumerate([
        (even, 1.0, 25.0, 0.3), (uneven, 0.8, 20.0, -2.0), (even, 1.5, 35.0, 2.8), (even, 0.6, 15.0, -0.7),
        (uneven, 1.2, 30.0, 1.1),
    ]):
        out.append(render(tex, res_m=RES_M, north_m=4.0 + 0.37 * k, east_m=5.0 - 0.21 * k, altitude_m=alt,
                          heading_rad=heading, tilt_rad=math.radians(tilt_deg), range_m=ranges,
                          azimuth_rad=AZIMUTH_RAD, timestamp_s=0.1 * k))
    return out


def _masks(frame: SonarFrame, seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    shadow = np.zeros(frame.image.shape, dtype=bool)
    target = np.zeros(frame.image.shape, dtype=bool)
    for _ in range(3):
        r = int(rng.integers(0, frame.n_samples - 60))
        c = int(rng.integers(0, frame.n_beams - 8))
        shadow[r + 20 : r + 60, c : c + 8] = True
        target[r : r + 60, c : c + 8] = True
    return shadow, target


@pytest.mark.parametrize("config", [
    MosaicConfig(),
    MosaicConfig(resolution_m=0.02, beam_taper_power=2.0, fan_taper_power=0.0),
    MosaicConfig(beam_taper_power=0.0, fan_taper_power=0.7, min_grazing_rad=math.radians(20)),
])
@pytest.mark.parametrize("block_cells", [1 << 18, projection.BLOCK_CELLS, 3000])
def test_projection_is_bit_for_bit_the_plain_computation(seabed, config, block_cells, monkeypatch):
    # one block per footprint (as before bands), the bands of a few dozen rows, and small
    # blocks: the box is cut into many, each to the columns the fan can reach
    monkeypatch.setattr(projection, "BLOCK_CELLS", block_cells)
    projection._axes.cache_clear()
    frames = _frames(seabed)
    # twice round, geometries interleaved: the cache serves frames of several geometries
    for rep in range(2):
        for k, frame in enumerate(frames):
            placement = placement_from_frame(frame)
            if rep:
                placement = placement.shifted(0.013 * k, -0.021)
            shadow, target = _masks(frame, k)
            for masks in ({}, {"exclude_mask": shadow}, {"unreliable_mask": target},
                          {"exclude_mask": shadow, "unreliable_mask": target}):
                _same(project_frame(frame, placement, config=config, **masks),
                      _reference_projection(frame, placement, config, **masks))


def test_frame_samples_projected_twice_give_what_two_projections_give(seabed):
    frame = _frames(seabed)[0]
    shadow, target = _masks(frame, 5)
    samples = frame_samples(frame, exclude_mask=shadow, unreliable_mask=target)
    cfg = MosaicConfig()
    for d in ((0.0, 0.0), (0.047, -0.031)):
        placement = placement_from_frame(frame).shifted(*d)
        _same(project_samples(samples, placement, config=cfg),
              project_frame(frame, placement, config=cfg, exclude_mask=shadow, unreliable_mask=target))


def test_axes_cache_tells_geometries_apart(seabed):
    a, b = _frames(seabed)[:2]
    assert axes_of(a) is axes_of(a.with_fields(timestamp_s=9.0))  # one geometry, one entry
    assert axes_of(a) is not axes_of(b)
    wider = a.with_fields(elevation_aperture_rad=math.radians(20))
    assert axes_of(wider) is not axes_of(a)
    assert not axes_of(b).evenly_spaced and axes_of(a).evenly_spaced


def test_seabed_cells_and_stack_are_the_plain_weighted_mean(seabed):
    frames = _frames(seabed)
    cfg = MosaicConfig()
    projected = []
    for k, frame in enumerate(frames[:4]):
        shadow, target = _masks(frame, k)
        p = project_frame(frame, placement_from_frame(frame.with_fields(north_m=4.0, east_m=5.0)), config=cfg,
                          exclude_mask=shadow, unreliable_mask=target)
        assert p is not None
        projected.append(p)
    newest, older = projected[0], projected[1:]
    got = _stack(newest, [_SeabedCells.of(p) for p in older])
    # the plain form: each older frame's reliable weights and their products formed where used
    n_rows, n_cols = newest.shape
    sum_w = np.where(newest.reliable, newest.weight, np.float32(0))
    sum_wi = sum_w * newest.intensity
    for p in older:
        r0, c0 = max(newest.row0, p.row0), max(newest.col0, p.col0)
        r1, c1 = min(newest.row0 + n_rows, p.row0 + p.shape[0]), min(newest.col0 + n_cols, p.col0 + p.shape[1])
        if r1 <= r0 or c1 <= c0:
            continue
        src = (slice(r0 - p.row0, r1 - p.row0), slice(c0 - p.col0, c1 - p.col0))
        dst = (slice(r0 - newest.row0, r1 - newest.row0), slice(c0 - newest.col0, c1 - newest.col0))
        w = np.where(p.reliable[src], p.weight[src], np.float32(0))
        sum_w[dst] += w
        sum_wi[dst] += w * p.intensity[src]
    mean = np.zeros_like(sum_wi)
    np.divide(sum_wi, sum_w, out=mean, where=sum_w > 0)
    _same(got, ProjectedFrame(newest.row0, newest.col0, mean, sum_w, newest.reliable & (sum_w > 0)))
    # the reference mosaic: sums added whole are what adding the masked frame gives
    by_sums, by_frames = TiledMosaic(cfg), TiledMosaic(cfg)
    for p in older:
        cells = _SeabedCells.of(p)
        by_sums.add_sums(cells.row0, cells.col0, cells.weight, cells.weighted_intensity)
        by_frames.add(ProjectedFrame(p.row0, p.col0, p.intensity, np.where(p.reliable, p.weight, np.float32(0)),
                                     p.reliable))
    for x, y in zip(by_sums.raster(), by_frames.raster(), strict=True):
        assert np.array_equal(np.asarray(x), np.asarray(y))


def test_moved_frame_is_with_fields(seabed):
    frame = _frames(seabed)[0]
    for north, east in ((1.25, -3.5), (math.nan, 2.0)):
        fast, slow = moved_frame(frame, north, east), frame.with_fields(north_m=north, east_m=east)
        for f in fields(SonarFrame):
            x, y = getattr(fast, f.name), getattr(slow, f.name)
            if isinstance(x, np.ndarray):
                assert np.array_equal(x, y) and x.dtype == y.dtype and not x.flags.writeable
            elif isinstance(x, float) and math.isnan(x):
                assert math.isnan(y)
            else:
                assert x == y and type(x) is type(y), f.name
    assert frame.north_m == 4.0  # the original is untouched
    with pytest.raises(ValueError, match="north_m"):  # beyond the origin's reach: refused as before
        moved_frame(frame, 2.0e6, 0.0)


def test_shared_blurs_of_the_registration_are_the_separate_ones(seabed):
    rng = np.random.default_rng(11)
    a = rng.random((150, 170)).astype(np.float32)
    b = rng.random((150, 170)).astype(np.float32)
    mask = np.zeros((150, 170), dtype=bool)
    mask[20:130, 15:160] = True

    def alone(image: np.ndarray) -> np.ndarray:  # the per-image form it replaced
        m = mask.astype(np.float32)
        local = cv2.GaussianBlur(image * m, (0, 0), 8.0)
        norm = cv2.GaussianBlur(m, (0, 0), 8.0)
        out = np.zeros_like(image)
        np.divide(local, norm, out=out, where=norm > 1e-3)
        return (image - out) * m

    ha, hb = registration._high_pass((a, b), mask, 8.0)
    assert np.array_equal(ha, alone(a)) and np.array_equal(hb, alone(b))
    smooth = registration._smoothed(ha)
    values = smooth[mask]
    median = float(np.median(values))
    spread = registration._robust_spread(values, median)
    assert spread == 1.4826 * float(np.median(np.abs(values - np.median(values))))
    assert np.array_equal(registration._outliers(smooth, mask, 1.0, spread, values, median),
                          registration._outliers(smooth, mask, 1.0, spread))


def test_builder_with_registration_matches_itself_rebuilt(seabed):
    """Two builders fed the same frames agree exactly (the caches hold no state between frames
    that could leak from one builder into another)."""
    frames = [render(seabed, res_m=RES_M, north_m=3.0 + 0.05 * k, east_m=6.0, altitude_m=1.0, heading_rad=0.0,
                     tilt_rad=math.radians(25), range_m=np.linspace(0.7, 3.0, 400), azimuth_rad=AZIMUTH_RAD,
                     timestamp_s=0.1 * k, nav_offset_m=(0.0, 0.002 * k)) for k in range(40)]
    cfg = RegistrationConfig(reference_lag_frames=6, stack_frames=3, every_n_frames=2)
    first, second = MosaicBuilder(MosaicConfig(), cfg), MosaicBuilder(MosaicConfig(), cfg)
    projection._axes.cache_clear()
    for frame in frames:
        first.add_frame(frame)
    for frame in frames:
        second.add_frame(frame)
    for x, y in zip(first.mosaic.raster(), second.mosaic.raster(), strict=True):
        assert np.array_equal(np.asarray(x), np.asarray(y))
    assert first.drift is not None and second.drift is not None
    assert (first.drift.north_m, first.drift.east_m) == (second.drift.north_m, second.drift.east_m)


@pytest.mark.parametrize("threads", [2, 4])
def test_map_and_heights_on_one_opencv_thread_are_those_on_several(seabed, threads):
    """The map process runs OpenCV on one thread (perception.mapping.map_process): the mosaic,
    its registration and the frames' shadows come out the same as on several."""
    from perception.heights.detect import detect_shadows

    frames = [render(seabed, res_m=RES_M, north_m=3.0 + 0.05 * k, east_m=6.0, altitude_m=1.0, heading_rad=0.0,
                     tilt_rad=math.radians(25), range_m=np.linspace(0.7, 3.0, 400), azimuth_rad=AZIMUTH_RAD,
                     timestamp_s=0.1 * k, nav_offset_m=(0.0, 0.002 * k)) for k in range(24)]
    cfg = RegistrationConfig(reference_lag_frames=6, stack_frames=3, every_n_frames=2)
    from perception import imaging

    before = imaging.threads()
    results = []
    try:
        for n in (1, threads):
            imaging.set_threads(n)
            projection._axes.cache_clear()
            builder = MosaicBuilder(MosaicConfig(), cfg)
            shadows = []
            for frame in frames:
                builder.add_frame(frame)
                shadows.append(detect_shadows(frame.image, range_m=frame.range_m,
                                              beam_azimuth_rad=frame.beam_azimuth_rad))
            results.append((builder, shadows))
    finally:
        imaging.set_threads(before)
    (one, one_shadows), (many, many_shadows) = results
    for x, y in zip(one.mosaic.raster(), many.mosaic.raster(), strict=True):
        assert np.array_equal(np.asarray(x), np.asarray(y), equal_nan=True)
    assert one.drift is not None and many.drift is not None
    assert (one.drift.north_m, one.drift.east_m) == (many.drift.north_m, many.drift.east_m)
    assert repr(one_shadows) == repr(many_shadows)


def test_heights_layer_drawn_per_target_is_the_plain_one():
    rng = np.random.default_rng(4)
    targets = []
    for k in range(40):
        north, east = rng.uniform(-0.05, 1.25, 2)  # some beyond the raster's edges
        height = math.nan if k % 7 == 0 else float(rng.uniform(0.01, 0.3))
        footprint: tuple[tuple[float, float], ...] = ()
        if k % 2:
            angles = np.sort(rng.uniform(0, 2 * math.pi, 5))
            radius = rng.uniform(0.005, 0.08)
            footprint = tuple((north + radius * math.cos(a), east + radius * math.sin(a)) for a in angles)
        targets.append(MappedTarget(k, north, east, height, 0.01, 3, footprint))
    shape, row0, col0, res = (110, 95), 3, -2, 0.01
    plain = np.full(shape, np.nan, dtype=np.float32)  # the form it replaced: a fresh mask per target
    for t in sorted(targets, key=lambda t: t.height_m if math.isfinite(t.height_m) else -1):
        if not math.isfinite(t.height_m):
            continue
        mask = np.zeros(shape, dtype=np.uint8)
        if len(t.footprint_ne_m) >= 3:
            pts = np.array([[(e / res - 0.5 - col0), (n / res - 0.5 - row0)] for n, e in t.footprint_ne_m])
            cv2.fillPoly(mask, [np.round(pts * 16).astype(np.int32)], 1, lineType=cv2.LINE_8, shift=4)
        else:
            centre = (int(round(t.east_m / res - 0.5 - col0)), int(round(t.north_m / res - 0.5 - row0)))
            cv2.circle(mask, centre, 1, 1, -1)
        plain[mask > 0] = t.height_m
    got = height_raster(targets, row0=row0, col0=col0, shape=shape, resolution_m=res)
    assert np.array_equal(got, plain, equal_nan=True)
    assert np.isfinite(got).sum() > 100
