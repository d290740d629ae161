"""Mosaic speed: frames added per second, 128 beams x 1000 samples, 1 cm cells, one core.

Frames follow a lawnmower lane at 1 m altitude, 25 deg tilt, 0.7-3.0 m window, 10 pings
per metre of track: the projection, the tile blending and (in the second row) the drift
registration against the lagged reference mosaic, as the executor runs them on board.
"""

from __future__ import annotations

import math
import statistics
import time

import numpy as np

from perception.beams import aris3000_128
from perception.frame import SonarFrame
from perception.mosaic import MosaicConfig
from perception.mosaic_builder import MosaicBuilder
from perception.registration import RegistrationConfig

N_FRAMES = 300


def _frames(n: int, *, altitude_m: float, tilt_deg: float) -> list[SonarFrame]:
    rng = np.random.default_rng(1)
    azimuth = np.asarray(aris3000_128().azimuth_rad)
    ranges = np.linspace(0.7, 3.0, 1000)
    frames = []
    for k in range(n):
        image = rng.gamma(2.0, 40.0, size=(1000, 128)).clip(0, 255).astype(np.uint8)
        frames.append(
            SonarFrame(
                image=image, range_m=ranges, beam_azimuth_rad=azimuth, elevation_aperture_rad=math.radians(14),
                timestamp_s=0.1 * k, altitude_m=altitude_m, sonar_depth_m=10.0, tilt_rad=math.radians(tilt_deg),
                heading_rad=0.0, vehicle_pitch_rad=0.0, vehicle_roll_rad=0.0, north_m=0.05 * k, east_m=0.0,
            )
        )
    return frames


def _rate(frames: list[SonarFrame], registration: RegistrationConfig | None) -> tuple[float, float]:
    builder = MosaicBuilder(MosaicConfig(resolution_m=0.01), registration)
    times = []
    for frame in frames:
        t0 = time.perf_counter()
        builder.add_frame(frame)
        times.append(time.perf_counter() - t0)
    return len(frames) / sum(times), statistics.median(times) * 1e3


def main() -> str:
    rows = ["| geometry | registration | frames/s | median ms/frame |", "|---|---|---|---|"]
    for altitude_m, tilt_deg in ((0.5, 20.0), (1.0, 25.0), (2.0, 30.0)):
        frames = _frames(N_FRAMES, altitude_m=altitude_m, tilt_deg=tilt_deg)
        for reg in (None, RegistrationConfig()):
            fps, median_ms = _rate(frames, reg)
            rows.append(
                f"| {altitude_m} m alt, {tilt_deg:.0f} deg tilt | {'on' if reg else 'off'} | "
                f"{fps:.0f} | {median_ms:.2f} |"
            )
    text = "## Mosaic\n\n128 x 1000 frames, 1 cm cells, one core; requirement >= 100 frames/s.\n\n" + "\n".join(rows)
    print(text)
    return text


if __name__ == "__main__":
    main()
