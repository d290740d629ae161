"""SonarFrame: every rule of frame-format.md is enforced, naming the key."""

from __future__ import annotations

import math

import numpy as np
import pytest

from perception.errors import FrameFormatError
from perception.sonar_io.frame import OPTIONAL_FIELDS, SonarFrame, frame_field_names


def make(**changes):
    kwargs = dict(
        image=np.zeros((5, 4), dtype=np.uint8),
        range_m=np.linspace(2.0, 6.0, 5),
        beam_azimuth_rad=np.deg2rad([-15.0, -5.0, 5.0, 15.0]),
        elevation_aperture_rad=math.radians(14.0),
        timestamp_s=12.5,
    )
    kwargs.update(changes)
    return SonarFrame(**kwargs)


def test_valid_frame_properties():
    frame = make(altitude_m=3.0)
    assert (frame.n_samples, frame.n_beams) == (5, 4)
    assert frame.range_resolution_m == pytest.approx(1.0)
    assert frame.window_m == (2.0, 6.0)
    assert frame.known("altitude_m") and not frame.known("tilt_rad")
    assert math.isnan(frame.sonar_depth_m)
    with pytest.raises(KeyError):
        frame.known("image")
    assert frame_field_names()[:5] == ("image", "range_m", "beam_azimuth_rad", "elevation_aperture_rad", "timestamp_s")


def test_arrays_are_readonly_and_callers_untouched():
    image = np.arange(20, dtype=np.uint16).reshape(5, 4)
    frame = make(image=image)
    assert image.flags.writeable
    with pytest.raises(ValueError):
        frame.image[0, 0] = 7
    with pytest.raises(ValueError):
        frame.range_m[0] = 0.0
    np.testing.assert_array_equal(frame.image, image)


@pytest.mark.parametrize(
    ("changes", "key"),
    [
        ({"image": np.zeros((5, 4, 1), dtype=np.uint8)}, "image"),
        ({"image": np.zeros((5, 4), dtype=np.int32)}, "image"),
        ({"image": np.zeros((5, 4), dtype=np.float64)}, "image"),
        ({"image": np.full((5, 4), np.nan, dtype=np.float32)}, "image"),
        ({"image": np.zeros((4, 4), dtype=np.uint8)}, "image"),
        ({"image": np.zeros((5, 3), dtype=np.uint8)}, "image"),
        ({"range_m": np.linspace(2.0, 6.0, 5)[::-1].copy()}, "range_m"),
        ({"range_m": np.array([2.0, 3.0, 3.0, 4.0, 5.0])}, "range_m"),
        ({"range_m": np.array([2.0, 3.0, np.nan, 4.0, 5.0])}, "range_m"),
        ({"range_m": np.array([-1.0, 3.0, 3.5, 4.0, 5.0])}, "range_m"),
        ({"range_m": np.ones((5, 1))}, "range_m"),
        ({"beam_azimuth_rad": np.deg2rad([15.0, 5.0, -5.0, -15.0])}, "beam_azimuth_deg"),
        ({"beam_azimuth_rad": np.deg2rad([-95.0, -5.0, 5.0, 15.0])}, "beam_azimuth_deg"),
        ({"beam_azimuth_rad": np.array([0.0, np.inf, 1.0, 1.2])}, "beam_azimuth_deg"),
        ({"elevation_aperture_rad": 0.0}, "elevation_aperture_deg"),
        ({"elevation_aperture_rad": math.nan}, "elevation_aperture_deg"),
        ({"elevation_aperture_rad": math.pi}, "elevation_aperture_deg"),
        ({"timestamp_s": math.inf}, "timestamp_s"),
        ({"timestamp_s": math.nan}, "timestamp_s"),
    ],
)
def test_rule_violations_name_the_key(changes, key):
    with pytest.raises(FrameFormatError) as info:
        make(**changes)
    assert info.value.key == key
    assert key in str(info.value)


@pytest.mark.parametrize("name", OPTIONAL_FIELDS)
def test_optional_fields_reject_infinity_accept_nan(name):
    assert math.isnan(getattr(make(**{name: math.nan}), name))
    with pytest.raises(FrameFormatError) as info:
        make(**{name: -math.inf})
    assert info.value.key == name


def test_with_fields_revalidates_and_same_geometry():
    frame = make()
    moved = frame.with_fields(timestamp_s=13.0, tilt_rad=0.3)
    assert moved.tilt_rad == 0.3 and frame.same_geometry(moved)
    assert not frame.same_geometry(make(range_m=np.linspace(2.0, 7.0, 5)))
    with pytest.raises(FrameFormatError):
        frame.with_fields(range_m=np.zeros(5))


_POSE_VALUES = {
    "timestamp_s": [0.0, 12.5, -3.0, math.inf, math.nan],
    "sonar_depth_m": [0.0, 12.0, -5.0, 20000.0, math.inf, math.nan],
    "altitude_m": [0.5, 0.0, -1.0, 5000.0, math.nan],
    "tilt_rad": [0.3, -0.2, 2.0, math.nan],
    "vehicle_pitch_rad": [0.05, 1.7, math.nan],
    "vehicle_roll_rad": [-0.1, 3.5, math.nan],
    "heading_rad": [0.0, 6.0, -1.0, 100.0, math.nan],
    "north_m": [3.0, -40.0, 1e9, math.nan],
    "east_m": [-2.0, 1e9, -math.inf, math.nan],
    "sound_speed_m_s": [1500.0, 100.0, 0.0, math.nan],
}


def _outcome(make):
    try:
        frame = make()
    except FrameFormatError as exc:
        return ("refused", exc.key, str(exc))
    return ("made", tuple(repr(getattr(frame, name)) for name in frame_field_names() if name != "image"),
            frame.image.tobytes(), frame.image.flags.writeable)


def test_pose_changes_are_checked_as_a_new_frame_checks_them():
    """``with_fields`` of the ping time and pose fields (stamping, every ping) shares the
    checked arrays instead of checking them again: each change, good or bad, must give
    what building the frame anew gives (``dataclasses.replace``): the same fields, or the
    same refusal naming the same key."""
    import dataclasses
    import itertools

    rng = np.random.default_rng(5)
    base = SonarFrame(rng.integers(0, 255, (40, 8)).astype(np.uint8), np.linspace(1.0, 6.0, 40),
                      np.linspace(-0.25, 0.25, 8), math.radians(14.0), 1.0, altitude_m=2.0, tilt_rad=0.3,
                      north_m=1.0, east_m=2.0, heading_rad=0.5)
    names = sorted(_POSE_VALUES)
    checked = 0
    for a, b in itertools.combinations(names, 2):
        for va, vb in itertools.product(_POSE_VALUES[a], _POSE_VALUES[b]):
            changes = {a: va, b: vb}
            assert _outcome(lambda c=changes: base.with_fields(**c)) == \
                _outcome(lambda c=changes: dataclasses.replace(base, **c)), changes
            checked += 1
    assert checked == 828  # every pair of fields, every pair of their values
    moved = base.with_fields(north_m=5.0)
    assert moved.north_m == 5.0 and base.north_m == 1.0  # a copy: the original is untouched
    assert not moved.image.flags.writeable
