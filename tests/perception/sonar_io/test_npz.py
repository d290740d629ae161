"""Frame files (.npz): round trips (hypothesis) and every frame-format.md rule."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from perception.errors import FrameFormatError
from perception.sonar_io import npz
from perception.sonar_io.frame import OPTIONAL_FIELDS, SonarFrame
from perception.sonar_io.npz import load_frames, save_frame, save_frames

DTYPES = (np.uint8, np.uint16, np.float32)
ANGLE_FIELDS = {"tilt_rad", "vehicle_pitch_rad", "vehicle_roll_rad", "heading_rad"}
#: Values a frame's optional fields may take (perception.sonar_io.validate refuses the rest).
PLAUSIBLE = {"sonar_depth_m": (-1.0, 1e4), "altitude_m": (1e-3, 1e3), "tilt_rad": (-1.5, 1.5),
             "vehicle_pitch_rad": (-1.5, 1.5), "vehicle_roll_rad": (-3.1, 3.1), "heading_rad": (-60.0, 60.0),
             "north_m": (-1e4, 1e4), "east_m": (-1e4, 1e4), "sound_speed_m_s": (1300.0, 1800.0)}


@st.composite
def geometries(draw):
    n_samples = draw(st.integers(2, 12))
    n_beams = draw(st.integers(2, 9))
    start = draw(st.floats(0.0, 50.0))
    steps = draw(st.lists(st.floats(1e-3, 2.0), min_size=n_samples - 1, max_size=n_samples - 1))
    ranges = start + np.concatenate([[0.0], np.cumsum(steps)])
    left = draw(st.floats(-80.0, 0.0))
    widths = draw(st.lists(st.floats(0.05, 20.0 / n_beams), min_size=n_beams - 1, max_size=n_beams - 1))
    azimuth_deg = left + np.concatenate([[0.0], np.cumsum(widths)])
    return ranges, np.deg2rad(azimuth_deg)


@st.composite
def frames(draw, geometry=None, dtype=None):
    ranges, azimuth = geometry if geometry is not None else draw(geometries())
    dtype = dtype or draw(st.sampled_from(DTYPES))
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    shape = (ranges.size, azimuth.size)
    if dtype == np.float32:
        image = rng.normal(size=shape).astype(np.float32)
    else:
        image = rng.integers(0, np.iinfo(dtype).max, size=shape, dtype=dtype, endpoint=True)
    optional = {
        name: draw(st.one_of(st.just(math.nan), st.floats(*PLAUSIBLE[name], allow_nan=False)))
        for name in OPTIONAL_FIELDS
    }
    return SonarFrame(
        image=image,
        range_m=ranges,
        beam_azimuth_rad=azimuth,
        elevation_aperture_rad=math.radians(draw(st.floats(0.5, 60.0))),
        timestamp_s=draw(st.floats(-1e9, 2e9, allow_nan=False)),
        **optional,
    )


def assert_same(a: SonarFrame, b: SonarFrame) -> None:
    assert b.image.dtype == a.image.dtype
    np.testing.assert_array_equal(b.image, a.image)
    np.testing.assert_array_equal(b.range_m, a.range_m)
    np.testing.assert_allclose(b.beam_azimuth_rad, a.beam_azimuth_rad, rtol=1e-12, atol=1e-15)
    assert b.elevation_aperture_rad == pytest.approx(a.elevation_aperture_rad, rel=1e-12)
    assert b.timestamp_s == a.timestamp_s
    for name in OPTIONAL_FIELDS:
        x, y = getattr(a, name), getattr(b, name)
        if math.isnan(x):
            assert math.isnan(y), name
        elif name in ANGLE_FIELDS:
            assert y == pytest.approx(x, rel=1e-12, abs=1e-15), name
        else:
            assert y == x, name


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(frame=frames(), compressed=st.booleans())
def test_single_frame_round_trip(tmp_path, frame, compressed):
    path = save_frame(tmp_path / "one.npz", frame, compressed=compressed)
    (back,) = load_frames(path)
    assert_same(frame, back)


@st.composite
def stacks(draw):
    shared = draw(st.booleans())
    dtype = draw(st.sampled_from(DTYPES))
    n = draw(st.integers(1, 4))
    if shared:
        geometry = draw(geometries())
        out = [draw(frames(geometry=geometry, dtype=dtype)) for _ in range(n)]
    else:
        first = draw(geometries())
        out = [draw(frames(geometry=first, dtype=dtype))]
        for _ in range(n - 1):
            ranges, azimuth = first
            shift = draw(st.floats(0.01, 5.0))
            out.append(draw(frames(geometry=(ranges + shift, azimuth), dtype=dtype)))
    return shared, out


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(case=stacks())
def test_stacked_round_trip_shared_and_per_frame_axes(tmp_path, case):
    shared, stack = case
    path = save_frames(tmp_path / "stack.npz", stack)
    with np.load(path) as raw:
        assert raw["image"].shape == (len(stack), *stack[0].image.shape)
        assert raw["timestamp_s"].shape == (len(stack),)
        expect_2d = not shared and len(stack) > 1
        assert raw["range_m"].ndim == (2 if expect_2d else 1)
    back = load_frames(path)
    assert len(back) == len(stack)
    for a, b in zip(stack, back, strict=True):
        assert_same(a, b)


def test_file_is_plain_numpy_in_degrees(tmp_path):
    frame = SonarFrame(
        image=np.ones((3, 2), dtype=np.uint8),
        range_m=[1.0, 2.0, 3.0],
        beam_azimuth_rad=np.deg2rad([-10.0, 10.0]),
        elevation_aperture_rad=math.radians(14.0),
        timestamp_s=5.0,
        tilt_rad=math.radians(30.0),
        altitude_m=2.5,
    )
    with np.load(save_frame(tmp_path / "f.npz", frame)) as raw:
        assert set(raw.files) == {
            "image",
            "range_m",
            "beam_azimuth_deg",
            "elevation_aperture_deg",
            "timestamp_s",
            "tilt_deg",
            "altitude_m",
        }
        np.testing.assert_allclose(raw["beam_azimuth_deg"], [-10.0, 10.0])
        assert float(raw["elevation_aperture_deg"]) == pytest.approx(14.0)
        assert float(raw["tilt_deg"]) == pytest.approx(30.0)
        assert raw["timestamp_s"].shape == ()


def valid_arrays(n_frames: int | None = None) -> dict[str, np.ndarray]:
    image = np.zeros((4, 3), dtype=np.uint8)
    arrays = {
        "image": image,
        "range_m": np.array([1.0, 2.0, 3.0, 4.0]),
        "beam_azimuth_deg": np.array([-10.0, 0.0, 10.0]),
        "elevation_aperture_deg": np.array(14.0),
        "timestamp_s": np.array(1.0),
        "altitude_m": np.array(3.0),
    }
    if n_frames is not None:
        arrays["image"] = np.stack([image] * n_frames)
        for key in ("elevation_aperture_deg", "timestamp_s", "altitude_m"):
            arrays[key] = np.full(n_frames, float(arrays[key]))
    return arrays


def check_rejected(tmp_path, arrays, key, frame_index=None):
    path = tmp_path / "bad.npz"
    np.savez(path, **arrays)
    with pytest.raises(FrameFormatError) as info:
        load_frames(path)
    err = info.value
    assert err.path == str(path) and err.key == key and err.frame_index == frame_index
    assert str(path) in str(err) and repr(key) in str(err)


@pytest.mark.parametrize("key", npz.REQUIRED_KEYS)
def test_missing_required_key(tmp_path, key):
    arrays = valid_arrays()
    del arrays[key]
    check_rejected(tmp_path, arrays, key)


def _mutate(key, value):
    def apply(arrays):
        arrays[key] = value
        return arrays

    return apply


@pytest.mark.parametrize(
    ("mutate", "key"),
    [
        (_mutate("image", np.zeros(12, dtype=np.uint8)), "image"),
        (_mutate("image", np.zeros((1, 1, 4, 3), dtype=np.uint8)), "image"),
        (_mutate("image", np.zeros((4, 3), dtype=np.int64)), "image"),
        (_mutate("image", np.zeros((5, 3), dtype=np.uint8)), "image"),
        (_mutate("image", np.full((4, 3), np.inf, dtype=np.float32)), "image"),
        (_mutate("range_m", np.array([[1.0, 2.0, 3.0, 4.0]])), "range_m"),
        (_mutate("range_m", np.array([4.0, 3.0, 2.0, 1.0])), "range_m"),
        (_mutate("range_m", np.array([1.0, np.nan, 3.0, 4.0])), "range_m"),
        (_mutate("range_m", np.array(["a", "b", "c", "d"])), "range_m"),
        (_mutate("beam_azimuth_deg", np.array([10.0, 0.0, -10.0])), "beam_azimuth_deg"),
        (_mutate("beam_azimuth_deg", np.array([-10.0, 0.0, np.inf])), "beam_azimuth_deg"),
        (_mutate("elevation_aperture_deg", np.array([14.0, 14.0])), "elevation_aperture_deg"),
        (_mutate("elevation_aperture_deg", np.array(-3.0)), "elevation_aperture_deg"),
        (_mutate("timestamp_s", np.array(np.nan)), "timestamp_s"),
        (_mutate("timestamp_s", np.array("noon")), "timestamp_s"),
        (_mutate("altitude_m", np.array([3.0, 4.0])), "altitude_m"),
        (_mutate("altitude_m", np.array(np.inf)), "altitude_m"),
    ],
)
def test_single_frame_rule_violations(tmp_path, mutate, key):
    check_rejected(tmp_path, mutate(valid_arrays()), key)


def test_stacked_rule_violations(tmp_path):
    arrays = valid_arrays(3)
    arrays["timestamp_s"] = np.array(1.0)
    check_rejected(tmp_path, arrays, "timestamp_s")

    arrays = valid_arrays(3)
    arrays["range_m"] = np.tile([1.0, 2.0, 3.0, 4.0], (2, 1))
    check_rejected(tmp_path, arrays, "range_m")

    arrays = valid_arrays(3)
    ranges = np.tile([1.0, 2.0, 3.0, 4.0], (3, 1))
    ranges[1] = ranges[1][::-1]
    arrays["range_m"] = ranges
    check_rejected(tmp_path, arrays, "range_m", frame_index=1)

    arrays = valid_arrays(3)
    arrays["altitude_m"] = np.array([1.0, -np.inf, 2.0])
    check_rejected(tmp_path, arrays, "altitude_m", frame_index=1)

    arrays = valid_arrays(3)
    arrays["image"] = np.zeros((0, 4, 3), dtype=np.uint8)
    check_rejected(tmp_path, arrays, "image")


def test_not_an_archive_and_missing_file(tmp_path):
    path = tmp_path / "junk.npz"
    path.write_bytes(b"this is not a zip file")
    with pytest.raises(FrameFormatError) as info:
        load_frames(path)
    assert info.value.path == str(path)
    with pytest.raises(FileNotFoundError):
        load_frames(tmp_path / "absent.npz")


def _frame(shape=(4, 3), t=0.0):
    return SonarFrame(
        image=np.zeros(shape, dtype=np.uint8),
        range_m=np.arange(1.0, shape[0] + 1.0),
        beam_azimuth_rad=np.linspace(-0.2, 0.2, shape[1]),
        elevation_aperture_rad=0.2,
        timestamp_s=t,
    )


def test_failed_writes_leave_old_file_and_no_temporaries(tmp_path, monkeypatch):
    path = save_frames(tmp_path / "set.npz", [_frame(), _frame(t=1.0)])
    before = path.read_bytes()
    with pytest.raises(FrameFormatError) as info:
        save_frames(path, [_frame(), _frame(shape=(5, 3))])
    assert info.value.frame_index == 1 and info.value.key == "image"

    def explode(*args, **kwargs):
        raise OSError("disk full")

    monkeypatch.setattr(np, "savez_compressed", explode)
    with pytest.raises(OSError, match="disk full"):
        save_frame(path, _frame())
    assert path.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["set.npz"]
    with pytest.raises(ValueError):
        npz.frames_to_arrays([])
