"""The sonar renderer: shadows from occlusion, exact seabed coverage, speckle statistics."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats

from sim_harness.sonar.receiver import power_to_uint8
from sim_harness.sonar.renderer import SonarConfig, SonarPose, SonarRenderer
from sim_harness.sonar.scene import load_scene
from sim_harness.sonar.seabed import arccos01_f32
from sim_harness.sonar.truth import Label
from sim_harness.sonar.viewpoint import scene_pose
from sim_harness.world.errors import PoseError, SonarConfigError
from sim_harness.world.relief import Relief
from sim_harness.world.world import Seabed, TargetSpec, World

QUIET = {"speckle_looks": 0.0, "noise_floor_db": None}


def _cell(config: SonarConfig, range_m: float) -> int:
    return math.floor((range_m - config.window_start_m) / config.range_resolution_m)


def _check_shadow_labels(renderer: SonarRenderer, pose: SonarPose) -> int:
    """Every fully visible shadow's label run matches its analytic ranges to one sample."""
    cfg = renderer.config
    _, truth = renderer.render(pose, 0.0)
    # beam -> [(near, far, target index)]: where each target hides or echoes in that beam
    spans: dict[int, list[tuple[float, float, int]]] = {}
    for t in truth.targets:
        for j, near, far in zip(t.beams, np.minimum(t.highlight_start_m, t.hidden_seabed_start_m),
                                t.shadow_end_m, strict=True):
            spans.setdefault(int(j), []).append((near, far, t.index))
    checked = 0
    for t in truth.targets:
        if t.shape == "rock":
            continue  # lobes shadow each other: the dark run may begin before the top edge
        for j, top, foot, end, band, window in zip(
            t.beams, t.shadow_start_m, t.hidden_seabed_start_m, t.shadow_end_m, t.in_band, t.in_window,
            strict=True,
        ):
            start = max(top, foot)  # layover: seabed shows between a side's top and its foot
            if not (band and window) or end - start < 3 * cfg.range_resolution_m:
                continue
            lo, hi = min(top, foot, start) - 0.02, end + 0.02
            if any(i != t.index and a < hi and b > lo for a, b, i in spans[int(j)]):
                continue  # another target echoes or hides seabed here: not a clean shadow
            col = (truth.labels[:, j] == Label.SHADOW) & (truth.owner[:, j] == t.index)
            rows = np.nonzero(col)[0]
            assert rows.size, f"target {t.target_id} beam {j}: no shadow labelled"
            assert abs(rows[0] - _cell(cfg, start)) <= 1, (t.target_id, j, rows[0], _cell(cfg, start))
            assert abs(rows[-1] - _cell(cfg, end)) <= 1, (t.target_id, j, rows[-1], _cell(cfg, end))
            # the run is unbroken
            assert rows[-1] - rows[0] + 1 == rows.size
            checked += 1
    return checked


@pytest.mark.parametrize("altitude_m", [0.5, 0.6])
def test_paper_tank_shadow_labels_match_geometry_to_one_sample(altitude_m: float) -> None:
    scene = load_scene("paper-tank")
    config = SonarConfig(**scene.sonar)
    renderer = SonarRenderer(scene.world, config)
    pose = scene_pose(scene, altitude_m, config)
    _, truth = renderer.render(pose, 0.0)
    assert {t.target_id for t in truth.targets} == {"1", "2", "3", "4", "5"}
    assert all(t.whole_shadow_in_band and t.whole_shadow_in_window for t in truth.targets)
    assert _check_shadow_labels(renderer, pose) > 50


def test_shadow_labels_on_a_slope_with_attitude() -> None:
    seabed = Seabed(20.0, slope_rad=math.radians(4.0), slope_direction_rad=math.radians(60.0))
    targets = (
        TargetSpec("box", "box", 3.0, 1.2, 0.4, 0.3, 0.15, yaw_rad=0.4),
        TargetSpec("cyl", "cylinder", 3.6, 2.4, 0.25, 0.25, 0.2, material="metal"),
    )
    world = World(seabed, targets)
    config = SonarConfig(window_start_m=1.0, window_length_m=4.0, **QUIET)
    renderer = SonarRenderer(world, config)
    depth = world.seabed_depth_m(0.0, 0.0) - 1.3
    pose = SonarPose(0.0, 0.0, depth, heading_rad=math.radians(35.0), pitch_rad=math.radians(4.0),
                     roll_rad=math.radians(-3.0), tilt_rad=math.radians(24.0))
    assert _check_shadow_labels(renderer, pose) > 10


