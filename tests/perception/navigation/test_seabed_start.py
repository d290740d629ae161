"""Sonar altitude from the seabed onset, on synthetic frames made here.

Each synthetic frame is dark water (low Gaussian noise) then Rayleigh speckle from the
analytic onset range of each beam, ``H / down_j`` with ``down_j`` the steepest ray's
downward component worked out directly from the rotation (independently of the
closed form in the module), and dark again past the shallowest ray.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from perception.errors import GeometryError, SeabedNotFoundError
from perception.geometry import altitude_from_band_start, ray_direction_sonar, sonar_to_ned
from perception.navigation.altitude_filter import AltitudeFilter
from perception.navigation.seabed_start import find_seabed_start, sonar_altitude, steepest_down_component
from perception.sonar_io.frame import SonarFrame

APERTURE_RAD = math.radians(14.0)
AZIMUTH_RAD = np.linspace(math.radians(-15.0), math.radians(15.0), 128)


def onset_and_end(
    altitude_m: float, tilt_rad: float, pitch_rad: float, roll_rad: float
) -> tuple[np.ndarray, np.ndarray]:
    """Per-beam seabed start and end slant ranges, by brute force over elevations."""
    elev = np.linspace(-APERTURE_RAD / 2, APERTURE_RAD / 2, 2001)
    rays = ray_direction_sonar(AZIMUTH_RAD[:, None], elev[None, :])  # (beams, elev, 3)
    down = rays @ sonar_to_ned(tilt_rad=tilt_rad, pitch_rad=pitch_rad, roll_rad=roll_rad)[2]
    steep = down.max(axis=1)
    shallow = down.min(axis=1)
    end = np.where(shallow > 0, altitude_m / np.where(shallow > 0, shallow, 1.0), np.inf)
    return altitude_m / steep, end


def synthetic_frame(
    rng: np.random.Generator,
    *,
    altitude_m: float,
    tilt_rad: float,
    pitch_rad: float = 0.0,
    roll_rad: float = 0.0,
    window_m: tuple[float, float] = (1.0, 13.0),
    n_samples: int = 1200,
    known_attitude: bool = True,
) -> SonarFrame:
    range_m = np.linspace(*window_m, n_samples)
    start, end = onset_and_end(altitude_m, tilt_rad, pitch_rad, roll_rad)
    seabed = (range_m[:, None] >= start[None, :]) & (range_m[:, None] <= end[None, :])
    water = rng.normal(12.0, 3.0, seabed.shape)
    speckle = rng.rayleigh(90.0 / math.sqrt(math.pi / 2), seabed.shape) * (4.0 / range_m[:, None]) ** 0.5
    image = np.clip(np.where(seabed, speckle, water), 0, 255).astype(np.uint8)
    unknown = math.nan
    return SonarFrame(
        image, range_m, AZIMUTH_RAD, APERTURE_RAD, 12.5,
        tilt_rad=tilt_rad if known_attitude else unknown,
        vehicle_pitch_rad=pitch_rad if known_attitude else unknown,
        vehicle_roll_rad=roll_rad if known_attitude else unknown,
    )


def test_steepest_down_component_matches_geometry_on_the_boresight() -> None:
    for tilt_deg, pitch_deg in [(30.0, 0.0), (20.0, -5.0), (85.0, 0.0), (10.0, 8.0)]:
        tilt, pitch = math.radians(tilt_deg), math.radians(pitch_deg)
        down = steepest_down_component(
            np.array([0.0]), elevation_aperture_rad=APERTURE_RAD, tilt_rad=tilt, pitch_rad=pitch, roll_rad=0.0
        )
        # altitude_from_band_start(near, ...) = near * sin(min(depression + aperture/2, 90 deg))
        expected = altitude_from_band_start(1.0, depression_rad=tilt - pitch, elevation_aperture_rad=APERTURE_RAD)
        assert float(down[0]) == pytest.approx(expected, rel=1e-12)


def test_steepest_down_component_matches_brute_force_off_axis() -> None:
    tilt, pitch, roll = math.radians(35.0), math.radians(3.0), math.radians(4.0)
    start, _ = onset_and_end(2.0, tilt, pitch, roll)
    down = steepest_down_component(
        AZIMUTH_RAD, elevation_aperture_rad=APERTURE_RAD, tilt_rad=tilt, pitch_rad=pitch, roll_rad=roll
    )
    assert np.allclose(2.0 / down, start, rtol=1e-6)


def test_known_answer_altitude(rng: np.random.Generator) -> None:
    frame = synthetic_frame(rng, altitude_m=3.0, tilt_rad=math.radians(30.0))
    result = sonar_altitude(frame)
    assert result.altitude_m == pytest.approx(3.0, abs=0.015)
    assert result.timestamp_s == 12.5
    # the onset is where the steepest boresight ray meets the seabed: 3 / sin(37 deg)
    assert result.start.slant_m == pytest.approx(3.0 / math.sin(math.radians(37.0)), rel=0.005)
    assert abs(result.altitude_m - 3.0) <= 3.0 * result.std_m
    assert result.depression_rad == pytest.approx(math.radians(30.0))


@settings(max_examples=25, deadline=None)
@given(
    altitude=st.floats(1.5, 5.0),
    tilt_deg=st.floats(15.0, 50.0),
    pitch_deg=st.floats(-6.0, 6.0),
    roll_deg=st.floats(-4.0, 4.0),
    seed=st.integers(0, 2**31),
)
def test_altitude_recovered_across_attitudes(
    altitude: float, tilt_deg: float, pitch_deg: float, roll_deg: float, seed: int
) -> None:
    rng = np.random.default_rng(seed)
    tilt, pitch, roll = (math.radians(v) for v in (tilt_deg, pitch_deg, roll_deg))
    start, end = onset_and_end(altitude, tilt, pitch, roll)
    if start.min() < 1.2 or min(end.min(), 13.0) - start.max() < 0.3:
        return  # the window (1 to 13 m) must start in the water and hold the onset
    frame = synthetic_frame(rng, altitude_m=altitude, tilt_rad=tilt, pitch_rad=pitch, roll_rad=roll)
    result = sonar_altitude(frame)
    # (2.5 %: these frames' speckle is drawn in display levels, a far wider spread of power
    # than a sonar's, which jitters the onset's power profile; a roll spreads the onset
    # over the beams)
    assert abs(result.altitude_m - altitude) <= max(0.025 * altitude, 2.0 * frame.range_resolution_m)
    assert abs(result.altitude_m - altitude) <= 3.0 * result.std_m


def test_keyword_attitude_overrides_unknown_frame_fields(rng: np.random.Generator) -> None:
    frame = synthetic_frame(rng, altitude_m=2.5, tilt_rad=math.radians(25.0), known_attitude=False)
    with pytest.raises(GeometryError, match="tilt"):
        sonar_altitude(frame)
    with pytest.raises(GeometryError, match="pitch"):
        sonar_altitude(frame, tilt_rad=math.radians(25.0))
    result = sonar_altitude(frame, tilt_rad=math.radians(25.0), pitch_rad=0.0)
    assert result.altitude_m == pytest.approx(2.5, abs=0.015)


def test_window_starting_inside_the_seabed_band_is_refused(rng: np.random.Generator) -> None:
    frame = synthetic_frame(rng, altitude_m=2.0, tilt_rad=math.radians(40.0), window_m=(4.0, 12.0))
    with pytest.raises(SeabedNotFoundError, match="no water"):
        find_seabed_start(frame)


def test_frame_without_seabed_is_refused(rng: np.random.Generator) -> None:
    image = rng.normal(12.0, 3.0, (600, 128)).clip(0, 255).astype(np.uint8)
    frame = SonarFrame(image, np.linspace(1.0, 7.0, 600), AZIMUTH_RAD, APERTURE_RAD, 0.0, tilt_rad=0.5,
                       vehicle_pitch_rad=0.0)
    with pytest.raises(SeabedNotFoundError):
        sonar_altitude(frame)


def test_input_frame_is_not_modified(rng: np.random.Generator) -> None:
    frame = synthetic_frame(rng, altitude_m=3.0, tilt_rad=math.radians(30.0))
    before = frame.image.copy()
    find_seabed_start(frame)
    assert np.array_equal(before, frame.image)


def test_sonar_altitudes_feed_the_filter(rng: np.random.Generator) -> None:
    flt = AltitudeFilter()
    for k in range(50):
        t = 0.1 * k
        flt.update_depth(t, 6.0 + 0.01 * rng.standard_normal(), 0.01)
        if k % 5 == 0:
            frame = synthetic_frame(rng, altitude_m=3.0, tilt_rad=math.radians(30.0)).with_fields(timestamp_s=t)
            alt = sonar_altitude(frame)
            assert flt.update_sonar_altitude(alt.timestamp_s, alt.altitude_m, alt.std_m).accepted
    assert flt.counters["sonar"].accepted == 10
    est = flt.altitude_at(4.9)
    assert est.mean == pytest.approx(3.0, abs=3.0 * est.std + 0.005)


@pytest.mark.parametrize(
    ("altitude", "tilt_deg", "pitch_deg", "roll_deg"),
    [(1.5, 30.0, 0.0, 0.0), (1.2, 20.0, 3.0, 0.0), (1.8, 45.0, -2.0, 3.0), (1.0, 25.0, 0.0, 0.0)],
)
def test_altitude_from_the_simulator_renderer(
    altitude: float, tilt_deg: float, pitch_deg: float, roll_deg: float
) -> None:
    """The sim_harness renderer's frames (soft beam edge, pulse blur, log display, speckle)."""
    from sim_harness.sonar.renderer import SonarConfig, SonarPose, SonarRenderer
    from sim_harness.world.world import Seabed, World

    renderer = SonarRenderer(World(Seabed(10.0)), SonarConfig())
    pose = SonarPose(
        0.0, 0.0, 10.0 - altitude, 0.3, math.radians(pitch_deg), math.radians(roll_deg), math.radians(tilt_deg)
    )
    frame, truth = renderer.render(pose, 1.0)
    result = sonar_altitude(frame)
    assert truth.altitude_m == pytest.approx(altitude)
    assert abs(result.altitude_m - altitude) <= 0.01 * altitude
    assert abs(result.altitude_m - altitude) <= 3.0 * result.std_m


def test_the_height_pipeline_loads_without_the_altitude_filter():
    """perception.navigation's names load on first use: the height pipeline (in the map
    process, in `shadowsurvey heights`) reads the seabed's start without importing the
    altitude filter, whose filterpy brings in scipy.stats (about a second at start-up),
    and the package's names are all still there."""
    import subprocess
    import sys

    code = ("import sys, perception.heights.pipeline, perception.navigation as nav; "
            "assert 'filterpy' not in sys.modules and 'scipy.stats' not in sys.modules, 'loaded'; "
            "assert nav.AltitudeFilter.__name__ == 'AltitudeFilter' and 'filterpy' in sys.modules; "
            "assert set(nav.__all__) <= set(dir(nav))")
    subprocess.run([sys.executable, "-c", code], check=True)
