"""Sonar renderer speed: frames per second, 128 beams x 1000 samples, one core.

``python -m benchmarks.bench_renderer [--frames N]`` prints a Markdown section. Every frame
is rendered at full quality (analytic seabed, occlusion-refined targets, pulse blur, side
lobes, speckle, noise, uint8 mapping) plus its ground truth; the pose moves a little
between frames so nothing can be cached. OpenCV is held to one thread (as in the render
process of a dry run, :mod:`sim_harness.render_worker`). A fixed reference workload of
float32 array arithmetic is timed before and after the scenes, so that a slow (shared)
host shows.
"""

from __future__ import annotations

import argparse
import math
import platform
import time
from collections.abc import Sequence
from dataclasses import replace

import cv2
import numpy as np

from sim_harness.sonar.renderer import SonarConfig, SonarPose, SonarRenderer
from sim_harness.sonar.scene import Scene, load_scene
from sim_harness.sonar.viewpoint import scene_pose
from sim_harness.world.texture import SeabedTexture
from sim_harness.world.world import Seabed, World


def _measure(renderer: SonarRenderer, pose: SonarPose, frames: int) -> tuple[float, float, int]:
    """(wall fps, CPU fps, targets seen in the first frame), best of three runs."""
    _, truth = renderer.render(pose, 0.0)
    best_wall, best_cpu = math.inf, math.inf
    for _ in range(3):
        wall0, cpu0 = time.perf_counter(), time.process_time()
        for i in range(frames):
            moved = replace(pose, north_m=pose.north_m + 0.001 * i, heading_rad=pose.heading_rad + 1e-4 * i)
            renderer.render(moved, 0.1 * i)
        best_wall = min(best_wall, time.perf_counter() - wall0)
        best_cpu = min(best_cpu, time.process_time() - cpu0)
    return frames / best_wall, frames / best_cpu, len(truth.targets)


def reference_workload_cpu_s() -> float:
    """CPU time of a fixed workload of float32 array arithmetic like a frame's (best of 3), s."""
    a = np.linspace(0.0, 1.0, 128_000, dtype=np.float32)
    best = math.inf
    for _ in range(3):
        cpu0 = time.process_time()
        for _ in range(200):
            b = a * np.float32(0.5)
            b += a
            np.sqrt(b, out=b)
            np.exp(b, out=b)
        best = min(best, time.process_time() - cpu0)
    return best


def _with_texture(world: World, texture: SeabedTexture | None) -> World:
    """The same world with another seabed texture (None: none)."""
    return World(replace(world.seabed, texture=texture), world.targets, world.materials, world.name,
                 world.origin_lat_deg, world.origin_lon_deg)


def _cases() -> list[tuple[str, SonarRenderer, SonarPose]]:
    """Each scene with the seabed texture off and on (3 dB, 10 cm; `open-seabed` ships with it on)."""
    texture = SeabedTexture(std_db=3.0, correlation_m=0.1, seed=0)
    flat = World(Seabed(10.0))
    flat_pose = SonarPose(0.0, 0.0, 9.5, tilt_rad=math.radians(20.0))
    cases = [("flat seabed, no targets", SonarRenderer(flat), flat_pose),
             ("flat seabed, no targets, texture on", SonarRenderer(_with_texture(flat, texture)), flat_pose)]
    for name in ("paper-tank", "open-seabed"):
        scene: Scene = load_scene(name)
        config = SonarConfig(**scene.sonar)
        altitude = scene.viewpoint.altitude_m
        pose = scene_pose(scene, altitude, config)
        shipped = scene.world.seabed.texture
        for label, tex in (("texture off", None), ("texture on", shipped or texture)):
            suffix = f"{label}{' (as shipped)' if tex is shipped else ''}"
            cases.append((f"`{name}` at {altitude} m, {suffix}",
                          SonarRenderer(_with_texture(scene.world, tex), config), pose))
    return cases


def main(argv: Sequence[str] | None = None) -> None:
    """Print the renderer's Markdown section."""
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--frames", type=int, default=60)
    args = parser.parse_args(argv)
    cv2.setNumThreads(1)
    print("## renderer\n")
    print(f"128 beams x 1000 samples per frame, frame + truth, best of 3 x {args.frames} frames; "
          f"Python {platform.python_version()}, {platform.machine()}, OpenCV threads 1.\n")
    before = reference_workload_cpu_s()
    print("| scene | targets in view | frames/s (wall) | frames/s (CPU time) |")
    print("| --- | --- | --- | --- |")
    for label, renderer, pose in _cases():
        wall, cpu, n = _measure(renderer, pose, args.frames)
        print(f"| {label} | {n} | {wall:.0f} | {cpu:.0f} |")
    after = reference_workload_cpu_s()
    print(f"\nReference workload (float32 arithmetic, CPU): {before * 1e3:.0f} ms before, {after * 1e3:.0f} ms after.")
    print("\nRequirement >= 100 frames/s, goal >= 300. Repeat: `python -m benchmarks.bench_renderer`.")


if __name__ == "__main__":
    main()
