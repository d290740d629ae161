"""The renderer's shortcuts give the frames the long way gives, bit for bit: only the rays
that can meet a target are cast (sim_harness.sonar.hulls), the blur runs on the rows that
hold echo, the noise bank carries its mean."""

from __future__ import annotations

import dataclasses
import math

import cv2
import numpy as np
import pytest

from sim_harness.sonar.geometry import cast_targets, pose_geometry, target_table
from sim_harness.sonar.hulls import beam_step_bounds, solid_hulls
from sim_harness.sonar.receiver import NoiseBanks
from sim_harness.sonar.renderer import SonarConfig, SonarPose, SonarRenderer
from sim_harness.sonar.seabed import constant_f32
from sim_harness.world.relief import Relief
from sim_harness.world.shapes import intersect_batch
from sim_harness.world.world import SHAPES, Seabed, TargetSpec, World


def _world(rng: np.random.Generator, relief: Relief | None = None) -> World:
    """Every shape of target around 1-4 m ahead, on a sloped seabed 20 m deep."""
    seabed = Seabed(20.0, slope_rad=math.radians(rng.uniform(0, 6)), slope_direction_rad=rng.uniform(0, 6.28),
                    relief=relief)
    targets = tuple(
        TargetSpec(f"t{i}", SHAPES[i % len(SHAPES)], rng.uniform(1.0, 4.0), rng.uniform(-1.0, 1.0),
                   rng.uniform(0.1, 0.5), rng.uniform(0.1, 0.4), rng.uniform(0.03, 0.4), yaw_rad=rng.uniform(0, 3))
        for i in range(2 * len(SHAPES))
    )
    return World(seabed, targets)


def _pose(world: World, rng: np.random.Generator) -> SonarPose:
    altitude = rng.uniform(0.3, 2.0)
    return SonarPose(rng.uniform(-0.5, 0.5), rng.uniform(-0.5, 0.5), world.seabed_depth_m(0.0, 0.0) - altitude,
                     heading_rad=rng.uniform(-0.5, 0.5), pitch_rad=rng.uniform(-0.1, 0.1),
                     roll_rad=rng.uniform(-0.1, 0.1), tilt_rad=rng.uniform(0.0, 1.2))


def _without_hulls(renderer: SonarRenderer) -> SonarRenderer:
    """The same renderer casting every ray of every target's block (no hulls known)."""
    table = renderer._targets
    long_way = SonarRenderer(renderer.world, renderer.config)
    long_way._targets = dataclasses.replace(table, hulls=tuple(None for _ in table.hulls))
    return long_way


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_casting_only_the_rays_that_can_hit_changes_no_frame(seed: int) -> None:
    rng = np.random.default_rng(seed)
    relief = Relief(0.03, 6.0, seed=seed) if seed else None
    world = _world(rng, relief)
    config = SonarConfig(window_start_m=0.5, window_length_m=5.0, samples_per_beam=500, seed=seed)
    short = SonarRenderer(world, config)
    long_way = _without_hulls(short)
    seen = 0
    for i in range(8):
        pose = _pose(world, rng)
        frame, truth = short.render(pose, 0.1 * i)
        frame_l, truth_l = long_way.render(pose, 0.1 * i)
        assert np.array_equal(frame.image, frame_l.image)
        assert np.array_equal(truth.labels, truth_l.labels)
        assert np.array_equal(truth.owner, truth_l.owner)
        assert [t.target_id for t in truth.targets] == [t.target_id for t in truth_l.targets]
        for a, b in zip(truth.targets, truth_l.targets, strict=True):
            assert np.array_equal(a.shadow_end_m, b.shadow_end_m)
            assert np.array_equal(a.highlight_start_m, b.highlight_start_m)
        seen += len(truth.targets)
    assert seen > 10  # targets were in view


def test_the_casts_agree_ray_for_ray_where_a_ray_hits() -> None:
    rng = np.random.default_rng(5)
    world = _world(rng)
    config = SonarConfig(window_start_m=0.5, window_length_m=5.0)
    table = target_table(world)
    every_ray = dataclasses.replace(table, hulls=tuple(None for _ in table.hulls))
    azimuth = np.asarray(config.beam_azimuth_rad)
    hits = 0
    for _ in range(10):
        pose = _pose(world, rng)
        geo = pose_geometry(world, **dataclasses.asdict(pose), beam_azimuth_rad=azimuth)
        args = {"beam_azimuth_rad": azimuth, "step_rad": config.target_ray_step_rad,
                "half_aperture_rad": config.elevation_aperture_rad / 2, "max_range_m": config.window_end_m}
        short, full = cast_targets(world, geo, table, **args), cast_targets(world, geo, every_ray, **args)
        assert [(c.placed.target_id, c.j0, c.k0, c.t.shape) for c in short] == \
               [(c.placed.target_id, c.j0, c.k0, c.t.shape) for c in full]
        for a, b in zip(short, full, strict=True):
            assert np.array_equal(a.t, b.t)  # a ray left out is a miss
            assert np.array_equal(a.occluding, b.occluding)
            hit = np.isfinite(b.t)
            assert np.array_equal(a.cos_incidence[hit], b.cos_incidence[hit])
            assert np.array_equal(a.t_seabed[hit], b.t_seabed[hit])
            hits += int(hit.sum())
    assert hits > 1000


