"""The persistent seabed texture: its statistics, its place in the world, and scene keys."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial import cKDTree

from perception.geometry import sonar_to_ned
from sim_harness.sonar import geometry as sonar_geometry
from sim_harness.sonar import seabed as sonar_seabed
from sim_harness.sonar.renderer import SonarConfig, SonarPose, SonarRenderer
from sim_harness.sonar.scene import load_scene
from sim_harness.sonar.seabed import seabed_branches
from sim_harness.sonar.truth import Label
from sim_harness.world.errors import SceneError, WorldError
from sim_harness.world.texture import SeabedTexture
from sim_harness.world.world import Seabed, TargetSpec, World

SEABED_DEPTH_M = 10.0


@pytest.mark.parametrize(("std_db", "correlation_m", "seed"), [(3.0, 0.1, 0), (6.0, 0.05, 7), (1.5, 0.2, 3)])
def test_texture_statistics_match_its_parameters(
    std_db: float, correlation_m: float, seed: int, rng: np.random.Generator
) -> None:
    tex = SeabedTexture(std_db, correlation_m, seed=seed)
    n = rng.uniform(-200.0, 200.0, 100_000)
    e = rng.uniform(-200.0, 200.0, 100_000)
    db = tex.db(n, e)
    # bilinear sampling between nodes smooths the field by ~1-2 %
    assert db.std() == pytest.approx(std_db, rel=0.04)
    assert float(np.mean(tex.gain(n, e))) == pytest.approx(1.0, abs=0.02)  # mean backscatter kept
    # log-normal: the dB values are Gaussian (skewness and excess kurtosis near 0)
    z = (db - db.mean()) / db.std()
    assert abs(float(np.mean(z**3))) < 0.1 and abs(float(np.mean(z**4)) - 3.0) < 0.2
    # autocorrelation exp(-(d / L)^2) in any direction
    for lag, expected in ((0.5, math.exp(-0.25)), (1.0, math.exp(-1.0)), (2.5, 0.0)):
        theta = rng.uniform(0.0, 2 * math.pi, n.size)
        moved = tex.db(n + lag * correlation_m * np.cos(theta), e + lag * correlation_m * np.sin(theta))
        assert np.corrcoef(db, moved)[0, 1] == pytest.approx(expected, abs=0.04), lag


@settings(max_examples=30, deadline=None)
@given(
    seed=st.integers(0, 2**31),
    north_m=st.floats(-1e4, 1e4),
    east_m=st.floats(-1e4, 1e4),
    wraps=st.tuples(st.integers(-50, 50), st.integers(-50, 50)),
)
def test_texture_is_periodic_with_its_tile_and_fixed_by_its_seed(
    seed: int, north_m: float, east_m: float, wraps: tuple[int, int]
) -> None:
    tex = SeabedTexture(4.0, 0.08, seed=seed, tile_cells=64)
    here = tex.gain(north_m, east_m)
    there = tex.gain(north_m + wraps[0] * tex.tile_m, east_m + wraps[1] * tex.tile_m)
    assert float(there) == pytest.approx(float(here), rel=1e-3)
    again = SeabedTexture(4.0, 0.08, seed=seed, tile_cells=64)
    assert float(again.gain(north_m, east_m)) == float(here)


def test_texture_is_continuous_and_seeds_differ(rng: np.random.Generator) -> None:
    tex = SeabedTexture(3.0, 0.1, seed=1)
    n, e = rng.uniform(-50, 50, 5000), rng.uniform(-50, 50, 5000)
    # a millimetre is 1 % of the correlation length: the gain barely moves
    step = np.abs(tex.db(n + 1e-3, e) - tex.db(n, e))
    assert np.max(step) < 0.05 * 3.0 * 4
    other = SeabedTexture(3.0, 0.1, seed=2)
    assert abs(np.corrcoef(tex.db(n, e), other.db(n, e))[0, 1]) < 0.1


@pytest.mark.parametrize(
    ("kwargs", "key"),
    [
        ({"std_db": 0.0, "correlation_m": 0.1}, "seabed.texture_db"),
        ({"std_db": -1.0, "correlation_m": 0.1}, "seabed.texture_db"),
        ({"std_db": 25.0, "correlation_m": 0.1}, "seabed.texture_db"),
        ({"std_db": math.nan, "correlation_m": 0.1}, "seabed.texture_db"),
        ({"std_db": 3.0, "correlation_m": 0.0}, "seabed.texture_scale_m"),
        ({"std_db": 3.0, "correlation_m": 50.0}, "seabed.texture_scale_m"),
        ({"std_db": 3.0, "correlation_m": 0.1, "seed": -1}, "seabed.texture_seed"),
        ({"std_db": 3.0, "correlation_m": 0.1, "tile_cells": 100}, "seabed.texture_tile_cells"),
    ],
)
def test_bad_texture_parameters_name_the_key(kwargs: dict, key: str) -> None:
    with pytest.raises(WorldError) as info:
        SeabedTexture(**kwargs)
    assert info.value.key == key


# ---------------------------------------------------------------------------- rendering
def _ground_points(pose: SonarPose, config: SonarConfig) -> tuple[np.ndarray, np.ndarray]:
    """Where each cell's beam-axis ray meets the flat seabed at the cell's centre range:
    (north/east, shape (n_samples, n_beams, 2), m; elevation of that ray, rad), for the
    seabed branch below the nadir direction of each beam plane."""
    rot = sonar_to_ned(tilt_rad=pose.tilt_rad, pitch_rad=pose.pitch_rad, roll_rad=pose.roll_rad,
                       heading_rad=pose.heading_rad)
    az = np.asarray(config.beam_azimuth_rad)
    r = config.range_m[:, None]
    # down component of a ray (cos e cos a, cos e sin a, sin e): rho cos(e - phi)
    alpha = np.cos(az) * rot[2, 0] + np.sin(az) * rot[2, 1]
    rho, phi = np.hypot(alpha, rot[2, 2]), np.arctan2(rot[2, 2], alpha)
    height = SEABED_DEPTH_M - pose.depth_m
    e = phi - np.arccos(np.clip(height / (rho * r), -1.0, 1.0))
    d_sonar = np.stack([np.cos(e) * np.cos(az), np.cos(e) * np.sin(az), np.sin(e)], axis=-1)
    p = np.array([pose.north_m, pose.east_m, pose.depth_m]) + r[..., None] * (d_sonar @ rot.T)
    assert np.allclose(p[..., 2][height / (rho * r) < 1], SEABED_DEPTH_M)
    return p[..., :2], e


POSES = (
    SonarPose(3.0, -2.0, 9.1, heading_rad=0.3, tilt_rad=math.radians(25.0)),
    SonarPose(6.2, -1.1, 9.2, heading_rad=math.pi + 0.3, pitch_rad=0.05, roll_rad=-0.04,
              tilt_rad=math.radians(28.0)),
)


def test_texture_stays_at_its_ground_point_from_two_poses() -> None:
    tex = SeabedTexture(4.0, 0.15, seed=3)
    config = SonarConfig(noise_floor_db=None)
    plain = SonarRenderer(World(Seabed(SEABED_DEPTH_M)), config)
    textured = SonarRenderer(World(Seabed(SEABED_DEPTH_M, texture=tex)), config)
    seen = []
    for pose in POSES:
        ground, e = _ground_points(pose, config)
        base = plain.render_layers(pose, 0.0).clean_power.astype(np.float64)
        ok = (np.abs(e) < math.radians(6.0)) & (base > 0)
        assert np.count_nonzero(ok) > 20000
        # the clean echo over the plain one is the texture at that cell's ground point
        ratio_db = 10 * np.log10(textured.render_layers(pose, 0.0).clean_power[ok] / base[ok])
        truth_db = tex.db(ground[ok][:, 0], ground[ok][:, 1])
        assert np.corrcoef(ratio_db, truth_db)[0, 1] > 0.99
        assert np.std(ratio_db) == pytest.approx(np.std(truth_db), rel=0.05)
        # with per-ping speckle on top, the pattern survives averaging over pings
        mean_power = np.mean([textured.render_layers(pose, 0.1 * k).power[ok] for k in range(16)], axis=0)
        assert np.corrcoef(10 * np.log10(mean_power / base[ok]), truth_db)[0, 1] > 0.9
        seen.append((ground[ok], ratio_db))
    # the two poses look from opposite sides; where they see the same ground, same texture
    dist, idx = cKDTree(seen[1][0]).query(seen[0][0])
    same = dist < 0.005
    assert np.count_nonzero(same) > 5000
    assert np.corrcoef(seen[0][1][same], seen[1][1][idx[same]])[0, 1] > 0.99


@pytest.mark.parametrize(("correlation_m", "window_m"), [(0.1, (1.0, 7.0)), (0.1, (1.0, 3.3)), (0.04, (1.0, 7.0))])
def test_seabed_echo_carries_the_texture_at_each_cells_ground_point(
    correlation_m: float, window_m: tuple[float, float], monkeypatch: pytest.MonkeyPatch
) -> None:
    # the analytic seabed's echo (before blur and speckle) over the plain one is the texture
    # at each cell's ground point, also where it is sampled on every few range cells only
    tex = SeabedTexture(3.0, correlation_m, seed=2)
    config = SonarConfig(window_start_m=window_m[0], window_length_m=window_m[1] - window_m[0])
    pose = POSES[1]
    ground, e = _ground_points(pose, config)
    strides = []
    errors_db = []
    for sample_cells in (1e-9, sonar_seabed.TEXTURE_SAMPLE_CELLS):
        monkeypatch.setattr(sonar_seabed, "TEXTURE_SAMPLE_CELLS", sample_cells)
        power = []
        for texture in (None, tex):
            renderer = SonarRenderer(World(Seabed(SEABED_DEPTH_M, texture=texture)), config)
            geo = renderer_geometry(renderer, pose)
            branch = next(b for b in seabed_branches(
                renderer.world, geo, range_edges_m=renderer._edges, range_centres_m=renderer._range,
                half_aperture_rad=renderer._half_ap, pattern_coeff=renderer._pattern_coeff,
                footprint=renderer._footprint) if b.sign < 0)
            full = np.zeros((config.samples_per_beam, config.n_beams))
            full[branch.rows] = branch.power
            power.append(full)
        ok = (power[0] > 0) & (np.abs(e) < math.radians(6.0))
        assert np.count_nonzero(ok) > 5000
        got_db = 10 * np.log10(power[1][ok] / power[0][ok])
        errors_db.append(got_db - tex.db(ground[ok][:, 0], ground[ok][:, 1]))
        strides.append(math.floor(sample_cells * tex.cell_m / config.range_resolution_m))
    exact, sampled = errors_db
    assert np.sqrt(np.mean(exact**2)) < 0.01 and np.abs(exact).max() < 0.1
    assert np.sqrt(np.mean(sampled**2)) < 0.05 and np.abs(sampled).max() < 0.5
    if strides[1] >= 2:  # the coarse sampling does change something (the test can fail)
        assert not np.allclose(exact, sampled, atol=1e-4)
    else:  # texture cells finer than a sampling step: every range cell is sampled, as exact
        assert np.array_equal(exact, sampled)


def renderer_geometry(renderer: SonarRenderer, pose: SonarPose) -> sonar_geometry.PoseGeometry:
    """The renderer's per-pose geometry for ``pose``."""
    return sonar_geometry.pose_geometry(
        renderer.world, north_m=pose.north_m, east_m=pose.east_m, depth_m=pose.depth_m,
        heading_rad=pose.heading_rad, pitch_rad=pose.pitch_rad, roll_rad=pose.roll_rad,
        tilt_rad=pose.tilt_rad, beam_azimuth_rad=np.asarray(renderer.config.beam_azimuth_rad))


