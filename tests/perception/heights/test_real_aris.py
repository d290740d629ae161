"""The real ARIS recording shipped in the repository (``tests/data/aris/sample.aris``: an ARIS
1200 with its telephoto lens, 48 beams, 2000 samples over 3.3-23.4 m; no targets known, its
depth and altitude fields 0): the pipeline reads it, detects next to nothing (any detection
is a false target) and invents no height."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from perception.heights.detect import detect_shadows
from perception.heights.pipeline import HeightPipeline
from perception.sonar_io.readers import open_recording
from planner.cli import main

#: Most false detections per frame accepted on the recording (the benchmark reports the count).
MAX_FALSE_PER_FRAME = 0.5


@pytest.fixture(scope="module")
def frames(data_dir: Path):
    return list(open_recording(data_dir / "aris" / "sample.aris"))


def test_the_recording_is_read_with_its_own_geometry(frames) -> None:
    assert len(frames) == 6
    for frame in frames:
        assert frame.image.shape == (2000, 48) and frame.image.dtype == np.uint8
        assert frame.range_m[0] == pytest.approx(3.30, abs=0.01) and frame.range_m[-1] == pytest.approx(23.4, abs=0.05)
        assert math.isnan(frame.altitude_m) and math.isnan(frame.sonar_depth_m)  # its zeros are "unknown"


def test_next_to_nothing_is_detected_and_no_height_is_invented(frames) -> None:
    counts = [len(detect_shadows(f.image, range_m=f.range_m, beam_azimuth_rad=f.beam_azimuth_rad)) for f in frames]
    assert np.mean(counts) <= MAX_FALSE_PER_FRAME
    pipeline = HeightPipeline()
    for frame in frames:
        result = pipeline.add_frame(frame)
        assert all(not m.usable or math.isfinite(m.r_top_m) for m in result.measurements)
    assert all(t.height_m is None and t.reason for t in pipeline.targets())


def test_heights_refuses_the_recording_naming_it(data_dir: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = str(data_dir / "aris" / "sample.aris")
    assert main(["heights", path]) == 2
    err = capsys.readouterr().err
    assert path in err and "no altitude information" in err and "Traceback" not in err