@pytest.mark.parametrize("shape", SHAPES)
def test_every_ray_that_meets_a_solid_lies_within_its_beam_bounds(shape: str) -> None:
    rng = np.random.default_rng(len(shape))
    world = World(Seabed(5.0), (TargetSpec("t", shape, 1.5, 0.1, 0.3, 0.2, 0.15, yaw_rad=0.7),))
    placed = world.placed[0]
    hulls = solid_hulls(placed.solid)
    assert hulls is not None
    step = math.radians(0.08)
    azimuth = np.linspace(-0.4, 0.4, 161)
    k = np.arange(-1200, 1200)
    for _ in range(6):
        origin = np.array([rng.uniform(-0.5, 0.5), rng.uniform(-0.5, 0.5), rng.uniform(3.0, 4.7)])
        rot = np.linalg.qr(rng.normal(size=(3, 3)))[0]
        q = (hulls - origin) @ rot
        m = q.shape[0]
        lo, hi, everything = beam_step_bounds(np.tile(q, (azimuth.size, 1, 1)).transpose(1, 2, 0),
                                              np.repeat(azimuth, m), np.arange(0, m * azimuth.size, m), step)
        # brute force: every ray of the fan
        e = k * step
        local = np.stack(np.broadcast_arrays(np.cos(e)[None, :] * np.cos(azimuth)[:, None],
                                             np.cos(e)[None, :] * np.sin(azimuth)[:, None], np.sin(e)[None, :]), -1)
        d = local.reshape(-1, 3) @ rot.T
        t, _ = intersect_batch([placed.solid], np.zeros(d.shape[0], dtype=np.int64), origin, d, normals=False)
        beam, step_i = np.nonzero(np.isfinite(t.reshape(azimuth.size, k.size)))
        kk = k[step_i]
        inside = everything[beam] | ((kk >= lo[beam]) & (kk < hi[beam]))
        assert np.all(inside), (shape, int((~inside).sum()))


@pytest.mark.parametrize(("start", "stop"), [(0, 1000), (0, 3), (997, 1000), (400, 401), (10, 600), (500, 500)])
def test_blurring_the_echo_rows_only_is_the_whole_images_blur(start: int, stop: int) -> None:
    renderer = SonarRenderer(World(Seabed(5.0)), SonarConfig())
    rng = np.random.default_rng(start)
    raw = np.zeros((1000, 128), dtype=np.float32)
    raw[start:stop] = rng.exponential(1e4, size=(stop - start, 128)).astype(np.float32)
    whole = cv2.sepFilter2D(raw, cv2.CV_32F, renderer._beam_kernel, renderer._range_kernel,
                            borderType=cv2.BORDER_CONSTANT)
    assert np.array_equal(renderer._blur(raw, [(start, stop)]), whole)
    # several bands, one inside another
    assert np.array_equal(renderer._blur(raw, [(start, stop), (start, (start + stop) // 2)]), whole)


def test_a_noise_bank_with_its_mean_folded_in_gives_the_frame_of_the_mean_times_the_variate() -> None:
    seed, size, looks, mean = 3, 1 << 15, 1.0, 10.0 ** 1.2
    banks = NoiseBanks(seed=seed, size=size, speckle_looks=looks, texture_shape=math.inf, noise_mean=mean)
    clean = np.random.default_rng(1).exponential(100.0, size=(100, 64)).astype(np.float32)
    got = banks.apply(clean, 12.3)
    # the long way: the banks' variates as drawn, the offsets of the frame's timestamp
    bank_rng = np.random.default_rng([seed, 0x5EED])
    speckle = bank_rng.standard_gamma(looks, size, dtype=np.float32) / np.float32(looks)
    exponential = bank_rng.standard_exponential(size, dtype=np.float32)
    bits = int(np.array([12.3], dtype=np.float64).view(np.uint64)[0])
    rng = np.random.default_rng([seed, bits])
    o1, o2 = (int(rng.integers(0, size - clean.size + 1)) for _ in range(2))
    expected = clean * speckle[o1:o1 + clean.size].reshape(clean.shape)
    expected += np.float32(mean) * exponential[o2:o2 + clean.size].reshape(clean.shape)
    assert got.dtype == np.float32
    assert np.array_equal(got, expected)


def test_frames_are_the_same_with_any_number_of_opencv_threads() -> None:
    """The render process runs OpenCV on one thread (sim_harness.render_worker)."""
    rng = np.random.default_rng(9)
    world = _world(rng, Relief(0.03, 6.0, seed=4))
    renderer = SonarRenderer(world, SonarConfig(window_start_m=0.5, window_length_m=5.0))
    pose = _pose(world, rng)
    threads = cv2.getNumThreads()
    try:
        frames = []
        for n in (1, 4):
            cv2.setNumThreads(n)
            frames.append(renderer.render(pose, 1.0)[0].image)
    finally:
        cv2.setNumThreads(threads)
    assert np.array_equal(frames[0], frames[1])


@pytest.mark.parametrize("shape", [(0,), (1,), (7, 3), (501, 128)])
def test_constant_bounds_bound_as_scalars_do(shape: tuple[int, ...]) -> None:
    x = np.random.default_rng(sum(shape)).normal(size=shape).astype(np.float32)
    low = constant_f32(-0.2, shape)
    assert low.shape == shape and low.dtype == np.float32 and not low.flags.writeable
    assert np.all(low == np.float32(-0.2))
    assert np.array_equal(np.maximum(x, low), np.maximum(x, np.float32(-0.2)))
    assert np.array_equal(np.minimum(np.maximum(x, low), constant_f32(0.3, shape)),
                          np.clip(x, np.float32(-0.2), np.float32(0.3)))
