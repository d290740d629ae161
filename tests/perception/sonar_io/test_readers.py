"""open_recording: dispatch by suffix, sequence behaviour and describe()."""

from __future__ import annotations

import json
import math
import shutil

import numpy as np
import pytest

from perception.errors import FrameFormatError
from perception.sonar_io.aris.reader import ArisRecording, aris_grid, write_aris
from perception.sonar_io.beams import load_beam_table
from perception.sonar_io.frame import SonarFrame
from perception.sonar_io.npz import save_frames
from perception.sonar_io.readers import DESCRIBE_MAX_FRAMES, Recording, open_recording


@pytest.fixture
def sample(data_dir):
    return data_dir / "aris" / "sample.aris"


def frames_128(rng, n, *, altitude=math.nan, dt_s=0.1):
    _, _, ranges = aris_grid(1.0, 9.0, 20, 1490.0)
    return [
        SonarFrame(
            image=rng.integers(0, 256, size=(20, 128), dtype=np.uint8),
            range_m=ranges,
            beam_azimuth_rad=load_beam_table("ARIS3000_128").azimuth_rad,
            elevation_aperture_rad=math.radians(14.0),
            timestamp_s=1000.0 + dt_s * i,
            sound_speed_m_s=1490.0,
            altitude_m=altitude,
        )
        for i in range(n)
    ]


def test_sample_describe_known_answers(sample):
    with open_recording(sample) as rec:
        assert isinstance(rec, Recording) and rec.format == "aris" and len(rec) == 6
        info = rec.describe()
    assert info.sonar.startswith("ARIS 1200, telephoto lens")
    assert (info.n_frames, info.n_beams, info.n_samples, info.image_dtype) == (6, 48, 2000, "uint8")
    assert info.acquisition_window_m == pytest.approx((3.2976, 23.4007), abs=5e-5)
    assert info.time_span_s == pytest.approx((1371198079.122519, 1371198079.886496), abs=1e-6)
    assert info.frame_rate_hz == pytest.approx(5 / 0.763977, rel=1e-6)
    assert set(info.pose_fields) == {"tilt_rad", "heading_rad", "sound_speed_m_s"}
    assert info.truncation is None and info.problems == ()
    as_json = json.loads(json.dumps(info.to_dict()))
    assert as_json["n_beams"] == 48 and as_json["truncation"] is None


def test_uppercase_suffix_and_sequence_protocol(sample, tmp_path):
    copy = tmp_path / "SAMPLE.ARIS"
    shutil.copy(sample, copy)
    with open_recording(copy) as rec:
        assert rec[-1].timestamp_s == rec[5].timestamp_s
        assert [f.timestamp_s for f in rec[::2]] == [rec[i].timestamp_s for i in (0, 2, 4)]
        assert len(list(rec)) == 6
        for bad in (6, -7):
            with pytest.raises(IndexError):
                rec[bad]


def test_npz_recording_matches_aris(sample, tmp_path):
    with ArisRecording(sample) as rec:
        frames = rec[0:3]
    path = save_frames(tmp_path / "s.npz", frames)
    with open_recording(path) as rec:
        assert rec.format == "npz" and len(rec) == 3
        np.testing.assert_array_equal(rec[2].image, frames[2].image)
        info = rec.describe()
    assert info.sonar == "unknown" and info.acquisition_window_m is None
    assert info.range_window_m == pytest.approx(frames[0].window_m)
    assert info.frame_rate_hz == pytest.approx(2 / (frames[2].timestamp_s - frames[0].timestamp_s))


def test_elevation_override(sample, tmp_path):
    with open_recording(sample, elevation_aperture_rad=math.radians(3.0)) as rec:
        assert rec[0].elevation_aperture_rad == pytest.approx(math.radians(3.0))
    path = save_frames(tmp_path / "e.npz", frames_128(np.random.default_rng(1), 2))
    with open_recording(path, elevation_aperture_rad=0.1) as rec:
        assert all(f.elevation_aperture_rad == 0.1 for f in rec)


def test_unknown_suffix_and_missing(tmp_path):
    other = tmp_path / "frames.bin"
    other.write_bytes(b"x")
    with pytest.raises(FrameFormatError, match="unknown recording type"):
        open_recording(other)
    with pytest.raises(FileNotFoundError):
        open_recording(tmp_path / "absent.aris")
    with pytest.raises(FileNotFoundError):
        open_recording(tmp_path / "absent.npz")


def test_describe_samples_long_recordings_and_reports_damage(tmp_path, rng):
    n = DESCRIBE_MAX_FRAMES * 2 + 3
    frames = frames_128(rng, n)
    frames[-1] = frames[-1].with_fields(altitude_m=4.0)
    path = write_aris(tmp_path / "long.aris", frames)
    frame_size = 1024 + 128 * 20
    data = bytearray(path.read_bytes())
    bad = round((n - 2) / (DESCRIBE_MAX_FRAMES - 1))  # the second frame describe() looks at
    data[1024 + bad * frame_size : 1024 + bad * frame_size + 4] = (999).to_bytes(4, "little")
    path.write_bytes(bytes(data[:-10]))
    with open_recording(path) as rec:
        assert len(rec) == n - 1
        info = rec.describe()
    assert info.frames_examined <= DESCRIBE_MAX_FRAMES
    assert info.frame_rate_hz == pytest.approx(10.0)
    assert info.truncation is not None and f"frame {n - 1}" in info.truncation
    assert any(f"frame {bad}," in p and "FrameIndex" in p for p in info.problems)
    assert "altitude_m" not in info.pose_fields  # the only frame that had it is cut off


def test_describe_pose_fields_present(tmp_path, rng):
    path = write_aris(tmp_path / "alt.aris", frames_128(rng, 3, altitude=2.0))
    with open_recording(path) as rec:
        info = rec.describe()
    assert set(info.pose_fields) == {"altitude_m", "sound_speed_m_s"}


def test_describe_empty_aris(tmp_path, rng):
    path = write_aris(tmp_path / "one.aris", frames_128(rng, 1))
    path.write_bytes(path.read_bytes()[:1024])
    with open_recording(path) as rec:
        info = rec.describe()
    assert info.n_frames == 0 and info.n_beams is None and math.isnan(info.frame_rate_hz)
    assert info.time_span_s is None and math.isnan(info.duration_s)