def test_texture_changes_echo_only_not_labels_shadows_or_truth() -> None:
    target = TargetSpec("box", "box", 4.8, -1.4, 0.3, 0.3, 0.12, yaw_rad=0.4)
    tex = SeabedTexture(3.0, 0.1, seed=5)
    config = SonarConfig(noise_floor_db=None, speckle_looks=0.0)
    pose = POSES[0]
    plain = SonarRenderer(World(Seabed(SEABED_DEPTH_M), (target,)), config).render_layers(pose, 0.0)
    textured = SonarRenderer(World(Seabed(SEABED_DEPTH_M, texture=tex), (target,)), config).render_layers(pose, 0.0)
    assert len(plain.targets) == 1
    assert np.array_equal(plain.labels, textured.labels)
    assert np.array_equal(plain.owner, textured.owner)
    assert repr(plain.targets) == repr(textured.targets)
    shadow = plain.labels == Label.SHADOW
    assert np.count_nonzero(shadow) > 200
    # the texture never fills a shadow: hidden seabed stays removed
    seabed = plain.labels == Label.SEABED
    dark = np.median(plain.clean_power[seabed]) * 1e-3
    assert np.median(textured.clean_power[shadow]) < dark
    # and over many correlation lengths the mean seabed echo is unchanged
    ratio = textured.clean_power[seabed].astype(np.float64) / plain.clean_power[seabed]
    assert ratio.mean() == pytest.approx(1.0, abs=0.12)
    assert ratio.std() > 0.3