@settings(max_examples=25, deadline=None)
@given(
    heading=st.floats(-math.pi, math.pi),
    pitch=st.floats(-0.15, 0.15),
    roll=st.floats(-0.15, 0.15),
    altitude=st.floats(0.4, 2.0),
    height=st.floats(0.02, 0.3),
    yaw=st.floats(0.0, math.pi),
)
def test_shadow_truth_obeys_similar_triangles(
    heading: float, pitch: float, roll: float, altitude: float, height: float, yaw: float
) -> None:
    """Flat seabed: the central beam's shadow gives h = H (r_s - r_top) / r_s exactly."""
    ground = 3.0 * altitude
    n, e = ground * math.cos(heading), ground * math.sin(heading)
    world = World(Seabed(30.0), (TargetSpec("b", "box", n, e, 0.3, 0.2, height, yaw_rad=yaw),))
    renderer = SonarRenderer(world, SonarConfig(window_start_m=0.3, window_length_m=12.0, **QUIET))
    tilt = math.atan2(altitude, ground) + pitch
    pose = SonarPose(0.0, 0.0, 30.0 - altitude, heading, pitch, roll, tilt)
    _, truth = renderer.render(pose, 1.0)
    (t,) = truth.targets
    r_top, r_s = t.central_shadow_start_m, t.central_shadow_end_m
    assert altitude * (r_s - r_top) / r_s == pytest.approx(height, rel=1e-6)
    assert abs(t.azimuth_rad) < math.radians(16.0)


def test_seabed_coverage_is_exact_with_no_holes_or_stripes() -> None:
    world = World(Seabed(10.0))
    config = SonarConfig(pulse_length_s=0.0, sidelobe_db=(), **QUIET)
    renderer = SonarRenderer(world, config)
    pose = SonarPose(0.0, 0.0, 9.0, tilt_rad=math.radians(30.0))
    layers = renderer.render_layers(pose, 0.0)
    span = layers.seabed_span_rad
    half = config.elevation_aperture_rad / 2
    r0, r1 = config.window_start_m, config.window_end_m
    for j in (0, 40, 64, 127):
        a = config.beam_azimuth_rad[j]
        # beam plane: depression of elevation e is asin(cos(e) sin(tilt) cos(a)... ) -> solve numerically
        e = np.linspace(-half, half, 200001)
        down = np.cos(e) * math.cos(a) * math.sin(math.radians(30.0)) + np.sin(e) * math.cos(math.radians(30.0))
        with np.errstate(divide="ignore"):
            r = np.where(down > 0, 1.0 / np.where(down > 0, down, 1.0), np.inf)
        expected = np.count_nonzero((r >= r0) & (r <= r1)) * (e[1] - e[0])
        assert span[:, j].sum() == pytest.approx(expected, rel=2e-4)
        rows = np.nonzero(span[:, j] > 0)[0]
        assert rows.size > 100
        assert rows[-1] - rows[0] + 1 == rows.size  # no holes
        p = layers.clean_power[rows[2]:rows[-2], j].astype(np.float64)
        assert np.all(p > 0)
        assert np.max(np.abs(np.diff(np.log10(p)))) < 0.02  # no striping: smooth in range


def test_seabed_with_relief_is_continuous() -> None:
    scene = load_scene("open-seabed")
    config = SonarConfig(**scene.sonar, **QUIET)
    renderer = SonarRenderer(scene.world, config)
    pose = scene_pose(scene, 1.5, config, north_m=20.0, east_m=3.0)  # no targets ahead
    layers = renderer.render_layers(pose, 0.0)
    for j in range(0, 128, 9):
        rows = np.nonzero(layers.seabed_span_rad[:, j] > 0)[0]
        assert rows.size > 100 and rows[-1] - rows[0] + 1 == rows.size
        assert np.all(layers.clean_power[rows[3]:rows[-3], j] > 0)


