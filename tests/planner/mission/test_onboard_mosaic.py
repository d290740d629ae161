"""On board, the frame-to-map chain leaves the shadows the height pipeline measured out of
the mosaic's average, and (when turned on) registration takes the navigation's drift out
of the map; frames are stamped with the telemetry's navigation.

A raised cylinder (20 cm across, 15 cm high) on a flat seabed, seen along one lane at 1 m
altitude: its shadow falls behind it. The frames go through :class:`OnboardPerception`
exactly as during a dive (telemetry first, then the frames stamped with it); the cells the
shadow darkens in a plain mosaic of the same frames are, in the on-board mosaic, either
left empty or show the seabed the other frames saw there.
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from perception.mapping.builder import MosaicBuilder
from perception.mapping.mosaic import MosaicConfig
from perception.mapping.products import MapRaster
from perception.mapping.registration import RegistrationConfig
from perception.mapping.survey_map import SurveyMap
from perception.navigation.history import MAX_EXTRAPOLATION_S
from planner.mission.onboard import OnboardConfig, OnboardPerception
from sim_harness.world.texture import SeabedTexture
from sim_harness.world.world import TargetSpec
from tests.perception.mapping.test_mosaic_render import (
    ALTITUDE_M,
    DRIFT_DIRECTION,
    RES_M,
    SEABED_DEPTH_M,
    drift_quadratic,
    position_errors,
    render_dive,
)
from vehicle_link.telemetry import Attitude, GlobalPosition, LocalPositionNed, MountStatus, Rangefinder

CYLINDER = TargetSpec("C", "cylinder", 4.0, -0.2, 0.2, 0.2, 0.15, material="metal")


def _raster_as_mosaic(raster: MapRaster) -> SimpleNamespace:
    """A map raster (north up, cropped) in the layout of ``TiledMosaic.raster()`` (south up,
    (row0, col0) of its first cell), behind a ``.mosaic`` as the marker helpers read it."""
    rows = raster.intensity.shape[0]
    row0 = int(round(raster.north_m / raster.resolution_m)) - rows
    col0 = int(round(raster.west_m / raster.resolution_m))
    mean = np.nan_to_num(raster.intensity[::-1], nan=0.0)
    view = (mean, raster.weight[::-1], row0, col0)
    return SimpleNamespace(mosaic=SimpleNamespace(raster=lambda: view))


def _telemetry(frame, depth_m: float) -> list[object]:
    t = frame.timestamp_s
    return [
        GlobalPosition(t, t, math.nan, math.nan, math.nan, depth_m, 0.0, 0.0, 0.0, None),
        Rangefinder(t, "DISTANCE_SENSOR", 0, ALTITUDE_M, 0.3, 50.0, 25, 100, True),
        MountStatus(t, "GIMBAL_DEVICE_ATTITUDE_STATUS", 0.0, -frame.tilt_rad, 0.0, frame.tilt_rad),
        Attitude(t, t, 0.0, 0.0, frame.heading_rad, 0.0, 0.0, 0.0),
        LocalPositionNed(t, t, frame.north_m, frame.east_m, depth_m, 0.0, 0.0, 0.0),
    ]


@pytest.mark.slow
def test_onboard_mosaic_leaves_measured_shadows_out():
    dive = render_dive(texture=None, markers=False, extra_targets=(CYLINDER,))
    frames = [f for f, lane in zip(dive.frames, dive.lane, strict=True) if lane == 0][:90]
    onboard = OnboardPerception(OnboardConfig(mosaic_resolution_m=RES_M))
    plain = MosaicBuilder(MosaicConfig(resolution_m=RES_M))
    measured = 0
    for frame in frames:
        for record in _telemetry(frame, SEABED_DEPTH_M - ALTITUDE_M):
            onboard.listener(record)
        onboard.drain()
        measured += sum(len(r.measurements) for r in onboard.process_frames([frame]))
        own = onboard.stamp(frame)
        if own is not None and own.known("north_m") and own.known("heading_rad"):
            plain.add_frame(own, altitude_m=own.altitude_m)  # the same pose, no masks
    assert onboard.status().frames_used >= len(frames) - 5
    assert measured >= 10, "the height pipeline measured (almost) no shadow"
    raster = onboard.map_raster()
    assert raster is not None
    mean, weight, row0, col0 = _raster_as_mosaic(raster).mosaic.raster()
    p_mean, p_weight, p_row0, p_col0 = plain.mosaic.raster()
    assert p_row0 <= row0 and p_col0 <= col0
    # the on-board raster is cropped to its cells with data: bring both to one grid
    p_mean = p_mean[row0 - p_row0 : row0 - p_row0 + mean.shape[0], col0 - p_col0 : col0 - p_col0 + mean.shape[1]]
    p_weight = p_weight[row0 - p_row0 : row0 - p_row0 + mean.shape[0], col0 - p_col0 : col0 - p_col0 + mean.shape[1]]
    p_row0, p_col0 = row0, col0
    # the stretch behind the cylinder (north of it: the lane looks north)
    r0 = int(math.floor((CYLINDER.north_m + 0.1) / RES_M)) - row0
    c0 = int(math.floor(CYLINDER.east_m / RES_M)) - col0
    box = (slice(r0, r0 + 50), slice(c0 - 12, c0 + 13))
    seabed = float(np.median(p_mean[p_weight > 0.2]))
    shadowed = (p_weight[box] > 0.2) & (p_mean[box] < 0.7 * seabed)
    assert shadowed.sum() > 150, "the plain mosaic shows no shadow behind the target"
    still_dark = shadowed & (weight[box] > 0) & (mean[box] < 0.7 * seabed)
    assert still_dark.sum() < 0.2 * shadowed.sum(), (int(still_dark.sum()), int(shadowed.sum()))


@pytest.mark.slow
def test_onboard_registration_takes_drift_out_of_the_map():
    """The on-board path with registration on (masks and all), navigation drifting to 10 cm
    (~ distance squared) in the telemetry: the markers land within 3 cm of their truth."""
    dive = render_dive(texture=SeabedTexture(std_db=3.0, correlation_m=0.1, seed=5))
    onboard = OnboardPerception(OnboardConfig(mosaic_resolution_m=RES_M, registration=True))
    for frame, travelled in zip(dive.frames, dive.travelled_m, strict=True):
        d = drift_quadratic(travelled, dive.length_m)
        drifted = frame.with_fields(north_m=frame.north_m + DRIFT_DIRECTION[0] * d,
                                    east_m=frame.east_m + DRIFT_DIRECTION[1] * d)
        for record in _telemetry(drifted, SEABED_DEPTH_M - ALTITUDE_M):
            onboard.listener(record)
        onboard.drain()
        onboard.process_frames([frame])  # the frame's own (true) pose is replaced by the telemetry's
    drift = onboard.status().drift
    assert drift is not None and math.hypot(drift.north_m, drift.east_m) > 0.02
    raster = onboard.map_raster()
    assert raster is not None
    errors = position_errors(_raster_as_mosaic(raster), dive)
    assert errors.max() <= 0.03, errors


def test_frames_are_placed_from_position_reports_not_attitude_samples():
    """Position at 5 Hz, attitude at 20 Hz, moving north at 0.5 m/s: a frame between two
    position reports is placed where the vehicle was (interpolated, or extrapolated with
    the reported velocity past the newest report), not where it was last reported."""
    onboard = OnboardPerception()
    speed = 0.5
    for k in range(41):  # 0 .. 2 s at 20 Hz
        t = 0.05 * k
        onboard.listener(Attitude(t, t, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0))
        if k % 4 == 0:
            onboard.listener(LocalPositionNed(t, t, speed * t, 1.0, 5.0, speed, 0.0, 0.0))
    onboard.drain()
    for t in (0.13, 0.55, 1.21, 1.99):
        nav = onboard.nav_at(t)
        assert nav is not None
        assert nav.north_m == pytest.approx(speed * t, abs=1e-9) and nav.east_m == pytest.approx(1.0)
    ahead = onboard.nav_at(2.3)  # 0.3 s past the newest report: extrapolated
    assert ahead is not None and ahead.north_m == pytest.approx(speed * 2.3)
    far = onboard.nav_at(5.0)  # extrapolation stops after MAX_EXTRAPOLATION_S
    assert far is not None and far.north_m == pytest.approx(speed * (2.0 + MAX_EXTRAPOLATION_S))
    assert OnboardPerception().nav_at(1.0) is None


@pytest.mark.slow
def test_targets_are_placed_with_the_drift_registration_found():
    """The height pipeline sees each frame moved by the drift registration has found, so its
    targets sit where the mosaic puts them: the same frames through two chains, one with a
    drift estimate of (+6, -4) cm, give targets exactly that far apart."""
    dive = render_dive(texture=None, markers=False, extra_targets=(CYLINDER,))
    frames = [f for f, lane in zip(dive.frames, dive.lane, strict=True) if lane == 0][:60]
    plain = SurveyMap(mosaic=MosaicConfig(resolution_m=RES_M), registration=RegistrationConfig())
    drifted = SurveyMap(mosaic=MosaicConfig(resolution_m=RES_M), registration=RegistrationConfig())
    estimator = drifted._builder.drift  # the test stands in for an accepted match
    assert estimator is not None
    for survey_map in (plain, drifted):
        for frame in frames:
            if survey_map is drifted:  # as if registration had accepted a match before these frames
                estimator.north_m, estimator.east_m = 0.06, -0.04
            survey_map.add_frame(frame)
    assert plain.drift is not None and plain.drift.north_m == 0.0  # untextured: no match
    a = [t for t in plain.targets() if math.isfinite(t.north_m)]
    b = [t for t in drifted.targets() if math.isfinite(t.north_m)]
    assert len(a) == len(b) >= 1
    for ta, tb in zip(a, b, strict=True):
        assert tb.north_m - ta.north_m == pytest.approx(0.06, abs=1e-9)
        assert tb.east_m - ta.east_m == pytest.approx(-0.04, abs=1e-9)
