"""write_aris: byte layout checked against the SDK offsets, and write -> read round trips."""

from __future__ import annotations

import math
import struct

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from perception.errors import FrameFormatError
from perception.sonar_io.aris.reader import ArisRecording, aris_grid, write_aris
from perception.sonar_io.beams import load_beam_table
from perception.sonar_io.frame import SonarFrame
from tests.perception.sonar_io.aris_bytes import SIGNATURE, read_frame_field

CONFIGS = [  # (n_beams, system_type, telephoto, table)
    (128, 1, False, "ARIS3000_128"),
    (64, 1, False, "ARIS3000_64"),
    (96, 0, False, "ARIS1800_96"),
    (48, 2, False, "ARIS1800_1200_48"),
    (48, 2, True, "ARIS_Telephoto_48"),
    (96, 0, True, "ARIS_Telephoto_96"),
]


def grid_frame(
    rng, *, n_beams=128, table="ARIS3000_128", n_samples=50, t=1.7e9, speed=1480.0, window=(2.0, 12.0), **pose
):
    _, _, ranges = aris_grid(window[0], window[1], n_samples, speed)
    return SonarFrame(
        image=rng.integers(0, 256, size=(n_samples, n_beams), dtype=np.uint8),
        range_m=ranges,
        beam_azimuth_rad=load_beam_table(table).azimuth_rad,
        elevation_aperture_rad=math.radians(14.0),
        timestamp_s=t,
        sound_speed_m_s=speed,
        **pose,
    )


def test_byte_layout_matches_sdk_offsets(tmp_path, rng):
    frames = [
        grid_frame(
            rng,
            t=1.7e9 + 0.25 * i,
            sonar_depth_m=10.0 + i,
            altitude_m=2.5,
            tilt_rad=math.radians(25.0),
            heading_rad=math.radians(90.0),
        )
        for i in range(3)
    ]
    path = write_aris(tmp_path / "w.aris", frames, serial_number=4242)
    data = path.read_bytes()
    frame_size = 1024 + 128 * 50
    assert len(data) == 1024 + 3 * frame_size
    version, count = struct.unpack_from("<2I", data, 0)
    assert (version, count) == (SIGNATURE, 3)
    assert struct.unpack_from("<I", data, 16)[0] == 128  # NumRawBeams
    assert struct.unpack_from("<I", data, 24)[0] == 50  # SamplesPerChannel
    delay_us, period_us, _ = aris_grid(2.0, 12.0, 50, 1480.0)
    for i, frame in enumerate(frames):

        def field(name, i=i):
            return read_frame_field(data, i, frame_size, name)

        assert field("FrameIndex") == i and field("Version") == SIGNATURE
        assert field("FrameTime") == round(frame.timestamp_s * 1e6)
        assert (field("PingMode"), field("SamplesPerBeam"), field("TheSystemType")) == (9, 50, 1)
        assert (field("SamplePeriod"), field("SampleStartDelay")) == (period_us, delay_us)
        assert field("SoundSpeed") == np.float32(1480.0)
        assert field("ReorderedSamples") == 1 and field("SonarSerialNumber") == 4242
        assert field("Depth") == np.float32(10.0 + i) and field("Altitude") == np.float32(2.5)
        assert field("SonarTilt") == pytest.approx(-25.0) and field("Heading") == pytest.approx(90.0)
        start = 1024 + i * frame_size + 1024
        raw = np.frombuffer(data, np.uint8, 128 * 50, start).reshape(50, 128)
        np.testing.assert_array_equal(raw, frame.image[:, ::-1])
    assert read_frame_field(data, 1, frame_size, "FrameRate") == pytest.approx(4.0)


@st.composite
def recordings(draw):
    n_beams, system_type, telephoto, table = draw(st.sampled_from(CONFIGS))
    n_samples = draw(st.integers(2, 30))
    speed = draw(st.floats(1400.0, 1600.0))
    start = draw(st.floats(0.0, 40.0))
    length = draw(st.floats(0.5, 60.0))
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    t0 = draw(st.integers(0, 2**52)) * 1e-6
    frames = []
    for i in range(draw(st.integers(1, 3))):

        def maybe(lo, hi):
            return draw(st.one_of(st.just(math.nan), st.floats(lo, hi)))

        pose = {
            "sonar_depth_m": maybe(0.0, 500.0),
            "altitude_m": maybe(0.1, 50.0),
            "vehicle_pitch_rad": maybe(-0.5, 0.5),
            "vehicle_roll_rad": maybe(-0.5, 0.5),
            "heading_rad": maybe(0.0, 6.28),
            "tilt_rad": maybe(-0.3, 1.5),
        }
        frames.append(
            grid_frame(
                rng,
                n_beams=n_beams,
                table=table,
                n_samples=n_samples,
                t=t0 + 0.1 * i,
                speed=speed,
                window=(start, start + length),
                **pose,
            )
        )
    return system_type, telephoto, frames


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(case=recordings())
def test_write_read_round_trip(tmp_path, case):
    system_type, telephoto, frames = case
    path = write_aris(tmp_path / "rt.aris", frames, system_type=system_type, telephoto=telephoto)
    with ArisRecording(path) as rec:
        back = list(rec)
    assert len(back) == len(frames)
    for a, b in zip(frames, back, strict=True):
        np.testing.assert_array_equal(b.image, a.image)
        np.testing.assert_allclose(b.range_m, a.range_m, rtol=1e-12)
        np.testing.assert_array_equal(b.beam_azimuth_rad, a.beam_azimuth_rad)
        assert b.timestamp_s == pytest.approx(a.timestamp_s, abs=1e-6)
        assert b.sound_speed_m_s == pytest.approx(a.sound_speed_m_s, rel=1e-7)
        for name in ("sonar_depth_m", "altitude_m", "vehicle_pitch_rad", "vehicle_roll_rad", "tilt_rad"):
            x, y = getattr(a, name), getattr(b, name)
            assert (math.isnan(x) and math.isnan(y)) or y == pytest.approx(x, rel=1e-6, abs=1e-6)
        if math.isnan(a.heading_rad):
            assert math.isnan(b.heading_rad)
        else:
            diff = (b.heading_rad - a.heading_rad + math.pi) % (2 * math.pi) - math.pi
            assert abs(diff) < 1e-5


