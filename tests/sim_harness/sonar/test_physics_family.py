"""The renderer's physics as parameters: the default is the historical renderer bit for bit,
and each departure does what its physics says (speckle tails, beam patterns, outputs,
blanking, saturation); the family's members are valid and drawn repeatably."""

from __future__ import annotations

import hashlib
import math
from dataclasses import replace

import numpy as np
import pytest

from sim_harness.sonar.family import draw_member, presets
from sim_harness.sonar.physics import SonarPhysics, sinc_kernel
from sim_harness.sonar.receiver import power_to_image
from sim_harness.sonar.renderer import SonarConfig, SonarPose, SonarRenderer
from sim_harness.sonar.scene import load_scene
from sim_harness.sonar.viewpoint import choose_tilt_rad
from sim_harness.world.errors import SonarConfigError
from sim_harness.world.world import Seabed, TargetSpec, World

#: SHA-256 (first 16 hex digits) of the paper tank's frame image at 0.5 m (seed 11, 1000
#: samples), rendered by the renderer before its physics became parameters.
HISTORICAL_TANK_IMAGE = "142992e99d4f9770"


def _digest(array: np.ndarray) -> str:
    a = np.ascontiguousarray(array)
    m = hashlib.sha256()
    m.update(str(a.dtype).encode())
    m.update(str(a.shape).encode())
    m.update(a.tobytes())
    return m.hexdigest()[:16]


def test_the_default_physics_renders_the_historical_frame_bit_for_bit() -> None:
    tank = load_scene("paper-tank")
    window = {k: v for k, v in tank.sonar.items() if k in ("window_start_m", "window_length_m")}
    config = SonarConfig(seed=11, samples_per_beam=1000, **window)
    vp = tank.viewpoint
    tilt = choose_tilt_rad(tank.world, north_m=vp.north_m, east_m=vp.east_m, altitude_m=0.5, heading_rad=0.0,
                           pitch_rad=0.0, config=config)
    depth = tank.world.seabed_depth_m(vp.north_m, vp.east_m) - 0.5
    pose = SonarPose(vp.north_m, vp.east_m, depth, tilt_rad=tilt, pitch_rad=0.02, roll_rad=-0.01)
    frame, _ = SonarRenderer(tank.world, config).render(pose, 12.5)
    assert _digest(frame.image) == HISTORICAL_TANK_IMAGE


def _seabed_frame(physics: SonarPhysics, **changes) -> np.ndarray:
    """Linear power of a flat seabed seen at 1 m altitude (float32 output), 128 x 600."""
    world = World(seabed=Seabed(depth_m=3.0))
    config = SonarConfig(window_start_m=1.5, window_length_m=2.0, samples_per_beam=600, seed=5,
                         physics=replace(physics, output="float32_power"), **changes)
    frame, _ = SonarRenderer(world, config).render(SonarPose(0.0, 0.0, 2.0, tilt_rad=math.radians(25.0)), 3.0)
    return frame.image.astype(np.float64)


def _normalised_intensity(power: np.ndarray) -> np.ndarray:
    """Power over its running mean along range (the seabed's slow trend out), central rows."""
    rows = power[150:450]
    trend = np.convolve(rows.mean(axis=1), np.ones(21) / 21, mode="same")[:, None]
    return (rows / trend)[20:-20].ravel()


def test_k_distributed_speckle_has_heavier_tails_than_rayleigh() -> None:
    rayleigh = _normalised_intensity(_seabed_frame(SonarPhysics(), speckle_looks=1.0, noise_floor_db=None))
    k_dist = _normalised_intensity(_seabed_frame(SonarPhysics(speckle_texture_shape=1.0), speckle_looks=1.0,
                                                 noise_floor_db=None))
    # Intensity of one-look Rayleigh speckle: exponential, second moment 2 (mean 1); a gamma
    # texture of shape nu multiplies it by 1 + 1/nu: 4 for nu = 1.
    assert np.mean(rayleigh**2) / np.mean(rayleigh) ** 2 == pytest.approx(2.0, rel=0.15)
    assert np.mean(k_dist**2) / np.mean(k_dist) ** 2 == pytest.approx(4.0, rel=0.25)
    assert np.percentile(k_dist, 99.9) > 1.3 * np.percentile(rayleigh, 99.9)


