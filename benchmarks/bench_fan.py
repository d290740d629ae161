"""Fan conversion speed: a 128 x 2000 ARIS 3000 polar frame to its top-down fan image.

Frame: ARIS 3000 128-beam table (non-uniform azimuths, ~30 deg), 2000 samples over a
1-11 m window (5 mm). The remap maps are built once per geometry and cached; the figures
are per-frame times with warm maps (median and 90th percentile over many calls), plus the
one-off map build. Goal: <= 1 ms median for the conversion.
"""

from __future__ import annotations

import functools
import math
import os
import statistics
import time
from collections.abc import Callable

import cv2
import numpy as np

from perception.mapping.fan import frame_to_fan, polar_to_fan
from perception.mapping.fan_geometry import fan_geometry
from perception.sonar_io.beams import aris3000_128
from perception.sonar_io.frame import SonarFrame

N_SAMPLES = 2000
WINDOW_M = (1.0, 11.0)
REPEATS = 300
GOAL_MS = 1.0


def _times_ms(call: Callable[[], object], repeats: int = REPEATS) -> tuple[float, float, float]:
    for _ in range(10):  # warm-up (maps, caches)
        call()
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        call()
        times.append(time.perf_counter() - t0)
    times.sort()
    return statistics.median(times) * 1e3, times[int(0.9 * len(times))] * 1e3, times[0] * 1e3


def run() -> str:
    """Measure and return the Markdown section."""
    azimuth = np.asarray(aris3000_128().azimuth_rad)
    ranges = np.linspace(*WINDOW_M, N_SAMPLES)
    rng = np.random.default_rng(1)
    image_u8 = rng.gamma(2.0, 40.0, size=(N_SAMPLES, azimuth.size)).clip(0, 255).astype(np.uint8)
    image_f32 = image_u8.astype(np.float32)
    threads = cv2.getNumThreads()

    rows = [
        "| fan width px | fan shape | dtype | interpolation | median ms | p90 ms | best ms |",
        "| ---: | --- | --- | --- | ---: | ---: | ---: |",
    ]
    cases: list[tuple[int, np.ndarray, str]] = [
        (384, image_u8, "linear"),
        (512, image_u8, "linear"),
        (512, image_u8, "nearest"),
        (512, image_f32, "linear"),
        (768, image_u8, "linear"),
        (1024, image_u8, "linear"),
        (1024, image_u8, "nearest"),
    ]
    median_512 = math.nan
    for width, image, interpolation in cases:
        geometry = fan_geometry(ranges, azimuth, width_px=width)
        median, p90, best = _times_ms(functools.partial(polar_to_fan, image, geometry, interpolation=interpolation))
        if width == 512 and image is image_u8 and interpolation == "linear":
            median_512 = median
        rows.append(
            f"| {width} | {geometry.n_rows} x {geometry.n_cols} | {image.dtype} | "
            f"{interpolation} | {median:.3f} | {p90:.3f} | {best:.3f} |"
        )

    # End to end from a SonarFrame: geometry key from the frame's arrays + cached maps.
    frame = SonarFrame(image_u8, ranges, azimuth, math.radians(14.0), 0.0)
    e2e = _times_ms(lambda: frame_to_fan(frame, width_px=512))

    # One thread (OpenCV otherwise splits remap over the cores).
    geometry_512 = fan_geometry(ranges, azimuth, width_px=512)
    cv2.setNumThreads(1)
    try:
        one = _times_ms(lambda: polar_to_fan(image_u8, geometry_512))
    finally:
        cv2.setNumThreads(threads)

    # Cold map build: a geometry not seen before (window shifted by 1 um each time).
    builds = []
    for k in range(5):
        shifted = ranges + 1e-6 * (k + 1)
        geometry = fan_geometry(shifted, azimuth, width_px=512)
        t0 = time.perf_counter()
        polar_to_fan(image_u8, geometry)
        builds.append(time.perf_counter() - t0)

    rows.append(
        "| 512 | frame_to_fan from a SonarFrame (geometry key + cached maps) | uint8 | linear | "
        + " | ".join(f"{t:.3f}" for t in e2e)
        + " |"
    )
    rows.append("| 512 | one OpenCV thread | uint8 | linear | " + " | ".join(f"{t:.3f}" for t in one) + " |")
    verdict = "met" if median_512 <= GOAL_MS else "NOT met"
    return "\n".join(
        [
            "## Fan conversion",
            "",
            f"`polar_to_fan` of a 128 x {N_SAMPLES} ARIS 3000 frame ({WINDOW_M[0]:g}-"
            f"{WINDOW_M[1]:g} m window), warm maps, {REPEATS} calls per row, OpenCV "
            f"{cv2.__version__} with {threads} threads (cv2.remap, CV_16SC2 fixed-point maps).",
            f"Goal <= {GOAL_MS:g} ms median at 512 px width: {verdict} ({median_512:.3f} ms).",
            "",
            *rows,
            "",
            f"Map build for a new geometry (512 px, first frame): "
            f"{statistics.median(builds) * 1e3:.0f} ms median of 5. "
            f"Load average while measuring: {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores.",
        ]
    )


def main() -> None:
    """Print the Markdown section of figures."""
    print(run())


if __name__ == "__main__":
    main()
