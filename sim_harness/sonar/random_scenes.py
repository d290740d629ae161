"""Random two-altitude scenes for tests and benchmarks, rendered through a family member.

A scene is a flat seabed with one to three targets ahead of a sonar that climbs vertically
between its frames (the paper's survey step), with what may change from frame to frame
as it does on a real sonar: the tilt (re-aimed per altitude so the shadows stay in the
vertical beam), the range window (start, length, sample count; an operator or the ARIS
auto-window moves it when the altitude changes), the receiver gain and the output form
(uint8, uint16, float32). The targets:

- shapes: boxes and vertical cylinders by default, stones (half-ellipsoids: rounded tops)
  and rocks (irregular lobes) on request;
- heights 2-30 cm, at most 0.35 x the lower altitude (a taller target's shadow cannot fit
  the 14 deg aperture); lengths 5-40 cm; widths 0.4-1 x the length and at least 3 cm;
- yaw 0-90 deg to the beams; each target keeps to its own sector of the fan (with 0.5 deg
  between), as two targets side by side at one range would cast one merged shadow;
- materials of the world's table, or (``low_contrast_prob``) a material only 1-4 dB
  brighter than the seabed.

Geometry: altitude 0.4-2.0 m, then 0.05-0.3 m higher; targets at ground distances whose
depression below the sonar is 15-40 deg (one scene's within +-4 deg of each other, so that
one tilt holds their shadows), at azimuths within +-11 deg. The truth and
frames come from :class:`~sim_harness.sonar.renderer.SonarRenderer`; frames can report an
attitude other than the true one (``attitude_error_deg``: the true pitch and roll are drawn
within that many degrees and the frames report zero).

Pure functions of the ``rng`` they are given; one renderer per frame configuration.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from perception.sonar_io.frame import SonarFrame
from sim_harness.sonar.family import FamilyMember
from sim_harness.sonar.physics import OUTPUTS
from sim_harness.sonar.renderer import SonarConfig, SonarPose, SonarRenderer
from sim_harness.sonar.truth import FrameTruth
from sim_harness.sonar.viewpoint import choose_tilt_rad
from sim_harness.world.materials import MATERIALS, Material
from sim_harness.world.world import Seabed, TargetSpec, World

#: Output forms a frame may take when the scene varies them.
FRAME_OUTPUTS = ("uint8", "uint16_amplitude", "float32_power")
#: Materials a target may be made of (low-contrast ones are added per scene).
TARGET_MATERIALS = ("concrete", "rock", "brick", "wood", "plastic", "rubber", "metal", "glass", "gravel")
#: Redraws of a target that would overlap another's sector of the fan.
MAX_TRIES = 50
#: Narrowest target, m (a narrower one is under two beams wide at a few metres: its shadow
#: is filled by the neighbouring beams' seabed and never goes dark).
MIN_WIDTH_M = 0.03
#: Gap kept between targets' sectors of the fan, rad.
SECTOR_MARGIN_RAD = math.radians(0.5)
#: The paper's Table I targets (length, width, height), m, and their place in ``paper-tank``.
PAPER_TARGETS = (
    ((0.19, 0.19, 0.028), (1.35, 0.0), "concrete"),
    ((0.10, 0.05, 0.039), (1.15, -0.22), "brick"),
    ((0.05, 0.04, 0.047), (1.20, 0.20), "rock"),
    ((0.09, 0.04, 0.030), (1.55, -0.17), "rock"),
    ((0.06, 0.05, 0.028), (1.55, 0.16), "concrete"),
)
#: The paper's altitudes, m.
PAPER_ALTITUDES_M = (0.5, 0.6)
#: Water depth of the paper's tank, m.
PAPER_WATER_DEPTH_M = 0.85


@dataclass(frozen=True)
class FrameSpec:
    """One frame of a scene: where the sonar is, its window and what it reports.

    Attributes
    ----------
    pose : SonarPose
        The true pose.
    window_start_m, window_length_m : float
    samples : int
    gain_offset_db : float
        Receiver gain relative to the family member's.
    output : str or None
        The frame's output form; None: the member's.
    reported_pitch_rad, reported_roll_rad : float
        The attitude the frame reports (NaN: the true one).
    """

    pose: SonarPose
    window_start_m: float
    window_length_m: float
    samples: int
    gain_offset_db: float = 0.0
    output: str | None = None
    reported_pitch_rad: float = math.nan
    reported_roll_rad: float = math.nan


@dataclass(frozen=True)
class RandomScene:
    """A world and the frames taken of it (in order: lower altitude first)."""

    world: World
    frames: tuple[FrameSpec, ...]
    label: str = ""


def _materials(
    rng: np.random.Generator, n: int, low_contrast_prob: float, seabed: str
) -> tuple[list[str], dict[str, Material]]:
    names, extra = [], {}
    sea_db = MATERIALS[seabed].backscatter_db
    for k in range(n):
        if rng.random() < low_contrast_prob:
            name = f"low_contrast_{k}"
            extra[name] = Material(name, sea_db + float(rng.uniform(1.0, 4.0)), float(rng.uniform(0.7, 1.0)))
            names.append(name)
        else:
            names.append(str(rng.choice(TARGET_MATERIALS)))
    return names, extra


def _window(rng: np.random.Generator, altitude_m: float, depression_rad: float, aperture_rad: float,
            far_m: float, vary: bool, samples: int | None) -> tuple[float, float, int]:
    """A range window holding the band from the steep beam edge to past ``far_m``."""
    near = altitude_m / math.sin(min(depression_rad + aperture_rad / 2, math.radians(80.0)))
    start = near * (float(rng.uniform(0.6, 0.95)) if vary else 0.8)
    end = max(far_m * (float(rng.uniform(1.08, 1.35)) if vary else 1.2), start + 0.5)
    n = samples if samples is not None else (int(rng.integers(1000, 2001)) if vary else 1500)
    return start, end - start, n


def draw_scene(
    rng: np.random.Generator,
    *,
    shapes: Sequence[str] = ("box", "cylinder"),
    n_targets: tuple[int, int] = (1, 3),
    low_contrast_prob: float = 0.15,
    vary_window: bool = True,
    vary_gain: bool = True,
    vary_output: bool = True,
    attitude_error_deg: float = 0.0,
    samples: int | None = None,
    label: str = "",
) -> RandomScene:
    """A random scene (module docstring); ``samples`` fixes the sample count of every frame."""
    altitude = float(rng.uniform(0.4, 2.0))
    altitudes = (altitude, altitude + float(rng.uniform(0.05, 0.3)))
    seabed_material = str(rng.choice(["sand", "sand", "mud", "gravel"]))
    n = int(rng.integers(n_targets[0], n_targets[1] + 1))
    slots = rng.permutation(np.linspace(-9.0, 9.0, 4))[:n]
    names, extra = _materials(rng, n, low_contrast_prob, seabed_material)
    k_spec = 0
    depth = altitudes[1] + 1.0
    depression_deg = float(rng.uniform(19.0, 36.0))
    specs: list[TargetSpec] = []
    sectors: list[tuple[float, float]] = []
    for k, az_deg in enumerate(slots):
        for _ in range(MAX_TRIES):
            height = float(rng.uniform(0.02, min(0.30, 0.35 * altitude)))
            ground = altitude / math.tan(math.radians(depression_deg + float(rng.uniform(-4.0, 4.0))))
            length = float(rng.uniform(0.05, 0.40))
            length = min(length, 0.1 * ground + 0.05)
            width = max(length * float(rng.uniform(0.4, 1.0)), MIN_WIDTH_M)
            az = math.radians(float(az_deg) + float(rng.uniform(-2.0, 2.0)))
            # Targets keep to their own sectors of the fan (their shadows would merge).
            half = 0.5 * math.hypot(length, width) / ground + SECTOR_MARGIN_RAD
            if all(az + half < lo or az - half > hi for lo, hi in sectors):
                break
        else:
            continue  # no room left in the fan: fewer targets
        sectors.append((az - half, az + half))
        shape = str(rng.choice(list(shapes)))
        specs.append(TargetSpec(f"T{k_spec}", shape, ground * math.cos(az), ground * math.sin(az), length, width,
                                height, yaw_rad=math.radians(float(rng.uniform(0.0, 90.0))), material=names[k],
                                seed=int(rng.integers(0, 1000))))
        k_spec += 1
    world = World(seabed=Seabed(depth_m=depth, material=seabed_material), targets=tuple(specs),
                  materials={**MATERIALS, **extra})
    frames = []
    base = SonarConfig()
    for alt in altitudes:
        pitch = roll = 0.0
        if attitude_error_deg > 0:
            pitch = math.radians(float(rng.uniform(-attitude_error_deg, attitude_error_deg)))
            roll = math.radians(float(rng.uniform(-attitude_error_deg, attitude_error_deg)))
        wide = replace(base, window_start_m=0.1, window_length_m=30.0)
        tilt = choose_tilt_rad(world, north_m=0.0, east_m=0.0, altitude_m=alt, heading_rad=0.0, pitch_rad=pitch,
                               config=wide)
        far = max(math.hypot(math.hypot(s.north_m, s.east_m) + s.length_m, alt) * alt / max(alt - s.height_m, 1e-3)
                  for s in specs)
        start, length, n_samples = _window(rng, alt, tilt - pitch, base.elevation_aperture_rad, far, vary_window,
                                           samples)
        frames.append(FrameSpec(
            pose=SonarPose(0.0, 0.0, depth - alt, 0.0, pitch, roll, tilt),
            window_start_m=start, window_length_m=length, samples=n_samples,
            gain_offset_db=float(rng.uniform(-6.0, 6.0)) if vary_gain else 0.0,
            output=str(rng.choice(FRAME_OUTPUTS)) if vary_output else None,
            reported_pitch_rad=0.0 if attitude_error_deg > 0 else math.nan,
            reported_roll_rad=0.0 if attitude_error_deg > 0 else math.nan,
        ))
    return RandomScene(world, tuple(frames), label)


def paper_scene(index: int, orientation_deg: float, *, samples: int = 1000, window: tuple[float, float] = (0.7, 2.3),
                label: str = "") -> RandomScene:
    """One of the paper's Table I targets (``index`` 0-4) alone, yawed ``orientation_deg`` to
    the beams, at its ``paper-tank`` place, seen from 0.5 then 0.6 m with the tilt re-aimed."""
    (length, width, height), (north, east), material = PAPER_TARGETS[index]
    spec = TargetSpec(str(index + 1), "box", north, east, length, width, height,
                      yaw_rad=math.radians(orientation_deg), material=material)
    world = World(seabed=Seabed(depth_m=PAPER_WATER_DEPTH_M), targets=(spec,))
    base = SonarConfig(window_start_m=window[0], window_length_m=window[1], samples_per_beam=samples)
    frames = []
    for alt in PAPER_ALTITUDES_M:
        tilt = choose_tilt_rad(world, north_m=0.0, east_m=0.0, altitude_m=alt, heading_rad=0.0, pitch_rad=0.0,
                               config=base)
        frames.append(FrameSpec(SonarPose(0.0, 0.0, PAPER_WATER_DEPTH_M - alt, tilt_rad=tilt), window[0], window[1],
                                samples))
    return RandomScene(world, tuple(frames), label or f"T{index + 1} at {orientation_deg:g} deg")


def frame_config(member: FamilyMember, spec: FrameSpec, *, seed: int) -> SonarConfig:
    """The :class:`SonarConfig` of one frame: the member's physics in the frame's window.

    A member whose TVG restores less than the historical 30 log R plus absorption has its
    gain raised by what the historical TVG gives at the middle of the window, as an operator
    sets the gain for the window (else the far seabed of a long window sinks under the
    noise, which no method can see through); the TVG's shape over the window stays the member's.
    """
    base = SonarConfig(window_start_m=spec.window_start_m, window_length_m=spec.window_length_m,
                       samples_per_beam=spec.samples, seed=seed)
    config = member.config(base)
    changes: dict[str, object] = {}
    r_mid = spec.window_start_m + 0.5 * spec.window_length_m
    historical = 30.0 * math.log10(r_mid) + 2.0 * base.absorption_db_per_m * r_mid
    own = config.tvg_db_per_decade * math.log10(r_mid) + (2.0 * config.absorption_db_per_m * r_mid
                                                          if config.tvg_absorption else 0.0)
    compensation = max(historical - own, 0.0)
    if spec.gain_offset_db or compensation:
        changes["gain_db"] = config.gain_db + spec.gain_offset_db + compensation
    if spec.output is not None and spec.output != config.physics.output:
        if spec.output not in OUTPUTS:
            raise ValueError(f"unknown output {spec.output!r}")
        changes["physics"] = replace(config.physics, output=spec.output, full_scale_db=None)
    return replace(config, **changes) if changes else config


def render_scene(scene: RandomScene, member: FamilyMember, *, seed: int, t0_s: float = 100.0,
                 altitude_known: bool = True) -> list[tuple[SonarFrame, FrameTruth]]:
    """Render every frame of ``scene`` through ``member``; the frames report what
    :class:`FrameSpec` says (and no altitude when not ``altitude_known``: only the depth)."""
    out = []
    for k, spec in enumerate(scene.frames):
        renderer = SonarRenderer(scene.world, frame_config(member, spec, seed=seed + k))
        frame, truth = renderer.render(spec.pose, t0_s + 0.1 * k)
        changes: dict[str, float] = {}
        if math.isfinite(spec.reported_pitch_rad):
            changes["vehicle_pitch_rad"] = spec.reported_pitch_rad
        if math.isfinite(spec.reported_roll_rad):
            changes["vehicle_roll_rad"] = spec.reported_roll_rad
        if not altitude_known:
            changes["altitude_m"] = math.nan
        out.append((frame.with_fields(**changes) if changes else frame, truth))
    return out