@pytest.mark.parametrize("looks", [1.0, 3.0])
def test_seabed_speckle_is_gamma_with_the_chosen_looks(looks: float) -> None:
    world = World(Seabed(10.0))
    pose = SonarPose(0.0, 0.0, 9.0, tilt_rad=math.radians(30.0))
    noisy = SonarRenderer(world, SonarConfig(speckle_looks=looks, noise_floor_db=None, seed=5))
    layers = noisy.render_layers(pose, 2.5)
    mask = layers.labels == Label.SEABED
    ratio = (layers.power[mask] / layers.clean_power[mask]).astype(np.float64)
    assert ratio.size > 40000
    assert ratio.mean() == pytest.approx(1.0, abs=0.02)
    assert ratio.std() / ratio.mean() == pytest.approx(1.0 / math.sqrt(looks), rel=0.03)
    sample = ratio[:: max(1, ratio.size // 5000)]
    assert stats.kstest(sample, stats.gamma(looks, scale=1.0 / looks).cdf).pvalue > 1e-3


def test_noise_floor_is_exponential_with_its_mean() -> None:
    world = World(Seabed(10.0))
    renderer = SonarRenderer(world, SonarConfig(speckle_looks=0.0, noise_floor_db=10.0))
    layers = renderer.render_layers(SonarPose(0.0, 0.0, 9.0, tilt_rad=math.radians(30.0)), 0.0)
    far = (layers.labels == Label.OUTSIDE_BEAM) & (layers.clean_power == 0)
    noise = layers.power[far].astype(np.float64)
    assert noise.size > 20000
    assert noise.mean() == pytest.approx(10.0, rel=0.03)
    assert noise.std() == pytest.approx(10.0, rel=0.05)


def test_echo_levels_highlight_shadow_and_dark_outside_the_beam() -> None:
    scene = load_scene("paper-tank")
    config = SonarConfig(**scene.sonar, **QUIET)
    layers = SonarRenderer(scene.world, config).render_layers(scene_pose(scene, 0.5, config), 0.0)
    p, lab = layers.clean_power, layers.labels
    seabed = np.median(p[lab == Label.SEABED])
    assert np.median(p[lab == Label.HIGHLIGHT]) > 2.0 * seabed
    assert np.median(p[lab == Label.SHADOW]) < 0.05 * seabed
    # outside the vertical beam, away from the band's blurred edges, there is no echo
    has_seabed = np.nonzero(np.any(lab != Label.OUTSIDE_BEAM, axis=1))[0]
    assert np.all(p[: has_seabed[0] - 10] == 0)
    assert np.all(p[has_seabed[-1] + 10:] == 0)


def test_the_nearest_hit_wins() -> None:
    front = TargetSpec("wall", "box", 2.0, 0.0, 0.1, 0.6, 0.4)
    behind = TargetSpec("small", "box", 2.3, 0.0, 0.1, 0.1, 0.05)
    world = World(Seabed(10.0), (front, behind))
    renderer = SonarRenderer(world, SonarConfig(window_start_m=0.5, window_length_m=4.0, **QUIET))
    _, truth = renderer.render(SonarPose(0.0, 0.0, 9.0, tilt_rad=math.radians(25.0)), 0.0)
    small = truth.target("small")
    assert np.all(truth.owner[truth.labels == Label.HIGHLIGHT] != small.index)
    wall = truth.target("wall")
    assert np.any(truth.owner[truth.labels == Label.HIGHLIGHT] == wall.index)


def test_frames_are_deterministic_per_seed_and_timestamp() -> None:
    scene = load_scene("paper-tank")
    config = SonarConfig(**scene.sonar, seed=3)
    pose = scene_pose(scene, 0.5, config)
    a = SonarRenderer(scene.world, config)
    b = SonarRenderer(scene.world, config)
    f1, _ = a.render(pose, 1.0)
    a.render(pose, 2.0)
    f2, _ = b.render(pose, 1.0)
    np.testing.assert_array_equal(f1.image, f2.image)
    f3, _ = b.render(pose, 1.1)
    assert np.mean(f1.image != f3.image) > 0.3
    other = SonarRenderer(scene.world, SonarConfig(**scene.sonar, seed=4))
    f4, _ = other.render(pose, 1.0)
    assert np.mean(f1.image != f4.image) > 0.3


def test_frame_carries_only_what_a_vehicle_knows() -> None:
    world = World(Seabed(10.0))
    pose = SonarPose(1.0, 2.0, 9.2, heading_rad=0.3, pitch_rad=0.05, roll_rad=-0.02, tilt_rad=0.4)
    frame, truth = SonarRenderer(world).render(pose, 5.0)
    assert frame.image.shape == (1000, 128) and frame.image.dtype == np.uint8
    assert frame.range_m[0] == pytest.approx(0.7 + 2.3 / 2000)
    assert frame.elevation_aperture_rad == pytest.approx(math.radians(14.0))
    assert (frame.north_m, frame.east_m, frame.sonar_depth_m) == (1.0, 2.0, 9.2)
    assert (frame.heading_rad, frame.vehicle_pitch_rad, frame.vehicle_roll_rad, frame.tilt_rad) == (
        0.3, 0.05, -0.02, 0.4)
    assert frame.altitude_m == pytest.approx(0.8) and truth.altitude_m == pytest.approx(0.8)
    assert frame.extra == {}
    blind = SonarRenderer(world, SonarConfig(fill_altitude=False)).render(pose, 5.0)[0]
    assert math.isnan(blind.altitude_m)
    told = SonarRenderer(world).render(pose, 5.0, altitude_m=0.83)[0]
    assert told.altitude_m == 0.83


@pytest.mark.parametrize(
    ("pose", "field"),
    [
        (SonarPose(0.0, 0.0, 10.5, tilt_rad=0.3), "depth_m"),
        (SonarPose(0.0, 0.0, -1.0, tilt_rad=0.3), "depth_m"),
        (SonarPose(0.0, math.nan, 5.0, tilt_rad=0.3), "east_m"),
        (SonarPose(0.0, 0.0, 5.0, pitch_rad=2.0), "pitch_rad"),
    ],
)
def test_bad_poses_raise_clear_errors(pose: SonarPose, field: str) -> None:
    renderer = SonarRenderer(World(Seabed(10.0)))
    with pytest.raises(PoseError) as info:
        renderer.render(pose, 0.0)
    assert info.value.field == field
    assert f"pose.{field}" in str(info.value)


@pytest.mark.parametrize(
    ("changes", "key"),
    [
        ({"window_length_m": 0.0}, "window_length_m"),
        ({"samples_per_beam": 1}, "samples_per_beam"),
        ({"beam_azimuth_rad": (0.1, 0.0)}, "beam_azimuth_rad"),
        ({"speckle_looks": -1.0}, "speckle_looks"),
        ({"sidelobe_db": (3.0,)}, "sidelobe_db"),
        ({"elevation_aperture_rad": 0.0}, "elevation_aperture_rad"),
    ],
)
def test_bad_sonar_settings_name_the_setting(changes: dict, key: str) -> None:
    with pytest.raises(SonarConfigError) as info:
        SonarConfig(**changes)
    assert info.value.key == key


def test_power_maps_0_to_80_db_onto_0_to_255() -> None:
    power = np.array([[0.5, 1.0, 10.0**4, 10.0**8, 10.0**9]], dtype=np.float32)
    np.testing.assert_array_equal(power_to_uint8(power), [[0, 0, 128, 255, 255]])
    db = np.array([[10.0, 20.0, 33.0]])
    np.testing.assert_array_equal(power_to_uint8((10 ** (db / 10)).astype(np.float32)), np.round(db * 255 / 80))


def test_any_forward_looking_sonar_by_parameters() -> None:
    world = World(Seabed(5.0, relief=Relief(0.02, 3.0)), (TargetSpec("s", "stone", 3.0, 0.0, 0.3, 0.3, 0.1),))
    az = tuple(np.radians(np.linspace(-60.0, 60.0, 256)))
    config = SonarConfig(beam_azimuth_rad=az, elevation_aperture_rad=math.radians(20.0),
                         window_start_m=0.5, window_length_m=9.5, samples_per_beam=600)
    frame, truth = SonarRenderer(world, config).render(SonarPose(0.0, 0.0, 3.5, tilt_rad=math.radians(25.0)), 0.0)
    assert frame.image.shape == (600, 256)
    assert [t.target_id for t in truth.targets] == ["s"]
    assert truth.targets[0].whole_shadow_in_band


_OPEN = load_scene("open-seabed")
_OPEN_RENDERER = SonarRenderer(_OPEN.world, SonarConfig(**_OPEN.sonar))


@settings(max_examples=30, deadline=None)
@given(
    north=st.floats(0.0, 30.0),
    east=st.floats(0.0, 30.0),
    altitude=st.floats(0.2, 8.0),
    heading=st.floats(-math.pi, math.pi),
    pitch=st.floats(-0.5, 0.5),
    roll=st.floats(-0.5, 0.5),
    tilt=st.floats(-math.pi / 2, math.pi / 2),
)
def test_any_valid_pose_renders_consistently(
    north: float, east: float, altitude: float, heading: float, pitch: float, roll: float, tilt: float
) -> None:
    depth = _OPEN.world.seabed_depth_m(north, east) - altitude
    frame, truth = _OPEN_RENDERER.render(SonarPose(north, east, depth, heading, pitch, roll, tilt), 3.0)
    assert frame.image.shape == truth.labels.shape == (1000, 128)
    assert set(np.unique(truth.labels)) <= {int(label) for label in Label} - {Label.BEYOND_WINDOW}
    # owners only on target pixels, and every target pixel has an owner
    target_px = (truth.labels == Label.HIGHLIGHT) | (truth.labels == Label.SHADOW)
    assert np.all((truth.owner > 0) == target_px)
    assert truth.owner.max() <= len(truth.targets)
    for t in truth.targets:
        assert np.all(t.shadow_end_m >= t.shadow_start_m - 1e-9)
        assert np.all(t.highlight_start_m <= t.shadow_start_m + 1e-9)


def _random_scene(rng: np.random.Generator, relief: Relief | None) -> tuple[SonarRenderer, SonarPose]:
    seabed = Seabed(20.0, slope_rad=math.radians(rng.uniform(0, 6)), slope_direction_rad=rng.uniform(0, 6.28),
                    relief=relief)
    shapes = ("box", "cylinder", "stone")
    targets = tuple(
        TargetSpec(f"t{i}", shapes[i % 3], rng.uniform(2.0, 4.5), rng.uniform(-1.2, 1.2), rng.uniform(0.1, 0.5),
                   rng.uniform(0.1, 0.4), rng.uniform(0.03, 0.4), yaw_rad=rng.uniform(0, 3))
        for i in range(4)
    )
    world = World(seabed, targets)
    renderer = SonarRenderer(world, SonarConfig(window_start_m=1.0, window_length_m=5.0, **QUIET))
    altitude = rng.uniform(0.8, 2.0)
    pose = SonarPose(0.0, 0.0, world.seabed_depth_m(0.0, 0.0) - altitude, heading_rad=rng.uniform(-0.3, 0.3),
                     pitch_rad=rng.uniform(-0.1, 0.1), roll_rad=rng.uniform(-0.1, 0.1),
                     tilt_rad=math.atan2(altitude, 3.2) + rng.uniform(-0.05, 0.05))
    return renderer, pose


@pytest.mark.parametrize("with_relief", [False, True])
def test_random_scenes_shadow_labels_match_geometry(with_relief: bool) -> None:
    """Slopes, relief, attitude, mixed shapes: every clean shadow to one range sample."""
    rng = np.random.default_rng(2)
    checked = 0
    for _ in range(12):
        relief = Relief(0.03, 6.0, seed=int(rng.integers(100))) if with_relief else None
        checked += _check_shadow_labels(*_random_scene(rng, relief))
    assert checked > 200


def test_each_cell_is_owned_by_the_nearest_target_hiding_it() -> None:
    front = TargetSpec("front", "box", 2.0, 0.0, 0.1, 0.4, 0.1)
    back = TargetSpec("back", "box", 2.25, 0.0, 0.1, 0.2, 0.3)  # taller: its shadow reaches farther
    world = World(Seabed(10.0), (front, back))
    renderer = SonarRenderer(world, SonarConfig(window_start_m=0.5, window_length_m=4.0, **QUIET))
    _, truth = renderer.render(SonarPose(0.0, 0.0, 9.0, tilt_rad=math.radians(22.0)), 0.0)
    f, b = truth.target("front"), truth.target("back")
    j = b.central_beam
    cfg = renderer.config
    assert truth.labels[_cell(cfg, b.central_shadow_end_m) - 3, j] == Label.SHADOW
    assert truth.owner[_cell(cfg, b.central_shadow_end_m) - 3, j] == b.index
    k = int(np.nonzero(f.beams == j)[0][0])
    assert truth.labels[_cell(cfg, f.shadow_start_m[k]) + 2, j] == Label.SHADOW
    assert truth.owner[_cell(cfg, f.shadow_start_m[k]) + 2, j] == f.index


@settings(max_examples=200, deadline=None)
@given(st.lists(st.floats(0.0, 1.0, width=32), min_size=1, max_size=64))
def test_fast_arccos_matches_numpy_on_unit_interval(values: list[float]) -> None:
    x = np.array(values, dtype=np.float32)
    got = arccos01_f32(x)
    assert got.dtype == np.float32 and got.shape == x.shape
    np.testing.assert_allclose(got, np.arccos(x.astype(np.float64)), rtol=0.0, atol=3e-7)
    assert np.array_equal(x, np.array(values, dtype=np.float32))  # the input is left alone


def test_fast_arccos_known_values() -> None:
    x = np.array([0.0, 0.5, math.sqrt(0.5), 1.0, 1.5], dtype=np.float32)
    want = [math.pi / 2, math.pi / 3, math.pi / 4, 0.0, 0.0]
    np.testing.assert_allclose(arccos01_f32(x), want, rtol=0.0, atol=3e-7)
