"""The .aris reader on files written byte for byte from the SDK's documented layout."""

from __future__ import annotations

import math

import numpy as np
import pytest

from perception.errors import FrameFormatError
from perception.sonar_io.aris.reader import ArisRecording, beams_from_ping_mode
from perception.sonar_io.beams import load_beam_table
from tests.perception.sonar_io.aris_bytes import (
    expected_ranges_m,
    file_header,
    frame_header,
    raw_samples,
    write_recording,
)

N_SAMPLES = 40


def aris3000(tmp_path, rng, n_frames=3, headers=None, n_beams=128, name="rec.aris"):
    raws = [raw_samples(rng, n_beams, N_SAMPLES) for _ in range(n_frames)]
    return write_recording(tmp_path / name, raws, headers), raws


@pytest.mark.parametrize(("modes", "beams"), [((1, 2), 48), ((3, 4, 5), 96), ((6, 7, 8), 64), ((9, 10, 11, 12), 128)])
def test_beams_from_ping_mode(modes, beams):
    assert all(beams_from_ping_mode(m) == beams for m in modes)


@pytest.mark.parametrize("mode", [0, 13, 255])
def test_bad_ping_mode(mode):
    with pytest.raises(ValueError, match="PingMode"):
        beams_from_ping_mode(mode)


def test_128_beam_aris3000(tmp_path, rng):
    headers = [
        {"SampleStartDelay": 1333, "SamplePeriod": 8, "SoundSpeed": 1487.25},
        {"SampleStartDelay": 2000, "SamplePeriod": 12, "SoundSpeed": 1501.5},
    ]
    path, raws = aris3000(tmp_path, rng, 2, headers)
    table = load_beam_table("ARIS3000_128")
    with ArisRecording(path) as rec:
        assert len(rec) == 2 and rec.layout.n_beams == 128
        for i, frame in enumerate(rec):
            np.testing.assert_array_equal(frame.image, raws[i][:, ::-1])
            np.testing.assert_array_equal(frame.beam_azimuth_rad, table.azimuth_rad)
            h = headers[i]
            np.testing.assert_allclose(
                frame.range_m,
                expected_ranges_m(h["SampleStartDelay"], h["SamplePeriod"], N_SAMPLES, h["SoundSpeed"]),
                rtol=1e-12,
            )
            assert frame.timestamp_s == pytest.approx(1_700_000_000 + 0.1 * i, abs=1e-6)
            assert frame.extra["ping_mode"] == 9 and frame.extra["system_type"] == 1
        # the starboard-most column is SDK beam 0, whose table centre is the most negative
        assert rec[0].beam_azimuth_rad[-1] == pytest.approx(math.radians(15.0068))


@pytest.mark.parametrize(
    ("n_beams", "system_type", "large_lens", "table"),
    [
        (64, 1, 0, "ARIS3000_64"),
        (96, 0, 0, "ARIS1800_96"),
        (48, 2, 0, "ARIS1800_1200_48"),
        (48, 0, 1, "ARIS_Telephoto_48"),
        (96, 0, 1, "ARIS_Telephoto_96"),
    ],
)
def test_beam_table_by_system_and_lens(tmp_path, rng, n_beams, system_type, large_lens, table):
    header = {"TheSystemType": system_type, "LargeLens": large_lens}
    path, raws = aris3000(tmp_path, rng, 1, [header], n_beams=n_beams)
    with ArisRecording(path) as rec:
        frame = rec[0]
    np.testing.assert_array_equal(frame.beam_azimuth_rad, load_beam_table(table).azimuth_rad)
    np.testing.assert_array_equal(frame.image, raws[0][:, ::-1])


def test_pose_fields(tmp_path, rng):
    header = {
        "Depth": 12.5,
        "Altitude": 3.25,
        "Pitch": 2.0,
        "Roll": -1.5,
        "Heading": 270.0,
        "SonarTilt": -30.0,
        "CompassHeading": 10.0,
    }
    path, _ = aris3000(tmp_path, rng, 1, [header])
    with ArisRecording(path) as rec:
        frame = rec[0]
    assert frame.sonar_depth_m == 12.5 and frame.altitude_m == 3.25
    assert frame.vehicle_pitch_rad == pytest.approx(math.radians(2.0))
    assert frame.vehicle_roll_rad == pytest.approx(math.radians(-1.5))
    assert frame.heading_rad == pytest.approx(math.radians(270.0))  # platform beats compass
    assert frame.tilt_rad == pytest.approx(math.radians(30.0))  # 30 deg down
    assert frame.extra["compass_heading_rad"] == pytest.approx(math.radians(10.0))