def test_rewriting_sample_recording_keeps_samples_and_geometry(data_dir, tmp_path):
    source = data_dir / "aris" / "sample.aris"
    with ArisRecording(source) as rec:
        frames = list(rec)
    path = write_aris(tmp_path / "copy.aris", frames, system_type=2, telephoto=True)
    original, copy = source.read_bytes(), path.read_bytes()
    assert len(copy) == len(original)
    frame_size = 1024 + 48 * 2000
    for i in range(6):
        start = 1024 + i * frame_size + 1024
        assert copy[start : start + 96_000] == original[start : start + 96_000]
        for name in (
            "FrameIndex",
            "FrameTime",
            "PingMode",
            "SamplePeriod",
            "SampleStartDelay",
            "SoundSpeed",
            "SamplesPerBeam",
            "TheSystemType",
            "LargeLens",
        ):
            assert read_frame_field(copy, i, frame_size, name) == read_frame_field(original, i, frame_size, name), name
    with ArisRecording(path) as rec:
        for a, b in zip(frames, rec, strict=True):
            np.testing.assert_array_equal(a.range_m, b.range_m)
            assert a.heading_rad == pytest.approx(b.heading_rad)
            assert a.tilt_rad == pytest.approx(b.tilt_rad)


def test_aris_grid_is_whole_microseconds():
    delay, period, ranges = aris_grid(3.0, 23.0, 2000, 1500.0)
    assert period == 13 and delay == 4000
    assert ranges[0] == pytest.approx((4000 + 6.5) * 0.00075)
    with pytest.raises(ValueError):
        aris_grid(5.0, 4.0, 10, 1500.0)
    with pytest.raises(ValueError):
        aris_grid(0.0, 4.0, 1, 1500.0)


@pytest.mark.parametrize(
    ("make", "key", "index"),
    [
        (lambda f: [f.with_fields(image=f.image.astype(np.float32))], "image", 0),
        (lambda f: [f.with_fields(beam_azimuth_rad=f.beam_azimuth_rad * 0.9)], "beam_azimuth_deg", 0),
        (lambda f: [f.with_fields(range_m=f.range_m + 0.5 * 740e-6)], "range_m", 0),  # +0.5 us
        (lambda f: [f.with_fields(range_m=f.range_m * 1.001)], "range_m", 0),
        (lambda f: [f.with_fields(sound_speed_m_s=math.nan)], "sound_speed_mps", 0),
        (lambda f: [f, f.with_fields(image=f.image[:-1], range_m=f.range_m[:-1])], "image", 1),
        (lambda f: [f.with_fields(timestamp_s=-1.0)], "timestamp_s", 0),
        (lambda f: [f.with_fields(image=f.image[:, :100], beam_azimuth_rad=f.beam_azimuth_rad[:100])], "image", 0),
    ],
)
def test_unwritable_frames_name_frame_and_key(tmp_path, rng, make, key, index):
    target = tmp_path / "out.aris"
    target.write_bytes(b"previous")
    with pytest.raises(FrameFormatError) as info:
        write_aris(target, make(grid_frame(rng)))
    assert (info.value.key, info.value.frame_index) == (key, index)
    assert target.read_bytes() == b"previous"
    assert [p.name for p in tmp_path.iterdir()] == ["out.aris"]


def test_sound_speed_fallback_and_empty(tmp_path, rng):
    frame = grid_frame(rng, speed=1500.0).with_fields(sound_speed_m_s=math.nan)
    path = write_aris(tmp_path / "fallback.aris", [frame], sound_speed_m_s=1500.0)
    with ArisRecording(path) as rec:
        assert rec[0].sound_speed_m_s == 1500.0
        np.testing.assert_allclose(rec[0].range_m, frame.range_m, rtol=1e-12)
    with pytest.raises(ValueError, match="no frames"):
        write_aris(tmp_path / "none.aris", [])
    assert not (tmp_path / "none.aris").exists()