def test_more_looks_narrow_the_speckle() -> None:
    one = _normalised_intensity(_seabed_frame(SonarPhysics(), speckle_looks=1.0, noise_floor_db=None))
    eight = _normalised_intensity(_seabed_frame(SonarPhysics(), speckle_looks=8.0, noise_floor_db=None))
    assert np.std(one) == pytest.approx(1.0, rel=0.15)
    assert np.std(eight) == pytest.approx(1.0 / math.sqrt(8.0), rel=0.2)


def test_sinc_beam_pattern_has_its_side_lobes() -> None:
    physics = SonarPhysics(azimuth_pattern="sinc", azimuth_width_beams=1.0, azimuth_kernel_beams=8,
                           azimuth_sidelobe_db=-20.0)
    kernel = sinc_kernel(physics).astype(np.float64)
    centre = kernel.size // 2
    assert kernel[centre] == 1.0 and kernel.max() == 1.0
    np.testing.assert_allclose(kernel, kernel[::-1])
    # Half power half a beam off; beyond the first null, side lobes no higher than asked
    # (sampled at whole beams, near their peak).
    x = np.abs(np.arange(kernel.size) - centre)
    lobes_db = 10 * np.log10(kernel[x >= 2])
    assert -30.0 < lobes_db.max() <= -20.0 + 1e-6
    assert kernel[centre + 1] < 0.5
    with pytest.raises(SonarConfigError, match="azimuth_pattern"):
        SonarPhysics(azimuth_pattern="square")


def test_outputs_are_the_same_echo_in_other_forms() -> None:
    rng = np.random.default_rng(0)
    power = (10.0 ** (rng.uniform(1.0, 7.0, (50, 8)))).astype(np.float32)  # 10-70 dB
    uint8 = power_to_image(power, SonarPhysics())
    assert uint8.dtype == np.uint8
    np.testing.assert_array_equal(uint8, np.clip(np.rint(10 * np.log10(power) * 255 / 80), 0, 255).astype(np.uint8))
    p32 = power_to_image(power, SonarPhysics(output="float32_power", full_scale_db=None))
    a32 = power_to_image(power, SonarPhysics(output="float32_amplitude", full_scale_db=None))
    assert p32.dtype == np.float32 and a32.dtype == np.float32
    np.testing.assert_allclose(a32.astype(np.float64) ** 2 / p32, (a32[0, 0] ** 2 / p32[0, 0]), rtol=1e-4)
    u16 = power_to_image(power, SonarPhysics(output="uint16_power", full_scale_db=None))
    assert u16.dtype == np.uint16 and u16.max() > 1000
    # Saturation: nothing above the saturation level.
    saturated = power_to_image(power, SonarPhysics(output="float32_power", full_scale_db=None, saturation_db=50.0))
    ratio = saturated.astype(np.float64) / p32
    assert np.all(ratio <= 1.0 + 1e-5) and np.any(ratio < 0.5)


def test_near_range_blanking_zeroes_the_first_rows() -> None:
    world = World(seabed=Seabed(depth_m=3.0), targets=(TargetSpec("b", "box", 2.0, 0.0, 0.2, 0.2, 0.1),))
    config = SonarConfig(window_start_m=1.0, window_length_m=2.0, samples_per_beam=400, seed=1,
                         physics=SonarPhysics(blank_range_m=1.5))
    frame, _ = SonarRenderer(world, config).render(SonarPose(0.0, 0.0, 2.0, tilt_rad=math.radians(25.0)), 1.0)
    blanked = frame.range_m < 1.5
    assert np.all(frame.image[blanked] == 0) and frame.image[~blanked].max() > 0


def test_presets_and_drawn_members_are_valid_and_repeatable() -> None:
    members = presets()
    assert members[0].name == "historical renderer" and members[0].physics == SonarPhysics()
    assert len({m.name for m in members}) == len(members)
    base = SonarConfig(window_start_m=1.0, window_length_m=2.0, samples_per_beam=400)
    for member in members:
        assert isinstance(member.config(base), SonarConfig)  # validated
    a = [draw_member(np.random.default_rng(7)) for _ in range(2)]
    assert a[0] == a[1]
    drawn = [draw_member(np.random.default_rng(s)) for s in range(40)]
    assert len({m.name for m in drawn}) > 30  # the family, not a handful of members
    for member in drawn:
        assert isinstance(member.config(base), SonarConfig)
