"""Known answers on the SDK's real recording tests/data/aris/sample.aris (tests/data/README.md)."""

from __future__ import annotations

import math
import struct

import numpy as np
import pytest

from perception.sonar_io.aris.reader import ArisRecording, window_edges_m
from perception.sonar_io.beams import load_beam_table


@pytest.fixture(scope="module")
def sample_path(data_dir):
    return data_dir / "aris" / "sample.aris"


@pytest.fixture
def recording(sample_path):
    with ArisRecording(sample_path) as rec:
        yield rec


def test_layout_and_headers(sample_path, recording):
    assert sample_path.stat().st_size == 583_168
    assert recording.file_header["Version"] == 0x05464444
    assert len(recording) == 6 and recording.truncation is None
    assert (recording.layout.n_beams, recording.layout.n_samples) == (48, 2000)
    h = recording.header(0)
    assert (h["PingMode"], h["SamplesPerBeam"], h["SamplePeriod"], h["SampleStartDelay"]) == (1, 2000, 14, 4593)
    assert h["SoundSpeed"] == pytest.approx(1435.933, abs=5e-4)
    assert (h["TheSystemType"], h["LargeLens"], h["ReorderedSamples"]) == (2, 1, 1)
    assert [recording.header(i)["FrameIndex"] for i in range(6)] == list(range(6))
    assert recording.header(0)["FrameTime"] == 1371198079122519
    assert recording.header(5)["FrameTime"] == 1371198079886496


def test_window_from_formulas_not_header_floats(recording):
    start, end = window_edges_m(recording.header(0))
    assert start == pytest.approx(3.2976, abs=5e-5)
    assert end == pytest.approx(23.4007, abs=5e-5)
    assert recording.header(0)["WindowStart"] == pytest.approx(3.33, abs=1e-2)  # 1450 m/s
    frame = recording[0]
    sample_length = 14e-6 * recording.header(0)["SoundSpeed"] / 2
    assert frame.range_m[0] == pytest.approx(start + sample_length / 2, abs=1e-9)
    assert frame.range_m[-1] == pytest.approx(end - sample_length / 2, abs=1e-9)
    np.testing.assert_allclose(np.diff(frame.range_m), sample_length, rtol=1e-9)


def test_frame0_samples_and_beam_order(sample_path, recording):
    frame = recording[0]
    assert frame.image.shape == (2000, 48) and frame.image.dtype == np.uint8
    assert frame.image.mean() == pytest.approx(90.99, abs=5e-3)
    assert frame.image.max() == 190
    raw = np.fromfile(sample_path, dtype=np.uint8, count=96_000, offset=2048).reshape(2000, 48)
    np.testing.assert_array_equal(frame.image, raw[:, ::-1])  # SDK beam 0 is right-most
    table = load_beam_table("ARIS_Telephoto_48")
    np.testing.assert_array_equal(frame.beam_azimuth_rad, table.azimuth_rad)
    assert np.all(np.diff(frame.beam_azimuth_rad) > 0)
    assert frame.timestamp_s == pytest.approx(1371198079.122519, abs=1e-6)


def test_echo_falls_with_range_rows_are_nearest_first(recording):
    profile = recording[0].image.astype(float).mean(axis=1)
    assert profile[:200].mean() > profile[-200:].mean() + 40


def test_pose_mapping(sample_path, recording):
    data = sample_path.read_bytes()
    depth, altitude = struct.unpack_from("<2f", data, 1024 + 128)
    assert (depth, altitude) == (0.0, 0.0)
    frame = recording[0]
    assert math.isnan(frame.sonar_depth_m) and math.isnan(frame.altitude_m)
    assert math.isnan(frame.vehicle_pitch_rad) and math.isnan(frame.vehicle_roll_rad)
    (compass,) = struct.unpack_from("<f", data, 1024 + 160)
    assert frame.heading_rad == pytest.approx(math.radians(compass))
    (sonar_tilt,) = struct.unpack_from("<f", data, 1024 + 248)
    assert frame.tilt_rad == pytest.approx(-math.radians(sonar_tilt))
    assert frame.sound_speed_m_s == pytest.approx(1435.933, abs=5e-4)
    assert frame.extra["system_type"] == 2 and frame.extra["large_lens"] == 1
    assert frame.extra["sample_period_s"] == pytest.approx(14e-6)


def test_frames_differ_and_slice(recording):
    frames = recording[1:4]
    assert [f.extra["aris_frame_index"] for f in frames] == [1, 2, 3]
    assert not np.array_equal(frames[0].image, frames[1].image)
    assert recording[-1].timestamp_s == pytest.approx(1371198079.886496, abs=1e-6)
    with pytest.raises(IndexError):
        recording[6]