# ---------------------------------------------------------------------------- scene keys
SCENE = """
[seabed]
depth_m = 5.0
{texture}

[viewpoint]
altitude_m = 1.0
"""


def _scene(tmp_path: Path, texture: str) -> Path:
    path = tmp_path / "t.toml"
    path.write_text(SCENE.format(texture=texture), encoding="utf-8")
    return path


def test_scene_texture_keys_and_defaults(tmp_path: Path) -> None:
    world = load_scene(_scene(tmp_path, "texture_db = 2.5\ntexture_scale_m = 0.07\ntexture_seed = 9")).world
    assert world.seabed.texture == SeabedTexture(2.5, 0.07, seed=9)
    world = load_scene(_scene(tmp_path, "texture_db = 2.5")).world
    assert world.seabed.texture == SeabedTexture(2.5, 0.1, seed=0)
    assert load_scene(_scene(tmp_path, "texture_db = 0.0\ntexture_scale_m = 0.2")).world.seabed.texture is None
    assert load_scene(_scene(tmp_path, "")).world.seabed.texture is None
    assert load_scene("paper-tank").world.seabed.texture is None  # existing scenes: off
    assert load_scene("open-seabed").world.seabed.texture is not None


@pytest.mark.parametrize(
    ("texture", "key", "words"),
    [
        ("texture_scale_m = 0.1", "seabed.texture_scale_m", "needs seabed.texture_db"),
        ("texture_seed = 3", "seabed.texture_seed", "needs seabed.texture_db"),
        ("texture_db = -2.0", "seabed.texture_db", ">= 0"),
        ("texture_db = 40.0", "seabed.texture_db", "(0, 20]"),
        ('texture_db = "loud"', "seabed.texture_db", "must be a number"),
        ("texture_db = 3.0\ntexture_scale_m = 0.0", "seabed.texture_scale_m", "> 0"),
        ("texture_db = 3.0\ntexture_scale_m = 100.0", "seabed.texture_scale_m", "[0.002, 10]"),
        ("texture_db = 3.0\ntexture_seed = -4", "seabed.texture_seed", ">= 0"),
        ("texture_db = 3.0\ntexture_seed = 1.5", "seabed.texture_seed", "integer"),
    ],
)
def test_bad_scene_texture_keys_give_clear_errors(tmp_path: Path, texture: str, key: str, words: str) -> None:
    with pytest.raises(SceneError) as info:
        load_scene(_scene(tmp_path, texture))
    assert info.value.key == key
    assert words in str(info.value)
    assert str(tmp_path / "t.toml") in str(info.value)


def test_texture_off_renders_exactly_as_without_it(tmp_path: Path) -> None:
    off = load_scene(_scene(tmp_path, "texture_db = 0.0")).world
    assert off.seabed == Seabed(5.0)
    pose = SonarPose(0.2, 0.1, 4.0, heading_rad=0.2, tilt_rad=math.radians(25.0))
    a = SonarRenderer(off).render_layers(pose, 1.0)
    b = SonarRenderer(World(Seabed(5.0))).render_layers(pose, 1.0)
    on = SonarRenderer(World(Seabed(5.0, texture=SeabedTexture(3.0, 0.1)))).render_layers(pose, 1.0)
    assert np.array_equal(a.power, b.power) and np.array_equal(a.image, b.image)
    assert not np.array_equal(on.image, b.image)
