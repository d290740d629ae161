"""ARIS (.aris) read throughput: open, sequential and random frame reads, write.

Writes a synthetic ARIS Explorer 3000 recording (128 beams x 2000 samples, the product's
sonar) into a temporary folder with :func:`perception.sonar_io.aris.reader.write_aris`, then reads it with
:class:`perception.sonar_io.aris.reader.ArisRecording`. A sparse multi-GiB file shows that opening does not
depend on the file size. Run: ``python -m benchmarks.bench_aris_read [--frames N]``.
"""

from __future__ import annotations

import argparse
import math
import platform
import tempfile
import time
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path

import numpy as np

from perception.sonar_io.aris.reader import ArisRecording, aris_grid, write_aris
from perception.sonar_io.beams import aris3000_128
from perception.sonar_io.frame import SonarFrame

N_BEAMS = 128
N_SAMPLES = 2000
SPARSE_SIZE_BYTES = 8 * 2**30


def synthetic_frames(n_frames: int, seed: int = 7) -> Iterator[SonarFrame]:
    """ARIS 3000 frames, 1 to 11 m window at 1480 m/s, random uint8 images (seeded)."""
    rng = np.random.default_rng(seed)
    _, _, ranges = aris_grid(1.0, 11.0, N_SAMPLES, 1480.0)
    azimuth = aris3000_128().azimuth_rad
    for i in range(n_frames):
        yield SonarFrame(
            image=rng.integers(0, 256, size=(N_SAMPLES, N_BEAMS), dtype=np.uint8),
            range_m=ranges,
            beam_azimuth_rad=azimuth,
            elevation_aperture_rad=math.radians(14.0),
            timestamp_s=1.7e9 + i / 15.0,
            sound_speed_m_s=1480.0,
            altitude_m=3.0,
            tilt_rad=math.radians(30.0),
        )


def _timed(fn: Callable[[], object], repeat: int = 3) -> float:
    best = math.inf
    for _ in range(repeat):
        start = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - start)
    return best


def _sparse_recording(path: Path, template: Path) -> int:
    """An 8 GiB recording with real frames only at both ends (the rest is a hole)."""
    data = template.read_bytes()
    frame_size = 1024 + N_BEAMS * N_SAMPLES
    n_frames = (SPARSE_SIZE_BYTES - 1024) // frame_size
    last = bytearray(data[1024 : 1024 + frame_size])
    last[0:4] = (n_frames - 1).to_bytes(4, "little")
    with open(path, "wb") as handle:
        handle.write(data[: 1024 + frame_size])
        handle.seek(1024 + (n_frames - 1) * frame_size)
        handle.write(bytes(last))
    return n_frames


def run(n_frames: int) -> str:
    """Measure and return the Markdown section."""
    frame_bytes = 1024 + N_BEAMS * N_SAMPLES
    rows: list[tuple[str, str]] = []
    with tempfile.TemporaryDirectory(prefix="bench_aris_") as tmp:
        path = Path(tmp) / "bench.aris"
        start = time.perf_counter()
        write_aris(path, synthetic_frames(n_frames))
        write_s = time.perf_counter() - start
        size_mb = path.stat().st_size / 1e6
        rows.append(
            ("write_aris (incl. frame synthesis)", f"{n_frames / write_s:.0f} frames/s, {size_mb / write_s:.0f} MB/s")
        )

        open_s = _timed(lambda: ArisRecording(path).close(), repeat=5)
        rows.append(("open (file + frame 0 headers, mmap)", f"{open_s * 1e3:.2f} ms"))

        with ArisRecording(path) as rec:
            assert len(rec) == n_frames

            def read_all() -> None:
                for frame in rec:
                    frame.image.sum(dtype=np.uint64)  # touch every sample

            seq_s = _timed(read_all, repeat=2)
            rows.append(
                (
                    "sequential frame reads (warm page cache)",
                    f"{n_frames / seq_s:.0f} frames/s, {n_frames * frame_bytes / 1e6 / seq_s:.0f} MB/s",
                )
            )
            order = np.random.default_rng(3).integers(0, n_frames, size=min(n_frames, 300))

            def read_random() -> None:
                for i in order:
                    _ = rec[int(i)]

            rnd_s = _timed(read_random, repeat=2)
            rows.append(
                (
                    "random frame reads (warm page cache)",
                    f"{order.size / rnd_s:.0f} frames/s, {rnd_s / order.size * 1e3:.2f} ms/frame",
                )
            )
            head_s = _timed(lambda: [rec.header(int(i)) for i in order], repeat=2)
            rows.append(("frame header only", f"{head_s / order.size * 1e6:.0f} us/header"))

        sparse = Path(tmp) / "sparse.aris"
        n_sparse = _sparse_recording(sparse, path)

        def open_and_read_last() -> None:
            with ArisRecording(sparse) as big:
                assert len(big) == n_sparse
                big[-1].image.sum()

        big_s = _timed(open_and_read_last, repeat=3)
        rows.append(
            (
                f"open {SPARSE_SIZE_BYTES / 2**30:.0f} GiB sparse file + read its last frame",
                f"{big_s * 1e3:.2f} ms ({n_sparse} frames)",
            )
        )

    lines = [
        "## aris_read",
        "",
        f"Synthetic ARIS 3000 recording: {n_frames} frames of {N_BEAMS} beams x {N_SAMPLES} "
        f"samples ({size_mb:.0f} MB), temporary folder; best of 2-5 runs. "
        f"Machine: {platform.machine()}, {platform.system()}, Python {platform.python_version()}.",
        "",
        "| measure | figure |",
        "| --- | --- |",
        *[f"| {name} | {figure} |" for name, figure in rows],
    ]
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> None:
    """Print the Markdown section of figures."""
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--frames", type=int, default=400, help="frames in the synthetic file")
    args = parser.parse_args(argv)
    print(run(args.frames))


if __name__ == "__main__":
    main()