def test_unknown_pose_groups(tmp_path, rng):
    headers = [
        {},  # every pose field 0.0: no integration, no compass, no rotator
        {"CompassHeading": -20.0, "SonarTilt": math.nan, "SonarPan": 1.0},
    ]
    path, _ = aris3000(tmp_path, rng, 2, headers)
    with ArisRecording(path) as rec:
        bare, compass = rec[0], rec[1]
    for name in (
        "sonar_depth_m",
        "altitude_m",
        "vehicle_pitch_rad",
        "vehicle_roll_rad",
        "heading_rad",
        "tilt_rad",
        "north_m",
        "east_m",
    ):
        assert math.isnan(getattr(bare, name)), name
    assert compass.heading_rad == pytest.approx(math.radians(340.0))
    assert math.isnan(compass.tilt_rad)
    assert math.isnan(compass.sonar_depth_m)


def test_lazy_big_sparse_file_opens_and_reads_last_frame(tmp_path, rng):
    """A 5 GiB recording (sparse) opens without reading frames; 64-bit offsets work."""
    n_beams, n_samples = 128, 2000
    frame_size = 1024 + n_beams * n_samples
    n_frames = (5 * 2**30) // frame_size
    path = tmp_path / "big.aris"
    last_raw = raw_samples(rng, n_beams, n_samples)
    with open(path, "wb") as handle:
        handle.write(file_header(n_beams, n_samples, n_frames))
        handle.write(frame_header(0, n_beams, n_samples))
        handle.seek(1024 + (n_frames - 1) * frame_size)
        handle.write(frame_header(n_frames - 1, n_beams, n_samples, SampleStartDelay=3000))
        handle.write(last_raw.tobytes())
    assert path.stat().st_size > 2**32
    with ArisRecording(path) as rec:
        assert len(rec) == n_frames and rec.truncation is None
        last = rec[-1]
        np.testing.assert_array_equal(last.image, last_raw[:, ::-1])
        assert last.range_m[0] == pytest.approx((3000 + 5) * 1e-6 * 750.0)
        with pytest.raises(FrameFormatError) as info:  # a never-written (zero) frame
            rec[n_frames // 2]
        assert info.value.frame_index == n_frames // 2 and info.value.key == "Version"


@pytest.mark.parametrize(
    ("override", "key"),
    [
        ({"Version": 0x12345678}, "Version"),
        ({"FrameIndex": 7}, "FrameIndex"),
        ({"PingMode": 6}, "PingMode"),
        ({"PingMode": 99}, "PingMode"),
        ({"SamplesPerBeam": N_SAMPLES + 1}, "SamplesPerBeam"),
        ({"SoundSpeed": math.nan}, "SoundSpeed"),
        ({"SoundSpeed": 0.0}, "SoundSpeed"),
        ({"SoundSpeed": 1e30}, "SoundSpeed"),
        ({"SamplePeriod": 0}, "SamplePeriod"),
        ({"ReorderedSamples": 0}, "ReorderedSamples"),
        ({"TheSystemType": 9}, "TheSystemType"),
    ],
)
def test_corrupt_middle_frame_names_frame_and_field(tmp_path, rng, override, key):
    headers = [{}, dict(override), {}]
    path, raws = aris3000(tmp_path, rng, 3, headers)
    with ArisRecording(path) as rec:
        assert len(rec) == 3
        with pytest.raises(FrameFormatError) as info:
            rec[1]
        err = info.value
        assert (err.frame_index, err.key, err.path) == (1, key, str(path))
        assert "frame 1" in str(err) and key in str(err)
        np.testing.assert_array_equal(rec[0].image, raws[0][:, ::-1])
        np.testing.assert_array_equal(rec[2].image, raws[2][:, ::-1])


def test_truncated_sample_data(tmp_path, rng):
    path, raws = aris3000(tmp_path, rng, 3)
    data = path.read_bytes()
    path.write_bytes(data[:-100])
    with ArisRecording(path) as rec:
        assert len(rec) == 2
        assert "frame 2" in rec.truncation and "SampleData" in rec.truncation
        np.testing.assert_array_equal(rec[1].image, raws[1][:, ::-1])
        with pytest.raises(IndexError, match="SampleData"):
            rec[2]
        assert len(list(rec)) == 2


@pytest.mark.parametrize(("cut", "field"), [(2, "FrameIndex"), (466, "SoundSpeed"), (1000, "FrameHeader")])
def test_truncated_frame_header_names_field(tmp_path, rng, cut, field):
    path, _ = aris3000(tmp_path, rng, 2)
    frame_size = 1024 + 128 * N_SAMPLES
    path.write_bytes(path.read_bytes()[: 1024 + frame_size + cut])
    with ArisRecording(path) as rec:
        assert len(rec) == 1
        assert f"frame 1, field {field}" in rec.truncation
        assert rec[0].n_beams == 128


def test_frame0_header_truncated_gives_empty_recording(tmp_path, rng):
    path, _ = aris3000(tmp_path, rng, 1)
    path.write_bytes(path.read_bytes()[: 1024 + 500])
    with ArisRecording(path) as rec:
        assert len(rec) == 0 and "frame 0" in rec.truncation
        with pytest.raises(IndexError):
            rec[0]


@pytest.mark.parametrize(
    ("content", "key"),
    [
        (b"", "FileHeader"),
        (b"\x44\x44\x46\x05" + bytes(100), "FileHeader"),
        (bytes(1024), "Version"),
    ],
)
def test_bad_file_header(tmp_path, content, key):
    path = tmp_path / "bad.aris"
    path.write_bytes(content)
    with pytest.raises(FrameFormatError) as info:
        ArisRecording(path)
    assert info.value.key == key and info.value.path == str(path)


def test_bad_frame0_fails_open(tmp_path, rng):
    path, _ = aris3000(tmp_path, rng, 2, [{"PingMode": 0}, {}])
    with pytest.raises(FrameFormatError) as info:
        ArisRecording(path)
    assert (info.value.frame_index, info.value.key) == (0, "PingMode")


def test_header_only_file_is_empty(tmp_path):
    path = tmp_path / "empty.aris"
    path.write_bytes(file_header(128, 10, 0))
    with ArisRecording(path) as rec:
        assert len(rec) == 0 and rec.truncation is None and list(rec) == []


def test_nonzero_first_frame_index_is_accepted(tmp_path, rng):
    raws = [raw_samples(rng, 64, N_SAMPLES) for _ in range(2)]
    path = tmp_path / "snippet.aris"
    with open(path, "wb") as handle:
        handle.write(file_header(64, N_SAMPLES, 2))
        for i, raw in enumerate(raws):
            handle.write(frame_header(100 + i, 64, N_SAMPLES))
            handle.write(raw.tobytes())
    with ArisRecording(path) as rec:
        assert [f.extra["aris_frame_index"] for f in rec] == [100, 101]


def test_missing_file(tmp_path):
    with pytest.raises(FileNotFoundError):
        ArisRecording(tmp_path / "absent.aris")


def test_closed_recording_refuses_reads_frames_survive(tmp_path, rng):
    path, raws = aris3000(tmp_path, rng, 2)
    rec = ArisRecording(path)
    frame = rec[0]
    rec.close()
    rec.close()
    np.testing.assert_array_equal(frame.image, raws[0][:, ::-1])
    with pytest.raises(ValueError, match="closed"):
        rec[1]


def test_close_after_a_failed_frame_read(tmp_path, rng):
    path, _ = aris3000(tmp_path, rng, 2, [{}, {"SoundSpeed": -1.0}])
    with ArisRecording(path) as rec:
        try:
            rec[1]
        except FrameFormatError as exc:
            kept = exc  # a traceback kept alive must not pin the memory map
    assert kept.frame_index == 1
